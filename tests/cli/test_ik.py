"""End-to-end tests of ``kinbox.ik`` / ``kinbox.IK``: every IK solution, checked independently.

Nothing kinbox computes is taken on trust here:

* goal poses are made with Pinocchio forward kinematics on models loaded by example-robot-data
  itself (not by kinbox's loader) from seeded random configurations;
* every returned ``q`` is checked with Pinocchio ``forwardKinematics`` + ``updateFramePlacement``
  on that independent model (``result.residual`` is not used);
* for the UR arms the solution set is compared with the closed-form oracle
  (``tests/support/oracles/ur_ik.py``), restricted to the joint limits;
* the general 6R arm is compared with the published count (``tests/data/reference``).

Every solve has a ``time_limit`` and asserts ``complete``, so a slow regression fails instead of
hanging. Fast tests run with ``make test``; ``@pytest.mark.slow`` ones with ``make test-slow``.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pinocchio as pin
import pytest

import kinbox
from kinbox.errors import InputError, KinboxError, NameNotFound
from tests.support import paths as PATHS
from tests.support.oracles.ur_ik import SingularPoseError, expand_within_limits, ur_ik

TWO_PI = 2.0 * math.pi
REFERENCE = PATHS.DATA / "reference"
FK_TOL = 1e-10  # metres / radians
SAME_TOL = 1e-7  # two configurations closer than this (per joint) are the same


# ----------------------------------------------------------------------------------------------
# independent models and checks
# ----------------------------------------------------------------------------------------------
_MODELS: dict[str, pin.Model] = {}


def erd_model(name: str) -> pin.Model:
    """The Pinocchio model as example-robot-data loads it (the genuine UR3 for ``ur3``)."""
    if name not in _MODELS:
        import example_robot_data as erd

        if name == "ur3":  # example-robot-data maps "ur3" to the UR5 loader
            from example_robot_data.robots_loader import UR3Loader

            _MODELS[name] = UR3Loader().robot.model
        else:
            _MODELS[name] = erd.load(name).model
    return _MODELS[name]


def config_from_angles(model: pin.Model, angles) -> np.ndarray:
    """Pinocchio ``q`` from one value per joint (an angle for continuous joints)."""
    q = pin.neutral(model)
    for k, j in enumerate(model.joints[1:]):
        a = float(angles[k])
        if j.nq == 2 and j.nv == 1:
            q[j.idx_q : j.idx_q + 2] = [math.cos(a), math.sin(a)]
        else:
            assert j.nq == 1
            q[j.idx_q] = a
    return q


def joint_values(model: pin.Model, q) -> np.ndarray:
    """One value per joint (``atan2`` for continuous joints)."""
    q = np.asarray(q, float)
    out = []
    for j in model.joints[1:]:
        v = q[j.idx_q : j.idx_q + j.nq]
        out.append(math.atan2(v[1], v[0]) if (j.nq == 2 and j.nv == 1) else float(v[0]))
    return np.array(out)


def periodic_mask(model: pin.Model) -> np.ndarray:
    """True for joints compared modulo 2 pi: continuous joints and revolutes with range >= 2 pi."""
    out = []
    for j in model.joints[1:]:
        if j.nq == 2 and j.nv == 1:
            out.append(True)
            continue
        lo, hi = model.lowerPositionLimit[j.idx_q], model.upperPositionLimit[j.idx_q]
        revolute = j.shortname().startswith("JointModelR")  # RX/RY/RZ, RevoluteUnaligned, ...
        out.append(bool(revolute and hi - lo >= TWO_PI - 1e-9))
    return np.array(out)


def joint_distance(model: pin.Model, q1, q2, ignore=()) -> float:
    """Largest per-joint difference, modulo 2 pi for periodic joints; joints named in ``ignore``
    (e.g. joints kinbox left out because the frame does not depend on them) are not compared."""
    d = joint_values(model, q1) - joint_values(model, q2)
    per = periodic_mask(model)
    d[per] = np.angle(np.exp(1j * d[per]))
    keep = np.array([model.names[i] not in ignore for i in range(1, model.njoints)])
    return float(np.max(np.abs(d[keep]), initial=0.0))


def frame_pose(model: pin.Model, frame: str, q) -> pin.SE3:
    data = model.createData()
    pin.forwardKinematics(model, data, np.asarray(q, float))
    return pin.SE3(pin.updateFramePlacement(model, data, model.getFrameId(frame)))


def fk_error(model: pin.Model, frame: str, q, goal: pin.SE3) -> float:
    """max(position error, orientation error) of ``frame`` at ``q`` against ``goal``."""
    M = frame_pose(model, frame, q)
    pos = float(np.linalg.norm(M.translation - goal.translation))
    rot = float(np.linalg.norm(pin.log3(goal.rotation.T @ M.rotation)))
    return max(pos, rot)


def random_angles(model: pin.Model, rng, lock: dict | None = None) -> np.ndarray:
    """One value per joint, uniform in the joint limits (continuous joints: (-pi, pi])."""
    a = []
    for j in model.joints[1:]:
        if j.nq == 2 and j.nv == 1:
            a.append(rng.uniform(-math.pi, math.pi))
        else:
            a.append(rng.uniform(model.lowerPositionLimit[j.idx_q], model.upperPositionLimit[j.idx_q]))
    a = np.array(a)
    for name, v in (lock or {}).items():
        a[model.getJointId(name) - 1] = v
    return a


def check_solutions(model: pin.Model, frame: str, goal: pin.SE3, res, lock: dict | None = None, q_gen=None) -> None:
    """Every solution verifies by independent FK, lies in the limits, honours the locks, and no
    two coincide; ``q_gen`` (if given) is among them."""
    assert res.complete, res.message
    assert res.joint_names is not None
    sols = res.solutions
    for k, s in enumerate(sols):
        q = np.asarray(s.q, float)
        assert q.shape == (model.nq,)
        assert np.all(np.isfinite(q))
        err = fk_error(model, frame, q, goal)
        assert err < FK_TOL, f"solution {k}: FK error {err:.3e} (kinbox says {s.residual:.3e})"
        for j in model.joints[1:]:
            v = q[j.idx_q : j.idx_q + j.nq]
            if j.nq == 2 and j.nv == 1:
                assert abs(np.hypot(*v) - 1.0) < 1e-12, f"solution {k}: (cos, sin) not unit: {v}"
            else:
                lo, hi = model.lowerPositionLimit[j.idx_q], model.upperPositionLimit[j.idx_q]
                assert lo - 1e-9 <= v[0] <= hi + 1e-9, f"solution {k}: joint {j.id} = {v[0]} outside [{lo}, {hi}]"
        for name, val in (lock or {}).items():
            j = model.joints[model.getJointId(name)]
            assert abs(q[j.idx_q] - val) < 1e-12, f"solution {k}: locked joint {name} moved to {q[j.idx_q]}"
    for a in range(len(sols)):
        for b in range(a):
            d = joint_distance(model, sols[a].q, sols[b].q)
            assert d > 1e-6, f"solutions {b} and {a} coincide (distance {d:.2e})"
    if q_gen is not None:
        # joints the frame does not depend on (dropped by kinbox) cannot be recovered
        dropped = res.stats.get("dropped_joints", [])
        dmin = min((joint_distance(model, s.q, q_gen, ignore=dropped) for s in sols), default=math.inf)
        assert dmin < SAME_TOL, f"the generating configuration is not among the {len(sols)} solutions (nearest {dmin:.2e})"


# ----------------------------------------------------------------------------------------------
# UR arms against the closed-form oracle
# ----------------------------------------------------------------------------------------------
def _ur_case(robot: str, seed: int):
    """(model, q, goal, oracle solutions inside the limits) for a seeded random UR configuration.

    Poses near a wrist singularity (where the oracle is ill-conditioned) are skipped by moving
    on to the next random draw, deterministically.
    """
    model = erd_model(robot)
    oracle_robot = robot.replace("_limited", "")
    rng = np.random.default_rng(seed)
    lo, hi = model.lowerPositionLimit, model.upperPositionLimit
    while True:
        q = rng.uniform(lo, hi)
        if abs(math.sin(q[4])) < 0.05:
            continue
        goal = frame_pose(model, "tool0", q)
        try:
            ref = ur_ik(oracle_robot, goal.homogeneous)
        except SingularPoseError:
            continue
        break
    # distinct modulo 2 pi (every UR joint range is >= 2 pi): one representative per class that
    # has a copy inside the limits
    inside = [r for r in ref if expand_within_limits(r, lo, hi, eps=1e-9)]
    return model, q, goal, inside


def _check_ur(robot: str, seed: int, time_limit: float):
    model, q, goal, ref = _ur_case(robot, seed)
    return _check_ur_pose(robot, model, goal, ref, time_limit, q_gen=q, label=f"seed {seed}")


def _check_ur_pose(robot: str, model, goal, ref, time_limit: float, q_gen=None, label=""):
    # the oracle is exact: its solutions do reproduce the pose (sanity of the test itself)
    for r in ref:
        assert (
            fk_error(model, "tool0", expand_within_limits(r, model.lowerPositionLimit, model.upperPositionLimit, eps=1e-9)[0], goal) < 1e-9
        )
    res = kinbox.ik(robot, "tool0", goal, time_limit=time_limit)
    check_solutions(model, "tool0", goal, res, q_gen=q_gen)
    assert len(res.solutions) == len(ref), f"{robot} {label}: kinbox found {len(res.solutions)} solutions, the closed form {len(ref)}"
    # one-to-one with the oracle (modulo 2 pi)
    for r in ref:
        matches = [s for s in res.solutions if joint_distance(model, s.q, r) < SAME_TOL]
        assert len(matches) == 1, f"oracle solution {r} matched by {len(matches)} kinbox solutions"
    assert all(s.certified for s in res.solutions)
    return res


def test_ur5_random_pose_matches_closed_form():
    _check_ur("ur5", 0, time_limit=120)


# Poses where a root was lost: redundant rows derived in floating point along other
# paths than the core (projected loops) held with exact targets, so that near the root the
# overdetermined system had no solution at all and interval propagation proved its box empty.
LOST_ROOT_POSES = [
    (
        [
            -0.5511768829667542,
            0.09850881192944548,
            -0.4484635664491392,
            -0.5189678940870791,
            -0.4775712783882616,
            0.5442769278628995,
            -0.4542693306415786,
        ],
        4,
    ),
    (
        [
            0.5276134875078586,
            -0.17524708929620575,
            -0.2199338206838862,
            0.5231269889621887,
            0.7107261593552754,
            -0.43693918384651137,
            0.17404203356372952,
        ],
        8,
    ),
    # an ordinary pose on which one HiGHS run once never returned
    (
        [
            0.08246775261833508,
            -0.5979744537509144,
            0.28892455801373795,
            -0.16326894312906107,
            -0.48308623431340497,
            0.47881376152991645,
            0.7146385969117436,
        ],
        8,
    ),
]


@pytest.mark.parametrize("pose, count", LOST_ROOT_POSES)
def test_ur5_poses_that_lost_a_root(pose, count):
    model = erd_model("ur5")
    goal = pin.XYZQUATToSE3(np.array(pose))
    lo, hi = model.lowerPositionLimit, model.upperPositionLimit
    ref = [r for r in ur_ik("ur5", goal.homogeneous) if expand_within_limits(r, lo, hi, eps=1e-9)]
    assert len(ref) == count  # the published geometry's closed form
    _check_ur_pose("ur5", model, goal, ref, time_limit=60, label="lost-root pose")


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5])
def test_ur5_more_random_poses(seed):
    _check_ur("ur5", seed, time_limit=300)


@pytest.mark.slow
@pytest.mark.parametrize("robot", ["ur3", "ur10", "ur5_limited"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_ur_family_random_poses(robot, seed):
    _check_ur(robot, seed, time_limit=300)


def test_ur5_limited_has_narrower_limits():
    # the premise of the ur5_limited case: ranges of exactly 2 pi, unlike ur5's 4 pi
    lim = kinbox.load("ur5_limited").model
    full = kinbox.load("ur5").model
    assert np.allclose(lim.upperPositionLimit - lim.lowerPositionLimit, TWO_PI)
    assert np.all(full.upperPositionLimit - full.lowerPositionLimit >= TWO_PI - 1e-9)


def test_pose_at_matches_pinocchio():
    model = erd_model("ur5")
    rng = np.random.default_rng(11)
    prob = kinbox.IK("ur5", "tool0")
    for _ in range(5):
        q = rng.uniform(model.lowerPositionLimit, model.upperPositionLimit)
        M = prob.pose_at(q)
        ref = frame_pose(model, "tool0", q)
        assert np.allclose(M.homogeneous, ref.homogeneous, atol=1e-12)


# ----------------------------------------------------------------------------------------------
# other arms: continuous joints, extra joints, locked joints
# ----------------------------------------------------------------------------------------------
def _check_arm(robot: str, frame: str, seed: int, lock: dict | None = None, time_limit: float = 300, **solver_options):
    model = erd_model(robot)
    rng = np.random.default_rng(seed)
    q = config_from_angles(model, random_angles(model, rng, lock))
    goal = frame_pose(model, frame, q)
    res = kinbox.IK(robot, frame, lock=lock).solve(goal, time_limit=time_limit, **solver_options)
    check_solutions(model, frame, goal, res, lock=lock, q_gen=q)
    return res


def test_z1_arm_gripper_joint_left_out():
    # link06 does not depend on the gripper joint: kinbox leaves it out of the system
    res = _check_arm("z1", "link06", seed=3, time_limit=120)
    assert "jointGripper" in res.stats["dropped_joints"]


def test_panda_with_a_locked_joint():
    res = _check_arm("panda", "panda_hand", seed=4, lock={"panda_joint7": 0.3}, time_limit=120)
    assert res.solutions


@pytest.mark.slow
def test_xarm7_with_a_locked_joint():
    _check_arm("xarm7", "link_eef", seed=5, lock={"joint3": 0.3}, time_limit=300)


@pytest.mark.slow
def test_kinova_continuous_joints():
    model = erd_model("kinova")
    assert model.nq == 9 and model.nv == 6  # three continuous joints: (cos, sin) pairs
    res = _check_arm("kinova", "j2s6s200_end_effector", seed=6, time_limit=600)
    assert len(res.joint_names) == 9
    assert sum(n.endswith(".cos") for n in res.joint_names) == 3


def test_z1_ambiguous_frame_name_is_handled():
    """z1 has a FIXED_JOINT frame and a BODY frame both named ``gripperStator`` (same joint, same
    placement): kinbox must either solve for it or refuse it with a kinbox error, never let
    Pinocchio's ValueError escape."""
    model = erd_model("z1")
    try:
        prob = kinbox.IK("z1", "gripperStator")
    except KinboxError:
        return
    q = config_from_angles(model, random_angles(model, np.random.default_rng(8)))
    same = [i for i, f in enumerate(model.frames) if f.name == "gripperStator"]
    assert len(same) == 2  # the premise: one FIXED_JOINT and one BODY frame of that name...
    a, b = (model.frames[i] for i in same)
    assert a.parentJoint == b.parentJoint and a.placement.isApprox(b.placement)  # ...at one place
    fid = same[0]
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    goal = pin.SE3(pin.updateFramePlacement(model, data, fid))
    res = prob.solve(goal, time_limit=120)
    assert res.complete and res.solutions


