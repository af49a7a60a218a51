"""Fuzz harness: random serial arms of every structural class, written as URDF, checked.

Shared by the quick sweep of the test suite (``tests/cli/test_fuzz_quick.py``) and the large sweep
(``scripts/fuzz_sweep.py``). Nothing here is keyed to a robot's name: every arm is drawn from
a seeded random geometry of its *structural class* and written out as URDF text, which kinbox
loads through its public API (``kinbox.IK(path, frame, lock=...)``); the only named robots are
example-robot-data's ``ur5`` and ``ur10``, compared with the closed form of
``tests/support/oracles/ur_ik.py``.

Classes (:data:`GENERATORS`; each a function ``rng -> Arm``)
-----------------------------------------------------------------
``general_6r``      random modified-DH table: a, d in +-[0.05, 1] m, alpha uniform, random
                    zero offsets, base and tool transforms;
``spherical_wrist`` a general positioning part (joints 1-3) and three wrist axes through one
                    point, at random angles to each other;
``industrial``      spherical wrist, every twist a multiple of 90 degrees, axes 2 and 3
                    parallel, random shoulder / elbow offsets (the RX60 / KUKA / PUMA family);
``ur_like``         axes 2, 3, 4 parallel, twists of 90 degrees elsewhere (the UR family),
                    random lengths and offsets, sometimes extra offsets between the wrist axes;
``offset_wrist``    industrial shoulder and elbow, a wrist whose axes do not meet (offsets
                    d5 / a4 / a5, twists of 90 degrees or of 50-70 degrees, Kinova-like);
``prismatic``       one of joints 1-3 prismatic (Stanford-arm-like), spherical wrist;
``seven_dof_locked`` a 7-joint arm (S-R-S iiwa-like or Panda-like offsets) with one joint
                    locked at a random value (``lock={name: value}``);
``ur5``, ``ur10``   example-robot-data's models by name, poses from random configurations;
                    the answer must equal the closed-form solution set.

A design whose frame Jacobian is singular at random configurations (fewer than 6 degrees of
freedom, e.g. a prismatic joint between two parallel revolute axes) is drawn again from the
same stream (``notes["redraws"]``); ``tests/data/fuzz_failures/prismatic_1015`` is one such arm,
kept because kinbox mishandles it.

The URDF of a DH arm is not the plain DH frames: each link frame is turned by a random *gauge*
rotation (identity, a signed axis permutation, or a random rotation), so joint axes are
written along z, along any coordinate axis or along arbitrary unit vectors, with the joint
origins carrying the compensating rpy; the kinematics (checked against the DH product in
``test_fuzz_quick.py``) is that of the DH table. Joint limits are mixed per joint:
``+-2 pi`` revolute, ``+-pi`` revolute, ``continuous`` (Pinocchio's (cos, sin) joint) or a
random range narrower than 2 pi; prismatic joints get a random stroke.

Checks (:func:`run_case`), every one independent of kinbox's own checks
-------------------------------------------------------------------------
* the goal pose is Pinocchio forward kinematics of a seeded random configuration on a model
  loaded here from the same URDF text (``pin.buildModelFromXML``), not by kinbox;
* every returned ``q``: FK error < :data:`FK_TOL` on that model, within the limits, locked
  joints where locked, no two solutions the same (modulo 2 pi on periodic joints);
* the generating configuration is among the solutions (joints kinbox drops because the frame
  does not depend on them are not compared);
* every root that a many-start Levenberg-Marquardt search (:func:`newton_roots`, on
  Pinocchio's frame Jacobian, random starts inside the limits) converges to, inside the limits,
  is among the solutions;
* ``complete`` is true; for ``ur5`` / ``ur10`` the solutions equal the closed form's.

A record (a dict, one JSON line in the sweep) says what was found; ``record["problems"]`` lists
every failed check, ``record["status"]`` is the worst of them (:data:`STATUS_ORDER`).
"""

from __future__ import annotations

import math
import time
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin

TWO_PI = 2.0 * math.pi
FK_TOL = 1e-9  # every solution reproduces the pose this well (metres / radians)
SAME_TOL = 1e-6  # two configurations closer than this (per joint) are the same
NEWTON_TOL = 1e-12  # a Newton run has converged when the pose error is below this
# ...and goes on while its steps help, down to this: near a singular pose an error of 1e-12
# is a point up to |e| / sigma_min away from the root (8e-13 / 5e-7 = 1.6e-6, more than
# SAME_TOL: a UR-like 7-DOF arm's Newton point was reported as a root kinbox had lost, while
# kinbox's solution, 1.1e-6 from it, was the root to 5e-8)
POLISH_TOL = 1e-15
LIMIT_MARGIN = 1e-7  # Newton roots closer than this to a joint limit are not required

#: worst first: a record's status is the first of these among its problems
STATUS_ORDER = ("error", "lost_root", "lost_generator", "bad_solution", "incomplete", "extra", "slow", "ok")


