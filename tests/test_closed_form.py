"""Closed-form IK: families read off the geometry, answers the same as the branch and prune's."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np
import pytest

from kinbox.model.loading import load
from kinbox.pipeline import IK
from kinbox.search.closed_form import POSE_CLOSED_FORM, TemplateCertifier, run_batch

DATA = Path(__file__).parent / "data" / "arms"

#: (robot, frame, locked joints, family): one arm per family
ARMS = [
    ("ur5", "tool0", {}, "parallel"),
    (str(DATA / "irb120_dh.json"), "tool", {}, "wrist-meet"),
    (str(DATA / "kr6_dh.json"), "tool", {}, "wrist-parallel"),
    ("panda", "panda_hand", {"panda_joint7": 0.5}, "wrist-meet"),
]


def _angles(ik: IK, q: np.ndarray) -> np.ndarray:
    """The chain's joint angles of a Pinocchio ``q`` (continuous joints from (cos, sin))."""
    model = ik.robot.model
    out = []
    for j in ik.chain:
        jm = model.joints[j]
        if model.names[j] in ik.robot.locked:
            continue
        out.append(np.arctan2(q[jm.idx_q + 1], q[jm.idx_q]) if jm.nq == 2 else q[jm.idx_q])
    return np.array(out)


def _same_sets(ik: IK, a, b, tol: float = 1e-6) -> bool:
    """Do two answers hold the same configurations (angles compared modulo 2 pi)?"""
    qa = [_angles(ik, s.q) for s in a.solutions]
    qb = [_angles(ik, s.q) for s in b.solutions]
    if len(qa) != len(qb):
        return False
    left = list(range(len(qb)))
    for x in qa:
        hit = [k for k in left if np.max(np.abs(np.angle(np.exp(1j * (x - qb[k]))))) < tol]
        if len(hit) != 1:
            return False
        left.remove(hit[0])
    return True


def _poses(ik: IK, n: int, seed: int):
    rng = np.random.default_rng(seed)
    model = ik.robot.model
    lo, hi = [], []
    for j in ik.chain:
        i = model.joints[j].idx_q
        locked = ik.robot.locked.get(model.names[j])
        if locked is not None:  # the locked value
            lo.append(float(np.ravel(locked)[0]))
            hi.append(float(np.ravel(locked)[0]))
            continue
        lo.append(max(model.lowerPositionLimit[i], -np.pi))
        hi.append(min(model.upperPositionLimit[i], np.pi))
    return [ik.pose_at(rng.uniform(lo, hi)) for _ in range(n)]


def _ik(robot, frame, lock) -> IK:
    return IK(robot, frame, lock=lock)


@pytest.mark.parametrize("robot,frame,lock,family", ARMS)
def test_family_detected(robot, frame, lock, family):
    ik = _ik(robot, frame, lock)
    assert ik.closed_form is not None and ik.closed_form.family.name == family


def test_detection_from_geometry_not_names():
    """A DH arm renamed is the same family; the same arm with one twist off by 1e-9 rad (a
    wrist that nearly meets) is none: its poses go to the branch and prune."""
    rows = json.loads((DATA / "irb120_dh.json").read_text())["dh"]
    renamed = [dict(r, name=f"q{k}") for k, r in enumerate(rows)]
    ik = IK(load({"kind": "dh-arm", "dh": renamed}), "tool")
    assert ik.closed_form is not None and ik.closed_form.family.name == "wrist-meet"
    bent = copy.deepcopy(rows)
    bent[4]["alpha"] += 1e-9
    bent[5]["a"] = 1e-9  # line 6 misses the wrist centre by a nanometre
    ik2 = IK(load({"kind": "dh-arm", "dh": bent}), "tool")
    assert ik2.closed_form is None or ik2.closed_form.family.name != "wrist-meet"


