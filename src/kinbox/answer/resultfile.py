"""Result files: the JSON that ``kinbox ik/solve --json`` and ``Result.to_dict()`` write, read back
(for ``kinbox replay`` and ``kinbox plot``)."""

from __future__ import annotations

import os
from pathlib import Path

from ..errors import InputError, read_json


def load_result(path: str | os.PathLike) -> dict:
    """The JSON object of a result file, checked; ``_dir`` is set to the file's folder (a
    mechanism file named in its ``source`` may be relative to it)."""
    p = Path(path)
    d = read_json(p, InputError, "result file")
    if not isinstance(d, dict) or "solutions" not in d or "source" not in d:
        raise InputError(f"{str(path)!r} is not a kinbox result (no 'solutions' / 'source'); "
                         "make one with `kinbox ik ... --json` or `kinbox solve ... --json`")
    d.setdefault("_dir", str(p.resolve().parent))
    return d
