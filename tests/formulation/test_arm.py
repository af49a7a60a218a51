"""The arm formulation (kinbox.formulation.arm): built once per arm and frame, bound per pose.

Its answers must be the general formulation's (kinbox.formulation.build.formulate): both are
solved on random arms of each class (tests/support/fuzz_arms.py writes them as URDF) and must give the
same set of configurations, each reaching the pose by independent forward kinematics.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import kinbox
from kinbox.errors import FormulationError
from kinbox.formulation.arm import arm_template
from kinbox.model.loading import load
from tests.support import fuzz_arms as fa


def _values(case: fa.Case, res) -> list[np.ndarray]:
    return sorted((fa.joint_values(case.model, s.q) for s in res.solutions), key=lambda v: tuple(np.round(v, 6)))


def _same_sets(case: fa.Case, a, b) -> None:
    va, vb = _values(case, a), _values(case, b)
    assert len(va) == len(vb), (len(va), len(vb))
    for x in va:
        assert min(fa.value_distance(case.model, x, y) for y in vb) < 1e-6


def _compare(cls: str, seed: int, tmp_path) -> None:
    case = fa.make_case(cls, seed, tmp_path)
    arm = kinbox.IK(case.robot, case.frame, lock=case.lock or None, formulation="arm")
    gen = kinbox.IK(case.robot, case.frame, lock=case.lock or None, formulation="general")
    ra = arm.solve(case.goal, max_boxes=100_000)  # a count, not a clock: the machine may be loaded
    rg = gen.solve(case.goal, max_boxes=100_000)
    assert ra.complete and rg.complete
    _same_sets(case, ra, rg)
    for s in ra.solutions:
        assert fa.pose_error(case.model, case.frame, s.q, case.goal) < fa.FK_TOL
    assert any(fa.value_distance(case.model, fa.joint_values(case.model, s.q), case.values) < 1e-6 for s in ra.solutions)


@pytest.mark.parametrize(
    "cls,seed",
    [
        ("ur_like", 1),
        ("ur_like", 2),
        ("industrial", 1),
        ("industrial", 2),
        ("prismatic", 1),
        ("seven_dof_locked", 0),
        ("seven_dof_locked", 11),  # S-R-S, a wrist joint locked: written from the end (below)
        ("prismatic", 5031),
        ("prismatic", 5456),
    ],
)
def test_arm_equals_general(cls, seed, tmp_path):
    _compare(cls, seed, tmp_path)


@pytest.mark.slow
@pytest.mark.parametrize(
    "cls,seed",
    [
        ("spherical_wrist", 0),
        ("spherical_wrist", 1),
        ("general_6r", 2),
        ("prismatic", 2),
        ("ur_like", 0),
        ("offset_wrist", 2),
        ("seven_dof_locked", 5),  # Panda-like, joint 5 locked: written from the end
    ],
)
def test_arm_equals_general_slow(cls, seed, tmp_path):
    _compare(cls, seed, tmp_path)


@pytest.mark.parametrize(
    "robot, frame, lock, reversed_",
    [
        ("panda", "panda_hand", {"panda_joint7": 0.3}, True),  # shoulder axes 1-3 meet, wrist axes do not
        ("panda", "panda_hand", {"panda_joint6": 1.9}, True),
        ("panda", "panda_hand", {"panda_joint1": 0.3}, False),  # neither meets
        ("ur5", "tool0", None, False),
    ],
)
def test_a_spherical_shoulder_is_written_from_the_end(robot, frame, lock, reversed_):
    """The formulation decouples a wrist centre (axes 4, 5, 6 through one point); an arm whose
    first three axes meet instead (Panda with a wrist joint locked) is written for the reversed
    chain, where that point is the wrist centre."""
    ik = kinbox.IK(robot, frame, lock=lock)
    assert ik.arm is not None and ik.arm.geometry.chain.reversed is reversed_
    model = ik.robot.model
    q = np.random.default_rng(4).uniform(np.maximum(model.lowerPositionLimit, -3.0), np.minimum(model.upperPositionLimit, 3.0))
    for name, v in (lock or {}).items():
        q[model.joints[model.getJointId(name)].idx_q] = v
    goal = ik.pose_at(q)
    res = ik.solve(goal)
    assert res.complete and res.solutions and all(s.certified for s in res.solutions)
    for s in res.solutions:
        assert (ik.pose_at(s.q).inverse() * goal).isIdentity(1e-9)
    assert any(np.abs(np.angle(np.exp(1j * (s.q[:7] - q[:7])))).max() < 1e-7 for s in res.solutions)  # the generating one


def test_a_spherical_shoulder_stays_at_the_base_when_the_hand_joint_slides():
    """Reversed, a chain whose last joint is prismatic would have no revolute root: the arm is
    then written from the base (it fell back to the general formulation)."""
    from kinbox.model.mechanism import Mechanism

    model = pin.Model()
    parent = 0
    for kind, xyz in [
        ("RZ", (0, 0, 0.4)),
        ("RY", (0, 0, 0)),
        ("RX", (0, 0, 0)),
        ("RZ", (0.3, 0.05, 0.5)),
        ("RY", (0.1, 0.2, 0.3)),
        ("PZ", (0.2, 0.1, 0.3)),
    ]:
        joint = getattr(pin, f"JointModel{kind}")()
        lim = (np.array([-0.5]), np.array([0.5])) if kind == "PZ" else (np.array([-3.0]), np.array([3.0]))
        parent = model.addJoint(
            parent, joint, pin.SE3(np.eye(3), np.array(xyz, float)), f"j{parent + 1}", np.array([1.0]), np.array([1.0]), *lim
        )
    model.addFrame(pin.Frame("tool", parent, 0, pin.SE3(np.eye(3), np.array([0.0, 0.0, 0.1])), pin.FrameType.OP_FRAME))
    arm = arm_template(Mechanism(model, name="slider"), "tool")
    assert arm is not None and not arm.geometry.chain.reversed
    ik = kinbox.IK(Mechanism(model, name="slider"), "tool")
    q = np.array([0.4, -0.7, 1.1, 0.3, -0.9, 0.2])
    res = ik.solve(ik.pose_at(q))
    assert res.complete and any(np.abs(s.q - q).max() < 1e-7 for s in res.solutions)


@pytest.mark.parametrize("cls", ["spherical_wrist", "industrial", "seven_dof_locked"])
def test_the_line_2_distance_row_holds_at_every_configuration(cls, tmp_path):
    """With a wrist centre, the distance from line 2 to it and its component along line 2 are
    written from either side (rows in theta_3 and theta_1 alone): at configurations of the arm
    they hold within their slack, as every other row does (a wrong constant in them would lose
    roots, not only boxes), and they fail at a configuration with another theta_3."""
    checked = 0
    for seed in range(4):
        case = fa.make_case(cls, seed, tmp_path)
        ik = kinbox.IK(case.robot, case.frame, lock=case.lock or None)
        rng = np.random.default_rng(seed)
        for _ in range(5):
            q = fa.config_from_values(case.model, fa.random_values(case.model, rng, case.lock_idx))
            form = ik.problem(ik.pose_at(q)).formulation
            comp = form.system.compile()
            if "inv:line2" not in comp.row_names:
                continue
            F = comp.eval_eqs(form.encode(q))
            assert np.all(np.abs(F) <= comp.slack[: comp.n_eq]), [
                comp.row_names[i] for i in np.flatnonzero(np.abs(F) > comp.slack[: comp.n_eq])
            ]
            # theta_3 turned by 0.4 (the chain's third joint; the rows' own variables)
            # inv:axis2 is left out where it is the same row as a coupling row (couple1:p[y] on
            # the industrial arms here)
            pieper = [comp.row_names.index(n) for n in ("inv:line2", "inv:axis2") if n in comp.row_names]
            assert cls != "spherical_wrist" or len(pieper) == 2
            x = form.encode(q)
            third = form.arm.geometry.chain.joints[2].name
            ic, is_ = (form.system.index(n) for n in form.joint_vars[third])
            th = np.arctan2(x[is_], x[ic]) + 0.4
            x[ic], x[is_] = np.cos(th), np.sin(th)
            Fw = comp.eval_eqs(x)
            broken = [abs(Fw[i]) > 1e3 * comp.slack[i] for i in pieper]
            # special geometry can make one of them constant (axes 2, 3 parallel: the component
            # along line 2), never both; a general one moves both
            assert all(broken) if cls == "spherical_wrist" else any(broken), [Fw[i] for i in pieper]
            checked += 1
    assert checked >= 10


def test_joint_1_free_at_pinned_chains_is_split(tmp_path):
    # a random general 6R pose (the fuzz sweep's seed 5021) with a root where the coupling
    # leaves joint 1 nearly free once joints 2, 3, 5 and 6 are pinned: the search split the
    # pinned joints again and again (tens of thousands of boxes, no end) until derived
    # variables could be split; Newton from many starts finds 3 roots
    case = fa.make_case("general_6r", 5021, tmp_path)
    res = kinbox.IK(case.robot, case.frame, formulation="arm").solve(case.goal, max_boxes=5000)
    assert res.complete and len(res.solutions) == 3
    assert all(s.certified for s in res.solutions)
    roots = fa.newton_roots(case.model, case.frame, case.goal, 20, np.random.default_rng([5021, 7]))
    for s in res.solutions:
        assert fa.pose_error(case.model, case.frame, s.q, case.goal) < fa.FK_TOL
    found = [fa.joint_values(case.model, s.q) for s in res.solutions]
    for r in roots["roots"]:
        assert min(fa.value_distance(case.model, r, v) for v in found) < 1e-6


def test_template_built_once_bound_per_pose(ur5):
    ik = ur5
    arm = ik.arm
    assert arm is not None and ik.arm is arm
    rng = np.random.default_rng(3)
    frozen = arm.template.freeze()
    for _ in range(3):
        q = rng.uniform(-2, 2, 6)
        goal = ik.pose_at(q)
        form = ik.problem(goal).formulation
        x = form.encode(q)
        comp = form.system.compile()
        # the configuration's system point closes every row (to rounding), and decodes back
        assert np.max(np.abs(comp.eval_rows(x)[: comp.n_eq]), initial=0.0) < 1e-9
        assert np.max(np.abs(pin.difference(ik.robot.model, form.decode(x), q))) < 1e-9
        assert arm.template.freeze() is frozen  # nothing was built again


def test_bind_checks_parameters():
    arm = arm_template(load("ur5"), "tool0")
    assert arm is not None
    with pytest.raises(FormulationError):
        arm.template.bind(np.zeros(arm.template.nparams))


def test_chains_it_does_not_cover_fall_back():
    # seven moving joints: the general formulation, by structure (not by name)
    panda = load("panda")
    assert arm_template(panda, "panda_hand") is None
    with pytest.raises(FormulationError):
        _ = kinbox.IK("panda", "panda_hand", formulation="arm").arm
    assert kinbox.IK("panda", "panda_hand").arm is None
    # the same arm with a joint locked is six joints: covered
    assert kinbox.IK("panda", "panda_hand", lock={"panda_joint7": 0.3}).arm is not None


def test_solve_many_equals_solve(ur5):
    ik = ur5
    qs = [np.array([0.3, -1.2, 1.0, -0.8, 1.2, 0.4]), np.array([-1.0, -0.5, 2.0, 0.3, -1.0, 2.0])]
    poses = [ik.pose_at(q) for q in qs]
    many = ik.solve_many(poses)
    for pose, r in zip(poses, many):
        one = ik.solve(pose)
        assert len(r.solutions) == len(one.solutions) > 0
        assert r.stats["boxes"] == one.stats["boxes"]  # the same search, box for box


def test_solve_many_over_workers_equals_serial(ur5):
    ik = ur5
    poses = [ik.pose_at(q) for q in ([0.3, -1.2, 1.0, -0.8, 1.2, 0.4], [-1.0, -0.5, 2.0, 0.3, -1.0, 2.0])]
    serial = ik.solve_many(poses)
    spread = ik.solve_many(poses, workers=2)
    assert [len(r.solutions) for r in spread] == [len(r.solutions) for r in serial]
    assert [r.stats["boxes"] for r in spread] == [r.stats["boxes"] for r in serial]


def test_near_shoulder_singular_pose_is_settled():
    """A UR5 pose 1e-3 from the shoulder singularity: its 8 solutions come in pairs 8e-4 rad
    apart. With the derived rows' slack on the core rows, Krawczyk could prove no box next to
    a root empty (|J^-1| ~ 2e4 times the slack outweighed the Newton step) and the search
    split boxes of 1e-7 around each root without end; the box budget makes that a failure."""
    q = np.array([-2.62901, -2.09772, 1.29110, -2.98986, 0.55853, -0.94734])
    ik = kinbox.IK("ur5", "tool0")
    m = ik.robot.model
    d = m.createData()
    pin.framesForwardKinematics(m, d, q)
    r = ik.solve(d.oMf[m.getFrameId("tool0")], max_boxes=3000)
    assert r.complete
    assert len(r.solutions) == 8 and all(s.certified for s in r.solutions)
    assert min(np.max(np.abs(s.q - q)) for s in r.solutions) < 1e-5


def test_template_core_rows_slack_is_the_rounding_of_their_terms():
    """The core rows' slack scales with the size of their terms and the goal's translations,
    not with the derived rows' 1e-10 (see TEMPLATE_CORE_SLACK)."""
    from kinbox.formulation.template import TEMPLATE_CORE_SLACK

    ik = kinbox.IK("ur5", "tool0")
    comp = ik.arm.bind(pin.SE3(np.eye(3), np.array([0.3, 0.2, 0.4]))).compile()
    core, rest = comp.slack[: comp.n_core], comp.slack[comp.n_core :]
    assert np.all(core > 0) and np.all(core < 1e3 * TEMPLATE_CORE_SLACK)
    assert np.max(core) < 1e-3 * np.min(rest)


