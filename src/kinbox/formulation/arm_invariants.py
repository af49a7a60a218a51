"""Inverse kinematics of a general 6R arm: Raghavan and Roth's invariants, two joints eliminated.

An arm of six revolute joints whose axes meet neither at a wrist centre (lines 4, 5, 6) nor at a
shoulder (lines 1, 2, 3) has nothing that decouples its position from its orientation. Its
classical solution (Raghavan and Roth, 1993) splits the loop of :mod:`kinbox.formulation.arm`'s
canonical frames (``Rz(theta_1) L_1 J_2 L_2 J_3 L_3 J_4 L_4 J_5 L_5 J_6 = N``, ``N`` the goal in
the base's canonical frame, ``J_i = Rz(theta_i) Tz(d_i)``) as

    ``J_3 L_3 J_4 L_4 J_5 L_5 h = (Rz(theta_1) L_1 J_2 L_2)^-1 N Tz(-d_6) h``

for the point ``p`` (``h`` the origin) and the direction ``l`` (``h = e_z``) of line 6, which
joint 6 does not move. The left side depends on ``theta_3, theta_4, theta_5`` only, the right
side on ``theta_1, theta_2`` only, and both are of degree one in the cosine and sine of each
angle. So are the scalar invariants ``p.p``, ``p.l``, ``p x l`` and ``(p.p) l - 2 (p.l) p``: 14
equations linear in the 8 products of ``(1, c_1, s_1) x (1, c_2, s_2)``. Six combinations of
them (the left null space of those 8 columns, per pose) hold ``theta_3, theta_4, theta_5``
alone; eight more give each product of ``theta_1, theta_2`` as a function of them.

The system: ``(c_i, s_i)`` of joints 1..5, the products ``u`` of ``(c_4, s_4)`` and
``(c_5, s_5)``, the direction ``l`` of the left side and a factor ``lam`` (1 at solutions, as
in :mod:`kinbox.formulation.arm`); core rows: the circles, the definitions of ``u`` and ``l``,
``p`` equal on both sides and ``lam l`` equal to the right side's direction (square: 18 x 18).
The invariants and the per-pose combinations are redundant rows. The search splits joints 3,
4 and 5 only (three angles, against four in :mod:`kinbox.formulation.arm`): joints 1 and 2
follow from the combinations, and joint 6, which no row holds, is the rotation about line 6
that takes the rest of the chain to the goal (:meth:`InvariantsTemplate.decode`). The search
cannot keep to joint 6's limits, so the chain is taken reversed when that frees its last joint,
and otherwise the limits are checked at each root (:meth:`InvariantsTemplate.admissible`).

Coefficients: the core rows are products of the constant link matrices (exact up to a few
ulps, like :mod:`kinbox.formulation.arm`'s); the invariants are fitted on a 3 x 3 x 3 grid of
angles (checked at random angles to 1e-10) and every coefficient of the redundant rows is a
parameter of the pose, with the rounding of its computation within the redundant rows' slack
(:data:`kinbox.formulation.system.SLACK`, docs/soundness.md).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
import pinocchio as pin

from ..errors import FormulationError, finite_vector
from ..model.mechanism import Mechanism
from . import pairs
from .arm import (
    CONCURRENT,
    LAM_RANGE,
    PARALLEL,
    ArmFormulation,
    ArmTemplate,
    Chain,
    Geometry,
    _enclosed_links,
    canonical,
    get_angle,
    meet_at_a_point,
    put_angle,
    rotz,
    serial_chain,
    var_index,
)
from .errfloat import keep, num
from .system import SLACK, Expr
from .template import BoundSystem, Template

#: a root's joint 6 this far outside its limits (radians) is still kept: the rounding of a
#: polished root and of the limit, as the other joints' limit rows allow (their SLACK)
LIMIT_TOL = 1e-9
#: an uncertified root's joint 6 moves at most this many times the width of its box (a bound on
#: the sensitivity of joint 6 to the others that holds away from the arm's singularities; a
#: root kept wrongly is one answer too many, a root dropped wrongly would be lost)
LIMIT_SPREAD = 1e3
#: the three angles of the fitting grid (the basis ``1, cos, sin`` there is invertible)
GRID = (0.0, 2.0 * math.pi / 3.0, 4.0 * math.pi / 3.0)
#: relative error allowed when a fitted invariant is checked at random angles
FIT_CHECK = 1e-10

# the 4x4 parts of Rz(theta) = Z0 + c Zc + s Zs
_Z0 = np.diag([0.0, 0.0, 1.0, 1.0])
_ZC = np.diag([1.0, 1.0, 0.0, 0.0])
_ZS = np.zeros((4, 4))
_ZS[1, 0], _ZS[0, 1] = 1.0, -1.0


def _h(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The 4x4 matrix of ``(R, t)``; an object array when they hold
    :class:`~kinbox.formulation.errfloat.EF` (numpy's float array would drop their errors)."""
    obj = np.asarray(R).dtype == object or np.asarray(t).dtype == object
    T = np.eye(4, dtype=object if obj else float)
    if obj:
        T[:] = [[1.0 if i == j else 0.0 for j in range(4)] for i in range(4)]
    T[:3, :3], T[:3, 3] = R, t
    return T


