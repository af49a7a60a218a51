"""Parallel branch-and-prune: local worker processes or a Dask cluster.

The search runs in waves (:mod:`kinbox.search.waves`): the boxes of a wave are
independent of each other and are processed under the same policy, so a wave spreads over
processes the simple way:

* the **master** (the calling process) holds the wave, cuts it into batches, hands them to
  workers, and puts what comes back together **in the wave's order** (the solutions, the next
  wave, the counts that make the next policy), so the tree, its counts and its answer are
  exactly those of the serial search; it also enforces the budgets (``time_limit``,
  ``max_boxes``);
* a **worker** holds a :class:`~kinbox.search.processor.BoxProcessor`, built once per process from
  the pickled :class:`~kinbox.formulation.system.System`, and runs :func:`explore` on a batch:
  each box processed once, its outcome sent back.

**Faults.** The master's state changes only when a batch's result arrives (:func:`explore`
only returns), so a batch whose worker died is simply run again. A local pool that breaks (a
worker killed, out of memory) is replaced by a fresh one; on Dask the scheduler reschedules
tasks of a lost worker itself, and a task that fails with a lost worker (``KilledWorker``, a
cancelled future, a closed connection) is re-submitted by the master. After ``max_restarts``
such failures the search stops and returns what it found, marked incomplete, with the
unexplored boxes in ``pending`` — as a time budget does.

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
import signal
import sys
import threading
import time
import uuid
from collections import OrderedDict
from collections.abc import Callable, Iterator

import numpy as np

from ..errors import InputError
from ..formulation.system import System
from . import interrupt, lifeline
from .certify import Certifier
from .collector import Collector
from .options import SolverOptions
from .policy import Policy
from .processor import BoxProcessor
from .progress import Progress, show_progress
from .results import SolveResult
from .state import SearchState
from .status import Status
from .threads import single_threaded
from .waves import WaveLoop, finish, held_bytes, start_state, time_limit_message

#: most boxes in one batch (a box takes 0.1-5 ms; a batch, a few ms of scheduling on Dask)
BATCH_MAX = 64
#: batches per worker slot a wave is cut into, at least (so slots finish a wave together)
BATCHES_PER_SLOT = 4
#: batches kept in flight per worker slot: one running, one ready, so no slot waits on the master
IN_FLIGHT_PER_SLOT = 2
#: worker losses (broken pool, lost Dask worker) tolerated before the search gives up
MAX_RESTARTS = 20
#: local worker processes allowed per available core (each holds ~150 MB: Python, NumPy,
#: Pinocchio, the compiled kernels)
MAX_WORKERS_PER_CORE = 4


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


def _init_worker(key: str, payload, master: int) -> None:
    """Pool initializer: tie the worker's life to the master's, then build its BoxProcessor
    once, before any batch arrives."""
    lifeline.tie_to(master)
    # Ctrl-C in a terminal reaches every process of the group: the master stops the search (it
    # collects what the workers return); a worker killed by it would only break the pool
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    # SIGTERM ends a worker, as the pool means it to (a forked worker inherits the master's
    # handler, which only asks a search to stop: a worker blocked writing a result that no one
    # reads any more then lived on, and the master waited for it at exit)
    # (tests/cli/test_hostile.py::test_lost_worker_does_not_hang)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _processor(key, payload)


@single_threaded
def explore(key: str, payload, boxes, policy: Policy, deadline_in: float | None = None):
    """Process every box ``(lo, hi, hint)`` of ``boxes`` under ``policy``; returns
    ``(outcomes, cpu_seconds, pid)``, one outcome per box, in order. ``deadline_in``: seconds
    after which a box stops between LPs (it comes back ``"unfinished"``). Nothing but the
    worker's own BoxProcessor changes, so a batch can be run again (after a worker loss) by any
    worker."""
    proc = _processor(key, payload)
    c0 = time.process_time()
    proc.set_deadline(None if deadline_in is None else time.perf_counter() + deadline_in)
    outs = [proc.process(lo, hi, hint, policy) for lo, hi, hint in boxes]
    return outs, time.process_time() - c0, os.getpid()


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
        if self.ctx.get_start_method() == "forkserver":
            _guard_forkserver(self.ctx)
        self.pool: cf.ProcessPoolExecutor | None = None
        self._start()

    def _start(self):
        self.pool = cf.ProcessPoolExecutor(
            self.n, mp_context=self.ctx, initializer=_init_worker, initargs=(self.key, self.payload, os.getpid())
        )

    def slots(self) -> int:
        return self.n

    def submit(self, boxes, policy, deadline_in):
        # the payload travels once per process (initializer), not with every batch
        try:
            assert self.pool is not None  # started in __init__ and by restart
            return self.pool.submit(explore, self.key, None, boxes, policy, deadline_in)
        except cf.process.BrokenProcessPool as e:  # broke since the last wait: a lost batch
            fut: cf.Future = cf.Future()
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
        assert old is not None
        _stop_pool(old, grace=2.0)  # its surviving workers ended, not left blocked
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
            import distributed  # noqa: F401 - checked here, used through _dask_client
        except ImportError:  # pragma: no cover - checked by _dask_client first
            raise InputError("a Dask executor needs dask.distributed: pip install 'kinbox[dask]'") from None
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

    def submit(self, boxes, policy, deadline_in):
        fut = self.client.submit(explore, self.key, self.data, boxes, policy, deadline_in, pure=False)
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
    return bool(
        names
        & {
            "KilledWorker",
            "CancelledError",
            "FutureCancelledError",
            "CommClosedError",
            "FutureLostError",
            "ConnectionError",
            "StreamClosedError",
            "TimeoutError",
        }
    )


def _dask_client(executor):
    """``(client, owned)``: a Client as given, or one connected to a scheduler address."""
    if isinstance(executor, str):
        try:
            from distributed import Client
        except ImportError:
            raise InputError("--dask needs dask.distributed, an optional extra: pip install 'kinbox[dask]'") from None
        try:
            return Client(executor, timeout="30s"), True
        except (OSError, TimeoutError) as e:
            raise InputError(f"cannot reach the Dask scheduler at {executor!r}: {e}") from None
    if not (hasattr(executor, "submit") and hasattr(executor, "scatter") and hasattr(executor, "nthreads")):
        raise InputError(f"executor must be a dask.distributed.Client or a scheduler address, got {type(executor).__name__}")
    return executor, False


def _guard_forkserver(ctx) -> None:
    """Have the fork server, if this process has not started it yet, import
    :mod:`kinbox.search.forkserver_guard` first: then it dies with this process (lifeline)."""
    from multiprocessing import forkserver

    server = getattr(forkserver, "_forkserver", None)
    if server is None or getattr(server, "_forkserver_pid", None) is not None:
        return  # running already (started by someone else): the workers' own watch still holds
    mods = list(getattr(server, "_preload_modules", []) or [])
    guard = "kinbox.search.forkserver_guard"
    if guard not in mods:
        ctx.set_forkserver_preload([*mods, guard])


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


def check_workers(workers) -> int:
    """The number of local worker processes ``workers`` asks for (0: one per available core),
    validated: a non-negative integer, at most :data:`MAX_WORKERS_PER_CORE` per core."""
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 0:
        raise InputError(f"workers must be a non-negative integer, got {workers!r}")
    cores = _cpu_count()
    if workers > MAX_WORKERS_PER_CORE * cores:
        raise InputError(
            f"{workers} worker processes is too many: at most {MAX_WORKERS_PER_CORE * cores} "
            f"here ({MAX_WORKERS_PER_CORE} per available core; 0 means one per core)"
        )
    return int(workers) or cores


#: tasks per batch sent to a worker process at most, for :func:`imap_tasks` (a UR5 pose takes
#: some 25 ms: a batch of 8 is 0.2 s, so the answers stream out, and the cost of sending a batch
#: is spread over several tasks)
TASKS_PER_BATCH = 8


#: batches submitted ahead of the one the caller waits for: a slow task (a pose of seconds)
#: holds back the output, not the other workers, which go on with the next batches meanwhile
#: (their answers wait in memory: a few kB per task)
TASK_BATCHES_AHEAD = 128


def _init_task_worker(master: int, initializer: Callable | None, initargs: tuple) -> None:
    """Pool initializer of :func:`imap_tasks`: die with the master, leave Ctrl-C to it (a forked
    worker inherits its handlers and its interrupt flag); SIGTERM from the master (see
    :func:`_stop_pool`) stops the searches of this worker at their next box. Then the caller's
    own initializer."""
    lifeline.tie_to(master)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, lambda signum, frame: interrupt.request("stopped by the master"))
    interrupt.clear()
    if initializer is not None:
        initializer(*initargs)


def _run_batch(fn: Callable, batch: list) -> list:
    return [fn(t) for t in batch]


def imap_tasks(
    fn: Callable,
    tasks,
    workers: int,
    initializer: Callable | None = None,
    initargs: tuple = (),
    *,
    batch: int | None = None,
    start_method: str | None = None,
    max_restarts: int = MAX_RESTARTS,
) -> Iterator:
    """``fn(t)`` for each ``t`` of ``tasks``, computed over ``workers`` local processes (0: one per
    core), yielded in the order of ``tasks`` as soon as each is ready: independent searches
    (one per pose, say) rather than the boxes of one search.

    ``initializer(*initargs)`` runs once in each worker (build what every task needs there,
    once). ``fn`` and the tasks must be picklable (top-level functions); an exception of ``fn``
    is raised here, for its task. The workers die with this process, ignore Ctrl-C (the caller
    decides what to do) and are killed when the generator is closed before its end. A worker
    lost (killed, out of memory) costs a new pool and the batches in flight are run again (the
    tasks are independent); after ``max_restarts`` losses :class:`WorkerLost` is raised.
    """
    tasks = list(tasks)
    if not tasks:
        return
    n = min(check_workers(workers), len(tasks))
    size = batch or max(1, min(TASKS_PER_BATCH, len(tasks) // (n * BATCHES_PER_SLOT)))
    batches = [tasks[a : a + size] for a in range(0, len(tasks), size)]
    ctx = mp.get_context(start_method or _default_start_method())
    if ctx.get_start_method() == "forkserver":
        _guard_forkserver(ctx)

    def start():
        return cf.ProcessPoolExecutor(n, mp_context=ctx, initializer=_init_task_worker, initargs=(os.getpid(), initializer, initargs))

    pool = start()
    futures: dict[int, cf.Future] = {}
    sent = restarts = 0
    finished = False
    try:
        for k in range(len(batches)):
            while True:
                while sent < len(batches) and sent < k + max(n * IN_FLIGHT_PER_SLOT, TASK_BATCHES_AHEAD):
                    futures[sent] = pool.submit(_run_batch, fn, batches[sent])
                    sent += 1
                try:
                    outs = futures.pop(k).result()
                    break
                except cf.process.BrokenProcessPool as e:
                    restarts += 1
                    if restarts > max_restarts:
                        raise WorkerLost(f"worker processes were lost {restarts} times: {e}") from e
                    _stop_pool(pool)
                    pool = start()
                    futures.clear()
                    sent = k  # every batch from k on runs again
            yield from outs
        finished = True
    finally:
        if finished:
            pool.shutdown(wait=True)
        else:  # closed early (Ctrl-C, an error): nothing more is wanted from the workers
            _stop_pool(pool)


def _stop_pool(pool: cf.ProcessPoolExecutor, grace: float = 10.0) -> None:
    """Stop a pool now: queued batches are dropped, the running ones are asked (SIGTERM, see
    :func:`_init_task_worker`) to stop their searches at the next box, so they end within
    moments and their workers exit. A worker killed outright in the middle of sending its
    answer could leave the pool's reader thread waiting forever for the rest of it (and this
    process's exit, which joins that thread): it is killed only if it has not ended after
    ``grace`` seconds."""
    # the processes are in the pool's private table (there since Python 3.2)
    procs = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for p in procs:
        try:
            p.terminate()
        except (OSError, ValueError):  # already gone, or closed
            pass
    end = time.monotonic() + grace
    for p in procs:
        p.join(timeout=max(end - time.monotonic(), 0.0))
        if p.is_alive():
            try:
                p.kill()
            except (OSError, ValueError):  # ended (reaped by the pool's own thread) meanwhile
                continue
            p.join(timeout=5)


# ---------------------------------------------------------------------------- master
class ParallelRunner:
    """Runs the boxes of a wave as batches on ``backend``'s workers (the wave loop is
    :class:`~kinbox.search.waves.WaveLoop`'s): batches in flight while the budgets allow, the
    outcomes taken in the wave's order once every batch of the wave is back, up to the first
    box not processed (a budget stopped the wave, or the time limit passed inside a box): the
    boxes from there on stay in the wave, to be processed (again) later."""

    def __init__(self, backend, max_restarts: int, callback: Callable[[dict], None] | None):
        self.backend, self.max_restarts, self.callback = backend, max_restarts, callback
        self.inflight: dict = {}  # future -> (start, end) of its batch in the wave
        self.worker_cpu, self.batches, self.restarts = 0.0, 0, 0
        self.pids: set = set()

    def run_wave(self, loop: WaveLoop) -> None:
        results = self._explore(loop)
        for a in sorted(results):
            if a != loop.k:
                break
            if not all(loop.take(o) for o in results[a]):
                break
        if loop.k < len(loop.wave) and not loop.stopped:
            # every batch came back, one with a box the deadline cut short
            loop.stop(Status.TIME_LIMIT, time_limit_message(loop.opt))

    def _submit(self, loop: WaveLoop, todo: list, sent_boxes: int) -> int:
        """Submit batches of ``todo`` while there is room in flight and in the box budget."""
        opt, backend = loop.opt, self.backend
        while todo and len(self.inflight) < backend.slots() * IN_FLIGHT_PER_SLOT:
            a, b = todo.pop()
            if opt.max_boxes is not None:  # never more boxes than the budget allows
                room = opt.max_boxes - loop.boxes_run() - sent_boxes
                if room <= 0:
                    todo.append((a, b))
                    break
                if b - a > room:
                    todo.append((a + room, b))
                    b = a + room
            left = None if opt.time_limit is None else max(opt.time_limit - (time.perf_counter() - loop.clock), 0.0)
            self.inflight[backend.submit(loop.wave[a:b], loop.policy, left)] = (a, b)
            sent_boxes += b - a
        return sent_boxes

    def _explore(self, loop: WaveLoop) -> dict:
        """Batches of ``wave[k:]`` on the workers until all are back or the loop is stopped;
        returns the outcomes by the start of their batch."""
        opt, backend, st = loop.opt, self.backend, loop.col.stats
        wave, k = loop.wave, loop.k
        left_in_wave = len(wave) - k
        size = max(1, min(BATCH_MAX, -(-left_in_wave // (backend.slots() * BATCHES_PER_SLOT))))
        todo = [(a, min(a + size, len(wave))) for a in range(k, len(wave), size)][::-1]
        results: dict = {}  # start -> outcomes of the batch wave[start:end]
        done_boxes = sent_boxes = 0
        while todo or self.inflight:
            stop = loop.budget(done_boxes, held_bytes(loop.system.n, left_in_wave + len(loop.nxt) + 2 * done_boxes, len(loop.col.boxes)))
            if stop is None and self.restarts > self.max_restarts:
                stop = (Status.WORKERS_LOST, f"workers were lost {self.restarts} times; stopped with the search unfinished")
            if stop is not None:
                loop.stop(*stop)
                break
            sent_boxes = self._submit(loop, todo, sent_boxes)
            if not self.inflight:  # the box budget is spent
                loop.stop(Status.BOX_BUDGET, f"box budget of {opt.max_boxes} reached")
                break
            timeout = 0.5
            if opt.time_limit is not None:
                timeout = min(timeout, max(opt.time_limit - (time.perf_counter() - loop.clock), 0.0) + 1e-3)
            lost = False
            for fut in backend.wait(self.inflight, timeout):
                a, b = self.inflight.pop(fut)
                try:
                    outs, cpu, pid = backend.result(fut)
                except WorkerLost:
                    todo.append((a, b))  # the batch is run again: no box is lost
                    sent_boxes -= b - a
                    lost = True
                    continue
                results[a] = outs
                done_boxes += len(outs)
                self.worker_cpu += cpu
                self.batches += 1
                self.pids.add(pid)
                if self.callback is not None:
                    self.callback(dict(st, boxes=st["boxes"] + done_boxes))
            if lost:
                sent_boxes = self._lost(todo, sent_boxes)
            if loop.progress.enabled:
                loop.report(dict(st, boxes=st["boxes"] + done_boxes))
        return results

    def _lost(self, todo: list, sent_boxes: int) -> int:
        """A batch was lost with its worker: a broken local pool loses every batch in it, which
        run again on a fresh pool."""
        self.restarts += 1
        if self.restarts <= self.max_restarts and isinstance(self.backend, _LocalBackend):
            for fut, (a, b) in list(self.inflight.items()):
                if fut.done() and not fut.cancelled() and fut.exception() is None:
                    continue  # came back before the pool broke: collected next round
                self.inflight.pop(fut)
                todo.append((a, b))
                sent_boxes -= b - a
            self.backend.restart()
        return sent_boxes


def solve_parallel(
    system: System,
    options: SolverOptions,
    workers: int | None = None,
    executor=None,
    *,
    start_method: str | None = None,
    max_restarts: int = MAX_RESTARTS,
    callback: Callable[[dict], None] | None = None,
    resume: SearchState | None = None,
) -> SolveResult:
    """:func:`~kinbox.search.solver.solve_system` with the boxes of each wave processed by
    several processes; the answer, the boxes and the counts are the serial ones.

    ``workers``: number of local processes (0: one per available core). ``executor``: a
    ``dask.distributed.Client`` or a scheduler address such as ``"tcp://host:8786"``.
    ``start_method``: multiprocessing start method for local workers (default: fork when the
    master has no other thread, else forkserver). ``callback(stats)`` is called by the master
    after each batch it collects (progress, tests). ``resume``: a stopped search's state
    (:mod:`kinbox.search.state`), from this backend or any other.
    """
    if (workers is None) == (executor is None):
        raise InputError("give either workers=N or executor=<dask Client or address>, not both")
    if workers is not None:
        workers = check_workers(workers)
    opt = options
    c0 = time.process_time()
    t0 = time.perf_counter()
    clock = opt.started if opt.started is not None else t0
    try:
        payload = pickle.dumps((system, opt), protocol=pickle.HIGHEST_PROTOCOL)
    except Exception as e:
        raise InputError(f"the system cannot be sent to worker processes (pickling failed: {e})") from e
    # the serial search's collector (its duplicate test included), so both give the same boxes
    col = Collector(Certifier(system.compile()))
    state = start_state(system, opt, col, resume)
    before = dict(col.stats) if resume is not None else {}
    key = uuid.uuid4().hex
    backend = _LocalBackend(workers, key, payload, start_method) if workers is not None else _DaskBackend(executor, key, payload)
    lo0, hi0 = system.search_domain()
    loop = WaveLoop(system, opt, col, state, Progress(show_progress(opt.progress), np.maximum(hi0 - lo0, 1e-300)), clock)
    runner = ParallelRunner(backend, max_restarts, callback)
    try:
        state = loop.run(runner)
    except BaseException:
        backend.abandon(list(runner.inflight))
        raise
    if runner.inflight:
        backend.abandon(list(runner.inflight))
    else:
        backend.close()
    res = finish(system, col, loop.status, loop.message, state, t0, c0, before)
    res.stats["master_cpu_seconds"] = res.stats["cpu_seconds"]
    res.stats["cpu_seconds"] += runner.worker_cpu
    res.stats["backend"] = backend.name
    res.stats["workers"] = workers if workers is not None else len(runner.pids)
    res.stats["worker_processes"] = len(runner.pids)
    res.stats["batches"] = runner.batches
    res.stats["worker_restarts"] = runner.restarts
    return res