def test_isolated_roots_next_to_a_curve_are_not_taken_for_one():
    """UR5 1e-6 from the shoulder singularity: four pairs of roots 2e-6 apart, within 1e-6 of a
    curve of the singular arm. Curve boxes (on by default) once took a box of such a pair for a
    curve piece and the answer gave 4 uncertified points for these 8 roots; every one is
    certified, with curve boxes on (the default) and off."""
    from tests.support.stress import ur5_pose, ur5_singular

    q = ur5_singular("shoulder", 1e-6)
    for curve_boxes in (True, False):
        r = kinbox.ik("ur5", "tool0", ur5_pose(q), max_boxes=5000, curve_boxes=curve_boxes)
        assert r.complete
        assert len(r.solutions) == 8 and all(s.certified for s in r.solutions)


@pytest.mark.parametrize("pad", [5e-5, 1e-4])
def test_a_box_of_two_roots_next_to_a_curve_is_not_a_curve_box(pad):
    """The box around each pair of roots 1e-5 apart of the pose above (the closed form's, in the
    system's variables), widened by ``pad``: the transverse test proves every zero of it lies on
    one graph over one variable, and the dropped equation is ~1e-10 along it (the corrector
    once took that for a curve and returned the box whole). It must not come back as a curve
    box (an uncertified box wider than sigma): every sample of a curve closes each equation
    within its slack where the Jacobian is singular to working precision."""
    from kinbox.search.policy import Policy
    from kinbox.search.solver import BoxProcessor, SolverOptions
    from tests.support.stress import ur5_pose, ur5_singular, ur5_truths

    goal = ur5_pose(ur5_singular("shoulder", 1e-6))
    f = kinbox.IK("ur5", "tool0").problem(goal).formulation
    X = [f.encode(t) for t in ur5_truths(goal)]
    pairs = sorted(((i, j) for i in range(len(X)) for j in range(i)), key=lambda p: float(np.max(np.abs(X[p[0]] - X[p[1]]))))[:4]
    opt = SolverOptions(sigma=1e-4, curve_boxes=True)
    proc = BoxProcessor(f.system, opt)
    lo0, hi0 = f.system.search_domain()
    for i, j in pairs:
        assert np.max(np.abs(X[i] - X[j])) < 2e-5  # premise: a close pair
        lo = np.maximum(np.minimum(X[i], X[j]) - pad, lo0)
        hi = np.minimum(np.maximum(X[i], X[j]) + pad, hi0)
        o = proc.process(lo, hi, policy=Policy().with_rates(transverse=1.0))  # the transverse test on
        wide = o.solution is not None and not o.solution.certified and np.max(o.solution.hi - o.solution.lo) > opt.sigma
        assert not wide, f"the box of roots {i} and {j} came back as a curve box"


