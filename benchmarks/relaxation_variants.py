"""Variants of the LP contractors tried and not kept (benchmarks/relaxations.py --variant): here,
out of the package, so that what they measure can be measured again."""

from __future__ import annotations

import time

import numpy as np

from kinbox.search.contract import Contraction
from kinbox.search.ctc_linear import LinearRelaxation


class LinearWithSquares(LinearRelaxation):
    """Fünfzig et al. 2010, Sec. 6, in the linear relaxation: after the two LPs on ``x_i``, two on ``m = x_i^2``; then
    ``|x_i| <= sqrt(max m)``, and ``x_i`` keeps one sign's branch ``|x_i| >= sqrt(min m)`` when the
    box rules out the other (in the original coordinates a square gives ``|x|``, not ``x``)."""

    def contract(self, lo, hi, mlo=None, mhi=None, basis=None) -> Contraction:
        relax = self.relax
        if mlo is None or mhi is None:
            raise ValueError("the LP relaxation needs the monomial bounds (run propagation first)")
        comp = relax.comp
        sq_of = np.full(comp.n, -1)
        sq = comp.mi == comp.mj
        sq_of[comp.mi[sq]] = comp.n + np.flatnonzero(sq)
        relax.lps = 0
        relax.build(lo, hi, mlo, mhi, basis)
        lo, hi = lo.copy(), hi.copy()
        rel = (hi - lo) / self.root_w
        order = [int(i) for i in np.argsort(-rel, kind="stable") if self.mask[i] and hi[i] > lo[i]]
        for i in order:
            if self.deadline is not None and time.perf_counter() > self.deadline:
                break
            w = hi[i] - lo[i]
            cols = [i] + ([int(sq_of[i])] if sq_of[i] >= 0 else [])
            for k in cols:
                blo, bhi = -np.inf, np.inf
                for sense in (+1, -1):
                    b, infeasible = relax.bound(k, sense)
                    if infeasible:
                        return Contraction("empty", lo, hi, work=relax.lps)
                    if b is not None and sense > 0:
                        blo = b
                    if b is not None and sense < 0:
                        bhi = b
                if k == i:
                    lo[i], hi[i] = max(lo[i], blo), min(hi[i], bhi)
                else:
                    if bhi < 0:
                        return Contraction("empty", lo, hi, work=relax.lps)
                    s_hi = np.nextafter(np.sqrt(bhi), np.inf) if np.isfinite(bhi) else np.inf
                    lo[i], hi[i] = max(lo[i], -s_hi), min(hi[i], s_hi)
                    if blo > 0:
                        s_lo = np.nextafter(np.sqrt(blo), -np.inf)
                        if lo[i] > -s_lo:
                            lo[i] = max(lo[i], s_lo)
                        if hi[i] < s_lo:
                            hi[i] = min(hi[i], -s_lo)
                if lo[i] > hi[i]:
                    return Contraction("empty", lo, hi, work=relax.lps)
                relax.set_bounds(i, lo[i], hi[i])
            if hi[i] - lo[i] > (1.0 - self.pay) * w:
                break
        return Contraction("narrowed", lo, hi, work=relax.lps)
