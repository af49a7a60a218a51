"""A solution box: what the search returns for each part of the solution set it finished."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .status import BoxStatus


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
    #: what the box is known to hold: exactly one root, proven (certified); a piece of a curve
    #: (:mod:`kinbox.search.curvebox`: the search stopped on it because its zeros looked like a
    #: piece of a curve, whatever its width); within the core rows' resolution of a root; or
    #: nothing proven (uncertified)
    status: BoxStatus
    residual: float
    enclosure: tuple[np.ndarray, np.ndarray]
    #: for a box accepted within the core rows' resolution of a root
    #: (:meth:`kinbox.search.accept.Acceptance.below_floor`): that root, as Newton reached it;
    #: nothing in the box can be told apart from it
    within_resolution_of: np.ndarray | None = None

    def __post_init__(self) -> None:
        self.status = BoxStatus(self.status)

    @property
    def certified(self) -> bool:
        """Exactly one root in the box, proven (Krawczyk)."""
        return self.status is BoxStatus.CERTIFIED

    @property
    def curve(self) -> bool:
        """A curve box (:mod:`kinbox.search.curvebox`)."""
        return self.status is BoxStatus.CURVE

    @property
    def width(self) -> float:
        return float(np.max(self.enclosure[1] - self.enclosure[0], initial=0.0))
