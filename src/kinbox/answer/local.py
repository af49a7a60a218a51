"""The solution set near one point: rank, singular roots, multiplicity.

Every equation of a kinbox system has degree at most two, so around a point ``x0`` it is
exactly ``F(x0 + y) = F(x0) + J y + B(y, y)`` with the constant bilinear form ``B`` of its
monomials (no truncation). That makes three local questions cheap:

* the **rank** of the constraint Jacobian ``J`` (all equations, core and redundant) and the
  degrees of freedom ``n - rank`` that follow (:func:`rank`);
* a **singular root** (rank-deficient ``J``: a tangent, double or triple assembly mode, an arm at
  its elbow or wrist singularity) converges only linearly under Newton; :func:`refine` iterates
  least-squares steps until they stop helping, and ends within about ``eps**(1/m)`` of a root of
  multiplicity ``m``;
* its **multiplicity**: the dimension of the local dual space (Dayton and Zeng, *Computing the
  multiplicity structure in solving polynomial systems*, ISSAC 2005), computed on the
  Lyapunov-Schmidt reduction of ``F`` to the ``c = n - rank`` kernel directions (the local
  algebra, hence the multiplicity, is unchanged by the reduction, and its Macaulay matrices have
  ``C(c + k, k)`` columns instead of ``C(n + k, k)``). The reduced map is a power series whose
  coefficients follow from ``B`` by a recursion (:func:`reduced_series`). When the dimension of
  the dual space keeps growing with its order the point is not an isolated root of the complex
  system (a real point where a curve of complex solutions touches the reals, like a UR5 at its
  home pose): the multiplicity is then ``None`` and the growth rate the local dimension of the
  complex solution set.

Everything here is floating point and an *estimate*: proofs are Krawczyk's (:mod:`kinbox.search.certify`).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from ..formulation.system import Compiled
from ..search.lstsq import lstsq

#: relative size below which a singular value of ``J`` counts as zero (``J``'s entries are of
#: the order of the variables' ranges; a point is known to ~1e-8 near a double root, so its
#: "zero" singular values are ~1e-8 too)
RANK_RTOL = 1e-6
#: relative size below which a coefficient of the reduced series counts as zero (the point is
#: known to ~1e-8 near a double root, ~1e-6 near a triple one)
SERIES_RTOL = 1e-5
#: order up to which the dual space is computed (a multiplicity whose dual space needs a higher
#: order is reported as None)
MAX_ORDER = 8


class Quadratic:
    """The equations of a compiled system (rows ``0..m``, default all equations) as
    ``F(x) = Ax x + Am m(x) + c`` with the monomials ``m_k = x[mi_k] x[mj_k]``."""

    def __init__(self, comp: Compiled, rows: int | None = None):
        m = comp.n_eq if rows is None else rows
        self.comp, self.n, self.m = comp, comp.n, m
        A = comp.A[:m].tocsc()
        self.Am = A[:, comp.n :].tocsr()
        self.absA = abs(comp.A[:m].tocsr())
        self.mi, self.mj = comp.mi, comp.mj
        self.c = comp.c[:m]
        self.slack = comp.slack[:m] if len(comp.slack) else np.zeros(m)
        self.A = comp.A[:m].tocsr()

    def F(self, x: np.ndarray) -> np.ndarray:
        return self.A @ self.comp.z(x) + self.c

    def J(self, x: np.ndarray) -> np.ndarray:
        return self.comp.jacobian(x, slice(0, self.m))

    def B(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """The symmetric bilinear form of the monomials: ``F(x + y) = F(x) + J(x) y + B(y, y)``."""
        return self.Am @ (0.5 * (a[self.mi] * b[self.mj] + a[self.mj] * b[self.mi]))

    def scale(self, x: np.ndarray) -> np.ndarray:
        """Per row, the size of its terms at ``x`` (what its rounding error is relative to)."""
        return self.absA @ np.abs(self.comp.z(x)) + np.abs(self.c)

    def residual(self, x: np.ndarray) -> float:
        """The largest equation value at ``x`` relative to the size of the row's terms (and
        beyond the slack of derived rows): 0 at an exact root, ~1e-16 at a rounded one."""
        if self.m == 0:
            return 0.0
        r = np.maximum(np.abs(self.F(x)) - self.slack, 0.0) / (1.0 + self.scale(x))
        return float(np.max(r))


def rank(J: np.ndarray, rtol: float = RANK_RTOL) -> tuple[int, np.ndarray]:
    """Numerical rank of ``J`` and its singular values (largest first)."""
    if J.size == 0:
        return 0, np.zeros(0)
    s = np.linalg.svd(J, compute_uv=False)
    return int(np.sum(s > rtol * max(float(s[0]), 1.0))), s


def refine(q: Quadratic, x: np.ndarray, iters: int = 200) -> tuple[np.ndarray, float]:
    """Least-squares Newton steps from ``x`` as long as they lower the residual (near a singular
    root they converge linearly; the compiled Gauss-Newton gives up after a few slow steps).
    Returns the best point and its residual (:meth:`Quadratic.residual`)."""
    x = np.array(x, dtype=float)
    best, rb = x.copy(), q.residual(x)
    slow = 0
    for _ in range(iters):
        dx = lstsq(np.ascontiguousarray(q.J(x), dtype=float), -np.ascontiguousarray(q.F(x), dtype=float))[0]
        if not np.all(np.isfinite(dx)):  # also where J or F is not finite (NaN, nothing raised)
            break
        x = x + dx
        r = q.residual(x)
        if r < rb:
            slow = slow + 1 if r > 0.9 * rb else 0
            best, rb = x.copy(), r
        else:
            slow += 1
        if rb == 0.0 or slow >= 12 or np.max(np.abs(dx)) <= 1e-16 * (1.0 + np.max(np.abs(x))):
            break
    return best, rb


def monomials(c: int, k: int) -> list[tuple[int, ...]]:
    """Exponents of the monomials of degree ``k`` in ``c`` variables."""
    out = []
    for e in itertools.combinations_with_replacement(range(c), k):
        v = [0] * c
        for i in e:
            v[i] += 1
        out.append(tuple(v))
    return out


@dataclass
class Reduction:
    """The Lyapunov-Schmidt reduction of ``F`` at ``x0`` to its ``c`` kernel directions:
    ``g(z) = U2^T F(x0 + N z + W w(z))`` with ``w(z)`` solving the range equations."""

    x0: np.ndarray
    singular_values: np.ndarray
    rank: int
    kernel: np.ndarray  # n x c
    #: degree -> {exponent: coefficient vector of g}; degree 0 is U2^T F(x0) (~0)
    series: dict[int, dict[tuple[int, ...], np.ndarray]] = field(default_factory=dict)

    @property
    def corank(self) -> int:
        return self.kernel.shape[1]


def reduced_series(q: Quadratic, x0: np.ndarray, order: int = MAX_ORDER, rtol: float = RANK_RTOL) -> Reduction:
    """The reduced map's power series up to degree ``order`` (see :class:`Reduction`).

    With ``y = N z + W w``, ``J = U S V^T``: the range equations ``U1^T F = 0`` give
    ``w = -S1^-1 U1^T (F(x0) + B(y, y))`` degree by degree (``w`` has no linear term), and
    ``g = U2^T (F(x0) + B(y, y))``.
    """
    J = q.J(x0)
    U, S, Vt = np.linalg.svd(J, full_matrices=True)
    r = int(np.sum(S > rtol * max(float(S[0]) if len(S) else 0.0, 1.0)))
    N, W = Vt[r:].T, Vt[:r].T
    U1, U2, S1 = U[:, :r], U[:, r:], S[:r]
    c = q.n - r
    F0 = q.F(x0)
    red = Reduction(x0, S, r, N)
    zero = tuple([0] * c)
    red.series[0] = {zero: U2.T @ F0}
    y: dict[int, dict[tuple[int, ...], np.ndarray]] = {1: {e: N[:, i] for i, e in enumerate(monomials(c, 1))}}
    # the constant part of w (from F(x0) != 0) is below the point's accuracy: left out
    for k in range(2, order + 1):
        acc: dict[tuple[int, ...], np.ndarray] = {}
        for i in range(1, k // 2 + 1):
            j = k - i
            for ea, va in y[i].items():
                for eb, vb in y[j].items():
                    if i == j and eb < ea:
                        continue
                    e = tuple(a + b for a, b in zip(ea, eb))
                    f = 1.0 if (i == j and ea == eb) else 2.0
                    acc[e] = acc.get(e, 0.0) + f * q.B(va, vb)
        y[k] = {e: W @ (-(U1.T @ v) / S1) for e, v in acc.items()}
        red.series[k] = {e: U2.T @ v for e, v in acc.items()}
    return red


def dual_dimensions(red: Reduction, rtol: float = SERIES_RTOL) -> list[int]:
    """``dim`` of the local dual space of order ``<= k`` for ``k = 0 .. order - 1`` (the
    Hilbert function of the local algebra, summed): the null space of the Macaulay matrix whose
    rows are ``z^b g_i`` (``|b| < k``) truncated to degree ``k``."""
    c = red.corank
    order = max(red.series)
    if c == 0:
        return [1] * order
    poly: dict[tuple[int, ...], np.ndarray] = {}
    for terms in red.series.values():
        for e, v in terms.items():
            poly[e] = poly.get(e, 0.0) + v
    p = len(next(iter(poly.values())))
    size = max((float(np.max(np.abs(v))) for e, v in poly.items() if sum(e) >= 1), default=0.0)
    dims = []
    for k in range(order):
        cols = [e for d in range(k + 1) for e in monomials(c, d)]
        at = {e: i for i, e in enumerate(cols)}
        rows = []
        for d in range(k):
            for b in monomials(c, d):
                block = np.zeros((p, len(cols)))
                for e, v in poly.items():
                    ee = tuple(u + w for u, w in zip(e, b))
                    if sum(ee) <= k:
                        block[:, at[ee]] += v
                rows.append(block)
        if rows and size > 0:
            s = np.linalg.svd(np.vstack(rows), compute_uv=False)
            r = int(np.sum(s > rtol * size))
        else:
            r = 0
        dims.append(len(cols) - r)
    return dims


@dataclass
class Multiplicity:
    #: the multiplicity, or None if the dual space did not stop growing (not an isolated
    #: root of the complex system, or a multiplicity too high to tell)
    value: int | None
    corank: int
    #: dimensions of the dual space by order
    dims: list[int]

    @property
    def complex_dimension(self) -> int | None:
        """When the dual space grows without end: how fast (1: a curve of complex solutions)."""
        if self.value is not None or len(self.dims) < 3:
            return None
        steps = np.diff(self.dims[-3:])
        return 1 if steps[-1] == steps[-2] and steps[-1] > 0 else None


def multiplicity(q: Quadratic, x0: np.ndarray, order: int = MAX_ORDER) -> Multiplicity:
    """Estimated multiplicity of the root ``x0`` (see the module docstring)."""
    red = reduced_series(q, x0, order)
    if red.corank == 0:
        return Multiplicity(1, 0, [1])
    dims = dual_dimensions(red)
    # the dual space is complete once it stops growing; two equal steps guard against a
    # coefficient at the noise level
    value = dims[-1] if len(dims) >= 3 and dims[-1] == dims[-2] == dims[-3] else None
    return Multiplicity(value, red.corank, dims)
