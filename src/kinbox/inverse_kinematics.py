"""All inverse-kinematics solutions of an arm: ``kinbox.ik`` and ``kinbox.IK``.

Example::

    import kinbox, pinocchio as pin
    res = kinbox.ik("ur5", "tool0", pin.SE3(pin.rpy.rpyToMatrix(0.1, 0.2, 0.3), np.array([0.3, 0.2, 0.4])))
    for s in res.solutions:
        print(s.q, s.residual, s.certified)
"""

from __future__ import annotations

import copy
from typing import Mapping, Sequence

import numpy as np
import pinocchio as pin

from .errors import InputError
from .formulation import formulate
from .mechanism import Mechanism, load
from .refine import free_velocity_indices, refine
from .result import Result, build_result
from .solver import SolverOptions, solve_system

DEFAULT_SIGMA = 1e-4


def parse_pose(pose) -> pin.SE3:
    """A ``pin.SE3`` or a 7-vector ``x y z qx qy qz qw`` (Pinocchio's XYZQUAT), validated."""
    if isinstance(pose, pin.SE3):
        if not (np.all(np.isfinite(pose.translation)) and np.all(np.isfinite(pose.rotation))):
            raise InputError("pose has non-finite numbers")
        R = pose.rotation
        if np.max(np.abs(R.T @ R - np.eye(3))) > 1e-9 or np.linalg.det(R) < 0:
            raise InputError("pose rotation is not a rotation matrix")
        return pin.SE3(pose)
    v = np.asarray(pose, dtype=float).ravel()
    if v.size != 7:
        raise InputError(f"pose needs 7 numbers (x y z qx qy qz qw), got {v.size}")
    if not np.all(np.isfinite(v)):
        raise InputError(f"pose has non-finite numbers: {v.tolist()}")
    nq = float(np.linalg.norm(v[3:]))
    if abs(nq - 1.0) > 1e-6:
        raise InputError(f"quaternion (qx qy qz qw) = {v[3:].tolist()} is not unit (norm {nq:.6g})")
    v[3:] /= nq
    return pin.XYZQUATToSE3(v)


class IK:
    """An arm prepared once for many inverse-kinematics queries of one frame."""

    def __init__(self, robot, frame: str, base: str | None = None,
                 lock: Mapping[str, float] | None = None):
        self.robot = load(robot)
        self.source = {"kind": "ik", "robot": robot if isinstance(robot, str) else None,
                       "frame": frame, "base": base, "lock": dict(lock or {})}
        self.frame = frame
        self.base = base
        self.robot.frame_anchor(frame)  # validates the names now, not at the first solve
        if base is not None:
            self.robot.frame_anchor(base)
        for name, value in (lock or {}).items():
            self.robot.lock(name, value)

    def pose_at(self, q: Sequence[float]) -> pin.SE3:
        """The goal frame's pose (in ``base``) at configuration ``q`` (angles for continuous joints)."""
        model = self.robot.model
        q = _as_configuration(model, q)
        data = model.createData()
        pin.framesForwardKinematics(model, data, q)
        ja, pa = self.robot.frame_anchor(self.frame)
        jb, pb = self.robot.frame_anchor(self.base or "universe")
        Ma = data.oMi[ja] * pa
        Mb = data.oMi[jb] * pb
        return Mb.inverse() * Ma

    def solve(self, pose, **solver_options) -> Result:
        goal = parse_pose(pose)
        mech = copy.copy(self.robot)
        mech.closures = list(self.robot.closures)
        mech.locked = dict(self.robot.locked)
        mech.add_goal(self.frame, goal, self.base)
        form = formulate(mech)
        opts = SolverOptions(sigma=DEFAULT_SIGMA)
        raw = solve_system(form.system, opts, **solver_options)
        free_v = free_velocity_indices(mech.model, form.joint_vars.keys())
        polish = lambda q: refine(mech, q, free_v)  # noqa: E731
        source = dict(self.source, pose=[float(v) for v in pin.SE3ToXYZQUAT(goal)])
        return build_result(f"ik {mech.name} {self.frame}", raw, form, opts.sigma, polish=polish,
                            source=source)


def ik(robot, frame: str, pose, base: str | None = None,
       lock: Mapping[str, float] | None = None, **solver_options) -> Result:
    """Every configuration of ``robot`` that puts ``frame`` at ``pose`` (within joint limits).

    ``robot``: a ``pinocchio.Model``, a URDF path, or an example-robot-data name;
    ``pose``: a ``pinocchio.SE3`` or ``[x, y, z, qx, qy, qz, qw]``, in ``base`` (default: world);
    ``lock``: joints held fixed, ``{name: value}``. Solver options: ``sigma``, ``time_limit``,
    ``max_boxes``, ``progress``. An unreachable pose gives no solution and ``complete=True``.
    """
    return IK(robot, frame, base, lock).solve(pose, **solver_options)


def _as_configuration(model: pin.Model, q) -> np.ndarray:
    """Accept Pinocchio ``q`` (size nq) or one value per degree of freedom (size nv)."""
    v = np.asarray(q, dtype=float).ravel()
    if not np.all(np.isfinite(v)):
        raise InputError(f"joint values are not finite: {v.tolist()}")
    if v.size == model.nq:
        return v
    if v.size == model.nv:
        return pin.integrate(model, pin.neutral(model), _v_from_angles(model, v))
    raise InputError(f"{model.name or 'robot'} takes {model.nq} joint values (or {model.nv} angles), got {v.size}")


def _v_from_angles(model: pin.Model, a: np.ndarray) -> np.ndarray:
    # from the neutral configuration, integrating v by the angles gives those angles for
    # revolute (bounded or continuous) and prismatic joints
    return a
