"""Existence and uniqueness proofs (Krawczyk) and Newton polishing of isolated solutions.

The core equations ``F`` of a kinbox system are square and quadratic, so their Jacobian is
affine: ``J(x) = J(x0) + T(x - x0)`` with a constant, sparse ``T``. Over a box ``B`` the
Jacobian is therefore enclosed exactly (up to rounding) by ``J(x0) +- |T| d`` where ``d``
bounds ``|x - x0|``. The Krawczyk operator

    K(B) = x0 - Y F(x0) + (I - Y J(B)) (B - x0),      Y ~ J(x0)^-1,

evaluated in outward-rounded arithmetic, gives three results used by the solver:

* every zero of ``F`` in ``B`` lies in ``K(B)`` (a contractor; ``K ∩ B = ∅`` proves ``B``
  empty);
* ``K(B) ⊂ int(B)`` proves that ``B`` holds exactly one zero of ``F`` — the box needs no more
  splitting, whatever sigma is;
* iterating ``B <- K(B) ∩ B`` shrinks a proven box to a few ulps around the solution.

A zero of the core is a solution of the whole system when it satisfies the inequalities
(checked with interval evaluation over the final enclosure); the redundant equations are
implied by construction (``docs/formulation.md``).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from . import interval as iv
from .system import Compiled

#: the widest float type numpy offers here (x87 80-bit on x86-64, binary128 on aarch64,
#: binary64 elsewhere) and its unit roundoff
EXT = np.longdouble
U_EXT = EXT(np.finfo(EXT).epsneg)
#: core matrices up to this many entries are kept dense for point evaluations
DENSE_CORE = 40_000
#: Newton and Gauss-Newton give up after this many steps without halving the residual
STALL = 6


def _quiet(f):
    """Run ``f`` without numpy's overflow warnings: a Newton run far from any root may overflow
    before it is stopped, which is an outcome, not a problem to report."""
    @functools.wraps(f)
    def run(*a, **k):
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            return f(*a, **k)
    return run


@dataclass
class KrawczykResult:
    status: str  # "unique", "empty", "contracted" or "none"
    lo: np.ndarray
    hi: np.ndarray


class Certifier:
    """Krawczyk tests and Newton steps on the square core of a compiled system."""

    def __init__(self, comp: Compiled):
        self.comp = comp
        n = comp.n
        self.square = comp.n_core == n and n > 0
        A = comp.A[: comp.n_core].tocoo()
        lin = A.col < n
        self.Ax = np.zeros((comp.n_core, n))
        np.add.at(self.Ax, (A.row[lin], A.col[lin]), A.data[lin])
        r, k, a = A.row[~lin], A.col[~lin] - n, A.data[~lin]
        # d m_k / d x_mi = x_mj and d m_k / d x_mj = x_mi (both terms: 2 x for a square)
        self.t_row = np.concatenate([r, r])
        self.t_col = np.concatenate([comp.mi[k], comp.mj[k]])
        self.t_var = np.concatenate([comp.mj[k], comp.mi[k]])
        self.t_coef = np.concatenate([a, a])
        self.t_abs = np.abs(self.t_coef)
        # flat index of each slope term in the n_core x n Jacobian: one bincount builds J
        self.t_flat = self.t_row * n + self.t_col
        self.nJ = comp.n_core * n
        # rounding of those sums: at most k terms per entry (and the linear part), each a product
        self.g_slope = iv.gamma(int(np.bincount(self.t_flat).max(initial=0)) + 3)
        A_core = comp.A[: comp.n_core].tocsr()
        # point evaluations are ~20x more frequent than anything else here; a dense core is
        # faster to multiply up to a few hundred columns
        self.A_core = A_core.toarray() if A_core.shape[0] * A_core.shape[1] <= DENSE_CORE else A_core
        self.row_nnz = np.diff(A_core.indptr)
        self.c_core = comp.c[: comp.n_core]
        # F(x0) for Krawczyk is evaluated in extended precision (see _F_enclosure)
        self.A_ext = A_core.astype(EXT)
        self.absA_ext = abs(self.A_ext)
        self.c_ext = self.c_core.astype(EXT)

    # -- point evaluations ------------------------------------------------------------
    def F(self, x: np.ndarray) -> np.ndarray:
        return self.A_core @ self.comp.z(x) + self.c_core

    def J(self, x: np.ndarray) -> np.ndarray:
        return self.Ax + self._slopes(self.t_coef * x[self.t_var])

    def _slopes(self, w: np.ndarray) -> np.ndarray:
        """The n_core x n matrix with the slope terms ``w`` summed at their places."""
        return np.bincount(self.t_flat, weights=w, minlength=self.nJ).reshape(self.Ax.shape)

    def jac_magnitude(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """An upper bound of ``|J(x)|`` over the box (entrywise; not rounded, for heuristics)."""
        mid = 0.5 * (lo + hi)
        return np.abs(self.J(mid)) + self._slopes(self.t_abs * (0.5 * (hi - lo))[self.t_var])

    def _F_enclosure(self, x):
        """``F(x)`` rounded to binary64 and a rigorous bound on its error.

        Evaluated in the platform's extended precision (x87: unit roundoff 2^-64, 2048 times
        finer than binary64), so the bound is dominated by the final rounding of ``F`` itself,
        not by the size of its terms. Near a singular root ``|J^-1|`` reaches 1e7 and the
        binary64 bound (~1e-16 times the terms) times ``|J^-1|`` was already wider than any box
        Krawczyk could prove (UR5 one micro-radian from the elbow singularity).
        """
        xe = np.asarray(x, dtype=EXT)
        z = np.concatenate([xe, xe[self.comp.mi] * xe[self.comp.mj]])
        Fe = self.A_ext @ z + self.c_ext
        # a sum of nnz terms, each a product of up to three factors: gamma(nnz + 3)
        nu = (self.row_nnz + 3).astype(EXT) * U_EXT
        err = nu / (1 - nu) * (self.absA_ext @ np.abs(z) + np.abs(self.c_ext))
        F = Fe.astype(float)
        conv = np.abs(Fe - F.astype(EXT))  # exact: F is Fe rounded to binary64
        bound = iv.up(iv.up(err.astype(float)) * (1 + 4 * iv.U)) + iv.up(conv.astype(float))
        return F, iv.up(bound) + (self.row_nnz + 3) * iv.TINY

    # -- Krawczyk -------------------------------------------------------------------------
    def krawczyk(self, lo: np.ndarray, hi: np.ndarray, x0: np.ndarray | None = None) -> KrawczykResult:
        n = self.comp.n
        if not self.square:
            return KrawczykResult("none", lo, hi)
        if x0 is None:
            x0 = 0.5 * (lo + hi)
        x0 = np.clip(x0, lo, hi)
        J0 = self.J(x0)
        try:
            Y = np.linalg.inv(J0)
        except np.linalg.LinAlgError:
            return KrawczykResult("none", lo, hi)
        if not np.all(np.isfinite(Y)):
            return KrawczykResult("none", lo, hi)
        absY = np.abs(Y)
        d = np.maximum(iv.up(hi - x0), iv.up(x0 - lo))
        # J(B) in J0 +- Jrad (slope spread over the box, plus rounding of J0)
        Jrad = self._slopes(self.t_abs * d[self.t_var])
        # J0 is a sum of up to k terms per entry: off by gamma(k+2) times their magnitudes
        J0err = self.g_slope * (np.abs(self.Ax) + self._slopes(self.t_abs * np.abs(x0)[self.t_var]))
        Jrad = Jrad * (1 + self.g_slope) + J0err * (1 + self.g_slope) + iv.TINY
        F0, eF = self._F_enclosure(x0)
        YF = Y @ F0
        eYF = absY @ eF + iv.gamma(n + 2) * (absY @ np.abs(F0)) + iv.TINY
        C = np.eye(n) - Y @ J0
        Crad = absY @ Jrad + iv.gamma(n + 3) * (absY @ np.abs(J0) + 1.0)
        rho = (np.abs(C) + Crad) @ d
        rho = iv.up(rho * (1 + iv.gamma(n + 2))) + iv.TINY
        cen = x0 - YF
        klo = iv.down(iv.down(cen - eYF) - rho)
        khi = iv.up(iv.up(cen + eYF) + rho)
        if not (np.all(np.isfinite(klo)) and np.all(np.isfinite(khi))):
            return KrawczykResult("none", lo, hi)
        if np.all(klo > lo) and np.all(khi < hi):
            return KrawczykResult("unique", klo, khi)
        nlo, nhi = np.maximum(lo, klo), np.minimum(hi, khi)
        if np.any(nlo > nhi):
            return KrawczykResult("empty", nlo, nhi)
        if np.any(nlo > lo) or np.any(nhi < hi):
            return KrawczykResult("contracted", nlo, nhi)
        return KrawczykResult("none", lo, hi)

    def tighten(self, lo, hi, x0=None, iters: int = 30):
        """Iterate ``B <- K(B) ∩ B`` on a box proven to hold one zero; returns the final box."""
        for _ in range(iters):
            r = self.krawczyk(lo, hi, x0)
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
    @_quiet
    def newton(self, x: np.ndarray, lo: np.ndarray | None = None, hi: np.ndarray | None = None,
               iters: int = 20) -> np.ndarray:
        """Newton's method on the core from ``x`` (kept in ``[lo, hi]`` if given)."""
        x = np.array(x, dtype=float)
        F = self.F(x)
        best, best_r = x.copy(), np.max(np.abs(F))
        stalled = _Stall()
        for _ in range(iters):
            step = _newton_step(self.J(x), F, square=True)
            if step is None:
                break
            x = x - step
            if lo is not None:
                x = np.clip(x, lo, hi)
            F = self.F(x)
            r = np.max(np.abs(F))
            if stalled(r, best_r):
                break
            if r < best_r:
                best, best_r = x.copy(), r
            if r == 0.0 or np.max(np.abs(step)) < 1e-16 * (1 + np.max(np.abs(x))):
                break
        return best


