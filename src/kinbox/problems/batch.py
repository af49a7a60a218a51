"""Many poses of one arm: the one batch path of :meth:`kinbox.IK.solve_iter` and ``kinbox ik --poses``.

:func:`answers` answers each pose of a list in order, each as soon as it is ready:

* in this process, through the compiled closed form for all poses at once where the arm is of
  a closed-form family (:func:`kinbox.search.cf_batch.run_batch`), the others one by one;
* or on a Dask cluster (``executor``), each pose one task solved as alone;
* or over ``workers`` local processes (:func:`kinbox.search.parallel.imap_tasks`), each pose
  solved in one of them with the same answer as alone; a result comes back pickled without
  what the master holds already (the arm template, the robot's model: most of its bytes).

With ``catch=True`` a pose's bad input or internal error is its :class:`PoseAnswer`'s
``error`` (the batch goes on: the command line's error records); else it is raised.
"""

from __future__ import annotations

import io
import pickle
from collections.abc import Generator, Iterator, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

from ..answer.result import Result
from ..errors import KinboxError


class PoseSolver(Protocol):
    """What the batch asks of one arm's IK (:class:`kinbox.problems.ik.IK` has it): stated here,
    so that the batch imports nothing of the IK whose :meth:`~kinbox.problems.ik.IK.solve_iter`
    calls it (``tests/support/test_source_shape.py``)."""

    scene: Any

    @property
    def closed_form(self) -> Any: ...

    def prepare(self) -> Any: ...

    def solve(self, pose: Any, **solver_options: Any) -> Result: ...

    def _shared(self) -> dict[str, object]: ...

    def _within_scale(self, goal: Any) -> Any: ...

    def _closed_form_fast(self, pose: Any, solver_options: dict, batch: Any = None, k: int = 0) -> Result | None: ...


@dataclass
class PoseAnswer:
    """The answer to pose ``index`` of a batch: its ``result``, or (``catch=True``) its
    ``error`` in one line, ``internal`` when that is a bug of kinbox, not the input. A pose
    given as None (a bad line, reported by the caller) has neither."""

    index: int
    result: Result | None = None
    error: str | None = None
    internal: bool = False


def answers(
    ik: PoseSolver, goals: Sequence[Any | None], workers: int | None = None, catch: bool = False, debug: bool = False, **solver_options
) -> Generator[PoseAnswer, None, None]:
    """The answer to each of ``goals`` (parsed poses, or None to skip), in order (see the
    module's text). ``debug``: with ``catch``, internal errors are raised all the same."""
    executor = solver_options.get("executor")
    if executor is not None and sum(g is not None for g in goals) >= 2:
        yield from _dask(ik, goals, executor, catch, debug, {k: v for k, v in solver_options.items() if k != "executor"})
        return
    if workers is None or sum(g is not None for g in goals) < 2:
        yield from _serial(ik, goals, catch, debug, solver_options)
        return
    from ..search.parallel import imap_tasks

    ik.prepare()  # the template and the kernels, before the workers are forked
    shared = ik._shared()
    tasks = [(k, g, solver_options, catch, debug) for k, g in enumerate(goals)]
    records = imap_tasks(_solve_one, tasks, workers, initializer=_set_worker_ik, initargs=(ik,))
    try:
        for k, blob, error, internal in records:
            res = _Unpickler(io.BytesIO(blob), shared).load() if blob is not None else None
            yield PoseAnswer(k, res, error, internal)
    finally:
        close = getattr(records, "close", None)
        if close is not None:
            close()  # workers still busy are stopped


def _dask(ik: PoseSolver, goals: Sequence[Any | None], executor, catch: bool, debug: bool, options: dict) -> Iterator[PoseAnswer]:
    """Each pose solved as a task on a Dask cluster (``executor``: a Client or a scheduler
    address), with the same answer as alone: the arm goes to every worker once, the answers
    come back in the order of the poses."""
    from ..search.parallel import _dask_client

    ik.prepare()
    client, owned = _dask_client(executor)
    try:
        data = client.scatter(ik, broadcast=True, hash=False)
        todo = [k for k, g in enumerate(goals) if g is not None]
        futures = dict(
            zip(todo, client.map(_solve_dask, [data] * len(todo), [(k, goals[k], options, catch, debug) for k in todo], pure=False))
        )
        try:
            for k, g in enumerate(goals):
                if g is None:
                    yield PoseAnswer(k)
                    continue
                yield futures.pop(k).result()
        finally:
            if futures:
                client.cancel(list(futures.values()))
    finally:
        if owned:
            client.close()


def _solve_dask(ik_: PoseSolver, task) -> PoseAnswer:
    k, goal, options, catch, debug = task
    return _one(k, goal, catch, debug, lambda: ik_.solve(goal, **options))


