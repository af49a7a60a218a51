"""Parameters as enclosures: the arm template's rows carry how far the rows of the pose as given
lie from the rounded ones (``Compiled.merr``, ``Compiled.mgrad``), and Krawczyk's proofs hold
for the pose as given. Checked against roots computed at 40 digits (tests/support/oracles/mp_ik.py)."""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pytest

import kinbox
from kinbox.formulation import enclose
from kinbox.formulation.system import System
from kinbox.search.certify import Certifier
from tests.support import paths as PATHS
from tests.support.curves import judge
from tests.support.oracles import mp_ik


def _mp_params(arm, goal) -> list:
    """The arm's parameters at 60 digits from the pose's XYZQUAT and the arm's constant frames."""
    mp.mp.dps = 60
    R, t = mp_ik.exact_pose(goal)
    if arm.geometry.chain.reversed:
        R, t = R.T, -(R.T * t)

    def frame(T):
        return mp.matrix([[mp.mpf(float(v)) for v in row] for row in T.rotation]), mp.matrix([mp.mpf(float(v)) for v in T.translation])

    def inv(F):
        return F[0].T, -(F[0].T * F[1])

    def mul(A, B):
        return A[0] * B[0], A[0] * B[1] + A[1]

    g = arm.geometry
    GR, Gt = mul(mul(inv(frame(g.C0)), frame(g.chain.base)), mul((R, t), inv(frame(g.E))))
    v = mp.matrix([-Gt[1], Gt[0], 0])
    out = [mp.mpf(1)] + [GR[r, k] for r in range(3) for k in range(3)] + [Gt[r] for r in range(3)]
    out += [(GR.T * Gt)[r] for r in range(3)] + [sum(Gt[r] ** 2 for r in range(3))] + [(GR.T * v)[r] for r in range(3)]
    return out


@pytest.mark.parametrize("robot", ["ur5", "ur10"])
def test_goal_parameters_enclose_their_exact_values(robot):
    ik = kinbox.IK(robot, "tool0")
    arm = ik.arm
    rng = np.random.default_rng(3)
    for q in rng.uniform(-np.pi, np.pi, (20, 6)):
        goal = ik.pose_at(q)
        p, rad = arm.params_enclosure(goal)
        exact = _mp_params(arm, goal)
        for k, (a, e) in enumerate(zip(p, exact)):
            assert abs(mp.mpf(float(a)) - e) <= mp.mpf(float(rad[k])), (k, a, e, rad[k])
        # tight: half an ulp and the extended rounding, not a slack, besides the distance of
        # the arm's binary64 frames to the model's (formulation/constants.py)
        assert np.all(rad <= 4 * np.spacing(np.maximum(np.abs(p), 1.0)) + arm._constants_radius(goal, p))
        # the exact rational computation agrees
        p2, rad2 = arm._params_exact(goal)
        assert np.all(np.abs(p2 - p) <= rad + rad2)


def test_exact_rounding_radius():
    """:func:`enclose.rounded` gives the nearest double and a radius that holds the value."""
    from fractions import Fraction

    vals = [Fraction(1, 3), Fraction(-2, 7) * Fraction(10) ** -300, Fraction(5), Fraction(1, 2**1100)]
    mid, rad = enclose.rounded(vals)
    for v, m, r in zip(vals, mid, rad):
        assert abs(v - Fraction(float(m))) <= Fraction(float(r))
        assert m == float(v)


def test_a_unique_verdict_covers_every_system_within_the_model_error():
    """``x^2 - 2 = 0`` with its constant known to within ``r``: Krawczyk's unique box must hold
    the roots ``sqrt(2 - r)`` and ``sqrt(2 + r)`` of the extreme systems, not only ``sqrt(2)``."""
    s = System()
    x = s.add_var("x", 0.5, 3.0)
    s.add_eq(x * x - 2.0, "eq")
    comp = s.compile()
    r = 1e-6
    comp.merr = np.array([r])
    comp.mgrad = np.array([0.0])
    cert = Certifier(comp)
    k = cert.krawczyk(np.array([1.40]), np.array([1.43]))
    assert k.status == "unique"
    lo, hi = cert.tighten(k.lo, k.hi)
    mp.mp.dps = 40
    assert mp.mpf(float(lo[0])) <= mp.sqrt(2 - mp.mpf(r)) and mp.mpf(float(hi[0])) >= mp.sqrt(2 + mp.mpf(r))
    # without the model error the box is a few ulps around sqrt(2) and misses them
    s.invalidate()
    cert0 = Certifier(s.compile())
    k0 = cert0.krawczyk(np.array([1.40]), np.array([1.43]))
    assert k0.status == "unique"
    lo0, hi0 = cert0.tighten(k0.lo, k0.hi)
    assert hi0[0] - lo0[0] < 1e-14


