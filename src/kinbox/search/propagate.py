"""Cheap contractors: interval evaluation and constraint propagation (HC4-revise).

Before any LP is spent on a box, every row ``A[r] z + c[r] = 0`` (or ``<= 0``) of the
expanded system is used to narrow the interval of each of its terms from the others, and
the monomial intervals ``m = x_i x_j`` / ``m = x_i^2`` are projected back onto ``x``. Every
operation is rounded outward (as in ``kinbox.interval``), so a box is only ever narrowed by
what no solution can occupy. The contraction loop is compiled with numba (below); interval
evaluation of the rows stays in numpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import interval as iv
from ..formulation.system import Compiled
from ..interval import TINY, U
from . import jit as nb

#: HC4 sweeps per box at most, and the share of its width no variable lost in the last sweep
#: when it stops earlier. On many arms (the UR family, industrial and spherical wrists) HC4
#: converges on a sub-chain linearly, by some 0.7 per sweep, and a cap of 8 split boxes that
#: the next sweeps would have pinned; a sweep costs a few percent of a box
#: (benchmarks/arm_classes.py)
SWEEPS, SWEEP_TOL = 32, 1e-2


@dataclass
class Propagator:
    """HC4 over a :class:`~kinbox.system.Compiled` system."""

    comp: Compiled

    def __post_init__(self):
        A = self.comp.A.tocsr()
        A.sort_indices()
        self.cols = A.indices.astype(np.int64)
        self.coef = A.data.astype(float)
        self.indptr = A.indptr.astype(np.int64)
        self.mi = np.ascontiguousarray(self.comp.mi, dtype=np.int64)
        self.mj = np.ascontiguousarray(self.comp.mj, dtype=np.int64)
        self.nnz_row = np.diff(A.indptr)
        self.nonempty = self.nnz_row > 0
        self.starts = A.indptr[:-1][self.nonempty]
        # target interval of each row's linear part
        self.tlo = self.comp.target_lo
        self.thi = self.comp.target_hi
        self.sq = self.comp.mi == self.comp.mj

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
        # a sum that overflowed (+-inf) minus its error bound (then inf) is NaN: no bound
        slo = np.where(np.isnan(slo), -np.inf, slo)
        shi = np.where(np.isnan(shi), np.inf, shi)
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
    def contract(self, xlo, xhi, max_sweeps: int = SWEEPS, tol: float = SWEEP_TOL):
        """Narrow the box ``[xlo, xhi]``; returns ``(xlo, xhi, mlo, mhi)`` or ``None`` if empty."""
        ok, xlo, xhi, mlo, mhi = _contract(
            np.asarray(xlo, dtype=float),
            np.asarray(xhi, dtype=float),
            self.mi,
            self.mj,
            self.sq,
            self.indptr,
            self.cols,
            self.coef,
            self.tlo,
            self.thi,
            max_sweeps,
            tol,
        )
        return (xlo, xhi, mlo, mhi) if ok else None


def load_kernel() -> None:
    """Load (on the first run: compile and cache) the compiled kernel; a solve does it when it
    first needs it; benchmarks time it apart from the solve."""
    one, idx = np.ones(1), np.zeros(1, dtype=np.int64)
    _contract(-one, one, idx, idx, np.ones(1, dtype=bool), np.array([0, 1]), idx, one, -one, one, 1, 1e-3)
    next_up_down(one)  # the tests' view of the rounding helpers: compiled too, so that every kernel here is cached


# -- the compiled kernel -----------------------------------------------------------------------
# One HC4 contraction in numpy is some thirty calls on small arrays per sweep, and their
# overhead dominated solves without LPs (benchmarks/bench.py, the UR5 poses).
# The same arithmetic as kinbox.interval, written as scalar loops and compiled by numba: every
# operation is an IEEE operation moved one ulp outward (np.nextafter), sums are widened by
# Higham's gamma, as in the numpy code it replaced (tests/support/hc4_reference.py;
# tests/search/test_propagate.py checks that the two agree up to the order of summation on every
# contraction of four solves).


# The small helpers below are plain compiled functions: LLVM inlines them into their callers
# (the same speed as numba's inline="always", which types every call site anew and took seconds
# of a first run's compilation; tests/cli/test_startup.py times nothing, benchmarks/startup.py does).
@nb.njit(cache=True)
def _up(v):
    """``np.nextafter(v, inf)``, bit for bit (NaN payloads aside), from the bits: numba calls the
    C library's nextafter for ``np.nextafter`` (about 11 ns, not inlined), and HC4 takes some
    six of them per term and sweep: they were most of its time. A finite non-zero float's
    successor is its neighbour in the integer order of its bits (one more for a positive
    number, one less for a negative one: the sign bit is kept); 0 and -0 go to the smallest
    subnormal, +inf and NaN stay (``tests/search/test_propagate.py`` compares the two). Every test is on
    the bits, none on the float: with denormals-are-zero on, ``v > 0.0`` is false for a positive
    subnormal, which would step it down, inward."""
    i = np.float64(v).view(np.int64)
    mag = i & 0x7FFFFFFFFFFFFFFF
    if mag >= 0x7FF0000000000000 and (mag > 0x7FF0000000000000 or i > 0):
        return v
    if mag == 0:
        return 5e-324
    i = i + 1 if i > 0 else i - 1
    return np.int64(i).view(np.float64)


@nb.njit(cache=True)
def _dn(v):
    """``np.nextafter(v, -inf)``: the mirror image of :func:`_up`."""
    return -_up(-v)


@nb.njit(cache=True)
def next_up_down(x):
    """:func:`_up` and :func:`_dn` of every element (for the tests)."""
    a, b = np.empty_like(x), np.empty_like(x)
    for k in range(x.shape[0]):
        a[k] = _up(x[k])
        b[k] = _dn(x[k])
    return a, b


@nb.njit(cache=True)
def _nan0(v):
    return 0.0 if v != v else v


@nb.njit(cache=True)
def _monomials(xlo, xhi, mi, mj, sq, mlo, mhi):
    """Enclosures of ``x_i x_j`` (``x_i^2`` where ``sq``), as ``interval.mul`` / ``interval.sqr``."""
    for k in range(mi.shape[0]):
        i, j = mi[k], mj[k]
        if sq[k]:
            lo, hi = xlo[i], xhi[i]
            a, b = lo * lo, hi * hi
            mx = _up(max(a, b))
            mn = 0.0 if (lo <= 0.0 and hi >= 0.0) else _dn(min(a, b))
            mlo[k] = max(mn - TINY, 0.0)
            mhi[k] = mx + TINY
        else:
            p1 = _nan0(xlo[i] * xlo[j])
            p2 = _nan0(xlo[i] * xhi[j])
            p3 = _nan0(xhi[i] * xlo[j])
            p4 = _nan0(xhi[i] * xhi[j])
            mlo[k] = _dn(min(min(p1, p2), min(p3, p4))) - TINY
            mhi[k] = _up(max(max(p1, p2), max(p3, p4))) + TINY


@nb.njit(cache=True)
def _div_into(ml, mh, bl, bh, k, xlo, xhi):
    """Narrow ``x_k`` to ``[ml, mh] / [bl, bh]`` (as ``interval.div``; no-op if ``0 in [bl, bh]``,
    or if ``bl > bh``: a divisor emptied earlier in the same pass, which the caller then finds
    empty -- dividing by its end could divide by zero, ``tests/search/test_ctc_shave.py``)."""
    if (bl <= 0.0 and bh >= 0.0) or bl > bh:
        return
    p1 = _nan0(ml / bl)
    p2 = _nan0(ml / bh)
    p3 = _nan0(mh / bl)
    p4 = _nan0(mh / bh)
    lo = _dn(min(min(p1, p2), min(p3, p4))) - TINY
    hi = _up(max(max(p1, p2), max(p3, p4))) + TINY
    if lo > xlo[k]:
        xlo[k] = lo
    if hi < xhi[k]:
        xhi[k] = hi


@nb.njit(cache=True)
def _square_roots_into(xlo, xhi, mlo, mhi, mi, sq, plo, phi):
    """Narrow ``[plo, phi]`` to the square roots of the square monomials ``x_i^2`` (the branch
    of each sign that meets ``[xlo, xhi]``); False proves the box empty."""
    for k in range(mi.shape[0]):
        if not sq[k]:
            continue
        i = mi[k]
        if mhi[k] < 0:
            return False
        ra = max(_dn(np.sqrt(max(mlo[k], 0.0))), 0.0)
        rb = _up(np.sqrt(max(mhi[k], 0.0)))
        neg_lo, neg_hi = max(xlo[i], -rb), min(xhi[i], -ra)
        pos_lo, pos_hi = max(xlo[i], ra), min(xhi[i], rb)
        neg_ok, pos_ok = neg_lo <= neg_hi, pos_lo <= pos_hi
        if not neg_ok and not pos_ok:
            return False
        lo = neg_lo if neg_ok else pos_lo
        hi = pos_hi if pos_ok else neg_hi
        if lo > plo[i]:
            plo[i] = lo
        if hi < phi[i]:
            phi[i] = hi
    return True


@nb.njit(cache=True)
def _contract(xlo, xhi, mi, mj, sq, indptr, cols, coef, tlo, thi, max_sweeps, tol):
    """HC4 sweeps over the rows ``A z + c`` (targets ``[tlo, thi]``) and the monomials.

    Returns ``(ok, xlo, xhi, mlo, mhi)``; ``ok`` False proves the box empty.
    """
    n, nm, nrow = xlo.shape[0], mi.shape[0], indptr.shape[0] - 1
    xlo, xhi = xlo.copy(), xhi.copy()
    mlo, mhi = np.empty(nm), np.empty(nm)
    _monomials(xlo, xhi, mi, mj, sq, mlo, mhi)
    nz = n + nm
    zlo, zhi = np.empty(nz), np.empty(nz)
    nlo_z, nhi_z = np.empty(nz), np.empty(nz)
    tl, th = np.empty(cols.shape[0]), np.empty(cols.shape[0])
    w0 = np.empty(n)
    flo, fhi = np.empty(nm), np.empty(nm)
    for _ in range(max_sweeps):
        for k in range(n):
            w0[k] = xhi[k] - xlo[k]
            zlo[k], zhi[k] = xlo[k], xhi[k]
        for k in range(nm):
            zlo[n + k], zhi[n + k] = mlo[k], mhi[k]
        for k in range(nz):  # element by element: a slice copy compiles numba's shape-error message (seconds)
            nlo_z[k], nhi_z[k] = zlo[k], zhi[k]
        # every row: enclose its terms and sum, then each term from the others
        for r in range(nrow):
            a, b = indptr[r], indptr[r + 1]
            slo = shi = alo = ahi = wmax = 0.0
            for p in range(a, b):
                c = coef[p]
                p1 = _nan0(c * zlo[cols[p]])
                p2 = _nan0(c * zhi[cols[p]])
                lo = _dn(min(p1, p2)) - TINY
                hi = _up(max(p1, p2)) + TINY
                tl[p], th[p] = lo, hi
                slo += lo
                shi += hi
                alo += abs(lo)
                ahi += abs(hi)
                wmax = max(wmax, hi - lo)
            m = b - a
            nu = (m + 1) * U
            g = nu / (1.0 - nu)
            slo = _dn(slo - g * alo - m * TINY)
            shi = _up(shi + g * ahi + m * TINY)
            if slo > thi[r] or shi < tlo[r]:
                return False, xlo, xhi, mlo, mhi
            # a term narrows only if it is wider than the room the target leaves beside the sum
            # of the others, shi - tlo or thi - slo: the projection of a narrower term (with
            # room for the rounding of these differences) contains its interval, and narrows
            # nothing. Such terms are skipped, with the same result
            room = min(shi - tlo[r], thi[r] - slo) / (1.0 + 1e-6)
            if not (slo >= -1e300 and shi <= 1e300):
                room = -1.0  # an unbounded sum: every term is projected
            if wmax <= room:
                continue
            for p in range(a, b):
                if coef[p] == 0.0:  # a stored zero (an underflowed coefficient) says nothing of its term
                    continue
                if th[p] - tl[p] <= room:
                    continue
                olo = _dn(slo - tl[p])
                ohi = _up(shi - th[p])
                plo = _dn(tlo[r] - ohi)
                phi = _up(thi[r] - olo)
                c = coef[p]
                q1, q2 = plo / c, phi / c
                if c > 0:
                    lo, hi = _dn(q1), _up(q2)
                else:
                    lo, hi = _dn(q2), _up(q1)
                k = cols[p]
                if lo > nlo_z[k]:  # NaN (no information) never narrows
                    nlo_z[k] = lo
                if hi < nhi_z[k]:
                    nhi_z[k] = hi
        for k in range(nz):
            if nlo_z[k] > nhi_z[k]:
                return False, xlo, xhi, mlo, mhi
        for k in range(n):
            xlo[k], xhi[k] = nlo_z[k], nhi_z[k]
        for k in range(nm):
            mlo[k], mhi[k] = nlo_z[n + k], nhi_z[n + k]
        # project the monomials back on x: squares first (from the box before), then x_i from
        # m / x_j for every product, then x_j from m / x_i
        plo, phi = xlo.copy(), xhi.copy()
        if not _square_roots_into(xlo, xhi, mlo, mhi, mi, sq, plo, phi):
            return False, xlo, xhi, mlo, mhi
        for side in range(2):
            slo_, shi_ = plo.copy(), phi.copy()
            for k in range(nm):
                if sq[k]:
                    continue
                tgt, src = (mi[k], mj[k]) if side == 0 else (mj[k], mi[k])
                _div_into(mlo[k], mhi[k], slo_[src], shi_[src], tgt, plo, phi)
        for k in range(n):
            if plo[k] > phi[k]:
                return False, xlo, xhi, mlo, mhi
        xlo, xhi = plo, phi
        _monomials(xlo, xhi, mi, mj, sq, flo, fhi)
        for k in range(nm):
            mlo[k] = max(mlo[k], flo[k])
            mhi[k] = min(mhi[k], fhi[k])
            if mlo[k] > mhi[k]:
                return False, xlo, xhi, mlo, mhi
        done = True
        for k in range(n):
            d = (w0[k] - (xhi[k] - xlo[k])) / max(w0[k], 1e-300)
            if not d < tol:  # NaN (infinite widths) is not converged
                done = False
        if done:
            break
    return True, xlo, xhi, mlo, mhi
