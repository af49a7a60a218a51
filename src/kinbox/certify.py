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

from dataclasses import dataclass

import numpy as np

from . import interval as iv
from .system import Compiled


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
        A_core = comp.A[: comp.n_core].tocsr()
        self.A_core = A_core
        self.absA_core = abs(A_core)
        self.row_nnz = np.diff(A_core.indptr)
        self.c_core = comp.c[: comp.n_core]

    # -- point evaluations ------------------------------------------------------------
    def F(self, x: np.ndarray) -> np.ndarray:
        return self.A_core @ self.comp.z(x) + self.c_core

    def J(self, x: np.ndarray) -> np.ndarray:
        J = self.Ax.copy()
        np.add.at(J, (self.t_row, self.t_col), self.t_coef * x[self.t_var])
        return J

    def jac_magnitude(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """An upper bound of ``|J(x)|`` over the box (entrywise; not rounded, for heuristics)."""
        mid = 0.5 * (lo + hi)
        M = np.abs(self.J(mid))
        np.add.at(M, (self.t_row, self.t_col), np.abs(self.t_coef) * (0.5 * (hi - lo))[self.t_var])
        return M

    def _F_enclosure(self, x):
        z = self.comp.z(x)
        F = self.A_core @ z + self.c_core
        err = iv.gamma(self.row_nnz + 3) * (self.absA_core @ np.abs(z) + np.abs(self.c_core))
        return F, err + (self.row_nnz + 3) * iv.TINY

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
        Jrad = np.zeros((n, n))
        np.add.at(Jrad, (self.t_row, self.t_col), np.abs(self.t_coef) * d[self.t_var])
        Jrad = Jrad * (1 + iv.gamma(4)) + iv.gamma(4) * np.abs(J0) + iv.TINY
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
    def newton(self, x: np.ndarray, lo: np.ndarray | None = None, hi: np.ndarray | None = None,
               iters: int = 20) -> np.ndarray:
        """Newton's method on the core from ``x`` (kept in ``[lo, hi]`` if given)."""
        x = np.array(x, dtype=float)
        best, best_r = x.copy(), np.max(np.abs(self.F(x)))
        for _ in range(iters):
            F = self.F(x)
            try:
                step = np.linalg.solve(self.J(x), F)
            except np.linalg.LinAlgError:
                step = np.linalg.lstsq(self.J(x), F, rcond=None)[0]
            x = x - step
            if lo is not None:
                x = np.clip(x, lo, hi)
            r = np.max(np.abs(self.F(x)))
            if r < best_r:
                best, best_r = x.copy(), r
            if r == 0.0 or np.max(np.abs(step)) < 1e-16 * (1 + np.max(np.abs(x))):
                break
        return best


def gauss_newton(comp: Compiled, x: np.ndarray, lo=None, hi=None, iters: int = 30) -> np.ndarray:
    """Gauss-Newton on all equations (for non-square systems), kept in ``[lo, hi]`` if given."""
    x = np.array(x, dtype=float)
    best, best_r = x.copy(), np.max(np.abs(comp.eval_eqs(x)), initial=0.0)
    for _ in range(iters):
        F = comp.eval_eqs(x)
        J = comp.jacobian(x)
        step = np.linalg.lstsq(J, F, rcond=None)[0]
        x = x - step
        if lo is not None:
            x = np.clip(x, lo, hi)
        r = np.max(np.abs(comp.eval_eqs(x)), initial=0.0)
        if r < best_r:
            best, best_r = x.copy(), r
        if np.max(np.abs(step), initial=0.0) < 1e-16 * (1 + np.max(np.abs(x))):
            break
    return best
