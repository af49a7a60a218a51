"""Worker processes die with the search that started them, whatever kills it.

A search killed by SIGKILL (``timeout -s KILL``, a job scheduler, the OOM killer) runs no
clean-up, and a worker blocked on its task queue never learns (a forked worker holds both ends
of the queue's pipe), while one in the middle of a long computation keeps a core busy. So each
worker process ties its life to the master's:

* **the kernel**: ``prctl(PR_SET_PDEATHSIG, SIGKILL)`` (Linux) kills a worker when its parent
  dies, whatever the worker is doing (no Python code has to run). The parent of a worker is the
  master with the ``fork`` and ``spawn`` start methods; with ``forkserver`` it is the fork
  server, which gets the same treatment when it starts (:mod:`kinbox.search.forkserver_guard`,
  preloaded by it) and dies with the master;
* **a watch**: a thread of the worker waits on the master's process (a pidfd, or polls it where
  pidfds are missing) and ends the worker when the master ends: the same without the kernel's
  help, at the next moment the worker runs Python code.

The parent's death signal fires when the parent *thread* that made the process ends: a search
must not be started from a thread that ends while the search runs (the pool lives for one
search, so this holds whenever the thread waits for the search's answer).
"""

from __future__ import annotations

import ctypes
import os
import select
import signal
import sys
import threading
import time

PR_SET_PDEATHSIG = 1


def die_with_parent(sig: int = signal.SIGKILL) -> bool:
    """Have the kernel send ``sig`` to this process when its parent (thread) ends (Linux only);
    True if it was set."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(PR_SET_PDEATHSIG, int(sig), 0, 0, 0) == 0
    except (OSError, AttributeError):  # no libc prctl: the watch still works
        return False


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def watch(pid: int) -> None:
    """End this process (``os._exit``) as soon as process ``pid`` ends, from a daemon thread."""
    try:
        fd: int | None = os.pidfd_open(pid)
    except (AttributeError, OSError):  # not Linux >= 5.3, or the process is already gone
        fd = None
    if fd is None and not alive(pid):
        os._exit(1)

    def run():
        if fd is not None:
            select.select([fd], [], [])  # readable when the process has ended
            os._exit(1)
        while alive(pid):
            time.sleep(1.0)
        os._exit(1)

    threading.Thread(target=run, name="kinbox-lifeline", daemon=True).start()


def tie_to(master: int) -> None:
    """Everything above, in a worker process whose master is ``master``."""
    die_with_parent()
    watch(master)
