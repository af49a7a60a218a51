"""End-to-end tests of ``kinbox.solve``: assembly modes and configuration curves of linkages.

Answers are compared with independent references, never with kinbox itself:

* the published problems of ``tests/data/reference`` (general 6R: 16 real solutions;
  Dietmeier 6-6 platform: 40; Griffis-Duffy: two 1-dimensional components; Bricard: a
  1-dimensional self-motion plus 2 isolated configurations), with every configuration checked
  by the reference's own equations (DH product, leg lengths) written out here;
* the closed-form four-bar and the 3-RPR sextic of ``tests/support/oracles/planar.py``;
* loop closures re-measured with Pinocchio forward kinematics (``Mechanism.closure_residuals``,
  ``kinbox.formulation.decode.check``), never ``Solution.residual``.

Every solve has a ``time_limit`` and asserts ``complete``.
"""

from __future__ import annotations

import copy
import json
import math

import numpy as np
import pinocchio as pin
import pytest

import kinbox
from kinbox.formulation.build import formulate
from kinbox.formulation.decode import check
from kinbox.pipeline import MECHANISM_SIGMA
from tests.support import paths as PATHS
from tests.support.oracles.planar import (
    four_bar_assemblies,
    four_bar_relative_angles,
    three_rpr_assemblies,
    three_rpr_residuals,
)

REFERENCE = PATHS.DATA / "reference"
ROBOTS = PATHS.ROBOTS
TOL = 1e-10


def reference(name: str) -> dict:
    return json.loads((REFERENCE / name).read_text())


def robot_file(name: str) -> dict:
    return json.loads((ROBOTS / name).read_text())


def wrap(a):
    return float(np.angle(np.exp(1j * a)))


def assert_closures(mech, res, tol: float = TOL) -> None:
    """Every solution closes every loop (Pinocchio FK) and keeps its locked joints."""
    for k, s in enumerate(res.solutions):
        for name, pos, rot in mech.closure_residuals(s.q):
            assert pos < tol and rot < tol, f"solution {k}: closure {name}: {pos:.2e} m, {rot:.2e} rad"
        c = check(mech, s.q)
        assert c["max_position"] < tol and c["max_orientation"] < tol and c["locked"] < 1e-12, (k, c)


def assert_distinct(model, res, tol: float = 1e-6) -> None:
    qs = [np.asarray(s.q) for s in res.solutions]
    for a in range(len(qs)):
        for b in range(a):
            d = float(np.max(np.abs(pin.difference(model, qs[a], qs[b]))))
            assert d > tol, f"solutions {b} and {a} coincide ({d:.2e})"


# ----------------------------------------------------------------------------------------------
# general 6R loop
# ----------------------------------------------------------------------------------------------
def _dh_product(rows, theta) -> np.ndarray:
    """prod_i Rx(alpha_i) Tx(a_i) Rz(theta_i) Tz(d_i) (the reference tables' convention)."""
    T = np.eye(4)
    for r, th in zip(rows, theta):
        ca, sa = math.cos(r["alpha"]), math.sin(r["alpha"])
        c, s = math.cos(th), math.sin(th)
        A = np.array([[1, 0, 0, 0], [0, ca, -sa, 0], [0, sa, ca, 0], [0, 0, 0, 1.0]])
        A[0, 3] = r["a"]
        Rz = np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, r["d"]], [0, 0, 0, 1.0]])
        T = T @ A @ Rz
    return T


def test_general_6r_loop_has_the_published_16_solutions():
    ref = reference("general_6r.json")
    res = kinbox.solve("general-6r", time_limit=120)
    assert res.complete, res.message
    assert len(res.solutions) == ref["expected"]["real_solutions"] == 16
    assert all(s.certified for s in res.solutions)
    assert not [c for c in res.components if c.dimension >= 1]
    mech = kinbox.load("general-6r")
    assert_closures(mech, res)
    assert_distinct(mech.model, res)
    for k, s in enumerate(res.solutions):  # the reference's own loop equation
        err = np.abs(_dh_product(ref["dh"], s.q) - np.eye(4)).max()
        assert err < TOL, f"solution {k}: DH loop product off identity by {err:.2e}"