# ----------------------------------------------------------------------------------------------
# transforms
# ----------------------------------------------------------------------------------------------
def _rotx(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    T = np.eye(4)
    T[1:3, 1:3] = [[c, -s], [s, c]]
    return T


def _rotz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    T = np.eye(4)
    T[0:2, 0:2] = [[c, -s], [s, c]]
    return T


def _trans(x: float, y: float, z: float) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = [x, y, z]
    return T


def _inv(T: np.ndarray) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3] = T[:3, :3].T
    out[:3, 3] = -T[:3, :3].T @ T[:3, 3]
    return out


def _random_rotation(rng) -> np.ndarray:
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    return pin.Quaternion(q[3], q[0], q[1], q[2]).toRotationMatrix()


def _signed_permutation(rng) -> np.ndarray:
    R = np.eye(3)[rng.permutation(3)] * rng.choice([-1.0, 1.0], size=3)[:, None]
    if np.linalg.det(R) < 0:
        R[2] *= -1.0
    return R


def _homogeneous(R: np.ndarray, p=(0.0, 0.0, 0.0)) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = p
    return T


# ----------------------------------------------------------------------------------------------
# arms: a modified-DH table, joint kinds and limits, written as URDF
# ----------------------------------------------------------------------------------------------
@dataclass
class Joint:
    name: str
    kind: str  # "revolute" | "continuous" | "prismatic"
    origin: np.ndarray  # 4x4, parent link frame -> joint frame at q = 0
    axis: np.ndarray  # unit 3-vector in the joint frame
    lower: float = -math.pi
    upper: float = math.pi


@dataclass
class Arm:
    """A serial arm: joints in chain order, a tool frame, optional locks, and the DH table it
    was made from (for the generator's own check, :func:`dh_fk`)."""

    cls: str
    joints: list[Joint]
    tool: np.ndarray  # last link -> tool frame
    frame: str = "tool"
    lock: dict = field(default_factory=dict)  # joint name -> value
    dh: list | None = None  # [(alpha, a, d, theta0, kind), ...] modified DH
    base: np.ndarray | None = None
    tool_dh: np.ndarray | None = None  # last DH frame -> tool (the URDF's `tool` has the gauge in it)
    notes: dict = field(default_factory=dict)

    def urdf(self, name: str = "fuzz_arm") -> str:
        def f(v) -> str:
            return " ".join(repr(float(x)) for x in v)

        def origin(T) -> str:
            rpy = pin.rpy.matrixToRpy(T[:3, :3])
            return f'<origin xyz="{f(T[:3, 3])}" rpy="{f(rpy)}"/>'

        inertial = (
            '<inertial><mass value="1.0"/><origin xyz="0 0 0" rpy="0 0 0"/>'
            '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>'
        )
        out = ['<?xml version="1.0"?>', f'<robot name="{name}">', f'  <link name="base_link">{inertial}</link>']
        parent = "base_link"
        for k, j in enumerate(self.joints):
            child = f"link{k + 1}"
            lim = "" if j.kind == "continuous" else f'<limit lower="{j.lower!r}" upper="{j.upper!r}" effort="100" velocity="2"/>'
            out += [
                f'  <joint name="{j.name}" type="{j.kind}">',
                f'    <parent link="{parent}"/><child link="{child}"/>',
                f"    {origin(j.origin)}",
                f'    <axis xyz="{f(j.axis)}"/>',
                f"    {lim}" if lim else None,
                "  </joint>",
                f'  <link name="{child}">{inertial}</link>',
            ]
            parent = child
        out += [
            '  <joint name="tool_joint" type="fixed">',
            f'    <parent link="{parent}"/><child link="{self.frame}"/>',
            f"    {origin(self.tool)}",
            "  </joint>",
            f'  <link name="{self.frame}">{inertial}</link>',
            "</robot>",
            "",
        ]
        return "\n".join(x for x in out if x is not None)


def dh_fk(arm: Arm, values) -> np.ndarray:
    """Forward kinematics of the arm's DH table (one value per joint): base -> tool, 4x4."""
    T = np.eye(4) if arm.base is None else arm.base.copy()
    for (alpha, a, d, th0, kind), v in zip(arm.dh, values):
        dv, tv = (v, 0.0) if kind == "P" else (0.0, v)
        T = T @ _rotx(alpha) @ _trans(a, 0.0, d + dv) @ _rotz(th0 + tv)
    return T @ (arm.tool if arm.tool_dh is None else arm.tool_dh)


def _limits(rng, kind: str, profile: str = "mixed") -> tuple[str, float, float]:
    """(URDF type, lower, upper) of one joint."""
    if kind == "P":
        lo = rng.uniform(-0.4, 0.1)
        return "prismatic", lo, lo + rng.uniform(0.3, 1.0)
    r = rng.random() * (0.7 if profile == "full" else 1.0)
    if r < 0.3:
        return "revolute", -TWO_PI, TWO_PI
    if r < 0.5:
        return "revolute", -math.pi, math.pi
    if r < 0.7:
        return "continuous", -math.pi, math.pi
    c, w = rng.uniform(-1.0, 1.0), rng.uniform(1.0, 5.5)
    return "revolute", c - w / 2, c + w / 2


def _gauges(rng, n: int, mode: str | None = None) -> tuple[str, list[np.ndarray]]:
    mode = mode or str(rng.choice(["dh", "permutation", "random"]))
    if mode == "dh":
        return mode, [np.eye(4) for _ in range(n)]
    if mode == "permutation":
        return mode, [_homogeneous(_signed_permutation(rng)) for _ in range(n)]
    return mode, [_homogeneous(_random_rotation(rng)) for _ in range(n)]