def test_curve_boxes_the_answer_finds_no_curve_in_are_searched_again(monkeypatch):
    """The answer stage is the second judge of a curve box. Both of the solver's judges are
    fooled here: the test at the samples is loosened back to what took the root pairs of the pose
    above for curve pieces (every equation within 1e-9), and the graph test is taken to pass on
    every box it is asked about (the transverse operator's uniqueness condition now rejects the
    root pairs' boxes by itself). The curve boxes the search then returns hold no curve the
    answer can follow, so they are searched again without curve boxes, and all 8 roots come out
    certified. (The steady start: the quick one settles this pose by Krawczyk's tests before
    any graph test; the fooled tests change the tree, and a box below sigma beside one root pair
    may be reported too, an uncertified near-duplicate: counted, not asserted away.)"""
    from kinbox.search import transverse
    from kinbox.search.curvebox import CurveBoxRule
    from kinbox.search.solver import RESOLVED
    from tests.support.stress import angle_distance, ur5_pose, ur5_singular, ur5_truths

    def loose(self, y):
        return bool(np.max(np.abs(self.comp.eval_eqs(y)), initial=0.0) <= RESOLVED)

    real = transverse.Transverse.contract

    def fooled(self, lo, hi, graph=False):
        t = real(self, lo, hi, graph)
        if graph and t.status != "empty" and t.params is not None and len(t.params) == 1 and t.graph_box is None:
            t.graph_box, t.graph = (t.lo.copy(), t.hi.copy()), True
        return t

    monkeypatch.setattr(CurveBoxRule, "on_curve", loose)
    monkeypatch.setattr(transverse.Transverse, "contract", fooled)
    goal = ur5_pose(ur5_singular("shoulder", 1e-6))
    r = kinbox.ik("ur5", "tool0", goal, max_boxes=5000, policy="steady", closed_form=False)  # the search's curve boxes
    assert r.stats.get("curve_boxes_searched_again", 0) > 0  # premise: the fooled tests let curve boxes through
    assert r.complete
    cert = [s for s in r.solutions if s.certified]
    assert len(cert) == 8
    for t in ur5_truths(goal):
        assert min(angle_distance(s.q, t) for s in cert) < 1e-8


