"""Exceptions raised by kinbox, and the small input checks that raise them. Every one names
the problem in its message."""

from __future__ import annotations

import json
from pathlib import Path

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


class InputError(KinboxError):
    """A malformed argument: non-finite numbers, non-unit quaternion, wrong vector length."""


def finite_vector(v, size: int, what: str, owner: str) -> np.ndarray:
    """``v`` as a flat float array of ``size`` finite entries, else :class:`InputError`
    (``"{what} has 5 entries, {owner}"`` / ``"{what} is not finite"``)."""
    x = np.asarray(v, dtype=float).ravel()
    if x.size != size:
        raise InputError(f"{what} has {x.size} entries, {owner}")
    if not np.all(np.isfinite(x)):
        raise InputError(f"{what} is not finite")
    return x


def read_json(path, error: type[KinboxError], what: str, parse_constant=None):
    """The parsed JSON of the file ``path``; an unreadable or malformed file raises ``error``
    naming the file (``what`` says what it is)."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as e:
        raise error(f"cannot read {what} {str(path)!r}: {e.strerror or e}") from None
    try:
        return json.loads(text, parse_constant=parse_constant)
    except json.JSONDecodeError as e:
        raise error(f"{str(path)!r} is not valid JSON: {e}") from None
