"""Exceptions raised by kinbox, and the small input checks that raise them. Every one names
the problem in its message."""

from __future__ import annotations

import json
from pathlib import Path
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
#: degrees of freedom of a loaded model (the largest robot of example-robot-data, tiago_dual,
#: has 101): Pinocchio's ``Data`` of a model grows with the cube of its size (about 140 MB at
#: 128), and kinbox makes one for every check of a solution
MAX_MODEL_DOF = 128
#: loop closures (legs, welds) of a mechanism
MAX_CLOSURES = 1000


def read_text(path, error: type[KinboxError], what: str, max_bytes: int = MAX_INPUT_BYTES) -> str:
    """The UTF-8 text of the file ``path``; a missing, unreadable, oversized or binary file
    raises ``error`` naming the file."""
    p = Path(path)
    try:
        size = p.stat().st_size
        if size > max_bytes:
            raise error(f"{what} {str(path)!r} is {_mb(size)}, more than the limit of {_mb(max_bytes)}")
        data = p.read_bytes()
    except OSError as e:
        raise error(f"cannot read {what} {str(path)!r}: {e.strerror or e}") from None
    if len(data) > max_bytes:  # grew while read, or a special file
        raise error(f"{what} {str(path)!r} is larger than the limit of {_mb(max_bytes)}")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise error(f"{what} {str(path)!r} is not UTF-8 text (byte {e.start}: a binary file?)") from None


def _mb(n: int) -> str:
    return f"{n / 2**20:.1f} MB" if n >= 2**20 else f"{n} bytes"


def parse_json(text: str, error: type[KinboxError], where: str, parse_constant=None, max_depth: int = MAX_JSON_DEPTH):
    """``json.loads(text)``; malformed JSON, a key given twice in one object, or JSON nested
    too deeply raises ``error``."""
    try:
        out = json.loads(text, parse_constant=parse_constant, object_pairs_hook=_unique_keys)
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