def arm_from_dh(
    cls: str, rng, rows, base=None, tool=None, gauge: str | None = None, profile: str | None = None, lock_index: int | None = None
) -> Arm:
    """An :class:`Arm` from a modified-DH table ``[(alpha_{i-1}, a_{i-1}, d_i, theta0_i, 'R'|'P')]``:
    link frame i of the DH convention turned by a random gauge rotation G_i (the joint origin
    absorbs it and the axis becomes G_i^T z)."""
    base = np.eye(4) if base is None else base
    tool = np.eye(4) if tool is None else tool
    mode, G = _gauges(rng, len(rows), gauge)
    profile = profile or ("full" if rng.random() < 0.4 else "mixed")
    joints = []
    G_prev = np.eye(4)
    for i, (alpha, a, d, th0, kind) in enumerate(rows):
        T = _rotx(alpha) @ _trans(a, 0.0, d) @ _rotz(th0)
        if i == 0:
            T = base @ T
        O = _inv(G_prev) @ T @ G[i]
        axis = G[i][:3, :3].T @ np.array([0.0, 0.0, 1.0])
        urdf_kind, lo, hi = _limits(rng, kind, profile)
        joints.append(Joint(f"j{i + 1}", urdf_kind, O, axis, lo, hi))
        G_prev = G[i]
    arm = Arm(
        cls, joints, _inv(G_prev) @ tool, dh=[tuple(r) for r in rows], base=base, tool_dh=tool, notes={"gauge": mode, "limits": profile}
    )
    if lock_index is not None:
        j = joints[lock_index]
        arm.lock = {j.name: float(rng.uniform(max(j.lower, -math.pi), min(j.upper, math.pi)))}
    return arm


def _len(rng, lo: float = 0.05, hi: float = 1.0) -> float:
    return float(rng.uniform(lo, hi))


def _slen(rng, lo: float = 0.05, hi: float = 1.0) -> float:
    return float(rng.choice([-1.0, 1.0]) * rng.uniform(lo, hi))


def _maybe(rng, p: float, value: float) -> float:
    return value if rng.random() < p else 0.0


def _right(rng) -> float:
    return float(rng.choice([-1.0, 1.0]) * math.pi / 2)


def _quarter(rng) -> float:
    return float(rng.integers(0, 4) * math.pi / 2)


def _random_base(rng) -> np.ndarray:
    return _homogeneous(_random_rotation(rng), rng.uniform(-0.3, 0.3, 3))


def _random_tool(rng) -> np.ndarray:
    return _homogeneous(_random_rotation(rng), rng.uniform(-0.15, 0.15, 3))


def _upright_base(rng) -> np.ndarray:
    return _homogeneous(_rotz(_quarter(rng))[:3, :3], [rng.uniform(-0.2, 0.2), rng.uniform(-0.2, 0.2), rng.uniform(0.0, 0.3)])


def _flange_tool(rng) -> np.ndarray:
    """A tool along the flange axis, turned by multiples of 90 degrees (sometimes offset)."""
    R = _signed_permutation(rng) if rng.random() < 0.5 else np.eye(3)
    p = [_maybe(rng, 0.3, rng.uniform(-0.05, 0.05)), _maybe(rng, 0.3, rng.uniform(-0.05, 0.05)), rng.uniform(0.05, 0.2)]
    return _homogeneous(R, p)


# --- the classes -------------------------------------------------------------------------------
def general_6r(rng, gauge: str | None = None) -> Arm:
    rows = [(float(rng.uniform(-math.pi, math.pi)), _slen(rng), _slen(rng), float(rng.uniform(-math.pi, math.pi)), "R") for _ in range(6)]
    rows[0] = (0.0, 0.0, rows[0][2], rows[0][3], "R")  # the base transform takes the first link
    return arm_from_dh("general_6r", rng, rows, base=_random_base(rng), tool=_random_tool(rng), gauge=gauge)


def spherical_wrist(rng, gauge: str | None = None) -> Arm:
    rows = [(0.0, 0.0, _len(rng), float(rng.uniform(-math.pi, math.pi)), "R")]
    for _ in range(3):  # joints 2, 3, 4: general
        rows.append((float(rng.uniform(-math.pi, math.pi)), _slen(rng), _slen(rng), float(rng.uniform(-math.pi, math.pi)), "R"))
    for _ in range(2):  # joints 5, 6: through the point of axis 4 at d4
        rows.append((float(rng.uniform(0.3, math.pi - 0.3) * rng.choice([-1, 1])), 0.0, 0.0, float(rng.uniform(-math.pi, math.pi)), "R"))
    return arm_from_dh("spherical_wrist", rng, rows, base=_random_base(rng), tool=_random_tool(rng), gauge=gauge)


