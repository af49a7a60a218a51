"""Existence and uniqueness proofs (Krawczyk) and Newton polishing of isolated solutions.

The core equations ``F`` of a kinbox system are square and quadratic, so their Jacobian is
affine: ``J(x) = J(x0) + T(x - x0)`` with a constant, sparse ``T``. Over a box ``B`` the
Jacobian is therefore enclosed exactly (up to rounding) by ``J(x0) +- |T| d`` where ``d``
bounds ``|x - x0|``. For a quadratic ``F`` the mean value theorem holds exactly at the midpoint:
``F(x) - F(x0) = J((x + x0) / 2) (x - x0)``, and the midpoints of ``B`` lie within ``d / 2`` of
``x0``, so ``J(M) = J(x0) +- |T| d / 2`` serves where only ``x0`` is paired with the box's
points. The Krawczyk operator in this slope form

    K(B) = x0 - Y F(x0) + (I - Y J(M)) (B - x0),      Y ~ J(x0)^-1,

evaluated in outward-rounded arithmetic, gives three results used by the solver:

* ``K(B) ⊂ int(B)`` together with ``|I - Y J(B)| d < d`` (every row, strictly) proves that
  ``B`` holds exactly one zero of ``F``: ``x - Y F(x)`` maps ``B`` into ``K(B)`` (existence,
  Brouwer), and two zeros ``x, x'`` would give ``x - x' = (I - Y J(m)) (x - x')`` with ``m``
  their midpoint, anywhere in ``B``, which the second condition forbids in the norm scaled by
  ``d`` (uniqueness) — the box needs no more splitting, whatever sigma is;
* every zero of ``F - e`` in ``B``, for every ``|e| <= slack``, lies in ``K(B) + |Y| slack``
  (a contractor; an empty intersection with ``B`` proves that ``B`` holds no such point: the
  search keeps every point where the rows hold to their slack, see ``SLACK`` in
  :mod:`kinbox.formulation.system`, so what it discards must be free of those too);
* iterating ``B <- K(B) ∩ B`` (without the slack) shrinks a proven box around its zero.

The slope form halves the Jacobian's spread in ``K`` against the whole-box form (the usual
Krawczyk operator), so narrowing reaches boxes about twice as wide; the uniqueness condition
keeps the whole box's Jacobian.

A zero of the core is a solution of the whole system when it satisfies the inequalities
(checked with interval evaluation over the final enclosure); the redundant equations are
implied by construction (``docs/formulation.md``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba as nb
import numpy as np

from .. import interval as iv
from ..formulation.system import Compiled, Rows
from .lstsq import lstsq

#: core matrices up to this many entries are kept dense for point evaluations
DENSE_CORE = 40_000
#: Newton and Gauss-Newton give up after this many steps without halving the residual
STALL = 6
#: :func:`set_newton` drops singular values of ``J`` below this share of the largest
TRUNCATE = 1e-2


@dataclass
class KrawczykResult:
    status: str  # "unique", "empty", "contracted" or "none"
    lo: np.ndarray
    hi: np.ndarray
    #: the radius ``K`` has even for a point box (``|Y| |F(x0)|``'s error and the slack): a box
    #: narrower than twice this in some coordinate cannot be proven unique
    floor: np.ndarray | None = None


class Certifier:
    """Krawczyk tests and Newton steps on the square core of a compiled system."""

    def __init__(self, comp: Compiled):
        self.comp = comp
        n = comp.n
        self.square = comp.n_core == n and n > 0
        R = comp.rows(comp.n_core)
        self.Ax, self.t_var, self.t_flat = R.Ax, R.t_var, R.t_flat
        self.t_abs = np.abs(R.t_coef)
        # rounding of those sums: at most k terms per entry (and the linear part), each a product
        self.g_slope = float(iv.gamma(int(np.bincount(self.t_flat).max(initial=0)) + 3))
        A_core = comp.A[: comp.n_core].tocsr()
        # point evaluations are ~20x more frequent than anything else here; a dense core is
        # faster to multiply up to a few hundred columns
        self.A_core = A_core.toarray() if A_core.shape[0] * A_core.shape[1] <= DENSE_CORE else A_core
        self.row_nnz = np.diff(A_core.indptr)
        self.c_core = comp.c[: comp.n_core]
        #: zeros of F - e for every |e| <= slack are the solutions a search keeps (every row holds
        #: up to its slack): Krawczyk encloses them all, so its "empty" verdicts are about them
        self.slack_core = comp.slack[: comp.n_core]
        #: how far the rows of the input as given may lie from the rounded ones (value, and every
        #: partial derivative): every proof here holds for all rows within these bounds
        self.merr_core, self.mgrad_core = comp.model_error(comp.n_core)
        self.R = R

    # -- point evaluations ------------------------------------------------------------
    def F(self, x: np.ndarray) -> np.ndarray:
        return self.A_core @ self.comp.z(x) + self.c_core

    def J(self, x: np.ndarray) -> np.ndarray:
        return self.comp.jacobian(x, slice(0, self.comp.n_core))

    def _slopes(self, w: np.ndarray) -> np.ndarray:
        """The n_core x n matrix with the slope terms ``w`` summed at their places."""
        return np.bincount(self.t_flat, weights=w, minlength=self.Ax.size).reshape(self.Ax.shape)

    def jacobian_radius(self, x0: np.ndarray, d: np.ndarray, share: float = 1.0) -> np.ndarray:
        """``Jrad`` with ``J(x) in J(x0) +- Jrad`` (entrywise) for every ``|x - x0| <= share *
        d``: the slope spread over the box plus the rounding of ``J(x0)`` as :meth:`J` computes
        it (``share=0.5``: over the midpoints ``(x + x0) / 2`` of the box ``|x - x0| <= d``)."""
        Jrad = share * self._slopes(self.t_abs * d[self.t_var])
        # J0 is a sum of up to k terms per entry: off by gamma(k+2) times their magnitudes
        J0err = self.g_slope * (np.abs(self.Ax) + self._slopes(self.t_abs * np.abs(x0)[self.t_var]))
        return (Jrad + J0err + self.mgrad_core[:, None]) * (1 + self.g_slope) + iv.TINY

    def F_enclosure(self, x: np.ndarray, model: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """``F(x)`` rounded to binary64 (nearly always correctly) and a rigorous bound on its
        error, each row evaluated as if in twice the working precision (:func:`_f_enclosure_kernel`):
        the bound is dominated by the final rounding of ``F`` itself, not by the size of its
        terms. Near a singular root ``|J^-1|`` reaches 1e7 and the binary64 bound (~1e-16 times
        the terms) times ``|J^-1|`` was already wider than any box Krawczyk could prove (UR5 one
        micro-radian from the elbow singularity). ``model``: add the bound of the input's rows'
        distance from the rounded ones (``Compiled.merr``), so that the enclosure is of the
        input's rows at ``x``; without it, of the rounded rows'."""
        R = self.R
        F = np.empty(R.c.shape[0])
        eF = np.empty(R.c.shape[0])
        _f_enclosure_kernel(np.ascontiguousarray(x, dtype=float), R.n, R.mi, R.mj, R.indptr, R.indices, R.data, R.c, iv.U, iv.TINY, F, eF)
        return F, (_with_model_error(eF, self.merr_core) if model else eF)

    # -- Krawczyk -------------------------------------------------------------------------
    def krawczyk(self, lo: np.ndarray, hi: np.ndarray, x0: np.ndarray | None = None, exact: bool = False) -> KrawczykResult:
        """The Krawczyk test on ``[lo, hi]``. ``exact`` drops the slack: ``K`` then encloses the
        zeros of ``F`` alone (to locate a root already proven unique, not to discard a box)."""
        return self._krawczyk(lo, hi, x0, exact)  # compiled: an overflow gives no verdict, no warning

    def _krawczyk(self, lo: np.ndarray, hi: np.ndarray, x0: np.ndarray | None, exact: bool) -> KrawczykResult:
        if not self.square:
            return KrawczykResult("none", lo, hi)
        R = self.R
        lo = np.ascontiguousarray(lo, dtype=float)
        hi = np.ascontiguousarray(hi, dtype=float)
        status, klo, khi, eYF = _krawczyk_full(
            lo,
            hi,
            np.empty(0) if x0 is None else np.ascontiguousarray(x0, dtype=float),
            R.Ax,
            R.t_flat,
            R.t_var,
            R.t_coef,
            self.t_abs,
            self.g_slope,
            self.slack_core,
            self.merr_core,
            self.mgrad_core,
            exact,
            iv.TINY,
            iv.U,
            R.mi,
            R.mj,
            R.indptr,
            R.indices,
            R.data,
            R.c,
        )
        if status == _K_UNIQUE:
            return KrawczykResult("unique", klo, khi, eYF)
        if status == _K_EMPTY:
            return KrawczykResult("empty", klo, khi, eYF)
        if status == _K_CONTRACTED:
            return KrawczykResult("contracted", klo, khi, eYF)
        if status == _K_NONE:
            return KrawczykResult("none", lo, hi, eYF)
        return KrawczykResult("none", lo, hi)  # J(x0) singular or K not finite: no verdict

    def at_most_one_zero(self, lo: np.ndarray, hi: np.ndarray, x0: np.ndarray) -> bool:
        """Krawczyk's uniqueness condition (:func:`at_most_one_kernel`) on the box ``[lo, hi]``
        about ``x0``, with ``Y`` the inverse of ``J(x0)``: True proves that ``F`` has at most
        one zero in the box; False decides nothing."""
        J0 = self.J(x0)
        Y = np.empty_like(J0)
        if not lu_inverse(J0, Y):
            return False
        R = self.R
        b_lo, b_hi, x = (np.ascontiguousarray(v, dtype=float) for v in (lo, hi, x0))
        d, Jrad, _ = box_jacobian_radius(b_lo, b_hi, x, R.Ax, R.t_var, R.t_flat, self.t_abs, self.g_slope, iv.TINY, self.mgrad_core)
        return bool(at_most_one_kernel(d, J0, Y, np.arange(len(x)), Jrad, len(x), iv.TINY))

    def tighten(self, lo, hi, x0=None, iters: int = 30):
        """Iterate ``B <- K(B) ∩ B`` on a box proven to hold one zero of ``F``; returns the final
        box. Without the slack: the enclosure is of that exact zero, a few ulps wide, so whether
        it lies in the domain can be told even for a root on a bound."""
        for _ in range(iters):
            r = self.krawczyk(lo, hi, x0, exact=True)
            if r.status == "empty":  # cannot happen for a proven box; keep the proven one
                break
            nlo, nhi = np.maximum(lo, r.lo), np.minimum(hi, r.hi)
            if np.all(nhi - nlo >= 0.9 * (hi - lo)):
                lo, hi = nlo, nhi
                break
            lo, hi = nlo, nhi
            x0 = None
        return lo, hi

    # -- Newton -----------------------------------------------------------------------------
    def newton(self, x: np.ndarray, lo: np.ndarray | None = None, hi: np.ndarray | None = None, iters: int = 20) -> np.ndarray:
        """Newton's method on the core from ``x`` (kept in ``[lo, hi]`` if given)."""
        return _newton(self.comp.rows(self.comp.n_core), x, lo, hi, iters, square=True)


