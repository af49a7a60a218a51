"""Branch-and-prune over boxes (003 Algorithm 1), with cheap contractors before LPs.

For each box taken from the list:

1. **propagate** (``propagate.py``): interval constraint propagation, vectorised; may prove
   the box empty;
2. **Krawczyk** (``certify.py``, square systems only): may prove the box empty, contract it, or
   prove it holds exactly one solution — then the box is finished at once (polished by Newton,
   certified), however wide it still is;
3. **SHRINK-BOX** (``relaxation.py``): two LPs per variable over the linear relaxation,
   repeated while the box volume drops below ``rho`` of what it was;
4. a box narrower than ``sigma`` that is not certified is returned as an (uncertified) solution
   box — the only outcome on positive-dimensional solution sets; otherwise it is **split**.

Every pruning step is conservative (outward rounding, safe LP bounds), so the union of the
returned boxes holds every solution of the system inside the initial domain. When a budget
(``max_boxes``, ``time_limit``) stops the search the result says so (``complete=False``) and keeps
the unexplored boxes in ``pending``.
"""

from __future__ import annotations

import dataclasses
import math
import sys
import time
from dataclasses import dataclass, field

import numpy as np

from . import certify, propagate, relaxation
from .certify import Certifier, gauss_newton
from .propagate import Propagator
from .relaxation import Relaxation
from ..formulation.system import System

SPLIT_POINT = 0.4937  # a split slightly off the middle: solutions rarely sit on the cut
RATIO = 0.1  # split candidates are at least this wide relative to the widest: no flat boxes
LP_RATE = 0.5  # LP rounds are run while at least this share of recent ones paid...
LP_PROBE = 8  # ...and on a probe box otherwise (every 8th or rarer, see _lp_worth_it)
K_RATE = 0.15  # Krawczyk runs on every box while this share of recent tests paid (else probes)
#: an LP round pays if it proves the box empty or removes this much log-volume per box of
#: work it costs. Measured 2026-11-22 (CPU s, against the rule before: a fifth of the volume
#: whatever the cost, LPs always on boxes wider than a tenth of the domain): UR5 median over
#: 5 poses 10.3 -> 3.1, general 6R 1.12 -> 0.79, four-bar 2.8 -> 2.4, Dietmeier 53 -> 62
#: (noisy runs, two jobs at once)
LP_GAIN = 0.05
RESOLVED = 1e-9  # equation residual of an approximate solution found in a box
#: a round of LPs moves on to the next variable only if the last one shrank by this share of
#: its width: 1 = one variable per round. Measured against 0.05 (2026-11-22, CPU time): general
#: 6R -30 %, Dietmeier -15 %, UR5 -5 %, Griffis-Duffy -6 %, four-bar equal, with 2-2.4x fewer LPs
LP_VAR_PAYS = 1.0


@dataclass
class SolutionBox:
    """A box returned by the solver.

    ``lo``/``hi`` is the box the solver finished (for a certified box: the region proven to
    hold exactly one solution); ``enclosure`` is the tightest box known to hold it; ``x`` a
    polished point; ``residual`` the max absolute equation value at ``x``.
    """

    lo: np.ndarray
    hi: np.ndarray
    x: np.ndarray
    certified: bool
    residual: float
    enclosure: tuple[np.ndarray, np.ndarray]

    @property
    def width(self) -> float:
        return float(np.max(self.enclosure[1] - self.enclosure[0], initial=0.0))


@dataclass
class SolveResult:
    """Outcome of :func:`solve_system`, in the style of ``scipy.optimize.OptimizeResult``."""

    success: bool
    complete: bool
    message: str
    boxes: list[SolutionBox]
    pending: list[tuple[np.ndarray, np.ndarray]]
    stats: dict
    system: System

    @property
    def certified(self) -> list[SolutionBox]:
        return [b for b in self.boxes if b.certified]

    def __repr__(self) -> str:
        return (f"SolveResult(success={self.success}, complete={self.complete}, "
                f"boxes={len(self.boxes)}, certified={len(self.certified)}, "
                f"message={self.message!r})")