@pytest.mark.parametrize("q3", [pytest.param(1e-5, marks=pytest.mark.slow), 1e-6])
def test_certified_boxes_near_the_elbow_singularity_hold_the_exact_roots(q3):
    """A UR5 ``q3`` from its elbow singularity: two roots ``2 q3`` apart. Each is certified in a
    box that holds the root of the pose as given at 40 digits (the rounded rows' root is 5e-11
    from it at 1e-6: a box of a few ulps around that one missed it)."""
    ik = kinbox.IK("ur5", "tool0")
    q = [0.3, -1.2, q3, -0.8, 1.2, 0.4]
    goal = ik.pose_at(q)
    res = ik.solve(goal)
    rep = judge(ik, goal, res, q)
    assert rep["real"] == 2 and rep["certified"] == 2
    assert rep["lost"] == rep["cert_missing"] == rep["merged"] == 0, rep


def test_the_kr6_file_is_the_dh_table():

    from tests.support import kr6_dh

    assert (PATHS.DATA / "kr6_dh15.urdf").read_text() == kr6_dh.URDF


def kr6_case(q5: float):

    from tests.support import kr6_dh

    ik = kinbox.IK(str(PATHS.DATA / "kr6_dh15.urdf"), "tool0")
    mp.mp.dps = mp_ik.WORK
    chain = mp_ik.Chain(ik.robot.model, "tool0", placements=kr6_dh.exact_placements())
    q = [0.3, -1.2, 0.5, -0.8, q5, 0.4]
    goal = ik.pose_at(q)
    res = ik.solve(goal)
    return ik, goal, res, judge(ik, goal, res, q, chain=chain)


@pytest.mark.parametrize(
    "q5",
    [
        pytest.param(1e-7, marks=pytest.mark.slow),
        pytest.param(1e-8, marks=pytest.mark.slow),
        pytest.param(1e-9, marks=pytest.mark.slow),
        1e-10,
    ],
)
def test_a_near_right_angle_is_kept_as_given(q5):
    """The KR6 of ``tests/data/kr6_dh15.urdf`` (right angles to 15 digits), ``q5`` from its wrist
    singularity: every certified box holds a root of the model as written at 40 digits (snapped
    to exact right angles, the certified roots were 2e-6..2e-3 rad from them)."""
    ik, goal, res, rep = kr6_case(q5)
    assert rep["real"] >= 2 and rep["certified"] >= 1
    assert rep["lost"] == rep["cert_missing"] == rep["merged"] == 0, rep


def test_an_errfloat_bounds_its_distance_to_the_exact_value():
    """:class:`errfloat.EF` through sums and products: the exact result (rational arithmetic on
    exact inputs within the starting errors) lies within the carried bound."""
    from fractions import Fraction

    from kinbox.formulation.errfloat import EF

    rng = np.random.default_rng(5)
    for _ in range(200):
        vals = rng.normal(size=4) * 10.0 ** rng.integers(-3, 3, size=4)
        errs = np.abs(vals) * rng.uniform(0, 4e-16, size=4)
        shifts = rng.uniform(-1, 1, size=4)
        ex = [Fraction(float(v)) + Fraction(float(e)) * Fraction(float(s)) for v, e, s in zip(vals, errs, shifts)]
        a, b, c, d = (EF(float(v), float(e)) for v, e in zip(vals, errs))
        r = a * b - c * d + a * 2.0 + (b - 0.0) * d
        exact = ex[0] * ex[1] - ex[2] * ex[3] + ex[0] * 2 + ex[1] * ex[3]
        assert abs(exact - Fraction(float(r))) <= Fraction(r.err)
        v0, v1, v2, v3 = (float(v) for v in vals)
        assert float(r) == v0 * v1 - v2 * v3 + v0 * 2.0 + v1 * v3  # the value is the plain float's


