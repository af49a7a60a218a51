"""Parallel branch-and-prune: local worker processes or a Dask cluster.

The boxes of branch-and-prune are independent, so the search spreads over processes the
simple way (master/worker with work sharing):

* the **master** (the calling process) keeps the box stack and the :class:`~kinbox.solver.Collector`,
  and enforces the budgets (``time_limit``, ``max_boxes``);
* a **worker** holds a :class:`~kinbox.solver.BoxProcessor`, built once per process from the
  pickled :class:`~kinbox.system.System`, and runs :func:`explore`: it takes a few boxes and
  explores them depth-first, exactly as the serial loop does, for a short time slice
  (``slice_seconds``, a few tens of ms) or ``cap`` boxes, then returns the outcomes of the boxes
  it processed plus the boxes it did not get to. Those go back on the master's stack, so a
  worker that runs dry gets work again within one slice: no worker idles while boxes remain.

Every box is processed by the same :meth:`BoxProcessor.process` as in the serial search. Each
box carries its path in the tree; the master records the solutions in the order the serial loop
would have found them, so the de-duplication of certified boxes (the first found is kept) and
the order of ``result.boxes`` follow the serial search. Where processing a box does not depend
on the boxes processed before it (``lp=False``), the tree is the serial tree and the answer is
the serial one box for box. With LPs the processor adapts between boxes (a warm LP basis, a
running measure of whether LP rounds pay), so each process prunes a little differently from one
serial pass: the answer has the same certified solutions and the same completeness, while the
covering of positive-dimensional sets and the box counts may differ slightly — as they would for
a serial search visiting the boxes in another order.

**Faults.** The master's state changes only when a batch's result arrives (:func:`explore`
only returns), so a batch whose worker died is simply run again: its boxes go back on the stack. A local pool that breaks (a worker
killed, out of memory) is replaced by a fresh one; on Dask the scheduler reschedules tasks of a
lost worker itself, and a task that fails with a lost worker (``KilledWorker``, a cancelled
future, a closed connection) is re-submitted by the master. After ``max_restarts`` such failures
the search stops and returns what it found, marked incomplete, with the unexplored boxes in
``pending`` — as a time budget does.

Backends: ``workers=N`` uses ``concurrent.futures.ProcessPoolExecutor`` with N processes;
``executor=`` a ``dask.distributed.Client`` (or a scheduler address) runs the same
:func:`explore` tasks on a Dask cluster (``pip install kinbox[dask]``; kinbox must be
installed on every worker). See ``docs/scaling.md``.
"""

from __future__ import annotations

import concurrent.futures as cf
import multiprocessing as mp
import os
import pickle
import sys
import threading
import time
import uuid
from collections import OrderedDict
from typing import Callable

import numpy as np

from ..errors import InputError
from .solver import BoxProcessor, Collector, SolveResult, SolverOptions, Progress, finish
from ..formulation.system import System

#: seconds a worker explores before it hands its leftover boxes back to the master: local
#: processes answer in ~0.1 ms, a Dask task costs a few ms of scheduling (more across machines)
SLICE_SECONDS = 0.05
DASK_SLICE_SECONDS = 0.2
#: most boxes a worker processes in one batch
BATCH_CAP = 5000
#: most boxes the master sends in one batch (the worker expands them depth-first)
SEND_MAX = 8
#: batches kept in flight per worker slot: one running, one ready, so no slot waits on the master
IN_FLIGHT_PER_SLOT = 2
#: worker losses (broken pool, lost Dask worker) tolerated before the search gives up
MAX_RESTARTS = 20


# ---------------------------------------------------------------------------- worker side
# A BoxProcessor has scratch state (its LP), so each thread has its own: a Dask worker with
# several threads runs several batches at once. A long-lived Dask worker serves several searches
# one after the other: keep the processors of the last few.
_LOCAL = threading.local()
_PROCESSORS_KEEP = 2


