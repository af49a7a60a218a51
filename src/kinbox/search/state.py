"""A search stopped between two boxes, and going on with it (``kinbox ... --save/--resume``).

The search runs in waves under a :class:`~kinbox.search.policy.Policy` made from counts
(:mod:`kinbox.search.waves`), so where it stands is small and exact:

* ``rest``: the boxes of the current wave not processed yet, in order, with their
  :class:`~kinbox.search.policy.Hint`;
* ``nxt``: the children of the processed boxes of the wave, in order (the next wave so far);
* ``policy`` and ``events``: the wave's policy and the counts of its processed boxes;
* ``boxes`` and ``stats``: what the :class:`~kinbox.search.collector.Collector` gathered.

A search given this state (``resume=``) processes exactly the boxes the stopped one would have
processed next, under the same policies: it makes the same tree, the same counts and the same
answer as a search that never stopped.

The file is a NumPy ``.npz`` archive (uncompressed, read with ``allow_pickle=False``: loading
one runs no code) holding the arrays and a JSON header. The header carries a fingerprint of the
polynomial system and the options that shape the tree (:data:`~kinbox.search.options.TREE_OPTIONS`,
derived from the options' marks): a state is only resumed on the problem it was saved from, under
the same values of those options.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..formulation.system import System
from .boxes import SolutionBox
from .options import TREE_OPTIONS, tree_options
from .policy import Events, Hint, Policy
from .statefile import check_header, read_npz, typed_fields, write_replacing
from .status import BoxStatus

__all__ = ["FORMAT", "TREE_OPTIONS", "VERSION", "SearchState", "fingerprint", "tree_options"]

FORMAT = "kinbox-search-state"
VERSION = 1


def fingerprint(system: System) -> str:
    """A digest of the compiled system (variables, domain, rows, slacks)."""
    comp = system.compile()
    h = hashlib.sha256()
    h.update(json.dumps(list(system.names)).encode())
    A = comp.A
    for a in (*system.search_domain(), comp.mi, comp.mj, A.indptr, A.indices, A.data, comp.c, comp.slack):
        arr = np.ascontiguousarray(a)
        h.update(str(arr.dtype).encode() + str(arr.shape).encode())
        h.update(arr.tobytes())
    h.update(f"{comp.n_core},{comp.n_eq}".encode())
    return h.hexdigest()


#: tree options added since states were first saved, with the value every earlier search had (a
#: tree option missing from a saved state and not here is unknown: the state is not resumed)
_BEFORE = {"policy": "steady", "extra_steps": ""}


@dataclass
class SearchState:
    """Where a search stands between two boxes (see the module docstring)."""

    rest: list  # (lo, hi, Hint)
    nxt: list  # (lo, hi, Hint)
    policy: Policy
    events: Events
    boxes: list  # SolutionBox
    stats: dict[str, Any]
    fingerprint: str
    options: dict[str, Any]
    names: list[str]

    @property
    def pending(self) -> list[tuple[np.ndarray, np.ndarray]]:
        return [(lo, hi) for lo, hi, _ in self.rest] + [(lo, hi) for lo, hi, _ in self.nxt]

    def check(self, system: System, options) -> None:
        """Raise :class:`InputError` unless this state belongs to ``system`` solved with ``options``."""
        if self.fingerprint != fingerprint(system):
            raise InputError(
                "the saved search is of another problem (its equations differ): resume it with "
                "the command, robot, frame, pose and --set/--lock values it was saved with"
            )
        now = tree_options(options)
        saved = {**_BEFORE, **self.options}
        diff = [
            f"{k} {saved[k]!r} (now {now[k]!r})" if k in saved else f"{k} not recorded (now {now[k]!r})"
            for k in TREE_OPTIONS
            if k not in saved or saved[k] != now[k]
        ]
        if diff:
            raise InputError("the saved search used other solver options: " + ", ".join(diff))

    # -- files -----------------------------------------------------------------------------------
    def save(self, path: str | os.PathLike) -> Path:
        """Write the state to ``path`` (an ``.npz`` archive; written to a temporary file first,
        then renamed, so an interrupted save leaves the previous file whole)."""
        path = Path(path)
        n = len(self.names)
        bases: dict[int, int] = {}
        cols: list[np.ndarray] = []
        rows: list[np.ndarray] = []

        def pack(items):
            lo = np.array([b[0] for b in items], dtype=float).reshape(-1, n)
            hi = np.array([b[1] for b in items], dtype=float).reshape(-1, n)
            ids = np.array([b[2].id for b in items], dtype=np.uint64)
            bidx = np.full(len(items), -1, dtype=np.int64)
            for k, (_, _, hint) in enumerate(items):
                if hint.basis is not None:
                    key = id(hint.basis)
                    if key not in bases:
                        bases[key] = len(cols)
                        cols.append(np.asarray(hint.basis[0], dtype=np.int8))
                        rows.append(np.asarray(hint.basis[1], dtype=np.int8))
                    bidx[k] = bases[key]
            return lo, hi, ids, bidx

        arrays: dict[str, np.ndarray] = {}
        for part in ("rest", "nxt"):
            lo, hi, ids, bidx = pack(getattr(self, part))
            arrays.update({f"{part}_lo": lo, f"{part}_hi": hi, f"{part}_id": ids, f"{part}_basis": bidx})
        arrays["basis_col"] = np.concatenate(cols) if cols else np.zeros(0, np.int8)
        arrays["basis_row"] = np.concatenate(rows) if rows else np.zeros(0, np.int8)
        arrays["basis_col_off"] = np.cumsum([0] + [len(c) for c in cols]).astype(np.int64)
        arrays["basis_row_off"] = np.cumsum([0] + [len(r) for r in rows]).astype(np.int64)
        sb = self.boxes
        arrays["sol_lo"] = np.array([b.lo for b in sb], dtype=float).reshape(-1, n)
        arrays["sol_hi"] = np.array([b.hi for b in sb], dtype=float).reshape(-1, n)
        arrays["sol_x"] = np.array([b.x for b in sb], dtype=float).reshape(-1, n)
        arrays["sol_elo"] = np.array([b.enclosure[0] for b in sb], dtype=float).reshape(-1, n)
        arrays["sol_ehi"] = np.array([b.enclosure[1] for b in sb], dtype=float).reshape(-1, n)
        arrays["sol_certified"] = np.array([b.certified for b in sb], dtype=bool)
        arrays["sol_residual"] = np.array([b.residual for b in sb], dtype=float)
        # NaN rows: boxes not accepted within a root's resolution
        arrays["sol_root"] = np.array(
            [b.within_resolution_of if b.within_resolution_of is not None else np.full(n, np.nan) for b in sb], dtype=float
        ).reshape(-1, n)
        arrays["sol_curve"] = np.array([b.curve for b in sb], dtype=bool)
        header = {
            "format": FORMAT,
            "version": VERSION,
            "fingerprint": self.fingerprint,
            "options": self.options,
            "names": list(self.names),
            "policy": self.policy.to_dict(),
            "events": dataclasses.asdict(self.events),
            "stats": _plain(self.stats),
        }
        arrays["header"] = np.array(json.dumps(header))
        return write_replacing(path, lambda f: np.savez(f, allow_pickle=False, **arrays), "the search state")

    @classmethod
    def load(cls, path: str | os.PathLike) -> SearchState:
        """Read a state written by :meth:`save`; a file that is not one raises :class:`InputError`."""
        where = f"search state {str(path)!r}"
        a = read_npz(path, where)  # budgets, types and shapes before reading: statefile.py
        try:
            header = check_header(str(a["header"]), where)
            if header.get("format") != FORMAT:
                raise ValueError("not a kinbox search state")
            if header.get("version") != VERSION:
                raise ValueError(f"version {header.get('version')} (this kinbox reads version {VERSION})")
            names = [str(s) for s in header["names"]]
            n = len(names)
            # a policy saved by an older kinbox may hold rules since removed: left out
            policy = Policy.from_dict(typed_fields(Policy, header["policy"], where))
            events = Events.from_dict(typed_fields(Events, header["events"], where))
            cols, rows = a["basis_col"], a["basis_row"]
            coff, roff = a["basis_col_off"], a["basis_row_off"]
            nb = len(coff) - 1
            if len(roff) != nb + 1 or nb < 0:
                raise ValueError("basis offsets disagree")
            bases = [(cols[coff[k] : coff[k + 1]].copy(), rows[roff[k] : roff[k + 1]].copy()) for k in range(nb)]

            def unpack(part):
                lo, hi, ids, bidx = (a[f"{part}_{s}"] for s in ("lo", "hi", "id", "basis"))
                m = len(ids)
                if lo.shape != (m, n) or hi.shape != (m, n) or bidx.shape != (m,):
                    raise ValueError(f"{part}: arrays of the wrong shape")
                if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(lo <= hi)):
                    raise ValueError(f"{part}: a box is not a finite box")
                if np.any(bidx < -1) or np.any(bidx >= nb):
                    raise ValueError(f"{part}: a basis index is out of range")
                return [(lo[k].copy(), hi[k].copy(), Hint(int(ids[k]), bases[bidx[k]] if bidx[k] >= 0 else None)) for k in range(m)]

            rest, nxt = unpack("rest"), unpack("nxt")
            m = len(a["sol_certified"])
            shapes = [a[f"sol_{s}"].shape for s in ("lo", "hi", "x", "elo", "ehi")]
            if any(s != (m, n) for s in shapes) or a["sol_residual"].shape != (m,):
                raise ValueError("solution boxes: arrays of the wrong shape")
            roots = a["sol_root"].copy() if "sol_root" in a else np.full((m, n), np.nan)
            if "sol_curve" in a:
                curve = a["sol_curve"].copy()
            else:  # written before curve boxes were flagged: they were its uncertified boxes wider
                # than sigma (the search returned no other such boxes then)
                sigma = float(header["options"].get("sigma", 0.0))
                curve = (np.max(a["sol_hi"] - a["sol_lo"], axis=1, initial=0.0) > sigma) & ~a["sol_certified"]
            if roots.shape != (m, n) or curve.shape != (m,):
                raise ValueError("solution boxes: arrays of the wrong shape")
            boxes = [
                SolutionBox(
                    a["sol_lo"][k].copy(),
                    a["sol_hi"][k].copy(),
                    a["sol_x"][k].copy(),
                    _box_status(bool(a["sol_certified"][k]), bool(curve[k]), bool(np.all(np.isfinite(roots[k])))),
                    float(a["sol_residual"][k]),
                    (a["sol_elo"][k].copy(), a["sol_ehi"][k].copy()),
                    roots[k] if np.all(np.isfinite(roots[k])) else None,
                )
                for k in range(m)
            ]
            stats = dict(header["stats"])
        except (KeyError, TypeError, ValueError, IndexError) as e:
            raise InputError(f"{where} is damaged or not a kinbox search state: {e}") from None
        return cls(
            rest=rest,
            nxt=nxt,
            policy=policy,
            events=events,
            boxes=boxes,
            stats=stats,
            fingerprint=str(header["fingerprint"]),
            options=dict(header["options"]),
            names=names,
        )


def _plain(d: dict) -> dict:
    """The JSON-safe part of a stats dict (numbers, strings, lists of them)."""
    out: dict[str, Any] = {}
    for k, v in d.items():
        if isinstance(v, (bool, int, float, str)) or v is None:
            out[k] = v
        elif isinstance(v, (np.integer, np.floating)):
            out[k] = v.item()
        elif isinstance(v, (list, tuple)) and all(isinstance(x, (int, float, str)) for x in v):
            out[k] = list(v)
    return out


def _box_status(certified: bool, curve: bool, near_root: bool) -> BoxStatus:
    """A saved solution box's status from the flags the state file keeps (certified first,
    then curve, within resolution, uncertified)."""
    if certified:
        return BoxStatus.CERTIFIED
    if curve:
        return BoxStatus.CURVE
    return BoxStatus.WITHIN_RESOLUTION if near_root else BoxStatus.UNCERTIFIED
