"""Result files: the JSON that ``kinbox ik/solve --json`` and ``Result.to_dict()`` write, read back
(for ``kinbox replay`` and ``kinbox plot``) and checked against their JSON Schema,
``result.schema.json`` beside this module (``docs/result-file.md``). A file that does not match
gives one line naming the offending field, e.g. ``solutions[2].q[4]: NaN is not a finite
number``."""

from __future__ import annotations

import functools
import json
import os
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import MAX_RESULT_BYTES, InputError, read_json

SCHEMA_FILE = "result.schema.json"


class _NonFinite:
    """``NaN``, ``Infinity`` or ``-Infinity`` as read from a file: not a number to the schema."""

    def __init__(self, text: str):
        self.text = text

    def __repr__(self) -> str:
        return self.text

    def value(self) -> float:
        return float(self.text.replace("Infinity", "inf"))


@functools.lru_cache(maxsize=1)
def schema() -> dict:
    """The JSON Schema of a result file."""
    text = resources.files(__package__).joinpath(SCHEMA_FILE).read_text(encoding="utf-8")
    out: dict = json.loads(text)
    return out


@functools.lru_cache(maxsize=1)
def _validator() -> Any:
    from jsonschema import Draft202012Validator

    return Draft202012Validator(schema())


def load_result(path: str | os.PathLike) -> dict:
    """The JSON object of a result file, checked (:func:`check_result`); ``_dir`` is set to
    the file's folder (a mechanism file named in its ``source`` may be relative to it)."""
    p = Path(path)
    seen: list[_NonFinite] = []

    def constant(text: str) -> _NonFinite:
        seen.append(_NonFinite(text))
        return seen[-1]

    d = read_json(p, InputError, "result file", parse_constant=constant, max_bytes=MAX_RESULT_BYTES)
    bound_result(d, repr(str(path)))
    check_result(d, repr(str(path)))
    if seen:  # allowed where no number is required (stats): back to floats
        d = _restore(d)
    d.setdefault("_dir", str(p.resolve().parent))
    return d


def check_result(d: Any, where: str = "result") -> None:
    """Raise :class:`InputError` (one line: ``where``, the field, what is wrong) unless ``d``
    is a result as the schema describes it, with boxes of matching shapes."""
    if not isinstance(d, dict) or ("solutions" not in d and "source" not in d):
        raise InputError(
            f"{where} is not a kinbox result (no 'solutions' / 'source'); make one with `kinbox ik ... --json` or `kinbox solve ... --json`"
        )
    from jsonschema.exceptions import best_match

    view = d
    b = d.get("boxes")
    if isinstance(b, dict) and any(isinstance(b.get(k), list) and len(b[k]) > 2 for k in ("lo", "hi")):
        # the bulk of the numbers checked here, fast; the schema sees two rows of each
        for k in ("lo", "hi"):
            if isinstance(b.get(k), list):
                _vectors(b[k], where, f"boxes.{k}")
        view = {**d, "boxes": {**b, **{k: b[k][:2] for k in ("lo", "hi") if isinstance(b.get(k), list)}}}
    err = best_match(_validator().iter_errors(view))
    if err is not None:
        raise InputError(f"{where}: {_field(err.absolute_path)}: {_explain(err)}")
    _check_meaning(d, where)


#: what a result file read back (``kinbox replay``/``plot``) may hold: solutions and boxes
#: (kinbox writes at most 20000 boxes); curve points per component are thinned to
#: MAX_CURVE_POINTS, evenly along the list, as a page shows no more
#: (tests/cli/test_hostile.py::test_big_results_bounded)
MAX_RESULT_SOLUTIONS = 1000
MAX_RESULT_BOXES = 20000
MAX_RESULT_COMPONENTS = 1000
MAX_CURVE_POINTS = 1000


def bound_result(d: Any, where: str) -> None:
    """Refuse a result with more solutions, boxes or components than the limits above, and
    thin its curves (``samples``, ``polyline``) to :data:`MAX_CURVE_POINTS` each, before the
    schema is checked (its check of 100,000 points takes a minute)."""
    if not isinstance(d, dict):
        return
    for key, limit in (("solutions", MAX_RESULT_SOLUTIONS), ("components", MAX_RESULT_COMPONENTS)):
        if isinstance(d.get(key), list) and len(d[key]) > limit:
            raise InputError(f"{where}: {len(d[key])} {key}, more than the limit of {limit} for a picture")
    b = d.get("boxes")
    if isinstance(b, dict):
        for key in ("lo", "hi", "component"):
            if isinstance(b.get(key), list) and len(b[key]) > MAX_RESULT_BOXES:
                raise InputError(f"{where}: boxes.{key}: {len(b[key])} boxes, more than the limit of {MAX_RESULT_BOXES}")
    for c in d.get("components") or []:
        if not isinstance(c, dict):
            continue
        for key in ("samples", "polyline"):
            pts = c.get(key)
            if isinstance(pts, list) and len(pts) > MAX_CURVE_POINTS:
                keep = np.unique(np.linspace(0, len(pts) - 1, MAX_CURVE_POINTS).round().astype(int))
                c[key] = [pts[i] for i in keep]