def _first_split(arm) -> set[str]:
    ranks, names = arm.template.vars.ranks, arm.template.vars.names
    return {names[k] for k, r in enumerate(ranks) if r == 0} if ranks else set()


def _chain_vars(arm, positions) -> set[str]:
    return {v for k in positions for v in arm.joint_vars[arm.geometry.chain.joints[k].name]}


def test_parallel_shoulder_axes_split_the_wrist_first(ur5):
    """A UR's lines 2, 3, 4 are parallel: line 4's direction and the offset along it are rows
    in joints 1, 5 and 6 alone, which the search settles before the planar arm of joints 2, 3."""
    ik = ur5
    arm = ik.arm
    assert arm is not None
    assert _first_split(arm) == _chain_vars(arm, [4, 5]) != set()
    comp = ik.problem(ik.pose_at(np.array([0.3, -1.0, 1.2, 0.4, 0.9, -0.5]))).formulation.system.compile()
    names, chain_a = arm.template.vars.names, _chain_vars(arm, [1, 2])
    rows = [r for r, name in enumerate(comp.row_names) if name.startswith(("couple:z", "inv:pz"))]
    assert len(rows) == 5  # three direction rows, inv:pz and inv:pz5
    # chain A turns about one axis: its frame's four moving entries are two variables up to sign
    assert [n for n in names if n.startswith("R[elbow_joint]")] == ["R[elbow_joint][0,x]", "R[elbow_joint][2,x]"]
    assert (comp.n, comp.n_core) == (22, 22)
    for r in rows:
        used = set()
        for col in comp.A[r].indices:
            used |= {col} if col < comp.n else {comp.mi[col - comp.n], comp.mj[col - comp.n]}
        assert not {names[k] for k in used} & chain_a, comp.row_names[r]