def test_general_6r_loop_via_the_reference_table():
    """The same loop built from the reference file with kinbox.model.builders.dh_chain (not robots/)."""
    from kinbox.model.builders import dh_chain

    rows = reference("general_6r.json")["dh"]
    mech = dh_chain(rows, closed=True, name="general-6r-from-reference")
    res = kinbox.solve(mech, time_limit=120)
    assert res.complete, res.message
    assert len(res.solutions) == 16 and all(s.certified for s in res.solutions)
    assert_closures(mech, res)


# ----------------------------------------------------------------------------------------------
# Gough-Stewart platforms
# ----------------------------------------------------------------------------------------------
def _leg_errors(ref: dict, q, lengths=None) -> np.ndarray:
    """| |t + R q_i - p_i| - l_i | from the free-flyer configuration (t, quaternion xyzw)."""
    q = np.asarray(q, float)
    t, quat = q[:3], q[3:7]
    assert abs(np.linalg.norm(quat) - 1.0) < 1e-12
    R = pin.Quaternion(quat[3], *quat[:3]).toRotationMatrix()
    p = np.asarray(ref["base_points"], float)
    b = np.asarray(ref["platform_points"], float)
    L = np.asarray(ref["leg_lengths"] if lengths is None else lengths, float)
    return np.abs(np.linalg.norm(t + b @ R.T - p, axis=1) - L)


def test_stewart_leg_equations_match_the_reference():
    """The premise of the platform tests: robots/dietmeier.json is the reference platform."""
    ref = reference("dietmeier_66.json")
    spec = robot_file("dietmeier.json")
    for key in ("base_points", "platform_points", "leg_lengths"):
        assert np.allclose(spec[key], ref[key], atol=0, rtol=0)


@pytest.mark.slow
@pytest.mark.parametrize("sigma", [None, 1e-3])  # 1e-3: near-singular pairs once lost 3 of the 40
def test_dietmeier_has_the_published_40_assemblies(sigma):
    ref = reference("dietmeier_66.json")
    res = kinbox.solve("dietmeier", time_limit=900, **({} if sigma is None else {"sigma": sigma}))
    assert res.complete, res.message
    assert len(res.solutions) == ref["expected"]["real_solutions"] == 40
    assert all(s.certified for s in res.solutions)
    # one component per assembly mode, nothing left over: no undecided box, no uncertified
    # box beside a mode, no singular point
    assert len(res.components) == 40 and all(c.dimension == 0 and c.certified for c in res.components)
    assert not res.undecided and res.stats["unresolved_boxes"] == 0 and res.stats["singular"] == 0
    mech = kinbox.load("dietmeier")
    assert_closures(mech, res)
    assert_distinct(mech.model, res)
    for k, s in enumerate(res.solutions):
        assert _leg_errors(ref, s.q).max() < TOL, k


@pytest.mark.parametrize("factor", [10.0, 0.1])
def test_stewart_with_unassemblable_legs_is_proven_empty(factor):
    ref = reference("dietmeier_66.json")
    lengths = [factor * v for v in ref["leg_lengths"]]
    mech = kinbox.load("dietmeier", leg_lengths=lengths)
    res = kinbox.solve(mech, time_limit=120)
    assert res.complete, res.message
    assert res.solutions == [] and res.components == []


def _griffis_duffy_checks(res, sigma: float) -> None:
    assert res.complete, res.message
    # exactly two components, both curves: no stray point or box beside them (the two curves
    # come close: at sigma = 0.5 their boxes touch and they are one component at that resolution)
    assert len(res.components) == 2, [(c.dimension, len(c.boxes)) for c in res.components]
    assert all(c.dimension == 1 and not c.bifurcations for c in res.components)
    assert res.stats.get("unresolved_boxes", 0) == 0
    # a mobile platform: no isolated certified assembly
    assert not [s for s in res.solutions if s.certified]
    ref = reference("griffis_duffy.json")
    # the samples along each curve are box centres: near the legs' lengths to about the box size
    for ci in range(len(res.components)):
        samples = res.curves[ci].samples() if ci in res.curves else []
        assert samples
        worst = max(_leg_errors(ref, q, ref["leg_lengths_consistent"]).max() for q in samples)
        assert worst < 10 * sigma, f"component {ci}: a sample is {worst:.3g} off the legs"


