"""What a search returns: solution boxes, the outcome of one box, the raw search result."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..formulation.system import System
from .boxes import SolutionBox
from .outcome import Outcome, Stats
from .policy import Events
from .state import SearchState
from .status import Status

__all__ = ["BoxOutcome", "SolutionBox", "SolveResult"]


@dataclass
class BoxOutcome:
    """What processing one box gave: ``kind`` is "empty", "solution", "split" or "unfinished"
    (a deadline passed inside the box: ``children`` holds the box, to be explored later).
    ``children`` are ``(lo, hi, hint)``."""

    kind: str
    solution: SolutionBox | None = None
    children: list = field(default_factory=list)
    lps: int = 0
    krawczyk: int = 0
    events: Events = field(default_factory=Events)


@dataclass(repr=False)
class SolveResult(Outcome):
    """Outcome of :func:`~kinbox.search.solver.solve_system` (:class:`~kinbox.search.outcome.Outcome`:
    ``status``, ``complete``, ``message``, ``stats``, ``to_json``, ``table``): the solution
    boxes, which enclose every solution when the search is complete, and the boxes left
    (``pending``) when it is not."""

    status: Status
    message: str
    boxes: list[SolutionBox]
    pending: list[tuple[np.ndarray, np.ndarray]]
    stats: Stats
    system: System
    #: where an incomplete search stopped, to go on with it (``resume=``); None when complete
    state: SearchState | None = None

    def __post_init__(self) -> None:
        self.status = Status(self.status)

    @property
    def certified(self) -> list[SolutionBox]:
        return [b for b in self.boxes if b.certified]

    def to_dict(self) -> dict:
        """The boxes (bounds, point, status) and the counts, as JSON types."""
        return {
            "status": self.status.value,
            "complete": self.complete,
            "message": self.message,
            "variables": list(self.system.names),
            "boxes": [
                {"lo": b.lo.tolist(), "hi": b.hi.tolist(), "x": b.x.tolist(), "status": b.status.value, "residual": float(b.residual)}
                for b in self.boxes
            ],
            "pending": len(self.pending),
            "stats": dict(self.stats),
        }

    def table(self) -> str:
        counts: dict[str, int] = {}
        for b in self.boxes:
            counts[b.status.value] = counts.get(b.status.value, 0) + 1
        st = self.stats
        kinds = ", ".join(f"{n} {k}" for k, n in counts.items()) or "none"
        return (
            f"{len(self.boxes)} solution box(es) ({kinds}); {self.completeness()}; "
            f"{st.get('boxes')} boxes processed, {st.get('lps')} LPs, {st.get('seconds', 0.0):.3f} s"
            + (f"; {len(self.pending)} box(es) left" if self.pending else "")
        )

    def __repr__(self) -> str:
        return (
            f"SolveResult(status={self.status.value!r}, complete={self.complete}, "
            f"boxes={len(self.boxes)}, certified={len(self.certified)}, "
            f"message={self.message!r})"
        )
