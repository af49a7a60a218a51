"""Why a search stopped (:class:`Status`, shared by every result: :mod:`kinbox.search.outcome`) and
what a solution box holds (:class:`BoxStatus`).

The values are strings (``Status.BOX_BUDGET == "box budget"``), so JSON writes them as they are
and a comparison with the string works.
"""

from __future__ import annotations

from enum import Enum


class Status(str, Enum):
    """How a search ended: every box explored, or the reason it stopped with boxes left."""

    COMPLETE = "complete"
    BOX_BUDGET = "box budget"
    TIME_LIMIT = "time limit"
    MEMORY_BUDGET = "memory budget"
    INTERRUPTED = "interrupted"
    WORKERS_LOST = "workers lost"

    def __str__(self) -> str:
        return self.value

    @property
    def complete(self) -> bool:
        return self is Status.COMPLETE


class BoxStatus(str, Enum):
    """What a solution box of a search is known to hold (:attr:`kinbox.search.boxes.SolutionBox.status`)."""

    #: exactly one root, proven (Krawczyk)
    CERTIFIED = "certified"
    #: a piece of a curve of solutions (:mod:`kinbox.search.curvebox`), returned whatever its width
    CURVE = "curve"
    #: within the core rows' resolution of a root that Newton reached: nothing in it can be told apart from that root
    WITHIN_RESOLUTION = "within resolution"
    #: narrower than sigma with no proof either way (a singular root, a piece of a curve at resolution, or nothing)
    UNCERTIFIED = "uncertified"

    def __str__(self) -> str:
        return self.value