def _tz(d: float) -> np.ndarray:
    T = np.eye(4)
    T[2, 3] = d
    return T


def _inv(T: np.ndarray) -> np.ndarray:
    R, t = T[:3, :3], T[:3, 3]
    return _h(R.T, -R.T @ t)


def _basis(angles) -> np.ndarray:
    """``kron`` of ``(1, cos, sin)`` over the angles (the first angle varies slowest)."""
    out: np.ndarray = np.ones(1)
    for a in angles:
        out = np.kron(out, [1.0, math.cos(a), math.sin(a)])
    return out


def _grid_inverse(k: int) -> np.ndarray:
    V = np.array([[1.0, math.cos(a), math.sin(a)] for a in GRID])
    Vi = np.linalg.inv(V)
    out: np.ndarray = np.ones((1, 1))
    for _ in range(k):
        out = np.kron(out, Vi)
    return out


def invariants(p: np.ndarray, l: np.ndarray) -> np.ndarray:
    """Raghavan and Roth's 14 quantities of a line through ``p`` along ``l``: ``p``, ``l``,
    ``p.p``, ``p.l``, ``p x l``, ``(p.p) l - 2 (p.l) p`` (along the last axis, for stacks of
    lines too)."""
    pp = np.sum(p * p, axis=-1, keepdims=True)
    pl = np.sum(p * l, axis=-1, keepdims=True)
    return np.concatenate([p, l, pp, pl, np.cross(p, l), pp * l - 2.0 * pl * p], axis=-1)


