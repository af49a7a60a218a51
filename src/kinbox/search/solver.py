"""Branch-and-prune over boxes (Porta, Ros and Thomas 2009, Algorithm 1), in the shape of Ibex's generic solver: a
contractor sequence, a bisector and a buffer of boxes.

The pieces, each in a module of its own:

* :mod:`~kinbox.search.options`: the options, which of them shape the tree, their choices;
* :mod:`~kinbox.search.contract` and the ``ctc_*`` modules: the contractors (propagation,
  Krawczyk, the transverse test, the linear and Bernstein relaxations), one interface;
* :mod:`~kinbox.search.steps`: the per-box sequence as data, each step behind a gate of
  :mod:`~kinbox.search.policy`;
* :mod:`~kinbox.search.processor`: one box through the sequence, then
  :mod:`~kinbox.search.accept` (acceptance), :mod:`~kinbox.search.curvebox` (curve boxes) or
  :mod:`~kinbox.search.bisector` (bisection);
* :mod:`~kinbox.search.waves`: the wave loop the serial search (here) and the parallel one
  (:mod:`~kinbox.search.parallel`) share; :mod:`~kinbox.search.collector` gathers the outcomes;
* :mod:`~kinbox.search.results` and :mod:`~kinbox.search.status`: what a search returns, and
  why it stopped.

Every pruning step is conservative (outward rounding, safe LP bounds), so the union of the
returned boxes holds every solution of the system inside the initial domain. When a budget
(``max_boxes``, ``time_limit``, ``max_memory``), a stop request or lost workers stop the search,
the result says so (``status``, ``complete=False``) and keeps the unexplored boxes in
``pending``.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any, cast

from ..formulation.system import System
from .accept import RESOLVED, Acceptance, looks_regular, regular_root
from .bisector import AUX_SPLIT_BELOW, AUX_WIDER, RANK_DONE, RATIO, SPLIT_POINT, Bisector
from .certify import Certifier
from .collector import Collector
from .ctc_krawczyk import K_REPEATS
from .curvebox import CURVE_CLOSE, CURVE_END, CURVE_ITERS, CURVE_RANK, CURVE_SAMPLES, CURVE_SLACK, CURVE_STALL, CurveBoxRule
from .loading import load_clock, search_kernel_modules
from .options import RELAXATIONS, SolverOptions, check_options, make_options
from .outcome import Stats
from .processor import BoxProcessor, check_floating_point, lp_contractor, lp_kind
from .progress import Progress, show_progress
from .results import BoxOutcome, SolutionBox, SolveResult
from .state import SearchState
from .status import Status
from .threads import single_threaded
from .waves import SerialRunner, WaveLoop, budget_hit, finish, held_bytes, start_state

__all__ = [
    "AUX_SPLIT_BELOW",
    "AUX_WIDER",
    "CURVE_CLOSE",
    "CURVE_END",
    "CURVE_ITERS",
    "CURVE_RANK",
    "CURVE_SAMPLES",
    "CURVE_SLACK",
    "CURVE_STALL",
    "K_REPEATS",
    "RANK_DONE",
    "RATIO",
    "RELAXATIONS",
    "RESOLVED",
    "SPLIT_POINT",
    "Acceptance",
    "Bisector",
    "BoxOutcome",
    "BoxProcessor",
    "Collector",
    "CurveBoxRule",
    "Progress",
    "SolutionBox",
    "SolveResult",
    "SolverOptions",
    "Status",
    "budget_hit",
    "check_floating_point",
    "check_options",
    "held_bytes",
    "load_kernels",
    "looks_regular",
    "lp_contractor",
    "lp_kind",
    "make_options",
    "regular_root",
    "search_again",
    "solve_system",
]

_KERNELS_LOADED = False


def load_kernels() -> None:
    """Load (the first time after an install: compile and cache) every compiled kernel of the
    search; after the first call in a process, nothing."""
    global _KERNELS_LOADED
    if not _KERNELS_LOADED:
        for mod in search_kernel_modules():
            mod.load_kernel()
        _KERNELS_LOADED = True


@single_threaded
def solve_system(
    system: System, options: SolverOptions | None = None, *, resume: SearchState | None = None, within: list | None = None, **kw
) -> SolveResult:
    """Enclose every solution of ``system`` in its domain, in this process. Keyword arguments
    set options. (:func:`kinbox.solve_system` also spreads the search over workers.)

    The search runs in waves: the boxes of one wave (the children of the previous one, in
    order) are processed under one :class:`~kinbox.search.policy.Policy`, and the next wave's
    policy is made from the wave's counts, so the tree does not depend on the order in which a
    wave's boxes are processed (:mod:`kinbox.search.parallel` processes them in parallel).

    A search stopped by a budget or by :func:`kinbox.search.interrupt.request` returns its
    :class:`~kinbox.search.state.SearchState` in ``state``; ``resume=state`` goes on from there
    and ends as the search would have ended had it not stopped. ``within``: boxes ``(lo, hi)``
    of the search domain to search instead of the whole domain (:func:`search_again`).
    """
    opt = make_options(options, **kw)
    c0 = time.process_time()
    t0 = time.perf_counter()
    clock = opt.started if opt.started is not None else t0
    # loading the compiled kernels (at their first call in this process) is reported apart
    with load_clock() as loads:
        proc = BoxProcessor(system, opt)
        if opt.time_limit is not None:
            proc.set_deadline(clock + opt.time_limit)
        col = Collector(proc.cert)
        state = start_state(system, opt, col, resume, within)
        before = dict(col.stats) if resume is not None else {}
        loop = WaveLoop(system, opt, col, state, Progress(show_progress(opt.progress), proc.root_w), clock)
        state = loop.run(SerialRunner(proc))
    return finish(system, col, loop.status, loop.message, state, t0, c0, before, loads.seconds)


def search_again(system: System, raw: SolveResult, redo: list[int], options: SolverOptions) -> SolveResult:
    """``raw`` (a complete search) with its solution boxes ``redo`` searched again without curve
    boxes: the answer stage found no curve through those curve boxes (their points are isolated
    or singular roots, or lie on nothing), so what they hold is resolved like any other box,
    down to certified roots and boxes below sigma. The union of the boxes returned still
    encloses every solution: the boxes searched again are replaced by what their search
    returns. Certified boxes found twice (a root on a face of a curve box) are merged as in a
    search. The budgets are those of ``options`` (the time limit counts from the same start);
    a search again that stops leaves the answer incomplete, with no state to resume."""
    opt = dataclasses.replace(options, curve_boxes=False)
    sub = solve_system(system, opt, within=[(raw.boxes[i].lo, raw.boxes[i].hi) for i in redo])
    col = Collector(Certifier(system.compile()))
    gone = set(redo)
    for i, b in enumerate(raw.boxes):
        if i not in gone:
            col.record(b)
    for b in sub.boxes:
        col.record(b)
    st: dict[str, Any] = dict(raw.stats)
    added: dict[str, Any] = dict(sub.stats)
    for k in ("boxes", "empty", "split", "lps", "krawczyk", "seconds", "cpu_seconds", "load_seconds"):
        st[k] = st.get(k, 0) + added[k]
    st["solutions"], st["certified"] = col.stats["solutions"], col.stats["certified"]
    st["curve_boxes_searched_again"] = st.get("curve_boxes_searched_again", 0) + len(redo)
    status = raw.status if not raw.complete else sub.status
    message = raw.message if sub.complete else f"{sub.message} (searching curve boxes again)"
    return SolveResult(status, message, col.boxes, list(raw.pending) + list(sub.pending), cast(Stats, st), system, raw.state)
