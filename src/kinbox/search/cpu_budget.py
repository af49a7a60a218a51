"""A CPU-time budget for a run: once the process has used ``seconds`` of CPU (all its threads,
``time.process_time``) since :class:`CpuBudget` started, every running search is asked to stop
at its next box (:func:`kinbox.search.interrupt.request`), so the answer is what was found so
far, marked incomplete, its state ready to be saved.

A budget, like ``time_limit`` (wall time), never a pruning decision: where the search stops
depends on the machine's speed, the boxes it explored before do not. It counts this process
only: worker processes (``workers=``, Dask) are not counted, and the ``kinbox`` command refuses
``--cpu-limit`` with them (test_cpu_limit_stops_the_search_incomplete).
"""

from __future__ import annotations

import threading
import time

from . import interrupt

POLL_SECONDS = 0.05  # how often the watcher looks at the process's CPU time


class CpuBudget:
    """Asks the searches of this process to stop once ``seconds`` of CPU are used from its
    creation; :meth:`stop` ends the watch (also a context manager)."""

    def __init__(self, seconds: float):
        self.seconds = seconds
        self._limit = time.process_time() + seconds
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._watch, name="kinbox-cpu-budget", daemon=True)
        self._thread.start()

    def _watch(self) -> None:
        while not self._done.wait(POLL_SECONDS):
            if time.process_time() > self._limit:
                interrupt.request(f"CPU limit of {self.seconds:g} s reached")
                return

    def stop(self) -> None:
        self._done.set()
        self._thread.join()

    def __enter__(self) -> CpuBudget:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()
