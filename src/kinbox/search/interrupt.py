"""Asking a running search to stop, from a signal handler or another thread.

A search checks :func:`requested` between boxes, as it checks its budgets: when set, it stops
there and returns what it found, marked incomplete, with the unexplored boxes pending and its
state ready to be saved (:mod:`kinbox.search.state`). Nothing is cut in the middle of a box, so
the answer and the state are exact.

The ``kinbox`` command line turns SIGINT (Ctrl-C) and SIGTERM into :func:`request` while a
search runs (:func:`running`); from Python, call :func:`request` from another thread (a
KeyboardInterrupt still interrupts a search the usual way, losing it).
"""

from __future__ import annotations

import contextlib
import threading

_lock = threading.Lock()
_reason: str | None = None
_running = 0


def request(reason: str = "interrupted") -> None:
    """Ask every running search of this process to stop at its next box (``reason`` ends up in
    the result's message)."""
    global _reason
    with _lock:
        _reason = reason


def requested() -> str | None:
    """Why the searches must stop, or None."""
    return _reason


def clear() -> None:
    global _reason
    with _lock:
        _reason = None


def running() -> bool:
    """Is a search running in this process?"""
    return _running > 0


@contextlib.contextmanager
def searching():
    """Marks the body as a running search (see :func:`running`)."""
    global _running
    with _lock:
        _running += 1
    try:
        yield
    finally:
        with _lock:
            _running -= 1
