"""The linear relaxation of a box and its LPs (Porta, Ros and Thomas 2009, Sec. IV-B, Algorithm 2), solved by HiGHS.

For a box, the LP holds

* every equation and inequality of the expanded system, linear in ``z = (x, m)``;
* for each parabola ``m = x^2`` on ``[a, b]``: the secant ``m <= (a+b) x - ab`` and the
  tangents at ``a``, ``b`` and ``(a+b)/2`` (Fig. 4);
* for each hyperbolic paraboloid ``m = x y``: the four McCormick half-spaces of its
  tetrahedron (Fig. 5).

Numerical safety. The LP solver works in floating point, so nothing it returns is trusted
as such:

* Relaxation rows are *valid by construction*: the slope is any float, and the right-hand
  side is an outward-rounded bound of the exact function over the box (convexity for the
  parabola, vertices for the bilinear form), so every solution point satisfies every row.
* A bound is derived from the LP's dual values ``y`` (any ``y`` gives a valid bound) as
  Neumaier and Shcherbina do (Neumaier and Shcherbina 2004): for ``min z_i``, ``z_i = y^T G z + r^T z`` with
  ``r = e_i - G^T y``, so ``z_i >= min_{w in [L,U]} y^T w + min_{z in box} r^T z``, evaluated
  in outward-rounded interval arithmetic with ``r`` enclosed with its rounding error.
* A box is discarded as infeasible only when the dual ray ``y`` HiGHS returns passes the same
  interval check (Farkas: ``y^T G z`` over the box and ``y^T w`` over the row bounds are
  disjoint). Otherwise the box is kept unchanged.
"""

from __future__ import annotations

import ctypes
import os
import sys
import time

import highspy
import numpy as np
import scipy.sparse as sp

from .. import interval as iv
from ..formulation.system import Compiled
from ..interval import TINY, U
from . import jit as nb

_INF = highspy.kHighsInf
BASIS_STATUS = {
    int(v): v
    for v in (
        highspy.HighsBasisStatus.kLower,
        highspy.HighsBasisStatus.kBasic,
        highspy.HighsBasisStatus.kUpper,
        highspy.HighsBasisStatus.kZero,
        highspy.HighsBasisStatus.kNonbasic,
    )
}
#: the basis statuses by their number (a list: indexing it is cheaper than hashing an int8)
_STATUS_OF = [BASIS_STATUS[i] for i in range(max(BASIS_STATUS) + 1)]
_ROWWISE = int(highspy.MatrixFormat.kRowwise)
_MINIMIZE = int(highspy.ObjSense.kMinimize)
#: where parabolas get tangents, as fractions of their interval (the secant is always there)
TANGENTS = (0.0, 1.0, 0.5)
#: LPs up to this many matrix entries (rows x columns) keep ``G^T`` dense for the Farkas checks
DENSE = 250_000
#: simplex iterations allowed per LP (they take 50-100 at the root of a 6R, a few afterwards)
ITERATION_LIMIT = 5000
#: simplex steps allowed per LP, counted by HiGHS's simplex interrupt callback: iterations and
#: also the bound flips and rebuilds that HiGHS's own iteration count leaves out. Primal phase 1
#: can flip nonbasic variables between their bounds forever without one basis change, so
#: ``simplex_iteration_limit`` alone never stops it (tests/search/test_relaxation.py replays such an LP).
#: A count, not a clock: an LP stopped here stops at the same step on every machine.
STEP_LIMIT = 2 * ITERATION_LIMIT
#: steps allowed beyond the simplex iterations (bound flips, rebuilds): a few tens in the LPs
#: measured, thousands in a flip cycle, which this stops long before STEP_LIMIT (such an LP
#: gives no bound either way, and was most of the time of the arm poses it occurred in;
#: benchmarks/arm_classes.py; tests/search/test_relaxation.py replays a flip cycle)
FLIP_LIMIT = 1000
#: a last-resort wall-clock cap per LP (seconds), for a HiGHS loop that does not reach the
#: callback. Not reached by any LP seen so far; an LP stopped by it gives no bound, which is safe
#: but depends on the machine, so it sits far above what any LP takes (milliseconds) even on a
#: loaded machine that deschedules the process: only a hang reaches it, and the counts stay the
#: same from run to run.
LP_SECONDS = 10.0
#: an LP the primal simplex found infeasible without a dual ray is solved again by the dual
#: simplex, which gives one (for the Farkas check)
RAY_FROM_DUAL = True
#: HiGHS's ``simplex_strategy`` values
DUAL, PRIMAL = 1, 4
#: columns whose bounds are both smaller than this are zero up to underflow (an exact 0 widened
#: outward by a few ``TINY``): HiGHS gets them fixed at 0
UNDERFLOW = 1e-300