def _with_model_error(eF: np.ndarray, merr: np.ndarray) -> np.ndarray:
    """``eF + merr`` rounded up: the error bound of ``F(x0)`` as an enclosure of the input's rows."""
    if not np.any(merr):
        return eF
    return np.nextafter(eF + merr, np.inf)


def gauss_newton(comp: Compiled, x: np.ndarray, lo=None, hi=None, iters: int = 30) -> np.ndarray:
    """Gauss-Newton on all equations (for non-square systems), kept in ``[lo, hi]`` if given."""
    return _newton(comp.rows(comp.n_eq), x, lo, hi, iters, square=False)


def set_newton(comp: Compiled, x: np.ndarray, iters: int = 12) -> np.ndarray:
    """A point of the solution set near ``x``, however singular: Gauss-Newton on the core
    equations with the pseudo-inverse of ``J`` truncated at :data:`TRUNCATE` of its largest
    singular value (the best point seen).

    Near a curve ``J`` is close to rank-deficient: a full least-squares (or Newton) step
    divides by the tiny singular value across the curve's tangent and runs far along it, and
    on all rows the redundant ones make ``J`` tall and of full rank there. Both stalled on most
    boxes next to a curve (the four-bar, Griffis-Duffy); dropping the near-null directions steps
    straight onto the set.
    """
    R = comp.rows(comp.n_core)
    return _set_newton_kernel(
        np.array(x, dtype=float),
        int(iters),
        TRUNCATE,
        STALL,
        R.n,
        R.mi,
        R.mj,
        R.indptr,
        R.indices,
        R.data,
        R.c,
        R.Ax,
        R.t_flat,
        R.t_var,
        R.t_coef,
    )