def _vectors(rows: list, where: str, field: str) -> None:
    """Each of ``rows`` a list of finite numbers (the schema's ``vector``), checked in one pass."""
    for k, row in enumerate(rows):
        if type(row) is not list:
            raise InputError(f"{where}: {field}[{k}]: {_show(row)} is not a list")
        for j, x in enumerate(row):
            if type(x) is not float and type(x) is not int:
                what = "a finite number" if isinstance(x, _NonFinite) else "a number"
                raise InputError(f"{where}: {field}[{k}][{j}]: {_show(x)} is not {what}")


def _check_meaning(d: dict, where: str) -> None:
    """What the schema cannot say: names given once, one length for every configuration, boxes
    with ``lo <= hi`` and one bound per variable, component indices that exist. A constraint
    system's answer (``"kind": "constraints"``) places entities by name, not joint vectors: the
    checks of configurations do not apply to it, those of boxes do."""
    names = d.get("joint_names")
    if names is not None and len(set(names)) != len(names):
        dup = next(s for s in names if names.count(s) > 1)
        raise InputError(f"{where}: joint_names: {dup!r} appears twice")
    size = len(names) if names is not None else None
    comps = d.get("components", [])
    vectors = []
    if d.get("kind") != "constraints":  # else the schema requires "q" and vector samples
        vectors = [(f"solutions[{k}].q", s["q"]) for k, s in enumerate(d.get("solutions", []))]
        vectors += [(f"components[{k}].samples[{j}]", q) for k, c in enumerate(comps) for j, q in enumerate(c.get("samples", []))]
    for what, q in vectors:
        if size is not None and len(q) != size:
            raise InputError(f"{where}: {what}: {len(q)} entries, expected {size} (one per joint)")
        size = len(q)
    b = d.get("boxes")
    if not isinstance(b, dict) or ("lo" not in b and "hi" not in b):
        return
    n_var = len(b.get("variables") or [])
    lo, hi = b.get("lo", []), b.get("hi", [])
    if len(lo) != len(hi):
        raise InputError(f"{where}: boxes.lo has {len(lo)} boxes, boxes.hi {len(hi)}: not the same length")
    for key, rows in (("lo", lo), ("hi", hi)):
        for k, row in enumerate(rows):
            if len(row) != n_var:
                raise InputError(f"{where}: boxes.{key}[{k}]: {len(row)} numbers, expected {n_var} (one per variable)")
    a, z = np.array(lo, dtype=float).reshape(len(lo), n_var), np.array(hi, dtype=float).reshape(len(hi), n_var)
    bad = np.argwhere(a > z)
    if len(bad):
        raise InputError(f"{where}: boxes[{bad[0][0]}]: lo > hi for {b['variables'][bad[0][1]]!r}")
    comp = b.get("component")
    if comp is not None:
        if len(comp) != len(lo):
            raise InputError(f"{where}: boxes.component: {len(comp)} entries for {len(lo)} boxes")
        for k, c in enumerate(comp):
            if not -1 <= c < len(comps):
                raise InputError(f"{where}: boxes.component[{k}]: component {c} does not exist (-1 or 0..{len(comps) - 1})")


def _field(path: Any) -> str:
    out = ""
    for p in path:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out or "the file"


def _show(v: Any) -> str:
    if isinstance(v, _NonFinite):
        return repr(v)
    if isinstance(v, dict):
        return "an object"
    if isinstance(v, list):
        return "a list"
    text = json.dumps(v)
    return text if len(text) <= 40 else text[:37] + "..."


_NOUNS = {
    "number": "a number",
    "integer": "an integer",
    "string": "a string",
    "boolean": "true or false",
    "array": "a list",
    "object": "an object",
    "null": "null",
}


def _explain(err: Any) -> str:
    kind, v = err.validator, err.instance
    if kind == "type":
        if isinstance(v, _NonFinite):
            return f"{v!r} is not a finite number"
        want = err.validator_value if isinstance(err.validator_value, list) else [err.validator_value]
        return f"{_show(v)} is not {' or '.join(_NOUNS.get(str(w), str(w)) for w in want)}"
    if kind == "required":
        missing = [k for k in err.validator_value if isinstance(v, dict) and k not in v]
        return f"missing {missing[0]!r}" if missing else err.message
    if kind == "enum":
        return f"{_show(v)} is not one of {', '.join(json.dumps(x) for x in err.validator_value)}"
    if kind == "minimum":
        return f"{_show(v)} is below {err.validator_value}"
    if kind in ("minItems", "maxItems"):
        return f"{len(v)} entries, expected {'at least' if kind == 'minItems' else 'at most'} {err.validator_value}"
    if kind == "anyOf":
        return f"{_show(v)} is not a number or a list of numbers"
    return err.message if len(err.message) <= 120 else err.message[:117] + "..."


def _restore(v: Any) -> Any:
    if isinstance(v, _NonFinite):
        return v.value()
    if isinstance(v, dict):
        return {k: _restore(x) for k, x in v.items()}
    if isinstance(v, list):
        return [_restore(x) for x in v]
    return v