class Relaxation:
    """Builds the LP of a box once and solves min/max of chosen variables on it."""

    def __init__(self, comp: Compiled):
        self.comp = comp
        n = comp.n
        self.n, self.nz = n, comp.nz
        A = comp.A.tocsr()
        A.sort_indices()
        self.n_base = A.shape[0]
        sq = comp.mi == comp.mj
        self.sq_k = np.flatnonzero(sq)
        self.bl_k = np.flatnonzero(~sq)
        ns, nb = len(self.sq_k), len(self.bl_k)
        # relaxation rows: per parabola the secant + tangents, 4 per hyperbola
        self.nsq = nsq = 1 + len(TANGENTS)
        self.n_rel = nsq * ns + 4 * nb
        # rows of parabolas: [x_i, m_k] ; hyperbolas: [x_i, x_j, m_k]
        ind_sq = np.stack([comp.mi[self.sq_k], n + self.sq_k], axis=1)  # (ns, 2)
        ind_bl = np.stack([comp.mi[self.bl_k], comp.mj[self.bl_k], n + self.bl_k], axis=1)
        rel_idx = np.concatenate([np.repeat(ind_sq, nsq, axis=0).ravel(), np.repeat(ind_bl, 4, axis=0).ravel()])
        rel_len = np.concatenate([np.full(nsq * ns, 2), np.full(4 * nb, 3)])
        self.nrow = self.n_base + self.n_rel
        self.start = np.concatenate([A.indptr, A.indptr[-1] + np.cumsum(rel_len)]).astype(np.int32)
        self.index = np.concatenate([A.indices, rel_idx]).astype(np.int32)
        self.value = np.concatenate([A.data, np.zeros(len(rel_idx))])
        self.base_nnz = len(A.data)
        self.rel_len = rel_len
        self.row_of = np.repeat(np.arange(self.nrow), np.diff(self.start))
        # structural non-zeros per column (an upper bound of the actual ones, for rounding bounds)
        self.col_nnz = np.bincount(self.index, minlength=self.nz)
        self.gamma_col = iv.gamma(self.col_nnz + 2)
        self.tiny_col = (self.col_nnz + 1) * iv.TINY
        self.dense = self.nz * self.nrow <= DENSE
        self.base_lo = comp.target_lo
        self.base_hi = comp.target_hi
        self.lps = 0
        self.iterations = 0
        self._h = new_highs()
        h = self._h
        h.setOptionValue("output_flag", False)
        h.setOptionValue("presolve", "off")
        h.setOptionValue("simplex_strategy", PRIMAL)  # after a change of objective the basis stays feasible
        h.setOptionValue("threads", 1)
        # a guard against stalls (a degenerate LP once ran for minutes): an LP stopped early
        # gives no bound, which is always safe
        h.setOptionValue("simplex_iteration_limit", ITERATION_LIMIT)
        #: the end of the search's time budget (``time.perf_counter()``), or None: LPs are not
        #: started after it and are stopped at it, so a budget holds inside a box too
        self.deadline: float | None = None
        self._steps = [0]  # simplex steps of the current run
        self._cold = False
        h.setCallback(_step_counter(self._steps), None)
        h.startCallback(highspy.cb.HighsCallbackType.kCallbackSimplexInterrupt)

    # -- rows ---------------------------------------------------------------------
    def _relaxation_rows(self, xlo, xhi):
        """Values and bounds of the relaxation rows for the box (valid by construction)."""
        c = self.comp
        ns, nb = len(self.sq_k), len(self.bl_k)
        vals = []
        rlo = np.full(self.n_rel, -np.inf)
        rhi = np.full(self.n_rel, np.inf)
        if ns:
            i = c.mi[self.sq_k]
            a, b = xlo[i], xhi[i]
            # secant: m - s x <= max_{x in {a,b}} (x^2 - s x) (convex in x)
            s = a + b
            ga = _quad_at(a, s)
            gb = _quad_at(b, s)
            sec_t = np.maximum(ga[1], gb[1])
            # tangents at p: m - 2p x >= -(2p)^2/4 holds for every x
            slopes = [s] + [2.0 * (a + f * (b - a)) for f in TANGENTS]
            k = self.nsq
            vsq = np.empty((ns, k, 2))
            for r, sl in enumerate(slopes):
                vsq[:, r, 0] = -sl
                vsq[:, r, 1] = 1.0
            vals.append(vsq.ravel())
            blk_lo = np.empty((ns, k))
            blk_hi = np.empty((ns, k))
            blk_lo[:, 0] = -np.inf
            blk_hi[:, 0] = sec_t
            for r, sl in enumerate(slopes[1:], start=1):
                blk_lo[:, r] = -(iv.up(sl * sl) * 0.25) - iv.TINY
                blk_hi[:, r] = np.inf
            rlo[: k * ns] = blk_lo.ravel()
            rhi[: k * ns] = blk_hi.ravel()
        if nb:
            i, j = c.mi[self.bl_k], c.mj[self.bl_k]
            xl, xu, yl, yu = xlo[i], xhi[i], xlo[j], xhi[j]
            # McCormick: m - alpha x - beta y >= / <= -beta alpha, from the exact products
            # (x - xl)(y - yl) >= 0, (xu - x)(yu - y) >= 0, (x - xl)(yu - y) >= 0 and
            # (xu - x)(y - yl) >= 0 over the box; the slopes are box bounds (exact floats) and
            # the right-hand side is one product, rounded outward (TINY covers underflow)
            specs = [(yl, xl, True), (yu, xu, True), (yu, xl, False), (yl, xu, False)]
            vbl = np.empty((nb, 4, 3))
            blo = np.full((nb, 4), -np.inf)
            bhi = np.full((nb, 4), np.inf)
            for r, (alpha, beta, under) in enumerate(specs):
                vbl[:, r, 0] = -alpha
                vbl[:, r, 1] = -beta
                vbl[:, r, 2] = 1.0
                p = alpha * beta
                if under:
                    blo[:, r] = -(iv.up(p) + iv.TINY)
                else:
                    bhi[:, r] = -(iv.down(p) - iv.TINY)
            vals.append(vbl.ravel())
            rlo[self.nsq * ns :] = blo.ravel()
            rhi[self.nsq * ns :] = bhi.ravel()
        v = np.concatenate(vals) if vals else np.zeros(0)
        return v, rlo, rhi

    def build(self, xlo, xhi, mlo, mhi, basis=None) -> None:
        """Pass the LP of box ``(x, m)`` to HiGHS (one model per box), starting from ``basis``
        (see :meth:`basis`) if given, else from HiGHS's slack basis. Nothing of the LPs solved
        before for other boxes is used: a box's bounds depend on the box (and ``basis``) only."""
        v, rlo, rhi = self._relaxation_rows(xlo, xhi)
        self.value[self.base_nnz :] = v
        self.row_lo = np.concatenate([self.base_lo, rlo])
        self.row_hi = np.concatenate([self.base_hi, rhi])
        self.zlo = np.concatenate([xlo, mlo])
        self.zhi = np.concatenate([xhi, mhi])
        self._GT: tuple | None = None  # G^T and |G^T| for Farkas checks, made when one is needed
        self.zmag = np.maximum(np.abs(self.zlo), np.abs(self.zhi))
        self.pass_model(basis)

    def pass_model(self, basis=None) -> None:
        """Give HiGHS the LP held here (rows ``start/index/value`` in ``[row_lo, row_hi]``,
        columns in ``[zlo, zhi]``, no objective yet), starting from ``basis`` if given.

        The arrays go to HiGHS through ``passModel``'s array form (pointers, copied in C++): the
        same LP as a ``HighsLp`` filled field by field, without pybind's element-by-element
        conversion of each array, which cost some 120 us per box (tests/search/test_relaxation.py checks
        that the array form gives HiGHS the same LP and the same steps)."""
        col_lo, col_hi = for_highs(self.zlo, self.zhi)
        h = self._h
        h.passModel(
            self.nz,
            self.nrow,
            len(self.value),
            _ROWWISE,
            _MINIMIZE,
            0.0,
            np.zeros(self.nz),
            col_lo,
            col_hi,
            np.where(np.isfinite(self.row_lo), self.row_lo, -_INF),
            np.where(np.isfinite(self.row_hi), self.row_hi, _INF),
            self.start,
            self.index,
            self.value,
            # all continuous: HiGHS reads num_col entries from a non-null pointer, so an
            # empty array would be read past its end
            np.zeros(self.nz, dtype=np.int32),
        )
        if basis is not None:
            b = highspy.HighsBasis()
            b.col_status = list(map(_STATUS_OF.__getitem__, basis[0].tolist()))
            b.row_status = list(map(_STATUS_OF.__getitem__, basis[1].tolist()))
            b.valid = True
            h.setBasis(b)
        self._cost_col: int | None = None
        #: the next LP starts from HiGHS's slack basis. The columns are boxed (a box), so that
        #: basis is dual feasible for any objective and the dual simplex needs no phase 1, where
        #: the primal one starts infeasible; and many such LPs prove the box empty, which the
        #: dual simplex reaches directly, with the ray the Farkas check needs
        self._cold = basis is None

    def basis(self):
        """The basis of the last LP solved, as two small arrays (picklable, for a child box)."""
        b = self._h.getBasis()
        if not b.valid:
            return None
        cs, rs = b.col_status, b.row_status  # each access converts the whole vector
        return np.fromiter(map(int, cs), np.int8, len(cs)), np.fromiter(map(int, rs), np.int8, len(rs))

    # -- solves ---------------------------------------------------------------------
    def bound(self, k: int, sense: int):
        """Safe bound of ``z_k``: a lower bound (``sense=+1``) or upper bound (``-1``).

        Returns ``(bound, infeasible)``; ``bound`` is ``None`` when nothing safe was derived
        and ``infeasible`` is True only when infeasibility was verified.
        """
        h = self._h
        if self._cost_col is not None and self._cost_col != k:
            h.changeColCost(self._cost_col, 0.0)
        h.changeColCost(k, float(sense))
        self._cost_col = k
        t = time.perf_counter()
        limit = LP_SECONDS
        if self.deadline is not None:
            limit = min(limit, self.deadline - t)
            if limit <= 0.0:
                return None, False  # the budget is spent: no bound (the search stops after this box)
        # HiGHS's time limit is on its run clock, which adds up over the runs of one instance
        h.setOptionValue("time_limit", h.getRunTime() + limit)
        self._steps[0] = 0
        if self._cold:
            h.setOptionValue("simplex_strategy", DUAL)
            h.run()
            h.setOptionValue("simplex_strategy", PRIMAL)
            self._cold = False
        else:
            h.run()
        self.lps += 1
        self.iterations += h.getInfo().simplex_iteration_count
        status = h.getModelStatus()
        if status == highspy.HighsModelStatus.kOptimal:
            y = np.asarray(h.getSolution().row_dual, dtype=float)
            lb = _safe_lower(
                k,
                float(sense),
                y,
                self.start,
                self.index,
                self.value,
                self.row_lo,
                self.row_hi,
                self.zlo,
                self.zhi,
                self.zmag,
                self.gamma_col,
                self.tiny_col,
            )
            if not np.isfinite(lb):
                return None, False
            return (lb if sense > 0 else -lb), False
        if status == highspy.HighsModelStatus.kInfeasible:
            ok, has, ray = h.getDualRay()  # type: ignore[attr-defined]  # in highspy, missing from its stubs
            if not has and RAY_FROM_DUAL:
                # the primal simplex proves infeasibility without a dual ray, and HiGHS's
                # attempt to find one solves again with the primal simplex: the dual simplex
                # finds one (7 % of the four-bar's LPs were infeasible with no ray, the box kept)
                h.setOptionValue("simplex_strategy", DUAL)
                self._steps[0] = 0
                ok, has, ray = h.getDualRay()  # type: ignore[attr-defined]
                h.setOptionValue("simplex_strategy", PRIMAL)
            if has and self._farkas(np.asarray(ray, dtype=float)):
                return None, True
        return None, False

    def _enclose_GTy(self, y):
        if self._GT is None:
            if self.dense:  # small LPs: numpy on a dense G^T, no scipy overhead
                GT = np.zeros((self.nz, self.nrow))
                GT[self.index, self.row_of] = self.value
            else:
                GT = sp.csr_matrix((self.value, self.index, self.start), shape=(self.nrow, self.nz)).T.tocsr()
            self._GT = GT, abs(GT)
        GT, absGT = self._GT
        GTy = GT @ y
        err = self.gamma_col * (absGT @ np.abs(y)) + self.tiny_col
        return GTy, err

    def _row_part(self, y):
        lo, hi = iv.mul(y, y, self.row_lo, self.row_hi)
        return lo, hi

    def _farkas(self, y) -> bool:
        """True if ``y`` proves that ``G z in [row_lo, row_hi]`` has no ``z`` in the box."""
        for yy in (y, -y):
            yy = np.where((yy > 0) & ~np.isfinite(self.row_lo), 0.0, yy)
            yy = np.where((yy < 0) & ~np.isfinite(self.row_hi), 0.0, yy)
            GTy, err = self._enclose_GTy(yy)
            rlo = iv.down(GTy - err)
            rhi = iv.up(GTy + err)
            zl, zh = iv.mul(rlo, rhi, self.zlo, self.zhi)
            zmax = iv.dot_bounds(zl, zh)[1]
            wl, _ = self._row_part(yy)
            wmin = iv.dot_bounds(wl, wl)[0]
            # y^T G z <= zmax < wmin <= y^T w: no z with G z = w
            if zmax < wmin:
                return True
        return False

    def set_bounds(self, k: int, lo: float, hi: float) -> None:
        """Tighten column ``k`` in the live model (Gauss-Seidel use of new bounds)."""
        self.zlo[k] = lo
        self.zhi[k] = hi
        self.zmag[k] = max(abs(lo), abs(hi))
        self._h.changeColBounds(k, *(float(v) for v in for_highs(lo, hi)))