def _processor(key: str, payload) -> BoxProcessor:
    cache = getattr(_LOCAL, "processors", None)
    if cache is None:
        cache = _LOCAL.processors = OrderedDict()
    p = cache.get(key)
    if p is None:
        if payload is None:
            raise RuntimeError(f"kinbox worker {os.getpid()} has no system for search {key}")
        system, options = pickle.loads(payload) if isinstance(payload, bytes) else payload
        p = cache[key] = BoxProcessor(system, options)
        while len(cache) > _PROCESSORS_KEEP:
            cache.popitem(last=False)
    else:
        cache.move_to_end(key)
    return p


def _init_worker(key: str, payload) -> None:
    """Pool initializer: build the worker's BoxProcessor once, before any batch arrives."""
    _processor(key, payload)
    # a forked worker inherits both ends of the pool's pipes, so it would wait forever if the
    # master were killed: leave when the parent goes
    ppid = os.getppid()

    def watch():
        while True:
            time.sleep(1.0)
            if os.getppid() != ppid:
                os._exit(1)

    threading.Thread(target=watch, name="kinbox-parent-watch", daemon=True).start()


def explore(key: str, payload, boxes, slice_seconds: float, cap: int):
    """Explore ``boxes`` depth-first for ``slice_seconds`` or ``cap`` boxes (at least one).

    A box is ``(lo, hi, path)``, ``path`` its place in the tree (bytes, one per split, ordered
    as the serial loop visits the boxes). Returns ``(outcomes, leftover, cpu_seconds, pid)``:
    ``(outcome, path)`` for every box processed, in processing order (children removed: the
    unexplored ones are in ``leftover``; ``path`` only for solutions, else None). Nothing but
    the worker's own BoxProcessor changes, so a batch can be run again (after a worker loss)
    by any worker.
    """
    proc = _processor(key, payload)
    t0, c0 = time.perf_counter(), time.process_time()
    stack = list(boxes)  # the last box first, as in the serial loop
    outs = []
    while stack and len(outs) < cap:
        lo, hi, path = stack.pop()
        o = proc.process(lo, hi)
        kids, o.children = o.children, []
        m = len(kids)
        # the serial loop pushes the children in order and pops the last first
        stack.extend((clo, chi, path + bytes((m - 1 - j,))) for j, (clo, chi) in enumerate(kids))
        outs.append((o, path if o.kind == "solution" else None))
        if time.perf_counter() - t0 >= slice_seconds:
            break
    return outs, stack, time.process_time() - c0, os.getpid()


# ---------------------------------------------------------------------------- backends
class WorkerLost(Exception):
    """A batch did not come back because its worker (or the whole pool) was lost."""


class _LocalBackend:
    """N local processes (``ProcessPoolExecutor``); a broken pool is replaced."""

    name = "processes"

    def __init__(self, workers: int, key: str, payload: bytes, start_method: str | None):
        self.n = workers
        self.key, self.payload = key, payload
        self.ctx = mp.get_context(start_method or _default_start_method())
        self.pool = None
        self._start()

    def _start(self):
        self.pool = cf.ProcessPoolExecutor(self.n, mp_context=self.ctx, initializer=_init_worker,
                                           initargs=(self.key, self.payload))

    def slots(self) -> int:
        return self.n

    def submit(self, boxes, slice_seconds, cap):
        # the payload travels once per process (initializer), not with every batch
        try:
            return self.pool.submit(explore, self.key, None, boxes, slice_seconds, cap)
        except cf.process.BrokenProcessPool as e:  # broke since the last wait: a lost batch
            fut = cf.Future()
            fut.set_exception(e)
            return fut

    def wait(self, futures, timeout):
        done, _ = cf.wait(list(futures), timeout=timeout, return_when=cf.FIRST_COMPLETED)
        return done

    def result(self, fut):
        try:
            return fut.result()
        except (cf.process.BrokenProcessPool, cf.CancelledError) as e:
            raise WorkerLost(str(e) or type(e).__name__) from e

    def restart(self):
        old, self.pool = self.pool, None
        old.shutdown(wait=False, cancel_futures=True)
        self._start()

    def close(self):
        if self.pool is not None:
            self.pool.shutdown(wait=True, cancel_futures=True)
            self.pool = None

    def abandon(self, futures=()):
        """Stop now: queued batches are cancelled, running ones end within their slice."""
        if self.pool is not None:
            self.pool.shutdown(wait=False, cancel_futures=True)
            self.pool = None