@pytest.mark.slow  # up to a minute each on a loaded 2-core VM (timed by benchmarks/mobile.py, not here)
@pytest.mark.parametrize("sigma", [0.25, 0.125, 0.0625])
def test_griffis_duffy_two_curves(sigma):
    """Porta, Ros and Thomas 2009, Table II right: two separate 1-dimensional components, at the paper's sigmas (the last one
    is the published run's), with the default options (legs="auto" picks leg vectors)."""
    assert reference("griffis_duffy.json")["paper_run"][-1]["sigma"] == 0.0625
    res = kinbox.solve("griffis-duffy", sigma=sigma, time_limit=3600)
    assert res.stats["variables"] == 27  # the leg-vector formulation
    _griffis_duffy_checks(res, sigma)


# ----------------------------------------------------------------------------------------------
# Bricard
# ----------------------------------------------------------------------------------------------
@pytest.mark.slow
def test_bricard_curve_and_two_isolated_configurations():
    ref = reference("bricard_6r.json")
    sigma = ref["paper_run"]["sigma"]
    res = kinbox.solve("bricard", sigma=sigma, time_limit=3600)
    assert res.complete, res.message
    curves = [c for c in res.components if c.dimension >= 1]
    assert len(curves) == 1 and curves[0].dimension == 1, [(c.dimension, len(c.boxes)) for c in res.components]
    assert len(res.components) == 3  # the curve and the two rigid configurations, nothing else
    assert len(curves[0].bifurcations) == 2  # where the self-motion's branches cross (reference)
    mech = kinbox.load("bricard")
    info = [(np.round(s.q, 6).tolist(), s.certified, max(max(p, r) for _, p, r in mech.closure_residuals(s.q))) for s in res.solutions]
    assert len(res.solutions) == 2, info
    for s in res.solutions:  # the two rigid configurations close the loop (Pinocchio and the DH table)
        for name, pos, rot in mech.closure_residuals(s.q):
            assert pos < TOL and rot < TOL, (name, pos, rot, info)
        assert np.abs(_dh_product(ref["dh"], s.q) - np.eye(4)).max() < TOL, info
    assert_distinct(mech.model, res)
    # Jacobian rank 6 there (reference README): regular, so Krawczyk can certify them
    assert all(s.certified for s in res.solutions), info
    ci = res.components.index(curves[0])
    for q in res.curves[ci].samples():  # configurations along the self-motion: close to closing
        assert np.abs(_dh_product(ref["dh"], q) - np.eye(4)).max() < 10 * sigma


# ----------------------------------------------------------------------------------------------
# four-bar with the crank set
# ----------------------------------------------------------------------------------------------
FOUR_BAR = robot_file("four-bar.json")


def _check_four_bar(mech, dims, crank_angle):
    res = kinbox.solve(mech, set={"crank": crank_angle}, time_limit=60)
    assert res.complete, res.message
    ref = four_bar_assemblies(*dims, crank_angle)
    assert len(res.solutions) == len(ref), (crank_angle, [s.q for s in res.solutions], ref)
    assert all(s.certified for s in res.solutions)
    assert not [c for c in res.components if c.dimension >= 1]
    locked = copy.copy(mech)
    locked.locked = dict(mech.locked)
    locked.lock("crank", crank_angle)
    assert_closures(locked, res)
    model = res.mechanism.model
    names = [model.names[i] for i in range(1, model.njoints)]
    for asm in ref:
        want = four_bar_relative_angles(crank_angle, asm)
        hits = []
        for s in res.solutions:
            got = [s.q[model.joints[model.getJointId(n)].idx_q] for n in ("crank", "coupler", "rocker")]
            if max(abs(wrap(g - w)) for g, w in zip(got, want)) < 1e-9:
                hits.append(s)
        assert len(hits) == 1, (names, want, [s.q for s in res.solutions])
    return res


