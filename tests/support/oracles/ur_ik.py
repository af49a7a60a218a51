"""Closed-form inverse kinematics of the Universal Robots UR3 / UR5 / UR10 (independent oracle).

Written from the *published* UR Denavit-Hartenberg parameters (standard DH, as in Universal
Robots' "DH parameters for calculations of kinematics and dynamics" and K. Hawkins, "Analytic
inverse kinematics for the Universal Robots UR-5/UR-10 arms", 2013).  No Pinocchio, no
numerical solver: a shoulder (2) x wrist (2) x elbow (2) branch enumeration giving at most 8
solutions.  Pinocchio is only used by :func:`load_model` (to *load* the URDF for tests).

Standard DH, ``T_{i-1,i} = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``::

            d1       a2        a3        d4         d5       d6
    UR3   0.1519  -0.24365  -0.21325   0.11235   0.08535   0.0819
    UR5   0.089159 -0.425   -0.39225   0.10915   0.09465   0.0823
    UR10  0.1273  -0.612    -0.5723    0.163941  0.1157    0.0922
    alpha = (pi/2, 0, 0, pi/2, -pi/2, 0)

Mapping to the example-robot-data Pinocchio models (``ur_description/urdf/ur{3,5,10}_robot.urdf``)
-- derived by comparing :func:`dh_fk` with ``pin.forwardKinematics`` /
``pin.updateFramePlacements`` / ``data.oMf`` on random ``q`` (see
``tests/support/test_oracles.py::test_ur_conventions``; agreement ~1e-11, the URDF writes pi/2 as
``1.57079632679`` and pi as ``3.14159265359``):

* **world** = Pinocchio ``universe`` = URDF ``base_link``.  The DH base frame is the URDF frame
  ``base`` (the UR controller's base frame): ``world_T_dhbase = Rz(pi)`` (:data:`WORLD_T_DHBASE`),
  i.e. x and y flipped.
* **joints**: ``q_pinocchio = theta_DH + JOINT_OFFSETS`` with ``JOINT_OFFSETS = 0`` and the same
  sign for all six joints (:data:`JOINT_OFFSETS`, :data:`JOINT_SIGNS`).
* **tool**: the DH flange frame 6 *is* ``tool0`` (identity).  Other frames are supported through
  constant transforms :func:`tool0_T_frame`: ``ee_link`` = ``tool0 * [Rx(pi/2) Rz(pi/2)]``
  (ee_link's x axis is tool0's z / approach axis) and ``wrist_3_link`` =
  ``tool0 * (Rx(pi/2), (0, 0, -d6))``.

The default frame of :func:`ur_ik` is ``'tool0'``.  Poses are 4x4 homogeneous matrices expressed
in the Pinocchio world frame (``data.oMf[frame].homogeneous``).

Caveat: ``example_robot_data.load('ur3')`` returns the **UR5** (its ``ROBOTS`` table maps
``"ur3"`` to ``UR5Loader``, checked with example-robot-data installed in a fresh virtual environment).  The
genuine UR3 is ``example_robot_data.robots_loader.UR3Loader().robot.model``, which
:func:`load_model` uses.

Solutions: the oracle returns the solutions *distinct modulo 2 pi*, each joint wrapped to
``(-pi, pi]``.  The Pinocchio models have limits ``+-2 pi`` on joints 1, 2, 4, 5, 6 and ``+-pi``
on the elbow, so each solution has 2**5 = 32 copies inside the limits generically;
:func:`expand_within_limits` enumerates them.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

__all__ = [
    "UR_DH",
    "ALPHA",
    "WORLD_T_DHBASE",
    "JOINT_OFFSETS",
    "JOINT_SIGNS",
    "SingularPoseError",
    "dh_fk",
    "fk",
    "tool0_T_frame",
    "ur_ik_dh",
    "ur_ik",
    "wrap_angle",
    "same_mod_2pi",
    "dedup_mod_2pi",
    "expand_within_limits",
    "load_model",
]

#: (d1, a2, a3, d4, d5, d6) in metres, published UR DH parameters.
UR_DH: dict[str, tuple[float, float, float, float, float, float]] = {
    "ur3": (0.1519, -0.24365, -0.21325, 0.11235, 0.08535, 0.0819),
    "ur5": (0.089159, -0.425, -0.39225, 0.10915, 0.09465, 0.0823),
    "ur10": (0.1273, -0.612, -0.5723, 0.163941, 0.1157, 0.0922),
}
ALPHA = (math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0)

#: Pinocchio world (URDF base_link) -> DH base frame (URDF 'base'): rotation of pi about z.
WORLD_T_DHBASE = np.array([[-1.0, 0.0, 0.0, 0.0], [0.0, -1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
#: q_pinocchio = JOINT_SIGNS * theta_DH + JOINT_OFFSETS
JOINT_OFFSETS = np.zeros(6)
JOINT_SIGNS = np.ones(6)


class SingularPoseError(ValueError):
    """The pose is at a wrist singularity (sin(theta5) = 0): infinitely many solutions."""


def _dh(theta: float, d: float, a: float, alpha: float) -> np.ndarray:
    c, s = math.cos(theta), math.sin(theta)
    ca, sa = math.cos(alpha), math.sin(alpha)
    return np.array([[c, -s * ca, s * sa, a * c], [s, c * ca, -c * sa, a * s], [0.0, sa, ca, d], [0.0, 0.0, 0.0, 1.0]])


def _inv(T: np.ndarray) -> np.ndarray:
    R, p = T[:3, :3], T[:3, 3]
    out = np.eye(4)
    out[:3, :3] = R.T
    out[:3, 3] = -R.T @ p
    return out


def _params(robot: str):
    try:
        d1, a2, a3, d4, d5, d6 = UR_DH[robot.lower()]
    except KeyError:
        raise ValueError(f"unknown UR robot {robot!r}; expected one of {sorted(UR_DH)}") from None
    return (d1, 0.0, 0.0, d4, d5, d6), (0.0, a2, a3, 0.0, 0.0, 0.0)


def dh_fk(robot: str, theta) -> np.ndarray:
    """DH forward kinematics: DH base -> DH flange (= tool0), 4x4."""
    d, a = _params(robot)
    T = np.eye(4)
    for i in range(6):
        T = T @ _dh(float(theta[i]), d[i], a[i], ALPHA[i])
    return T


def tool0_T_frame(robot: str, frame: str) -> np.ndarray:
    """Constant transform tool0 -> ``frame`` (a frame rigidly attached to wrist_3_link)."""
    d6 = UR_DH[robot.lower()][5]
    if frame == "tool0":
        return np.eye(4)
    if frame == "ee_link":
        # wrist_3_link -> tool0 = (Rx(-pi/2), (0, d6, 0)); wrist_3_link -> ee_link = (Rz(pi/2), (0, d6, 0))
        # tool0 -> ee_link = Rx(pi/2) Rz(pi/2)
        return np.array([[0.0, -1.0, 0.0, 0.0], [0.0, 0.0, -1.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0, 0, 0, 1.0]])
    if frame == "wrist_3_link":
        # inverse of (Rx(-pi/2), (0, d6, 0))
        return np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0, 0.0], [0.0, 1.0, 0.0, -d6], [0, 0, 0, 1.0]])
    raise ValueError(f"unsupported frame {frame!r}; use 'tool0', 'ee_link' or 'wrist_3_link'")


def fk(robot: str, q, frame: str = "tool0") -> np.ndarray:
    """Independent FK of the Pinocchio model: world -> ``frame`` for Pinocchio joint values ``q``."""
    theta = (np.asarray(q, dtype=float) - JOINT_OFFSETS) * JOINT_SIGNS
    return WORLD_T_DHBASE @ dh_fk(robot, theta) @ tool0_T_frame(robot, frame)


def wrap_angle(x):
    """Wrap to (-pi, pi] (elementwise)."""
    return np.pi - np.mod(np.pi - np.asarray(x, dtype=float), 2 * np.pi)


def same_mod_2pi(q1, q2, tol: float = 1e-8) -> bool:
    """True iff every joint of q1 and q2 agrees modulo 2 pi to ``tol``."""
    d = np.asarray(q1, float) - np.asarray(q2, float)
    return bool(np.all(np.abs(np.angle(np.exp(1j * d))) <= tol))


def dedup_mod_2pi(sols, tol: float = 1e-8) -> list[np.ndarray]:
    out: list[np.ndarray] = []
    for s in sols:
        if not any(same_mod_2pi(s, t, tol) for t in out):
            out.append(np.asarray(s, dtype=float))
    return out


def _branches(arg: float, tol: float):
    """acos branches (+, -) of arg, clipping |arg| <= 1 + tol; [] if unreachable."""
    if abs(arg) > 1.0 + tol:
        return []
    v = math.acos(max(-1.0, min(1.0, arg)))
    return [v, -v]


def ur_ik_dh(robot: str, T06: np.ndarray, tol: float = 1e-10, singular: str = "raise") -> list[np.ndarray]:
    """All DH joint vectors ``theta`` with ``dh_fk(robot, theta) == T06`` (raw, not deduplicated).

    ``tol`` is the slack allowed on |cos| / |sin| arguments at workspace boundaries.
    ``singular``: what to do if sin(theta5) ~ 0 for some branch: ``'raise'`` (SingularPoseError),
    ``'representative'`` (return theta6 = 0 for that branch) or ``'skip'``.
    """
    (d1, _, _, d4, d5, d6), (_, a2, a3, _, _, _) = _params(robot)
    T06 = np.asarray(T06, dtype=float)
    R, p = T06[:3, :3], T06[:3, 3]
    z6 = R[:, 2]
    p05 = p - d6 * z6
    sols = []
    # --- shoulder: p05 . z1 = d4, z1 = (sin t1, -cos t1, 0) -> r sin(t1 - psi) = d4
    r = math.hypot(p05[0], p05[1])
    if r < 1e-14:
        raise SingularPoseError("shoulder singularity: wrist centre on the base axis")
    if abs(d4 / r) > 1.0 + tol:
        return []
    psi = math.atan2(p05[1], p05[0])
    beta = math.asin(max(-1.0, min(1.0, d4 / r)))
    for t1 in (psi + beta, psi + math.pi - beta):
        s1, c1 = math.sin(t1), math.cos(t1)
        z1 = np.array([s1, -c1, 0.0])
        # --- wrist: p06 . z1 = d4 + d6 cos t5
        for t5 in _branches((p @ z1 - d4) / d6, tol):
            s5 = math.sin(t5)
            # z1 in frame 6 coordinates = (c6 s5, -s6 s5, c5)
            u = R.T @ z1
            if abs(s5) < 1e-12:
                if singular == "raise":
                    raise SingularPoseError("wrist singularity: sin(theta5) = 0, theta6 is free")
                if singular == "skip":
                    continue
                t6 = 0.0
            else:
                t6 = math.atan2(-u[1] / s5, u[0] / s5)
            A1 = _dh(t1, d1, 0.0, ALPHA[0])
            A5 = _dh(t5, d5, 0.0, ALPHA[4])
            A6 = _dh(t6, d6, 0.0, ALPHA[5])
            T14 = _inv(A1) @ T06 @ _inv(A6) @ _inv(A5)  # = A2 A3 A4
            px, py = T14[0, 3], T14[1, 3]
            # --- elbow: (px, py) = a2 (c2, s2) + a3 (c23, s23)
            c3 = (px * px + py * py - a2 * a2 - a3 * a3) / (2.0 * a2 * a3)
            for t3 in _branches(c3, tol):
                t2 = math.atan2(py, px) - math.atan2(a3 * math.sin(t3), a2 + a3 * math.cos(t3))
                t234 = math.atan2(T14[1, 0], T14[0, 0])
                t4 = t234 - t2 - t3
                sols.append(np.array([t1, t2, t3, t4, t5, t6]))
    return sols


def ur_ik(
    robot: str,
    T: np.ndarray,
    frame: str = "tool0",
    tol: float = 1e-10,
    dedup_tol: float = 1e-9,
    singular: str = "raise",
) -> list[np.ndarray]:
    """All Pinocchio joint vectors (distinct modulo 2 pi, wrapped to (-pi, pi]) placing ``frame``
    at ``T`` (4x4, Pinocchio world frame; a ``pin.SE3`` is accepted too).  At most 8.  See the
    module docstring for conventions.  Raises SingularPoseError at a wrist singularity
    (sin(theta5) = 0, e.g. the home pose q = 0) unless ``singular`` says otherwise."""
    T = np.asarray(getattr(T, "homogeneous", T), dtype=float)
    T06 = _inv(WORLD_T_DHBASE) @ T @ _inv(tool0_T_frame(robot, frame))
    raw = ur_ik_dh(robot, T06, tol=tol, singular=singular)
    qs = [wrap_angle(JOINT_SIGNS * th + JOINT_OFFSETS) for th in raw]
    return dedup_mod_2pi(qs, dedup_tol)


def expand_within_limits(q, lower, upper, eps: float = 1e-12) -> list[np.ndarray]:
    """Every ``q + 2 pi k`` (k integer per joint) inside ``[lower - eps, upper + eps]``."""
    q = np.asarray(q, dtype=float)
    choices = []
    for qi, lo, hi in zip(q, lower, upper):
        kmin = math.ceil((lo - eps - qi) / (2 * math.pi))
        kmax = math.floor((hi + eps - qi) / (2 * math.pi))
        choices.append([qi + 2 * math.pi * k for k in range(kmin, kmax + 1)])
    return [np.array(c) for c in itertools.product(*choices)]


def load_model(robot: str):
    """The example-robot-data Pinocchio model of a UR arm (the genuine UR3 for ``'ur3'``)."""
    from example_robot_data.robots_loader import UR3Loader, UR5Loader, UR10Loader

    loader = {"ur3": UR3Loader, "ur5": UR5Loader, "ur10": UR10Loader}[robot.lower()]
    return loader().robot.model