class _DaskBackend:
    """The same :func:`explore` tasks on a Dask cluster; the system is scattered once."""

    name = "dask"

    def __init__(self, executor, key: str, payload: bytes):
        try:
            import distributed
        except ImportError:  # pragma: no cover - checked by _dask_client first
            raise InputError("a Dask executor needs dask.distributed: pip install 'kinbox[dask]'") from None
        self.dd = distributed
        self.client, self.own_client = _dask_client(executor)
        self.key, self.payload = key, payload
        self._slots, self._slots_t = 1, -1e9
        self._event = threading.Event()
        self.data = None
        self._scatter()

    def _scatter(self):
        # every worker gets a replica, so losing one worker does not lose the system
        self.data = self.client.scatter(self.payload, broadcast=True, hash=False)

    def slots(self) -> int:
        now = time.perf_counter()
        if now - self._slots_t > 1.0:  # the cluster may grow or shrink while we run
            try:
                self._slots = max(1, sum(self.client.nthreads().values()))
            except Exception:  # a scheduler hiccup: keep the last count
                pass
            self._slots_t = now
        return self._slots

    def submit(self, boxes, slice_seconds, cap):
        fut = self.client.submit(explore, self.key, self.data, boxes, slice_seconds, cap, pure=False)
        fut.add_done_callback(lambda _f: self._event.set())
        return fut

    def wait(self, futures, timeout):
        # distributed.wait raises on cancelled futures and uses the default client: poll instead,
        # woken by the futures' done callbacks
        self._event.clear()
        done = {f for f in futures if f.done()}
        if not done:
            self._event.wait(max(timeout, 0.0))
            done = {f for f in futures if f.done()}
        return done

    def result(self, fut):
        try:
            return fut.result(timeout=60)  # done: only the transfer is left
        except Exception as e:
            if _is_worker_loss(e):
                raise WorkerLost(f"{type(e).__name__}: {e}") from e
            raise  # an error in kinbox itself: as in the serial search

    def restart(self):
        # Dask replaces workers itself; the scattered system may have been lost with them
        try:
            if self.data is None or self.data.status != "finished":
                self._scatter()
        except Exception:
            self._scatter()

    def close(self):
        try:
            if self.data is not None:
                self.data.release()
        finally:
            if self.own_client:
                self.client.close()

    def abandon(self, futures=()):
        """Stop now: batches in flight are cancelled (a running one ends within its slice)."""
        try:
            if futures:
                self.client.cancel(list(futures))
        except Exception:  # the connection may be what failed
            pass
        self.close()


def _is_worker_loss(exc) -> bool:
    if exc is None:
        return False
    names = {c.__name__ for c in type(exc).__mro__}
    return bool(names & {"KilledWorker", "CancelledError", "FutureCancelledError", "CommClosedError",
                         "FutureLostError", "ConnectionError", "StreamClosedError", "TimeoutError"})


def _dask_client(executor):
    """``(client, owned)``: a Client as given, or one connected to a scheduler address."""
    if isinstance(executor, str):
        try:
            from distributed import Client
        except ImportError:
            raise InputError("--dask needs dask.distributed, an optional extra: "
                             "pip install 'kinbox[dask]'") from None
        try:
            return Client(executor, timeout="30s"), True
        except (OSError, TimeoutError) as e:
            raise InputError(f"cannot reach the Dask scheduler at {executor!r}: {e}") from None
    if not (hasattr(executor, "submit") and hasattr(executor, "scatter") and hasattr(executor, "nthreads")):
        raise InputError(f"executor must be a dask.distributed.Client or a scheduler address, "
                         f"got {type(executor).__name__}")
    return executor, False


