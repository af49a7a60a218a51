"""Inverse kinematics of a serial arm: one system per arm and frame, bound per goal pose.

An arm whose frame hangs from the base through six one-degree-of-freedom joints (revolute,
continuous or prismatic; locked joints are constants, joints off the path are left out) has
an IK problem that is a closed loop of six joints through the goal. :class:`ArmTemplate`
writes it once from the arm's geometry (read off Pinocchio at the reference configuration),
with the goal as parameters (:mod:`kinbox.formulation.template`); :meth:`ArmTemplate.bind`
gives the system of one pose.

**Frames from the geometry, not from the URDF.** Each joint is a line in space. Joint ``i``
gets a *canonical* frame ``C_i``: ``z`` on its line, ``x`` along the common normal to line
``i+1``, origin at the foot of that normal (the Denavit-Hartenberg frames; for parallel lines
the normal goes through the previous foot, so that the offset along the line is zero). The
link between two joints is then the constant ``L_i`` with ``C_{i+1} = C_i L_i Rz(theta_{i+1})
Tz(d_{i+1})``, where ``theta = q + gamma`` absorbs the zero offset of the URDF. ``L_i`` is computed
exactly from the frames (``C_i^-1 C_{i+1}``) and is ``Tx(a) Rx(alpha)`` when the geometry is that
of a DH table: zero offsets, right angles and intersecting or parallel axes give zero entries,
so the equations only hold the terms the geometry needs. (Written in the URDF's own frames, a
random 6R arm had 1100 terms and took 10-60 s per pose; in these frames, 400 terms.)

**The loop split at two joints.** Call the joints 1..6 from the base. Joint 1 turns everything
about line 1; joint 4 turns the far side about line 4. The system uses neither as a search
variable:

* chain A, joints 2 and 3, is written in the frame of link 1 (``C_1``): it places line 4 (a
  point ``p`` on it, the foot of the normal from line 3, and its direction ``z4``), depending on
  ``theta_2, theta_3`` only;
* chain B, joints 6 and 5 backwards from the goal, is written in the frame of link 6 (the goal
  frame ``G``): it places line 4 too (the same point, ``z4``, and link 4's ``x`` axis),
  depending on ``theta_5, theta_6`` only;
* joint 1 is the rotation about ``z`` that maps chain A's line onto chain B's, in the frame of
  the base: ``Rz(theta_1) p_A = R_G p_B + t_G`` and ``Rz(theta_1) z4_A = R_G z4_B`` (six core
  equations, bilinear in ``(c_1, s_1)``); joint 4 is the angle between chain A's ``x`` axis at
  line 4 and chain B's (two core equations defining ``c_4, s_4``).

The search splits only ``theta_2, theta_3, theta_5, theta_6`` (four angles instead of six);
``c_1, s_1, c_4, s_4`` and the rotation entries are derived (tag ``aux``). What does not depend
on ``theta_1`` gives redundant equations between the two chains (Raghavan and Roth's
invariants): ``|p|^2``, ``p . z4`` and ``(p x z4) . z`` computed on either side. Where the
geometry decouples, so does the system: for a spherical wrist (lines 4, 5, 6 through one point)
chain B's ``p`` is a constant and the position equations hold chain A and joint 1 only.

Parameters (the goal): ``G = C_0^-1 M_goal E^-1`` (``C_0`` the base's canonical frame, ``E``
the frame's offset from ``C_6``); ``p = [1, R_G (9), t_G (3), R_G^T t_G (3), |t_G|^2,
R_G^T (e_z x t_G) (3)]``.

Orientation of the loop: the formulation is written from the base (root joint 1, cut joint 4)
or, when joint 1 or 4 is prismatic, for the reversed chain (root joint 6, cut joint 3; the goal
inverted). Arms with another number of joints, or other joint types, use the general
formulation (:func:`kinbox.formulation.build.formulate`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction
from typing import ClassVar, Protocol

import numpy as np
import pinocchio as pin

from ..errors import FormulationError, finite_vector
from ..model.mechanism import Mechanism
from . import enclose, pairs
from .errfloat import EF, err, keep, num
from .pairs import wrap_angle
from .system import Expr, as_expr, made_before, terms_key
from .template import BoundSystem, PExpr, Template, padd, pneg

#: lines closer to parallel than this (sine of their angle) get a normal through a chosen point
PARALLEL = 1e-6
#: lengths below this (relative to the arm's size) are zero: points that coincide
SAME = 1e-12
#: lines this close to one point (relative to the arm's size) meet there, for the choice of
#: which end of the chain is the base (a choice only: either end gives the same solutions)
CONCURRENT = 1e-9
#: entries of the constant link matrices (and offsets along a joint) below this share of 1 (of
#: the arm's size for lengths) are zero: the rounding of the canonical frames computed from
#: Pinocchio's joint lines (a few ulps), no more. A structure that holds only to more than that
#: (a right angle written to 15 digits, an offset of 1e-12 m) is the user's model and kept as
#: given: snapped, it changed the model, and the certificates were of the snapped arm (a KR6
#: 1e-10 from its wrist singularity: certified roots 1e-3 rad from the roots of its URDF;
#: tests/formulation/test_enclosures.py::test_a_near_right_angle_is_kept_as_given)
SNAP = 8 * 2.0**-53
#: half-width of the domain of the factor ``lam`` of the direction coupling (1 at solutions)
LAM_RANGE = 1e-6
#: indices into the parameter vector
P_R, P_T, P_U, P_TT, P_V, NPARAMS = 1, 10, 13, 16, 17, 20


def _pr(r: int, k: int) -> int:
    return P_R + 3 * r + k


# ----------------------------------------------------------------------------------------------
# the chain: joints from the base to the frame, as lines at the reference configuration
# ----------------------------------------------------------------------------------------------
@dataclass
class ChainJoint:
    jid: int
    name: str
    kind: str  # "revolute" | "prismatic"
    idx_q: int
    nq: int
    lo: float  # limits of q (revolute continuous: -inf, inf)
    hi: float
    unbounded: bool
    point: np.ndarray  # a point of the line, base coordinates, reference configuration
    axis: np.ndarray  # unit direction of positive motion of the frame relative to the base


@dataclass
class Chain:
    """Six moving joints from the base to the frame (base coordinates, reference configuration
    ``q_ref``), the poses of the base and of the frame there, and what else the model holds."""

    joints: list[ChainJoint]
    base: pin.SE3  # the base frame at q_ref (identity: the coordinates are the base's)
    tool: pin.SE3  # the frame at q_ref
    q_ref: np.ndarray
    locked: dict[int, np.ndarray]
    dropped: list[str]
    reversed: bool = False

    def reverse(self) -> Chain:
        """The same loop seen from the frame: joints in reverse order, each moving the base
        relative to the frame (its axis flipped); the goal becomes its inverse."""
        js = [
            ChainJoint(j.jid, j.name, j.kind, j.idx_q, j.nq, j.lo, j.hi, j.unbounded, j.point.copy(), -j.axis)
            for j in reversed(self.joints)
        ]
        return Chain(js, self.tool, self.base, self.q_ref, self.locked, self.dropped, not self.reversed)


def serial_chain(mech: Mechanism, frame: str, base: str | None = None) -> Chain | None:
    """The chain from ``base`` (default: the world) to ``frame`` if it is six moving revolute or
    prismatic joints (others locked), else None (the general formulation applies)."""
    model = mech.model
    ja, pa = mech.frame_anchor(frame)
    jb, pb = mech.frame_anchor(base or "universe")
    parents = [int(p) for p in model.parents]

    def up(j):
        out = []
        while j != 0:
            out.append(j)
            j = parents[j]
        return out

    ua, ub = up(ja), up(jb)
    common = set(ua) & set(ub)
    down = [j for j in ua if j not in common][::-1]  # from the common ancestor to the frame
    rise = [j for j in ub if j not in common]  # from the base up to the common ancestor
    locked = mech.locked_q()
    q_ref = pin.neutral(model)
    for jid, v in locked.items():
        j = model.joints[jid]
        q_ref[j.idx_q : j.idx_q + j.nq] = v
    data = model.createData()
    pin.forwardKinematics(model, data, q_ref)
    Mb = data.oMi[jb] * pb
    Mbinv = Mb.inverse()
    joints = []
    for jid, sign in [(j, -1.0) for j in rise] + [(j, 1.0) for j in down]:
        if jid in locked:
            continue
        jm = model.joints[jid]
        try:
            parts = pairs.joint_parts(jm, model.names[jid])
        except FormulationError:  # a joint the pairs do not write
            return None
        if len(parts) != 1 or parts[0].kind not in ("revolute", "prismatic"):
            return None
        part = parts[0]
        assert part.axis is not None  # revolute and prismatic parts have one
        M = Mbinv * data.oMi[jid]
        axis = M.rotation @ (part.axis / np.linalg.norm(part.axis))
        iq = part.idx_q
        lo, hi = float(model.lowerPositionLimit[iq]), float(model.upperPositionLimit[iq])
        if part.unbounded:
            lo, hi = -math.inf, math.inf
        joints.append(
            ChainJoint(jid, model.names[jid], part.kind, iq, part.nq, lo, hi, part.unbounded, np.array(M.translation), sign * axis)
        )
    if len(joints) != 6:
        return None
    on_path = set(rise) | set(down)
    dropped = [model.names[j] for j in range(1, model.njoints) if j not in on_path and j not in locked]
    tool = Mbinv * (data.oMi[ja] * pa)
    return Chain(joints, pin.SE3.Identity(), tool, q_ref, locked, dropped)


# ----------------------------------------------------------------------------------------------
# canonical frames
# ----------------------------------------------------------------------------------------------
def _perpendicular(u: np.ndarray) -> np.ndarray:
    e = np.zeros(3)
    e[int(np.argmin(np.abs(u)))] = 1.0
    v = e - (e @ u) * u
    return v / np.linalg.norm(v)


def _unit_perp(v: np.ndarray, u: np.ndarray, tol: float) -> np.ndarray | None:
    v = v - (v @ u) * u
    n = float(np.linalg.norm(v))
    return v / n if n > tol else None


def _common_normal(p1, u1, p2, u2, ref, tol):
    """(foot on line 1, foot on line 2, unit x) of the common normal of two lines; for lines
    parallel to :data:`PARALLEL`, the normal through the point of line 1 nearest ``ref``."""
    n = np.cross(u1, u2)
    nn = float(np.linalg.norm(n))
    if nn > PARALLEL:
        t1, t2, _ = np.linalg.solve(np.column_stack([u1, -u2, n]), p2 - p1)
        f1, f2 = p1 + t1 * u1, p2 + t2 * u2
        x = _unit_perp(f2 - f1, u1, tol)
        if x is None:  # the lines meet: x along u1 x u2
            x = _unit_perp(n, u1, 0.0)
        return f1, f2, x
    f1 = p1 + ((ref - p1) @ u1) * u1
    f2 = p2 + ((f1 - p2) @ u2) * u2
    x = _unit_perp(f2 - f1, u1, tol)
    return f1, f2, (x if x is not None else _perpendicular(u1))


def _frame(o, z, x) -> pin.SE3:
    x = x - (x @ z) * z
    x = x / np.linalg.norm(x)
    return pin.SE3(np.column_stack([x, np.cross(z, x), z]), np.asarray(o, dtype=float))


@dataclass
class Link:
    """``L = (R, t)``: from joint ``i``'s frame (after its motion) to joint ``i+1``'s before."""

    R: np.ndarray
    t: np.ndarray


@dataclass
class Geometry:
    """The chain in canonical frames: ``C_1(theta) = C_0 Rz(theta_1)`` (or ``Tz`` for a prismatic
    joint), ``C_{i+1} = C_i L_i Rz(theta_{i+1}) Tz(d_{i+1})``, frame ``= C_6 E``; ``theta_i = q_i +
    gamma_i`` (revolute), displacement ``q_i + d_i`` (prismatic, whose ``gamma_i`` is constant)."""

    chain: Chain
    C0: pin.SE3
    links: list[Link]  # L_1 .. L_5
    gamma: np.ndarray  # per joint
    d: np.ndarray  # per joint
    E: pin.SE3
    scale: float
    #: the canonical frames (binary64), for the enclosures of the constants
    #: (:mod:`kinbox.formulation.constants`)
    frames: list[pin.SE3] | None = None

    def goal_frame(self, goal: pin.SE3) -> pin.SE3:
        """Where a goal pose (the frame's pose in the base frame) puts ``C_6``, in the frame
        of ``C_0`` (for a reversed chain, the inverse pose)."""
        return self.C0.inverse() * self.chain.base * self.oriented(goal) * self.E.inverse()

    def oriented(self, goal: pin.SE3) -> pin.SE3:
        """The goal as this chain's loop sees it: inverted for a reversed chain."""
        return goal if not self.chain.reversed else goal.inverse()


def canonical(chain: Chain) -> Geometry:
    js = chain.joints
    pts = [j.point for j in js] + [chain.tool.translation, chain.base.translation]
    scale = max(1.0, float(max(np.linalg.norm(p) for p in pts)))
    tol = SAME * scale
    u = [j.axis / np.linalg.norm(j.axis) for j in js]
    p = [j.point for j in js]
    frames: list[pin.SE3] = []
    ref = p[0]
    incoming = None
    for i in range(6):
        if i < 5:
            f1, f2, x = _common_normal(p[i], u[i], p[i + 1], u[i + 1], ref, tol)
            frames.append(_frame(f1, u[i], x))
            ref, incoming = f2, f2
        else:
            x = _unit_perp(frames[-1].rotation[:, 0], u[5], 1e-6)
            frames.append(_frame(incoming, u[5], x if x is not None else _perpendicular(u[5])))
    links, gamma, d = [], np.zeros(6), np.zeros(6)
    for i in range(5):
        M = frames[i].inverse() * frames[i + 1]
        R, t = M.rotation, M.translation
        g = math.atan2(-R[0, 1], R[0, 0])
        z = R[:, 2]
        dd = float(t @ z)
        LR = R @ rotz(-g)
        Lt = t - dd * z
        links.append(Link(pairs.snap(LR, SNAP), pairs.snap(Lt, SNAP * scale)))
        gamma[i + 1] = g
        d[i + 1] = 0.0 if abs(dd) < SNAP * scale else dd
    E = frames[5].inverse() * chain.tool
    return Geometry(chain, frames[0], links, gamma, d, E, scale, frames)


def _rotz_enclosed(a: float) -> np.ndarray:
    """:func:`rotz` with each entry an :class:`EF` of its rounding (the exact ``Rz(a)``)."""
    R = rotz(a)
    out = np.empty((3, 3), dtype=object)
    for i in range(3):
        for j in range(3):
            out[i, j] = EF(R[i, j], 2.0**-52) if R[i, j] not in (0.0, 1.0) else R[i, j]
    return out


def _enclosed_links(geom: Geometry, radii: dict | None) -> list[Link] | None:
    """The links as :class:`EF` arrays with the radii of
    :func:`kinbox.formulation.constants.enclose_links` (None without them)."""
    if radii is None:
        return None
    out = []
    for L, (rR, rt) in zip(geom.links, radii["links"]):
        R = np.empty((3, 3), dtype=object)
        t = np.empty(3, dtype=object)
        for i in range(3):
            t[i] = EF(L.t[i], rt[i])
            for j in range(3):
                R[i, j] = EF(L.R[i, j], rR[i, j])
        out.append(Link(R, t))
    return out


def rotz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


# ----------------------------------------------------------------------------------------------
# frames of expressions
# ----------------------------------------------------------------------------------------------
@dataclass
class _XFrame:
    R: list  # 3x3 of Expr | float
    o: list  # 3 of Expr | float

    @staticmethod
    def identity() -> _XFrame:
        return _XFrame([[1.0 if r == k else 0.0 for k in range(3)] for r in range(3)], [0.0, 0.0, 0.0])

    def col(self, k: int) -> list:
        return [self.R[r][k] for r in range(3)]

    def times(self, R: np.ndarray, t: np.ndarray) -> _XFrame:
        """``self * (R, t)`` for constants."""
        return _XFrame(pairs.mat_mul_const(self.R, R), pairs.vadd(self.o, pairs.mat_vec_const(self.R, t)))


# ----------------------------------------------------------------------------------------------
# the template
# ----------------------------------------------------------------------------------------------
@dataclass
class _JointVars:
    c: Expr | None = None
    s: Expr | None = None
    d: Expr | None = None


@dataclass
class ArmTemplate:
    """The IK system of one arm and frame, for any goal pose (see the module docstring)."""

    kind: ClassVar[str] = "arm"
    mechanism: Mechanism
    geometry: Geometry
    template: Template
    jvars: list[_JointVars]
    defs: list[tuple[int, PExpr]]  # aux variable index -> its definition, in creation order
    joint_vars: dict[str, list[str]]
    dropped_joints: list[str]
    fixed: dict[int, float] = field(default_factory=dict)  # variable index -> its value at solutions
    #: radii of the model's exact constants (:func:`kinbox.formulation.constants.enclose_links`),
    #: None where they are not enclosed
    constants: dict | None = None

    # -- goal --------------------------------------------------------------------------------
    def params(self, goal: pin.SE3) -> np.ndarray:
        """The parameter vector of a goal pose (the frame's pose in the base frame)."""
        return self.params_enclosure(goal)[0]

    def params_enclosure(self, goal: pin.SE3) -> tuple[np.ndarray, np.ndarray]:
        """The parameter vector of a goal pose and the radius of each entry's enclosure of its
        exact value: the pose as given (:mod:`kinbox.formulation.enclose`), composed with the
        arm's constant frames (``C_0``, the base, ``E`` in binary64) and rounded once; the
        distance of those frames to the model's exact ones (:attr:`constants`) is added."""
        g = self.geometry
        if enclose.EXT is None:
            p, rad = self._params_exact(goal)
        else:
            M = enclose.ExtFrame.pose(goal)
            if g.chain.reversed:
                M = M.inverse()
            A = enclose.ExtFrame.constant(g.C0).inverse() * enclose.ExtFrame.constant(g.chain.base)
            G = A * (M * enclose.ExtFrame.constant(g.E).inverse())
            R, t, MR, Mt = G.R, G.t, G.MR, G.Mt
            v = np.array([-t[1], t[0], t[2] * 0], dtype=enclose.EXT)
            Mv = np.array([Mt[1], Mt[0], Mt[2] * 0], dtype=enclose.EXT)
            vals = np.concatenate([[1], R.ravel(), t, R.T @ t, [t @ t], R.T @ v])
            mags = np.concatenate([[1], MR.ravel(), Mt, MR.T @ Mt, [Mt @ Mt], MR.T @ Mv])
            p, rad = enclose.ext_rounded(vals, mags)
        p[0] = 1.0
        if self.constants is not None:
            rad = rad + self._constants_radius(goal, p)
        rad[0] = 0.0
        return p, rad

    def _constants_radius(self, goal: pin.SE3, p: np.ndarray) -> np.ndarray:
        """How far the parameters may move when ``C_0^-1 base`` and ``E^-1`` are the model's
        exact frames instead of the binary64 ones (their radii: :attr:`constants`): first
        and second order terms of the products, in binary64 widened by a relative 1e-10."""
        g = self.geometry
        assert self.constants is not None
        (rAR, rAt), (rBR, rBt) = self.constants["A"], self.constants["B"]
        A = g.C0.inverse() * g.chain.base
        B = g.E.inverse()
        M = g.oriented(goal)
        aAR, aBR, aMR = np.abs(A.rotation), np.abs(B.rotation), np.abs(M.rotation)
        dR = rAR @ aMR @ aBR + aAR @ aMR @ rBR + rAR @ aMR @ rBR
        v = np.abs(M.rotation @ B.translation + M.translation)
        d1 = aMR @ rBt
        dt = rAR @ (v + d1) + aAR @ d1 + rAt
        R = np.abs(p[P_R : P_R + 9].reshape(3, 3))
        t = np.abs(p[P_T : P_T + 3])
        w = np.array([t[1], t[0], 0.0])
        dw = np.array([dt[1], dt[0], 0.0])
        out = np.zeros(NPARAMS)
        out[P_R : P_R + 9] = dR.ravel()
        out[P_T : P_T + 3] = dt
        out[P_U : P_U + 3] = dR.T @ (t + dt) + R.T @ dt
        out[P_TT] = 2.0 * t @ dt + dt @ dt
        out[P_V : P_V + 3] = dR.T @ (w + dw) + R.T @ dw
        return out * (1.0 + 1e-10)

    def params_binary64(self, goal: pin.SE3) -> np.ndarray:
        """The parameters computed in binary64 alone, without an enclosure: what
        ``benchmarks/enclosures.py`` compares :meth:`params_enclosure` and its rows against."""
        G = self.geometry.goal_frame(goal)
        R, t = G.rotation, G.translation
        p = np.empty(NPARAMS)
        p[0] = 1.0
        p[P_R : P_R + 9] = R.ravel()
        p[P_T : P_T + 3] = t
        p[P_U : P_U + 3] = R.T @ t
        p[P_TT] = float(t @ t)
        p[P_V : P_V + 3] = R.T @ np.array([-t[1], t[0], 0.0])
        return p

    def _params_exact(self, goal: pin.SE3) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`params_enclosure` in exact rational arithmetic (no extended type)."""
        g = self.geometry
        M = enclose.pose_exact(goal)
        if g.chain.reversed:
            M = enclose.inverse(M)
        G = enclose.compose(
            enclose.compose(enclose.inverse(enclose.frame_exact(g.C0)), enclose.frame_exact(g.chain.base)),
            enclose.compose(M, enclose.inverse(enclose.frame_exact(g.E))),
        )
        R, t = G
        Rt = [[R[k][r] for k in range(3)] for r in range(3)]
        v = [-t[1], t[0], t[2] * 0]
        vals = [Fraction(1)] + [R[r][k] for r in range(3) for k in range(3)] + list(t)
        vals += [sum((Rt[r][k] * t[k] for k in range(3)), Fraction(0)) for r in range(3)]
        vals += [sum((a * a for a in t), Fraction(0))]
        vals += [sum((Rt[r][k] * v[k] for k in range(3)), Fraction(0)) for r in range(3)]
        return enclose.rounded(vals)

    def param_magnitudes(self, goal: pin.SE3) -> np.ndarray:
        """Bounds on the size of each parameter and of the terms it was computed from: the
        rounding of :meth:`params` is a few ulps of these (a translation that cancels in the
        product of the four poses is still off by ulps of the translations it summed)."""
        g = self.geometry
        M = g.oriented(goal)
        tmag = sum(float(np.linalg.norm(T.translation)) for T in (g.C0, g.chain.base, M, g.E))
        m = np.empty(NPARAMS)
        m[0] = 1.0
        m[P_R : P_R + 9] = 1.0
        m[P_T : P_T + 3] = tmag
        m[P_U : P_U + 3] = 3.0 * tmag
        m[P_TT] = 3.0 * tmag * tmag
        m[P_V : P_V + 3] = 3.0 * tmag
        return m

    def bind(self, goal: pin.SE3) -> BoundSystem:
        """The system of one goal pose: numbers bound into the compiled rows built once."""
        p, prad = self.params_enclosure(goal)
        return self.template.bind(p, self.param_magnitudes(goal), prad)

    def formulation(self, mechanism: Mechanism, goal: pin.SE3) -> ArmFormulation:
        """What the answer stage needs for one pose: ``mechanism`` (this arm with the goal as a
        closure, for the residuals), the bound system, and ``encode``/``decode``."""
        return ArmFormulation(mechanism, self.bind(goal), self.dropped_joints, self.joint_vars, self, goal)

    # -- joint values ----------------------------------------------------------------------------
    def decode(self, x: np.ndarray, goal: pin.SE3 | None = None) -> np.ndarray:
        """The Pinocchio ``q`` of a system point (every joint has variables: the goal is not
        needed)."""
        g = self.geometry
        x = np.asarray(x, dtype=float)
        q = g.chain.q_ref.copy()
        for j, jv, gam, dd in zip(g.chain.joints, self.jvars, g.gamma, g.d):
            if j.kind == "prismatic":
                assert jv.d is not None
                q[j.idx_q] = jv.d.value(x) - dd
                continue
            assert jv.c is not None and jv.s is not None
            put_angle(q, j, math.atan2(jv.s.value(x), jv.c.value(x)) - gam)
        return q

    def admissible(self, x: np.ndarray, goal: pin.SE3, width: float = 0.0) -> bool:
        """Always: every joint's limits are rows of the system."""
        return True

    def encode(self, q: np.ndarray, goal: pin.SE3) -> np.ndarray:
        """The system point of a configuration ``q`` (exact when ``q`` reaches ``goal``)."""
        g = self.geometry
        model = self.mechanism.model
        q = finite_vector(q, model.nq, "q", f"model {self.mechanism.name!r} has nq = {model.nq}")
        x = np.zeros(self.template.n)
        for i, val in self.fixed.items():
            x[i] = val
        for j, jv, gam, dd in zip(g.chain.joints, self.jvars, g.gamma, g.d):
            if j.kind == "prismatic":
                assert jv.d is not None
                x[var_index(jv.d)] = q[j.idx_q] + dd
                continue
            th = get_angle(q, j) + gam
            for v, f in ((jv.c, math.cos), (jv.s, math.sin)):
                if v is not None and _is_var(v):
                    x[var_index(v)] = f(th)
        p = self.params(goal)
        for i, e in self.defs:
            x[i] = sum(p[k] * v.value(x) for k, v in e.items())
        return x


def get_angle(q: np.ndarray, j: ChainJoint) -> float:
    """A revolute joint's angle in Pinocchio's ``q`` (from (cos, sin) for a continuous joint)."""
    return math.atan2(q[j.idx_q + 1], q[j.idx_q]) if j.unbounded else float(q[j.idx_q])


def put_angle(q: np.ndarray, j: ChainJoint, angle: float) -> None:
    """Write a revolute joint's angle into Pinocchio's ``q``: (cos, sin) for a continuous
    joint, else the turn of it inside the joint's limits (if one is)."""
    if j.unbounded:
        q[j.idx_q : j.idx_q + 2] = [math.cos(angle), math.sin(angle)]
    else:
        q[j.idx_q] = wrap_angle(angle, j.lo, j.hi)


class PoseTemplate(Protocol):
    """An arm's system built once, for the configurations of one goal pose at a time."""

    @property
    def kind(self) -> str: ...

    def encode(self, q: np.ndarray, goal: pin.SE3) -> np.ndarray: ...

    def decode(self, x: np.ndarray, goal: pin.SE3 | None = None) -> np.ndarray: ...

    def admissible(self, x: np.ndarray, goal: pin.SE3, width: float = 0.0) -> bool: ...


@dataclass
class ArmFormulation:
    """An arm template's system of one pose (:class:`ArmTemplate`, or the invariants of
    :mod:`kinbox.formulation.arm_invariants`), with the interface of
    :class:`~kinbox.formulation.build.Formulation` that the answer stage uses."""

    mechanism: Mechanism
    system: BoundSystem
    dropped_joints: list[str]
    joint_vars: dict[str, list[str]]
    arm: PoseTemplate
    goal: pin.SE3
    closure_vars: dict[str, list[str]] = field(default_factory=dict)

    @property
    def kind(self) -> str:
        """``"arm"`` or ``"invariants"``: the template's."""
        return self.arm.kind

    def encode(self, q: np.ndarray) -> np.ndarray:
        return self.arm.encode(q, self.goal)

    def decode(self, x: np.ndarray) -> np.ndarray:
        return self.arm.decode(x, self.goal)

    #: joint limits are checked at each root (:meth:`admissible`): a joint may have no variable
    limits_after = True

    def admissible(self, x: np.ndarray, width: float = 0.0) -> bool:
        """Are a root's joint values inside the limits that the search did not keep to?"""
        return self.arm.admissible(x, self.goal, width)


def _is_var(e) -> bool:
    return isinstance(e, Expr) and len(e.terms) == 1 and next(iter(e.terms)) != () and len(next(iter(e.terms))) == 1


def var_index(e: Expr) -> int:
    """The index of the variable an expression is (``Expr.var(i)``)."""
    (k,) = next(iter(e.terms))
    return k


class _Builder:
    """Writes the template (see the module docstring for the equations)."""

    def __init__(self, geom: Geometry, links: list[Link] | None = None):
        self.g = geom
        #: the links the rows are written from: ``geom.links``, or the same numbers as
        #: :class:`~kinbox.formulation.errfloat.EF` with the radii of the model's exact links
        self.links = links if links is not None else geom.links
        self.T = Template(NPARAMS)
        self.defs: list[tuple[int, PExpr]] = []
        self.jv = [_JointVars() for _ in range(6)]
        self.fixed: dict[int, float] = {}  # variables with one value at every solution
        self.names = [j.name for j in geom.chain.joints]
        self.made: dict[tuple, int] = {}  # the terms of an entry made a variable -> that variable
        self.made_from: dict[int, Expr] = {}  # that variable -> the entry

    # -- variables -----------------------------------------------------------------------------
    def angle(self, i: int, tag_aux: bool = False) -> tuple[Expr, Expr]:
        j = self.g.chain.joints[i]
        lo, hi = j.lo + self.g.gamma[i], j.hi + self.g.gamma[i]
        c, s = pairs.revolute_angle(self.T, self.names[i], lo, hi, j.unbounded)
        if tag_aux:  # derived from the coupling; its circle is redundant (written by the caller)
            for v in (c, s):
                self.T.vars.tags[var_index(v)] = "aux"
        else:
            pairs.add_eq(self.T, c * c + s * s - 1.0, f"circle:{self.names[i]}")
        self.jv[i].c, self.jv[i].s = c, s
        return c, s

    def displacement(self, i: int) -> Expr:
        j = self.g.chain.joints[i]
        dd = self.g.d[i]
        v = pairs.displacement(self.T.vars, f"d[{self.names[i]}]", self.names[i], j.lo + dd, j.hi + dd)
        self.jv[i].d = v
        return v

    def aux(self, name: str, definition: PExpr, lo: float = -1.0, hi: float = 1.0) -> Expr:
        v = self.T.add_var(name, lo, hi, "aux")
        self.T.add_eq(padd(v, pneg(definition)), f"def:{name}")
        self.defs.append((var_index(v), definition))
        return v

    def linear_entries(self, vec: list, stem: str, labels, unit: bool = True) -> list:
        """Entries of degree 2 replaced by new variables: in ``[-1, 1]`` for entries of unit
        vectors (``unit``), else in the range of the entry over the variables' domain (a
        position can be longer than 1: a bound of 1 there cut true roots off).

        An entry made a variable before, or its negative, is that variable again (as
        :meth:`System.materialize`): joints about parallel lines turn a frame about one axis,
        and of the four entries that move, two are the other two up to sign (a UR's chain A)."""
        out = []
        for r, e in enumerate(vec):
            if pairs.deg(e) <= 1:
                out.append(e)
                continue
            found = made_before(self.made, e)
            if found is not None:
                # the variable stands for the expression it was made of: the two are the same
                # numbers, their exact values within both errors (a term of zero value each)
                first = self.made_from[found[0]]
                gap = {k: EF(0.0, err(e.terms.get(k, 0.0)) + err(first.terms.get(k, 0.0))) for k in set(e.terms) | set(first.terms)}
                gap = {k: v for k, v in gap.items() if v.err > 0.0}
                out.append(found[1] * Expr.var(found[0]) + Expr(gap) if gap else found[1] * Expr.var(found[0]))
                continue
            b = 1.0 if unit else self.magnitude(e)
            v = self.aux(f"{stem}[{labels[r]}]", {0: e}, -b, b)
            self.made[terms_key(e.terms, 1.0)] = var_index(v)
            self.made_from[var_index(v)] = e
            out.append(v)
        return out

    def magnitude(self, e) -> float:
        """An upper bound of ``|e|`` over the domain (:meth:`System.size`), widened by a
        relative 1e-12 for the rounding of that sum."""
        return self.T.vars.size(as_expr(e)) * (1.0 + 1e-12) + 1e-300

    def materialize(self, F: _XFrame, stem: str) -> _XFrame:
        """``F`` with its rotation made linear (columns 0 and 1 of degree 2 become variables),
        and the redundant ``|u| = |v| = 1``, ``u . v = 0``."""
        if max(pairs.deg(a) for row in F.R for a in row) <= 1:
            return F
        cols = [F.col(k) for k in range(3)]
        for k in (0, 1):
            if max(pairs.deg(a) for a in cols[k]) > 1:
                cols[k] = self.linear_entries(cols[k], stem, [f"{r},{'xy'[k]}" for r in range(3)])
        if max(pairs.deg(a) for a in cols[2]) > 1:  # pragma: no cover - z columns are never rotated here
            cols[2] = self.linear_entries(cols[2], stem, [f"{r},z" for r in range(3)])
        u, v = cols[0], cols[1]
        pairs.add_eq(self.T, pairs.vdot(u, u) - 1.0, f"unit:{stem}[x]", redundant=True)
        pairs.add_eq(self.T, pairs.vdot(v, v) - 1.0, f"unit:{stem}[y]", redundant=True)
        pairs.add_eq(self.T, pairs.vdot(u, v), f"ortho:{stem}", redundant=True)
        R = [[cols[k][r] for k in range(3)] for r in range(3)]
        return _XFrame(R, F.o)

    # -- motions -------------------------------------------------------------------------------
    def joint(self, F: _XFrame, i: int, backwards: bool) -> _XFrame:
        """``F * Rz(theta_i) Tz(d_i)`` (or ``F * (Rz Tz)^-1`` backwards) for a linear ``F``; a
        rotation that comes out bilinear is made linear at once, in the joint's own frame
        (where only its columns ``x`` and ``y`` move)."""
        j = self.g.chain.joints[i]
        if j.kind == "prismatic":
            dv = self.displacement(i)
            Rg = _rotz_enclosed(self.g.gamma[i])
            if backwards:  # F Tz(-d) Rz(g)^-1
                o = pairs.vadd(F.o, pairs.vscale(-1.0 * dv, F.col(2)))
                return _XFrame(pairs.mat_mul_const(F.R, Rg.T), o)
            F = _XFrame(pairs.mat_mul_const(F.R, Rg), F.o)
            return _XFrame(F.R, pairs.vadd(F.o, pairs.vscale(dv, F.col(2))))
        c, s = self.angle(i)
        dd = float(self.g.d[i])  # a Python float: numpy's scalar would drop an EF's error
        u0, u1, u2 = F.col(0), F.col(1), F.col(2)
        shift = [dd * a for a in u2] if dd else [0.0, 0.0, 0.0]
        if backwards:  # F Tz(-d) Rz(-theta)
            o = pairs.vsub(F.o, shift)
            cx = [pairs.simplify(c * a - s * b) for a, b in zip(u0, u1)]
            cy = [pairs.simplify(s * a + c * b) for a, b in zip(u0, u1)]
        else:  # F Rz(theta) Tz(d)
            cx = [pairs.simplify(c * a + s * b) for a, b in zip(u0, u1)]
            cy = [pairs.simplify(c * b - s * a) for a, b in zip(u0, u1)]
            o = pairs.vadd(F.o, shift)
        R = [[cx[r], cy[r], u2[r]] for r in range(3)]
        return self.materialize(_XFrame(R, o), f"R[{self.names[i]}]")

    # -- the system ------------------------------------------------------------------------------
    def build(self) -> None:
        g, T = self.g, self.T
        L = self.links
        # joint 1 (root) and joint 4 (cut): derived, never split
        c1, s1 = self.angle(0, tag_aux=True)
        # chain A in the frame of link 1: joints 2, 3, then link 3 up to line 4
        A = _XFrame.identity().times(L[0].R, L[0].t)
        A = self.joint(A, 1, backwards=False)
        A = A.times(L[1].R, L[1].t)
        A = self.joint(A, 2, backwards=False)
        A = A.times(L[2].R, L[2].t)  # the frame before joint 4's motion
        zA, xA, yA = A.col(2), A.col(0), A.col(1)
        dd4 = float(g.d[3])  # Python floats: numpy's scalars would drop an EF's error
        d5 = float(g.d[4])
        # the point where the coupling meets line 4: the origin of C_4 (for a spherical wrist,
        # its centre, which chain B places without variables)
        pA = pairs.vadd(A.o, [dd4 * a for a in zA]) if dd4 else A.o
        if max(pairs.deg(a) for a in pA) > 1:
            pA = self.linear_entries(pA, "pA", "xyz", unit=False)
        # chain B in the frame of link 6 (the goal frame): joints 6, 5 backwards, to joint 4
        B = _XFrame.identity()
        B = self.joint(B, 5, backwards=True)
        B = B.times(L[4].R.T, -L[4].R.T @ L[4].t)
        o5 = B.o  # origin of C_5
        B = self.joint(B, 4, backwards=True)
        B = B.times(L[3].R.T, -L[3].R.T @ L[3].t)  # frame of link 4 (after joint 4's motion)
        zB, xB = B.col(2), B.col(0)
        pB = B.o
        if max(pairs.deg(a) for a in pB) > 1:
            pB = self.linear_entries(pB, "pB", "xyz", unit=False)
        # zB . (o4 - o5), a constant: o4 = o5 - R_4 L4t - d5 z5 and z4 . z5 = L4R[2, 2]
        kappa = -(num(L[3].t[2]) + d5 * num(L[3].R[2, 2]))

        def goal_rot(v, r):  # (R_G v)_r
            return {_pr(r, k): v[k] for k in range(3) if not (isinstance(v[k], float) and not keep(v[k]))}

        def goal_point(v, r):  # (R_G v + t_G)_r
            return padd(goal_rot(v, r), {P_T + r: Expr.const(1.0)})

        # coupling through joint 1: Rz(theta_1) (pA, zA) = G (pB, lam zB), c_1^2 + s_1^2 = 1. The
        # factor lam (1 at every solution: both sides are unit vectors) keeps the core regular
        # where line 4 is parallel to line 1: without it, the scale of (c_1, s_1) stands for the
        # norm of the direction, and is lost there (Rz(theta_1) e_z = e_z whatever the scale),
        # so that regular roots with line 4 upright could not be certified. Its domain only needs
        # to hold 1 (and the roots of the rounded system next to it): a narrow one keeps the
        # relaxations of lam zB as tight as those of zB
        lam = self.T.add_var("lam", 1.0 - LAM_RANGE, 1.0 + LAM_RANGE, "aux")
        self.fixed[var_index(lam)] = 1.0
        for what, va in (("p", pA), ("z", zA)):
            for r in range(3):
                if r == 0:
                    rot = c1 * va[0] - s1 * va[1]
                elif r == 1:
                    rot = s1 * va[0] + c1 * va[1]
                else:
                    rot = va[2]
                if what == "p":
                    rhs = goal_point(pB, r)
                else:
                    rhs = {k: lam * e for k, e in goal_rot(zB, r).items()}
                T.add_eq(padd(rot, pneg(rhs)), f"couple:{what}[{'xyz'[r]}]")
        pairs.add_eq(T, c1 * c1 + s1 * s1 - 1.0, f"circle:{self.names[0]}")
        # joint 4: link 4's x axis from chain B, in the frame of link 1
        w = [goal_rot(xB, r) for r in range(3)]
        x4 = [
            self.aux(f"x4[{'xyz'[0]}]", padd({k: c1 * e for k, e in w[0].items()}, {k: s1 * e for k, e in w[1].items()})),
            self.aux(f"x4[{'xyz'[1]}]", padd({k: -1.0 * s1 * e for k, e in w[0].items()}, {k: c1 * e for k, e in w[1].items()})),
            self.aux(f"x4[{'xyz'[2]}]", w[2]),
        ]
        j4 = g.chain.joints[3]
        lo4, hi4 = j4.lo + g.gamma[3], j4.hi + g.gamma[3]
        c4, s4 = self._derived_angle(3, lo4, hi4, pairs.vdot(xA, x4), pairs.vdot(yA, x4))
        pairs.add_eq(T, c4 * c4 + s4 * s4 - 1.0, f"circle:{self.names[3]}", redundant=True)
        pairs.add_eq(T, pairs.vdot(x4, x4) - 1.0, "unit:x4", redundant=True)
        pairs.add_eq(T, pairs.vdot(x4, zA), "ortho:x4", redundant=True)
        # invariants of line 4 about line 1, from either chain
        uB = {P_U + k: pB[k] for k in range(3)}
        T.add_eq(
            padd(pairs.vdot(pA, pA), pneg(padd(pairs.vdot(pB, pB), {k: 2.0 * e for k, e in uB.items()}, {P_TT: Expr.const(1.0)}))),
            "inv:pp",
            redundant=True,
        )
        T.add_eq(padd(pairs.vdot(pA, zA), pneg(padd(pairs.vdot(pB, zB), {P_U + k: zB[k] for k in range(3)}))), "inv:pz", redundant=True)
        T.add_eq(
            padd(pairs.vdot(pA, zA), pneg(padd(pairs.vdot(zB, o5), kappa, {P_U + k: zB[k] for k in range(3)}))), "inv:pz5", redundant=True
        )
        cross_a = pA[0] * zA[1] - pA[1] * zA[0]
        pzB = pairs.vcross(pB, zB)
        cross_b = padd({_pr(2, k): pzB[k] for k in range(3)}, {P_V + k: zB[k] for k in range(3)})
        T.add_eq(padd(cross_a, pneg(cross_b)), "inv:cross", redundant=True)
        # the coupling seen from link 1 (Rz(-theta_1) G (pB, zB) = (pA, zA)) and from the goal
        # frame (G^-1 Rz(theta_1) (pA, zA) = (pB, zB)): the same equations, other monomials
        for what, va, vb, point in (("p", pA, pB, True), ("z", zA, zB, False)):
            gx = goal_point(vb, 0) if point else goal_rot(vb, 0)
            gy = goal_point(vb, 1) if point else goal_rot(vb, 1)
            T.add_eq(
                padd({k: c1 * e for k, e in gx.items()}, {k: s1 * e for k, e in gy.items()}, -1.0 * va[0]),
                f"couple1:{what}[x]",
                redundant=True,
            )
            T.add_eq(
                padd({k: -1.0 * s1 * e for k, e in gx.items()}, {k: c1 * e for k, e in gy.items()}, -1.0 * va[1]),
                f"couple1:{what}[y]",
                redundant=True,
            )
            rot = [c1 * va[0] - s1 * va[1], s1 * va[0] + c1 * va[1], va[2]]
            for k in range(3):
                e = {_pr(r, k): rot[r] for r in range(3)}
                if point:
                    e = padd(e, {P_U + k: Expr.const(-1.0)})
                T.add_eq(padd(e, -1.0 * vb[k]), f"couple6:{what}[{'xyz'[k]}]", redundant=True)
        # the loop along line 4, chain B's part written from C_5 (degree 2 only where chain A's
        # z4 or C_5's origin is constant: parallel axes 2, 3, 4, or a wrist centre at C_5)
        try:  # of degree > 2 otherwise (Expr refuses it): left out, it is redundant
            rot = [c1 * zA[0] - s1 * zA[1], s1 * zA[0] + c1 * zA[1], zA[2]]
            wpart = padd(*[{k: rot[r] * e for k, e in goal_point(o5, r).items()} for r in range(3)])
            T.add_eq(padd(pairs.vdot(pA, zA), pneg(wpart), -kappa), "proj:z4", redundant=True)
        except FormulationError:
            pass
        self.x4 = x4
        js = g.chain.joints

        def const(v):
            return all(pairs.deg(a) == 0 for a in v)

        if const(pB) and js[1].kind == "revolute" and js[2].kind == "revolute":
            # the distance from line 2 to the wrist centre (chain B's point, a constant): joint 2
            # turns the rest of chain A about line 2, so from the origin F of its frame that
            # distance depends on theta_3 alone; in the base, F is turned about line 1 by
            # theta_1. A row linear in (c_3, s_3) and in (c_1, s_1) (Pieper's), which propagation
            # uses directly where the coupling only bounds products
            c3, s3 = self.jv[2].c, self.jv[2].s
            assert c3 is not None and s3 is not None
            b = np.array([0.0, 0.0, g.d[2]]) + L[2].t + dd4 * L[2].R[:, 2]
            a = L[1].R.T @ L[1].t
            f = L[0].t + g.d[1] * L[0].R[:, 2]
            near = num(L[1].t @ L[1].t + b @ b + 2.0 * a[2] * b[2] - f @ f)
            side_a = 2.0 * num(a[0] * b[0] + a[1] * b[1]) * c3 + 2.0 * num(a[1] * b[0] - a[0] * b[1]) * s3 + near
            rzf = [num(f[0]) * c1 - num(f[1]) * s1, num(f[0]) * s1 + num(f[1]) * c1, num(f[2])]
            ww = padd(pairs.vdot(pB, pB), {k: 2.0 * e for k, e in uB.items()}, {P_TT: Expr.const(1.0)})
            wf = padd(*[{k: -2.0 * e * rzf[r] for k, e in goal_point(pB, r).items()} for r in range(3)])
            T.add_eq(padd(side_a, pneg(padd(ww, wf))), "inv:line2", redundant=True)
            # Pieper's second row: the same vector's component along line 2, which joint 2
            # does not change either: from chain A linear in (c_3, s_3), from the base, with
            # line 2 turned about line 1, linear in (c_1, s_1)
            e2 = L[0].R[:, 2]
            along_a = num(L[1].t[2] + L[1].R[2, 2] * b[2]) + num(L[1].R[2, 0] * b[0] + L[1].R[2, 1] * b[1]) * c3
            along_a = along_a + num(L[1].R[2, 1] * b[0] - L[1].R[2, 0] * b[1]) * s3
            rze = [num(e2[0]) * c1 - num(e2[1]) * s1, num(e2[0]) * s1 + num(e2[1]) * c1, num(e2[2])]
            we = padd(*[{k: e * rze[r] for k, e in goal_point(pB, r).items()} for r in range(3)])
            T.add_eq(padd(we, -num(e2 @ f), pneg({0: along_a})), "inv:axis2", redundant=True)

        # a block that decides the rest: with a wrist centre on line 4 (chain B's point is a
        # constant) the position is chain A's and joint 1's alone: split chain A first (and
        # chain B first in the mirror case). With lines 2, 3, 4 parallel (chain A's z4 is a
        # constant) it is the other way round: line 4's direction (two coupling rows) and the
        # offset along it (inv:pz) give three rows in joints 1, 5 and 6 alone, and chain A is a
        # planar two-link arm once they are known: split chain B first (chain A first in the
        # mirror case, lines 4, 5, 6 parallel)
        if const(pB) != const(pA):
            first = [1, 2] if const(pB) else [4, 5]
        elif const(zA) != const(zB):
            first = [4, 5] if const(zA) else [1, 2]
        else:
            first = []
        if first:
            ranks = [1] * T.n
            for i in first:
                for v in (self.jv[i].c, self.jv[i].s, self.jv[i].d):
                    if v is not None and _is_var(v):
                        ranks[var_index(v)] = 0
            T.vars.ranks = ranks

    def _derived_angle(self, i: int, lo: float, hi: float, cdef, sdef) -> tuple[Expr, Expr]:
        j = self.g.chain.joints[i]
        name = self.names[i]
        if pairs.revolute_is_limited(lo, hi, j.unbounded):
            from ..interval import cos_range, sin_range

            clo, chi = cos_range(lo, hi)
            slo, shi = sin_range(lo, hi)
        else:
            clo, chi, slo, shi = -1.0, 1.0, -1.0, 1.0
        c = self.aux(f"c[{name}]", {0: cdef}, clo, chi)
        s = self.aux(f"s[{name}]", {0: sdef}, slo, shi)
        self.T.vars.tags[var_index(c)] = "aux"
        self.T.vars.tags[var_index(s)] = "aux"
        if pairs.revolute_is_limited(lo, hi, j.unbounded):
            mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
            pad = 8 * np.finfo(float).eps
            pairs.add_ineq(self.T, (math.cos(half) - pad) - (c * math.cos(mid) + s * math.sin(mid)), f"limit:{name}")
        self.jv[i].c, self.jv[i].s = c, s
        return c, s


def _rooted(chain: Chain) -> bool:
    """Can the formulation be written from this chain's base: revolute root and cut joints?"""
    return chain.joints[0].kind == "revolute" and chain.joints[3].kind == "revolute"


def meet_at_a_point(joints: list[ChainJoint], tol: float) -> bool:
    """Do the lines of these revolute joints pass through one point (not all parallel)?"""
    if any(j.kind != "revolute" for j in joints):
        return False
    A, b, proj = np.zeros((3, 3)), np.zeros(3), []
    for j in joints:
        u = j.axis / np.linalg.norm(j.axis)
        P = np.eye(3) - np.outer(u, u)  # distance to the line: |P (x - point)|
        A += P
        b += P @ j.point
        proj.append((P, j.point))
    w = np.linalg.eigvalsh(A)
    if w[0] <= 1e-6 * w[-1]:
        return False  # parallel lines (their point would be at infinity)
    c = np.linalg.solve(A, b)
    return all(float(np.linalg.norm(P @ (c - p))) <= tol for P, p in proj)


def _shoulder_not_wrist(chain: Chain) -> bool:
    """Lines 1, 2, 3 meet at a point (a spherical shoulder) and lines 4, 5, 6 do not.

    The formulation uses a wrist centre (lines 4, 5, 6 through one point): the position then
    depends on chain A and joint 1 alone. A shoulder centre is the same structure seen from
    the goal, so such an arm is written for the reversed chain (a Panda with a wrist joint
    locked: docs/formulation.md, "Which end is the base")."""
    js = chain.joints
    scale = max(1.0, float(max(np.linalg.norm(j.point) for j in js)))
    tol = CONCURRENT * scale
    return meet_at_a_point(js[:3], tol) and not meet_at_a_point(js[3:], tol)


def arm_template(mech: Mechanism, frame: str, base: str | None = None) -> ArmTemplate | None:
    """The arm formulation of ``frame`` (relative to ``base``), or None if the chain is not six
    revolute/prismatic joints with revolute joints at the root and the cut."""
    chain = serial_chain(mech, frame, base)
    if chain is None:
        return None
    if not _rooted(chain) or (_shoulder_not_wrist(chain) and _rooted(chain.reverse())):
        chain = chain.reverse()
        if not _rooted(chain):
            return None
    for j in chain.joints:
        if j.kind == "prismatic" and not pairs.finite_limit(j.lo, j.hi):
            return None
    geom = canonical(chain)
    from .constants import enclose_links  # noqa: PLC0415 (mpmath's interval context, once per arm)

    radii = enclose_links(geom, mech, frame, base)
    b = _Builder(geom, _enclosed_links(geom, radii))
    b.build()
    joint_vars = {}
    for j, jv in zip(chain.joints, b.jv):
        joint_vars[j.name] = [b.T.vars.names[var_index(v)] for v in (jv.c, jv.s, jv.d) if v is not None and _is_var(v)]
    b.T.freeze()  # the expanded pattern, built once per arm and frame (not at the first pose)
    return ArmTemplate(mech, geom, b.T, b.jv, b.defs, joint_vars, chain.dropped, b.fixed, radii)
