"""UR5 singular configurations and the closed-form oracle's answers for them, with angle distances."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
from scipy.optimize import brentq

from tests.support.oracles.ur_ik import UR_DH, WORLD_T_DHBASE, load_model, ur_ik
from tests.support.oracles.ur_ik import fk as ur_fk


# ----------------------------------------------------------------------------------------------
# helpers: distances, reports, solution boxes
# ----------------------------------------------------------------------------------------------
def angle_distance(a, b) -> float:
    """Largest per-joint difference modulo 2 pi (revolute joints of range >= 2 pi)."""
    d = np.asarray(a, float) - np.asarray(b, float)
    return float(np.max(np.abs(np.angle(np.exp(1j * d)))))


# ----------------------------------------------------------------------------------------------
# UR5: singular configurations and the closed-form oracle
# ----------------------------------------------------------------------------------------------
UR5_BASE = np.array([0.3, -1.2, 1.5, -0.8, 1.2, 0.4])  # the `make demo` configuration


_UR5: list = []


def ur5_model() -> pin.Model:
    """The example-robot-data UR5 model, loaded without kinbox."""
    if not _UR5:
        _UR5.append(load_model("ur5"))
    return _UR5[0]


def ur5_pose(q) -> pin.SE3:
    model = ur5_model()
    data = model.createData()
    pin.framesForwardKinematics(model, data, np.asarray(q, float))
    return pin.SE3(data.oMf[model.getFrameId("tool0")])


def _shoulder_offset(q) -> float:
    """Signed distance of the wrist centre from the vertical plane through the base axis
    that holds the shoulder axis; the shoulder singularity is where it vanishes."""
    T = np.linalg.inv(WORLD_T_DHBASE) @ ur_fk("ur5", q)
    wrist = T[:3, 3] - UR_DH["ur5"][5] * T[:3, 2]
    return float(wrist @ np.array([math.cos(q[0]), math.sin(q[0]), 0.0]))


def ur5_singular(kind: str, offset: float = 0.0) -> np.ndarray:
    """UR5_BASE made singular (``offset = 0``) or ``offset`` rad away from it."""
    q = UR5_BASE.copy()
    if kind == "wrist":
        q[4] = offset
    elif kind == "elbow":
        q[2] = offset
    elif kind == "shoulder":
        f = lambda a: _shoulder_offset(np.r_[q[0], a, q[2:]])  # noqa: E731
        grid = np.linspace(-math.pi, math.pi, 73)
        a, b = next((a, b) for a, b in zip(grid, grid[1:]) if f(a) * f(b) < 0)
        q[1] = brentq(f, a, b, xtol=1e-15, rtol=1e-15) + offset
    else:
        raise ValueError(kind)
    return q


def ur5_polish(q, goal: pin.SE3, iters: int = 60) -> np.ndarray:
    """Newton on the example-robot-data model (least squares: also at singular points)."""
    model = ur5_model()
    data = model.createData()
    fid = model.getFrameId("tool0")
    q = np.array(q, float)
    for _ in range(iters):
        pin.computeJointJacobians(model, data, q)
        pin.framesForwardKinematics(model, data, q)
        E = goal.inverse() * data.oMf[fid]
        J = pin.Jlog6(E) @ pin.getFrameJacobian(model, data, fid, pin.ReferenceFrame.LOCAL)
        dq = -np.linalg.lstsq(J, pin.log6(E).vector, rcond=1e-14)[0]
        q += dq
        if np.max(np.abs(dq)) < 1e-16:
            break
    return np.angle(np.exp(1j * q))


def ur5_truths(goal: pin.SE3, singular: str = "raise") -> list[np.ndarray]:
    """The closed-form solutions of ``goal``, polished on the URDF model (one per class modulo
    2 pi; every UR5 joint range is at least 2 pi, so every class is inside the limits)."""
    out = []
    for r in ur_ik("ur5", goal.homogeneous, singular=singular):
        p = ur5_polish(r, goal)
        assert angle_distance(p, r) < 1e-4, "polishing moved an oracle solution far"
        out.append(p)
    for i in range(len(out)):
        for j in range(i):
            assert angle_distance(out[i], out[j]) > 1e-7, "two oracle solutions polished into one"
    return out