def _default_start_method() -> str:
    methods = mp.get_all_start_methods()
    # fork starts a worker in milliseconds but is unsafe once the master runs threads (a Dask
    # client, a GUI); forkserver/spawn re-import kinbox in each worker (~1 s, once per search)
    if "fork" in methods and sys.platform.startswith("linux") and threading.active_count() == 1:
        return "fork"
    return "forkserver" if "forkserver" in methods else "spawn"


def _cpu_count() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


# ---------------------------------------------------------------------------- master
def solve_parallel(system: System, options: SolverOptions, workers: int | None = None, executor=None,
                   *, start_method: str | None = None, slice_seconds: float | None = None,
                   max_restarts: int = MAX_RESTARTS,
                   callback: Callable[[dict], None] | None = None) -> SolveResult:
    """:func:`~kinbox.solver.solve_system` with the boxes explored by several processes.

    ``workers``: number of local processes (0: one per available core). ``executor``: a
    ``dask.distributed.Client`` or a scheduler address such as ``"tcp://host:8786"``.
    ``start_method``: multiprocessing start method for local workers (default: fork when the
    master has no other thread, else forkserver). ``callback(stats)`` is called by the master
    after each batch it collects (progress, tests). ``slice_seconds``: how long a worker explores
    before handing its leftover boxes back (default 0.05 s locally, 0.2 s on Dask).
    """
    if (workers is None) == (executor is None):
        raise InputError("give either workers=N or executor=<dask Client or address>, not both")
    if workers is not None:
        if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 0:
            raise InputError(f"workers must be a non-negative integer, got {workers!r}")
        workers = int(workers) or _cpu_count()
    opt = options
    if slice_seconds is None:
        slice_seconds = SLICE_SECONDS if workers is not None else DASK_SLICE_SECONDS
    t0, c0 = time.perf_counter(), time.process_time()
    lo0, hi0 = system.search_domain()
    try:
        payload = pickle.dumps((system, opt), protocol=pickle.HIGHEST_PROTOCOL)
    except Exception as e:
        raise InputError(f"the system cannot be sent to worker processes (pickling failed: {e})") from e
    key = uuid.uuid4().hex
    backend = (_LocalBackend(workers, key, payload, start_method) if workers is not None
               else _DaskBackend(executor, key, payload))
    col = Collector()
    st = col.stats
    show = opt.progress if opt.progress is not None else sys.stderr.isatty()
    progress = Progress(bool(show), np.maximum(hi0 - lo0, 1e-300))
    stack: list[tuple[np.ndarray, np.ndarray, bytes]] = [(lo0, hi0, b"")]
    sols: list[tuple[bytes, object]] = []  # (path, SolutionBox): recorded in serial order at the end
    inflight: dict = {}  # future -> (boxes, cap)
    reserved = 0  # boxes of max_boxes promised to batches in flight
    worker_cpu, batches, restarts, pids = 0.0, 0, 0, set()
    complete, message = True, "search complete"
    stopping = None  # None, or the deadline (perf_counter) until which in-flight batches are awaited
    try:
        while True:
            now = time.perf_counter()
            if stopping is None:
                if opt.time_limit is not None and now - t0 > opt.time_limit:
                    complete, message = False, f"time limit of {opt.time_limit} s reached"
                elif opt.max_boxes is not None and st["boxes"] >= opt.max_boxes and stack:
                    complete, message = False, f"box budget of {opt.max_boxes} reached"
                elif restarts > max_restarts:
                    complete, message = False, (f"workers were lost {restarts} times; stopped with "
                                                "the search unfinished")
                if not complete:
                    stopping = now + 2.0 * slice_seconds + 1.0
            # hand boxes to free slots
            if stopping is None:
                slots = backend.slots() * IN_FLIGHT_PER_SLOT
                while stack and len(inflight) < slots:
                    cap = BATCH_CAP
                    if opt.max_boxes is not None:
                        cap = min(cap, opt.max_boxes - st["boxes"] - reserved)
                        if cap <= 0:
                            break
                    sl = slice_seconds
                    if opt.time_limit is not None:
                        sl = min(sl, max(opt.time_limit - (now - t0), 1e-3))
                    free = max(1, slots - len(inflight))
                    k = max(1, min(SEND_MAX, len(stack) // free))
                    boxes = stack[-k:]
                    del stack[-k:]
                    inflight[backend.submit(boxes, sl, cap)] = (boxes, cap)
                    reserved += cap if opt.max_boxes is not None else 0
            if not inflight:
                break
            n_pending = len(stack) + sum(len(b) for b, _ in inflight.values())
            st["max_pending"] = max(st["max_pending"], n_pending)
            timeout = 0.5
            if stopping is not None:
                timeout = stopping - time.perf_counter()
                if timeout <= 0:
                    break
            elif opt.time_limit is not None:
                timeout = min(timeout, max(opt.time_limit - (time.perf_counter() - t0), 0.0) + 1e-3)
            lost = False
            for fut in backend.wait(inflight, timeout):
                boxes, cap = inflight.pop(fut)
                reserved -= cap if opt.max_boxes is not None else 0
                try:
                    outs, left, cpu, pid = backend.result(fut)
                except WorkerLost:
                    stack.extend(boxes)  # the batch is run again: no box is lost
                    lost = True
                    continue
                for o, path in outs:
                    col.add(o)  # statistics now; solutions are recorded again in serial order below
                    if path is not None:
                        sols.append((path, o.solution))
                stack.extend(left)
                worker_cpu += cpu
                batches += 1
                pids.add(pid)
                if callback is not None:
                    callback(st)
            if lost:
                restarts += 1
                if stopping is None and restarts <= max_restarts:
                    # the pool is broken: every batch in it is lost, run them again
                    if isinstance(backend, _LocalBackend):
                        for fut, (boxes, cap) in list(inflight.items()):
                            if fut.done() and not fut.cancelled() and fut.exception() is None:
                                continue  # came back before the pool broke: collected next round
                            inflight.pop(fut)
                            reserved -= cap if opt.max_boxes is not None else 0
                            stack.extend(boxes)
                    backend.restart()
            if progress.enabled:
                progress.report(st, [b[:2] for b in stack] + [b[:2] for bs, _ in inflight.values() for b in bs])
    except BaseException:
        backend.abandon(list(inflight))
        raise
    # boxes of batches that did not come back in time stay unexplored
    for boxes, _ in inflight.values():
        stack.extend(boxes)
    if inflight:
        backend.abandon(list(inflight))
    else:
        backend.close()
    pending = [(lo, hi) for lo, hi, _ in stack]
    progress.report(st, pending, force=True)
    if complete and pending:  # cannot happen: the loop only ends with an empty stack
        complete, message = False, "search stopped with boxes left"
    # record the solutions in the order the serial search finds them, so that the de-duplication
    # of certified boxes (first found is kept) and the order of the answer are the serial ones
    sols.sort(key=lambda t: t[0])
    col.boxes = []
    st["solutions"] = st["certified"] = 0
    for _, sol in sols:
        col.record(sol)
    res = finish(system, col, complete, message, pending, t0, c0)
    res.stats["master_cpu_seconds"] = res.stats["cpu_seconds"]
    res.stats["cpu_seconds"] += worker_cpu
    res.stats.update(backend=backend.name, workers=(workers if workers is not None else len(pids)),
                     worker_processes=len(pids), batches=batches, worker_restarts=restarts)
    return res
