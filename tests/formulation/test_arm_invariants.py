"""Raghavan and Roth's invariants for general 6R arms (kinbox.formulation.arm_invariants).

Every row must hold at every configuration of the arm with its goal computed by Pinocchio (and
fail at a wrong one), the answers must be the arm formulation's, and only arms without
structure the arm formulation uses get this one.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

import kinbox
from kinbox.formulation.arm import ArmTemplate
from kinbox.formulation.arm_invariants import InvariantsTemplate, invariants
from kinbox.model.builders import dh_chain
from tests.support import fuzz_arms as fa


def _ik(case: fa.Case, formulation: str = "auto") -> kinbox.IK:
    return kinbox.IK(case.robot, case.frame, lock=case.lock or None, formulation=formulation)


def _values(case: fa.Case, res) -> list[np.ndarray]:
    return [fa.joint_values(case.model, s.q) for s in res.solutions]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_every_row_holds_at_configurations_of_the_arm(seed, tmp_path):
    case = fa.make_case("general_6r", seed, tmp_path)
    ik = _ik(case, "invariants")
    tpl = ik.arm
    assert isinstance(tpl, InvariantsTemplate)
    rng = np.random.default_rng(seed)
    for _ in range(8):
        values = fa.random_values(case.model, rng)
        q = fa.config_from_values(case.model, values)
        goal = fa.frame_pose(case.model, case.frame, q)  # Pinocchio's FK, not kinbox's
        form = ik.problem(goal).formulation
        comp = form.system.compile()
        x = form.encode(q)
        F = comp.eval_eqs(x)
        bad = np.flatnonzero(np.abs(F) > comp.slack[: comp.n_eq])
        assert not len(bad), [(comp.row_names[i], F[i], comp.slack[i]) for i in bad]
        assert np.all(comp.eval_ineqs(x) <= comp.slack[comp.n_eq :])
        # the joint values come back, joint 6 from the goal
        back = fa.joint_values(case.model, form.decode(x))
        assert fa.value_distance(case.model, back, values) < 1e-9
        # and a configuration that misses the goal breaks the invariant and combination rows
        wrong = values.copy()
        wrong[2] += 0.3
        Fw = comp.eval_eqs(form.encode(fa.config_from_values(case.model, wrong)))
        for stem in ("inv:", "elim:", "solve:", "couple:"):
            rows = [i for i, n in enumerate(comp.row_names[: comp.n_eq]) if n.startswith(stem)]
            assert rows and np.max(np.abs(Fw[rows])) > 1e3 * np.max(comp.slack[rows]), stem


def test_invariants_of_a_line_do_not_depend_on_its_frame():
    # the 14 quantities of a line turned about z (the rotation the elimination relies on)
    # keep p.p and p.l, and turn the vectors
    rng = np.random.default_rng(0)
    p, l = rng.normal(size=3), rng.normal(size=3)
    l /= np.linalg.norm(l)
    a = 0.7
    R = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1.0]])
    v, w = invariants(p, l), invariants(R @ p, R @ l)
    assert np.allclose(v[6:8], w[6:8])
    for k in (0, 3, 8, 11):
        assert np.allclose(R @ v[k : k + 3], w[k : k + 3])
    assert np.allclose(v[8:11], np.cross(p, l)) and np.allclose(v[11:], (p @ p) * l - 2 * (p @ l) * p)


@pytest.mark.parametrize("seed", [2, 6, pytest.param(30001, marks=pytest.mark.slow), pytest.param(30004, marks=pytest.mark.slow)])
def test_answers_equal_the_arm_formulation(seed, tmp_path):
    case = fa.make_case("general_6r", seed, tmp_path)
    inv = _ik(case).solve(case.goal, max_boxes=50_000, closed_form=False)  # the searches, not the eigenvalue path
    arm = _ik(case, "arm").solve(case.goal, max_boxes=50_000, closed_form=False)
    assert inv.complete and arm.complete
    assert all(s.certified for s in inv.solutions)
    va, vb = _values(case, inv), _values(case, arm)
    assert len(va) == len(vb) >= 1
    for x in va:
        assert min(fa.value_distance(case.model, x, y) for y in vb) < 1e-6
    for s in inv.solutions:
        assert fa.pose_error(case.model, case.frame, s.q, case.goal) < fa.FK_TOL
    assert min(fa.value_distance(case.model, x, case.values) for x in va) < 1e-6


def test_an_unreachable_pose_is_proven_empty(tmp_path):
    case = fa.make_case("general_6r", 1, tmp_path)
    far = pin.SE3(case.goal.rotation, case.goal.translation + np.array([20.0, 0.0, 0.0]))
    res = _ik(case).solve(far)
    assert res.complete and not res.solutions


def test_which_arms_get_the_invariants(tmp_path):
    assert isinstance(_ik(fa.make_case("general_6r", 1, tmp_path)).arm, InvariantsTemplate)
    # a wrist centre, three parallel axes (UR): the arm formulation
    for cls, seed in (("spherical_wrist", 1), ("industrial", 1), ("ur_like", 1)):
        assert isinstance(_ik(fa.make_case(cls, seed, tmp_path)).arm, ArmTemplate), cls
    assert isinstance(kinbox.IK("ur5", "tool0").arm, ArmTemplate)
    with pytest.raises(kinbox.FormulationError):
        _ = kinbox.IK("ur5", "tool0", formulation="invariants").arm


def _limited_ends(text: str, first: bool, last: bool) -> str:
    """The URDF with joint 1 and joint 6 given a range narrower than a turn (``first``,
    ``last``: 3 and 1.2 radians) or two turns."""
    for name, on in (("j1", first), ("j6", last)):
        head, rest = text.split(f'<joint name="{name}"', 1)
        body, tail = rest.split("</joint>", 1)
        body = body.replace('type="continuous"', 'type="revolute"')
        lines = [ln for ln in body.splitlines() if "<limit" not in ln]
        lo = (-1.5 if name == "j1" else -0.6) if on else -2 * math.pi
        lines.insert(1, f'    <limit lower="{lo}" upper="{-lo}" effort="1" velocity="1"/>')
        text = head + f'<joint name="{name}"' + "\n".join(lines) + "</joint>" + tail
    return text


@pytest.mark.parametrize("first,last", [(False, True), (True, True)])
def test_a_limited_end_joint(first, last, tmp_path):
    # joint 6 follows from the goal and no row holds it: with joint 6 limited the chain is
    # taken reversed, with both ends limited joint 6's limits are checked at each root; the
    # answers stay those of the arm formulation (which keeps to every limit in its search)
    case = fa.make_case("general_6r", 2, tmp_path)
    path = tmp_path / "limited.urdf"
    path.write_text(_limited_ends(case.urdf or "", first, last))
    model = pin.buildModelFromXML(path.read_text())
    ik = kinbox.IK(str(path), case.frame)
    assert isinstance(ik.arm, InvariantsTemplate) and ik.arm.geometry.chain.reversed == (not first)
    arm_ik = kinbox.IK(str(path), case.frame, formulation="arm")
    rng = np.random.default_rng(5)
    dropped = 0
    for _ in range(4):
        values = fa.random_values(model, rng)
        goal = fa.frame_pose(model, case.frame, fa.config_from_values(model, values))
        inv, arm = ik.solve(goal, closed_form=False), arm_ik.solve(goal, closed_form=False)  # the searches, not the eigenvalue path
        assert inv.complete and arm.complete
        va = [fa.joint_values(model, s.q) for s in inv.solutions]
        vb = [fa.joint_values(model, s.q) for s in arm.solutions]
        assert len(va) == len(vb) >= 1
        for x in va:
            assert min(fa.value_distance(model, x, y) for y in vb) < 1e-6
        assert min(fa.value_distance(model, x, values) for x in va) < 1e-6
        dropped += inv.stats.get("outside_limits", 0)
    assert dropped >= (1 if first else 0)  # roots with joint 6 outside its limits were dropped


def test_the_combinations_stay_out_of_the_lp(tmp_path):
    # linear combinations of rows add nothing to a relaxation linear in the monomials; the LP
    # gets the core and the invariants, propagation every row
    case = fa.make_case("general_6r", 1, tmp_path)
    comp = _ik(case).problem(case.goal).formulation.system.compile()
    lp = comp.for_lp()
    assert comp.lp_rows is not None and lp.lp_rows is None
    names = set(lp.row_names)
    assert not any(n.startswith(("elim:", "solve:")) for n in names)
    assert {n for n in comp.row_names if n.startswith(("inv:", "couple:", "circle:", "limit:"))} <= names
    assert lp.n_core == comp.n_core and lp.n_eq == comp.n_eq - 14
    keep = np.flatnonzero(comp.lp_rows)
    assert np.array_equal(lp.A.toarray(), comp.A.toarray()[keep]) and np.array_equal(lp.slack, comp.slack[keep])


def test_the_published_general_6r_as_an_arm(reference):
    # the general 6R loop of Porta, Ros and Thomas 2009 (Table I) is the IK of its DH chain at the identity: 16 real
    # solutions, all certified, each closing the chain by Pinocchio's forward kinematics
    ref = reference("general_6r.json")
    mech = dh_chain(ref["dh"], closed=False, name="arm")
    ik = kinbox.IK(mech, "tool")
    assert isinstance(ik.arm, InvariantsTemplate)
    res = ik.solve(pin.SE3.Identity(), closed_form=False)  # the invariants' search (the eigenvalue path: tests/search/test_eigen6r.py)
    assert res.complete and len(res.solutions) == ref["expected"]["real_solutions"] == 16
    assert all(s.certified for s in res.solutions)
    data = mech.model.createData()
    for s in res.solutions:
        pin.framesForwardKinematics(mech.model, data, s.q)
        assert np.abs(data.oMf[mech.model.getFrameId("tool")].homogeneous - np.eye(4)).max() < 1e-9
    qs = np.array([s.q for s in res.solutions])
    gaps = [np.abs(np.angle(np.exp(1j * (a - b)))).max() for i, a in enumerate(qs) for b in qs[i + 1 :]]
    assert min(gaps) > 1e-6  # 16 distinct configurations


def test_two_workers_give_the_serial_tree(tmp_path):
    # the bound system (with its LP row mask) goes to worker processes and back: the same
    # boxes, LPs and solutions as in one process
    case = fa.make_case("general_6r", 2, tmp_path)
    ik = _ik(case)
    one = ik.solve(case.goal, closed_form=False)  # the search in one process, not the eigenvalue path
    two = ik.solve(case.goal, workers=2)
    assert one.complete and two.complete
    assert (one.stats["boxes"], one.stats["lps"]) == (two.stats["boxes"], two.stats["lps"])
    assert len(one.solutions) == len(two.solutions)
    for s in one.solutions:
        assert min(np.abs(np.angle(np.exp(1j * (s.q - t.q)))).max() for t in two.solutions) < 1e-9


def _roots_in_certified_boxes(tpl, res, real) -> int:
    """How many of the 40-digit roots ``real`` (joint angles along the chain) lie in a
    certified box (their cosines and sines of joints 1..5, at 60 digits)."""
    import mpmath as mp

    g = tpl.geometry
    held = 0
    for r in real:
        for b in res.raw.boxes:
            if not b.certified:
                continue
            lo, hi = b.enclosure
            inside = True
            for i, (ic, is_) in enumerate(tpl.angles):
                th = r[i] + mp.mpf(float(g.gamma[i]))
                for v, val in ((ic, mp.cos(th)), (is_, mp.sin(th))):
                    inside = inside and mp.mpf(float(lo[v])) <= val <= mp.mpf(float(hi[v]))
            if inside:
                held += 1
                break
    return held


def test_certificates_hold_the_roots_of_the_arm_and_pose_as_given(tmp_path):
    """The core rows carry the model's exact links (formulation/constants.py, as errfloat.EF
    coefficients) and the goal line's enclosure (``merr``, ``mgrad``): each certified box holds
    its root of the pose and the arm as given, computed at 40 digits (complex Newton,
    tests/support/oracles/mp_ik.py). The same rows without the enclosures certify boxes of a
    few ulps about the rounded rows' roots, which miss them."""
    from tests.support.oracles import mp_ik

    case = fa.make_case("general_6r", 1, tmp_path)
    ik = _ik(case, "invariants")
    tpl = ik.arm
    assert isinstance(tpl, InvariantsTemplate) and tpl.enclosure is not None and not tpl.geometry.chain.reversed
    q = fa.config_from_values(case.model, fa.random_values(case.model, np.random.default_rng(1)))
    goal = ik.pose_at(q)
    comp = tpl.bind(goal).compile()
    assert np.all(comp.merr[: comp.n_core] <= comp.slack[: comp.n_core]) and comp.merr[: comp.n_core].max() > 0.0
    res = ik.solve(goal, closed_form=False)
    seeds = [s for x in [q, *(s.q for s in res.solutions)] for s in mp_ik.wrist_and_elbow_seeds(fa.joint_values(case.model, x))]
    real, _ = mp_ik.roots(mp_ik.Chain(ik.robot.model, ik.frame), mp_ik.exact_pose(goal), seeds)
    assert len(real) >= 2 and len(res.solutions) == len(real) and all(s.certified for s in res.solutions)
    assert _roots_in_certified_boxes(tpl, res, real) == len(real)
    enclosure, tpl.enclosure = tpl.enclosure, None
    try:
        rounded = ik.solve(goal, closed_form=False)
    finally:
        tpl.enclosure = enclosure
    assert _roots_in_certified_boxes(tpl, rounded, real) < len(real)
