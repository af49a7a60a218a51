"""The time a search spends loading its compiled kernels, reported apart from the search.

Each compiled kernel loads at its first call in a process: from the ahead-of-time module
(:mod:`kinbox.search.jit`), or from numba's on-disk cache (the first run after an install
compiles it) after numba's own import and set-up: a cost paid once per process, which a
one-pose ``kinbox ik`` would otherwise report as if the search had taken it. numba announces
every time it holds its compiler lock (loading or compiling) through its event API
(``numba.core.event``); a listener sums those periods for the thread that installed it, and
:mod:`kinbox.search.jit` counts the rest. It only reports: no search decision reads it.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from types import ModuleType

from . import jit

EVENT = "numba:compiler_lock"


class LoadClock:
    """Seconds the installing thread spends loading compiled code: holding numba's compiler
    lock, importing numba, loading the ahead-of-time kernels (:mod:`kinbox.search.jit`).

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


def _listen(clock: LoadClock, stack: ExitStack) -> None:
    """``clock`` hears numba's compiler lock until ``stack`` closes (numba imported)."""
    from numba.core import event as numba_event

    class Listener(numba_event.Listener):
        def on_start(self, event) -> None:
            clock.on_start(event)

        def on_end(self, event) -> None:
            clock.on_end(event)

    stack.enter_context(numba_event.install_listener(EVENT, Listener()))


def _forget(hook) -> None:
    if hook in jit.after_import:
        jit.after_import.remove(hook)


@contextmanager
def load_clock() -> Iterator[LoadClock]:
    """A :class:`LoadClock` running inside the ``with`` block; numba is not imported for it
    (it listens from numba's import on, if a kernel imports it)."""
    clock = LoadClock()
    before = jit.loading_seconds[0]
    with ExitStack() as stack:
        hook = lambda: _listen(clock, stack)  # noqa: E731
        if "numba" in sys.modules:
            hook()
        else:
            jit.after_import.append(hook)
            stack.callback(_forget, hook)
        try:
            yield clock
        finally:
            clock.seconds += jit.loading_seconds[0] - before


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
    (tests/search/test_loading.py::test_kernels_cached_sees_every_kernel). A kernel compiled by
    the build of the current ahead-of-time module counts as compiled without numba
    (:func:`kinbox.search.jit.built_with_module`); for the others, reads numba's cache index
    (numba's own layout: an index whose source stamp is out of date reads as empty); True when
    that cannot be told."""
    try:
        for mod in modules if modules is not None else search_kernel_modules():
            for k in vars(mod).values():
                if isinstance(k, jit.Kernel) and k.__module__ == mod.__name__:
                    if jit.built_with_module(k.name):  # compiled by the build of the current ahead-of-time module
                        continue
                    k = k.dispatcher
                elif "numba" not in sys.modules or not _is_dispatcher(k) or k.__module__ != mod.__name__:
                    continue
                from numba.core.caching import NullCache

                cache = getattr(k, "_cache")  # noqa: B009 - not in numba's stubs
                if isinstance(cache, NullCache) or not cache._cache_file._load_index():  # no cache at all: compiled every time
                    return False
    except Exception:  # noqa: BLE001 - another numba layout: say nothing
        return True
    return True


def _is_dispatcher(k: object) -> bool:
    from numba.core.dispatcher import Dispatcher

    return isinstance(k, Dispatcher)
