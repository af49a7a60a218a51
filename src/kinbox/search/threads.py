"""One thread for the linear algebra of a solve.

numpy's and scipy's OpenBLAS (numba's ``np.linalg`` calls scipy's LAPACK) start a thread per
core for any matrix past a few dozen rows. kinbox's matrices are small (one Jacobian, one LP
basis) and it spreads work over processes of its own (``--workers``), so those threads only
wait for each other: on a 2-core machine with other work running, an SVD of a 44 x 44 Jacobian
took 1-100 ms instead of 0.05 ms. And a threaded
product sums in an order that depends on the thread count, so its last bits, and the search
tree that follows from them, changed from run to run. A solve therefore runs with every BLAS
and OpenMP pool of the process at one thread (``threadpoolctl``, the library scikit-learn uses
for the same purpose), restored afterwards: a user's own numpy work keeps its threads (tests/search/test_threads.py).
"""

from __future__ import annotations

import contextlib
import functools
from collections.abc import Callable
from pathlib import Path
from typing import ParamSpec, TypeVar

from threadpoolctl import ThreadpoolController

P = ParamSpec("P")
R = TypeVar("R")

_controller: ThreadpoolController | None = None


def one_thread() -> contextlib.AbstractContextManager:
    """A context in which every BLAS and OpenMP pool loaded in this process uses one thread."""
    global _controller
    if _controller is None:
        # the scan finds only the libraries loaded so far: scipy's LAPACK (numba's np.linalg)
        # is loaded here first, the scan (a few ms) is made once per process
        _load_scipy_lapack()
        _controller = ThreadpoolController()
    return _controller.limit(limits=1)


def _load_scipy_lapack() -> None:
    """Load the BLAS/LAPACK library of ``scipy.linalg.cython_lapack`` (what numba's
    ``np.linalg`` calls) into the process: the module's shared object loaded as a plain library
    (its dependencies with it; Python imports it the same file later), which spares a solve that
    never calls LAPACK the import of ``scipy.linalg`` (some 0.07 s of CPU); the import where the
    file is not found."""
    import ctypes
    import sys

    if "scipy.linalg.cython_lapack" in sys.modules:
        return
    import scipy

    for so in sorted((Path(scipy.__file__).parent / "linalg").glob("cython_lapack.*")):
        if so.suffix in (".so", ".pyd", ".dylib"):
            try:
                ctypes.CDLL(str(so))
                return
            except OSError:
                break
    import scipy.linalg.cython_lapack  # noqa: F401


def single_threaded(fn: Callable[P, R]) -> Callable[P, R]:
    """``fn`` run inside :func:`one_thread`."""

    @functools.wraps(fn)
    def run(*args: P.args, **kwargs: P.kwargs) -> R:
        with one_thread():
            return fn(*args, **kwargs)

    return run