def _serial(ik: PoseSolver, goals: Sequence[Any | None], catch: bool, debug: bool, solver_options: dict) -> Iterator[PoseAnswer]:
    batch = solver_options.get("closed_form", True) and solver_options.get("resume") is None
    batch = batch and ik.scene is None and not solver_options.get("collision_free")  # scenes: per pose
    todo = [k for k, g in enumerate(goals) if g is not None]
    if len(todo) > 1 and batch and ik.closed_form:
        yield from _closed_form_batch(ik, goals, todo, catch, debug, solver_options)
        return
    for k, g in enumerate(goals):
        yield _one(k, g, catch, debug, lambda g=g: ik.solve(g, **solver_options))


def _one(k: int, goal, catch: bool, debug: bool, solve) -> PoseAnswer:
    """Pose ``k`` answered by ``solve()``, its errors caught or raised (see :func:`answers`)."""
    from ..search import interrupt

    if goal is None:
        return PoseAnswer(k)
    if not catch:
        with interrupt.searching():
            return PoseAnswer(k, solve())
    try:
        with interrupt.searching():
            return PoseAnswer(k, solve())
    except KinboxError as e:
        return PoseAnswer(k, error=str(e))
    except Exception as e:  # a bug: reported for this pose, the batch goes on
        if debug:
            raise
        return PoseAnswer(k, error=f"internal error: {type(e).__name__}: {e}", internal=True)


def _closed_form_batch(
    ik: PoseSolver, goals: Sequence[Any | None], todo: list[int], catch: bool, debug: bool, options: dict
) -> Iterator[PoseAnswer]:
    """The poses ``todo`` through the compiled closed form, all at once
    (:func:`kinbox.search.cf_batch.run_batch`, each root certified in the joint angles); a
    pose it does not decide is solved as :meth:`IK.solve` solves it alone."""
    import numpy as np
    import pinocchio as pin

    from ..search.cf_batch import run_batch

    cf = ik.closed_form
    options = {k: v for k, v in options.items() if k != "closed_form"}
    scaled = {}
    for k in todo:  # the goals as each pose's problem has them (far poses brought nearer)
        try:
            scaled[k] = ik._within_scale(goals[k])
        except KinboxError:  # refused: by the pose's own solve, below
            pass
    at = {k: i for i, k in enumerate(scaled)}
    R = np.array([g.rotation for g in scaled.values()])
    t = np.array([g.translation for g in scaled.values()])
    V = np.array([pin.SE3ToXYZQUAT(g) for g in scaled.values()]).reshape(len(scaled), 7)
    batch = run_batch(cf, cf.certifier, R, t, V=V, certificate="joint") if scaled else None

    def solve(k: int) -> Result:
        g = goals[k]
        if k not in at:
            return ik.solve(g, **options)
        fast = ik._closed_form_fast(g, dict(options), batch, at[k])
        return fast if fast is not None else ik.solve(g, **options)

    for k, g in enumerate(goals):
        yield _one(k, g, catch, debug, lambda k=k: solve(k))


_WORKER_IK: PoseSolver | None = None  # the arm of a pose worker, formulated once per process


def _set_worker_ik(ik_: PoseSolver) -> None:
    global _WORKER_IK
    _WORKER_IK = ik_


def _solve_one(task) -> tuple[int, bytes | None, str | None, bool]:
    """A pose solved in a worker: ``(index, pickled result or None, error, internal)``, the
    result pickled without what the master holds already (see :class:`_Pickler`)."""
    k, goal, options, catch, debug = task
    ik_ = _WORKER_IK
    assert ik_ is not None
    a = _one(k, goal, catch, debug, lambda: ik_.solve(goal, **options))
    if a.result is None:
        return k, None, a.error, a.internal
    out = io.BytesIO()
    _Pickler(out, ik_._shared()).dump(a.result)
    return k, out.getvalue(), None, False


class _Pickler(pickle.Pickler):
    """Pickles the objects of ``shared`` (name -> object) by name: the master puts its own in
    their place (:class:`_Unpickler`), the same objects (its IK is the one the worker has)."""

    def __init__(self, file, shared: dict[str, object]):
        super().__init__(file, protocol=pickle.HIGHEST_PROTOCOL)
        self.names = {id(v): k for k, v in shared.items() if v is not None}

    def persistent_id(self, obj):
        return self.names.get(id(obj))


class _Unpickler(pickle.Unpickler):
    def __init__(self, file, shared: dict[str, object]):
        super().__init__(file)
        self.shared = shared

    def persistent_load(self, pid):
        return self.shared[pid]
