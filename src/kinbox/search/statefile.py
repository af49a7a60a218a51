"""The files of :mod:`kinbox.search.state`, read and written defensively.

Reading (:func:`read_npz`, :func:`check_header`): the file is read with a byte budget (a device
or FIFO is refused), must be a zip archive of uncompressed ``.npy`` members (what ``np.savez``
writes: a compressed member could expand without bound), and each member's declared shape
and dtype are checked against the budget before its data is read; the JSON header is parsed
with bounded depth and digits and its fields checked for their types.

Writing (:func:`write_replacing`): the data goes to a new temporary file created exclusively
with a unique name in the target's folder (never an existing file or a link planted there),
which then replaces the target in one rename; writers to one folder take turns (a lock on the
folder); temporary files left by savers that died are removed.
"""

from __future__ import annotations

import contextlib
import dataclasses
import fcntl
import io
import math
import os
import re
import tempfile
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import MAX_STATE_BYTES, InputError, parse_json, read_bytes

#: dtypes a saved state holds (floats, ids, basis indices, flags, the header string)
_DTYPES = "fiub"


def read_npz(path: str | os.PathLike, where: str, max_bytes: int = MAX_STATE_BYTES) -> dict[str, np.ndarray]:
    """The arrays of the ``.npz`` file ``path``, checked as the module docstring says; any
    fault raises :class:`InputError` naming ``where`` (tests/cli/test_hostile.py::test_resume_faults)."""
    raw = read_bytes(path, InputError, "search state", max_bytes)
    try:
        z = zipfile.ZipFile(io.BytesIO(raw))
    except (zipfile.BadZipFile, ValueError, OSError):
        raise InputError(f"{where} is not a kinbox search state (not an .npz archive; a .npy file?)") from None
    total = 0
    out: dict[str, np.ndarray] = {}
    with z:
        for info in z.infolist():
            if not info.filename.endswith(".npy") or info.compress_type != zipfile.ZIP_STORED:
                raise InputError(f"{where}: member {info.filename[:60]!r} is not an uncompressed .npy array (kinbox writes no other)")
            total += info.file_size
            if total > max_bytes:
                raise InputError(f"{where}: its members hold more than {max_bytes} bytes")
            try:
                with z.open(info) as f:
                    version = np.lib.format.read_magic(f)
                    if version not in ((1, 0), (2, 0)):
                        raise ValueError(f"npy format version {version}")
                    read_header = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
                    shape, _, dtype = read_header(f, max_header_size=10000)
                    if dtype.hasobject or dtype.kind not in _DTYPES + "U":
                        raise ValueError(f"dtype {dtype} is not one kinbox writes")
                    count = math.prod(int(s) for s in shape)
                    if count * dtype.itemsize > max_bytes or count * dtype.itemsize > info.file_size:
                        raise ValueError(f"its header claims {count} entries of {dtype.itemsize} bytes, more than the member holds")
                    out[info.filename[:-4]] = np.lib.format.read_array(io.BytesIO(z.read(info)), allow_pickle=False)
            except (ValueError, OSError, EOFError, zipfile.BadZipFile, KeyError, SyntaxError, TypeError, OverflowError) as e:
                raise InputError(f"{where}: member {info.filename[:60]!r} is not a valid array ({type(e).__name__}: {e})") from None
    return out


def check_header(text: str, where: str) -> dict[str, Any]:
    """The JSON header of a state, with the types of its fields checked."""
    header = parse_json(text, InputError, where)
    if not isinstance(header, dict):
        raise InputError(f"{where}: its header is not a JSON object")
    for key, kind in (("fingerprint", str), ("options", dict), ("names", list), ("policy", dict), ("events", dict), ("stats", dict)):
        if key in header and not isinstance(header[key], kind):
            noun = {list: "a list", dict: "an object", str: "a string"}[kind]
            raise InputError(f"{where}: header field {key!r} is not {noun}")
    if not all(isinstance(s, str) for s in header.get("names", [])):
        raise InputError(f"{where}: header field 'names' holds something else than names")
    for k, v in header.get("options", {}).items():
        if not (v is None or isinstance(v, (bool, int, float, str))):
            raise InputError(f"{where}: option {k!r} is not a number, a string, true/false or null")
    return header


def typed_fields(cls: type, values: Any, where: str) -> dict[str, Any]:
    """``values`` (a dict) with each field of the dataclass ``cls`` of the type of its default
    (an int where a float is due is taken) and every other entry a finite number, true/false
    or an object of them (older states' fields, which ``cls.from_dict`` converts); anything
    else raises."""
    if not isinstance(values, dict):
        raise InputError(f"{where}: {cls.__name__.lower()} is not an object")
    out: dict[str, Any] = {}
    fields = {f.name: f for f in dataclasses.fields(cls)}
    for name, v in values.items():
        f = fields.get(name)
        default = f.default if f is not None else dataclasses.MISSING
        if isinstance(default, bool):
            ok = isinstance(v, bool)
        elif isinstance(default, int):
            ok = isinstance(v, int) and not isinstance(v, bool)
        elif isinstance(default, float):
            ok = _number(v)
        else:
            ok = _number(v) or isinstance(v, bool) or (isinstance(v, dict) and all(_number(x) or isinstance(x, bool) for x in v.values()))
        if not ok:
            raise InputError(f"{where}: {cls.__name__.lower()} field {name!r} is {type(v).__name__}, not what it holds")
        out[name] = float(v) if isinstance(default, float) else v
    return out


def _number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


#: temporary files of :func:`write_replacing`: ``.NAME.PID.RANDOM.part``
_PART = re.compile(r"^\.(?P<name>.+)\.(?P<pid>\d+)\.[A-Za-z0-9_]+\.part$")


def write_replacing(path: str | os.PathLike, write: Callable[[Any], None], what: str) -> Path:
    """Write a file through ``write(binary file)`` and put it at ``path`` in one rename, as
    the module docstring says; a failure raises :class:`InputError` and leaves ``path`` as it
    was (tests/cli/test_hostile.py::test_save_is_safe)."""
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    try:
        dfd = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except OSError as e:
        raise InputError(f"cannot write {what} to {str(path)!r}: {e.strerror or e}") from None
    tmp = None
    try:
        fcntl.flock(dfd, fcntl.LOCK_EX)  # savers to one folder take turns
        _remove_stale_parts(folder, path.name)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.{os.getpid()}.", suffix=".part", dir=folder)  # O_EXCL
        mask = os.umask(0)
        os.umask(mask)
        os.fchmod(fd, 0o666 & ~mask)  # as a plain open would make it (mkstemp makes it 0600)
        with os.fdopen(fd, "wb") as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
        tmp = None
    except OSError as e:
        raise InputError(f"cannot write {what} to {str(path)!r}: {e.strerror or e}") from None
    finally:
        if tmp is not None:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
        os.close(dfd)  # releases the lock
    return path


def _remove_stale_parts(folder: Path, name: str) -> None:
    """Remove this user's temporary files for ``name`` whose writer has died (a regular file,
    never a link)."""
    with contextlib.suppress(OSError):
        for entry in os.scandir(folder):
            m = _PART.match(entry.name)
            if not m or m["name"] != name:
                continue
            with contextlib.suppress(OSError):
                st = entry.stat(follow_symlinks=False)
                if not entry.is_file(follow_symlinks=False) or st.st_uid != os.getuid() or _alive(int(m["pid"])):
                    continue
                os.unlink(entry.path)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return True
    return True