def _industrial_shoulder(rng) -> list:
    """Joints 1-4 of an industrial arm: vertical base axis, shoulder and elbow parallel, the
    forearm axis 4 at 90 degrees; random shoulder offset a1, d2, forearm offset a3."""
    return [
        (0.0, 0.0, _len(rng, 0.1, 0.8), _quarter(rng), "R"),
        (_right(rng), _maybe(rng, 0.6, _len(rng, 0.05, 0.4)), _maybe(rng, 0.4, _slen(rng, 0.05, 0.3)), _quarter(rng), "R"),
        (0.0, _len(rng, 0.2, 1.0), _maybe(rng, 0.3, _slen(rng, 0.05, 0.3)), _quarter(rng), "R"),
        (_right(rng), _maybe(rng, 0.5, _slen(rng, 0.02, 0.2)), _len(rng, 0.2, 1.0), _quarter(rng), "R"),
    ]


def industrial(rng, gauge: str | None = None) -> Arm:
    rows = _industrial_shoulder(rng)
    rows += [(_right(rng), 0.0, 0.0, _quarter(rng), "R"), (_right(rng), 0.0, 0.0, _quarter(rng), "R")]
    gauge = gauge or str(rng.choice(["dh", "permutation"]))  # axes along coordinate axes, like real URDFs
    return arm_from_dh("industrial", rng, rows, base=_upright_base(rng), tool=_flange_tool(rng), gauge=gauge)


def ur_like(rng, gauge: str | None = None) -> Arm:
    th = lambda: _quarter(rng) if rng.random() < 0.5 else float(rng.uniform(-math.pi, math.pi))
    rows = [
        (0.0, 0.0, _len(rng, 0.05, 0.5), th(), "R"),
        (_right(rng), _maybe(rng, 0.2, _len(rng, 0.05, 0.2)), _maybe(rng, 0.3, _slen(rng, 0.05, 0.2)), th(), "R"),
        (0.0, _slen(rng, 0.2, 1.0), _maybe(rng, 0.3, _slen(rng, 0.05, 0.2)), th(), "R"),  # 3 parallel to 2
        (0.0, _slen(rng, 0.2, 1.0), _slen(rng, 0.05, 0.3), th(), "R"),  # 4 parallel to 3
        (_right(rng), _maybe(rng, 0.2, _slen(rng, 0.05, 0.15)), _slen(rng, 0.05, 0.3), th(), "R"),
        (_right(rng), _maybe(rng, 0.2, _slen(rng, 0.05, 0.15)), _maybe(rng, 0.5, _slen(rng, 0.05, 0.2)), th(), "R"),
    ]
    return arm_from_dh("ur_like", rng, rows, base=_upright_base(rng), tool=_flange_tool(rng), gauge=gauge)


def offset_wrist(rng, gauge: str | None = None) -> Arm:
    rows = _industrial_shoulder(rng)
    twist = (lambda: _right(rng)) if rng.random() < 0.6 else (lambda: float(rng.choice([-1, 1]) * rng.uniform(0.87, 1.22)))  # 50-70 degrees
    a4, d5, a5 = 0.0, 0.0, 0.0
    while a4 == 0.0 and d5 == 0.0 and a5 == 0.0:
        a4 = _maybe(rng, 0.4, _slen(rng, 0.05, 0.2))
        d5 = _maybe(rng, 0.5, _slen(rng, 0.05, 0.2))
        a5 = _maybe(rng, 0.4, _slen(rng, 0.05, 0.2))
    rows += [(twist(), a4, d5, _quarter(rng), "R"), (twist(), a5, 0.0, _quarter(rng), "R")]
    return arm_from_dh("offset_wrist", rng, rows, base=_upright_base(rng), tool=_flange_tool(rng), gauge=gauge)


def prismatic(rng, gauge: str | None = None) -> Arm:
    k = int(rng.integers(0, 3))  # which of joints 1-3 slides
    ninety = rng.random() < 0.5
    tw = (lambda: _right(rng)) if ninety else (lambda: float(rng.uniform(-math.pi, math.pi)))
    rows = [(0.0, 0.0, _len(rng, 0.1, 0.6), _quarter(rng), "R")]
    rows.append((tw(), _maybe(rng, 0.5, _len(rng, 0.05, 0.4)), _maybe(rng, 0.5, _slen(rng, 0.05, 0.3)), _quarter(rng), "R"))
    rows.append((tw(), _maybe(rng, 0.5, _len(rng, 0.05, 0.4)), _maybe(rng, 0.5, _slen(rng, 0.05, 0.3)), _quarter(rng), "R"))
    rows.append((tw(), _maybe(rng, 0.5, _slen(rng, 0.05, 0.2)), _len(rng, 0.1, 0.6), _quarter(rng), "R"))
    rows += [(_right(rng), 0.0, 0.0, _quarter(rng), "R"), (_right(rng), 0.0, 0.0, _quarter(rng), "R")]
    al, a, d, th0, _ = rows[k]
    rows[k] = (al, a, d, th0, "P")
    arm = arm_from_dh("prismatic", rng, rows, base=_upright_base(rng), tool=_flange_tool(rng), gauge=gauge)
    arm.notes.update(prismatic_joint=k + 1, ninety=bool(ninety))
    return arm