@dataclass
class SolverOptions:
    sigma: float = 1e-3
    rho: float = 0.95
    max_boxes: int | None = 500_000
    time_limit: float | None = None
    lp: bool = True
    certify: bool = True
    progress: bool | None = None  # None: only when stderr is a terminal
    lp_rounds: int = 20
    #: square systems: a box below sigma that holds a regular-looking root is split further
    #: (until Krawczyk proves it or it is narrower than this), since sigma is meant for
    #: positive-dimensional sets and certification, not width, decides isolated roots
    min_width: float = 1e-11
    #: a box below sigma in which no approximate solution is found is split down to
    #: ``sigma * resolve`` before it is returned (uncertified)
    resolve: float = 1e-3


class Progress:
    def __init__(self, enabled: bool, root_logvol: np.ndarray):
        self.enabled = enabled
        self.t0 = time.perf_counter()
        self.last = self.t0
        self.root_w = root_logvol

    def report(self, stats, stack, force=False):
        if not self.enabled:
            return
        now = time.perf_counter()
        if not force and now - self.last < 1.0:
            return
        self.last = now
        vol = sum(float(np.prod(np.clip((hi - lo) / self.root_w, 0, 1))) for lo, hi in stack)
        rate = stats["boxes"] / max(now - self.t0, 1e-9)
        print(f"kinbox: {stats['boxes']} boxes, {len(stack)} pending, {stats['solutions']} solutions "
              f"({stats['certified']} certified), volume left {vol:.3e}, {rate:.0f} boxes/s",
              file=sys.stderr, flush=True)


@dataclass
class BoxOutcome:
    """What processing one box gave: ``kind`` is "empty", "solution" or "split"."""

    kind: str
    solution: SolutionBox | None = None
    children: list = field(default_factory=list)
    lps: int = 0
    krawczyk: int = 0