# ----------------------------------------------------------------------------------------------
# a general 6R arm (DH table of the published general 6R loop)
# ----------------------------------------------------------------------------------------------
def _general_6r_rows():
    return json.loads((REFERENCE / "general_6r.json").read_text())["dh"]


def _dh_fk(rows, theta) -> np.ndarray:
    """Independent FK of the reference convention: prod Rx(alpha_i) Tx(a_i) Rz(theta_i) Tz(d_i)."""
    T = np.eye(4)
    for r, th in zip(rows, theta):
        ca, sa = math.cos(r["alpha"]), math.sin(r["alpha"])
        Rx = np.array([[1, 0, 0, 0], [0, ca, -sa, 0], [0, sa, ca, 0], [0, 0, 0, 1.0]])
        Tx = np.eye(4)
        Tx[0, 3] = r["a"]
        c, s = math.cos(th), math.sin(th)
        Rz = np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])
        Tz = np.eye(4)
        Tz[2, 3] = r["d"]
        T = T @ Rx @ Tx @ Rz @ Tz
    return T


def _general_6r_arm():
    from kinbox.model.builders import dh_chain

    rows = _general_6r_rows()
    mech = dh_chain(rows, closed=False, name="general-6r-arm")
    return rows, mech


def test_general_6r_arm_model_follows_the_dh_convention():
    rows, mech = _general_6r_arm()
    rng = np.random.default_rng(12)
    for _ in range(5):
        th = rng.uniform(-math.pi, math.pi, 6)
        assert np.allclose(frame_pose(mech.model, "tool", th).homogeneous, _dh_fk(rows, th), atol=1e-12)