def for_highs(lo, hi):
    """Column bounds as HiGHS gets them: a column that is zero up to underflow is fixed at 0.

    HiGHS treats such a column as boxed (and perturbs its bounds). Three UR5 LPs with such
    columns (one is tests/data/lp_flip_cycle.npz) made its primal phase 1 flip variables between
    their bounds forever; with these columns fixed, each solves in a few hundred iterations,
    while widening them to +-1e-12 does not help. Nothing is lost in rigour:
    the safe bound and the Farkas check take the box's own bounds (``zlo``, ``zhi``), and any
    row multipliers give a valid bound.
    """
    zero = (np.abs(lo) < UNDERFLOW) & (np.abs(hi) < UNDERFLOW)
    return np.where(zero, 0.0, lo), np.where(zero, 0.0, hi)


def _step_counter(steps: list):
    """HiGHS's simplex interrupt callback: counts the steps of a run (iterations, bound flips,
    rebuilds) in ``steps[0]`` and stops the run past :data:`STEP_LIMIT`, or once the steps that
    are not iterations pass :data:`FLIP_LIMIT`. A closure over the
    counter, not a method: a callback held by HiGHS (C++) that referred back to the Relaxation
    would make a cycle Python's garbage collector cannot see, and every Relaxation would leak."""

    def on_step(callback_type, message, data_out, data_in, user_data):
        steps[0] += 1
        # assigned every time: HiGHS keeps the flag set from one run to the next
        data_in.user_interrupt = steps[0] > STEP_LIMIT or steps[0] - data_out.simplex_iteration_count > FLIP_LIMIT

    return on_step