@pytest.mark.parametrize("robot,frame,lock,family", ARMS)
def test_same_answers_as_branch_and_prune(robot, frame, lock, family):
    ik = _ik(robot, frame, lock)
    closed = 0
    for pose in _poses(ik, 4, seed=7):
        fast = ik.solve(pose)
        slow = ik.solve(pose, closed_form=False)
        assert slow.stats["method"] == "branch-and-prune"
        assert fast.complete and slow.complete
        assert _same_sets(ik, fast, slow), (fast, slow)
        assert all(s.certified for s in fast.solutions) or fast.stats["method"] == "branch-and-prune"
        closed += fast.stats["method"] == "closed-form"
    assert closed >= 3  # random poses are regular


@pytest.mark.parametrize(
    "q",
    [
        [0.3, -1.2, 1.5, -0.8, 1e-9, 0.4],  # wrist 1e-9 from singular
        [0.3, -1.2, 1e-7, -0.8, 1.2, 0.4],  # elbow 1e-7 from straight
        [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],  # both, and the shoulder
    ],
)
def test_near_singular_falls_back_and_loses_nothing(q):
    ik = IK("ur5", "tool0")
    pose = ik.pose_at(q)
    fast = ik.solve(pose)
    slow = ik.solve(pose, closed_form=False)
    assert fast.stats["method"] == "branch-and-prune"
    assert len(fast.solutions) == len(slow.solutions)
    assert len(fast.curves) == len(slow.curves)
    near = any(np.max(np.abs(np.angle(np.exp(1j * (_angles(ik, s.q) - np.array(q)))))) < 1e-5 for s in fast.solutions)
    assert near or fast.curves  # the pose's own q: a root, or on a curve (the all-zero pose)


@pytest.mark.parametrize("robot,frame,lock,family", ARMS[:2])
def test_batch_matches_single_poses(robot, frame, lock, family):
    ik = _ik(robot, frame, lock)
    cf = ik.closed_form
    poses = _poses(ik, 6, seed=3)
    R = np.array([p.rotation for p in poses])
    t = np.array([p.translation for p in poses])
    b = run_batch(cf, TemplateCertifier(ik.arm, cf.joints, cf.gamma), R, t)
    for k, pose in enumerate(poses):
        if b.status[k] != POSE_CLOSED_FORM:
            continue
        res = ik.solve(pose)
        assert res.stats["method"] == "closed-form"
        assert b.count[k] == len(res.solutions)
        rows = b.theta[b.first[k] : b.first[k] + b.count[k]] - cf.gamma
        for s in res.solutions:
            x = _angles(ik, s.q)
            order = [next(i for i, j in enumerate(ik.chain) if j == jj.jid) for jj in cf.joints]
            assert any(np.max(np.abs(np.angle(np.exp(1j * (r - x[order]))))) < 1e-6 for r in rows)
    assert np.all(b.residual < 1e-9)


def test_solve_array_and_solve_many_use_the_batch():
    ik = IK("ur5", "tool0")
    poses = _poses(ik, 5, seed=11) + [ik.pose_at([0.3, -1.2, 1.5, -0.8, 1e-9, 0.4])]
    import pinocchio as pin

    arr = np.array([pin.SE3ToXYZQUAT(p) for p in poses])
    ans = ik.solve_array(arr)
    many = ik.solve_many(poses)
    assert ans.method[-1] == "branch-and-prune" and many[-1].stats["method"] == "branch-and-prune"
    for k, res in enumerate(many):
        assert ans.count[k] == len(res.solutions)
        assert ans.method[k] == res.stats["method"]
        for s in res.solutions:
            x = _angles(ik, s.q)
            assert any(np.max(np.abs(np.angle(np.exp(1j * (r - x))))) < 1e-6 for r in ans.solutions(k))
    assert all(ans.complete)


@pytest.mark.parametrize("robot,frame,lock,family", ARMS)
def test_structure_read_from_the_other_end(robot, frame, lock, family):
    """The exact tests of a family, mirrored, hold on the reversed chain's numbers: the check
    that lets a family found on the reversed chain be used for the arm's own system."""
    from kinbox.formulation.arm import canonical
    from kinbox.formulation.families import _mirrored, family_of

    g = _ik(robot, frame, lock).arm.geometry
    assert family_of(g) == family
    assert _mirrored(canonical(g.chain.reverse()), family)
