"""Exceptions raised by kinbox, and the small input checks that raise them. Every one names
the problem in its message."""

from __future__ import annotations

import json
import os
import stat
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np


class KinboxError(Exception):
    """Base class of all kinbox errors: bad input or a problem kinbox cannot formulate."""


class ModelError(KinboxError):
    """A robot or mechanism could not be loaded: unknown name, malformed file, bad numbers."""


class NameNotFound(KinboxError):
    """An unknown frame, joint, link or robot name."""


class FormulationError(KinboxError):
    """A mechanism cannot be turned into a polynomial system (unsupported joint, bad closure)."""


class InconsistentError(KinboxError):
    """A geometric constraint system whose constraints cannot all hold (the message names a
    minimal set of them)."""


class FloatingPointModeError(KinboxError):
    """The processor flushes subnormal numbers to zero (a library built with ``-ffast-math``
    switched it on): outward rounding is then not sound, so kinbox refuses to search."""


class InputError(KinboxError):
    """A malformed argument: non-finite numbers, non-unit quaternion, wrong vector length."""


def finite_vector(v, size: int, what: str, owner: str) -> np.ndarray:
    """``v`` as a flat float array of ``size`` finite entries, else :class:`InputError`
    (``"{what} has 5 entries, {owner}"`` / ``"{what} is not finite"``)."""
    import numpy as np  # here, not at the top: the ``kinbox`` program sets up BLAS before numpy loads

    x = np.asarray(v, dtype=float).ravel()
    if x.size != size:
        raise InputError(f"{what} has {x.size} entries, {owner}")
    if not np.all(np.isfinite(x)):
        raise InputError(f"{what} is not finite")
    return x


#: input limits, checked where input enters (files, mechanism specs, models). kinbox refuses
#: larger input with a one-line error instead of running out of memory or time on it.
#: robot, mechanism and poses files: bytes
MAX_INPUT_BYTES = 16 * 2**20
#: result files (``kinbox ik/solve --json``; up to 20000 solution boxes): bytes
MAX_RESULT_BYTES = 64 * 2**20
#: nesting of JSON arrays and objects (a result file needs 4)
MAX_JSON_DEPTH = 32
#: characters of one JSON number (a float needs 24; Python refuses ints beyond 4300 digits)
MAX_JSON_DIGITS = 100
#: degrees of freedom of a loaded model (the largest robot of example-robot-data, tiago_dual,
#: has 101): Pinocchio's ``Data`` of a model grows with the cube of its size (about 140 MB at
#: 128), and kinbox makes one for every check of a solution
MAX_MODEL_DOF = 128
#: loop closures (legs, welds) of a mechanism
MAX_CLOSURES = 1000
#: links of a URDF and bodies of an MJCF file, counted before Pinocchio reads the file: its
#: loaders recurse along the tree and crash (a segmentation fault) on a chain of some
#: thousands (the largest robot of example-robot-data, tiago_dual, has 130 links)
MAX_LINKS = 1000
#: nesting of XML elements in a robot file (an MJCF chain of bodies nests one level a body)
MAX_XML_DEPTH = 256
#: lengths in a model (metres, or the unit of its file): larger numbers are not a robot, and
#: their squares (which the equations hold) lose every digit of the small ones or overflow
MAX_LENGTH = 1e6
#: entities (points, lines, planes) and bodies of a geometric constraint system: its
#: diagnosis factors dense matrices of all their coordinates, many times (a chain of 30 free
#: points takes seconds)
MAX_ENTITIES = 32
#: a search state file (``--save``/``--resume``): bytes, and the numbers its arrays declare
MAX_STATE_BYTES = 1 * 2**30


