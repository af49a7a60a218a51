"""The small algebra the pair equations are written in: scalars, 3-vectors and 3x3 matrices
whose entries are :class:`~kinbox.formulation.system.Expr` or floats, and :class:`Rot`, the
orientation of a frame (degree <= 2, made linear on demand).

It is kinbox's one vector and rotation algebra outside the compiled kernels: the pairs, the
constraint-system formulations (:mod:`kinbox.formulation.geometry`: :func:`vdot`,
:func:`vcross`, :func:`kabsch`; :mod:`kinbox.formulation.distance`: :func:`kabsch`) and the
enclosures of an arm's constants (:mod:`kinbox.formulation.constants`: :func:`vdot`,
:func:`vcross`, :func:`mat_mul`, :func:`mat_vec`, :func:`transpose` on ``mpmath.iv`` intervals)
use it. :func:`vdot`, :func:`vcross`, :func:`mat_mul`, :func:`mat_vec` and :func:`transpose`
take entries of any kind with ``+``, ``-`` and ``*`` (an ``Expr``, a float, an interval), each
result computed in one fixed order (the same bits on every run)."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Protocol

import numpy as np

from ...errors import FormulationError
from ..errfloat import EF, err, keep, num
from ..system import Expr, System

#: domain given to a free-flyer translation with no finite limits; it must be eliminated
PLACEHOLDER_BOUND = 1e6

#: position limits at or beyond this magnitude mean "unlimited" (Pinocchio uses +-DBL_MAX)
UNBOUNDED = 1e100
#: entries of constant matrices below this magnitude are set to zero (cos(pi/2) = 6e-17 ...)
SNAP = 1e-14


# ----------------------------------------------------------------------------------------------
# small algebra on scalars, vectors and 3x3 matrices of Expr/float
# ----------------------------------------------------------------------------------------------
def snap(a: np.ndarray, tol: float = SNAP) -> np.ndarray:
    """Copy of ``a`` with entries below ``tol`` (default :data:`SNAP`) in magnitude set to
    exactly zero. An array of :class:`~kinbox.formulation.errfloat.EF` (the shadow build of
    :mod:`kinbox.formulation.enclose_rows`) keeps each snapped entry's value as its error."""
    if isinstance(a, np.ndarray) and a.dtype == object:
        return snap_ef(a, tol)
    a = np.array(a, dtype=float)
    a[np.abs(a) < tol] = 0.0
    return a


def snap_ef(a: np.ndarray, tol: float = SNAP) -> np.ndarray:
    """:func:`snap` of an :class:`~kinbox.formulation.errfloat.EF` array: an entry below ``tol``
    becomes a zero whose error is its value plus its error (the exact entry is not assumed to
    be zero)."""
    out = a.copy()
    for idx in np.ndindex(out.shape):
        v = out[idx]
        f = float(v)
        if f != 0.0 and abs(f) < tol:
            out[idx] = EF(0.0, math.nextafter(abs(f) + err(v), math.inf))
    return out


def lincomb(coefs, items):
    """``sum_k coefs[k] * items[k]`` for float ``coefs``; a float if the result is constant."""
    t: dict = {}
    const = 0.0
    for a, e in zip(coefs, items):
        a = num(a)
        if not keep(a):
            continue
        if isinstance(e, Expr):
            for k, v in e.terms.items():
                t[k] = t.get(k, 0.0) + a * v
        else:
            const += a * num(e)
    if not t:
        return const
    if keep(const):
        t[()] = t.get((), 0.0) + const
    t = {k: v for k, v in t.items() if keep(v)}
    if not t or list(t) == [()]:
        return t.get((), 0.0)
    return Expr(t)


def deg(a) -> int:
    return a.degree if isinstance(a, Expr) else 0


def simplify(a):
    """A float if ``a`` is a constant expression, else ``a``."""
    if isinstance(a, Expr) and a.degree == 0 and all(len(k) == 0 or v == 0.0 and not keep(v) for k, v in a.terms.items()):
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
    return [simplify(c * v[k]) if isinstance(c, Expr) or isinstance(v[k], Expr) else num(c) * num(v[k]) for k in range(3)]