class BoxProcessor:
    """Processes one box at a time (contract, certify, shrink, split). Holds no search state,
    so serial and parallel searches share it; each process builds its own."""

    def __init__(self, system: System, options: SolverOptions):
        self.opt = options
        self.comp = comp = system.compile()
        self.prop = Propagator(comp)
        self.cert = Certifier(comp)
        self.relax = Relaxation(comp) if options.lp and comp.n > 0 else None
        # compile (first run after an install) or load the kernels now, not inside a timed box:
        # a first LP round that took seconds of compiling made LPs look 1000x dearer than they
        # are, and a Griffis-Duffy solve then ran 53 000 boxes instead of 19 000 (2026-11-22)
        for load_kernel in (propagate.load_kernel, certify.load_kernel, relaxation.load_kernel):
            load_kernel()
        # the domain widened by the slack of derived rows: a root on a bound (an angle of 0, a
        # rotation entry of 1, a joint at its limit) is inside it, however its proof box lies
        self.lo0, self.hi0 = system.search_domain()
        self.root_w = np.maximum(self.hi0 - self.lo0, 1e-300)
        self.split_mask = system.independent()
        # LPs start off: the first round is a probe (box 8), and rounds that pay turn them on.
        # Measured 2026-11-22 against starting at the threshold (one round on the first box), in
        # the same conditions: UR5 median of 5 poses 0.10 -> 0.06 s (it needs ~150 boxes; its
        # cold first LPs cost 5-10 ms), general 6R 0.31 -> 0.19 s, four-bar, Panda, Dietmeier
        # and Griffis-Duffy even. (Starting at 1, LPs on every box until ~7 rounds failed, had
        # cost the UR5 another 2x.)
        self._lp_rate, self._lp_wait, self._lp_misses = 0.0, 0, 0
        self._k_rate, self._k_wait = 1.0, 0
        self._t_box, self._t_lp = None, None  # running seconds per box (without LPs), per LP round

    def _lp_worth_it(self) -> bool:
        """Spend LPs where they pay: while a running share of LP rounds pays off (see
        :meth:`_lp_paid`), and on a probe box every so often otherwise, to notice when they start
        paying again: rarer when an LP round costs many boxes, and twice as rare after a round
        that did not pay. Measured 2026-11-22: a UR5 pose (~150 boxes, LPs hardly ever pay)
        spent a third of its time on probes; the back-off takes the median of 5 poses from
        0.09-0.105 to 0.065-0.07 s, Griffis-Duffy (sigma 1/4) 88 -> 81 s, Dietmeier even
        (31.3 / 31.6 s). Backing off up to 8x took Dietmeier to 36.7 s (6x more boxes)."""
        if self._lp_rate >= LP_RATE:
            return True
        self._lp_wait += 1
        if self._lp_wait < max(LP_PROBE, int(2 * self._lp_cost())) << min(self._lp_misses, 1):
            return False
        self._lp_wait = 0
        return True

    def _krawczyk_worth_it(self, lo, hi) -> bool:
        """Krawczyk on every box while a running share of its tests pays (proves a box empty,
        or unique, or contracts it by a tenth of its log-volume), on every 8th box otherwise,
        and always on boxes below twice sigma, where isolated roots get certified. On a mobile
        platform (Griffis-Duffy, a curve: the Jacobian is singular on it) 94 % of the tests
        did nothing (2026-11-22). Only with LPs on: the choice depends on the search's history,
        and a search with ``lp=False`` repeats box for box, in one process or in many."""
        if self.relax is None or self._k_rate >= K_RATE or np.max(hi - lo) <= 2.0 * self.opt.sigma:
            return True
        self._k_wait += 1
        if self._k_wait < LP_PROBE:
            return False
        self._k_wait = 0
        return True

    def _krawczyk_paid(self, k, lo, hi) -> None:
        paid = k.status in ("empty", "unique") or (
            k.status == "contracted" and self._logvol(lo, hi) - self._logvol(
                np.maximum(k.lo, lo), np.minimum(k.hi, hi)) >= 0.1)
        self._k_rate += 0.1 * (float(paid) - self._k_rate)

    def _lp_cost(self) -> float:
        """What an LP round costs, in boxes processed without LPs (running averages)."""
        if self._t_box is None or self._t_lp is None:
            return 1.0
        return self._t_lp / max(self._t_box, 1e-9)

    def _lp_paid(self, gain: float) -> None:
        """Record an LP round that removed ``gain`` of the box's log-volume (inf: proved it
        empty). It pays if the gain is worth its cost: a round that costs as much as R cheap
        boxes must remove ``LP_GAIN * R`` of log-volume. Costs are measured (running averages
        of seconds), so which boxes get LPs depends on the machine and its load: the boxes
        covering a curve can differ from run to run (``lp=False`` makes a search repeatable
        box for box); what is proven (certified solutions, emptiness, completeness) cannot."""
        paid = gain >= LP_GAIN * self._lp_cost()
        self._lp_rate += 0.1 * (float(paid) - self._lp_rate)
        self._lp_misses = 0 if paid else self._lp_misses + 1

    def _timed(self, attr: str, seconds: float) -> None:
        """Running average of a cost, robust to a rare stall (another process, a page fault):
        a sample counts for at most 4x the average so far."""
        old = getattr(self, attr)
        setattr(self, attr, seconds if old is None else old + 0.05 * (min(seconds, 4.0 * old) - old))

    def _split_variable(self, lo, hi) -> int:
        """The independent variable of largest *smear*: sum_r |dF_r/dx_j| * width_j.

        The smear (|J| at the box centre times the width) measures how much the equations vary along ``x_j``;
        cutting there reduces the linearization error most. Derived (``aux``) variables are
        never cut. Falls back to the widest relative width when the Jacobian is not at hand.
        """
        w = hi - lo
        if self.comp.n_core:
            smear = np.abs(self.cert.J(0.5 * (lo + hi))).sum(axis=0) * w
        else:
            smear = w / self.root_w
        rel = w / self.root_w
        # ignore variables already much narrower than the others: the Jacobian at the centre
        # may vanish along a wide one (then the widest is cut, below)
        smear = np.where(self.split_mask & (rel >= RATIO * rel[self.split_mask].max()), smear, -1.0)
        i = int(np.argmax(smear))
        if smear[i] <= 0:
            i = int(np.argmax(np.where(self.split_mask, w / self.root_w, -1.0)))
        return i

    def _logvol(self, lo, hi):
        return float(np.sum(np.log(np.maximum((hi - lo) / self.root_w, 1e-30))))

    def _certified(self, vlo, vhi, klo, khi) -> BoxOutcome:
        """``[vlo, vhi]`` holds exactly one zero of the core, inside ``[klo, khi]``.

        Every zero of the box being processed lies in ``[vlo, vhi]`` (contractors are
        conservative), so that zero is the box's only candidate.
        """
        comp, cert = self.comp, self.cert
        elo, ehi = cert.tighten(klo, khi)
        if np.any(ehi < self.lo0) or np.any(elo > self.hi0):
            return BoxOutcome("empty")  # the only zero lies outside the search domain
        x = cert.newton(0.5 * (elo + ehi), elo, ehi)
        rlo, rhi = self.prop.eval_rows(elo, ehi)
        ineq_lo, ineq_hi = rlo[comp.n_eq:], rhi[comp.n_eq:]
        if np.any(ineq_lo > 0):
            return BoxOutcome("empty")  # the core's zero violates an inequality
        ok = bool(np.all(ineq_hi < 0)) if len(ineq_hi) else True
        ok = ok and bool(np.all(elo >= self.lo0) and np.all(ehi <= self.hi0))
        res = float(np.max(np.abs(comp.eval_eqs(x)), initial=0.0))
        return BoxOutcome("solution", SolutionBox(vlo, vhi, x, ok, res, (elo, ehi)))

    def _next_to_root(self, lo, hi) -> BoxOutcome | None:
        """Settle a small box lying next to a regular root, where the relaxations are too weak to
        separate the two (near-singular roots leave such clusters of boxes).

        Newton from the box centre finds a root ``x`` within sigma of the box; if Krawczyk proves
        that the hull of the box and ``x`` holds exactly one zero, the box holds that zero or
        none: it is then certified (a duplicate the collector merges) or proven empty.
        """
        cert = self.cert
        if not (cert.square and self.opt.certify):
            return None
        x = cert.newton(0.5 * (lo + hi), iters=25)
        if not np.all(np.isfinite(x)) or np.max(np.abs(cert.F(x)), initial=0.0) > 1e-10:
            return None
        d = self.opt.sigma
        if np.any(x < lo - d) or np.any(x > hi + d):
            return None
        vlo, vhi = np.minimum(lo, x), np.maximum(hi, x)
        pad = 1e-3 * (vhi - vlo) + 1e-12 * (1.0 + np.abs(x))
        vlo, vhi = vlo - pad, vhi + pad
        k = cert.krawczyk(vlo, vhi, x)
        if k.status != "unique":
            return None
        klo, khi = np.maximum(k.lo, vlo), np.minimum(k.hi, vhi)
        if np.any(khi < lo) or np.any(klo > hi):
            return BoxOutcome("empty")  # the hull's only zero lies outside the box
        return self._certified(vlo, vhi, klo, khi)

    def _accepted(self, lo, hi) -> BoxOutcome:
        """A box below sigma that the search stops on. An approximate solution lies in it or
        near it; if that is a regular root just outside, a proof settles the box (empty, or a
        certified duplicate) instead of reporting it: a box accepted next to a near-singular
        assembly mode could hide its twin (Dietmeier, 2026-11-22)."""
        return self._next_to_root(lo, hi) or self._uncertified(lo, hi)

    def _uncertified(self, lo, hi) -> BoxOutcome:
        comp = self.comp
        x0 = 0.5 * (lo + hi)
        x = gauss_newton(comp, x0, lo, hi)  # least squares: robust where J is singular
        r0 = float(np.max(np.abs(comp.eval_eqs(x0)), initial=0.0))
        res = float(np.max(np.abs(comp.eval_eqs(x)), initial=0.0))
        if res > r0:
            x, res = x0, r0
        if res > RESOLVED:
            # clipping can stall on a face next to a near-singular root inside the box (a
            # Dietmeier assembly mode was reported as an unresolved box): the free iteration
            # counts if it ends in the box
            x1 = gauss_newton(comp, x0)
            r1 = float(np.max(np.abs(comp.eval_eqs(x1)), initial=0.0))
            if r1 < res and np.all(x1 >= lo) and np.all(x1 <= hi):
                x, res = x1, r1
        return BoxOutcome("solution", SolutionBox(lo, hi, x, False, res, (lo.copy(), hi.copy())))

    def _accept_small(self, lo, hi) -> bool:
        """Is a box narrower than sigma finished (returned as an uncertified solution box)?

        Not yet if it holds a regular-looking root (Krawczyk will decide it once smaller), nor
        if no approximate solution can be found in it at all (it is probably empty, like the
        "box traces" near singular configurations): such boxes are split down to
        ``sigma * resolve`` first.
        """
        w = np.max(hi - lo)
        if w > self.opt.sigma:
            return False
        if _looks_regular(self.cert, self.comp, lo, hi, max(self.opt.min_width, 1e-3 * self.opt.sigma * self.opt.resolve)):
            return False
        if w > self.opt.sigma * self.opt.resolve:
            # an approximate solution in the box or within sigma of it (unclipped Gauss-Newton:
            # a curve may leave the box where the iteration heads)
            x = gauss_newton(self.comp, 0.5 * (lo + hi), iters=12)
            near = np.all(x >= lo - self.opt.sigma) and np.all(x <= hi + self.opt.sigma)
            if not near or np.max(np.abs(self.comp.eval_eqs(x)), initial=0.0) > RESOLVED:
                return False
            if (self.cert.square and (np.any(x < lo) or np.any(x > hi))
                    and _regular_root(self.cert, x)):
                return False  # an isolated root next to the box, not a curve through it
        return True

    def process(self, lo: np.ndarray, hi: np.ndarray) -> BoxOutcome:
        t0 = time.perf_counter()
        self._lp_seconds = 0.0
        out = self._process(lo, hi)
        self._timed("_t_box", time.perf_counter() - t0 - self._lp_seconds)
        if self.relax is not None:
            out.lps, self.relax.lps = self.relax.lps, 0
        return out

    def _process(self, lo, hi) -> BoxOutcome:
        opt, prop, cert, relax = self.opt, self.prop, self.cert, self.relax
        nk = 0
        for _ in range(opt.lp_rounds):
            r = prop.contract(lo, hi)
            if r is None:
                return BoxOutcome("empty", krawczyk=nk)
            lo, hi, mlo, mhi = r
            if cert.square and opt.certify and self._krawczyk_worth_it(lo, hi):
                nk += 1
                k = cert.krawczyk(lo, hi)
                self._krawczyk_paid(k, lo, hi)
                if k.status == "empty":
                    return BoxOutcome("empty", krawczyk=nk)
                vlo, vhi = lo, hi  # the box in which uniqueness is tested
                if k.status != "unique" and np.max(hi - lo) < 1e-4:
                    k2, vlo, vhi = _inflated(cert, lo, hi)
                    if k2 is not None:
                        k = k2
                if k.status == "unique":
                    o = self._certified(vlo, vhi, k.lo, k.hi)
                    o.krawczyk = nk
                    return o
                if k.status == "contracted":
                    r = prop.contract(k.lo, k.hi)
                    if r is None:
                        return BoxOutcome("empty", krawczyk=nk)
                    lo, hi, mlo, mhi = r
            if self._accept_small(lo, hi):
                o = self._accepted(lo, hi)
                o.krawczyk = nk
                return o
            if relax is None or not self._lp_worth_it():
                break
            v0 = self._logvol(lo, hi)
            t = time.perf_counter()
            s = _shrink(relax, lo, hi, mlo, mhi, self.split_mask, self.root_w)
            t = time.perf_counter() - t
            self._lp_seconds += t
            self._timed("_t_lp", t)
            self._lp_paid(math.inf if s is None else v0 - self._logvol(*s))
            if s is None:
                return BoxOutcome("empty", krawczyk=nk)
            lo, hi = s
            if np.max(hi - lo) <= opt.sigma:
                continue  # back to the top: propagate, certify or accept
            if self._logvol(lo, hi) - v0 > math.log(opt.rho):
                break
        if self._accept_small(lo, hi):
            o = self._accepted(lo, hi)
            o.krawczyk = nk
            return o
        if np.max(hi - lo) <= opt.sigma:
            o = self._next_to_root(lo, hi)
            if o is not None:
                o.krawczyk = nk
                return o
        i = self._split_variable(lo, hi)
        cut = lo[i] + SPLIT_POINT * (hi[i] - lo[i])
        hi1 = hi.copy()
        hi1[i] = cut
        lo2 = lo.copy()
        lo2[i] = cut
        return BoxOutcome("split", children=[(lo2, hi), (lo, hi1)], krawczyk=nk)