def load_kernel() -> None:
    """Load (on the first run: compile and cache) the compiled Newton kernel; a solve does it
    when it first needs it. Benchmarks time it apart, with ``propagate.load_kernel``."""
    one, idx = np.ones(1), np.zeros(1, dtype=np.int64)
    _newton_kernel(
        one, one, one, False, 1, True, STALL, 1, idx, idx, np.array([0, 1]), idx, one, -one, np.ones((1, 1)), idx, idx, np.zeros(1)
    )
    _set_newton_kernel(one, 1, TRUNCATE, STALL, 1, idx, idx, np.array([0, 1]), idx, one, -one, np.ones((1, 1)), idx, idx, np.zeros(1))
    eye = np.ones((1, 1))
    _krawczyk_kernel(-one, one, 0 * one, eye, eye, 0 * one, 0 * one, eye, idx, idx, one, 0.0, 0 * one, 0 * one, False, iv.TINY)
    # called here, not only from the transverse operator: a kernel compiled as another's callee
    # gets no cache entry of its own, and kernels_cached() would stay False
    at_most_one_scaled(one, eye, eye, idx, eye, 1, iv.TINY)
    _f_enclosure_kernel(one, 1, idx, idx, np.array([0, 1]), idx, one, -one, iv.U, iv.TINY, np.empty(1), np.empty(1))
    ptr = np.array([0, 1])
    _krawczyk_full(
        -one, one, np.empty(0), eye, idx, idx, one, one, 0.0, 0 * one, 0 * one, 0 * one, False, iv.TINY, iv.U, idx, idx, ptr, idx, one, -one
    )


