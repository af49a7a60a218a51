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
from types import ModuleType

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


def search_kernel_modules() -> tuple[ModuleType, ...]:
    """The modules holding the search's compiled kernels, each with its ``load_kernel()``."""
    from . import bernstein, certify, propagate, relaxation, transverse

    return (propagate, certify, relaxation, bernstein, transverse)


def kernels_cached(modules: tuple[ModuleType, ...] | None = None) -> bool:
    """Are the compiled kernels of ``modules`` (default: the search's,
    :func:`search_kernel_modules`) in numba's on-disk cache, current with their source? False on
    the first run after an install or an edit of a kernel's module, which compiles them (a
    minute or so of CPU): the ``kinbox`` command then says so on a terminal instead of sitting
    silent, and compiles them before a time limit's clock starts
    (:func:`kinbox.problems.run.compile_kernels`). Every numba function the modules define counts,
    so one added later makes this False until it is compiled
    (tests/search/test_loading.py::test_kernels_cached_sees_every_kernel). Reads numba's cache
    index (numba's own layout: an index whose source stamp is out of date reads as empty); True
    when that cannot be told."""
    from numba.core.caching import NullCache
    from numba.core.dispatcher import Dispatcher

    try:
        for mod in modules if modules is not None else search_kernel_modules():
            for k in vars(mod).values():
                if not isinstance(k, Dispatcher) or k.__module__ != mod.__name__:
                    continue
                cache = getattr(k, "_cache")  # noqa: B009 - not in numba's stubs
                if isinstance(cache, NullCache) or not cache._cache_file._load_index():  # no cache at all: compiled every time
                    return False
    except Exception:  # noqa: BLE001 - another numba layout: say nothing
        return True
    return True