def test_general_6r_arm_random_pose():
    rows, mech = _general_6r_arm()
    rng = np.random.default_rng(13)
    th = rng.uniform(-math.pi, math.pi, 6)
    goal = pin.SE3(_dh_fk(rows, th))
    res = kinbox.ik(mech, "tool", goal, time_limit=120)
    check_solutions(mech.model, "tool", goal, res, q_gen=th)
    assert all(s.certified for s in res.solutions)
    # real solutions of a general 6R come in an even number, at most 16
    assert len(res.solutions) <= 16 and len(res.solutions) % 2 == 0


def test_general_6r_arm_identity_pose_has_the_published_16():
    """Placing the tool at the identity is the general 6R loop problem: 16 real solutions."""
    rows, mech = _general_6r_arm()
    expected = json.loads((REFERENCE / "general_6r.json").read_text())["expected"]["real_solutions"]
    goal = pin.SE3.Identity()
    res = kinbox.ik(mech, "tool", goal, time_limit=120)
    check_solutions(mech.model, "tool", goal, res)
    assert len(res.solutions) == expected
    assert all(s.certified for s in res.solutions)
    for s in res.solutions:  # and the independent DH product closes
        assert np.abs(_dh_fk(rows, s.q) - np.eye(4)).max() < 1e-10