# -- compiled Krawczyk -------------------------------------------------------------------------
# The Krawczyk test runs on most boxes of an arm's search (about 70 tests a UR5 pose), and its
# numpy form was some forty calls on small arrays (a third of the pose's time). Everything after
# ``Y`` and ``F(x0)`` is one compiled call: the same formulas and error terms, element by element
# (sums in any order are covered by Higham's gamma; nextafter moves a result one ulp outward, as
# in :mod:`kinbox.interval`); the three matrix products go to BLAS through numba as they went
# through numpy. ``tests/search/test_soundness_*.py`` check its verdicts.
_K_NOT_FINITE, _K_NONE, _K_UNIQUE, _K_EMPTY, _K_CONTRACTED = 0, 1, 2, 3, 4


@nb.njit(cache=True)
def lu_inverse(A, Y):
    """``Y = A^-1`` by LU with partial pivoting and a solve per column (LAPACK's gesv with the
    identity, as ``np.linalg.inv`` computes it, in another order of operations); False if a
    pivot is zero or the result is not finite. ``Y`` only has to be near ``J(x0)^-1``: any
    matrix keeps Krawczyk sound."""
    n = A.shape[0]
    M = A.copy()
    perm = np.arange(n)
    if not _lu_factor(M, perm):
        return False
    e = np.zeros(n)
    col = np.empty(n)
    for c in range(n):
        e[c] = 1.0
        ok = _lu_substitute(M, perm, e, col)
        e[c] = 0.0
        if not ok:
            return False
        for i in range(n):
            Y[i, c] = col[i]
    return True


@nb.njit(cache=True)
def _lu_factor(M, perm):
    """``M`` overwritten by its LU factors with partial pivoting (the multipliers of the unit
    lower triangle below the diagonal), ``perm`` by the rows' order; False if a pivot is zero or
    NaN. :func:`lu_inverse` and Newton's :func:`_lu_solve` share it."""
    n = M.shape[0]
    for k in range(n):
        p = k
        for i in range(k + 1, n):
            if abs(M[i, k]) > abs(M[p, k]):
                p = i
        if not M[p, k] != 0.0:  # zero or NaN
            return False
        if p != k:
            for j in range(n):
                M[k, j], M[p, j] = M[p, j], M[k, j]
            perm[k], perm[p] = perm[p], perm[k]
        piv = M[k, k]
        for i in range(k + 1, n):
            f = M[i, k] / piv
            M[i, k] = f
            if f != 0.0:
                for j in range(k + 1, n):
                    M[i, j] -= f * M[k, j]
    return True


@nb.njit(cache=True)
def _lu_substitute(M, perm, b, x):
    """``x = A^-1 b`` from the factors of :func:`_lu_factor`; False if it is not finite."""
    n = M.shape[0]
    for i in range(n):  # forward: L (unit diagonal), b in the pivots' order
        s = b[perm[i]]
        for j in range(i):
            s -= M[i, j] * x[j]
        x[i] = s
    for i in range(n - 1, -1, -1):
        s = x[i]
        for j in range(i + 1, n):
            s -= M[i, j] * x[j]
        x[i] = s / M[i, i]
    for i in range(n):
        if not np.isfinite(x[i]):
            return False
    return True


@nb.njit(cache=True)
def _krawczyk_full(
    lo, hi, x0, Ax, t_flat, t_var, t_coef, t_abs, g_slope, slack, merr, mgrad, exact, tiny, u, mi, mj, indptr, indices, data, c
):
    """:meth:`Certifier._krawczyk` in one call: ``x0`` (the centre when empty) clipped to the box,
    ``J(x0)`` (summed as :meth:`Compiled.jacobian` sums it), ``Y``, ``F(x0)`` with its bound, then
    :func:`_krawczyk_kernel`. Status :data:`_K_NOT_FINITE` also for a singular ``J(x0)``."""
    n = lo.shape[0]
    x = np.empty(n)
    for i in range(n):
        v = 0.5 * (lo[i] + hi[i]) if x0.shape[0] == 0 else x0[i]
        x[i] = min(max(v, lo[i]), hi[i])
    acc = np.zeros(Ax.size)
    for k in range(t_flat.shape[0]):
        acc[t_flat[k]] += t_coef[k] * x[t_var[k]]
    J0 = Ax + acc.reshape(Ax.shape)
    Y = np.empty((n, n))
    if not lu_inverse(J0, Y):
        return _K_NOT_FINITE, lo, hi, np.zeros(n)
    F0 = np.empty(n)
    eF = np.empty(n)
    _f_enclosure_kernel(x, n, mi, mj, indptr, indices, data, c, u, tiny, F0, eF)
    for k in range(n):  # the rows of the input as given lie within merr of the rounded ones
        eF[k] = np.nextafter(eF[k] + merr[k], np.inf)
    return _krawczyk_kernel(lo, hi, x, J0, Y, F0, eF, Ax, t_var, t_flat, t_abs, g_slope, slack, mgrad, exact, tiny)