def vdot(a, b):
    s = 0.0
    for x, y in zip(a, b):
        s = s + x * y
    return simplify(s)


def vcross(a, b):
    return [simplify(a[1] * b[2] - a[2] * b[1]), simplify(a[2] * b[0] - a[0] * b[2]), simplify(a[0] * b[1] - a[1] * b[0])]


def mat_mul(A, B) -> list:
    """``A B`` for 3x3 matrices as nested lists of scalars of any kind (see the module's text)."""
    return [[A[i][0] * B[0][j] + A[i][1] * B[1][j] + A[i][2] * B[2][j] for j in range(3)] for i in range(3)]


def mat_vec(A, v) -> list:
    """``A v`` for a 3x3 matrix and a 3-vector as lists of scalars of any kind."""
    return [A[i][0] * v[0] + A[i][1] * v[1] + A[i][2] * v[2] for i in range(3)]


def transpose(A) -> list:
    """``A^T`` for a 3x3 matrix as nested lists."""
    return [[A[j][i] for j in range(3)] for i in range(3)]


def kabsch(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """The rotation ``R`` that minimizes ``sum_i |R a_i - b_i|^2`` over the rows ``a_i`` of
    ``A`` and ``b_i`` of ``B`` (Kabsch: the SVD of ``A^T B``, a reflection turned into a
    rotation)."""
    U, _, Vt = np.linalg.svd(np.asarray(A, dtype=float).T @ np.asarray(B, dtype=float))
    D = np.diag([1.0, 1.0, float(np.sign(np.linalg.det(Vt.T @ U.T))) or 1.0])
    return Vt.T @ D @ U.T


def _const_product(A: np.ndarray, K):
    """``A @ K`` of constant arrays; of :class:`~kinbox.formulation.errfloat.EF` arrays (the
    shadow build) the same float values, each with its error (``errfloat.matmul``)."""
    K = np.asarray(K)
    if A.dtype == object or K.dtype == object:
        from ..errfloat import matmul  # noqa: PLC0415

        return matmul(A, K)
    return A @ K


def mat_mul_const(A, K: np.ndarray):
    """``A @ K`` for a matrix ``A`` (array or nested lists) and a constant array ``K``."""
    if isinstance(A, np.ndarray):
        return _const_product(A, K)
    return [[lincomb(K[:, j], A[i]) for j in range(K.shape[1])] for i in range(len(A))]


def mat_vec_const(A, v: np.ndarray):
    """``A @ v`` for a matrix ``A`` (array or nested lists) and a constant vector ``v``."""
    if isinstance(A, np.ndarray):
        return list(_const_product(A, v))
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


class Equations(Protocol):
    """Where the helpers below write: a :class:`System`, or a
    :class:`~kinbox.formulation.template.Template` (equations with parameters)."""

    def add_var(self, name: str, lo: float, hi: float, tag: str = "") -> Expr: ...

    def add_eq(self, expr, name: str = "", redundant: bool = False) -> None: ...

    def add_ineq(self, expr, name: str = "") -> None: ...


def add_eq(sys: Equations, expr, name: str, redundant: bool = False, tol: float = 1e-12) -> None:
    """``System.add_eq`` that drops constant equations satisfied up to ``tol`` (rounding)."""
    if not isinstance(expr, Expr) or expr.degree == 0:
        c = expr.constant if isinstance(expr, Expr) else float(expr)
        if abs(c) <= tol:
            return
    sys.add_eq(expr, name, redundant=redundant)


def add_ineq(sys: Equations, expr, name: str, tol: float = 1e-12) -> None:
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

    def on_linear(self, make_linear: Callable[[], None]) -> None:
        """Make the orientation linear with ``make_linear`` when :meth:`linear` is first asked."""
        self._make_linear = make_linear

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

        out.on_linear(make_linear)
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


def finite_limit(lo: float, hi: float) -> bool:
    return math.isfinite(lo) and math.isfinite(hi) and abs(lo) < UNBOUNDED and abs(hi) < UNBOUNDED