# -- the compiled safe bound ---------------------------------------------------------------------
# The numpy version (tests/support/lp_reference.py) made some twenty-five calls on small arrays per LP,
# a large share of the LP time (benchmarks/relaxations.py counts LPs and time). The same
# arithmetic in one loop over the rows of G (tests/search/test_relaxation.py checks the two agree).


def load_kernel() -> None:
    """Load (on the first run: compile and cache) the compiled safe bound; a solve does it when
    it first needs it."""
    one, i0 = np.ones(1), np.zeros(1, dtype=np.int32)
    _safe_lower(0, 1.0, one, np.array([0, 1], dtype=np.int32), i0, one, -one, one, -one, one, one, one, one)


def new_highs() -> highspy.Highs:
    """A HiGHS instance that prints nothing on stdout.

    HiGHS 1.16 prints its banner from C++ when the first instance of a process is made, before
    ``output_flag`` can be set; stdout carries kinbox's JSON, so the C-level stdout is pointed at
    ``/dev/null`` while the instance is made.
    """
    global _BANNER_DONE
    if _BANNER_DONE:
        return highspy.Highs()
    sys.stdout.flush()
    libc = ctypes.CDLL(None)
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            try:
                h = highspy.Highs()
            finally:
                libc.fflush(None)
                os.dup2(saved, 1)
    finally:
        os.close(saved)
    _BANNER_DONE = True
    return h