def seven_dof_locked(rng, gauge: str | None = None) -> Arm:
    style = str(rng.choice(["srs", "offset"]))
    if style == "srs":  # shoulder and wrist spherical, elbow between (iiwa-like)
        d = [_len(rng, 0.15, 0.4), 0.0, _len(rng, 0.3, 0.6), 0.0, _len(rng, 0.3, 0.6), 0.0, 0.0]
        a = [0.0] * 7
    else:  # Panda-like elbow offsets and a flange offset
        off = _len(rng, 0.05, 0.12)
        d = [_len(rng, 0.2, 0.4), 0.0, _len(rng, 0.25, 0.4), 0.0, _len(rng, 0.3, 0.45), 0.0, 0.0]
        a = [0.0, 0.0, 0.0, off, -off, 0.0, _len(rng, 0.05, 0.12)]
    rows = [(0.0 if i == 0 else _right(rng), a[i], d[i], _quarter(rng), "R") for i in range(7)]
    # not the elbow of an S-R-S arm: the shoulder-wrist line would be a free axis (a self-motion)
    lock = int(rng.choice([0, 1, 2, 4, 5, 6] if style == "srs" else range(7)))
    arm = arm_from_dh("seven_dof_locked", rng, rows, base=_upright_base(rng), tool=_flange_tool(rng), lock_index=lock, gauge=gauge)
    arm.notes.update(style=style, locked_joint=lock + 1)
    return arm


GENERATORS = {
    "ur_like": ur_like,
    "industrial": industrial,
    "spherical_wrist": spherical_wrist,
    "offset_wrist": offset_wrist,
    "prismatic": prismatic,
    "seven_dof_locked": seven_dof_locked,
    "general_6r": general_6r,
}
NAMED = {"ur5": "tool0", "ur10": "tool0"}  # example-robot-data name -> frame
CLASSES = tuple(GENERATORS) + tuple(NAMED)


def class_rng(cls: str, seed: int) -> np.random.Generator:
    """The random stream of case (cls, seed): independent across classes, replayable."""
    return np.random.default_rng([int(seed), zlib.crc32(cls.encode())])


# ----------------------------------------------------------------------------------------------
# independent model helpers (joint values: one per joint, an angle for continuous joints)
# ----------------------------------------------------------------------------------------------
def _continuous(j) -> bool:
    return j.nq == 2 and j.nv == 1


def config_from_values(model: pin.Model, values) -> np.ndarray:
    q = pin.neutral(model)
    for k, j in enumerate(model.joints[1:]):
        v = float(values[k])
        if _continuous(j):
            q[j.idx_q : j.idx_q + 2] = [math.cos(v), math.sin(v)]
        else:
            q[j.idx_q] = v
    return q


def joint_values(model: pin.Model, q) -> np.ndarray:
    q = np.asarray(q, float)
    out = []
    for j in model.joints[1:]:
        v = q[j.idx_q : j.idx_q + j.nq]
        out.append(math.atan2(v[1], v[0]) if _continuous(j) else float(v[0]))
    return np.array(out)


def _revolute(j) -> bool:
    return _continuous(j) or j.shortname().startswith("JointModelR")


def periodic_mask(model: pin.Model) -> np.ndarray:
    """Joints compared modulo 2 pi: continuous, and revolute with a range of at least 2 pi."""
    out = []
    for j in model.joints[1:]:
        if _continuous(j):
            out.append(True)
            continue
        lo, hi = model.lowerPositionLimit[j.idx_q], model.upperPositionLimit[j.idx_q]
        out.append(bool(_revolute(j) and hi - lo >= TWO_PI - 1e-9))
    return np.array(out)


def joint_limits(model: pin.Model) -> tuple[np.ndarray, np.ndarray]:
    lo, hi = [], []
    for j in model.joints[1:]:
        if _continuous(j):
            lo.append(-math.inf)
            hi.append(math.inf)
        else:
            lo.append(model.lowerPositionLimit[j.idx_q])
            hi.append(model.upperPositionLimit[j.idx_q])
    return np.array(lo), np.array(hi)


def value_distance(model: pin.Model, a, b, keep=None) -> float:
    """Largest per-joint difference of two value vectors, modulo 2 pi on periodic joints."""
    d = np.asarray(a, float) - np.asarray(b, float)
    per = periodic_mask(model)
    d[per] = np.angle(np.exp(1j * d[per]))
    if keep is not None:
        d = d[keep]
    return float(np.max(np.abs(d), initial=0.0))


def frame_pose(model: pin.Model, frame: str, q) -> pin.SE3:
    data = model.createData()
    pin.forwardKinematics(model, data, np.asarray(q, float))
    return pin.SE3(pin.updateFramePlacement(model, data, model.getFrameId(frame)))


def pose_error(model: pin.Model, frame: str, q, goal: pin.SE3) -> float:
    M = frame_pose(model, frame, q)
    return max(float(np.linalg.norm(M.translation - goal.translation)), float(np.linalg.norm(pin.log3(goal.rotation.T @ M.rotation))))


def random_values(model: pin.Model, rng, lock_idx: dict | None = None) -> np.ndarray:
    """One value per joint, uniform inside the limits (continuous: (-pi, pi])."""
    lo, hi = joint_limits(model)
    lo = np.where(np.isfinite(lo), lo, -math.pi)
    hi = np.where(np.isfinite(hi), hi, math.pi)
    v = rng.uniform(lo, hi)
    for k, val in (lock_idx or {}).items():
        v[k] = val
    return v


