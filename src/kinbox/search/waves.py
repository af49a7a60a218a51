"""The wave loop, written once: the serial search and the parallel one (local processes, Dask)
run it with a runner of their own (in the manner of Ibex's ``Solver``: contractor, bisector, and
a cell buffer, here the wave).

The search runs in waves: the boxes of one wave (the children of the previous one, in order)
are processed under one :class:`~kinbox.search.policy.Policy`, and the next wave's policy is made
from the wave's counts, so the tree does not depend on the order in which a wave's boxes are
processed, nor on which process processed them. A runner processes the boxes of a wave from
``loop.k`` on and hands their outcomes to :meth:`WaveLoop.take` **in the wave's order**; it
checks the budgets (:meth:`WaveLoop.budget`) as it goes and stops the loop
(:meth:`WaveLoop.stop`) when one is spent.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Protocol, cast

from ..formulation.system import System
from . import interrupt
from .collector import Collector
from .options import SolverOptions, tree_options
from .outcome import Stats
from .policy import POLICIES, Events, Hint, Policy
from .progress import Progress
from .results import BoxOutcome, SolveResult
from .state import SearchState, fingerprint
from .status import Status

#: estimated bytes of a box held by the search: per variable (two float64 bounds) and fixed
#: (two NumPy arrays, a tuple and a Hint); a solution box holds five arrays
BOX_BYTES_PER_VAR, BOX_BYTES = 16, 400
SOLUTION_BYTES_PER_VAR, SOLUTION_BYTES = 40, 800


def held_bytes(n: int, pending: int, solutions: int) -> float:
    """Estimated memory of ``pending`` boxes and ``solutions`` solution boxes of ``n`` variables."""
    return pending * (BOX_BYTES_PER_VAR * n + BOX_BYTES) + solutions * (SOLUTION_BYTES_PER_VAR * n + SOLUTION_BYTES)


def time_limit_message(opt: SolverOptions) -> str:
    return f"time limit of {opt.time_limit:g} s reached"


def budget_hit(opt: SolverOptions, boxes: int, clock: float, held: float = 0.0) -> tuple[Status, str] | None:
    """Why the search must stop now, or None: a stop request (:mod:`kinbox.search.interrupt`) or a
    budget spent (``boxes`` processed in this run, time since ``clock``, ``held`` bytes)."""
    why = interrupt.requested()
    if why is not None:
        return Status.INTERRUPTED, why
    if opt.max_boxes is not None and boxes >= opt.max_boxes:
        return Status.BOX_BUDGET, f"box budget of {opt.max_boxes} reached"
    if opt.time_limit is not None and time.perf_counter() - clock > opt.time_limit:
        return Status.TIME_LIMIT, time_limit_message(opt)
    if opt.max_memory is not None and held > opt.max_memory:
        return Status.MEMORY_BUDGET, f"memory budget of {opt.max_memory / 1e9:g} GB for boxes reached"
    return None


class Runner(Protocol):
    def run_wave(self, loop: WaveLoop) -> None:
        """Process ``loop.wave[loop.k:]``, handing each outcome to ``loop.take`` in order, until
        the wave is done or the loop is stopped (:meth:`WaveLoop.stop`)."""


class WaveLoop:
    """A search's state between boxes and the loop over its waves (see the module docstring)."""

    def __init__(self, system: System, opt: SolverOptions, col: Collector, state: SearchState, progress: Progress, clock: float):
        self.system, self.opt, self.col, self.progress, self.clock = system, opt, col, progress, clock
        self.state = state
        self.boxes0 = col.stats["boxes"]
        self.wave: list = state.rest
        self.k = 0
        self.nxt: list = state.nxt
        self.ev: Events = state.events
        self.policy: Policy = state.policy
        self.status, self.message = Status.COMPLETE, "search complete"
        self.stopped = False

    def take(self, o: BoxOutcome) -> bool:
        """The outcome of ``wave[k]``; False (nothing taken) if the box is unfinished: a
        deadline passed inside it, and it stays pending."""
        if o.kind == "unfinished":
            return False
        self.col.add(o)
        self.ev.add(o.events)
        self.nxt.extend(o.children)
        self.k += 1
        return True

    def stop(self, status: Status, message: str) -> None:
        self.status, self.message, self.stopped = status, message, True

    def boxes_run(self) -> int:
        """Boxes processed in this run (not counting a resumed search's)."""
        return self.col.stats["boxes"] - self.boxes0

    def budget(self, done: int = 0, held: float | None = None) -> tuple[Status, str] | None:
        """:func:`budget_hit` with ``done`` boxes processed beyond those taken, and ``held``
        bytes (default: the boxes left in the wave, the next wave so far, the solutions)."""
        if held is None:
            held = held_bytes(self.system.n, len(self.wave) - self.k + len(self.nxt), len(self.col.boxes))
        return budget_hit(self.opt, self.boxes_run() + done, self.clock, held)

    def report(self, stats: dict | None = None, force: bool = False) -> None:
        self.progress.report(self.col.stats if stats is None else stats, self.wave, self.k, self.nxt, force=force)

    def _next_wave(self) -> bool:
        """The wave is done: the next one, under a policy made from its counts (False: none)."""
        st = self.col.stats
        st["waves"] = st.get("waves", 0) + 1
        self.policy = self.policy.next(self.ev)
        self.wave, self.k, self.nxt, self.ev = self.nxt, 0, [], Events()
        if not self.wave:
            return False
        st["max_pending"] = max(st["max_pending"], len(self.wave))
        return True

    def run(self, runner: Runner) -> SearchState:
        """Run the waves with ``runner`` until none is left or the loop is stopped; returns what
        is left (:func:`pending_state`)."""
        with interrupt.searching():
            while not self.stopped:
                if self.k == len(self.wave) and not self._next_wave():
                    break
                runner.run_wave(self)
        self.report(force=True)
        return pending_state(self.system, self.state, self.wave[self.k :], self.nxt, self.policy, self.ev, self.col)