def test_the_batch_model_errors_are_the_one_pose_ones():
    """``template.model_errors`` (the closed-form batch) gives each pose the bounds
    ``Template.bind`` gives it alone."""
    from kinbox.formulation.template import model_errors

    ik = kinbox.IK("ur5", "tool0")
    arm = ik.arm
    f = arm.template.freeze()
    rng = np.random.default_rng(2)
    P, AP, PRAD, M, G = [], [], [], [], []
    for q in rng.uniform(-np.pi, np.pi, (4, 6)):
        goal = ik.pose_at(q)
        p, prad = arm.params_enclosure(goal)
        P.append(p)
        AP.append(np.maximum(np.abs(p), arm.param_magnitudes(goal)))
        PRAD.append(prad)
        comp = arm.bind(goal).compile()
        M.append(comp.merr)
        G.append(comp.mgrad)
    merr, mgrad = model_errors(f, np.array(P), np.array(AP), np.array(PRAD))
    assert np.allclose(merr, np.array(M), rtol=1e-12, atol=0) and np.allclose(mgrad, np.array(G), rtol=1e-12, atol=0)


def test_the_model_constants_are_enclosed_tightly():
    """The exact links of Pinocchio's UR5 (rotations read through their unit quaternions) lie
    within an ulp or so of the template's binary64 links: the radii are not a slack."""
    arm = kinbox.IK("ur5", "tool0").arm
    assert arm.constants is not None
    for rR, rt in arm.constants["links"]:
        assert np.all(rR <= 2.0**-52) and np.all(rt <= 2.0**-51)
    f = arm.template.freeze()
    assert f["coef_err"].max() < 1e-15 and f["zero_val"].max() < 1e-14


def _general_case(robot: str, q: list[float], roots=None):
    """Solve the pose of ``q`` through the general formulation (the search alone) and check
    every certified box against the 40-digit roots (:func:`tests.support.enclosures.general_check`)."""
    from tests.support import kr6_dh
    from tests.support.enclosures import general_check

    chain = None
    if robot == "kr6":
        ik = kinbox.IK(str(PATHS.DATA / "kr6_dh15.urdf"), "tool0", formulation="general")
        mp.mp.dps = mp_ik.WORK
        chain = mp_ik.Chain(ik.robot.model, "tool0", placements=kr6_dh.exact_placements())
    else:
        ik = kinbox.IK(robot, "tool0", formulation="general")
    goal = ik.pose_at(q)
    res = ik.solve(goal, closed_form=False)
    assert res.stats["method"] == "branch-and-prune"
    return res, general_check(ik, goal, res, [q], chain=chain, roots=roots)


def test_the_general_formulation_certifies_the_model_as_given(monkeypatch):
    """The general formulation (``formulation="general"``) writes its rows from the model's
    binary64 numbers (products rounded, entries below ``pairs.SNAP`` set to zero, the goal's
    rotation as its binary64 matrix); its core rows carry their distance to the rows of the model
    and pose as given (``merr``, ``mgrad`` from the shadow build of
    ``formulation/enclose_rows.py``). A UR5 1e-6 from its elbow singularity: both roots certified
    in boxes that hold the 40-digit roots; with the rows taken as exact (no enclosure) the boxes
    are a few ulps wide and miss them (6.9e-11 away)."""
    from kinbox.formulation import build

    q = [0.3, -1.2, 1e-6, -0.8, 1.2, 0.4]
    res, rep = _general_case("ur5", q)
    assert rep["real"] == 2 and len(res.solutions) == 2 and all(s.certified for s in res.solutions)
    assert all(r["in_certified_box"] for r in rep["roots"]), rep
    monkeypatch.setattr(build, "_core_errors", lambda *a: None)
    res0, rep0 = _general_case("ur5", q, roots=rep["oracle"])
    assert all(s.certified for s in res0.solutions)
    assert not any(r["in_certified_box"] for r in rep0["roots"]) and min(r["gap"] for r in rep0["roots"]) > 1e-12, rep0


