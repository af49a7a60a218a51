"""The HC4 contraction written with numpy array operations: the reference the compiled kernel of
``kinbox.propagate`` is checked against (it was the solver's own code until 2026-11-22)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from kinbox import interval as iv


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


def contract_reference(p, xlo, xhi, max_sweeps: int = 8, tol: float = 1e-3):
    """``Propagator.contract`` of ``p`` in numpy; ``(xlo, xhi, mlo, mhi)`` or ``None``."""
    c = p.comp
    n = c.n
    xlo = xlo.copy()
    xhi = xhi.copy()
    mlo, mhi = p.monomials(xlo, xhi)
    for _ in range(max_sweeps):
        w0 = xhi - xlo
        zlo = np.concatenate([xlo, mlo])
        zhi = np.concatenate([xhi, mhi])
        tlo, thi, slo, shi = p.row_sums(zlo, zhi)
        if np.any(slo > p.thi) or np.any(shi < p.tlo):
            return None
        # others = S - t  (exact bound arithmetic, rounded outward)
        olo = iv.down(slo[sc(p).rows] - tlo)
        ohi = iv.up(shi[sc(p).rows] - thi)
        # a z_k in [T.lo - o.hi, T.hi - o.lo]
        plo = iv.down(p.tlo[sc(p).rows] - ohi)
        phi = iv.up(p.thi[sc(p).rows] - olo)
        pos = p.coef > 0
        with np.errstate(invalid="ignore", over="ignore"):
            q1 = plo / p.coef
            q2 = phi / p.coef
        nlo = iv.down(np.where(pos, q1, q2))
        nhi = iv.up(np.where(pos, q2, q1))
        nlo = np.where(np.isnan(nlo), -np.inf, nlo)
        nhi = np.where(np.isnan(nhi), np.inf, nhi)
        sc(p).cols.max_into(zlo, nlo)
        sc(p).cols.min_into(zhi, nhi)
        if np.any(zlo > zhi):
            return None
        xlo, xhi = zlo[:n], zhi[:n]
        mlo, mhi = zlo[n:], zhi[n:]
        # project monomials back on x
        r = _project(p, xlo, xhi, mlo, mhi)
        if r is None:
            return None
        xlo, xhi = r
        flo, fhi = p.monomials(xlo, xhi)
        mlo = np.maximum(mlo, flo)
        mhi = np.minimum(mhi, fhi)
        if np.any(mlo > mhi):
            return None
        w1 = xhi - xlo
        scale = np.maximum(w0, 1e-300)
        if np.max((w0 - w1) / scale) < tol:
            break
    return xlo, xhi, mlo, mhi


def _project(p, xlo, xhi, mlo, mhi):
    c = p.comp
    xlo = xlo.copy()
    xhi = xhi.copy()
    sq = p.sq
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
        sc(p).sq.max_into(xlo, new_lo)
        sc(p).sq.min_into(xhi, new_hi)
    bl = ~sq
    if np.any(bl):
        i, j = sc(p).bl_i, sc(p).bl_j
        for to, v in ((sc(p).bl[0], j), (sc(p).bl[1], i)):
            qlo, qhi = iv.div(mlo[bl], mhi[bl], xlo[v], xhi[v])
            to.max_into(xlo, qlo)
            to.min_into(xhi, qhi)
    if np.any(xlo > xhi):
        return None
    return xlo, xhi


def sc(p) -> SimpleNamespace:
    """Index helpers of a Propagator for the numpy code (built once, kept on the Propagator: an
    id-keyed cache handed a dead Propagator's helpers to a new one at the same address)."""
    if "_reference" not in p.__dict__:
        c = p.comp
        bl = ~p.sq
        bl_i, bl_j = c.mi[bl], c.mj[bl]
        p._reference = SimpleNamespace(
            rows=np.repeat(np.arange(len(p.nnz_row)), p.nnz_row),
            cols=_Scatter(p.cols),
            sq=_Scatter(c.mi[p.sq]),
            bl=(_Scatter(bl_i), _Scatter(bl_j)),
            bl_i=bl_i,
            bl_j=bl_j,
        )
    return p._reference