def _fit(values: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Coefficients (functions x 3^k) of functions sampled on the grid (grid points x
    functions), and the size of the terms each was summed from (the scale of its rounding)."""
    Vi = _grid_inverse(k)
    return (Vi @ values).T, (np.abs(Vi) @ np.abs(values)).T


@dataclass
class _Side:
    """One side of the split as sums over monomials: ``point[m]``, ``direction[m]`` (3-vectors
    per monomial index of ``kron(1, c, s)`` over its angles)."""

    point: np.ndarray  # (3^k, 3)
    direction: np.ndarray  # (3^k, 3)


def _left(geom: Geometry, links: list | None = None) -> _Side:
    """``J_3 L_3 J_4 L_4 J_5 L_5 h`` expanded over the monomials of joints 3, 4, 5 (``links``:
    default the geometry's; :func:`~kinbox.formulation.arm._enclosed_links` for
    :class:`~kinbox.formulation.errfloat.EF` coefficients)."""
    L = [_h(lk.R, lk.t) for lk in (links or geom.links)]
    parts = [_Z0, _ZC, _ZS]
    pts, dirs = [], []
    for a, b, c in itertools.product(range(3), repeat=3):
        M = parts[a] @ _tz(geom.d[2]) @ L[2] @ parts[b] @ _tz(geom.d[3]) @ L[3] @ parts[c] @ _tz(geom.d[4]) @ L[4]
        pts.append(M[:3, 3])
        dirs.append(M[:3, 2])
    return _Side(np.array(pts), np.array(dirs))


def _right_matrices(geom: Geometry, links: list | None = None) -> np.ndarray:
    """``P[m]`` (9 x 4 x 4) with ``(Rz(theta_1) L_1 J_2 L_2)^-1 = sum_m monomial_m(theta_1,
    theta_2) P[m]`` (``links`` as for :func:`_left`)."""
    L = [_h(lk.R, lk.t) for lk in (links or geom.links)]
    parts_t = [_Z0, _ZC, _ZS.T]  # Rz(-theta) = Z0 + c Zc - s Zs
    out = []
    for a, b in itertools.product(range(3), repeat=2):
        out.append(_inv(L[1]) @ _tz(-geom.d[1]) @ parts_t[b] @ _inv(L[0]) @ parts_t[a])
    return np.array(out)


def _left_at(side: _Side, angles) -> tuple[np.ndarray, np.ndarray]:
    m = _basis(angles)
    return m @ side.point, m @ side.direction


#: parameter layout: [1, g_p (3), g_l (3), then the redundant rows' coefficients]
P_GP, P_GL, P_ROWS = 1, 4, 7


@dataclass
class InvariantsTemplate:
    """The IK system of one general 6R arm and frame, for any goal pose (module docstring)."""

    kind: ClassVar[str] = "invariants"

    mechanism: Mechanism
    geometry: Geometry
    template: Template
    joint_vars: dict[str, list[str]]
    dropped_joints: list[str]
    angles: list[tuple[int, int]]  # (c, s) variable indices of joints 1..5
    left: _Side  # the left side over its monomials (for encode)
    left_fit: np.ndarray  # 14 x 27: the invariants of the left side
    left_mag: np.ndarray  # 14 x 27: the size of what each was summed from
    right_P: np.ndarray  # 9 x 4 x 4
    red_rows: list[tuple[str, list[int], list[int]]]  # name, left monomial params, right monomial params
    u_index: dict[tuple[int, int], int] = field(default_factory=dict)
    l_index: list[int] = field(default_factory=list)
    lam_index: int = -1
    #: the enclosure of the goal frame and of the arm's constant frames
    #: (:meth:`kinbox.formulation.arm.ArmTemplate.params_enclosure`, whose parameters 1..12 are
    #: the goal frame's rotation, row by row, and translation)
    enclosure: ArmTemplate | None = None

    # -- goal --------------------------------------------------------------------------------
    def goal_in_base(self, goal: pin.SE3) -> np.ndarray:
        return self.geometry.goal_frame(goal).homogeneous

    def right_fit(self, N: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(14 x 9 coefficients of the right side's invariants, their sizes, g_p, g_l) for
        goal ``N``."""
        gp = N @ np.array([0.0, 0.0, -self.geometry.d[5], 1.0])
        gl = N @ np.array([0.0, 0.0, 1.0, 0.0])
        P = self.right_P
        samples = []
        for a1, a2 in itertools.product(GRID, repeat=2):
            m = _basis((a1, a2))
            Q = np.tensordot(m, P, axes=1)
            samples.append(invariants((Q @ gp)[:3], (Q @ gl)[:3]))
        B, Bmag = _fit(np.array(samples), 2)
        return B, Bmag, gp[:3], gl[:3]

    def params(self, goal: pin.SE3) -> tuple[np.ndarray, np.ndarray]:
        """The parameter vector of a goal pose, and bounds on the size of what each was
        computed from (the scale of its rounding)."""
        N = self.goal_in_base(goal)
        B, Bmag, gp, gl = self.right_fit(N)
        A = self.left_fit
        p = np.zeros(self.template.nparams)
        mag = np.zeros(self.template.nparams)
        p[0] = mag[0] = 1.0
        p[P_GP : P_GP + 3], p[P_GL : P_GL + 3] = gp, gl
        tmag = float(np.abs(N[:3, 3]).sum()) + abs(self.geometry.d[5]) + 1.0
        mag[P_GP : P_GP + 3], mag[P_GL : P_GL + 3] = tmag, 1.0
        # the rows: 8 invariants as they are, 6 combinations free of joints 1 and 2, and 8
        # combinations that each give one product of theta_1, theta_2
        full = np.hstack([A, -B])  # 14 x (27 + 9): left minus right = 0
        scale_full = np.hstack([self.left_mag, Bmag]) * (1.0 + 64 * np.finfo(float).eps) + 1e-300
        B8 = B[:, 1:]
        U, _, _ = np.linalg.svd(B8)
        W = U[:, 8:]  # 14 x 6, W^T B8 = 0 up to rounding
        Pinv = np.linalg.pinv(B8, rcond=1e-9)  # 8 x 14
        combos = np.vstack([np.eye(14)[6:], W.T, Pinv])  # 22 x 14
        rows = combos @ full
        rmag = np.abs(combos) @ scale_full
        # the columns left out of a row (theta_1, theta_2 in the 6 combinations, the other
        # products in the last 8) cancel up to rounding: what is left of them, at most
        # ``left_out`` over the domain (every monomial is at most 1), goes into the size of
        # the row's constant, divided by SLACK, so that the row's slack covers it
        k = P_ROWS
        for (_name, lcols, rcols), r in zip(self.red_rows, range(len(rows))):
            cols = lcols + [27 + j for j in rcols]
            dropped = np.setdiff1d(np.arange(36), cols)
            left_out = float(np.abs(rows[r, dropped]).sum()) if len(dropped) else 0.0
            n = len(cols)
            # a combination that does not cancel (a side of lower rank: special geometry) is
            # left empty, 0 = 0, rather than failing the pose
            if left_out <= 1e-12 * max(1.0, float(rmag[r].max())):
                p[k : k + n] = rows[r, cols]
                mag[k : k + n] = rmag[r, cols]
                mag[k + len(lcols)] += left_out / SLACK  # the constant (first right column)
            k += n
        return p, mag

    def goal_line(self, goal: pin.SE3) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(g_p, g_l)`` of the goal and the radii of their enclosures of the exact values (the
        pose and the arm's constant frames as given: :attr:`enclosure`): ``g_l`` is the goal
        frame's ``z`` column, ``g_p = t - d_6 g_l`` rounded once more (``d_6`` exact)."""
        assert self.enclosure is not None
        pe, re = self.enclosure.params_enclosure(goal)
        R, rR = pe[1:10].reshape(3, 3), re[1:10].reshape(3, 3)
        t, rt = pe[10:13], re[10:13]
        d6 = float(self.geometry.d[5])
        gl, rgl = R[:, 2].copy(), rR[:, 2].copy()
        gp = t - d6 * gl
        rgp = rt + abs(d6) * rgl + 2.0**-52 * (np.abs(t) + abs(d6) * np.abs(gl)) * (1.0 + 2.0**-50) + 1e-300
        return gp, gl, rgp, rgl

    def bind(self, goal: pin.SE3) -> BoundSystem:
        """The system of a goal, its rows carrying how far the rows of the pose and the arm as
        given lie from them (``merr``, ``mgrad``: the goal line's enclosure and the core rows'
        :class:`~kinbox.formulation.errfloat.EF` coefficients; docs/soundness.md)."""
        p, mag = self.params(goal)
        if self.enclosure is None:
            return self.template.bind(p, mag)
        prad = np.zeros_like(p)
        gp, gl, rgp, rgl = self.goal_line(goal)
        p[P_GP : P_GP + 3], p[P_GL : P_GL + 3] = gp, gl
        prad[P_GP : P_GP + 3], prad[P_GL : P_GL + 3] = rgp, rgl
        return self.template.bind(p, mag, prad)

    def formulation(self, mechanism: Mechanism, goal: pin.SE3) -> ArmFormulation:
        return ArmFormulation(mechanism, self.bind(goal), self.dropped_joints, self.joint_vars, self, goal)

    # -- joint values ----------------------------------------------------------------------------
    def thetas(self, x: np.ndarray, goal: pin.SE3) -> np.ndarray:
        """The six canonical angles of a system point: joint 6 from the goal."""
        g = self.geometry
        th = np.array([math.atan2(x[s], x[c]) for c, s in self.angles] + [0.0])
        T = _h(rotz(th[0]), np.zeros(3))
        for i in range(1, 5):
            T = T @ _h(g.links[i - 1].R, g.links[i - 1].t) @ _h(rotz(th[i]), np.array([0.0, 0.0, g.d[i]]))
        T = T @ _h(g.links[4].R, g.links[4].t)
        R6 = (_inv(T) @ self.goal_in_base(goal))[:3, :3]
        th[5] = math.atan2(R6[1, 0], R6[0, 0])
        return th

    def decode(self, x: np.ndarray, goal: pin.SE3 | None = None) -> np.ndarray:
        if goal is None:
            raise FormulationError("the invariants formulation decodes joint 6 from the goal: give it")
        g = self.geometry
        th = self.thetas(np.asarray(x, dtype=float), goal)
        q = g.chain.q_ref.copy()
        for j, t, gam in zip(g.chain.joints, th, g.gamma):
            put_angle(q, j, t - gam)
        return q

    def admissible(self, x: np.ndarray, goal: pin.SE3, width: float = 0.0) -> bool:
        """Is joint 6 of a root within its limits? It has no variable, so the search does not
        keep to them: a root ``x`` (within ``width`` of the true one, 0 for a certified root
        polished by Newton) is dropped only when its joint 6 is outside by more than
        :data:`LIMIT_TOL` plus ``LIMIT_SPREAD * width``: never a root that may be inside."""
        j = self.geometry.chain.joints[5]
        if not pairs.revolute_is_limited(j.lo, j.hi, j.unbounded):
            return True
        a = self.thetas(np.asarray(x, dtype=float), goal)[5] - self.geometry.gamma[5]
        tol = LIMIT_TOL + LIMIT_SPREAD * width
        a = j.lo + (a - j.lo) % (2.0 * math.pi)  # the turn of a at or above the lower limit
        return a <= j.hi + tol or a >= j.lo + 2.0 * math.pi - tol

    def encode(self, q: np.ndarray, goal: pin.SE3) -> np.ndarray:
        """The system point of a configuration ``q`` (exact when ``q`` reaches ``goal``)."""
        g = self.geometry
        model = self.mechanism.model
        q = finite_vector(q, model.nq, "q", f"model {self.mechanism.name!r} has nq = {model.nq}")
        x = np.zeros(self.template.n)
        th = [get_angle(q, j) + gam for j, gam in zip(g.chain.joints, g.gamma)]
        for (c, s), t in zip(self.angles, th):
            x[c], x[s] = math.cos(t), math.sin(t)
        for (a, b), i in self.u_index.items():
            x[i] = [math.cos, math.sin][a](th[3]) * [math.cos, math.sin][b](th[4])
        _, l = _left_at(self.left, th[2:5])
        x[self.l_index] = l
        x[self.lam_index] = 1.0
        return x


def _parallel(joints) -> bool:
    u = [j.axis / np.linalg.norm(j.axis) for j in joints]
    return all(float(np.linalg.norm(np.cross(u[0], v))) < PARALLEL for v in u[1:])


def _free_last(chain: Chain) -> bool:
    j = chain.joints[5]
    return not pairs.revolute_is_limited(j.lo, j.hi, j.unbounded)


def general_chain(mech: Mechanism, frame: str, base: str | None = None) -> Chain | None:
    """The chain of ``frame`` if this formulation applies: six revolute joints, no three
    consecutive axes through one point at either end, no three consecutive parallel axes;
    reversed if that makes the last joint, which has no variable, free over a whole turn."""
    chain = serial_chain(mech, frame, base)
    if chain is None or any(j.kind != "revolute" for j in chain.joints):
        return None
    js = chain.joints
    scale = max(1.0, float(max(np.linalg.norm(j.point) for j in js)))
    if meet_at_a_point(js[:3], CONCURRENT * scale) or meet_at_a_point(js[3:], CONCURRENT * scale):
        return None  # a wrist or shoulder centre: the arm formulation decouples position
    if any(_parallel(js[i : i + 3]) for i in range(4)):
        return None  # a planar sub-chain (UR-like): the arm formulation is 3-15x faster there
    if _free_last(chain) or not _free_last(chain.reverse()):
        return chain  # a limited joint 6 is checked at each root (InvariantsTemplate.admissible)
    return chain.reverse()


def invariants_template(mech: Mechanism, frame: str, base: str | None = None) -> InvariantsTemplate | None:
    """This formulation of ``frame``'s IK, or None where it does not apply (:func:`general_chain`)."""
    chain = general_chain(mech, frame, base)
    if chain is None:
        return None
    geom = canonical(chain)
    left = _left(geom)
    # the core rows' coefficients as EF (the model's exact links within their radii:
    # formulation/constants.py), the fit and encode on the binary64 numbers
    from .constants import enclose_links  # noqa: PLC0415 (mpmath's interval context, once per arm)

    radii = enclose_links(geom, mech, frame, base)
    links = _enclosed_links(geom, radii)
    left_core = _left(geom, links) if links is not None else left
    # the left side's invariants, fitted on the grid and checked elsewhere
    samples = np.array([invariants(*_left_at(left, a)) for a in itertools.product(GRID, repeat=3)])
    A, Amag = _fit(samples, 3)
    rng = np.random.default_rng(0)
    for _ in range(4):
        at = rng.uniform(-math.pi, math.pi, 3)
        want = invariants(*_left_at(left, at))
        if np.abs(_basis(at) @ A.T - want).max() > FIT_CHECK * (1.0 + np.abs(want).max()):
            return None  # pragma: no cover - an identity; never seen to fail
    T = Template(1)  # parameter count set below
    names = [j.name for j in chain.joints]
    angles = []
    for i in range(5):
        jt = chain.joints[i]
        ce, se = pairs.revolute_angle(T, names[i], jt.lo + geom.gamma[i], jt.hi + geom.gamma[i], jt.unbounded)
        if i < 2:  # derived from the others through the combinations: never split first
            for v in (ce, se):
                T.vars.tags[var_index(v)] = "aux"
        angles.append((var_index(ce), var_index(se)))
    rows_core = []
    cs = [(Expr.var(c), Expr.var(s)) for c, s in angles]
    one = Expr.const(1.0)
    u = {}
    for a, b in itertools.product((1, 2), repeat=2):
        v = T.add_var(f"u[{'cs'[a - 1]}4{'cs'[b - 1]}5]", -1.0, 1.0, "aux")
        u[(a, b)] = v
        rows_core.append(({0: v - cs[3][a - 1] * cs[4][b - 1]}, f"def:u{a}{b}"))
    m3 = [one, cs[2][0], cs[2][1]]
    m4 = [one, cs[3][0], cs[3][1]]
    m5 = [one, cs[4][0], cs[4][1]]

    def mono_left(a: int, b: int, c: int) -> Expr:
        if b and c:
            return m3[a] * u[(b, c)]
        return m3[a] * (m4[b] * m5[c])

    mono_l = [mono_left(a, b, c) for a, b, c in itertools.product(range(3), repeat=3)]
    m1 = [one, cs[0][0], cs[0][1]]
    m2 = [one, cs[1][0], cs[1][1]]
    mono_r = [m1[a] * m2[b] for a, b in itertools.product(range(3), repeat=2)]

    def dot(coefs, monos) -> Expr:
        e = Expr()
        for cf, m in zip(coefs, monos):
            if keep(cf):  # a zero with an error (errfloat.EF) is kept: its error reaches the row
                e = e + num(cf) * m
        return e

    # l: the left side's direction (its own variables, for lam l)
    lvars = []
    for r in range(3):
        v = T.add_var(f"l[{'xyz'[r]}]", -1.0, 1.0, "aux")
        lvars.append(v)
        rows_core.append(({0: v - dot(left_core.direction[:, r], mono_l)}, f"def:l[{'xyz'[r]}]"))
    lam = T.add_var("lam", 1.0 - LAM_RANGE, 1.0 + LAM_RANGE, "aux")
    P = _right_matrices(geom)
    P_core = _right_matrices(geom, links) if links is not None else P
    for r in range(3):
        # p: left = sum_m mono_r[m] (P[m] (g_p, 1))_r = sum_m mono_r[m] (P[m, r, :3] . g_p + P[m, r, 3])
        parts: dict[int, Expr] = {0: dot(left_core.point[:, r], mono_l) - dot(P_core[:, r, 3], mono_r)}
        for k in range(3):
            parts[P_GP + k] = -1.0 * dot(P_core[:, r, k], mono_r)
        rows_core.append((parts, f"couple:p[{'xyz'[r]}]"))
        dparts: dict[int, Expr] = {0: lam * lvars[r]}
        for k in range(3):
            dparts[P_GL + k] = -1.0 * dot(P_core[:, r, k], mono_r)
        rows_core.append((dparts, f"couple:l[{'xyz'[r]}]"))
    # the redundant rows, every coefficient a parameter
    names_inv = ["pp", "pl", "pxl[x]", "pxl[y]", "pxl[z]", "w[x]", "w[y]", "w[z]"]
    all_l = list(range(27))
    red = [(f"inv:{n}", all_l, list(range(9))) for n in names_inv]
    red += [(f"elim:{k}", all_l, [0]) for k in range(6)]
    red += [(f"solve:{'1cs'[(m + 1) // 3]}{'1cs'[(m + 1) % 3]}", all_l, [0, m + 1]) for m in range(8)]
    k = P_ROWS
    red_parts = []
    for name, lc, rc in red:
        parts = {}
        for col in lc:
            parts[k] = mono_l[col]
            k += 1
        for col in rc:
            parts[k] = mono_r[col]
            k += 1
        red_parts.append((parts, name))
    T.nparams = k
    for parts, name in rows_core:
        T.add_eq(parts, name)
    for n, (cv, sv) in zip(names, cs):
        T.add_eq(cv * cv + sv * sv - 1.0, f"circle:{n}")
    for parts, name in red_parts:
        # the combinations are linear in the rows' monomials, as the LP is: leaving them out
        # of it cut a sweep of 18 arms from 15.7 to 10.7 s (and its boxes from 3,131 to 2,633)
        T.add_eq(parts, name, redundant=True, lp=name.startswith("inv:"))
    joint_vars: dict[str, list[str]] = {n: [] for n in names}
    for n, (ic, is_) in zip(names, angles):
        joint_vars[n] = [T.vars.names[ic], T.vars.names[is_]]
    tpl = InvariantsTemplate(
        mech,
        geom,
        T,
        joint_vars,
        chain.dropped,
        angles,
        left,
        A,
        Amag,
        P,
        red,
        {(a - 1, b - 1): var_index(v) for (a, b), v in u.items()},
        [var_index(v) for v in lvars],
        var_index(lam),
        # an arm template without rows: what params_enclosure needs (geometry, constants)
        ArmTemplate(mech, geom, Template(1), [], [], {}, [], constants=radii),
    )
    T.freeze()  # the expanded pattern, built once per arm and frame (not at the first pose)
    return tpl
