"""What a search returns: solution boxes, the outcome of one box, the raw search result."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..formulation.system import System
from .boxes import SolutionBox
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


@dataclass
class SolveResult:
    """Outcome of :func:`~kinbox.search.solver.solve_system`, in the style of
    ``scipy.optimize.OptimizeResult``: ``status`` says why the search ended
    (:class:`~kinbox.search.status.Status`), ``complete`` whether every box was explored,
    ``message`` the same in words."""

    status: Status
    message: str
    boxes: list[SolutionBox]
    pending: list[tuple[np.ndarray, np.ndarray]]
    stats: dict
    system: System
    #: where an incomplete search stopped, to go on with it (``resume=``); None when complete
    state: SearchState | None = None

    def __post_init__(self) -> None:
        self.status = Status(self.status)

    @property
    def complete(self) -> bool:
        """Every box was explored: the boxes enclose every solution."""
        return self.status is Status.COMPLETE

    @property
    def success(self) -> bool:
        """The same as :attr:`complete` (the name ``scipy.optimize`` uses)."""
        return self.complete

    @property
    def certified(self) -> list[SolutionBox]:
        return [b for b in self.boxes if b.certified]

    def __repr__(self) -> str:
        return (
            f"SolveResult(status={self.status.value!r}, complete={self.complete}, "
            f"boxes={len(self.boxes)}, certified={len(self.certified)}, "
            f"message={self.message!r})"
        )
