"""The base of every kinbox result, in the manner of ``scipy.optimize.OptimizeResult``.

:class:`Outcome` is shared by the raw search result (:class:`kinbox.search.results.SolveResult`),
the joint-space answer (:class:`kinbox.answer.result.Result`, what :func:`kinbox.ik` and
:func:`kinbox.solve` return) and the constraint-system answer
(:class:`kinbox.answer.assembly.AssemblyResult`): each has

* ``status``: why the search ended, one :class:`~kinbox.search.status.Status` (complete, box
  budget, time limit, memory budget, interrupted, workers lost);
* ``complete``: every box was explored (``status is Status.COMPLETE``), so the answer holds
  every solution; ``success`` is the same (scipy's name);
* ``message``: the same in words;
* ``stats``: the counts of the run (:class:`Stats`);
* ``to_dict()`` (what ``--json`` prints), ``to_json()`` and ``table()`` (what the command line
  prints; also ``str(result)``).

Every solution box of a search has one :class:`BoxStatus` (certified, curve, within resolution,
uncertified): :attr:`kinbox.search.boxes.SolutionBox.status`
(tests/answer/test_resultfile.py::test_result_family_shares_one_status).
"""

from __future__ import annotations

import json
from typing import Any, TypedDict

from .status import BoxStatus, Status

__all__ = ["BoxStatus", "Outcome", "Stats", "Status"]


class Stats(TypedDict, total=False):
    """The counts of a run (``result.stats``; a plain dict in JSON). Keys present depend on the
    problem; every search writes the first group."""

    #: boxes processed, of them proven empty, split; LPs solved; Krawczyk tests run
    boxes: int
    empty: int
    split: int
    lps: int
    krawczyk: int
    #: solution boxes returned, of them certified (one proven root each)
    solutions: int
    certified: int
    #: the largest number of boxes waiting at once; waves of the parallel runners
    max_pending: int
    waves: int
    #: parallel runs (:mod:`kinbox.search.parallel`): the backend, workers asked for and started,
    #: batches sent, workers restarted after a loss
    backend: str
    workers: int
    worker_processes: int
    batches: int
    worker_restarts: int
    #: wall-clock and CPU seconds of the search, and the part of them loading compiled kernels
    seconds: float
    cpu_seconds: float
    load_seconds: float
    master_cpu_seconds: float
    #: the system's size (:meth:`kinbox.formulation.system.System.summary`)
    variables: int
    equations: int
    core_equations: int
    redundant_equations: int
    inequalities: int
    #: curve boxes the answer found on no curve, searched again down to sigma
    curve_boxes_searched_again: int
    #: answer stage (joint space): isolated solutions, of them singular; solutions outside the
    #: joint limits; boxes holding no solution found; corrections of traced curves; joints the
    #: formulation left out; how the answer was found ("closed form" or "branch-and-prune")
    singular: int
    outside_limits: int
    unresolved_boxes: int
    curve_corrections: int
    dropped_joints: list[str]
    method: str
    #: where the branch and prune searched, if not the whole domain: ``{"closed-form
    #: enclosures": n}``, the n boxes of :mod:`kinbox.search.cf_fallback`
    searched: dict[str, int]
    #: the closed form's arm family (:mod:`kinbox.formulation.families`)
    family: str
    #: how a fast answer's roots were certified: "joint angles" (:mod:`kinbox.search.cf_certify`),
    #: "system, from Newton's point" (:mod:`kinbox.search.cf_seeded`)
    certificate: str
    #: answer stage (constraint systems): candidates that failed the constraints; distance
    #: solutions with no embedding in 3-D
    spurious: int
    not_embeddable: int
    #: near-double pairs reported as two certified roots instead of one point
    #: (:mod:`kinbox.answer.separate`)
    separated: int
    #: roots of the general formulation proven in the joint angles (:mod:`kinbox.answer.angle_proof`)
    proven_in_angles: int
    #: a scene's verdicts (:mod:`kinbox.answer.collision`)
    collision: dict[str, Any]


class Outcome:
    """The fields and methods every kinbox result shares (see the module's text). Subclasses
    are dataclasses that declare ``status``, ``message`` and ``stats`` and write
    :meth:`to_dict` and :meth:`table`."""

    status: Status
    message: str
    stats: Stats

    @property
    def complete(self) -> bool:
        """Every box was explored: the answer holds every solution."""
        return self.status is Status.COMPLETE

    @property
    def success(self) -> bool:
        """The same as :attr:`complete` (the name ``scipy.optimize`` uses)."""
        return self.complete

    def completeness(self) -> str:
        """``complete (message)`` or ``INCOMPLETE (message)``: how every table says it."""
        return f"{'complete' if self.complete else 'INCOMPLETE'} ({self.message})"

    def to_dict(self) -> dict:
        raise NotImplementedError

    def table(self) -> str:
        raise NotImplementedError

    def to_json(self, indent: int | None = 1) -> str:
        """:meth:`to_dict` as JSON text (what ``--json`` prints, with ``indent=None``)."""
        return json.dumps(self.to_dict(), indent=indent)

    def __str__(self) -> str:
        return self.table()
