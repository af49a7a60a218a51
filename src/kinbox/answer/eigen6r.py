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

import math
import time
from functools import partial
from typing import Any, cast

import numpy as np
import pinocchio as pin

from ..search.eigen6r import EigenSolver, certify, certify_reference
from ..search.loading import load_clock
from ..search.outcome import Stats
from ..search.solver import SolutionBox
from ..search.status import BoxStatus, Status
from .closed_form import ArmFacts, LazyFormulation, LazyRaw, configurations
from .components import Component
from .result import Result, Solution, max_residual
from .turns import add_turns

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
    m = len(roots.theta)
    theta = roots.theta
    x = np.zeros((m, facts.n))
    tc = es.certifier
    if tc is not None and m:
        from ..search.closed_form import encode_rows

        P, _ = tc.params(goal.rotation[None], goal.translation[None])
        encode_rows(theta, P[0], tc.fixed, tc.cvar, tc.svar, tc.shift, tc.def_target, tc.def_start, tc.def_param, tc.def_coef,
                    tc.def_a, tc.def_b, x)  # fmt: skip
    Q = configurations(cast(Any, es), theta)  # reads the joints' idx_q, gamma, limits, q_ref
    widths = np.max(roots.hi - roots.lo, axis=1) if m else np.zeros(0)
    sols = []
    comps = []
    for r in range(m):
        width = float(widths[r])
        sols.append(Solution(Q[r], math.nan, BoxStatus.CERTIFIED, width, x[r], component=r))  # residual below, after the turns
        comps.append(Component(0, [r], True, rank=facts.n, dof=0, point=x[r], width=width))
    stats: dict[str, object] = dict(boxes=0, empty=0, split=0, solutions=m, certified=m, lps=0, krawczyk=m)
    stats.update(
        seconds=time.perf_counter() - t0, cpu_seconds=time.process_time() - c0, load_seconds=clock.seconds, max_pending=0, **facts.summary
    )
    stats.update(method="eigen-6r", certificate="joint angles")
    stats.update(dropped_joints=list(es.arm.dropped_joints), unresolved_boxes=0, singular=0, curve_corrections=0)
    form = LazyFormulation(es.arm, mech, goal)
    res = Result(
        problem=facts.label,
        joint_names=facts.joint_names,
        status=Status.COMPLETE,
        message=MESSAGE,
        solutions=sols,
        components=comps,
        stats=cast(Stats, stats),
        raw=LazyRaw(partial(system_boxes, es, goal), form, MESSAGE, cast(Stats, stats)),  # type: ignore[arg-type]  # a SolveResult on first use
        formulated=form,
        source=source,
        joint_limits=dict(facts.joint_limits),
    )
    add_turns(res, all_turns)  # the residual of each solution it moves or copies
    data = mech.model.createData()
    for s in res.solutions:
        if math.isnan(s.residual):
            s.residual = max_residual(mech, s.q, data)
    return res