def read_bytes(path, error: type[KinboxError], what: str, max_bytes: int = MAX_INPUT_BYTES) -> bytes:
    """At most ``max_bytes`` bytes of the file ``path``, read with that budget whatever the file
    is: a missing or unreadable file, one that is not a regular file (a device such as
    ``/dev/zero``, a FIFO, a directory) or one holding more raises ``error`` naming the file.
    The file is opened without blocking (a FIFO without a writer does not hang) and checked
    on the open descriptor, so it cannot be swapped between check and read
    (tests/cli/test_hostile.py::test_special_files_refused)."""
    name = str(path)
    try:
        fd = os.open(name, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError as e:
        raise error(f"cannot read {what} {name!r}: {e.strerror or e}") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise error(f"{what} {name!r} is {_file_kind(st.st_mode)}, not a regular file")
        if st.st_size > max_bytes:
            raise error(f"{what} {name!r} is {_mb(st.st_size)}, more than the limit of {_mb(max_bytes)}")
        chunks: list[bytes] = []
        got = 0
        while got <= max_bytes:
            b = os.read(fd, min(2**20, max_bytes + 1 - got))
            if not b:
                break
            chunks.append(b)
            got += len(b)
    except OSError as e:
        raise error(f"cannot read {what} {name!r}: {e.strerror or e}") from None
    finally:
        os.close(fd)
    if got > max_bytes:  # grew while read
        raise error(f"{what} {name!r} is larger than the limit of {_mb(max_bytes)}")
    return b"".join(chunks)


def _file_kind(mode: int) -> str:
    for test, kind in (
        (stat.S_ISDIR, "a directory"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISFIFO, "a FIFO (named pipe)"),
        (stat.S_ISSOCK, "a socket"),
    ):
        if test(mode):
            return kind
    return "a special file"


def read_text(path, error: type[KinboxError], what: str, max_bytes: int = MAX_INPUT_BYTES) -> str:
    """The UTF-8 text of the file ``path`` (read by :func:`read_bytes`); a missing, unreadable,
    special, oversized or binary file raises ``error`` naming the file."""
    data = read_bytes(path, error, what, max_bytes)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise error(f"{what} {str(path)!r} is not UTF-8 text (byte {e.start}: a binary file or another encoding?)") from None


def _mb(n: int) -> str:
    return f"{n / 2**20:.1f} MB" if n >= 2**20 else f"{n} bytes"


def parse_json(text: str, error: type[KinboxError], where: str, parse_constant=None, max_depth: int = MAX_JSON_DEPTH):
    """``json.loads(text)``; malformed JSON, a key given twice in one object, or JSON nested
    too deeply raises ``error``."""
    try:
        out = json.loads(text, parse_constant=parse_constant, object_pairs_hook=_unique_keys, parse_int=_int, parse_float=_float)
    except _LongNumber as e:
        raise error(f"{where}: a number of {e.args[0]} digits (at most {MAX_JSON_DIGITS})") from None
    except json.JSONDecodeError as e:
        raise error(f"{where} is not valid JSON: {e}") from None
    except _DuplicateKey as e:
        raise error(f"{where}: key {e.args[0]!r} appears twice in one JSON object") from None
    except RecursionError:
        raise error(f"{where}: JSON nested deeper than {max_depth} levels") from None
    if json_depth(out, max_depth) > max_depth:
        raise error(f"{where}: JSON nested deeper than {max_depth} levels")
    return out


class _DuplicateKey(Exception):
    pass


class _LongNumber(Exception):
    pass


def _int(text: str) -> int:
    if len(text) > MAX_JSON_DIGITS:
        raise _LongNumber(len(text))
    return int(text)


def _float(text: str) -> float:
    if len(text) > MAX_JSON_DIGITS:
        raise _LongNumber(len(text))
    return float(text)


def _unique_keys(pairs):
    out = dict(pairs)
    if len(out) != len(pairs):
        seen = set()
        for k, _ in pairs:
            if k in seen:
                raise _DuplicateKey(k)
            seen.add(k)
    return out


def json_depth(obj, limit: int) -> int:
    """Nesting depth of lists and dicts in ``obj`` (1 for a flat list), counted without
    recursion; stops counting past ``limit``."""
    deepest = 0
    stack = [(obj, 1)] if isinstance(obj, (list, dict)) else []
    while stack:
        o, d = stack.pop()
        deepest = max(deepest, d)
        if d > limit:
            return d
        items = o.values() if isinstance(o, dict) else o
        stack.extend((x, d + 1) for x in items if isinstance(x, (list, dict)))
    return deepest


def read_json(path, error: type[KinboxError], what: str, parse_constant=None, max_bytes: int = MAX_INPUT_BYTES):
    """The parsed JSON of the file ``path``; an unreadable, oversized, binary, malformed or
    too deeply nested file raises ``error`` naming the file (``what`` says what it is)."""
    text = read_text(path, error, what, max_bytes)
    return parse_json(text, error, repr(str(path)), parse_constant)