def test_parallel_wrist_axes_split_the_shoulder_first(tmp_path):
    """The mirror image: lines 4, 5, 6 parallel. Chain A (joints 2, 3) is split first, and the
    answer is the general formulation's."""
    rng = np.random.default_rng(5)
    rows = [
        (0.0, 0.0, 0.3, 0.2, "R"),
        (np.pi / 2, 0.1, 0.05, -0.4, "R"),
        (-np.pi / 2, 0.4, 0.1, 0.3, "R"),
        (np.pi / 2, 0.05, 0.2, 0.1, "R"),
        (0.0, 0.5, 0.1, -0.2, "R"),  # 5 parallel to 4
        (0.0, 0.4, 0.08, 0.5, "R"),  # 6 parallel to 5
    ]
    a = fa.arm_from_dh("parallel_wrist", rng, rows)
    path = tmp_path / "parallel_wrist.urdf"
    path.write_text(a.urdf())
    model = pin.buildModelFromUrdf(str(path))
    values = fa.random_values(model, rng)
    goal = fa.frame_pose(model, a.frame, fa.config_from_values(model, values))
    ik = kinbox.IK(str(path), a.frame, formulation="arm")
    assert ik.arm is not None and not ik.arm.geometry.chain.reversed
    assert _first_split(ik.arm) == _chain_vars(ik.arm, [1, 2]) != set()
    case = fa.Case("parallel_wrist", 0, str(path), a.frame, model, values, goal)
    ra = ik.solve(goal, max_boxes=100_000)
    rg = kinbox.IK(str(path), a.frame, formulation="general").solve(goal, max_boxes=100_000)
    assert ra.complete and rg.complete and len(ra.solutions) >= 1
    _same_sets(case, ra, rg)
    assert any(fa.value_distance(model, fa.joint_values(model, s.q), values) < 1e-6 for s in ra.solutions)