@nb.njit(cache=True)
def _gamma(k):
    nu = k * 2.0**-53
    return nu / (1.0 - nu)


@nb.njit(cache=True)
def box_jacobian_radius(lo, hi, x0, Ax, t_var, t_flat, t_abs, g_slope, tiny, mgrad):
    """``d`` (the box's radius about ``x0``, rounded up), ``Jrad`` with ``J(x) in J(x0) +-
    Jrad`` over the box (:meth:`Certifier.jacobian_radius`) and ``Jmid``, the same over the
    midpoints ``(x + x0) / 2`` (half the slope part; the rounding of ``J(x0)`` stays whole), for
    the compiled Krawczyk and transverse operators. ``mgrad`` (per row): how far each partial
    derivative of the input's rows may lie from the rounded rows' (``Compiled.mgrad``), added to
    both spreads."""
    n = x0.shape[0]
    inf = np.inf
    d = np.empty(n)
    for i in range(n):
        a = np.nextafter(hi[i] - x0[i], inf)
        b = np.nextafter(x0[i] - lo[i], inf)
        d[i] = a if a >= b or a != a else b  # NaN propagates, as np.maximum does
    m = Ax.shape[0]
    sr = np.zeros(m * n)
    s0 = np.zeros(m * n)
    for k in range(t_flat.shape[0]):
        sr[t_flat[k]] += t_abs[k] * d[t_var[k]]
        s0[t_flat[k]] += t_abs[k] * abs(x0[t_var[k]])
    Jrad = np.empty((m, n))
    Jmid = np.empty((m, n))
    for r in range(m):
        for j in range(n):
            e = r * n + j
            j0err = g_slope * (abs(Ax[r, j]) + s0[e])
            Jrad[r, j] = (sr[e] + j0err + mgrad[r]) * (1 + g_slope) + tiny
            # 0.5 * sr is exact but for subnormal sr, where ``tiny`` covers the half ulp
            Jmid[r, j] = (0.5 * sr[e] + j0err + mgrad[r]) * (1 + g_slope) + tiny
    return d, Jrad, Jmid


@nb.njit(cache=True)
def _krawczyk_kernel(lo, hi, x0, J0, Y, F0, eF, Ax, t_var, t_flat, t_abs, g_slope, slack, mgrad, exact, tiny):
    """``K(B)`` of :meth:`Certifier._krawczyk` (see the module docstring) and its verdict: a
    status code, the new bounds and ``eYF`` (the radius ``K`` has for a point box)."""
    n = x0.shape[0]
    inf = np.inf
    d, Jrad, Jmid = box_jacobian_radius(lo, hi, x0, Ax, t_var, t_flat, t_abs, g_slope, tiny, mgrad)
    absJ0 = np.abs(J0)
    absY = np.abs(Y)
    YJ = Y @ J0
    AJmid = absY @ Jmid
    AJ0 = absY @ absJ0
    g2 = _gamma(n + 2.0)
    g3 = _gamma(n + 3.0)
    klo = np.empty(n)
    khi = np.empty(n)
    eYF = np.empty(n)
    finite = True
    for i in range(n):
        yf = 0.0
        e1 = 0.0
        e2 = 0.0
        for k in range(n):
            yf += Y[i, k] * F0[k]
            e1 += absY[i, k] * eF[k]
            e2 += absY[i, k] * abs(F0[k])
        eYF[i] = e1 + g2 * e2 + tiny
        rho = 0.0
        for j in range(n):
            c = abs((1.0 if i == j else 0.0) - YJ[i, j]) + g3 * (AJ0[i, j] + 1.0)
            rho += (c + AJmid[i, j]) * d[j]
        rho = np.nextafter(rho * (1 + g2), inf) + tiny
        cen = x0[i] - yf
        klo[i] = np.nextafter(np.nextafter(cen - eYF[i], -inf) - rho, -inf)
        khi[i] = np.nextafter(np.nextafter(cen + eYF[i], inf) + rho, inf)
        if not (np.isfinite(klo[i]) and np.isfinite(khi[i])):
            finite = False
    if not finite:
        return _K_NOT_FINITE, klo, khi, eYF
    # uniqueness is proven for the zero of F itself (without the slack)
    inside = True
    for i in range(n):
        if not (klo[i] > lo[i] and khi[i] < hi[i]):
            inside = False
    # uniqueness over the whole box (over K alone, where every zero lies, would do for the proof,
    # but a curve box's graph test taken over K made Bricard's answer report a stray point)
    if inside and at_most_one_kernel(d, J0, Y, np.arange(n), Jrad, n, tiny):
        return _K_UNIQUE, klo, khi, eYF
    if not exact:  # verdicts that discard points: about every zero of F - e, |e| <= slack
        for i in range(n):
            es = 0.0
            for k in range(n):
                es += absY[i, k] * slack[k]
            w = np.nextafter(es * (1 + g2), inf)
            klo[i] = np.nextafter(klo[i] - w, -inf)
            khi[i] = np.nextafter(khi[i] + w, inf)
    empty = False
    moved = False
    for i in range(n):
        a = max(lo[i], klo[i])
        b = min(hi[i], khi[i])
        klo[i] = a
        khi[i] = b
        if a > b:
            empty = True
        if a > lo[i] or b < hi[i]:
            moved = True
    if empty:
        return _K_EMPTY, klo, khi, eYF
    if moved:
        return _K_CONTRACTED, klo, khi, eYF
    return _K_NONE, klo, khi, eYF


