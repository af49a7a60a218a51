"""The arms of the closed-form tests and their helpers: poses, IK problems, answers compared as sets."""

from __future__ import annotations

import numpy as np

from kinbox.pipeline import IK
from tests.support import paths as PATHS

DATA = PATHS.DATA / "arms"


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