@pytest.mark.parametrize("crank_angle", [0.7, 0.0, 2.5, math.pi, -1.9])
def test_four_bar_crank_set_matches_closed_form(crank_angle):
    dims = (FOUR_BAR["ground"], FOUR_BAR["crank"], FOUR_BAR["coupler"], FOUR_BAR["rocker"])
    res = _check_four_bar(kinbox.load("four-bar"), dims, crank_angle)
    assert len(res.solutions) == 2  # a Grashof crank: the crank turns fully, two modes at every angle


@pytest.mark.parametrize("crank_angle,count", [(0.3, 2), (math.pi, 0), (2.8, 0)])
def test_four_bar_non_grashof(crank_angle, count):
    """ground 3, crank 1, coupler 1.5, rocker 1: the crank cannot turn fully; at crank = pi
    |BD| = 4 > coupler + rocker and the linkage cannot be assembled (a proven empty answer)."""
    dims = (3.0, 1.0, 1.5, 1.0)
    mech = kinbox.load("four-bar", ground=dims[0], crank=dims[1], coupler=dims[2], rocker=dims[3])
    assert len(four_bar_assemblies(*dims, crank_angle)) == count
    res = _check_four_bar(mech, dims, crank_angle)
    if count == 0:
        assert res.solutions == [] and res.components == []


@pytest.mark.parametrize("sigma", [0.5, 0.1])  # at 0.1, stray boxes beside a curve once made 4 "curves"
@pytest.mark.slow
def test_four_bar_free_is_two_circuits(sigma):
    """Without the crank set, the four-bar moves: a positive-dimensional answer, not an error.

    ground 3, crank 1, coupler 3, rocker 2 is a Grashof crank-rocker (1 + 3 <= 3 + 2): the
    coupler and rocker never line up (|BD| stays in [2, 4], strictly inside (1, 5)), so its
    configuration curve is two disjoint circuits, C on the left of B -> D or on the right."""
    _check_four_bar_circuits(kinbox.solve("four-bar", sigma=sigma, time_limit=120), sigma)


def test_four_bar_free_is_two_circuits_by_default():
    """The same with the default options (about 1 s): exactly the two circuits, no
    bifurcation, no stray point."""
    res = kinbox.solve("four-bar", time_limit=120)
    _check_four_bar_circuits(res, MECHANISM_SIGMA)
    assert len(res.components) == 2 and not any(c.bifurcations for c in res.components)
    assert res.stats.get("unresolved_boxes", 0) == 0


def _check_four_bar_circuits(res, sigma: float) -> None:
    assert res.complete, res.message
    curves = [ci for ci, c in enumerate(res.components) if c.dimension >= 1]
    assert len(curves) == 2, [(c.dimension, len(c.boxes)) for c in res.components]
    assert all(res.components[ci].dimension == 1 for ci in curves)
    assert not [s for s in res.solutions if s.certified]
    dims = (FOUR_BAR["ground"], FOUR_BAR["crank"], FOUR_BAR["coupler"], FOUR_BAR["rocker"])
    model = res.mechanism.model
    idx = [model.joints[model.getJointId(n)].idx_q for n in ("crank", "coupler", "rocker")]
    sides = []
    for ci in curves:
        side = set()
        for q in res.curves[ci].samples():
            got = [q[i] for i in idx]
            asms = four_bar_assemblies(*dims, got[0])
            assert len(asms) == 2
            errs = [max(abs(wrap(g - w)) for g, w in zip(got, four_bar_relative_angles(got[0], a))) for a in asms]
            k = int(np.argmin(errs))
            assert errs[k] < 4 * sigma, (got, errs)  # a box centre, near the curve
            side.add(k)
        assert len(side) == 1, f"component {ci} has samples on both circuits"
        sides.append(side.pop())
    assert sorted(sides) == [0, 1]


# ----------------------------------------------------------------------------------------------
# 3-RPR
# ----------------------------------------------------------------------------------------------
RPR = robot_file("3-rpr.json")


def _platform_poses(res):
    """(x, y, phi) of the platform frame at every solution (Pinocchio FK)."""
    model = res.mechanism.model
    data = model.createData()
    fid = model.getFrameId("platform")
    out = []
    for s in res.solutions:
        pin.forwardKinematics(model, data, s.q)
        M = pin.updateFramePlacement(model, data, fid)
        assert abs(M.translation[2]) < 1e-12
        out.append((M.translation[0], M.translation[1], math.atan2(M.rotation[1, 0], M.rotation[0, 0])))
    return out