@nb.njit(cache=True)
def at_most_one_kernel(d, J0, Y, V, Jrad, m, tiny):
    """Krawczyk's uniqueness condition for the zeros of ``Y F`` in ``y = x[V]`` (the other
    variables held) in a box of radius ``d`` about ``x0``, over which ``J(x) in J(x0) +- Jrad``
    (``J0`` is ``J(x0)``, ``m`` the number of rows ``Y`` sums over). Two zeros ``y, y'`` would
    meet at a midpoint ``mid`` in the box, with ``y - y' = (I - Y J_V(mid)) (y - y')``. None can
    if ``(|I - Y J_V(x0)| + |Y| Jrad_V) d_V < d_V`` in every row (strictly, each term rounded up;
    any positive scaling vector serves, ``d_V`` is the box's radius). Square Krawczyk has ``V``
    = every variable and ``Y = J(x0)^-1``."""
    k = V.shape[0]
    g = _gamma(m + 3.0)
    gn = _gamma(d.shape[0] + 2.0)
    absY = np.abs(Y)
    JV = np.ascontiguousarray(J0[:, V])
    YJV = Y @ JV
    AV = absY @ np.abs(JV)
    RV = absY @ np.ascontiguousarray(Jrad[:, V])
    for i in range(k):
        r = 0.0
        for jj in range(k):
            c = abs((1.0 if i == jj else 0.0) - YJV[i, jj]) * (1 + g)
            r += (c + (RV[i, jj] + g * (AV[i, jj] + 1.0)) * (1 + g)) * d[V[jj]]
        if not np.nextafter(r * (1 + gn) * (1 + gn), np.inf) + tiny < d[V[i]]:
            return False
    return True


@nb.njit(cache=True)
def at_most_one_scaled(d, J0, Y, V, Jrad, m, tiny):
    """:func:`at_most_one_kernel` scaled by the box's radius ``d_V`` and, where that fails, by
    ``v = (I - M)^-1 1``, ``M = |I - Y J_V(x0)| + |Y| Jrad_V`` (in floating point: ``v`` is only
    a candidate). The condition holds for some positive vector exactly when ``M``'s spectral
    radius is below one, and then ``v`` is one (``M v = v - 1 < v``); the radius itself fails
    where the box is much narrower in some ``y`` than in others (a link that hardly turns along a
    piece of the rhombus four-bar's curve beside one that turns with the parameter), although
    the spread ``Jrad`` is small. Whatever ``v`` is, the verdict is
    :func:`at_most_one_kernel`'s rounded test with it: a positive ``v`` it accepts proves the
    spectral radius below one (tests/search/test_transverse.py)."""
    if at_most_one_kernel(d, J0, Y, V, Jrad, m, tiny):
        return True
    k = V.shape[0]
    A = np.empty((k, k))
    for i in range(k):
        for j in range(k):
            yj = 0.0
            yr = 0.0
            for r in range(m):
                yj += Y[i, r] * J0[r, V[j]]
                yr += abs(Y[i, r]) * Jrad[r, V[j]]
            A[i, j] = (1.0 if i == j else 0.0) - (abs((1.0 if i == j else 0.0) - yj) + yr)
    perm = np.arange(k)
    if not _lu_factor(A, perm):
        return False
    ones = np.ones(k)
    v = np.empty(k)
    if not _lu_substitute(A, perm, ones, v):
        return False
    scaled = d.copy()
    for i in range(k):
        if not v[i] > 0.0:
            return False
        scaled[V[i]] = v[i]
    return at_most_one_kernel(scaled, J0, Y, V, Jrad, m, tiny)