@pytest.mark.slow
@pytest.mark.parametrize(
    "robot, q",
    [
        ("ur5", [0.3, -1.2, 1e-5, -0.8, 1.2, 0.4]),
        ("ur5", [0.3, -1.2, 1.5, -0.8, 1e-6, 0.4]),
        ("kr6", [0.3, -1.2, 0.5, -0.8, 1e-10, 0.4]),
        ("kr6", [0.3, -1.2, 0.5, -0.8, 1e-8, 0.4]),
    ],
)
def test_the_general_formulation_holds_the_exact_roots_near_singularities(robot, q):
    """Near the elbow and wrist singularities of a UR5 and the wrist of the KR6 of
    ``tests/data/kr6_dh15.urdf`` (right angles to 15 digits, which ``pairs.SNAP`` snaps to
    exact ones: the snapped entry's value is carried as its error), every certified box of the
    general formulation holds its 40-digit root, and every real root is in one."""
    res, rep = _general_case(robot, q)
    assert rep["real"] >= 2
    assert all(r["in_certified_box"] for r in rep["roots"]), rep


@pytest.mark.parametrize(
    "name, covered",
    [
        ("general-6r", True),
        ("bricard", True),
        ("delta", True),
        ("dietmeier", True),
        ("four-bar", True),
        ("3-rpr", True),
        ("watt-baranov", True),
    ],
)
def test_which_mechanisms_the_shadow_build_covers(name, covered):
    """The shadow build covers, in the general formulation, every pair kinbox formulates and
    weld, point and distance closures (``tests/formulation/test_enclose_pairs.py``), and in the
    planar one exactly planar models (welds included)."""
    from kinbox.problems.mechanism import choose_formulation

    sys_ = choose_formulation(kinbox.load(name)).system
    assert (sys_.core_errors is not None) == covered
    if covered:
        comp = sys_.compile()
        assert comp.merr.shape == comp.slack.shape and np.all(comp.slack[: comp.n_core] >= comp.merr[: comp.n_core])
        assert 0 < comp.merr.max() < 1e-13


def test_a_snapped_entry_keeps_its_value_as_its_error():
    """``pairs.snap`` of an ``EF`` array (the shadow build) sets small entries to a zero whose
    error holds the entry; a float array is snapped as before."""
    from kinbox.formulation import pairs
    from kinbox.formulation.enclose_rows import ef_array
    from kinbox.formulation.errfloat import err

    a = ef_array(np.array([3e-15, 1.0, -6e-17, 0.0]), np.array([1e-18, 0.0, 0.0, 0.0]))
    out = pairs.snap(a)
    assert [float(v) for v in out] == [0.0, 1.0, 0.0, 0.0]
    assert err(out[0]) >= 3e-15 + 1e-18 and err(out[2]) >= 6e-17 and err(out[3]) == 0.0
    assert pairs.snap(np.array([3e-15, 1.0])).tolist() == [0.0, 1.0]


def test_a_nearly_planar_model_keeps_its_rows_as_rounded():
    """A four-bar whose first joint's placement is turned by 1e-13 rad about x: the planar
    formulation still takes it (its axes are parallel to ``PARALLEL_TOL``), but the model as
    given is not planar, so its rows are not claimed to be the model's (``core_errors`` None);
    the four-bar as given is exactly planar and its rows carry their errors."""
    import pinocchio as pin

    from kinbox.formulation.planar import formulate_planar

    mech = kinbox.load("four-bar")
    assert formulate_planar(mech).system.core_errors is not None
    model = mech.model
    j = next(j for j in range(1, model.njoints) if model.joints[j].shortname().endswith("RZ"))
    M = model.jointPlacements[j]
    model.jointPlacements[j] = pin.SE3(pin.exp3(np.array([1e-13, 0.0, 0.0])) @ M.rotation, M.translation)
    pf = formulate_planar(mech)
    assert pf is not None and pf.system.core_errors is None


