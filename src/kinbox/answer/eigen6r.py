"""Answers of general 6R arms from the eigenvalue path (:mod:`kinbox.search.eigen6r`), proven
complete, or nothing.

A pose is answered here when

1. the eigenvalue proof holds (16 roots of the elimination's polynomial in disjoint discs, the
   real ones in discs symmetric about the real axis: every real solution's ``x3 = tan(t3 / 2)``
   is the eigenvalue of one of them, and each stands for at most one solution), and
2. each real eigenvalue's solution is certified by Krawczyk on the kinbox system of the pose
   (the search's own test, :meth:`kinbox.search.certify.Certifier.krawczyk`), its proof box's
   ``x3`` inside that eigenvalue's disc, the proof boxes disjoint, and its place in the system's
   domain and inequality rows (joint limits) decided as the search's acceptance decides it
   (inside: a solution; outside: beyond a joint limit; across a bound: undecided).

Every real solution is then one of the certified roots, and the answer is complete
(``stats["method"] = "eigen-6r"``). Otherwise :func:`eigen_result` returns None and the pose
goes to the branch and prune (``"branch-and-prune"``). ``tests/search/test_eigen6r.py``
compares both.
"""

from __future__ import annotations

import time

import numpy as np

from ..formulation.arm import _is_var, put_angle, var_index
from ..search.certify import Certifier
from ..search.eigen6r import EigenSolver, x3_enclosure
from ..search.loading import load_clock
from ..search.propagate import Propagator
from ..search.solver import SolutionBox, SolveResult
from ..search.status import Status
from .result import Result, build_result
from .turns import add_turns

#: half-width of a root's proof box, relative to ``1 + |x|`` (the search's
#: :data:`kinbox.search.accept.PROOF_RADIUS` is 1e-8; the eigenvalue discs are 1e-7 wide)
PROOF_RADIUS = 1e-9


def _angle_vars(arm, i: int) -> tuple[int, int] | None:
    """The system variables ``(c, s)`` of joint ``i``'s canonical angle, or None."""
    angles = getattr(arm, "angles", None)
    if angles is not None:  # the invariants template: joints 1..5
        return tuple(angles[i]) if i < len(angles) else None
    jv = arm.jvars[i]
    if jv.c is None or jv.s is None or not (_is_var(jv.c) and _is_var(jv.s)):
        return None
    return var_index(jv.c), var_index(jv.s)


def certified_boxes(es: EigenSolver, formulation) -> list[SolutionBox] | None:
    """The certified solution boxes of the pose of ``formulation`` (module docstring), or None."""
    goal = formulation.goal
    cand = es.candidates(goal.rotation, goal.translation)
    if cand is None:
        return None
    cs = _angle_vars(es.arm, 2)
    if cs is None:
        return None
    system = formulation.system
    comp = system.compile()
    cert = Certifier(comp)
    prop = Propagator(comp) if comp.A.shape[0] > comp.n_eq else None  # inequality rows: joint limits
    if not cert.square:
        return None
    lo0, hi0 = system.search_domain()
    geom = es.arm.geometry
    out: list[SolutionBox] = []
    proofs: list[tuple[np.ndarray, np.ndarray]] = []
    for k in range(len(cand.centre)):
        q = geom.chain.q_ref.copy()
        for j, th, gam in zip(geom.chain.joints, cand.theta[k], geom.gamma):
            put_angle(q, j, float(th - gam))
        x = cert.newton(formulation.encode(q), iters=4)
        w = PROOF_RADIUS * (1.0 + np.abs(x))
        r = cert.krawczyk(x - w, x + w, x)
        if r.status != "unique":
            return None
        enc = x3_enclosure(r.lo[cs[0]], r.hi[cs[0]], r.lo[cs[1]], r.hi[cs[1]])
        c, rad = float(cand.centre[k]), float(cand.radius[k])
        if enc is None or not (c - rad < enc[0] and enc[1] < c + rad):
            return None
        for plo, phi in proofs:
            if not (np.any(plo > r.hi) or np.any(r.lo > phi)):
                return None
        proofs.append((r.lo, r.hi))
        elo, ehi = cert.tighten(r.lo, r.hi)
        if np.any(ehi < lo0) or np.any(elo > hi0):
            continue  # the root lies outside the domain: beyond a joint limit
        if not (np.all(elo >= lo0) and np.all(ehi <= hi0)):
            return None  # on a bound of the domain: undecided
        if prop is not None:  # as the search's acceptance (kinbox.search.accept.Acceptance.certified)
            rlo, rhi = prop.eval_rows(elo, ehi)
            tol = comp.slack[comp.n_eq :]
            if np.any(rlo[comp.n_eq :] > tol):
                continue  # the root violates an inequality: beyond a joint limit
            if not np.all(rhi[comp.n_eq :] <= tol):
                return None  # on a limit: undecided
        res = float(np.max(np.abs(comp.eval_eqs(x)), initial=0.0))
        out.append(SolutionBox(r.lo.copy(), r.hi.copy(), x, True, res, (elo, ehi)))
    return out


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
    raw = SolveResult(Status.COMPLETE, "eigenvalues: every root proven and certified", boxes, [], stats, formulation.system)
    res = build_result(label, raw, formulation, sigma, polish=polish, source=source)
    add_turns(res, all_turns)
    return res