class Collector:
    """Gathers outcomes: solution boxes (with de-duplication) and statistics.

    Two certified boxes hold the same solution when one's enclosure lies in the other's
    uniqueness box, or (a root on the face between two sibling boxes, certified in both) when
    Krawczyk proves a single zero in the small hull of both enclosures.
    """

    def __init__(self, certifier: Certifier | None = None):
        self.cert = certifier
        self.boxes: list[SolutionBox] = []
        self.stats = dict(boxes=0, empty=0, split=0, solutions=0, certified=0, lps=0, krawczyk=0,
                          seconds=0.0, cpu_seconds=0.0, max_pending=1)

    def add(self, o: BoxOutcome) -> None:
        st = self.stats
        st["boxes"] += 1
        st["lps"] += o.lps
        st["krawczyk"] += o.krawczyk
        if o.kind == "empty":
            st["empty"] += 1
        elif o.kind == "split":
            st["split"] += 1
        else:
            self.record(o.solution)

    def record(self, sol: SolutionBox) -> None:
        if sol.certified:
            for o in self.boxes:
                if o.certified and self._same(sol, o):
                    return
        self.boxes.append(sol)
        self.stats["solutions"] += 1
        self.stats["certified"] += int(sol.certified)


    def _same(self, a: SolutionBox, b: SolutionBox) -> bool:
        if _inside(a.enclosure, (b.lo, b.hi)) or _inside(b.enclosure, (a.lo, a.hi)):
            return True  # a's root lies in b's uniqueness box: it is b's root
        if self.cert is None:
            return False
        hlo = np.minimum(a.enclosure[0], b.enclosure[0])
        hhi = np.maximum(a.enclosure[1], b.enclosure[1])
        if np.max(hhi - hlo) > 1e-6 * (1.0 + np.max(np.abs(hlo))):
            return False
        c = 0.5 * (hlo + hhi)
        r = np.maximum(hhi - hlo, 1e-12 * (1.0 + np.abs(c)))
        # both roots lie in [c - r, c + r]; a unique zero there makes them one
        return self.cert.krawczyk(c - r, c + r).status == "unique"