# -- compiled Newton ---------------------------------------------------------------------------
# Newton runs decide whether a small box holds a root (and polish every solution): tens of
# thousands of short runs on a platform, a third of the solve as numpy calls (benchmarks/bench.py
# shows it on Dietmeier's platform). The same iteration compiled by numba. It is a heuristic
# everywhere it is used (proofs are Krawczyk's), so no outward rounding.


def _newton(R: Rows, x, lo, hi, iters: int, square: bool) -> np.ndarray:
    x = np.array(x, dtype=float)
    clip = lo is not None
    lo = np.asarray(lo, dtype=float) if clip else x
    hi = np.asarray(hi, dtype=float) if clip else x
    return _newton_kernel(
        x, lo, hi, clip, int(iters), square, STALL, R.n, R.mi, R.mj, R.indptr, R.indices, R.data, R.c, R.Ax, R.t_flat, R.t_var, R.t_coef
    )


@nb.njit(cache=True)
def _rows_F(x, n, mi, mj, indptr, indices, data, c, out):
    for r in range(c.shape[0]):
        s = c[r]
        for p in range(indptr[r], indptr[r + 1]):
            k = indices[p]
            s += data[p] * (x[k] if k < n else x[mi[k - n]] * x[mj[k - n]])
        out[r] = s


@nb.njit(cache=True)
def _maxabs(v):
    m = 0.0
    for e in v:
        a = abs(e)
        if a > m or a != a:
            m = a
    return m


@nb.njit(cache=True)
def _lu_solve(A, b, out):
    """Solve ``A out = b`` by Gaussian elimination with partial pivoting; False (``out``
    unspecified) if a pivot is zero or NaN or the result is not finite. ``A`` and ``b`` are kept."""
    M = A.copy()
    perm = np.arange(A.shape[0])
    return _lu_factor(M, perm) and _lu_substitute(M, perm, b, out)


@nb.njit(cache=True)
def _copy2(dst, src):
    """``dst[:, :] = src`` element by element: numba's slice copy compiles a formatted
    shape-error message, seconds of the first run's compilation (same values, bit for bit)."""
    for i in range(src.shape[0]):
        for j in range(src.shape[1]):
            dst[i, j] = src[i, j]


@nb.njit(cache=True)
def _jacobian_into(J, x, Ax, t_flat, t_var, t_coef):
    """``J = J(x)``: the constant part ``Ax`` plus each slope term at its place."""
    _copy2(J, Ax)
    Jf = J.reshape(-1)
    for k in range(t_flat.shape[0]):
        Jf[t_flat[k]] += t_coef[k] * x[t_var[k]]


@nb.njit(cache=True)
def _newton_kernel(x, lo, hi, clip, iters, square, stall_max, n, mi, mj, indptr, indices, data, c, Ax, t_flat, t_var, t_coef):
    """Newton (``square``: ``J^-1 F``, least squares where J is singular) or Gauss-Newton from
    ``x``; the best point seen. Stops at convergence, when the residual has not halved in
    ``stall_max`` steps, or when the iteration overflows."""
    x = x.copy()
    F = np.empty(c.shape[0])
    _rows_F(x, n, mi, mj, indptr, indices, data, c, F)
    best = x.copy()
    best_r = _maxabs(F)
    stall = 0
    J = np.empty_like(Ax)
    step = np.zeros(x.shape[0])
    for _ in range(iters):
        if not (np.all(np.isfinite(F)) and np.all(np.isfinite(x))):
            break
        _jacobian_into(J, x, Ax, t_flat, t_var, t_coef)
        if not np.all(np.isfinite(J)):
            break
        solved = False
        if square:
            solved = _lu_solve(J, F, step)
        if not solved:
            # least squares where J is singular or not square (minimum norm, numpy's cut-off);
            # the inputs are finite
            step = lstsq(J, F)[0]
        x = x - step
        if clip:
            x = np.minimum(np.maximum(x, lo), hi)
        _rows_F(x, n, mi, mj, indptr, indices, data, c, F)
        r = _maxabs(F)
        stall = 0 if r < 0.5 * best_r else stall + 1
        if stall >= stall_max or r != r:
            break
        if r < best_r:
            for k in range(x.shape[0]):
                best[k] = x[k]
            best_r = r
        if r == 0.0 or _maxabs(step) < 1e-16 * (1.0 + _maxabs(x)):
            break
    return best


