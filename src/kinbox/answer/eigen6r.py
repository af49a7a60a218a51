"""Answers of general 6R arms from the eigenvalue path (:mod:`kinbox.search.eigen6r`), proven
complete, or nothing.

A pose is answered here when

1. the eigenvalue proof holds (16 roots of the elimination's polynomial in disjoint discs, the
   real ones in discs symmetric about the real axis: every real solution's ``x3 = tan(t3 / 2)``
   is the eigenvalue of one of them, and each stands for at most one solution), and
2. each real eigenvalue's solution is certified by Krawczyk in the six joint angles on the pose
   as given (:mod:`kinbox.search.cf_certify`, as the closed form's batch does), its ``x3``
   inside that eigenvalue's disc (so the proof boxes are disjoint), and its joint-limit rows
   proven to hold or to fail (a root on a limit is undecided).

Every real solution is then one of the certified roots, and the answer is complete
(``stats["method"] = "eigen-6r"``). Otherwise :func:`fast_result` returns None and the pose
goes to the branch and prune (``"branch-and-prune"``). ``tests/search/test_eigen6r.py``
compares both.

The answer is built as the closed form's fast answer is
(:func:`kinbox.answer.closed_form.fast_result`): each solution's ``q`` from its angles, checked
with Pinocchio's forward kinematics; the bound system and the solver-style record (boxes in the
system's variables, certified on the kinbox system by :func:`kinbox.search.eigen6r.certify_reference`)
only if asked for.
"""

from __future__ import annotations

import time
from functools import partial
from typing import Any, cast

import numpy as np
import pinocchio as pin

from ..search.eigen6r import EigenSolver, certify, certify_reference
from ..search.loading import load_clock
from ..search.solver import SolutionBox
from ..search.status import BoxStatus
from .closed_form import ArmFacts, certified_answer
from .result import Result

MESSAGE = "eigenvalues: every root proven and certified"


def system_boxes(es: EigenSolver, goal: pin.SE3) -> list[SolutionBox]:
    """The roots of ``goal`` certified on the kinbox system (the eigenvalue proof in numpy,
    then Krawczyk on the system), as solver boxes; empty where that proof does not hold."""
    cert = certify_reference(es, goal.rotation, goal.translation)
    if cert is None:
        return []
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


def fast_result(
    es: EigenSolver, facts: ArmFacts, mech, goal: pin.SE3, V: np.ndarray, source: dict, all_turns: bool = False
) -> Result | None:
    """The complete answer of one pose from the eigenvalue path (module docstring), or None
    (the pose goes to the branch and prune). A solution's ``width`` is that of its proof box
    in the joint angles; ``x`` its point in the system's variables."""
    t0, c0 = time.perf_counter(), time.process_time()
    with load_clock() as clock:  # the kernels' loading, once per process, reported apart
        roots = certify(es, goal.rotation, goal.translation, V)
    if roots is None:
        return None
    widths = np.max(roots.hi - roots.lo, axis=1) if len(roots.theta) else np.zeros(0)
    stats = dict(method="eigen-6r", certificate="joint angles")
    boxes = partial(system_boxes, es, goal)
    # configurations() reads the joints' idx_q, gamma, limits, q_ref of the eigenvalue solver
    return certified_answer(cast(Any, es), es.arm, facts, mech, goal, roots.theta, widths, stats, MESSAGE, boxes, source, all_turns,
                            (t0, c0, clock.seconds))  # fmt: skip