def _newton_step(J: np.ndarray, F: np.ndarray, square: bool) -> np.ndarray | None:
    """The (least-squares) Newton step ``J^-1 F``, or ``None`` once the iteration has run off
    (non-finite values: the LAPACK routines fail on them)."""
    if not (np.all(np.isfinite(J)) and np.all(np.isfinite(F))):
        return None
    try:
        if square:
            try:
                return np.linalg.solve(J, F)
            except np.linalg.LinAlgError:
                pass
        return np.linalg.lstsq(J, F, rcond=None)[0]
    except np.linalg.LinAlgError:
        return None


class _Stall:
    """Stops Newton iterations that no longer converge: the best residual has not halved in
    :data:`STALL` iterations (a near-double root still halves it every step or two)."""

    def __init__(self):
        self.count = 0

    def __call__(self, r: float, best: float) -> bool:
        self.count = 0 if r < 0.5 * best else self.count + 1
        return self.count >= STALL


@_quiet
def gauss_newton(comp: Compiled, x: np.ndarray, lo=None, hi=None, iters: int = 30) -> np.ndarray:
    """Gauss-Newton on all equations (for non-square systems), kept in ``[lo, hi]`` if given."""
    x = np.array(x, dtype=float)
    F = comp.eval_eqs(x)
    best, best_r = x.copy(), np.max(np.abs(F), initial=0.0)
    stalled = _Stall()
    for _ in range(iters):
        step = _newton_step(comp.jacobian(x), F, square=False)
        if step is None:
            break
        x = x - step
        if lo is not None:
            x = np.clip(x, lo, hi)
        F = comp.eval_eqs(x)
        r = np.max(np.abs(F), initial=0.0)
        if stalled(r, best_r):
            break
        if r < best_r:
            best, best_r = x.copy(), r
        if np.max(np.abs(step), initial=0.0) < 1e-16 * (1 + np.max(np.abs(x))):
            break
    return best