# ----------------------------------------------------------------------------------------------
# redundant arm: a positive-dimensional answer
# ----------------------------------------------------------------------------------------------
@pytest.mark.slow
def test_panda_redundant_gives_a_curve():
    model = erd_model("panda")
    q = config_from_angles(model, [0.1, -0.5, 0.2, -2.0, 0.1, 1.6, 0.5, 0.02, 0.02])
    goal = frame_pose(model, "panda_hand", q)
    res = kinbox.ik("panda", "panda_hand", goal, sigma=0.5, time_limit=900)
    assert res.complete, res.message
    dims = [c.dimension for c in res.components]
    assert max(dims, default=0) >= 1, dims
    assert any(c.samples() for c in res.curves.values())


# ----------------------------------------------------------------------------------------------
# empty answers and bad input
# ----------------------------------------------------------------------------------------------
def test_unreachable_pose_is_a_proven_empty_answer():
    res = kinbox.ik("ur5", "tool0", [10.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0], time_limit=60)
    assert res.complete, res.message
    assert res.solutions == []
    assert all(c.dimension == 0 for c in res.components) and not res.components
    d = res.to_dict()
    assert d["complete"] is True and d["solutions"] == []


def test_pose_as_xyzquat_and_se3_agree():
    model = erd_model("ur5")
    q = np.array([0.3, -1.2, 1.5, -0.8, 1.2, 0.4])
    goal = frame_pose(model, "tool0", q)
    # an unreachable shift of a reachable pose keeps the solve cheap; both forms must parse alike
    far = pin.SE3(goal.rotation, goal.translation + np.array([5.0, 0.0, 0.0]))
    r1 = kinbox.ik("ur5", "tool0", far, time_limit=60)
    r2 = kinbox.ik("ur5", "tool0", list(pin.SE3ToXYZQUAT(far)), time_limit=60)
    assert r1.complete and r2.complete and not r1.solutions and not r2.solutions
    assert np.allclose(r1.source["pose"], r2.source["pose"], atol=1e-12)