class SerialRunner:
    """Processes the boxes one after the other in this process, the budgets checked before each."""

    def __init__(self, proc):
        self.proc = proc

    def run_wave(self, loop: WaveLoop) -> None:
        while loop.k < len(loop.wave):
            stop = loop.budget()
            if stop:
                loop.stop(*stop)
                return
            lo, hi, hint = loop.wave[loop.k]
            if not loop.take(self.proc.process(lo, hi, hint, loop.policy)):
                loop.stop(Status.TIME_LIMIT, time_limit_message(loop.opt))
                return
            loop.report()


def pending_state(system: System, state: SearchState, rest: list, nxt: list, policy: Policy, ev: Events, col: Collector) -> SearchState:
    """What is left of a search that stops (or pauses): the boxes not processed yet, the policy
    and its counters, the solutions so far, for :func:`finish` and ``--save``."""
    return SearchState(
        rest=rest,
        nxt=nxt,
        policy=policy,
        events=ev,
        boxes=col.boxes,
        stats={},
        fingerprint=state.fingerprint or fingerprint(system),
        options=state.options,
        names=state.names,
    )


def start_state(system: System, opt: SolverOptions, col: Collector, resume: SearchState | None, within: list | None = None) -> SearchState:
    """The state a search starts from: the root box (or the boxes ``within``), or ``resume``
    (checked against the system and the options, its solutions and counts put in ``col``)."""
    fp = fingerprint(system) if resume is not None else ""
    if resume is None:
        lo0, hi0 = system.search_domain()
        return SearchState(
            rest=[(lo0, hi0, Hint())] if within is None else [(lo, hi, Hint()) for lo, hi in within],
            nxt=[],
            policy=POLICIES[opt.policy],
            events=Events(),
            boxes=[],
            stats={},
            fingerprint=fp,
            options=tree_options(opt),
            names=list(system.names),
        )
    resume.check(system, opt)
    col.boxes = list(resume.boxes)
    for k, v in resume.stats.items():
        if k in col.stats or k == "waves":
            col.stats[k] = v
    return SearchState(
        rest=list(resume.rest),
        nxt=list(resume.nxt),
        policy=resume.policy,
        events=dataclasses.replace(resume.events, tests=dict(resume.events.tests), paid=dict(resume.events.paid)),
        boxes=[],
        stats={},
        fingerprint=fp,
        options=tree_options(opt),
        names=list(system.names),
    )


def finish(
    system: System,
    col: Collector,
    status: Status,
    message: str,
    state: SearchState | None,
    t0,
    c0,
    before: dict | None = None,
    load_seconds: float = 0.0,
) -> SolveResult:
    """The result of a search that ran from ``t0`` (``perf_counter``) / ``c0`` (``process_time``);
    ``before``: the stats of the run it resumed (its times are added). ``load_seconds``: the part
    of the search's seconds spent loading compiled kernels (:mod:`kinbox.search.loading`)."""
    st = col.stats
    before = before or {}
    st["seconds"] = time.perf_counter() - t0 + float(before.get("seconds", 0.0))
    st["load_seconds"] = load_seconds + float(before.get("load_seconds", 0.0))
    st["cpu_seconds"] = time.process_time() - c0 + float(before.get("cpu_seconds", 0.0))
    st.update(system.summary())
    complete = status is Status.COMPLETE
    if complete and not col.boxes:
        message = "search complete: no solution (proven)"
    if state is not None:
        state.stats = dict(st)
    return SolveResult(
        status=status,
        message=message,
        boxes=col.boxes,
        pending=[] if complete or state is None else state.pending,
        stats=cast(Stats, st),
        system=system,
        state=None if complete else state,
    )