_BANNER_DONE = False


@nb.njit(cache=True)
def _safe_lower(k, sense, y, start, index, value, row_lo, row_hi, zlo, zhi, zmag, gamma_col, tiny_col):
    """A lower bound of ``sense * z_k`` over the LP's feasible set, from any row multipliers ``y``.

    With ``r = cost - G^T y``: ``cost^T z = r^T z + y^T (G z)`` and ``G z`` lies in the row
    bounds, so ``cost^T z >= min_box r^T z + min_rows y^T w``. ``r`` is enclosed in ``r +- rad``
    (``G^T y`` summed over each column's ``nnz`` terms is off by ``gamma(nnz + 2)`` of the sum of
    their magnitudes, and the subtraction by ``gamma(2) |r|``), each term ``min_z (r_i z_i) -
    rad_i |z_i|`` is a lower bound of its exact counterpart, and the sum of the ``N`` float terms
    is widened by Higham's ``gamma(N + 4)`` (each term costs at most three more roundings,
    relative to the magnitudes of its parts) and rounded down. A multiplier of a row unbounded
    on its side is taken as 0 (any ``y`` gives a bound).
    """
    nrow, nz = len(start) - 1, len(zlo)
    gty, agty = np.zeros(nz), np.zeros(nz)
    s, mag = 0.0, 0.0
    for i in range(nrow):
        yi = y[i]
        if yi > 0.0:
            if row_lo[i] == -np.inf:
                continue
            t = yi * row_lo[i]
        elif yi < 0.0:
            if row_hi[i] == np.inf:
                continue
            t = yi * row_hi[i]
        else:
            continue
        s += t
        mag += abs(t)
        ay = abs(yi)
        for p in range(start[i], start[i + 1]):
            j = index[p]
            gty[j] += value[p] * yi
            agty[j] += abs(value[p]) * ay
    g2 = 2.0 * U / (1.0 - 2.0 * U)
    for j in range(nz):
        r = (sense if j == k else 0.0) - gty[j]
        rad = gamma_col[j] * agty[j] + tiny_col[j] + g2 * abs(r)
        p1, p2 = r * zlo[j], r * zhi[j]
        if p1 != p1:  # 0 * inf: a zero multiplier of an unbounded column contributes nothing
            p1 = 0.0
        if p2 != p2:
            p2 = 0.0
        pz = min(p1, p2)
        ez = rad * zmag[j]
        if ez != ez:
            ez = 0.0
        s += pz - ez
        mag += abs(pz) + ez
    if not np.isfinite(s):
        return -np.inf
    n = nz + nrow
    nu = (n + 4) * U
    return np.nextafter(s - (nu / (1.0 - nu) * mag + 4 * n * TINY), -np.inf)


def _quad_at(x, s):
    """Enclosure of ``x^2 - s x`` at points ``x``."""
    v = x * x - s * x
    e = iv.gamma(3) * (x * x + np.abs(s * x)) + 3 * iv.TINY
    return iv.down(v - e), iv.up(v + e)