def test_unknown_robot():
    with pytest.raises(NameNotFound):
        kinbox.ik("no_such_robot_xyz", "tool0", [0.3, 0.2, 0.4, 0, 0, 0, 1])


def test_unknown_frame():
    with pytest.raises(NameNotFound):
        kinbox.IK("ur5", "no_such_frame")


def test_unknown_base_frame():
    with pytest.raises(NameNotFound):
        kinbox.IK("ur5", "tool0", base="no_such_frame")


def test_unknown_lock_joint():
    with pytest.raises(NameNotFound):
        kinbox.IK("panda", "panda_hand", lock={"panda_joint99": 0.3})


def test_non_finite_lock_value():
    with pytest.raises(InputError):
        kinbox.IK("panda", "panda_hand", lock={"panda_joint7": float("nan")})


@pytest.mark.parametrize("quat", [[0, 0, 0, 2.0], [0, 0, 0, 0.0], [0.5, 0.5, 0.5, 0.6]])
def test_non_unit_quaternion(quat):
    prob = kinbox.IK("ur5", "tool0")
    with pytest.raises(InputError):
        prob.solve([0.3, 0.2, 0.4, *quat], time_limit=30)


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -float("inf")])
def test_non_finite_pose(bad):
    prob = kinbox.IK("ur5", "tool0")
    with pytest.raises(InputError):
        prob.solve([0.3, bad, 0.4, 0, 0, 0, 1], time_limit=30)
    with pytest.raises(InputError):
        prob.solve([0.3, 0.2, 0.4, 0, 0, bad, 1], time_limit=30)
    M = pin.SE3.Identity()
    M.translation = np.array([0.3, bad, 0.4])
    with pytest.raises(InputError):
        prob.solve(M, time_limit=30)


