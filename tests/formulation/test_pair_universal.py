"""The universal pair (Pinocchio's ``JointModelUniversal``, :mod:`kinbox.formulation.pairs.universal`).

Robots are built in Pinocchio with universal joints; everything is checked against Pinocchio's
forward kinematics: the round trip q -> system point -> q at random configurations (every row
holds at the encoded point), and IK end to end (every solution's pose by Pinocchio is the goal,
and the configuration the goal was made from is among the solutions).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import kinbox
from kinbox.formulation.build import formulate
from kinbox.formulation.pairs import FAMILIES, joint_parts
from kinbox.formulation.pairs.family import supported
from kinbox.model.describe import joint_kind
from kinbox.model.mechanism import Mechanism


def orthonormal_pair(rng) -> tuple[np.ndarray, np.ndarray]:
    a = rng.normal(size=3)
    a /= np.linalg.norm(a)
    b = np.cross(a, rng.normal(size=3))
    return a, b / np.linalg.norm(b)


def add(model, parent, jm, xyz, name, lim=3.0):
    nq = jm.nq
    lo, hi = np.full(nq, -lim), np.full(nq, lim)
    return model.addJoint(parent, jm, pin.SE3(np.eye(3), np.array(xyz, float)), name, np.ones(jm.nv), np.ones(jm.nv), lo, hi)


def universal_arm(seed: int, aligned: bool = False) -> Mechanism:
    """Six degrees of freedom: RZ, a universal joint, RY, a universal joint, and a tool frame."""
    rng = np.random.default_rng(seed)
    model = pin.Model()
    axes = [(np.array([1.0, 0, 0]), np.array([0, 1.0, 0]))] * 2 if aligned else [orthonormal_pair(rng) for _ in range(2)]
    p = add(model, 0, pin.JointModelRZ(), (0, 0, 0.3), "base")
    p = add(model, p, pin.JointModelUniversal(*axes[0]), (0.05, 0.1, 0.4), "shoulder")
    p = add(model, p, pin.JointModelRY(), (0.1, -0.05, 0.5), "elbow")
    p = add(model, p, pin.JointModelUniversal(*axes[1]), (0.0, 0.08, 0.45), "wrist")
    model.addFrame(pin.Frame("tool", p, 0, pin.SE3(np.eye(3), np.array([0.03, 0.02, 0.15])), pin.FrameType.OP_FRAME))
    return Mechanism(model, name=f"universal-{seed}")


def test_a_universal_joint_is_two_revolute_parts_in_sequence():
    a1, a2 = np.array([1.0, 0, 0]), np.array([0, 0, 1.0])
    model = pin.Model()
    jid = add(model, 0, pin.JointModelUniversal(a1, a2), (0.1, 0.2, 0.3), "u")
    parts = joint_parts(model.joints[jid], "u", model.jointPlacements[jid])
    assert [(p.kind, p.idx_q, p.nq) for p in parts] == [("revolute", 0, 1), ("revolute", 1, 1)]
    q = np.array([0.4, -1.1])
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    M = parts[0].placement * parts[0].motion(q) * parts[1].placement * parts[1].motion(q)
    assert np.allclose(M.homogeneous, data.oMi[jid].homogeneous, atol=1e-14)  # Pinocchio's motion
    assert "universal" in FAMILIES and "universal" in supported()
    assert joint_kind(model.joints[jid]) == "universal"


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_round_trip_through_pinocchio(seed):
    rng = np.random.default_rng(100 + seed)
    for _ in range(5):
        mech = universal_arm(seed)
        q = rng.uniform(-3.0, 3.0, mech.model.nq)
        data = mech.model.createData()
        pin.framesForwardKinematics(mech.model, data, q)
        mech.add_goal("tool", data.oMf[mech.model.getFrameId("tool")])
        form = formulate(mech)
        x = form.encode(q)
        res = np.abs(form.system.residuals(x))
        assert res.max() < 1e-12
        if form.system.count("ineq"):
            assert form.system.compile().eval_ineqs(x).max() <= 1e-12
        assert np.abs(form.decode(x) - q).max() < 1e-10


@pytest.mark.parametrize(("seed", "aligned", "lock"), [(0, False, "elbow"), (3, False, "elbow"), (0, True, None)])
def test_ik_of_an_arm_with_universal_joints(seed, aligned, lock):
    """Every solution reaches the goal by Pinocchio's forward kinematics, and the configuration
    the goal was made from (a planted root) is among them. Random axes with the elbow locked
    (five joints: a fraction of a second), and the six joints with the universal joints' axes
    along x and y (seven solutions on the first seed; a general geometry with six joints takes
    minutes: the general formulation of a general 6R-like chain)."""
    mech = universal_arm(seed, aligned=aligned)
    rng = np.random.default_rng(200 + seed)
    q0 = rng.uniform(-2.5, 2.5, mech.model.nq)
    if lock:
        mech.lock(lock, q0[mech.model.joints[mech.model.getJointId(lock)].idx_q])
    ik = kinbox.IK(mech, "tool")
    goal = ik.pose_at(q0)
    res = ik.solve(goal)
    assert res.complete and res.solutions
    model, data = mech.model, mech.model.createData()
    fid = model.getFrameId("tool")
    target = pin.SE3(goal.homogeneous)
    for s in res.solutions:
        assert np.all(s.q >= model.lowerPositionLimit - 1e-9) and np.all(s.q <= model.upperPositionLimit + 1e-9)
        pin.framesForwardKinematics(model, data, s.q)
        err = pin.log6(target.actInv(data.oMf[fid])).vector
        assert np.abs(err).max() < 1e-8, (s.q, err)
    assert any(np.abs(s.q - q0).max() < 1e-7 for s in res.solutions), (q0, [s.q for s in res.solutions])
    if lock is None:  # a square system: every root certified (five joints: six rows, none proven)
        assert all(s.certified for s in res.solutions)
        assert len(res.solutions) > 1  # more than the planted root: a real search


def test_the_replay_shapes_show_two_hinges_per_universal_joint():
    from kinbox.viz.shapes import simple_model

    mech = universal_arm(0, aligned=True)
    geom, _ = simple_model(mech, [])
    hinges = [g for g in geom.geometryObjects if g.name.startswith("hinge")]
    assert len(hinges) == 2 + 2 + 2  # one per revolute joint, two per universal joint
