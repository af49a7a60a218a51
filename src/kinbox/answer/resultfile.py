"""Reading a result file back (``kinbox ik/solve --json``, for ``kinbox replay`` and ``kinbox plot``).

A result file is checked where it enters, so that a damaged or hand-edited one is refused with
one line naming what is wrong (``solution 3: q[2] is NaN``), never drawn wrong or half read:
the size, encoding and nesting of the JSON (:func:`kinbox.errors.read_json`), then the shape of
what kinbox reads from it: configurations are lists of finite numbers of one length (that of
``joint_names`` when given), boxes are finite with ``lo <= hi``, one bound per variable.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import MAX_RESULT_BYTES, InputError, read_json


def load_result(path) -> dict:
    """The checked JSON object of a result file, with ``_dir`` (the file's folder) added."""
    p = Path(path)
    d = read_json(p, InputError, "result file", max_bytes=MAX_RESULT_BYTES)
    where = repr(str(path))
    if not isinstance(d, dict) or "solutions" not in d or "source" not in d:
        raise InputError(f"{where} is not a kinbox result (no 'solutions' / 'source'); "
                         "make one with `kinbox ik ... --json` or `kinbox solve ... --json`")
    check_result(d, where)
    d.setdefault("_dir", str(p.resolve().parent))
    return d


def check_result(d: dict, where: str = "result") -> None:
    """Raise :class:`InputError` naming the first part of ``d`` kinbox cannot read."""
    if not isinstance(d.get("source"), dict):
        raise InputError(f"{where}: 'source' must be an object, not {_kind(d.get('source'))}")
    names = d.get("joint_names")
    if names is not None:
        _strings(names, f"{where}: joint_names")
    size = len(names) if names is not None else None
    sols = d.get("solutions")
    if not isinstance(sols, list):
        raise InputError(f"{where}: 'solutions' must be a list, not {_kind(sols)}")
    for k, s in enumerate(sols):
        what = f"{where}: solution {k + 1}"
        if not isinstance(s, dict) or "q" not in s:
            raise InputError(f"{what} has no 'q'")
        size = _vector(s["q"], f"{what}: q", size)
    comps = d.get("components", [])
    if not isinstance(comps, list):
        raise InputError(f"{where}: 'components' must be a list, not {_kind(comps)}")
    for k, c in enumerate(comps):
        what = f"{where}: component {k + 1}"
        if not isinstance(c, dict):
            raise InputError(f"{what} must be an object, not {_kind(c)}")
        dim = c.get("dimension", 0)
        if isinstance(dim, bool) or not isinstance(dim, int) or dim < 0:
            raise InputError(f"{what}: dimension must be a non-negative integer, got {dim!r}")
        samples = c.get("samples", [])
        if not isinstance(samples, list):
            raise InputError(f"{what}: samples must be a list, not {_kind(samples)}")
        for j, q in enumerate(samples):
            size = _vector(q, f"{what}, sample {j + 1}", size)
    boxes = d.get("boxes")
    if boxes is None:
        return
    if not isinstance(boxes, dict):
        raise InputError(f"{where}: 'boxes' must be an object, not {_kind(boxes)}")
    variables = boxes.get("variables", [])
    _strings(variables, f"{where}: boxes.variables")
    if "lo" not in boxes and "hi" not in boxes:
        return
    lo, hi = boxes.get("lo"), boxes.get("hi")
    if not (isinstance(lo, list) and isinstance(hi, list)) or len(lo) != len(hi):
        raise InputError(f"{where}: boxes.lo and boxes.hi must be lists of the same length")
    n = len(variables)
    for name, rows in (("lo", lo), ("hi", hi)):
        try:
            a = np.array(rows, dtype=float)
        except (TypeError, ValueError):
            raise InputError(f"{where}: boxes.{name} must be lists of numbers") from None
        if a.shape != (len(rows), n) or (rows and a.dtype != float):
            raise InputError(f"{where}: boxes.{name} must hold {n} numbers per box (one per variable)")
        if not np.all(np.isfinite(a)):
            k = int(np.argwhere(~np.isfinite(a))[0][0])
            raise InputError(f"{where}: box {k + 1} {name} is not finite")
        if name == "lo":
            a_lo = a
    if np.any(a_lo > a):
        k = int(np.argwhere(a_lo > a)[0][0])
        raise InputError(f"{where}: box {k + 1} has lo > hi")
    comp = boxes.get("component", [-1] * len(lo))
    if not isinstance(comp, list) or len(comp) != len(lo):
        raise InputError(f"{where}: boxes.component must list one component per box")
    for k, c in enumerate(comp):
        if isinstance(c, bool) or not isinstance(c, int) or not -1 <= c < len(comps):
            raise InputError(f"{where}: box {k + 1}: component {c!r} is not -1 or a component index")


def _kind(v: Any) -> str:
    return "null" if v is None else type(v).__name__


def _strings(v, what: str) -> None:
    if not isinstance(v, list) or not all(isinstance(s, str) for s in v):
        raise InputError(f"{what} must be a list of strings")
    if len(set(v)) != len(v):
        dup = next(s for s in v if v.count(s) > 1)
        raise InputError(f"{what}: {dup!r} appears twice")


def _vector(v, what: str, size: int | None) -> int:
    """Check ``v`` is a list of finite numbers (of ``size`` entries if given); its length."""
    if not isinstance(v, list):
        raise InputError(f"{what} must be a list of numbers, not {_kind(v)}")
    for i, x in enumerate(v):
        if isinstance(x, bool) or not isinstance(x, (int, float)):
            raise InputError(f"{what}[{i}] is {_kind(x)} {x!r}, not a number")
        if not math.isfinite(x):
            raise InputError(f"{what}[{i}] is {x}, not a finite number")
    if size is not None and len(v) != size:
        raise InputError(f"{what} has {len(v)} entries, expected {size}")
    return len(v)
