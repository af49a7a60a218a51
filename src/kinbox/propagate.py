"""Cheap contractors: interval evaluation and constraint propagation (HC4-revise).

Before any LP is spent on a box, every row ``A[r] z + c[r] = 0`` (or ``<= 0``) of the
expanded system is used to narrow the interval of each of its terms from the others, and
the monomial intervals ``m = x_i x_j`` / ``m = x_i^2`` are projected back onto ``x``. All of
it is vectorised over the non-zeros of ``A`` and rounded outward (``kinbox.interval``), so a
box is only ever narrowed by what no solution can occupy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import interval as iv
from .system import Compiled


class _Scatter:
    """``np.maximum.at`` / ``np.minimum.at`` for a fixed index array, by sorted segments
    (``reduceat`` is many times faster than ``ufunc.at``; max and min are exact either way)."""

    def __init__(self, idx: np.ndarray):
        idx = np.asarray(idx, dtype=np.int64)
        self.order = np.argsort(idx, kind="stable")
        sidx = idx[self.order]
        first = np.flatnonzero(np.r_[True, sidx[1:] != sidx[:-1]]) if len(sidx) else np.zeros(0, dtype=np.int64)
        self.starts = first
        self.targets = sidx[first] if len(sidx) else sidx

    def max_into(self, target: np.ndarray, vals: np.ndarray) -> None:
        if len(self.targets):
            r = np.maximum.reduceat(vals[self.order], self.starts)
            target[self.targets] = np.maximum(target[self.targets], r)

    def min_into(self, target: np.ndarray, vals: np.ndarray) -> None:
        if len(self.targets):
            r = np.minimum.reduceat(vals[self.order], self.starts)
            target[self.targets] = np.minimum(target[self.targets], r)


@dataclass
class Propagator:
    """Vectorised HC4 over a :class:`~kinbox.system.Compiled` system."""

    comp: Compiled

    def __post_init__(self):
        A = self.comp.A.tocsr()
        A.sort_indices()
        self.rows = np.repeat(np.arange(A.shape[0]), np.diff(A.indptr))
        self.cols = A.indices.astype(np.int64)
        self.coef = A.data.astype(float)
        self.indptr = A.indptr
        self.nnz_row = np.diff(A.indptr)
        self.nonempty = self.nnz_row > 0
        self.starts = A.indptr[:-1][self.nonempty]
        n_eq = self.comp.n_eq
        nrow = A.shape[0]
        # target interval of each row's linear part: -c (equations) or (-inf, -c] (inequalities)
        self.tlo = np.where(np.arange(nrow) < n_eq, -self.comp.c, -np.inf)
        self.thi = -self.comp.c.copy()
        self.sq = self.comp.mi == self.comp.mj
        self.sq_i = self.comp.mi[self.sq]
        bl = ~self.sq
        self.bl_i, self.bl_j = self.comp.mi[bl], self.comp.mj[bl]
        self.to_cols = _Scatter(self.cols)
        self.to_sq = _Scatter(self.sq_i)
        self.to_bl = (_Scatter(self.bl_i), _Scatter(self.bl_j))

    # -- evaluation --------------------------------------------------------------
    def monomials(self, xlo, xhi):
        c = self.comp
        mlo, mhi = iv.mul(xlo[c.mi], xhi[c.mi], xlo[c.mj], xhi[c.mj])
        slo, shi = iv.sqr(xlo[c.mi], xhi[c.mi])
        return np.where(self.sq, slo, mlo), np.where(self.sq, shi, mhi)

    def row_sums(self, zlo, zhi):
        """Enclosures of the terms ``a z`` of every non-zero and of each row's sum."""
        tlo, thi = iv.scale(self.coef, zlo[self.cols], zhi[self.cols])
        nrow = len(self.nnz_row)
        slo = np.zeros(nrow)
        shi = np.zeros(nrow)
        alo = np.zeros(nrow)
        ahi = np.zeros(nrow)
        if len(tlo):
            slo[self.nonempty] = np.add.reduceat(tlo, self.starts)
            shi[self.nonempty] = np.add.reduceat(thi, self.starts)
            alo[self.nonempty] = np.add.reduceat(np.abs(tlo), self.starts)
            ahi[self.nonempty] = np.add.reduceat(np.abs(thi), self.starts)
        g = iv.gamma(self.nnz_row + 1)
        slo = iv.down(slo - g * alo - self.nnz_row * iv.TINY)
        shi = iv.up(shi + g * ahi + self.nnz_row * iv.TINY)
        return tlo, thi, slo, shi

    def eval_rows(self, xlo, xhi, mlo=None, mhi=None):
        """Enclosure of every row value ``A[r] z + c[r]`` over the box."""
        if mlo is None:
            mlo, mhi = self.monomials(xlo, xhi)
        zlo = np.concatenate([xlo, mlo])
        zhi = np.concatenate([xhi, mhi])
        _, _, slo, shi = self.row_sums(zlo, zhi)
        return iv.down(slo + self.comp.c), iv.up(shi + self.comp.c)

    # -- contraction -------------------------------------------------------------
    def contract(self, xlo, xhi, max_sweeps: int = 8, tol: float = 1e-3):
        """Narrow the box ``[xlo, xhi]``; returns ``(xlo, xhi, mlo, mhi)`` or ``None`` if empty."""
        c = self.comp
        n = c.n
        xlo = xlo.copy()
        xhi = xhi.copy()
        mlo, mhi = self.monomials(xlo, xhi)
        for _ in range(max_sweeps):
            w0 = xhi - xlo
            zlo = np.concatenate([xlo, mlo])
            zhi = np.concatenate([xhi, mhi])
            tlo, thi, slo, shi = self.row_sums(zlo, zhi)
            if np.any(slo > self.thi) or np.any(shi < self.tlo):
                return None
            # others = S - t  (exact bound arithmetic, rounded outward)
            olo = iv.down(slo[self.rows] - tlo)
            ohi = iv.up(shi[self.rows] - thi)
            # a z_k in [T.lo - o.hi, T.hi - o.lo]
            plo = iv.down(self.tlo[self.rows] - ohi)
            phi = iv.up(self.thi[self.rows] - olo)
            pos = self.coef > 0
            with np.errstate(invalid="ignore", over="ignore"):
                q1 = plo / self.coef
                q2 = phi / self.coef
            nlo = iv.down(np.where(pos, q1, q2))
            nhi = iv.up(np.where(pos, q2, q1))
            nlo = np.where(np.isnan(nlo), -np.inf, nlo)
            nhi = np.where(np.isnan(nhi), np.inf, nhi)
            self.to_cols.max_into(zlo, nlo)
            self.to_cols.min_into(zhi, nhi)
            if np.any(zlo > zhi):
                return None
            xlo, xhi = zlo[:n], zhi[:n]
            mlo, mhi = zlo[n:], zhi[n:]
            # project monomials back on x
            r = self._project(xlo, xhi, mlo, mhi)
            if r is None:
                return None
            xlo, xhi = r
            flo, fhi = self.monomials(xlo, xhi)
            mlo = np.maximum(mlo, flo)
            mhi = np.minimum(mhi, fhi)
            if np.any(mlo > mhi):
                return None
            w1 = xhi - xlo
            scale = np.maximum(w0, 1e-300)
            if np.max((w0 - w1) / scale) < tol:
                break
        return xlo, xhi, mlo, mhi

    def _project(self, xlo, xhi, mlo, mhi):
        c = self.comp
        xlo = xlo.copy()
        xhi = xhi.copy()
        sq = self.sq
        if np.any(sq):
            i = c.mi[sq]
            a, b = iv.sqrt_hull(mlo[sq], mhi[sq])
            if np.any(mhi[sq] < 0):
                return None
            lo_i, hi_i = xlo[i], xhi[i]
            neg_lo, neg_hi = np.maximum(lo_i, -b), np.minimum(hi_i, -a)
            pos_lo, pos_hi = np.maximum(lo_i, a), np.minimum(hi_i, b)
            neg_ok = neg_lo <= neg_hi
            pos_ok = pos_lo <= pos_hi
            if np.any(~neg_ok & ~pos_ok):
                return None
            new_lo = np.where(neg_ok, neg_lo, pos_lo)
            new_hi = np.where(pos_ok, pos_hi, neg_hi)
            self.to_sq.max_into(xlo, new_lo)
            self.to_sq.min_into(xhi, new_hi)
        bl = ~sq
        if np.any(bl):
            i, j = self.bl_i, self.bl_j
            for to, v in ((self.to_bl[0], j), (self.to_bl[1], i)):
                qlo, qhi = iv.div(mlo[bl], mhi[bl], xlo[v], xhi[v])
                to.max_into(xlo, qlo)
                to.min_into(xhi, qhi)
        if np.any(xlo > xhi):
            return None
        return xlo, xhi
