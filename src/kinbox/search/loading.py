"""The time a search spends loading its compiled kernels, reported apart from the search.

Each numba kernel loads from the on-disk cache at its first call in a process (the first run
after an install compiles it): a cost paid once per process, which a one-pose ``kinbox ik``
would otherwise report as if the search had taken it. numba announces every time it holds its
compiler lock (loading or compiling) through its event API (``numba.core.event``); a listener
sums those periods for the thread that installed it. It only reports: no search decision reads
it.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from numba.core import event as numba_event

EVENT = "numba:compiler_lock"


class LoadClock(numba_event.Listener):
    """Seconds the installing thread spends holding numba's compiler lock.

    Not numba's own ``TimingListener``: that one times every thread's holds, and fails (an
    attribute error inside numba's lock) when it is installed while another thread holds the
    lock and sees an end without its start."""

    def __init__(self) -> None:
        self.seconds = 0.0
        self._thread = threading.get_ident()
        self._depth = 0
        self._t = 0.0

    def on_start(self, event) -> None:
        # other threads' compilations (a Dask worker runs several searches) are theirs; the
        # lock is re-entrant, so only the outermost hold is timed
        if threading.get_ident() != self._thread:
            return
        if self._depth == 0:
            self._t = time.perf_counter()
        self._depth += 1

    def on_end(self, event) -> None:
        if threading.get_ident() != self._thread or self._depth == 0:
            return
        self._depth -= 1
        if self._depth == 0:
            self.seconds += time.perf_counter() - self._t


@contextmanager
def load_clock() -> Iterator[LoadClock]:
    """A :class:`LoadClock` running inside the ``with`` block."""
    with numba_event.install_listener(EVENT, LoadClock()) as clock:
        yield clock


def kernels_cached() -> bool:
    """Are the search's compiled kernels in numba's on-disk cache? False on the first run after
    an install, which compiles them (a minute or so of CPU): the ``kinbox`` command then says so
    on a terminal instead of sitting silent. Reads where numba keeps its cache index (numba's
    own layout); True when that cannot be told."""
    import os

    try:
        from . import certify, propagate

        kernels: list[Any] = [propagate._contract, certify._newton_kernel]
        return all(os.path.exists(k._cache._cache_file._index_path) for k in kernels)
    except Exception:  # noqa: BLE001 - another numba layout: say nothing
        return True
