"""The equations of each pair (003, Sec. III, Table III, Appendices I and II).

Every function here writes the equations of one pair (or one closure) into a
:class:`~kinbox.system.System`; :mod:`kinbox.formulation` walks the kinematic tree and calls
them. Where to look:

==============================  =================================================================
pair / closure                  function
==============================  =================================================================
which pair a Pinocchio joint    :func:`joint_parts` (composite joints: :func:`joint_parts` too,
is (the table of the design)    one :class:`Part` per sub-joint, in sequence; :func:`sub_joint`)
revolute: angle and limits      :func:`revolute_angle` (``c, s`` with the domains of Appendix I
                                and the chord inequality)
revolute: propagation           :func:`revolute_propagate` (linear, or materialized on demand)
revolute: closing equations     :func:`revolute_closing`
prismatic                       :func:`prismatic_joint` (``d``)
spherical / free rotation       :func:`free_rotation`
planar                          :func:`planar_joint` (``x, y``; rotation as a revolute about z)
translation                     :func:`translation_joint`
free-flyer                      :func:`free_flyer_translation`, :func:`free_flyer_limits`
                                (+ :func:`free_rotation`)
constant relative orientation   :func:`const_propagate` (prismatic, translation, locked joints,
                                welds)
weld (orientation part)         :func:`weld_orientation`
point / distance closures       :func:`point_closure`, :func:`distance_closure`
==============================  =================================================================

Orientations are 3x3 matrices held by :class:`Rot`: either a numpy array (a constant) or
nested lists of :class:`~kinbox.system.Expr`/floats of degree <= 2. A degree-2 orientation (a
revolute propagated from a non-constant frame) is only **materialized** (its two moving columns
become auxiliary variables) when something needs it linear: a further propagation across a
revolute, a closing equation, or a product with a displacement variable. Used only in position
sums, it stays bilinear and costs no variable.

Variable names: ``c[j]``, ``s[j]`` (cos and sin of revolute ``j``), ``d[j]`` (prismatic),
``d[j][k]`` (planar / translation displacements), ``t[j][k]`` (free-flyer translation, world
frame, eliminated), ``R[f][r,k]`` (entry ``(r, k)`` of the orientation of frame ``f``: free
rotations, and materialized columns of a revolute's child frame when the axis is a coordinate
axis; ``R[f][r,b1]`` / ``R[f][r,b2]`` when it is not: entry ``r`` of ``R_f b1``),
``Rin[j][r,k]`` (the same for the frame *before* the motion of ``j``, ``R_parent * Rp``, when
propagating backwards across ``j``), ``dir[closure][k]`` (unit vector of a distance closure).
Tags: ``cos``, ``sin``, ``rot``, ``disp``, ``unit``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..errors import FormulationError
from ..interval import cos_range, sin_range
from .system import Expr, System, degree

#: domain given to a free-flyer translation with no finite limits; it must be eliminated
PLACEHOLDER_BOUND = 1e6

#: position limits at or beyond this magnitude mean "unlimited" (Pinocchio uses +-DBL_MAX)
UNBOUNDED = 1e100
#: entries of constant matrices below this magnitude are set to zero (cos(pi/2) = 6e-17 ...)
SNAP = 1e-14


# ----------------------------------------------------------------------------------------------
# small algebra on scalars, vectors and 3x3 matrices of Expr/float
# ----------------------------------------------------------------------------------------------
def snap(a: np.ndarray) -> np.ndarray:
    """Copy of ``a`` with entries below :data:`SNAP` in magnitude set to exactly zero."""
    a = np.array(a, dtype=float)
    a[np.abs(a) < SNAP] = 0.0
    return a


def lincomb(coefs, items):
    """``sum_k coefs[k] * items[k]`` for float ``coefs``; a float if the result is constant."""
    t: dict = {}
    const = 0.0
    for a, e in zip(coefs, items):
        a = float(a)
        if a == 0.0:
            continue
        if isinstance(e, Expr):
            for k, v in e.terms.items():
                t[k] = t.get(k, 0.0) + a * v
        else:
            const += a * float(e)
    if not t:
        return const
    if const != 0.0:
        t[()] = t.get((), 0.0) + const
    t = {k: v for k, v in t.items() if v != 0.0}
    if not t or list(t) == [()]:
        return t.get((), 0.0)
    return Expr(t)


def deg(a) -> int:
    return a.degree if isinstance(a, Expr) else 0


def simplify(a):
    """A float if ``a`` is a constant expression, else ``a``."""
    if isinstance(a, Expr) and a.degree == 0:
        return a.constant
    return a


def vadd(*vs):
    """Sum of 3-vectors (lists of scalars or arrays)."""
    out = [0.0, 0.0, 0.0]
    for v in vs:
        out = [simplify(out[k] + v[k]) for k in range(3)]
    return out


def vsub(a, b):
    return [simplify(a[k] - b[k]) for k in range(3)]


def vscale(c, v):
    """``c * v`` for a scalar ``c`` (Expr or float) and a vector of scalars."""
    return [simplify(c * v[k]) if isinstance(c, Expr) or isinstance(v[k], Expr) else float(c) * float(v[k])
            for k in range(3)]


def vdot(a, b):
    s = 0.0
    for x, y in zip(a, b):
        s = s + x * y
    return simplify(s)


def vcross(a, b):
    return [simplify(a[1] * b[2] - a[2] * b[1]), simplify(a[2] * b[0] - a[0] * b[2]),
            simplify(a[0] * b[1] - a[1] * b[0])]


def mat_mul_const(A, K: np.ndarray):
    """``A @ K`` for a matrix ``A`` (array or nested lists) and a constant array ``K``."""
    if isinstance(A, np.ndarray):
        return A @ K
    return [[lincomb(K[:, j], A[i]) for j in range(K.shape[1])] for i in range(len(A))]


def mat_vec_const(A, v: np.ndarray):
    """``A @ v`` for a matrix ``A`` (array or nested lists) and a constant vector ``v``."""
    if isinstance(A, np.ndarray):
        return list(A @ v)
    return [lincomb(v, row) for row in A]


def columns(A):
    if isinstance(A, np.ndarray):
        return [list(A[:, k]) for k in range(A.shape[1])]
    return [[A[r][k] for r in range(len(A))] for k in range(len(A[0]))]


def from_columns(cols):
    return [[cols[k][r] for k in range(len(cols))] for r in range(len(cols[0]))]


def mat_value(A, x: np.ndarray) -> np.ndarray:
    if isinstance(A, np.ndarray):
        return A.copy()
    return np.array([[a.value(x) if isinstance(a, Expr) else float(a) for a in row] for row in A])


def mat_degree(A) -> int:
    if isinstance(A, np.ndarray):
        return 0
    return max(deg(a) for row in A for a in row)


def add_eq(sys: System, expr, name: str, redundant: bool = False, tol: float = 1e-12) -> None:
    """``System.add_eq`` that drops constant equations satisfied up to ``tol`` (rounding)."""
    if not isinstance(expr, Expr) or expr.degree == 0:
        c = expr.constant if isinstance(expr, Expr) else float(expr)
        if abs(c) <= tol:
            return
    sys.add_eq(expr, name, redundant=redundant)


def add_ineq(sys: System, expr, name: str, tol: float = 1e-12) -> None:
    """``System.add_ineq`` (``expr <= 0``) dropping constant ones that hold up to ``tol``."""
    if not isinstance(expr, Expr) or expr.degree == 0:
        c = expr.constant if isinstance(expr, Expr) else float(expr)
        if c <= tol:
            return
    sys.add_ineq(expr, name)


def materialize(sys: System, expr, name: str, lo: float = -1.0, hi: float = 1.0, tag: str = "aux"):
    """``System.materialize`` keeping constants as floats."""
    if deg(expr) <= 1:
        return expr
    return sys.materialize(expr, name, lo, hi, tag)


# ----------------------------------------------------------------------------------------------
# orientations
# ----------------------------------------------------------------------------------------------
class Rot:
    """The orientation of a frame: a 3x3 matrix of degree <= 2, made linear on demand.

    ``M`` is a numpy array when the orientation is a constant. ``linear()`` returns ``M``
    after materializing it if it has degree 2 (the materialization adds variables and
    definition equations to the system once).
    """

    __slots__ = ("M", "_make_linear")

    def __init__(self, M, make_linear: Callable[[], None] | None = None):
        self.M = M
        self._make_linear = make_linear

    @staticmethod
    def const(R: np.ndarray) -> Rot:
        return Rot(snap(R))

    @property
    def is_const(self) -> bool:
        return isinstance(self.M, np.ndarray)

    @property
    def degree(self) -> int:
        return mat_degree(self.M)

    def linear(self):
        if self._make_linear is not None and self.degree > 1:
            self._make_linear()
        self._make_linear = None
        if self.degree > 1:  # pragma: no cover - a formulation bug
            raise FormulationError("internal: orientation could not be made linear")
        return self.M

    def value(self, x: np.ndarray) -> np.ndarray:
        return mat_value(self.M, x)


def const_propagate(known: Rot, K: np.ndarray, forward: bool = True) -> Rot:
    """Orientation across a constant relative rotation: ``R_child = R_parent K``.

    ``forward``: ``known`` is the parent (returns ``R_parent K``); else ``known`` is the child
    (returns ``R_child K^T``). Used for prismatic and translation pairs (``K = Rp``), locked
    joints (``K`` = their placement times their fixed motion) and welds. No variables; the
    result is as linear as ``known`` and made linear by making ``known`` linear.
    """
    K = K if forward else K.T
    out = Rot(mat_mul_const(known.M, K))
    if not known.is_const and known.degree > 1:
        def make_linear():
            out.M = mat_mul_const(known.linear(), K)
        out._make_linear = make_linear
    return out


def axis_basis(axis: np.ndarray) -> tuple[np.ndarray, tuple[str, str]]:
    """``(B, labels)``: ``B = [b1 b2 a]`` right-handed orthonormal with ``a`` the unit axis.

    For a (signed) coordinate axis ``b1, b2`` are coordinate axes too (cyclic order), and
    ``labels`` are their column indices (``"0"``, ``"1"``, ``"2"``) for variable names; else
    ``("b1", "b2")``.
    """
    a = np.asarray(axis, dtype=float)
    n = float(np.linalg.norm(a))
    if not math.isfinite(n) or n < 1e-9:
        raise FormulationError(f"joint axis {a.tolist()} is not a unit vector")
    a = a / n
    k = int(np.argmax(np.abs(a)))
    if abs(abs(a[k]) - 1.0) < 1e-14:
        a = np.zeros(3)
        a[k] = math.copysign(1.0, float(axis[k]))
        i1 = (k + 1) % 3
        b1 = np.zeros(3)
        b1[i1] = 1.0
        b2 = np.cross(a, b1)
        i2 = int(np.argmax(np.abs(b2)))
        return np.column_stack([b1, b2, a]), (str(i1), str(i2))
    e = np.zeros(3)
    e[int(np.argmin(np.abs(a)))] = 1.0
    b1 = e - a * float(a @ e)
    b1 /= np.linalg.norm(b1)
    b2 = np.cross(a, b1)
    return np.column_stack([b1, b2, a]), ("b1", "b2")


# ----------------------------------------------------------------------------------------------
# which pair is a Pinocchio joint
# ----------------------------------------------------------------------------------------------
@dataclass
class Part:
    """One elementary pair of a Pinocchio joint (a composite joint has several, in sequence).

    The motion of the part is ``placement * motion(q)``, with ``kind`` one of ``revolute``,
    ``prismatic``, ``spherical``, ``spherical_zyx``, ``free``, ``planar``, ``translation``.
    ``idx_q``/``nq``: its entries of the Pinocchio ``q``; ``unbounded``: a continuous revolute
    (``nq = 2``, ``q = (cos, sin)``); ``path``: see :func:`sub_joint`.
    """

    kind: str
    placement: pin.SE3
    idx_q: int
    nq: int
    axis: np.ndarray | None = None
    unbounded: bool = False
    #: where the part sits in a composite joint: indices into ``.joints`` of nested composites
    path: tuple = ()


_AXES = {"X": np.array([1.0, 0.0, 0.0]), "Y": np.array([0.0, 1.0, 0.0]), "Z": np.array([0.0, 0.0, 1.0])}


def joint_axis(jmodel, revolute: bool) -> np.ndarray:
    """Unit axis of an unaligned revolute/prismatic joint model.

    Read from ``.axis`` where the Python binding has it, else measured from the joint's own
    motion (``calc``) at a quarter turn / unit displacement (the binding of
    ``RevoluteUnboundedUnaligned`` has no ``axis``).
    """
    ext = jmodel.extract()
    if "axis" in type(ext).__dict__ or hasattr(type(ext), "axis"):
        a = np.array(ext.axis, dtype=float)
    else:
        iq = int(jmodel.idx_q)
        q = np.zeros(iq + int(jmodel.nq))
        if int(jmodel.nq) == 2:  # continuous: (cos, sin) of a quarter turn
            q[iq: iq + 2] = [0.0, 1.0]
        else:
            q[iq] = 1.0 if not revolute else math.pi / 2
        jd = jmodel.createData()
        jmodel.calc(jd, q)
        a = pin.log3(jd.M.rotation) / (math.pi / 2) if revolute else np.array(jd.M.translation)
    n = float(np.linalg.norm(a))
    if not (math.isfinite(n) and n > 1e-9):
        raise FormulationError(f"joint axis {a.tolist()} is not a unit vector")
    return a / n


def joint_parts(jmodel, name: str, placement: pin.SE3 | None = None, path: tuple = ()) -> list[Part]:
    """The pairs of a Pinocchio joint model, in sequence (see the table in the design doc).

    ====================================================  ===========================
    Pinocchio joint                                       part kind
    ====================================================  ===========================
    RX, RY, RZ, RevoluteUnaligned                         revolute
    RUBX, RUBY, RUBZ, RevoluteUnboundedUnaligned          revolute (unbounded, nq = 2)
    PX, PY, PZ, PrismaticUnaligned                        prismatic
    Spherical                                             spherical (quaternion)
    SphericalZYX                                          spherical_zyx (Euler angles)
    FreeFlyer                                             free
    Planar                                                planar
    Translation                                           translation
    Composite                                             its sub-joints, in order
    ====================================================  ===========================

    Others (helical, universal, mimic, ellipsoid) raise :class:`FormulationError` naming the
    joint and its type.
    """
    placement = pin.SE3.Identity() if placement is None else placement
    short = jmodel.shortname().replace("JointModel", "")
    iq, nq = int(jmodel.idx_q), int(jmodel.nq)
    if short in ("RX", "RY", "RZ"):
        return [Part("revolute", placement, iq, nq, _AXES[short[1]].copy(), path=path)]
    if short in ("RUBX", "RUBY", "RUBZ"):
        return [Part("revolute", placement, iq, nq, _AXES[short[3]].copy(), unbounded=True, path=path)]
    if short == "RevoluteUnaligned":
        return [Part("revolute", placement, iq, nq, joint_axis(jmodel, True), path=path)]
    if short == "RevoluteUnboundedUnaligned":
        return [Part("revolute", placement, iq, nq, joint_axis(jmodel, True), unbounded=True, path=path)]
    if short in ("PX", "PY", "PZ"):
        return [Part("prismatic", placement, iq, nq, _AXES[short[1]].copy(), path=path)]
    if short == "PrismaticUnaligned":
        return [Part("prismatic", placement, iq, nq, joint_axis(jmodel, False), path=path)]
    if short == "Spherical":
        return [Part("spherical", placement, iq, nq, path=path)]
    if short == "SphericalZYX":
        return [Part("spherical_zyx", placement, iq, nq, path=path)]
    if short == "FreeFlyer":
        return [Part("free", placement, iq, nq, path=path)]
    if short == "Planar":
        return [Part("planar", placement, iq, nq, _AXES["Z"].copy(), path=path)]
    if short == "Translation":
        return [Part("translation", placement, iq, nq, path=path)]
    if short == "Composite":
        comp = jmodel.extract()
        parts: list[Part] = []
        for k, (sub, P) in enumerate(zip(comp.joints, comp.jointPlacements)):
            Pk = placement * P if k == 0 else pin.SE3(P)
            parts += joint_parts(sub, name, Pk, path + (k,))
        return parts
    raise FormulationError(f"joint {name!r} has type {short}, which kinbox does not support "
                           f"(supported: revolute, continuous, prismatic, spherical, planar, "
                           f"translation, free-flyer and composites of them); lock it to leave it out")


def sub_joint(jmodel, path: tuple):
    """The sub-joint model of a (nested) composite joint at ``path`` (the joint itself for ())."""
    for k in path:
        jmodel = jmodel.extract().joints[k]
    return jmodel


def finite_limit(lo: float, hi: float) -> bool:
    return math.isfinite(lo) and math.isfinite(hi) and abs(lo) < UNBOUNDED and abs(hi) < UNBOUNDED


# ----------------------------------------------------------------------------------------------
# revolute pair
# ----------------------------------------------------------------------------------------------
def revolute_is_limited(lo: float, hi: float, unbounded: bool = False) -> bool:
    """A revolute range narrower than ``2 pi`` limits the joint; anything else does not."""
    return (not unbounded) and finite_limit(lo, hi) and (hi - lo) < 2 * math.pi


def revolute_angle(sys: System, name: str, lo: float = -math.inf, hi: float = math.inf,
                   unbounded: bool = False) -> tuple[Expr, Expr]:
    """The variables ``c[name] = cos q``, ``s[name] = sin q`` of a revolute pair.

    Joint limits (Appendix I): for a range ``[lo, hi]`` narrower than ``2 pi``, ``c`` and ``s``
    get the interval enclosures of ``cos``/``sin`` over the range, and the chord inequality
    ``cos(mid) c + sin(mid) s >= cos(half)`` (``mid``/``half``: centre and half-width of the
    range) cuts the unit circle to exactly the allowed arc (padded outward by a few ulps).
    Unlimited joints get ``[-1, 1]``. The circle equation is written by the caller
    (:func:`revolute_propagate`: core, :func:`revolute_closing`: redundant).
    """
    if lo > hi:
        raise FormulationError(f"joint {name!r} has an empty range [{lo}, {hi}]")
    if revolute_is_limited(lo, hi, unbounded):
        clo, chi = cos_range(lo, hi)
        slo, shi = sin_range(lo, hi)
        c = sys.add_var(f"c[{name}]", clo, chi, "cos")
        s = sys.add_var(f"s[{name}]", slo, shi, "sin")
        mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
        pad = 8 * np.finfo(float).eps
        add_ineq(sys, (math.cos(half) - pad) - (c * math.cos(mid) + s * math.sin(mid)), f"limit:{name}")
    else:
        c = sys.add_var(f"c[{name}]", -1.0, 1.0, "cos")
        s = sys.add_var(f"s[{name}]", -1.0, 1.0, "sin")
    return c, s


def _rot_z_columns(c, s, P1, P2, transpose: bool):
    """Columns 0 and 1 of ``[P1 P2 .] Rot_z(c, s)`` (or ``Rot_z^T`` if ``transpose``)."""
    if not transpose:
        u = [simplify(c * P1[r] + s * P2[r]) for r in range(3)]
        v = [simplify(c * P2[r] - s * P1[r]) for r in range(3)]
    else:
        u = [simplify(c * P1[r] - s * P2[r]) for r in range(3)]
        v = [simplify(s * P1[r] + c * P2[r]) for r in range(3)]
    return u, v


def revolute_propagate(sys: System, name: str, known: Rot, Rp: np.ndarray, B: np.ndarray,
                       labels: tuple[str, str], c: Expr, s: Expr, forward: bool,
                       new_frame: str) -> Rot:
    """Orientation across a revolute pair, ``R_child = R_parent Rp Rot_a(c, s)``.

    ``forward``: ``known`` is the parent, returns ``R_child``; else ``known`` is the child and
    returns ``R_parent = R_child Rot_a(c, s)^T Rp^T``. Writes the core ``c^2 + s^2 = 1``.

    With ``B = [b1 b2 a]``: ``R_child B = R_parent Rp B Rot_z(c, s)``. If ``known`` is constant
    the result is linear in ``(c, s)``. Otherwise it is bilinear; the two moving columns
    (``R_child b1, R_child b2``, or ``R_parent Rp b1, R_parent Rp b2`` backwards) are
    materialized as 6 variables in ``[-1, 1]`` (6 core definitions; redundant ``|u| = |v| = 1``,
    ``u . v = 0``) only when the result is needed linear (:meth:`Rot.linear`).
    """
    add_eq(sys, c * c + s * s - 1.0, f"circle:{name}")
    Bt = B.T
    if forward:
        P = mat_mul_const(known.linear(), Rp @ B)  # R_parent Rp B
    else:
        P = mat_mul_const(known.linear(), B)  # R_child B
    P1, P2, P3 = columns(P)
    u, v = _rot_z_columns(c, s, P1, P2, transpose=not forward)
    post = Bt if forward else Bt @ Rp.T

    def assemble(u, v):
        return mat_mul_const(from_columns([u, v, P3]), post)

    out = Rot(assemble(u, v))
    if max(deg(a) for a in u + v) > 1:
        prefix = f"R[{new_frame}]" if forward else f"Rin[{name}]"

        def make_linear():
            uu = [materialize(sys, u[r], f"{prefix}[{r},{labels[0]}]") for r in range(3)]
            vv = [materialize(sys, v[r], f"{prefix}[{r},{labels[1]}]") for r in range(3)]
            add_eq(sys, vdot(uu, uu) - 1.0, f"unit:{prefix}[{labels[0]}]", redundant=True)
            add_eq(sys, vdot(vv, vv) - 1.0, f"unit:{prefix}[{labels[1]}]", redundant=True)
            add_eq(sys, vdot(uu, vv), f"ortho:{prefix}", redundant=True)
            out.M = assemble(uu, vv)

        out._make_linear = make_linear
    return out


def revolute_closing(sys: System, name: str, parent: Rot, Rp: np.ndarray, child: Rot,
                     B: np.ndarray, c: Expr, s: Expr) -> None:
    """Closing equations of a revolute pair whose two frames were both reached elsewhere.

    With ``M = (R_parent Rp B)^T (R_child B)`` (which must be ``Rot_z(c, s)``): core
    ``M[0,2] = M[1,2] = 0`` (the axes agree up to sign), ``M[0,0] = c``, ``M[1,0] = s``;
    inequality ``M[2,2] >= 0`` (not the flipped axis); redundant ``M[2,2] = 1``,
    ``c^2 + s^2 = 1``, ``M[0,1] = -s``, ``M[1,1] = c``, ``M[2,0] = M[2,1] = 0``.
    """
    P = columns(mat_mul_const(parent.linear(), Rp @ B))
    Q = columns(mat_mul_const(child.linear(), B))

    def M(i, j):
        return vdot(P[i], Q[j])

    add_eq(sys, M(0, 2), f"axis:{name}[0]")
    add_eq(sys, M(1, 2), f"axis:{name}[1]")
    add_eq(sys, M(0, 0) - c, f"cos:{name}")
    add_eq(sys, M(1, 0) - s, f"sin:{name}")
    add_ineq(sys, -M(2, 2), f"axis-sign:{name}")
    add_eq(sys, M(2, 2) - 1.0, f"axis:{name}[2]", redundant=True)
    add_eq(sys, c * c + s * s - 1.0, f"circle:{name}", redundant=True)
    add_eq(sys, M(0, 1) + s, f"rot:{name}[0,1]", redundant=True)
    add_eq(sys, M(1, 1) - c, f"rot:{name}[1,1]", redundant=True)
    add_eq(sys, M(2, 0), f"rot:{name}[2,0]", redundant=True)
    add_eq(sys, M(2, 1), f"rot:{name}[2,1]", redundant=True)


# ----------------------------------------------------------------------------------------------
# prismatic, planar and translation pairs
# ----------------------------------------------------------------------------------------------
def _displacement(sys: System, var: str, joint: str, lo: float, hi: float) -> Expr:
    if not finite_limit(lo, hi):
        raise FormulationError(
            f"joint {joint!r} has no finite position limits ([{lo:g}, {hi:g}]); give it limits or lock it")
    if lo > hi:
        raise FormulationError(f"joint {joint!r} has an empty range [{lo}, {hi}]")
    return sys.add_var(var, lo, hi, "disp")


def prismatic_joint(sys: System, name: str, lo: float, hi: float) -> Expr:
    """The displacement ``d[name]`` of a prismatic pair, with the joint limits as domain.

    Orientation: ``R_child = R_parent Rp`` (:func:`const_propagate`); position term
    ``d R_pre a`` (Table III, ``delta_i``). Infinite limits raise :class:`FormulationError`.
    """
    return _displacement(sys, f"d[{name}]", name, lo, hi)


def planar_joint(sys: System, name: str, lo: np.ndarray, hi: np.ndarray) -> tuple[Expr, Expr]:
    """The in-plane displacements ``d[name][0], d[name][1]`` of a planar pair.

    Pinocchio's planar joint moves by ``(x, y, 0)`` in the frame before its motion, then
    rotates about ``z``: the rotation is a revolute pair (:func:`revolute_angle` with an
    unlimited range) and the position term is ``R_pre (x, y, 0)``.
    """
    x = _displacement(sys, f"d[{name}][0]", name, lo[0], hi[0])
    y = _displacement(sys, f"d[{name}][1]", name, lo[1], hi[1])
    return x, y


def translation_joint(sys: System, name: str, lo: np.ndarray, hi: np.ndarray) -> list[Expr]:
    """The displacements ``d[name][k]`` of a translation pair (three prismatic pairs).

    Orientation ``R_child = R_pre``; position term ``R_pre (x, y, z)``.
    """
    return [_displacement(sys, f"d[{name}][{k}]", name, lo[k], hi[k]) for k in range(3)]


def free_flyer_translation(sys: System, name: str, lo: np.ndarray, hi: np.ndarray) -> list[Expr]:
    """World position ``t[name][k]`` of a free-flyer's frame, domain ``[lo, hi]``.

    The formulation eliminates these variables afterwards (:meth:`System.eliminate_linear`),
    so the domain is a placeholder unless the elimination is impossible. Joint limits (on the
    translation in the frame before the motion) are :func:`free_flyer_limits`.
    """
    return [sys.add_var(f"t[{name}][{k}]", lo[k], hi[k], "disp") for k in range(3)]


def free_flyer_limits(sys: System, name: str, t: list, base: list, R_pre: np.ndarray,
                      lo: np.ndarray, hi: np.ndarray) -> None:
    """Inequalities ``lo <= R_pre^T (t - base) <= hi`` for a free-flyer whose frame before the
    motion has a constant orientation ``R_pre`` (linear in ``t``; skipped for infinite limits)."""
    rel = vsub(t, base)
    for k in range(3):
        if not finite_limit(lo[k], hi[k]):
            continue
        v = lincomb(R_pre[:, k], rel)
        add_ineq(sys, v - float(hi[k]), f"limit:{name}[{k}]:hi")
        add_ineq(sys, float(lo[k]) - v, f"limit:{name}[{k}]:lo")


# ----------------------------------------------------------------------------------------------
# spherical pair / free rotation
# ----------------------------------------------------------------------------------------------
def free_rotation(sys: System, frame: str) -> Rot:
    """A free rotation ``R = [u v w]`` (spherical pair, free-flyer): 9 variables ``R[frame][r,k]``.

    Core ``|u|^2 = 1, |v|^2 = 1, u . v = 0, w = u x v`` (Eqs. 3-6: 6 equations, 3 degrees of
    freedom, ``det R = +1``); redundant ``|w|^2 = 1, u . w = 0, v . w = 0``.
    """
    # u and v are unknowns; w = u x v is derived ("aux": the solver never splits it)
    cols = [[sys.add_var(f"R[{frame}][{r},{k}]", -1.0, 1.0, "rot" if k < 2 else "aux") for r in range(3)]
            for k in range(3)]
    u, v, w = cols
    add_eq(sys, vdot(u, u) - 1.0, f"unit:R[{frame}][0]")
    add_eq(sys, vdot(v, v) - 1.0, f"unit:R[{frame}][1]")
    add_eq(sys, vdot(u, v), f"ortho:R[{frame}][0,1]")
    uxv = vcross(u, v)
    for r in range(3):
        add_eq(sys, w[r] - uxv[r], f"cross:R[{frame}][{r}]")
    add_eq(sys, vdot(w, w) - 1.0, f"unit:R[{frame}][2]", redundant=True)
    add_eq(sys, vdot(u, w), f"ortho:R[{frame}][0,2]", redundant=True)
    add_eq(sys, vdot(v, w), f"ortho:R[{frame}][1,2]", redundant=True)
    return Rot(from_columns(cols))


# ----------------------------------------------------------------------------------------------
# closures
# ----------------------------------------------------------------------------------------------
def weld_orientation(sys: System, name: str, Ra: Rot, Ka: np.ndarray, Rb: Rot, Kb: np.ndarray) -> None:
    """Orientation part of a weld between two reached frames: ``(Ra Ka)^T (Rb Kb) = I``.

    With ``M = (Ra Ka)^T (Rb Kb)``: core ``M[1,0] = M[2,0] = M[2,1] = 0``; inequalities
    ``M[k,k] >= 0``; redundant ``M[0,1] = M[0,2] = M[1,2] = 0``, ``M[k,k] = 1``. (An orthogonal
    matrix with a zero lower triangle and a non-negative diagonal is the identity.) Also the
    closing equation of a prismatic/translation pair or a locked joint on a cycle.
    """
    A = columns(mat_mul_const(Ra.linear(), Ka))
    Bc = columns(mat_mul_const(Rb.linear(), Kb))

    def M(i, j):
        return vdot(A[i], Bc[j])

    for i, j in ((1, 0), (2, 0), (2, 1)):
        add_eq(sys, M(i, j), f"weld:{name}[{i},{j}]")
    for k in range(3):
        add_ineq(sys, -M(k, k), f"weld-sign:{name}[{k}]")
    for i, j in ((0, 1), (0, 2), (1, 2)):
        add_eq(sys, M(i, j), f"weld:{name}[{i},{j}]", redundant=True)
    for k in range(3):
        add_eq(sys, M(k, k) - 1.0, f"weld:{name}[{k},{k}]", redundant=True)


def point_closure(sys: System, name: str, pa: list, pb: list) -> None:
    """A loop equation (Eq. 23): the points ``pa`` and ``pb`` coincide (3 core equations)."""
    for k in range(3):
        add_eq(sys, simplify(pa[k] - pb[k]), f"loop:{name}[{k}]")


def unit_vector(sys: System, name: str) -> list[Expr]:
    """A unit vector ``dir[name]`` (3 variables in ``[-1, 1]``, core ``|d|^2 = 1``)."""
    d = [sys.add_var(f"dir[{name}][{k}]", -1.0, 1.0, "unit") for k in range(3)]
    add_eq(sys, vdot(d, d) - 1.0, f"unit:dir[{name}]")
    return d


def distance_closure(sys: System, name: str, pa: list, pb: list, length: float,
                     squared: bool = True) -> list[Expr]:
    """Spherical-spherical leg: ``|pb - pa| = l``.

    When ``squared`` and both end points are linear in unknowns with real (finite, not
    placeholder) domains, ``|pb - pa|^2 = l^2`` (1 core equation): a platform's translation then
    stays a variable.
    Otherwise Table III, last row: ``pa + l d = pb``, ``|d| = 1`` with a unit vector ``d``
    (4 core equations, 3 variables), which is returned. A zero length is a point closure.
    """
    if length == 0.0:
        point_closure(sys, name, pa, pb)
        return []
    ends = list(pa) + list(pb)
    used = {i for v in ends if isinstance(v, Expr) for i in v.variables()}
    bounded = all(max(abs(sys.lo[i]), abs(sys.hi[i])) < PLACEHOLDER_BOUND for i in used)
    if squared and bounded and all(degree(v) <= 1 for v in ends):
        # both ends linear in the unknowns (e.g. a base point and t + R q on a platform):
        # |pb - pa|^2 = l^2 is already quadratic: 1 core equation, no new variables
        diff = vsub(pb, pa)
        add_eq(sys, vdot(diff, diff) - float(length) ** 2, f"dist:{name}")
        return []
    d = unit_vector(sys, name)
    point_closure(sys, name, vadd(pa, vscale(float(length), d)), pb)
    return d