def _into_limits(model: pin.Model, v: np.ndarray, margin: float):
    """``v`` with each revolute joint moved by a multiple of 2 pi into its limits, or None if a
    joint cannot be; second value: True if a joint ends up within ``margin`` of a limit."""
    lo, hi = joint_limits(model)
    out = v.copy()
    near = False
    for k, j in enumerate(model.joints[1:]):
        if _continuous(j):
            out[k] = math.remainder(out[k], TWO_PI)
            continue
        x = out[k]
        periodic = _revolute(j) and hi[k] - lo[k] >= TWO_PI - 1e-9
        if _revolute(j):
            x = lo[k] + math.fmod(x - lo[k], TWO_PI) % TWO_PI  # smallest copy >= lo
            if x > hi[k] + margin and x - TWO_PI >= lo[k] - margin:
                x -= TWO_PI
        if x < lo[k] - margin or x > hi[k] + margin:
            return None, False
        # a periodic joint always has a copy well inside: only a real end stop is "near"
        near |= bool(not periodic and (x < lo[k] + margin or x > hi[k] - margin))
        out[k] = min(max(x, lo[k]), hi[k])
    return out, near


# ----------------------------------------------------------------------------------------------
# the independent root finder
# ----------------------------------------------------------------------------------------------
def newton_roots(model: pin.Model, frame: str, goal: pin.SE3, starts: int, rng, lock_idx: dict | None = None, iters: int = 100) -> dict:
    """Many-start Levenberg-Marquardt on Pinocchio's frame Jacobian: the distinct roots inside
    the limits (value vectors), and how many lie near a limit / outside the limits.

    The error is ``log6(goal^-1 M(q))`` and its Jacobian ``Jlog6 J_local``; locked joints stay
    at their value. A run that ends with an error below :data:`NEWTON_TOL` is a root; a run
    goes on while its steps lower the error, down to :data:`POLISH_TOL`.
    """
    fid = model.getFrameId(frame)
    data = model.createData()
    lock_idx = lock_idx or {}
    nj = model.njoints - 1
    free = np.array([k for k in range(nj) if k not in lock_idx], dtype=int)
    vidx = np.array([model.joints[int(k) + 1].idx_v for k in free])
    ginv = goal.inverse()

    def err_of(v):
        q = config_from_values(model, v)
        pin.forwardKinematics(model, data, q)
        M = ginv * pin.updateFramePlacement(model, data, fid)
        return q, M, pin.log6(M).vector

    roots, near_limit, outside, failed = [], [], 0, 0
    for _ in range(starts):
        v = random_values(model, rng, lock_idx)
        q, M, e = err_of(v)
        n = float(e @ e)
        lam = 1e-3
        for _it in range(iters):
            if n < POLISH_TOL**2:
                break
            J = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL)[:, vidx]
            J = pin.Jlog6(M) @ J
            g = J.T @ e
            H = J.T @ J
            accepted = False
            for _try in range(12):
                step = np.linalg.solve(H + lam * np.diag(np.diag(H) + 1e-9), -g)
                v2 = v.copy()
                v2[free] += step
                q2, M2, e2 = err_of(v2)
                n2 = float(e2 @ e2)
                if n2 < n:
                    v, q, M, e, n = v2, q2, M2, e2, n2
                    lam = max(lam / 5.0, 1e-12)
                    accepted = True
                    break
                lam *= 8.0
            if not accepted:
                break
        if n >= NEWTON_TOL**2:
            failed += 1
            continue
        w, near = _into_limits(model, v, LIMIT_MARGIN)
        if w is None:
            outside += 1
            continue
        bucket = near_limit if near else roots
        if not any(value_distance(model, w, r) < SAME_TOL for r in roots + near_limit):
            bucket.append(w)
    return {"roots": roots, "near_limit": near_limit, "outside": outside, "failed": failed}


def smallest_singular_value(model: pin.Model, frame: str, values, lock_idx=None) -> float:
    data = model.createData()
    q = config_from_values(model, values)
    fid = model.getFrameId(frame)
    J = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL)
    keep = [model.joints[k + 1].idx_v for k in range(model.njoints - 1) if k not in (lock_idx or {})]
    return float(np.linalg.svd(J[:, keep], compute_uv=False)[-1])


def degenerate(model: pin.Model, frame: str, rng, lock_idx=None, tries: int = 3) -> bool:
    """Is the frame Jacobian (unlocked joints) singular at ``tries`` random configurations? Then
    the design has fewer than 6 degrees of freedom and every pose a continuum of solutions."""
    return all(smallest_singular_value(model, frame, random_values(model, rng, lock_idx), lock_idx) < 1e-8 for _ in range(tries))