def _universal_arm(seed: int):
    """RZ, a universal joint about two random orthogonal axes (each normalized in binary64, so
    within an ulp of a unit vector), RY, a prismatic joint along a random axis and a second
    universal joint, with the tool's pose at a random configuration as the goal."""
    import pinocchio as pin

    from kinbox.model.mechanism import Mechanism

    rng = np.random.default_rng(seed)

    def unit():
        a = rng.normal(size=3)
        return a / np.linalg.norm(a)

    def pair():
        a = unit()
        b = np.cross(a, rng.normal(size=3))
        return a, b / np.linalg.norm(b)

    model = pin.Model()

    def add(parent, jm, xyz, name):
        lo, hi = np.full(jm.nq, -3.0), np.full(jm.nq, 3.0)
        return model.addJoint(parent, jm, pin.SE3(np.eye(3), np.array(xyz, float)), name, np.ones(jm.nv), np.ones(jm.nv), lo, hi)

    p = add(0, pin.JointModelRZ(), (0, 0, 0.3), "base")
    p = add(p, pin.JointModelUniversal(*pair()), (0.05, 0.1, 0.4), "shoulder")
    p = add(p, pin.JointModelRY(), (0.1, -0.05, 0.5), "elbow")
    p = add(p, pin.JointModelPrismaticUnaligned(unit()), (0.02, 0.01, 0.1), "slide")
    p = add(p, pin.JointModelUniversal(*pair()), (0.0, 0.08, 0.45), "wrist")
    model.addFrame(pin.Frame("tool", p, 0, pin.SE3(np.eye(3), np.array([0.03, 0.02, 0.15])), pin.FrameType.OP_FRAME))
    q = rng.uniform(-1.0, 1.0, model.nq)
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    return Mechanism(model, name=f"universal-{seed}"), data.oMf[model.getFrameId("tool")]


@pytest.mark.parametrize("name", ["3-rpr", "double-butterfly", "universal"])
def test_the_general_formulation_encloses_prismatic_and_universal_joints(name):
    """The general formulation's shadow build covers prismatic joints (the 3-RPR and the Double
    Butterfly written in 3D, whose slides are prismatic joints) and universal joints (two revolute
    parts about the joint's own two axes, each normalized exactly): their core rows carry
    ``merr`` and every core slack is at least it."""
    from kinbox.formulation.build import formulate

    if name == "universal":
        mech, goal = _universal_arm(0)
        mech.add_goal("tool", goal)
    else:
        mech = kinbox.load(name)
    sys_ = formulate(mech).system
    assert sys_.core_errors is not None
    comp = sys_.compile()
    assert np.all(comp.slack[: comp.n_core] >= comp.merr[: comp.n_core])
    assert comp.merr.max() < 1e-13
    if name == "universal":  # the binary64 axes are not exactly unit: the rows carry that
        assert comp.merr.max() > 0


def test_a_universal_joints_axis_bases_hold_the_exact_ones():
    """Each part of a universal joint (and a prismatic joint's slide) enters the shadow build as
    the binary64 basis ``[b1 b2 a]`` with errors that reach the exact orthonormal basis on the
    joint's own axis normalized at 60 digits (``z`` that axis, ``x`` ``b1`` made orthogonal to
    it); the binary64 bases differ from the exact ones, so the errors are what covers them."""
    from kinbox.formulation import build
    from kinbox.formulation.errfloat import err

    mech, goal = _universal_arm(1)
    mech.add_goal("tool", goal)
    sh = build._Steps(mech, "auto", enclose=True)
    sh.joints_that_enter()
    sh.frames_and_edges()
    mp.mp.dps = 60
    model, checked, off = mech.model, 0, 0
    for e in sh.edges:
        if e.B is None or e.jid < 0:
            continue
        jm = model.joints[e.jid]
        short = jm.shortname()
        if short == "JointModelUniversal":
            raw = (jm.extract().axis1, jm.extract().axis2)[int(e.name.rsplit("/", 1)[1])]
        elif short == "JointModelPrismaticUnaligned":
            raw = jm.extract().axis
        else:
            continue
        a = [mp.mpf(float(v)) for v in raw]
        n = mp.sqrt(sum(v * v for v in a))
        a = [v / n for v in a]
        b1 = [mp.mpf(float(e.B[i, 0])) for i in range(3)]
        d = sum(u * v for u, v in zip(b1, a))
        x = [u - d * v for u, v in zip(b1, a)]
        nx = mp.sqrt(sum(v * v for v in x))
        x = [v / nx for v in x]
        y = [a[1] * x[2] - a[2] * x[1], a[2] * x[0] - a[0] * x[2], a[0] * x[1] - a[1] * x[0]]
        cols = (x, y, a) if short == "JointModelUniversal" else (None, None, a)
        for j, col in enumerate(cols):
            if col is None:
                continue
            for i in range(3):
                gap = abs(col[i] - mp.mpf(float(e.B[i, j])))
                assert gap <= err(e.B[i, j])
                off += gap > 0
                checked += 1
    assert checked == 2 * 2 * 9 + 3 and off > 0
