"""What a replay shows, in order: the isolated solutions, then each curve component as a motion.

A result (a :class:`~kinbox.answer.result.Result` or its JSON dict) becomes a list of
:class:`Group`: one group of isolated configurations (each held for a while), then one group per
component of dimension >= 1 whose configurations are *ordered along the component*, so that
stepping through them moves the mechanism along it. The order is the component's ``polyline``
when the result has one (ordered and checked with Pinocchio by the answer stage), else its
``samples`` chained by nearest neighbours (:func:`order_along_curve`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from ..errors import InputError


@dataclass
class Group:
    """Configurations shown together: isolated solutions (``curve`` False) or the ordered
    configurations of one component (``curve`` True, shown as a motion)."""

    head: str  # "" for the isolated solutions, else "component 2 of 3 (dimension 1)"
    qs: list[np.ndarray]
    curve: bool
    #: per configuration, what a scene says of it (kinbox.viz.obstacles.verdict_notes), or []
    notes: list[str] = field(default_factory=list)

    def labels(self) -> list[str]:
        n = len(self.qs)
        if not self.curve:
            out = [f"solution {k + 1} of {n}" for k in range(n)]
        else:
            out = [f"{self.head}, point {k + 1} of {n}" for k in range(n)]
        if len(self.notes) == n:
            out = [f"{a} \u2014 {b}" if b else a for a, b in zip(out, self.notes)]
        return out


def _vector(q: Any, what: str) -> np.ndarray:
    try:
        v = np.asarray(q, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{what}: q is not a list of numbers") from None
    if v.ndim != 1:
        raise InputError(f"{what}: q is not a list of numbers")
    return v


def result_dict(result: Any) -> dict:
    """The parts of a result a replay needs, as in its JSON (``Result.to_dict``) but without the
    boxes: ``problem``, ``source``, ``solutions[].q``, ``components[]`` with ``dimension`` and
    their ``polyline`` or ``samples``. A dict is returned as it is."""
    if isinstance(result, dict):
        return result
    if getattr(result, "scene", None):  # checked against a scene: its verdicts are shown too
        return {k: v for k, v in result.to_dict().items() if k != "boxes"}
    comps = []
    curves = getattr(result, "curves", None) or {}
    for i, c in enumerate(result.components):
        cv = curves.get(i)
        d: dict = {"dimension": int(c.dimension), "samples": list(cv.samples()) if cv is not None else []}
        if cv is not None:
            d["polyline"] = list(cv.polyline)
        comps.append(d)
    return {"problem": result.problem, "source": result.source, "solutions": [{"q": s.q} for s in result.solutions], "components": comps}


def groups(d: dict, nq: int, name: str, features: Callable[[np.ndarray], np.ndarray]) -> list[Group]:
    """The groups of a result dict (see the module docstring); every ``q`` is checked to have
    ``nq`` finite entries (``name``: the mechanism, for the message). ``features(q)``: the
    vector that measures closeness of configurations for :func:`order_along_curve`."""

    def checked(qs: Sequence, what: str) -> list[np.ndarray]:
        out = []
        for k, q in enumerate(qs):
            v = _vector(q, f"{what} {k + 1}")
            if v.shape != (nq,) or not np.all(np.isfinite(v)):
                raise InputError(f"{what} {k + 1}: q must be {nq} finite numbers for {name!r}, got {v.size}")
            out.append(v)
        return out

    try:
        out = [Group("", checked([s["q"] for s in d.get("solutions") or []], "solution"), False)]
        curves = [c for c in d.get("components") or [] if int(c.get("dimension", 0)) >= 1]
        for n, c in enumerate(curves):
            head = f"component {n + 1} of {len(curves)} (dimension {int(c['dimension'])})"
            if c.get("polyline"):
                out.append(Group(head, checked(c["polyline"], head + ", point"), True))
                continue
            qs = checked(c.get("samples") or [], head + ", point")
            order = order_along_curve([features(q) for q in qs])
            out.append(Group(head, [qs[i] for i in order], True))
    except (KeyError, TypeError, AttributeError, ValueError) as e:
        raise InputError(f"malformed result: solutions need 'q', components 'dimension' ({e!r})") from None
    if d.get("scene"):
        from .obstacles import verdict_notes

        sols, per_curve = verdict_notes(d)
        out[0].notes = sols
        for n, g in enumerate(out[1:]):
            g.notes = per_curve.get(n, [])
    return out


def order_along_curve(points: Sequence[np.ndarray]) -> list[int]:
    """Indices of ``points`` (one feature vector each) in order along the curve they sample.

    A nearest-neighbour chain started at one end (the point farthest from the first point,
    then the point farthest from that one): good for the evenly spread samples of a curve; a
    closed curve is walked around once. Neighbours come from a k-d tree (``scipy.spatial``).
    """
    n = len(points)
    if n <= 2:
        return list(range(n))
    X = np.array([np.ravel(p) for p in points], dtype=float)
    start = int(np.argmax(np.linalg.norm(X - X[0], axis=1)))
    start = int(np.argmax(np.linalg.norm(X - X[start], axis=1)))
    tree = cKDTree(X)
    seen = np.zeros(n, dtype=bool)
    order = [start]
    seen[start] = True
    for _ in range(n - 1):
        cur = X[order[-1]]
        nxt = -1
        k = min(n, 16)
        while nxt < 0:  # ask for more neighbours until one is not yet visited
            _, idx = tree.query(cur, k=k)
            free = [int(i) for i in np.atleast_1d(idx) if i < n and not seen[i]]
            if free:
                nxt = free[0]
            elif k >= n:  # pragma: no cover - some point is always left while the loop runs
                break
            k = min(n, 4 * k)
        order.append(nxt)
        seen[nxt] = True
    return order


# -- timing ------------------------------------------------------------------------------------
FPS = 30  # frames per second of the HTML page's animation

#: a curve component is swept in this many delays unless told otherwise
SWEEP_DELAYS = 5.0


def _seconds(v: Any, what: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and v > 0):
        raise InputError(f"{what} must be a positive number of seconds, got {v!r}")
    return float(v)


def timeline(shown: Sequence[Group], delay: float, sweep: float | None = None) -> list[tuple[float, bool]]:
    """(seconds on screen, held) for every configuration of ``shown``, in order: an isolated
    solution is held ``delay`` seconds; the configurations of a curve component are passed
    through in ``sweep`` seconds in all (default ``SWEEP_DELAYS * delay``), as one motion."""
    delay = _seconds(delay, "delay")
    sweep = SWEEP_DELAYS * delay if sweep is None else _seconds(sweep, "sweep")
    out: list[tuple[float, bool]] = []
    for g in shown:
        if g.curve:
            out += [(sweep / max(len(g.qs), 1), False)] * len(g.qs)
        else:
            out += [(delay, True)] * len(g.qs)
    return out