# ----------------------------------------------------------------------------------------------
# cases
# ----------------------------------------------------------------------------------------------
@dataclass
class Case:
    cls: str
    seed: int
    robot: str  # URDF path or example-robot-data name (what kinbox is given)
    frame: str
    model: pin.Model  # loaded here, independently of kinbox
    values: np.ndarray  # the generating configuration, one value per joint
    goal: pin.SE3
    lock: dict = field(default_factory=dict)
    urdf: str | None = None
    oracle: list | None = None  # closed-form solutions (UR), value vectors
    notes: dict = field(default_factory=dict)

    @property
    def lock_idx(self) -> dict:
        return {self.model.getJointId(n) - 1: v for n, v in self.lock.items()}

    def describe(self) -> dict:
        return {
            "class": self.cls,
            "seed": self.seed,
            "frame": self.frame,
            "lock": self.lock,
            "q_gen": [float(x) for x in self.values],
            "pose": [float(x) for x in pin.SE3ToXYZQUAT(self.goal)],
            **self.notes,
        }


_ERD: dict[str, pin.Model] = {}


def _erd_model(name: str) -> pin.Model:
    if name not in _ERD:
        import example_robot_data as erd

        _ERD[name] = erd.load(name).model
    return _ERD[name]


def make_case(cls: str, seed: int, directory: str | Path, gauge: str | None = None) -> Case:
    """The seeded case ``(cls, seed)``: an arm (its URDF written into ``directory``), a random
    configuration inside the limits, and its pose. ``gauge`` (``dh``, ``permutation``,
    ``random``) forces how the joint axes are written; by default the seed draws it (the
    industrial class: ``dh`` or ``permutation`` only)."""
    if cls in NAMED:
        return _ur_case(cls, seed, class_rng(cls, seed))
    rng = class_rng(cls if gauge is None else f"{cls}/{gauge}", seed)
    check = np.random.default_rng([int(seed), 99])
    for redraws in range(20):  # noqa: B007 - a degenerate design (Jacobian singular everywhere): draw again
        arm = GENERATORS[cls](rng, gauge)
        text = arm.urdf(f"fuzz_{cls}_{seed}")
        model = pin.buildModelFromXML(text)
        lock_idx = {model.getJointId(n) - 1: v for n, v in arm.lock.items()}
        if not degenerate(model, arm.frame, check, lock_idx):
            break
    path = Path(directory) / f"fuzz_{cls}_{seed}.urdf"
    path.write_text(text)
    notes = dict(arm.notes, gauge_arg=gauge, **({"redraws": redraws} if redraws else {}))
    case = Case(
        cls, seed, str(path), arm.frame, model, np.zeros(model.njoints - 1), pin.SE3.Identity(), lock=dict(arm.lock), urdf=text, notes=notes
    )
    case.values = random_values(model, rng, case.lock_idx)
    case.goal = frame_pose(model, arm.frame, config_from_values(model, case.values))
    return case


def case_from_files(urdf_path: str | Path, frame: str, pose, q_gen=None, lock=None, cls="saved", seed=-1) -> Case:
    """A case from a saved URDF and pose (``tests/data/fuzz_failures``)."""
    text = Path(urdf_path).read_text()
    model = pin.buildModelFromXML(text)
    values = np.asarray(q_gen, float) if q_gen is not None else None
    return Case(
        cls, seed, str(urdf_path), frame, model, values, pin.XYZQUATToSE3(np.asarray(pose, float)), lock=dict(lock or {}), urdf=text
    )


def _ur_case(name: str, seed: int, rng) -> Case:
    from tests.support.oracles.ur_ik import SingularPoseError, expand_within_limits, ur_ik

    model = _erd_model(name)
    frame = NAMED[name]
    lo, hi = model.lowerPositionLimit, model.upperPositionLimit
    while True:  # poses near a wrist singularity (ill-conditioned closed form): next draw
        v = rng.uniform(lo, hi)
        if abs(math.sin(v[4])) < 0.05:
            continue
        goal = frame_pose(model, frame, v)
        try:
            ref = ur_ik(name, goal.homogeneous)
        except SingularPoseError:
            continue
        break
    inside = [r for r in ref if expand_within_limits(r, lo, hi, eps=1e-9)]
    return Case(name, seed, name, frame, model, v, goal, oracle=inside)