def _check_3rpr(legs):
    res = kinbox.solve("3-rpr", set={f"leg{i + 1}": v for i, v in enumerate(legs)}, time_limit=120)
    assert res.complete, res.message
    ref = three_rpr_assemblies(RPR["base_points"], RPR["platform_points"], legs)
    assert len(res.solutions) == len(ref), (legs, len(res.solutions), len(ref))
    assert all(s.certified for s in res.solutions)
    assert_closures(kinbox.load("3-rpr", leg_lengths=list(legs)), res)
    poses = _platform_poses(res)
    for p in poses:  # the oracle's leg equations
        assert np.abs(three_rpr_residuals(RPR["base_points"], RPR["platform_points"], legs, p)).max() < 1e-9
    for r in ref:
        hits = [p for p in poses if abs(p[0] - r[0]) < 1e-8 and abs(p[1] - r[1]) < 1e-8 and abs(wrap(p[2] - r[2])) < 1e-8]
        assert len(hits) == 1, (r, poses)
    return res


def test_3rpr_builtin_has_six_assemblies():
    assert RPR["platform_points"][0] == [0, 0]  # the platform frame is B1's: poses compare directly
    res = _check_3rpr(RPR["leg_lengths"])
    assert len(res.solutions) == 6


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_3rpr_legs_of_random_poses(seed):
    """Leg lengths of a random assembled pose: that pose is among the solutions."""
    rng = np.random.default_rng(seed)
    A = np.asarray(RPR["base_points"], float)
    b = np.asarray(RPR["platform_points"], float)
    x, y, phi = rng.uniform(0, 12), rng.uniform(0, 12), rng.uniform(-math.pi, math.pi)
    c, s = math.cos(phi), math.sin(phi)
    legs = np.linalg.norm(np.array([x, y]) + b @ np.array([[c, -s], [s, c]]).T - A, axis=1).tolist()
    res = _check_3rpr(legs)
    assert any(abs(p[0] - x) < 1e-8 and abs(p[1] - y) < 1e-8 and abs(wrap(p[2] - phi)) < 1e-8 for p in _platform_poses(res))


def test_3rpr_unassemblable_legs():
    assert three_rpr_assemblies(RPR["base_points"], RPR["platform_points"], [0.5, 0.5, 0.5]) == []
    res = _check_3rpr([0.5, 0.5, 0.5])
    assert res.solutions == [] and res.components == []


# ----------------------------------------------------------------------------------------------
# bad input
# ----------------------------------------------------------------------------------------------
def test_set_unknown_joint():
    with pytest.raises(kinbox.NameNotFound):
        kinbox.solve("four-bar", set={"no_such_joint": 0.3}, time_limit=10)


def test_unknown_mechanism():
    with pytest.raises(kinbox.NameNotFound):
        kinbox.solve("no-such-mechanism-xyz", time_limit=10)


def test_serial_arm_without_goal():
    with pytest.raises(kinbox.FormulationError):
        kinbox.solve("ur5", time_limit=10)


def test_non_finite_set_value():
    with pytest.raises(kinbox.InputError):
        kinbox.solve("four-bar", set={"crank": float("nan")}, time_limit=10)


def test_legs_forms_of_a_platform():
    """The two leg formulations of a Stewart platform: sizes, and an assembly found by an
    independent Newton solver is a zero of both systems."""
    from tests.support.oracles import stewart as sw

    ref = reference("dietmeier_66.json")
    mech = kinbox.load("dietmeier")
    sq, vec = formulate(mech), formulate(mech, legs="vector")
    assert sq.system.n == 12 and sq.system.is_square
    assert vec.system.n > sq.system.n and vec.system.is_square
    q = sw.assemblies(ref["base_points"], ref["platform_points"], ref["leg_lengths"], starts=40, seed=0)[0]
    for form in (sq, vec):
        x = form.encode(q)
        assert np.abs(form.system.compile().eval_eqs(x)).max() < 1e-9
    with pytest.raises(kinbox.InputError, match="legs"):
        formulate(mech, legs="round")