@nb.njit(cache=True)
def _set_newton_kernel(x, iters, trunc, stall_max, n, mi, mj, indptr, indices, data, c, Ax, t_flat, t_var, t_coef):
    """Gauss-Newton with the truncated pseudo-inverse (see :func:`set_newton`); the best point."""
    x = x.copy()
    F = np.empty(c.shape[0])
    _rows_F(x, n, mi, mj, indptr, indices, data, c, F)
    best = x.copy()
    best_r = _maxabs(F)
    stall = 0
    J = np.empty_like(Ax)
    for _ in range(iters):
        if best_r == 0.0 or not (np.all(np.isfinite(F)) and np.all(np.isfinite(x))):
            break
        _jacobian_into(J, x, Ax, t_flat, t_var, t_coef)
        if not np.all(np.isfinite(J)):
            break
        U, S, Vt = np.linalg.svd(J, full_matrices=False)
        if not S[0] > 0.0:
            break
        g = U.T @ F
        for i in range(S.shape[0]):
            g[i] = g[i] / S[i] if S[i] > trunc * S[0] else 0.0
        x = x - Vt.T @ g
        _rows_F(x, n, mi, mj, indptr, indices, data, c, F)
        r = _maxabs(F)
        stall = 0 if r < 0.5 * best_r else stall + 1
        if stall >= stall_max or r != r:
            break
        if r < best_r:
            for k in range(x.shape[0]):
                best[k] = x[k]
            best_r = r
    return best


# -- F(x0) with a rigorous error bound ------------------------------------------------------------
# Krawczyk needs F(x0) and a bound on its error that stays small next to a (near-)singular root,
# where |J^-1| reaches 1e7 and a binary64 bound (~1e-16 times the row's terms) times |J^-1| is
# wider than any box Krawczyk could prove. Each row is a dot product computed as Ogita, Rump and
# Oishi's Dot2 ("Accurate sum and dot product", SIAM J. Sci. Comput. 26(6), 2005, Algorithm 5.3):
# as if in twice the working precision, then rounded. A monomial x_i x_j is first split exactly
# into zh + zl (TwoProduct), so a row sum_k a_k z_k + c is the dot product of (a, a, c) with
# (zh, zl, 1) -- N = 2 nnz + 1 products -- and Dot2's bound (their Proposition 5.5 / Theorem 5.3)
#     |res - F| <= u |F| + gamma_N^2 sum |a_k zh_k| + |a_k zl_k| + |c|,   u = 2^-53,
# holds without underflow; |F| <= (|res| + ...) / (1 - u) turns it into a bound in |res|. The
# computed sum of magnitudes and the few operations that form the bound are each off by a factor
# (1 + u); the factor 2 covers them (and 1/(1 - u)) with room. Underflow (TwoProduct is exact
# only while its partial products are normal) changes each operation by at most a few multiples
# of the smallest subnormal; 8 (N + 2) times the smallest *normal* number covers that by far. But
# a monomial's split zh + zl is then off from x_i x_j by that much, and the row multiplies it by
# a_k, which may be huge (1e180 next to x ~ 1e-182: the arb tests at KINBOX_SOUNDNESS_SCALE=3
# found Krawczyk declaring such a box with a root empty): 16 TINY sum |a_k| over the monomials
# covers it (8 TINY per split, doubled for the rounding of the sum and of the bound).
_SPLITTER = 134217729.0  # 2^27 + 1, Dekker's split of a binary64


@nb.njit(cache=True)
def _two_prod(a, b):
    p = a * b
    t = _SPLITTER * a
    ah = t - (t - a)
    al = a - ah
    t = _SPLITTER * b
    bh = t - (t - b)
    bl = b - bh
    return p, al * bl - (((p - ah * bh) - al * bh) - ah * bl)


@nb.njit(cache=True)
def _f_enclosure_kernel(x, n, mi, mj, indptr, indices, data, c, u, tiny, F, eF):
    """``F`` (each row by Dot2) and ``eF >= |F - F(x) exact|`` row by row (see above)."""
    for r in range(c.shape[0]):
        p = c[r]  # c * 1: exact
        s = 0.0
        mag = abs(c[r])
        amono = 0.0  # sum of |a_k| over the monomials: their split's underflow error is scaled by a_k
        N = 2 * (indptr[r + 1] - indptr[r]) + 1
        for q in range(indptr[r], indptr[r + 1]):
            k = indices[q]
            a = data[q]
            if k < n:
                zh, zl = x[k], 0.0
            else:
                zh, zl = _two_prod(x[mi[k - n]], x[mj[k - n]])
                amono += abs(a)
            for z in (zh, zl):
                h, e = _two_prod(a, z)
                # TwoSum(p, h)
                t = p + h
                bb = t - p
                e2 = (p - (t - bb)) + (h - bb)
                p = t
                s = s + (e2 + e)
                mag += abs(h)
        res = p + s
        nu = N * u
        g = nu / (1.0 - nu)
        F[r] = res
        eF[r] = 2.0 * (u * abs(res) + (g * g) * mag) + 8.0 * (N + 2) * tiny + 16.0 * tiny * amono