# ----------------------------------------------------------------------------------------------
# running and checking one case
# ----------------------------------------------------------------------------------------------
def run_case(
    case: Case, time_limit: float = 60.0, newton_starts: int = 100, slow_s: float | None = None, newton_seed: int | None = None
) -> dict:
    """Solve the case with kinbox and check the answer; a JSON-able record."""
    import kinbox

    rec = {"class": case.cls, "seed": case.seed, **{k: v for k, v in case.notes.items()}}
    problems: list[str] = []
    model, frame = case.model, case.frame
    t0 = time.process_time()
    try:
        prob = kinbox.IK(case.robot, frame, lock=case.lock or None)
        t1 = time.process_time()
        res = prob.solve(case.goal, time_limit=time_limit)
        t2 = time.process_time()
    except Exception as exc:  # noqa: BLE001 - any exception is a finding
        rec.update(status="error", problems=[f"error: {type(exc).__name__}: {exc}"], cpu_s=time.process_time() - t0)
        return rec
    rec.update(
        load_cpu_s=round(t1 - t0, 4),
        cpu_s=round(t2 - t1, 4),
        solver_cpu_s=round(float(res.stats.get("cpu_seconds", math.nan)), 4),
        boxes=int(res.stats.get("boxes", -1)),
        complete=bool(res.complete),
        solutions=len(res.solutions),
        certified=sum(bool(s.certified) for s in res.solutions),
        components=[int(c.dimension) for c in res.components],
        method=res.stats.get("method", ""),
        searched=dict(res.stats.get("searched", {})),
    )
    if not res.complete:
        problems.append(f"incomplete: {res.message}")
    if any(c.dimension > 0 for c in res.components):
        problems.append(f"bad_solution: a component of dimension > 0 ({rec['components']})")
    lo, hi = joint_limits(model)
    sols = []
    for k, s in enumerate(res.solutions):
        q = np.asarray(s.q, float)
        if q.shape != (model.nq,) or not np.all(np.isfinite(q)):
            problems.append(f"bad_solution: solution {k} has shape {q.shape} / non-finite values")
            continue
        err = pose_error(model, frame, q, case.goal)
        if not err < FK_TOL:
            problems.append(f"bad_solution: solution {k}: FK error {err:.2e}")
        v = joint_values(model, q)
        bad = np.nonzero((v < lo - 1e-9) | (v > hi + 1e-9))[0]
        if bad.size:
            problems.append(f"bad_solution: solution {k}: joints {bad.tolist()} outside the limits")
        for jk, val in case.lock_idx.items():
            if abs(v[jk] - val) > 1e-12 and value_distance(model, v[[jk]], [val]) > 1e-12:
                problems.append(f"bad_solution: solution {k}: locked joint {jk + 1} at {v[jk]}, not {val}")
        sols.append(v)
    for a in range(len(sols)):
        for b in range(a):
            d = value_distance(model, sols[a], sols[b])
            if d <= SAME_TOL:
                problems.append(f"bad_solution: solutions {b} and {a} coincide ({d:.1e})")
    dropped = set(res.stats.get("dropped_joints", []))
    keep = np.array([model.names[i] not in dropped for i in range(1, model.njoints)])

    def found(r) -> float:
        return min((value_distance(model, s, r, keep) for s in sols), default=math.inf)

    lost_roots: list[np.ndarray] = []  # distinct roots missing from the answer
    if newton_starts:
        t3 = time.process_time()
        nrng = np.random.default_rng([case.seed if newton_seed is None else newton_seed, 7])
        nr = newton_roots(model, frame, case.goal, newton_starts, nrng, case.lock_idx)
        rec.update(
            newton=len(nr["roots"]),
            newton_near_limit=len(nr["near_limit"]),
            newton_outside=nr["outside"],
            newton_failed=nr["failed"],
            newton_cpu_s=round(time.process_time() - t3, 3),
        )
        lost = [r for r in nr["roots"] if found(r) > SAME_TOL]
        for r in lost:
            problems.append(
                f"lost_root: Newton root {np.round(r, 12).tolist()} not among the solutions "
                f"(nearest {found(r):.2e}, sigma_min "
                f"{smallest_singular_value(model, frame, r, case.lock_idx):.2e})"
            )
        rec["lost_newton"] = len(lost)
        lost_roots += lost
    if case.oracle is not None:
        rec["oracle"] = len(case.oracle)
        lost = [r for r in case.oracle if found(r) > SAME_TOL]
        for r in lost:
            problems.append(f"lost_root: closed-form solution {np.round(r, 12).tolist()} not among the solutions (nearest {found(r):.2e})")
        extra = [s for s in sols if min((value_distance(model, s, r) for r in case.oracle), default=math.inf) > SAME_TOL]
        for s in extra:
            problems.append(f"extra: solution {np.round(s, 12).tolist()} is not in the closed form")
        rec["lost_oracle"] = len(lost)
        lost_roots += [r for r in lost if all(value_distance(model, r, x) > SAME_TOL for x in lost_roots)]
    if case.values is not None:
        d = found(case.values)
        rec["gen_distance"] = d
        if d > SAME_TOL:
            problems.append(
                f"lost_generator: the generating configuration is not among the "
                f"{len(sols)} solutions (nearest {d:.2e}, sigma_min "
                f"{smallest_singular_value(model, frame, case.values, case.lock_idx):.2e})"
            )
            if all(value_distance(model, case.values, x, keep) > SAME_TOL for x in lost_roots):
                lost_roots.append(case.values)
    rec["lost"] = len(lost_roots)
    if not res.complete and lost_roots:
        # an incomplete search proves nothing missing: its misses are not counted as lost roots
        problems[:] = [
            p.replace("lost_root:", "incomplete: (missing)").replace("lost_generator:", "incomplete: (missing)") for p in problems
        ]
        rec["missing_incomplete"], rec["lost"] = rec["lost"], 0
    if slow_s is not None and rec["cpu_s"] > slow_s:
        problems.append(f"slow: {rec['cpu_s']:.2f} s CPU > {slow_s} s")
    rec["problems"] = problems
    tags = {p.split(":", 1)[0] for p in problems}
    rec["status"] = next(s for s in STATUS_ORDER if s in tags or s == "ok")
    return rec


def replay_command(cls: str, seed: int, gauge: str | None = None) -> str:
    """The command that runs case (cls, seed) again (``gauge``: the ``gauge_arg`` it was made with)."""
    g = f" --gauge {gauge}" if gauge else ""
    return f"python scripts/fuzz_sweep.py --classes {cls} --seed {seed} --poses-per-class 1{g} -v"
