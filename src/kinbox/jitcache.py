"""Where numba caches kinbox's compiled kernels, chosen before numba loads.

numba caches a kernel next to its source (``__pycache__``), else under ``NUMBA_CACHE_DIR``,
else in the user's cache folder; when none of them is writable (a service account whose home
and install tree are read-only) the ``@njit(cache=True)`` decorators fail as their module
loads. :func:`choose` keeps numba's own choice when it has one; otherwise it points
``NUMBA_CACHE_DIR`` at a folder of this user's in the temporary folder (created mode 0700, and
used only if it is a real folder owned by this user), and when nothing at all is writable it
turns caching off: the kernels are compiled in every process, slower but right
(tests/cli/test_hostile.py::test_numba_cache_choice).
"""

from __future__ import annotations

import contextlib
import os
import stat
import sys
from pathlib import Path

_HERE = Path(__file__).resolve().parent
#: folders whose modules hold cached kernels (numba's in-tree cache is their ``__pycache__``)
_KERNEL_DIRS = ("search", "answer")


def _usable(folder: str | os.PathLike | None) -> bool:
    """Can a cache file be written in ``folder`` (created if missing)?"""
    if not folder:
        return False
    probe = os.path.join(folder, f".kinbox-probe-{os.getpid()}")
    try:
        os.makedirs(folder, exist_ok=True)
        os.close(os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o600))
        os.unlink(probe)
    except OSError:
        return False
    return True


def _private(base: str) -> str | None:
    """``base/kinbox-numba-UID``, a folder of this user's only (not a link), or None."""
    if not _usable(base):
        return None
    d = os.path.join(base, f"kinbox-numba-{os.getuid()}")
    with contextlib.suppress(FileExistsError, OSError):
        os.mkdir(d, 0o700)
    try:
        st = os.lstat(d)
    except OSError:
        return None
    if not stat.S_ISDIR(st.st_mode) or st.st_uid != os.getuid() or st.st_mode & 0o077:
        return None
    return d if _usable(d) else None


def choose() -> str:
    """Set up numba's cache as the module docstring says; returns where it goes
    (``"numba"``: numba's own choice, a folder, or ``""``: no cache)."""
    given = os.environ.get("NUMBA_CACHE_DIR")
    if _usable(given):
        return given or ""
    in_tree = all(_usable(_HERE / sub / "__pycache__") for sub in _KERNEL_DIRS)
    user = Path(os.environ.get("XDG_CACHE_HOME") or Path("~/.cache").expanduser()) / "numba"
    if in_tree or _usable(user):
        return "numba"
    import tempfile

    for base in (tempfile.gettempdir(), "/dev/shm"):
        d = _private(base)
        if d is not None:
            os.environ["NUMBA_CACHE_DIR"] = d  # also for worker processes
            if "numba" in sys.modules:
                import numba

                setattr(numba.config, "CACHE_DIR", d)  # noqa: B010 - not in numba's stubs
            return d
    import numba.core.dispatcher

    numba.core.dispatcher.Dispatcher.enable_caching = lambda self: None  # type: ignore[method-assign]
    return ""
