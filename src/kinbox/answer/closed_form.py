"""Answers from a closed form (:mod:`kinbox.search.closed_form`), proven complete, or nothing.

A pose of an arm of a closed-form family is answered here when

1. the closed form, in interval arithmetic, proves its number of roots (every discriminant and
   pivot away from zero) and each root's joint limits (inside or outside, not on a limit), and
2. each root inside the limits is certified by Krawczyk on the kinbox system of the pose (the
   same proof, with the solver's domain and inequality checks, as the branch and prune's:
   :meth:`kinbox.search.solver.BoxProcessor.process` on a small box about the root), and the
   proof boxes are disjoint.

The closed form's roots are then all the roots of the system, each certified, and the answer
is complete (``stats["method"] = "closed-form"``). Otherwise :func:`closed_form_result`
returns None and the pose goes to the branch and prune (``"branch-and-prune"``), which finds
every root whatever the pose (singular roots, curves). ``tests/test_closed_form.py`` compares
both on random poses of each family.
"""

from __future__ import annotations

import time

import numpy as np

from ..search.closed_form import ClosedForm
from ..search.solver import BoxProcessor, SolutionBox, SolveResult, SolverOptions
from .result import Result, build_result

#: half-width of the proof box about a root, relative to ``1 + |x|`` (as the answer stage's
#: proofs of roots the search left uncertified)
PROOF_RADIUS = 1e-9


def certified_boxes(cf: ClosedForm, formulation, goal) -> tuple[list[SolutionBox] | None, dict]:
    """The certified solution boxes of every root of ``goal`` inside the limits, or None where
    the closed form or a proof does not decide (see the module docstring); and counts."""
    R, t = np.asarray(goal.rotation, dtype=float), np.asarray(goal.translation, dtype=float)
    n, enc, inside = cf.roots(R, t)
    info = {"closed_form_roots": int(n)}
    if n < 0 or np.any(inside[:n] < 0):
        return None, info
    system = formulation.system
    proc = None
    boxes: list[SolutionBox] = []
    for k in range(n):
        if inside[k] == 0:
            continue
        if proc is None:
            proc = BoxProcessor(system, SolverOptions(lp=False))
        x = formulation.encode(cf.configuration(enc[k]))
        r = PROOF_RADIUS * (1.0 + np.abs(x))
        o = proc.process(x - r, x + r)
        if o.solution is None or not o.solution.certified:
            return None, info
        boxes.append(o.solution)
    for i in range(len(boxes)):
        for j in range(i):
            a, b = boxes[i], boxes[j]
            if np.all(a.lo <= b.hi) and np.all(b.lo <= a.hi):
                return None, info  # two proofs about one root: not told apart here
    info["outside_limits"] = int(n - len(boxes))
    return boxes, info


def closed_form_result(cf: ClosedForm, formulation, label: str, sigma: float, polish=None, source: dict | None = None) -> Result | None:
    """The complete answer of one pose from the closed form, or None (see the module docstring)."""
    t0 = time.perf_counter()
    boxes, info = certified_boxes(cf, formulation, formulation.goal)
    if boxes is None:
        return None
    stats = {
        "method": "closed-form",
        "family": cf.family.name,
        "boxes": 0,
        "variables": formulation.system.n,
        "closed_form_roots": info["closed_form_roots"],
        "seconds": time.perf_counter() - t0,
    }
    raw = SolveResult(True, True, "closed form: every root proven and certified", boxes, [], stats, formulation.system)
    res = build_result(label, raw, formulation, sigma, polish=polish, source=source)
    res.stats["outside_limits"] = info.get("outside_limits", 0)
    return res
