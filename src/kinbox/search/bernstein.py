"""The Bernstein-polytope relaxation of Fünfzig et al. 2010, as a contractor.

For a box ``[u, v]`` each variable is rescaled to the unit interval, ``x_i = u_i + w_i X_i``
with ``X_i in [0, 1]`` (Fünfzig et al. 2010, Sec. 4.3), and each monomial of the system becomes a variable of
the unit box: ``M_k = X_i X_j`` or ``X_i^2``. The LP holds

* every row of the expanded system, rewritten in ``(X, M)`` by the linear map of Sec. 4.3
  (``x_i x_j = w_i w_j X_i X_j + u_i w_j X_j + u_j w_i X_i + u_i u_j``);
* the **Bernstein polytope** of the unit box (Sec. 3): for ``M = X^2`` the degree-2 Bernstein
  polynomials are non-negative, ``(1 - X)^2 >= 0 -> M - 2X + 1 >= 0``, ``2X(1 - X) >= 0 ->
  X - M >= 0`` and ``X^2 >= 0 -> M >= 0`` (a triangle, Fig. 2); for ``M = X_i X_j`` the four
  products of degree-1 Bernstein polynomials, ``(1 - X_i)(1 - X_j)``, ``X_i (1 - X_j)``,
  ``(1 - X_i) X_j`` and ``X_i X_j`` are non-negative (the tetrahedron of Fig. 4). The rows
  ``M >= 0`` are the columns' lower bounds.

Domain reduction (Sec. 4.2) minimises and maximises ``X_i`` over that LP and maps the bounds
back to ``x_i``. Optionally (Sec. 6, "nonlinear reduction for squared variables") two more LPs
bound ``M_ii`` and then ``X_i in [sqrt(min M_ii), sqrt(max M_ii)]``: on the unit box ``X_i >= 0``,
so the curve ``M = X^2`` gives both ends.

Numerical safety (Fünfzig et al. 2010, Sec. 5, lists strategies; this one is "polytope inflation" done once, at
the rows, plus a safe bound from the duals as in :mod:`kinbox.search.relaxation`):

* the polytope rows have small integer coefficients and integer right-hand sides: they hold
  exactly on the unit box, with no rounding at all. ``w_i`` is ``v_i - u_i`` rounded up, so the
  exact ``X_i = (x_i - u_i) / w_i`` of every point of the box lies in ``[0, 1]``;
* the rescaled coefficients of the system's rows are computed in floating point and each is
  enclosed with its rounding error (products of three floats, sums of a few terms: Higham's
  gamma, with room for underflow). Since every ``X`` and ``M`` lies in ``[0, 1]``, a row with
  float coefficients ``c`` enclosing the exact ones within ``e`` holds with its bounds widened by
  ``sum e``: every solution of the system satisfies every row of the LP;
* bounds come from :func:`kinbox.search.relaxation._safe_lower` (Neumaier-Shcherbina from any
  dual values) and emptiness from the same Farkas check as the linear relaxation, both inherited
  from :class:`~kinbox.search.relaxation.Relaxation`; a bound of ``X_i`` is mapped back to
  ``x_i`` rounded outward.

The polytope is the linear relaxation's without the mid-point tangent of each parabola and
without the interval bounds of the monomials (the columns ``M`` are bounded by ``[0, 1]``, their
range on the unit box); what differs is the coordinates: every variable of the LP lives in
``[0, 1]`` and the nonlinear rows are exact.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .. import interval as iv
from ..formulation.system import Compiled
from . import jit as nb
from .contract import Contraction, ContractStatus
from .ctc_linear import LP_VAR_PAYS
from .relaxation import DENSE, Relaxation

_U = 2.0**-53
_TINY = float(np.finfo(float).tiny)
#: the nonlinear reduction of squared variables (Fünfzig et al. 2010, Sec. 6) by default: two more LPs per
#: variable, on ``X_i^2``, then ``X_i`` from the square root
SQUARES = False


@dataclass(frozen=True)
class _Layout:
    """What the LP of :class:`BernsteinLP` looks like for one sparsity pattern of the system (the
    values of its coefficients aside): the same for every pose of an arm, whose template binds
    new numbers into one pattern, so it is built once per pattern (:func:`_layout`)."""

    src: np.ndarray  # per contribution: the index of the matrix entry it scales
    cp: np.ndarray
    cq: np.ndarray
    cs: np.ndarray
    slot_row: np.ndarray
    nslot: int
    n_base: int
    n_rel: int
    nrow: int
    start: np.ndarray
    index: np.ndarray
    value: np.ndarray  # zeros for the rescaled rows, then the polytope's coefficients
    rel_lo: np.ndarray
    rel_hi: np.ndarray
    row_of: np.ndarray
    col_nnz: np.ndarray
    gamma_col: np.ndarray
    tiny_col: np.ndarray
    sq_of: np.ndarray
    mono_of: list


#: layouts by pattern, the most recent last (a few arms and frames in one process)
_LAYOUTS: dict[tuple, _Layout] = {}
_LAYOUTS_KEPT = 16


def _layout(n: int, indptr: np.ndarray, indices: np.ndarray, mi: np.ndarray, mj: np.ndarray) -> _Layout:
    """The layout of the pattern (``n`` variables, CSR ``indptr``/``indices`` with sorted
    indices, monomials ``mi``/``mj``), from the cache when the same pattern was seen; the key
    is the pattern itself, so equal keys are equal patterns."""
    key = (n, indptr.tobytes(), indices.tobytes(), mi.tobytes(), mj.tobytes())
    lay = _LAYOUTS.pop(key, None)
    if lay is None:
        lay = _build_layout(n, indptr, indices, mi, mj)
        while len(_LAYOUTS) >= _LAYOUTS_KEPT:
            _LAYOUTS.pop(next(iter(_LAYOUTS)))
    _LAYOUTS[key] = lay
    return lay


def _build_layout(n: int, indptr: np.ndarray, indices: np.ndarray, mi: np.ndarray, mj: np.ndarray) -> _Layout:
    nm = len(mi)
    nbase = len(indptr) - 1
    nz = n + nm
    # -- pattern of the rescaled rows: each monomial brings its two variables along
    cols_of_row: list[list[int]] = []
    for r in range(nbase):
        cs = set()
        for p in range(indptr[r], indptr[r + 1]):
            c = int(indices[p])
            cs.add(c)
            if c >= n:
                cs.update((int(mi[c - n]), int(mj[c - n])))
        cols_of_row.append(sorted(cs))
    base_len = np.array([len(c) for c in cols_of_row], dtype=np.int64)
    base_index = np.array([c for cs in cols_of_row for c in cs], dtype=np.int64)
    base_start = np.concatenate([[0], np.cumsum(base_len)])
    slot_of = {(r, c): int(base_start[r]) + k for r, cs in enumerate(cols_of_row) for k, c in enumerate(cs)}
    nslot = int(base_start[-1])
    # -- contributions a * V[p] * V[q] to a slot (a coefficient) or to a row's constant
    # (slot nslot + r), with V = (u, w, 1): x_i = u_i + w_i X_i and
    # x_i x_j = w_i w_j M + u_j w_i X_i + u_i w_j X_j + u_i u_j; ``a`` is matrix entry ``src``
    U_, W_, ONE = 0, n, 2 * n
    src, cp, cq, cs_ = [], [], [], []

    def put(s, e, p, q):
        src.append(e)
        cp.append(p)
        cq.append(q)
        cs_.append(s)

    for r in range(nbase):
        for e in range(indptr[r], indptr[r + 1]):
            c = int(indices[e])
            if c < n:
                put(slot_of[(r, c)], e, W_ + c, ONE)
                put(nslot + r, e, U_ + c, ONE)
            else:
                i, j = int(mi[c - n]), int(mj[c - n])
                put(slot_of[(r, c)], e, W_ + i, W_ + j)
                put(slot_of[(r, i)], e, W_ + i, U_ + j)
                put(slot_of[(r, j)], e, U_ + i, W_ + j)
                put(nslot + r, e, U_ + i, U_ + j)
    # -- the polytope: per square 2 rows, per product 3 (M >= 0 is a column bound)
    sq = mi == mj
    rel_index, rel_value, rel_len, rel_lo = [], [], [], []
    for k in range(nm):
        i, j, m = int(mi[k]), int(mj[k]), n + k
        if sq[k]:
            rows = [
                ([i, m], [-2.0, 1.0], -1.0),  # (1 - X)^2 >= 0
                ([i, m], [1.0, -1.0], 0.0),
            ]  # 2 X (1 - X) >= 0
        else:
            rows = [
                ([i, j, m], [-1.0, -1.0, 1.0], -1.0),  # (1 - X_i)(1 - X_j) >= 0
                ([i, m], [1.0, -1.0], 0.0),  # X_i (1 - X_j) >= 0
                ([j, m], [1.0, -1.0], 0.0),
            ]  # (1 - X_i) X_j >= 0
        for idx, val, lo in rows:
            rel_index += idx
            rel_value += val
            rel_len.append(len(idx))
            rel_lo.append(lo)
    n_rel = len(rel_len)
    nrow = nbase + n_rel
    start = np.concatenate([base_start, nslot + np.cumsum(rel_len, dtype=np.int64)]).astype(np.int32)
    index = np.concatenate([base_index, np.array(rel_index, dtype=np.int64)]).astype(np.int32)
    col_nnz = np.bincount(index, minlength=nz)
    sq_of = np.full(n, -1, dtype=np.int64)  # the monomial X_i^2 of each variable, if any
    sq_of[mi[sq]] = n + np.flatnonzero(sq)
    return _Layout(
        src=np.array(src, dtype=np.int64),
        cp=np.array(cp, dtype=np.int64),
        cq=np.array(cq, dtype=np.int64),
        cs=np.array(cs_, dtype=np.int64),
        slot_row=np.repeat(np.arange(nbase), base_len).astype(np.int64),
        nslot=nslot,
        n_base=nbase,
        n_rel=n_rel,
        nrow=nrow,
        start=start,
        index=index,
        value=np.concatenate([np.zeros(nslot), np.array(rel_value, dtype=float)]),
        rel_lo=np.array(rel_lo, dtype=float),
        rel_hi=np.full(n_rel, np.inf),
        row_of=np.repeat(np.arange(nrow), np.diff(start)),
        col_nnz=col_nnz,
        gamma_col=np.asarray(iv.gamma(col_nnz + 2)),
        tiny_col=(col_nnz + 1) * iv.TINY,
        sq_of=sq_of,
        mono_of=[np.flatnonzero((mi == i) | (mj == i)) for i in range(n)],
    )


class BernsteinLP(Relaxation):
    """The LP of Fünfzig et al. 2010 over the unit box of a box, built once per box, solved for chosen columns.

    Columns: ``X_0 .. X_{n-1}`` then ``M_0 .. M_{nm-1}`` (the system's monomials, in the order of
    :class:`~kinbox.formulation.system.Compiled`). Rows: the system's rows rescaled (their
    coefficients change with the box), then the polytope rows (fixed). HiGHS, the safe bound,
    the Farkas check and the basis handling are :class:`Relaxation`'s.
    """

    def __init__(self, comp: Compiled):
        super().__init__(comp)  # HiGHS and its options, the step counter; the layout is replaced
        n = comp.n
        A = comp.A.tocsr()
        A.sort_indices()
        mi, mj = comp.mi.astype(np.int64), comp.mj.astype(np.int64)
        lay = _layout(n, A.indptr.astype(np.int64), A.indices.astype(np.int64), mi, mj)
        # the coefficients: per contribution, the matrix entry it scales (the layout says which)
        self._ca = np.asarray(A.data, dtype=float)[lay.src]
        self._cp, self._cq, self._cs = lay.cp, lay.cq, lay.cs
        self._slot_row = lay.slot_row
        self._nslot = lay.nslot
        self.n_base = lay.n_base
        self.n_rel = lay.n_rel
        self.nrow = lay.nrow
        self.start = lay.start
        self.index = lay.index
        self.value = lay.value.copy()
        self.base_nnz = lay.nslot
        self.rel_lo = lay.rel_lo
        self.rel_hi = lay.rel_hi
        self.row_of = lay.row_of
        self.col_nnz = lay.col_nnz
        self.gamma_col = lay.gamma_col
        self.tiny_col = lay.tiny_col
        self.dense = self.nz * self.nrow <= DENSE
        self.sq_of = lay.sq_of
        self.mono_of = lay.mono_of
        self.mi, self.mj = mi, mj
        self.u = np.zeros(n)
        self.w = np.zeros(n)

    # -- the LP of a box ---------------------------------------------------------------------
    def build(self, xlo, xhi, mlo=None, mhi=None, basis=None) -> None:
        """Pass the LP of the box ``[xlo, xhi]`` (its unit box) to HiGHS, starting from ``basis``
        if given. The monomial bounds ``mlo``/``mhi`` are not used: the columns ``M`` get
        ``[0, 1]``, their range on the unit box."""
        n = self.n
        u = np.asarray(xlo, dtype=float).copy()
        with np.errstate(over="ignore", invalid="ignore"):
            w = np.nextafter(np.asarray(xhi, dtype=float) - u, np.inf)
        w = np.where(xhi == xlo, 0.0, w)  # a pinned variable: X_i is a dummy, fixed at 0
        self.u, self.w = u, w
        vals, blo, bhi = _rescaled_rows(
            np.concatenate([u, w, [1.0]]), self._ca, self._cp, self._cq, self._cs, self._nslot, self._slot_row, self.base_lo, self.base_hi
        )
        self.value[: self.base_nnz] = vals
        self.row_lo = np.concatenate([blo, self.rel_lo])
        self.row_hi = np.concatenate([bhi, self.rel_hi])
        self.zlo = np.zeros(self.nz)
        self.zhi = np.ones(self.nz)
        self.zhi[:n] = np.where(w == 0.0, 0.0, 1.0)
        self.zmag = self.zhi.copy()
        self._GT = None
        self.pass_model(basis)

    def set_unit_bounds(self, i: int, lo: float, hi: float) -> None:
        """Narrow ``X_i`` to ``[lo, hi]`` (within [0, 1]) in the live model, and the monomials of
        ``X_i`` to their range over the narrowed unit box (all factors are >= 0): exact for
        ``X_i^2``, the products of the bounds for ``X_i X_j``, rounded outward."""
        self.set_bounds(i, lo, hi)
        n = self.n
        for k in self.mono_of[i]:
            a, b = int(self.mi[k]), int(self.mj[k])
            mlo = np.nextafter(self.zlo[a] * self.zlo[b], -np.inf)
            mhi = np.nextafter(self.zhi[a] * self.zhi[b], np.inf)
            c = n + int(k)
            nlo, nhi = max(self.zlo[c], mlo, 0.0), min(self.zhi[c], mhi)
            if nlo > self.zlo[c] or nhi < self.zhi[c]:
                self.set_bounds(c, nlo, max(nhi, nlo))

    def to_x(self, i: int, lo: float, hi: float) -> tuple[float, float]:
        """The bounds ``[lo, hi]`` of ``X_i`` as bounds of ``x_i = u_i + w_i X_i``, rounded outward."""
        u, w = self.u[i], self.w[i]
        if not (np.isfinite(u) and np.isfinite(w)):
            return -np.inf, np.inf
        xl = np.nextafter(u + np.nextafter(w * lo, -np.inf), -np.inf)
        xh = np.nextafter(u + np.nextafter(w * hi, np.inf), np.inf)
        return float(xl), float(xh)


@nb.njit(cache=True)
def _rescaled_rows(V, ca, cp, cq, cs, nslot, slot_row, tlo, thi):
    """Rescaled row coefficients (floats) and row bounds that hold for every point of the box.

    Each contribution ``a V[p] V[q]`` is computed as ``(a V[p]) V[q]``: off by at most
    ``gamma(3) |t| + 2 (1 + |V[q]|) TINY`` (two roundings, each with room for underflow). A slot's
    sum of ``N`` of them is off by ``gamma(N) sum |t|`` more; the error bound is doubled to
    cover its own rounding. The exact row ``sum c_s T_s + K`` lies in ``[tlo, thi]`` and every
    ``T_s`` in ``[0, 1]``, so ``sum c^_s T_s`` lies in ``[tlo - K^, thi - K^]`` widened by the sum
    of the errors of the coefficients and of ``K^``. A row with anything non-finite is dropped
    (no bounds, zero coefficients): fewer rows only relax the LP.
    """
    nbase = len(tlo)
    ntot = nslot + nbase
    val = np.zeros(ntot)
    mag = np.zeros(ntot)
    tiny = np.zeros(ntot)
    cnt = np.zeros(ntot)
    for c in range(len(ca)):
        q = V[cq[c]]
        t = (ca[c] * V[cp[c]]) * q
        s = cs[c]
        val[s] += t
        mag[s] += abs(t)
        tiny[s] += 2.0 * (1.0 + abs(q)) * _TINY
        cnt[s] += 1.0
    g3 = 3.0 * _U / (1.0 - 3.0 * _U)
    err = np.zeros(ntot)
    for s in range(ntot):
        nu = (cnt[s] + 1.0) * _U
        err[s] = np.nextafter(2.0 * ((nu / (1.0 - nu) + g3) * mag[s] + tiny[s]), np.inf)
    rad = np.zeros(nbase)
    bad = np.zeros(nbase, dtype=np.bool_)
    nterm = np.zeros(nbase)
    for s in range(nslot):
        r = slot_row[s]
        rad[r] += err[s]
        nterm[r] += 1.0
        if not (np.isfinite(val[s]) and np.isfinite(err[s])):
            bad[r] = True
    row_lo = np.empty(nbase)
    row_hi = np.empty(nbase)
    for r in range(nbase):
        k = val[nslot + r]
        e = err[nslot + r]
        nu = (nterm[r] + 2.0) * _U
        R = np.nextafter((rad[r] + e) * (1.0 + 2.0 * nu / (1.0 - nu)), np.inf)
        if bad[r] or not (np.isfinite(k) and np.isfinite(R)):
            row_lo[r] = -np.inf
            row_hi[r] = np.inf
            continue
        lo = -np.inf
        if tlo[r] > -np.inf:
            lo = np.nextafter(np.nextafter(tlo[r] - k, -np.inf) - R, -np.inf)
            if lo != lo:
                lo = -np.inf
        hi = np.inf
        if thi[r] < np.inf:
            hi = np.nextafter(np.nextafter(thi[r] - k, np.inf) + R, np.inf)
            if hi != hi:
                hi = np.inf
        row_lo[r] = lo
        row_hi[r] = hi
    for s in range(nslot):
        if bad[slot_row[s]]:
            val[s] = 0.0
    return val[:nslot], row_lo, row_hi


def load_kernel() -> None:
    """Load (on the first run: compile and cache) the rescaling kernel."""
    one = np.ones(1)
    i0 = np.zeros(1, dtype=np.int64)
    _rescaled_rows(np.ones(3), one, i0, i0, i0, 1, i0, -one, one)


class BernsteinRelaxation:
    """Domain reduction over the Bernstein polytope (Fünfzig et al. 2010, Sec. 4.2), with the interface and the
    round structure of :class:`~kinbox.search.contractors.LinearRelaxation`: one LP model per
    box (its unit box), the independent variables (``mask``) bounded by min/max LPs, widest
    first relative to ``root_w``; the round ends after a variable that shrank by less than
    ``pay`` of its width. ``squares=True`` adds the nonlinear reduction of Sec. 6 (two LPs on
    ``X_i^2`` after the two on ``X_i``).
    """

    def __init__(self, comp: Compiled, mask: np.ndarray, root_w: np.ndarray, pay: float = LP_VAR_PAYS, squares: bool | None = None):
        self.relax = BernsteinLP(comp)
        self.mask, self.root_w, self.pay = mask, root_w, pay
        self.squares = SQUARES if squares is None else squares
        self.deadline: float | None = None

    def contract(self, lo, hi, mlo=None, mhi=None, basis=None) -> Contraction:
        """One round on the box; ``basis`` (from ``relax.basis()``) starts the first LP."""
        lp = self.relax
        lp.lps = 0
        lp.build(lo, hi, basis=basis)
        lo, hi = np.array(lo, dtype=float), np.array(hi, dtype=float)
        rel = (hi - lo) / self.root_w
        order = [int(i) for i in np.argsort(-rel, kind="stable") if self.mask[i] and hi[i] > lo[i]]
        for i in order:
            if self.deadline is not None and time.perf_counter() > self.deadline:
                break
            w = hi[i] - lo[i]
            L, U = lp.zlo[i], lp.zhi[i]
            cols = [(i, False)]
            if self.squares and lp.sq_of[i] >= 0:
                cols.append((int(lp.sq_of[i]), True))
            for k, square in cols:
                for sense in (+1, -1):
                    b, infeasible = lp.bound(k, sense)
                    if infeasible:
                        return Contraction(ContractStatus.EMPTY, lo, hi, work=lp.lps)
                    if b is None:
                        continue
                    if square:  # X_i = sqrt(M_ii), X_i >= 0
                        b = (
                            (np.nextafter(np.sqrt(b), -np.inf) if b > 0.0 else 0.0)
                            if sense > 0
                            else (np.nextafter(np.sqrt(b), np.inf) if b >= 0.0 else -1.0)
                        )
                    if sense > 0 and b > L:
                        L = max(L, float(b))
                    if sense < 0 and b < U:
                        U = min(U, float(b))
                if L > U:
                    return Contraction(ContractStatus.EMPTY, lo, hi, work=lp.lps)
                if square is False:
                    lp.set_unit_bounds(i, L, U)
            if L > U:
                return Contraction(ContractStatus.EMPTY, lo, hi, work=lp.lps)
            lp.set_unit_bounds(i, L, U)
            xl, xh = lp.to_x(i, L, U)
            lo[i], hi[i] = max(lo[i], xl), min(hi[i], xh)
            if lo[i] > hi[i]:
                return Contraction(ContractStatus.EMPTY, lo, hi, work=lp.lps)
            if hi[i] - lo[i] > (1.0 - self.pay) * w:
                break
        return Contraction(ContractStatus.NARROWED, lo, hi, work=lp.lps)