def make_options(options: SolverOptions | None = None, **kw) -> SolverOptions:
    """``options`` (default: the defaults) with the keyword arguments set, as a new object."""
    opt = options or SolverOptions()
    fields = {f.name for f in dataclasses.fields(SolverOptions)}
    for k in kw:
        if k not in fields:
            raise TypeError(f"unknown solver option {k!r}")
    return dataclasses.replace(opt, **kw)


def finish(system: System, col: Collector, complete: bool, message: str, pending, t0, c0) -> SolveResult:
    st = col.stats
    st["seconds"] = time.perf_counter() - t0
    st["cpu_seconds"] = time.process_time() - c0
    st.update(system.summary())
    if complete and not col.boxes:
        message = "search complete: no solution (proven)"
    return SolveResult(success=complete, complete=complete, message=message, boxes=col.boxes,
                       pending=[] if complete else list(pending), stats=st, system=system)


def solve_system(system: System, options: SolverOptions | None = None, *, workers: int | None = None,
                 executor=None, **kw) -> SolveResult:
    """Enclose every solution of ``system`` in its domain. Keyword arguments set options.

    ``workers=N`` explores the boxes with N local processes (0: one per core), ``executor=`` a
    ``dask.distributed.Client`` (or scheduler address) on a Dask cluster; see :mod:`kinbox.parallel`.
    """
    opt = make_options(options, **kw)
    if workers is not None or executor is not None:
        from .parallel import solve_parallel

        return solve_parallel(system, opt, workers=workers, executor=executor)
    proc = BoxProcessor(system, opt)
    col = Collector(proc.cert)
    t0, c0 = time.perf_counter(), time.process_time()
    show = opt.progress if opt.progress is not None else sys.stderr.isatty()
    progress = Progress(bool(show), proc.root_w)
    stack: list[tuple[np.ndarray, np.ndarray]] = [(proc.lo0, proc.hi0)]
    message, complete = "search complete", True
    while stack:
        col.stats["max_pending"] = max(col.stats["max_pending"], len(stack))
        if opt.max_boxes is not None and col.stats["boxes"] >= opt.max_boxes:
            complete, message = False, f"box budget of {opt.max_boxes} reached"
            break
        if opt.time_limit is not None and time.perf_counter() - t0 > opt.time_limit:
            complete, message = False, f"time limit of {opt.time_limit} s reached"
            break
        lo, hi = stack.pop()
        o = proc.process(lo, hi)
        col.add(o)
        stack.extend(o.children)
        progress.report(col.stats, stack)
    progress.report(col.stats, stack, force=True)
    return finish(system, col, complete, message, stack, t0, c0)


