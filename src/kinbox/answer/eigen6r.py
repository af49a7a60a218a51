"""Answers of general 6R arms from the eigenvalue path (:mod:`kinbox.search.eigen6r`), proven
complete, or nothing.

A pose is answered here when

1. the eigenvalue proof holds (16 roots of the elimination's polynomial in disjoint discs, the
   real ones in discs symmetric about the real axis: every real solution's ``x3 = tan(t3 / 2)``
   is the eigenvalue of one of them, and each stands for at most one solution), and
2. each real eigenvalue's solution is certified by Krawczyk on the kinbox system of the pose
   (the arm formulation's, compiled as the closed form's: :func:`kinbox.search.eigen6r.certify`),
   its proof box inside the system's domain and its ``x3`` inside that eigenvalue's disc, the
   proof boxes disjoint, and its joint-limit rows proven to hold or to fail (a root on a limit
   is undecided).

Every real solution is then one of the certified roots, and the answer is complete
(``stats["method"] = "eigen-6r"``). Otherwise :func:`eigen_result` returns None and the pose
goes to the branch and prune (``"branch-and-prune"``). ``tests/search/test_eigen6r.py``
compares both.
"""

from __future__ import annotations

import time
from typing import cast

from ..search.eigen6r import EigenSolver, certify
from ..search.loading import load_clock
from ..search.outcome import Stats
from ..search.solver import SolutionBox, SolveResult
from ..search.status import BoxStatus, Status
from .result import Result, build_result
from .turns import add_turns


def certified_boxes(es: EigenSolver, formulation) -> list[SolutionBox] | None:
    """The certified solution boxes of the pose of ``formulation`` (module docstring), or None."""
    goal = formulation.goal
    cert = certify(es, goal.rotation, goal.translation)
    if cert is None:
        return None
    return [
        SolutionBox(
            cert.lo[m].copy(),
            cert.hi[m].copy(),
            cert.x[m].copy(),
            BoxStatus.CERTIFIED,
            float(cert.residual[m]),
            (cert.lo[m].copy(), cert.hi[m].copy()),
        )
        for m in range(len(cert.x))
    ]


def eigen_result(
    es: EigenSolver, formulation, label: str, sigma: float, polish=None, source: dict | None = None, all_turns: bool = False
) -> Result | None:
    """The complete answer of the pose of ``formulation`` from the eigenvalue path, or None."""
    t0, c0 = time.perf_counter(), time.process_time()
    with load_clock() as clock:
        boxes = certified_boxes(es, formulation)
    if boxes is None:
        return None
    stats: dict[str, object] = dict(boxes=0, empty=0, split=0, solutions=len(boxes), certified=len(boxes), lps=0, krawczyk=len(boxes))
    stats.update(
        seconds=time.perf_counter() - t0,
        cpu_seconds=time.process_time() - c0,
        load_seconds=clock.seconds,
        max_pending=0,
        **formulation.system.summary(),
    )
    stats.update(method="eigen-6r")
    raw = SolveResult(Status.COMPLETE, "eigenvalues: every root proven and certified", boxes, [], cast(Stats, stats), formulation.system)
    res = build_result(label, raw, formulation, sigma, polish=polish, source=source)
    add_turns(res, all_turns)
    return res
