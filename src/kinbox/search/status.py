"""Why a search stopped: one enum for the raw search result (:class:`kinbox.search.results.SolveResult`).

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