def test_wrong_pose_length():
    prob = kinbox.IK("ur5", "tool0")
    with pytest.raises(InputError):
        prob.solve([0.3, 0.2, 0.4, 0, 0, 1], time_limit=30)


@pytest.mark.parametrize("n", [0, 5, 7])
def test_wrong_number_of_joint_values(n):
    prob = kinbox.IK("ur5", "tool0")
    with pytest.raises(InputError):
        prob.pose_at([0.1] * n)


def test_non_finite_joint_values():
    prob = kinbox.IK("ur5", "tool0")
    with pytest.raises(InputError):
        prob.pose_at([0.1, 0.2, float("nan"), 0.0, 0.0, 0.0])


@pytest.mark.parametrize("q3", [1e-6, 0.0])
@pytest.mark.slow
def test_ur5_elbow_singular_no_approximate_duplicates(q3):
    """Near (1e-6) and at the elbow singularity the two elbow branches are 2e-6 apart / one
    double root. Points up to ~1e-4 from them also close the loop to 1e-8: they must not be
    reported as extra solutions (helper stress test finding)."""
    model = erd_model("ur5")
    prob = kinbox.IK("ur5", "tool0")
    q_gen = np.array([0.3, -1.2, q3, -0.8, 1.2, 0.4])
    goal = prob.pose_at(q_gen)
    res = prob.solve(goal, time_limit=120)
    check_solutions(model, "tool0", goal, res, q_gen=q_gen if q3 else None)
    if q3:
        assert len(res.solutions) == 2 and all(s.certified for s in res.solutions)
    else:  # one double root: found once, uncertified (a regular-root test cannot prove it)
        assert len(res.solutions) == 1 and not res.solutions[0].certified
        assert joint_distance(model, res.solutions[0].q, q_gen) < 1e-6


def test_ur5_a_micro_radian_from_the_elbow_singularity_ends_with_both_roots_certified():
    """Two roots 2e-6 apart (|J^-1| ~6e6): the boxes between them lie within the core rows'
    resolution, where no contractor can decide anything; they were split to 1e-10 by the
    thousand and the search did not end. Now they are reported (one uncertified cluster) and
    the search ends, both roots certified, each reported once (docs/soundness.md, "Acceptance
    and the answer")."""
    from tests.support.stress import angle_distance, ur5_pose, ur5_singular, ur5_truths

    goal = ur5_pose(ur5_singular("elbow", 1e-6))
    truths = ur5_truths(goal)
    res = kinbox.ik("ur5", "tool0", goal, max_boxes=5000)
    assert res.complete, res.message
    cert = [s.q for s in res.solutions if s.certified]
    assert len(cert) == len(truths) == 2
    assert all(min(angle_distance(c, t) for c in cert) < 1e-8 for t in truths)
    assert len(res.solutions) == 2  # the boxes between them joined the roots they cannot be told from


def test_compiling_the_kernels_does_not_count_against_the_time_limit(monkeypatch):
    """The first solve after an install compiles the kernels (tens of seconds on a busy machine):
    a time limit covers loading and solving, not that."""
    import time

    from kinbox.problems import run
    from kinbox.search import propagate, solver

    real, calls = propagate.load_kernel, []

    def slow_first_load():
        if not calls:
            time.sleep(1.5)  # stands for compiling
        calls.append(1)
        real()

    monkeypatch.setattr(solver, "_KERNELS_LOADED", False, raising=False)
    monkeypatch.setattr(run, "_kernels_ready", False)  # as in a fresh process
    monkeypatch.setattr(run, "kernels_cached", lambda: False)  # after an install: nothing cached yet
    monkeypatch.setattr(propagate, "load_kernel", slow_first_load)
    res = kinbox.ik("ur5", "tool0", kinbox.IK("ur5", "tool0").pose_at([0.3, -1.2, 1.5, -0.8, 1.2, 0.4]), time_limit=1.0)
    assert calls and res.complete, res.message
