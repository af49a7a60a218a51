"""Answers from a closed form (:mod:`kinbox.search.closed_form`), proven complete, or nothing.

A pose of an arm of a closed-form family is answered here when

1. the closed form, in interval arithmetic, proves its number of roots (every discriminant and
   pivot away from zero) and each root's joint limits (inside or outside, not on a limit), and
2. each root inside the limits is certified by Krawczyk on the kinbox system of the pose (the
   search's own test, :func:`kinbox.search.certify._krawczyk_full`, on a small box about the
   root, compiled with the binding of the pose), inside the system's domain, and the proof
   boxes are disjoint.

The closed form's roots are then all the roots of the system, each certified, and the answer
is complete (``stats["method"] = "closed-form"``). Otherwise :func:`closed_form_result`
returns None and the pose goes to the branch and prune (``"branch-and-prune"``), which finds
every root whatever the pose (singular roots, curves). ``tests/test_closed_form.py`` compares
both on random poses of each family.
"""

from __future__ import annotations

import time

import numpy as np

from dataclasses import dataclass

from ..search.closed_form import POSE_CLOSED_FORM, Batch, ClosedForm, run_batch
from ..search.solver import SolutionBox, SolveResult
from .result import Result, build_result


def boxes_of(batch: Batch, k: int) -> list[SolutionBox] | None:
    """The certified solution boxes of pose ``k`` of a batch, or None (the pose falls back)."""
    if batch.status[k] != POSE_CLOSED_FORM or not batch.certified:
        return None
    out = []
    for m in range(batch.first[k], batch.first[k] + batch.count[k]):
        lo, hi = batch.lo[m].copy(), batch.hi[m].copy()
        out.append(SolutionBox(lo, hi, batch.x[m].copy(), True, float(batch.residual[m]), (lo.copy(), hi.copy())))
    return out


def closed_form_result(
    cf: ClosedForm,
    formulation,
    label: str,
    sigma: float,
    polish=None,
    source: dict | None = None,
    batch: Batch | None = None,
    k: int = 0,
) -> Result | None:
    """The complete answer of one pose from the closed form (pose ``k`` of ``batch`` if given,
    else ``formulation.goal`` solved now), or None (see the module docstring)."""
    t0 = time.perf_counter()
    if batch is None:
        goal = formulation.goal
        batch = run_batch(cf, cf.certifier, goal.rotation[None], goal.translation[None])
        k = 0
    boxes = boxes_of(batch, k)
    if boxes is None:
        return None
    stats = {
        "method": "closed-form",
        "family": cf.family.name,
        "boxes": 0,
        "variables": formulation.system.n,
        "seconds": time.perf_counter() - t0,
    }
    raw = SolveResult(True, True, "closed form: every root proven and certified", boxes, [], stats, formulation.system)
    return build_result(label, raw, formulation, sigma, polish=polish, source=source)


@dataclass
class BatchAnswer:
    """Every solution of a batch of poses as flat arrays: the solutions of pose ``k`` are rows
    ``first[k] : first[k] + count[k]`` of ``q`` (joint values of the chain's moving joints, in
    model order: :attr:`joints`), ``certified`` and ``singular``. ``method[k]``: ``"closed-form"``
    or ``"branch-and-prune"`` (a pose the closed form did not decide: near a singularity, a
    root on a joint limit); ``complete[k]``; ``curves[k]``: curves of solutions of pose ``k``
    (the branch and prune's; their points are not in ``q``)."""

    joints: list[str]
    first: np.ndarray
    count: np.ndarray
    q: np.ndarray
    certified: np.ndarray
    singular: np.ndarray
    method: list[str]
    complete: np.ndarray
    curves: np.ndarray

    def solutions(self, k: int) -> np.ndarray:
        return self.q[self.first[k] : self.first[k] + self.count[k]]

    def to_dict(self) -> dict:
        return {
            "joints": self.joints,
            "first": self.first.tolist(),
            "count": self.count.tolist(),
            "q": self.q.tolist(),
            "certified": self.certified.tolist(),
            "singular": self.singular.tolist(),
            "method": self.method,
            "complete": self.complete.tolist(),
            "curves": self.curves.tolist(),
        }


def joint_values(cf: ClosedForm, theta: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """Joint values (model order) of canonical angles (rows of ``theta``): each moved by a
    multiple of 2 pi into its limits if narrower than a turn, else into ``(-pi, pi]``."""
    order = np.argsort(cf.idx_q)
    q = theta - cf.gamma
    for i, j in enumerate(cf.joints):
        a = q[:, i]
        if np.isfinite(j.lo) and np.isfinite(j.hi) and not j.unbounded and j.hi - j.lo < 2 * np.pi:
            mid = 0.5 * (j.lo + j.hi)
            q[:, i] = a + 2 * np.pi * np.round((mid - a) / (2 * np.pi))
        else:
            r = np.remainder(a + np.pi, 2 * np.pi) - np.pi
            q[:, i] = np.where(r <= -np.pi, np.pi, r)
    return q[:, order], [cf.joints[i].name for i in order]


def solve_array(cf: ClosedForm, R: np.ndarray, t: np.ndarray, fallback, certify: bool = True) -> BatchAnswer:
    """Every solution of goals ``(R, t)`` ((N, 3, 3), (N, 3)): the compiled closed form for
    the poses it decides (:func:`kinbox.search.closed_form.run_batch`; ``certify``: each root
    also by Krawczyk on the kinbox system), ``fallback(k)`` (a :class:`Result`) for the others."""
    batch = run_batch(cf, cf.certifier if certify else None, R, t)
    N = len(batch.status)
    qf, names = joint_values(cf, batch.theta)
    ok = batch.status == POSE_CLOSED_FORM
    method = ["closed-form" if o else "branch-and-prune" for o in ok]
    complete = ok.copy()
    curves = np.zeros(N, dtype=np.int64)
    count = np.where(ok, batch.count, 0)
    parts_q = [qf]
    parts_c = [np.ones(len(qf), dtype=bool)]
    parts_s = [np.zeros(len(qf), dtype=bool)]
    extra_first = {}
    m = len(qf)
    idx = [cf.joints[i].idx_q for i in np.argsort(cf.idx_q)]
    for k in np.flatnonzero(~ok):
        res = fallback(int(k))
        complete[k] = res.complete
        curves[k] = len(res.curves)
        if res.solutions:
            parts_q.append(np.array([[s.q[i] for i in idx] for s in res.solutions]))
            parts_c.append(np.array([s.certified for s in res.solutions]))
            parts_s.append(np.array([s.singular for s in res.solutions]))
        extra_first[int(k)] = m
        count[k] = len(res.solutions)
        m += len(res.solutions)
    first = batch.first.copy()
    for k, f in extra_first.items():
        first[k] = f
    return BatchAnswer(
        names, first, count, np.concatenate(parts_q).reshape(-1, 6), np.concatenate(parts_c), np.concatenate(parts_s),
        method, complete, curves,
    )  # fmt: skip
