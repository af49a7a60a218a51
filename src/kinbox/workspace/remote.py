"""A paving's work on a Dask cluster (:func:`~kinbox.workspace.paving.pave` with ``executor=``):
few tasks, the decider sent once.

* the decider is scattered once per paving, a replica on every worker (each worker unpickles it
  once and keeps it, with its compiled closed forms, for every task of the paving);
* the top of the tree (:func:`~kinbox.workspace.paving.pave_top`, a few hundred boxes, well under
  a second) is one task: one round trip instead of one per wave;
* the subtree tasks (:func:`~kinbox.workspace.paving.pave_subtree`) go in one batch of chunks of
  consecutive subtrees, the chunks shrinking towards the end (guided self-scheduling:
  :func:`chunk_sizes`): a few dozen Dask tasks instead of one per subtree (each costs a few
  milliseconds of scheduler, client and worker CPU), and the small last chunks even out the
  workers' ends. Each subtree's result (NumPy arrays and its counts) comes back as it would
  alone, in the order of the subtrees.

Which worker decides what never changes a verdict, and the results are read in the order of the
subtrees, so the paving is the one a serial run makes (``tests/workspace/test_dask.py``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

#: the chunk of subtrees a Dask task takes is the subtrees left over this many times the
#: cluster's worker threads (at least one subtree): 256 subtrees on two threads make 53 tasks,
#: the last 16 of one subtree each (with 4: 31 tasks, and the two workers of the UR5 map ended
#: 10 % apart)
GUIDED_SHARE = 8


def chunk_sizes(n: int, slots: int, share: int | None = None) -> list[int]:
    """Sizes of consecutive chunks covering ``n`` tasks for ``slots`` worker threads: each the
    tasks left over ``share * slots`` (default :data:`GUIDED_SHARE`), rounded up (guided
    self-scheduling, Polychronopoulos and Kuck 1987): large chunks first, single tasks at the end."""
    share = GUIDED_SHARE if share is None else share
    out: list[int] = []
    left = n
    while left > 0:
        k = max(1, math.ceil(left / (share * max(1, slots))))
        out.append(k)
        left -= k
    return out


def _top_remote(top: Callable, decider: Any, wave: np.ndarray, resolution: float, max_boxes: int, cut: int) -> dict:
    return top(decider, [(p[0], p[1]) for p in wave], resolution, max_boxes, cut)


def _subtrees_remote(subtree: Callable, decider: Any, chunk: list) -> list[dict]:
    return [subtree(decider, lo, hi, res, budget) for lo, hi, res, budget in chunk]


class DaskPaving:
    """One paving's session on a Dask cluster (``executor``: a ``dask.distributed.Client`` or a
    scheduler address): the decider scattered at the first task, released by :meth:`close`."""

    def __init__(self, executor, decider: Any):
        from ..search.parallel import _dask_client

        self.client, self.owned = _dask_client(executor)
        self.decider = decider
        self._data = None

    def _scattered(self):
        if self._data is None:
            # every worker gets a replica: no task waits for a transfer, a lost worker loses none
            self._data = self.client.scatter(self.decider, broadcast=True, hash=False)
        return self._data

    def top(self, top: Callable, wave: list, resolution: float, max_boxes: int, cut: int) -> dict:
        """``top`` (:func:`~kinbox.workspace.paving.pave_top`, sent by reference: this module
        does not import the paving loop back) of ``wave`` as one task."""
        d = len(wave[0][0])
        arr = np.array([[lo, hi] for lo, hi in wave], dtype=float).reshape(-1, 2, d)
        fut = self.client.submit(_top_remote, top, self._scattered(), arr, resolution, max_boxes, cut, pure=False)
        try:
            return fut.result()
        finally:
            fut.release()

    def subtrees(self, subtree: Callable, tasks: list) -> Iterator[dict]:
        """``subtree`` (:func:`~kinbox.workspace.paving.pave_subtree`) of each task, yielded in
        the order of ``tasks``; the tasks not yet run are cancelled when the iterator is closed."""
        slots = max(1, sum(self.client.nthreads().values()))
        chunks, i = [], 0
        for k in chunk_sizes(len(tasks), slots):
            chunks.append(tasks[i : i + k])
            i += k
        data = self._scattered()
        futures = self.client.map(_subtrees_remote, [subtree] * len(chunks), [data] * len(chunks), chunks, pure=False)
        try:
            for f in futures:
                yield from f.result()
        finally:
            self.client.cancel(futures)

    def close(self) -> None:
        try:
            if self._data is not None:
                self._data.release()
                self._data = None
        finally:
            if self.owned:
                self.client.close()