def _inflated(cert: Certifier, lo, hi):
    """Krawczyk on a slightly inflated copy of a tiny box (epsilon-inflation).

    The inflated box contains the tiny one, so its unique zero is the only candidate of the box
    being processed. Returns ``(result, vlo, vhi)`` with the box where uniqueness was proven.
    """
    c = 0.5 * (lo + hi)
    r = np.maximum(2.0 * (hi - lo), 1e-10 * (1.0 + np.abs(c)))
    vlo, vhi = c - r, c + r
    k = cert.krawczyk(vlo, vhi)
    return (k, vlo, vhi) if k.status == "unique" else (None, lo, hi)


def _looks_regular(cert: Certifier, comp, lo, hi, min_width: float) -> bool:
    """True if Newton from the box centre converges to a well-conditioned root in the box or
    within the box's width of it (a root next to the box: the box is then split until it is
    settled by :meth:`BoxProcessor._next_to_root`, or pruned).

    Newton may run off to a regular root outside the box while the box holds one of its own (a
    near-double root's twin): then Newton kept inside the box is tried too.
    """
    if not cert.square or np.max(hi - lo) <= min_width:
        return False
    w = np.max(hi - lo)
    x = cert.newton(0.5 * (lo + hi), iters=25)  # near-double roots converge slowly
    if _regular_root(cert, x) and not (np.any(x < lo - w) or np.any(x > hi + w)):
        return True
    x = cert.newton(0.5 * (lo + hi), lo, hi, iters=25)
    return _regular_root(cert, x)


