"""The collector of a search: solution boxes (duplicates merged) and the counts of the tree."""

from __future__ import annotations

from typing import Any

import numpy as np

from .certify import Certifier
from .results import BoxOutcome, SolutionBox

#: two certified enclosures are tried as one root when their hull is at most this wide
#: (relative to 1 + the largest magnitude of its lower corner)
SAME_HULL = 1e-6
#: the hull is widened to at least this (relative to 1 + |centre|) for the proof
SAME_PAD = 1e-12


class Collector:
    """Gathers outcomes: solution boxes (with de-duplication) and statistics.

    Two certified boxes hold the same solution when one's enclosure lies in the other's
    uniqueness box, or (a root on the face between two sibling boxes, certified in both) when
    Krawczyk proves a single zero in the small hull of both enclosures.
    """

    def __init__(self, certifier: Certifier | None = None):
        self.cert = certifier
        self.boxes: list[SolutionBox] = []
        self.stats: dict[str, Any] = dict(
            boxes=0, empty=0, split=0, solutions=0, certified=0, lps=0, krawczyk=0, seconds=0.0, cpu_seconds=0.0, max_pending=1
        )

    def add(self, o: BoxOutcome) -> None:
        st = self.stats
        st["boxes"] += 1
        st["lps"] += o.lps
        st["krawczyk"] += o.krawczyk
        if o.kind == "empty":
            st["empty"] += 1
        elif o.kind == "split":
            st["split"] += 1
        elif o.kind == "unfinished":
            st["boxes"] -= 1  # handed back: it will be processed (and counted) again
        elif o.solution is not None:
            self.record(o.solution)

    def record(self, sol: SolutionBox) -> None:
        if sol.certified:
            for o in self.boxes:
                if o.certified and self._same(sol, o):
                    return
        self.boxes.append(sol)
        self.stats["solutions"] += 1
        self.stats["certified"] += int(sol.certified)

    def _same(self, a: SolutionBox, b: SolutionBox) -> bool:
        if _inside(a.enclosure, (b.lo, b.hi)) or _inside(b.enclosure, (a.lo, a.hi)):
            return True  # a's root lies in b's uniqueness box: it is b's root
        if self.cert is None:
            return False
        hlo = np.minimum(a.enclosure[0], b.enclosure[0])
        hhi = np.maximum(a.enclosure[1], b.enclosure[1])
        if np.max(hhi - hlo) > SAME_HULL * (1.0 + np.max(np.abs(hlo))):
            return False
        c = 0.5 * (hlo + hhi)
        r = np.maximum(hhi - hlo, SAME_PAD * (1.0 + np.abs(c)))
        # both roots lie in [c - r, c + r]; a unique zero there makes them one
        return self.cert.krawczyk(c - r, c + r).status == "unique"


def _inside(inner, outer) -> bool:
    return bool(np.all(inner[0] >= outer[0]) and np.all(inner[1] <= outer[1]))
