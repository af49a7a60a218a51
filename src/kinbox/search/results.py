"""What a search returns: solution boxes, the outcome of one box, the raw search result."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..formulation.system import System
from .policy import Events
from .status import Status

if TYPE_CHECKING:
    from .state import SearchState


@dataclass
class SolutionBox:
    """A box returned by the solver.

    ``lo``/``hi`` is the box the solver finished (for a certified box: the region proven to
    hold exactly one solution); ``enclosure`` is the tightest box known to hold it; ``x`` a
    polished point; ``residual`` the max absolute equation value at ``x``.
    """

    lo: np.ndarray
    hi: np.ndarray
    x: np.ndarray
    certified: bool
    residual: float
    enclosure: tuple[np.ndarray, np.ndarray]
    #: for a box accepted within the core rows' resolution of a root
    #: (:meth:`kinbox.search.accept.Acceptance.below_floor`): that root, as Newton reached it;
    #: nothing in the box can be told apart from it
    within_resolution_of: np.ndarray | None = None
    #: a curve box (:mod:`kinbox.search.curvebox`): the search stopped on it because its zeros
    #: looked like a piece of a curve, whatever its width (narrowed after the test, it can end
    #: below sigma, like a box accepted beside a root)
    curve: bool = False

    @property
    def width(self) -> float:
        return float(np.max(self.enclosure[1] - self.enclosure[0], initial=0.0))


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