def _regular_root(cert: Certifier, x) -> bool:
    if not np.all(np.isfinite(x)) or np.max(np.abs(cert.F(x)), initial=0.0) > 1e-10:
        return False
    return bool(np.linalg.cond(cert.J(x)) < 1e10)


def _inside(inner, outer) -> bool:
    return bool(np.all(inner[0] >= outer[0]) and np.all(inner[1] <= outer[1]))


def _shrink(relax: Relaxation, lo, hi, mlo, mhi, mask=None, root_w=None, pay: float = LP_VAR_PAYS):
    """SHRINK-BOX (Algorithm 2), spending LPs only where they pay.

    One LP model is built for the box; the independent variables (``mask``) are bounded by
    min/max LPs widest first. The first LP also tests the relaxation for feasibility. After
    each pair, if the variable shrank by less than ``pay`` of its width, the remaining
    variables are skipped: on this box LPs cost more than splitting. With the default
    (:data:`LP_VAR_PAYS` = 1) a round bounds only the widest variable, unless its LPs pin it
    to a point; the caller runs another round while rounds pay. Returns the new box or
    ``None`` if proven empty.
    """
    relax.build(lo, hi, mlo, mhi)
    lo, hi = lo.copy(), hi.copy()
    n = len(lo)
    mask = np.ones(n, dtype=bool) if mask is None else mask
    rel = (hi - lo) / (root_w if root_w is not None else 1.0)
    order = [int(i) for i in np.argsort(-rel) if mask[i] and hi[i] > lo[i]]
    for i in order:
        w = hi[i] - lo[i]
        b, infeasible = relax.bound(i, +1)
        if infeasible:
            return None
        if b is not None and b > lo[i]:
            lo[i] = b
        b, infeasible = relax.bound(i, -1)
        if infeasible:
            return None
        if b is not None and b < hi[i]:
            hi[i] = b
        if lo[i] > hi[i]:
            return None
        relax.set_bounds(i, lo[i], hi[i])
        if hi[i] - lo[i] > (1.0 - pay) * w:
            break
    return lo, hi
