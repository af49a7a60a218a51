"""Mechanisms: a Pinocchio kinematic tree plus loop closures and locked joints.

A :class:`Mechanism` is what every kinbox problem is made of:

* ``model``: a ``pinocchio.Model`` (the spanning tree; fixed joints are already folded into
  frames by Pinocchio);
* ``closures``: constraints that close loops or pin a frame to a goal, each between a point
  or frame attached to one joint and one attached to another (joint 0 is the world);
* ``locked``: joints held at given values (Pinocchio ``q`` entries of that joint).

:func:`load` makes a Mechanism from a ``pinocchio.Model``, a URDF / MJCF / kinbox mechanism
file (``docs/mechanism-files.md``), a URDF string, a built-in mechanism name
(:func:`builtin_names`) or an example-robot-data robot name. Loading files is Pinocchio's job;
this module only wraps its loaders (kinematic models only: meshes are never loaded).
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import pinocchio as pin

from ..errors import MAX_CLOSURES, MAX_LENGTH, MAX_MODEL_DOF, InputError, ModelError, NameNotFound

ClosureKind = Literal["weld", "point", "distance"]


@dataclass
class Closure:
    """A loop closure between ``joint_a * placement_a`` and ``joint_b * placement_b``.

    * ``weld``: the two frames coincide (position and orientation);
    * ``point``: the two frame origins coincide (a spherical pair);
    * ``distance``: the two origins are ``length`` apart (a spherical-spherical leg).

    Joint ids are Pinocchio joint indices; ``0`` is the world (universe).
    """

    kind: ClosureKind
    joint_a: int
    placement_a: pin.SE3
    joint_b: int
    placement_b: pin.SE3
    length: float = 0.0
    name: str = ""

    def residual(self, model: pin.Model, data: pin.Data) -> tuple[float, float]:
        """(position error in metres, orientation error in radians) after ``forwardKinematics``.

        Orientation error is 0 for ``point`` and ``distance`` closures.
        """
        Ma = data.oMi[self.joint_a] * self.placement_a
        Mb = data.oMi[self.joint_b] * self.placement_b
        dt = Ma.translation - Mb.translation
        pos = math.sqrt(dt.dot(dt))  # np.linalg.norm of a vector, without its checks
        if self.kind == "distance":
            return abs(pos - self.length), 0.0
        if self.kind == "point":
            return pos, 0.0
        w = pin.log3(Ma.rotation.T @ Mb.rotation)
        return pos, math.sqrt(w.dot(w))


@dataclass
class Mechanism:
    """A Pinocchio model with loop closures and locked joints. See the module docstring."""

    model: pin.Model
    closures: list[Closure] = field(default_factory=list)
    locked: dict[str, np.ndarray] = field(default_factory=dict)
    name: str = "mechanism"

    # -- names -----------------------------------------------------------------
    def joint_id(self, name: str) -> int:
        if name in ("universe", "world", ""):
            return 0
        if not self.model.existJointName(name):
            known = ", ".join(self.model.names[1:])
            raise NameNotFound(f"unknown joint {name!r} in {self.name!r}; joints: {known}")
        return self.model.getJointId(name)

    def frame_id(self, name: str) -> int:
        if not self.model.existFrame(name):
            known = ", ".join(f.name for f in self.model.frames)
            raise NameNotFound(f"unknown frame {name!r} in {self.name!r}; frames: {known}")
        return self.model.getFrameId(name)

    def frame_anchor(self, name: str) -> tuple[int, pin.SE3]:
        """(parent joint id, placement in that joint's frame) of a frame or joint name.

        Frames of one name at one place (a URDF link and the fixed joint into it) are one
        frame. Frames of one name at different places (a joint ``gripper`` and a link
        ``gripper``) are refused, the candidates listed as ``NAME:TYPE`` (``gripper:body``,
        ``gripper:joint``), which choose one (test_ambiguous_frame_names_are_refused_with_candidates)."""
        if name in ("universe", "world", ""):
            return 0, pin.SE3.Identity()
        same = [f for f in self.model.frames if f.name == name]
        base, sep, kind = name.rpartition(":")
        if not same and sep and kind.lower() in FRAME_TYPES:
            same = [f for f in self.model.frames if f.name == base and f.type == FRAME_TYPES[kind.lower()]]
        if same:
            f = same[0]
            if any(g.parentJoint != f.parentJoint or not g.placement.isApprox(f.placement) for g in same[1:]):
                names = self.model.names
                what = ", ".join(f"{g.name}:{_frame_type_name(g.type)} (on joint {names[g.parentJoint]})" for g in same)
                raise NameNotFound(
                    f"frame name {name!r} is ambiguous in {self.name!r}: {len(same)} frames at different places, "
                    f"{what}; name one as NAME:TYPE"
                )
            return int(f.parentJoint), pin.SE3(f.placement)
        if self.model.existJointName(name):
            return self.model.getJointId(name), pin.SE3.Identity()
        return self.frame_id(name), pin.SE3.Identity()  # raises NameNotFound

    def joints_between(self, a: str, b: str | None = None) -> list[int]:
        """Ids of the joints on the tree path between the frames (or joints) ``a`` and ``b``
        (default: the world), in increasing order: the joints that move one relative to the other."""
        parents = self.model.parents
        ups = []
        for name in (a, b or "universe"):
            j, _ = self.frame_anchor(name)
            up = [j]
            while up[-1] != 0:
                up.append(int(parents[up[-1]]))
            ups.append(up)
        common = set(ups[0]) & set(ups[1])
        return sorted(j for up in ups for j in up if j not in common)

    def reach(self, name: str) -> float:
        """An upper bound on the distance of the frame (or joint) ``name`` from the world origin
        over every configuration: the lengths of its joint placements and its own placement
        summed, plus the travel of each prismatic joint on the way (``inf`` if a joint of
        another kind can translate, or a prismatic joint has no limit). Rounded up: a pose
        farther than ``reach(frame) + reach(base)`` has no solution
        (tests/cli/test_hostile.py::test_far_pose_is_proven_empty)."""
        model = self.model
        j, placement = self.frame_anchor(name)
        total = float(np.linalg.norm(placement.translation))
        locked = {self.joint_id(k): np.abs(np.asarray(v, dtype=float)) for k, v in self.locked.items()}
        while j != 0:
            total += float(np.linalg.norm(model.jointPlacements[j].translation))
            jm = model.joints[j]
            short = jm.shortname()
            if _PRISMATIC.match(short):
                iq = int(jm.idx_q)
                travel = max(abs(float(model.lowerPositionLimit[iq])), abs(float(model.upperPositionLimit[iq])))
                total += max(travel, float(np.max(locked.get(j, 0.0))))
            elif not _ROTATING.match(short):
                return math.inf
            j = int(model.parents[j])
        return total * (1 + 1e-9) + 1e-300

    # -- modifiers -------------------------------------------------------------
    def lock(self, joint: str, value: float | Sequence[float] | np.ndarray) -> Mechanism:
        """Hold ``joint`` at ``value`` (its Pinocchio ``q`` entries; a float for 1-dof joints)."""
        self.locked[joint] = self.lock_value(joint, value)[1]
        return self

    def lock_value(self, joint: str, value: float | Sequence[float] | np.ndarray) -> tuple[int, np.ndarray]:
        """(joint id, ``q`` entries) of ``joint`` held at ``value``: finite, as many entries as
        the joint has (a continuous joint may be given its angle). The one place lock values
        are checked and normalised."""
        jid = self.joint_id(joint)
        if jid == 0:
            raise InputError(f"cannot lock the universe ({joint!r})")
        j = self.model.joints[jid]
        try:
            v = np.atleast_1d(np.asarray(value, dtype=float)).ravel()
        except (TypeError, ValueError):
            raise InputError(f"lock value of joint {joint!r} must be a number, got {value!r:.80}") from None
        if not np.all(np.isfinite(v)):
            raise InputError(f"lock value of joint {joint!r} is not finite: {v}")
        if v.size == 1 and j.nq == 2 and j.nv == 1:  # continuous joint given as an angle
            v = np.array([math.cos(v[0]), math.sin(v[0])])
        if v.size != j.nq:
            raise InputError(f"joint {joint!r} takes {j.nq} value(s), got {v.size}")
        self._check_range(joint, jid, v)
        return jid, v

    def _check_range(self, joint: str, jid: int, v: np.ndarray) -> None:
        """A lock value beyond :data:`~kinbox.errors.MAX_LENGTH`, or outside the joint's finite
        limits (a revolute joint whose limits span a full turn takes any angle), is refused
        (tests/cli/test_hostile.py::test_cli_numbers)."""
        big = float(np.max(np.abs(v)))
        if big > MAX_LENGTH:
            raise InputError(f"lock value {big:g} of joint {joint!r} is beyond the limit of {MAX_LENGTH:g}")
        j = self.model.joints[jid]
        if j.nq != 1:
            return
        iq = int(j.idx_q)
        lo, hi = float(self.model.lowerPositionLimit[iq]), float(self.model.upperPositionLimit[iq])
        full_turn = _ROTATING.match(j.shortname()) is not None and hi - lo >= 2 * math.pi * (1 - 1e-9)
        if math.isfinite(lo) and math.isfinite(hi) and lo <= hi and not full_turn and not lo <= v[0] <= hi:
            raise InputError(f"lock value {v[0]:g} of joint {joint!r} is outside its range [{lo:g}, {hi:g}]")

    def locked_q(self) -> dict[int, np.ndarray]:
        """The locked joints by id, with their ``q`` entries (checked again: ``locked`` is a
        plain dict that callers may fill directly)."""
        return dict(self.lock_value(name, v) for name, v in self.locked.items())

    def add_goal(self, frame: str, pose: pin.SE3, base: str | None = None, name: str = "goal") -> Mechanism:
        """Pin ``frame`` to ``pose``, expressed in ``base`` (default: the world)."""
        ja, pa = self.frame_anchor(frame)
        jb, pb = self.frame_anchor(base or "universe")
        self.closures.append(Closure("weld", ja, pa, jb, pb * pose, name=name))
        return self

    def closure_residuals(self, q: np.ndarray, data: pin.Data | None = None) -> list[tuple[str, float, float]]:
        """(name, position error, orientation error) of every closure at ``q`` (Pinocchio FK);
        ``data``: the model's data to use as scratch (default: a new one)."""
        data = data if data is not None else self.model.createData()
        pin.forwardKinematics(self.model, data, q)
        return [(c.name or c.kind, *c.residual(self.model, data)) for c in self.closures]


#: Pinocchio joint kinds (``shortname()``) that only rotate, or translate along one axis
_ROTATING = re.compile(r"^JointModel(R[XYZ]|RUB[XYZ]|RevoluteUnaligned|RevoluteUnboundedUnaligned|Spherical|SphericalZYX)$")
_PRISMATIC = re.compile(r"^JointModel(P[XYZ]|PrismaticUnaligned)$")


#: the frame types a ``NAME:TYPE`` frame name may name (:meth:`Mechanism.frame_anchor`)
FRAME_TYPES = {
    "body": pin.FrameType.BODY,
    "joint": pin.FrameType.JOINT,
    "fixed_joint": pin.FrameType.FIXED_JOINT,
    "op_frame": pin.FrameType.OP_FRAME,
    "sensor": pin.FrameType.SENSOR,
}


def _frame_type_name(t: pin.FrameType) -> str:
    return next((k for k, v in FRAME_TYPES.items() if v == t), str(t))


# -- numbers -------------------------------------------------------------------------------
def finite(a) -> bool:
    return bool(np.all(np.isfinite(np.asarray(a, dtype=float))))


def check_model(model: pin.Model, where: str = "model") -> None:
    """Raise :class:`ModelError` if ``model`` holds a non-finite number.

    Joint and frame placements and inertias must be finite. Position limits may be infinite
    (that means "unlimited") but not NaN. Joint axes must not be zero; a model has at most
    :data:`~kinbox.errors.MAX_MODEL_DOF` degrees of freedom.
    """
    if model.nv > MAX_MODEL_DOF:
        raise ModelError(f"{where}: {model.nv} degrees of freedom, more than the limit of {MAX_MODEL_DOF}")
    for i in range(model.njoints):
        M = model.jointPlacements[i]
        if not (finite(M.translation) and finite(M.rotation)):
            raise ModelError(f"{where}: placement of joint {model.names[i]!r} is not finite")
        Y = model.inertias[i]
        if not (finite([Y.mass]) and finite(Y.lever) and finite(Y.inertia)):
            raise ModelError(f"{where}: inertia of body of joint {model.names[i]!r} is not finite")
    for f in model.frames:
        if not (finite(f.placement.translation) and finite(f.placement.rotation)):
            raise ModelError(f"{where}: placement of frame {f.name!r} is not finite")
    for i in range(model.njoints):  # lengths beyond MAX_LENGTH: tests/cli/test_hostile.py::test_huge_model_numbers
        far = float(np.max(np.abs(model.jointPlacements[i].translation), initial=0.0))
        if far > MAX_LENGTH:
            raise ModelError(f"{where}: joint {model.names[i]!r} is placed {far:.3g} from its parent, beyond the limit of {MAX_LENGTH:g}")
    for f in model.frames:
        far = float(np.max(np.abs(f.placement.translation), initial=0.0))
        if far > MAX_LENGTH:
            raise ModelError(f"{where}: frame {f.name!r} is placed {far:.3g} from its joint, beyond the limit of {MAX_LENGTH:g}")
    for i in range(1, model.njoints):
        n = _axis_norm(model.joints[i])
        if n == 0.0 or not math.isfinite(n):
            raise ModelError(f'{where}: joint {model.names[i]!r} has a zero axis (in URDF: <axis xyz="0 0 0"/>)')
        if n <= 1e-9:
            raise ModelError(
                f"{where}: joint {model.names[i]!r} has an axis of length {n:.3g}, too small to give a direction (at least 1e-9)"
            )
    lo = np.asarray(model.lowerPositionLimit, dtype=float)
    hi = np.asarray(model.upperPositionLimit, dtype=float)
    if np.any(np.isnan(lo)) or np.any(np.isnan(hi)):
        raise ModelError(f"{where}: a joint position limit is NaN")


def _axis_norm(jmodel) -> float:
    """The length of the axis of an unaligned revolute or prismatic joint (1 for others)."""
    short = jmodel.shortname()
    if "Unaligned" not in short or not ("Revolute" in short or "Prismatic" in short):
        return 1.0
    ext = jmodel.extract()
    if hasattr(type(ext), "axis"):
        a = np.array(ext.axis, dtype=float)
    else:  # RevoluteUnboundedUnaligned: the binding has no axis; measure a quarter turn
        iq = int(jmodel.idx_q)
        q = np.zeros(iq + int(jmodel.nq))
        q[iq : iq + 2] = [0.0, 1.0]
        jd = jmodel.createData()
        jmodel.calc(jd, q)
        a = np.array(pin.log3(jd.M.rotation))
    m = float(np.max(np.abs(a), initial=0.0))  # scaled: the square of 1e-300 underflows to 0
    return m * float(np.linalg.norm(a / m)) if 0.0 < m < math.inf else m


def check_mechanism(mech: Mechanism, where: str | None = None) -> None:
    """:func:`check_model` plus the closures: known joints, finite placements and lengths.

    A ``distance`` closure whose length is NaN is accepted: it means "not set yet"
    (see :func:`kinbox.builders.stewart`).
    """
    where = where or mech.name
    if not isinstance(mech.model, pin.Model):
        raise ModelError(f"{where}: model is not a pinocchio.Model but {type(mech.model).__name__}")
    if len(mech.closures) > MAX_CLOSURES:
        raise ModelError(f"{where}: {len(mech.closures)} closures, more than the limit of {MAX_CLOSURES}")
    check_model(mech.model, where)
    for k, c in enumerate(mech.closures):
        label = c.name or f"closure {k}"
        if c.kind not in ("weld", "point", "distance"):
            raise ModelError(f"{where}: {label}: unknown closure kind {c.kind!r}")
        for j in (c.joint_a, c.joint_b):
            if not 0 <= int(j) < mech.model.njoints:
                raise ModelError(f"{where}: {label}: joint index {j} out of range 0..{mech.model.njoints - 1}")
        for M in (c.placement_a, c.placement_b):
            if not (finite(M.translation) and finite(M.rotation)):
                raise ModelError(f"{where}: {label}: placement is not finite")
            if float(np.max(np.abs(M.translation))) > MAX_LENGTH:
                raise ModelError(f"{where}: {label}: placement beyond the limit of {MAX_LENGTH:g} (the model's unit)")
        if c.kind == "distance" and math.isfinite(c.length) and c.length > MAX_LENGTH:
            raise ModelError(f"{where}: {label}: length {c.length:g} is beyond the limit of {MAX_LENGTH:g}")
        if c.kind == "distance" and not math.isnan(c.length) and not (math.isfinite(c.length) and c.length >= 0):
            raise ModelError(f"{where}: {label}: length {c.length} is not a finite non-negative number")
