"""The answer of a pose on a wrist-singular arm of three parallel axes: its curves in closed form.

:func:`kinbox.search.cf_curve.wrist_curves` gives the curves of the *singular* arm (joint 5 at
its double root, joint 6 the parameter) and proves that every root of the pose lies in its
arcs' enclosures (or in the relaxed enclosures of a joint-1 branch whose wrist is not
singular, which the branch and prune searches). Whether the pose as given *has* those curves
is decided here as the branch and prune's curve boxes decide it
(:meth:`kinbox.search.curvebox.CurveBoxRule.on_curve`), only stricter: every sample, written as
a point of the kinbox system, closes every equation row within :data:`CLOSE` times its slack
(the bound on the row's rounding at a solution), and the Jacobian there is singular to working
precision (tested at every
:data:`RANK_EVERY`-th sample). On UR5 poses with joint 5
at 0 the samples close the rows within 0.016-0.018 of their slacks; with joint 5 at ``e`` (the
pose then has isolated roots) within about ``2e13 e`` of them: 0.2-0.3 at 1e-14 (inside the
goal's own enclosure, radius 1e-14), 2-3 at 1e-13, 20-27 at 1e-12, 10^4 at 1e-9. So a pose
1e-13 or more from the singularity is not taken for a curve: :func:`curve_points` returns None
and the pose goes to the branch and prune as before (whose curve boxes take rows within 100
times their slacks). The closure of every :data:`RESIDUAL_EVERY`-th sample is measured with
Pinocchio (the curve's ``residual``).
``tests/search/test_cf_curve.py`` compares the answers with the branch and prune's.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any, cast

import numpy as np

from ..search.curvebox import CURVE_RANK
from ..search.outcome import Stats
from ..search.results import SolveResult
from ..search.status import Status
from .closed_form import LazyRaw, configurations
from .components import Component
from .result import Curve, Result, applied_limits, max_residual, q_names
from .turns import add_turns

#: the note of :func:`~kinbox.answer.turns.add_turns` and its words on curves
TURNS_NOTE = "joints with a range wider than a turn"
ONE_TURN = "; curves are given over one turn"
#: a sample of a curve closes every equation row of the pose's system within this many times its
#: slack (tests/search/test_cf_curve.py::test_samples_close_the_rows_only_at_the_singularity)
CLOSE = 1.0
#: Pinocchio's closure is measured at every this many samples of a curve (and at its last): the
#: system's rows are checked at every sample (:func:`curve_points`)
RESIDUAL_EVERY = 4
#: the Jacobian's rank is tested at every this many samples (and at each curve's first)
RANK_EVERY = 16


def curve_points(cf, thetas: list[np.ndarray], goal, comp) -> list[np.ndarray] | None:
    """Samples ``thetas`` (each (m, 6): the family's angles) as points of the kinbox system
    (``comp``: the pose's compiled system), or None where one of them is not a point of a curve
    of the pose as given (see the module's text) or the closed form has no template
    certifier."""
    tc = cf.certifier
    if tc is None or tc.n != comp.n:
        return None
    from ..search.closed_form import encode_rows

    P, _ = tc.params(goal.rotation[None], goal.translation[None])
    slack = comp.slack[: comp.n_eq] if len(comp.slack) else np.zeros(comp.n_eq)
    out = []
    for theta in thetas:
        x = np.zeros((len(theta), comp.n))
        encode_rows(theta, P[0], tc.fixed, tc.cvar, tc.svar, tc.shift, tc.def_target, tc.def_start, tc.def_param, tc.def_coef,
                    tc.def_a, tc.def_b, x)  # fmt: skip
        Z = np.hstack([x, x[:, comp.mi] * x[:, comp.mj]])
        F = (comp.A @ Z.T).T[:, : comp.n_eq] + comp.c[: comp.n_eq]
        if not np.all(np.abs(F) <= CLOSE * slack):
            return None
        if comp.n_eq >= comp.n:
            for y in x[::RANK_EVERY]:
                s = np.linalg.svd(comp.jacobian(y, slice(0, comp.n_eq)), compute_uv=False)
                if not (len(s) >= comp.n and s[comp.n - 1] <= CURVE_RANK * max(float(s[0]), 1.0)):
                    return None
        out.append(x)
    return out


def wrist_curve_result(
    cf,
    wc,
    points: list[np.ndarray],
    formulation,
    label: str,
    source: dict,
    rest: Result | None,
    clock: tuple[float, float],
    all_turns: bool = False,
    boxes: Callable[[list[np.ndarray], np.ndarray], list] | None = None,
) -> Result:
    """The answer: the curves of ``wc`` (:func:`curve_points` gave their system ``points``) and
    the isolated roots of ``rest`` (the branch and prune of the other joint-1 branch's
    enclosures, or None where there is none). ``boxes``: each curve's arc enclosures as solver
    boxes of the system (:func:`kinbox.search.cf_curve.curve_boxes` bound to the pose, given a
    curve's enclosures; built on first use where ``rest`` is None), listed after ``rest``'s
    boxes and named by the curve's component."""
    t0, c0 = clock
    mech = formulation.mechanism
    data = mech.model.createData()
    comps: list[Component] = list(rest.components) if rest is not None else []
    curves: dict[int, Curve] = dict(rest.curves) if rest is not None else {}
    n = formulation.system.n
    worst = 0.0
    first = len(rest.raw.boxes) if rest is not None else 0
    spans = []
    for c, x in zip(wc.curves, points):
        spans.append(list(range(first, first + len(c.boxes))))
        first += len(c.boxes)
        Q = configurations(cf, c.theta)
        qs = [Q[k] for k in range(len(Q))]
        r = max(max_residual(mech, q, data) for q in qs[::RESIDUAL_EVERY] + qs[-1:])
        worst = max(worst, r)
        ci = len(comps)
        comps.append(
            Component(1, spans[-1] if boxes is not None else [], False, rank=n - 1, dof=1, polylines=[x], closed=[True], complete=True)
        )
        curves[ci] = Curve(branches=[qs], closed=[True], residual=r, bifurcations=[])
    msg = (
        f"closed form at a wrist singularity: {len(wc.curves)} curve(s) over joint 6 "
        f"({wc.arcs} arcs proven, {wc.fold_regions} fold region(s))"
    )
    if rest is not None:
        msg += f"; the other branch of joint 1 searched: {rest.message}"
    stats: dict[str, Any] = (
        dict(rest.stats) if rest is not None else dict(boxes=0, empty=0, split=0, solutions=0, certified=0, lps=0, krawczyk=0)
    )
    stats.update(
        seconds=time.perf_counter() - t0,
        cpu_seconds=time.process_time() - c0,
        method="closed-form curve",
        family=cf.family.name,
        curve_arcs=wc.arcs,
        fold_regions=wc.fold_regions,
        closed_form_runs=wc.evaluations,
        curve_points=sum(len(x) for x in points),
        curve_enclosures=sum(len(c.boxes) for c in wc.curves),
    )
    if rest is None:
        stats.update(load_seconds=0.0, max_pending=0, unresolved_boxes=0, singular=0, dropped_joints=[], **formulation.system.summary())
    typed = cast(Stats, stats)
    solutions = list(rest.solutions) if rest is not None else []
    if rest is not None:
        raw = rest.raw
        if boxes is not None:
            for c, x in zip(wc.curves, points):
                raw.boxes.extend(boxes(c.boxes, x))
    elif boxes is not None:
        fill = boxes

        def made() -> list:
            return [b for c, x in zip(wc.curves, points) for b in fill(c.boxes, x)]

        raw = LazyRaw(made, formulation, msg, typed)  # type: ignore[assignment]  # a SolveResult on first use
    else:
        raw = SolveResult(Status.COMPLETE, msg, [], [], typed, formulation.system)
    res = Result(
        problem=label,
        joint_names=q_names(mech.model),
        status=Status.COMPLETE,
        message=msg,
        solutions=solutions,
        components=comps,
        stats=typed,
        raw=raw,
        formulated=formulation,
        source=source,
        curves=curves,
        undecided=list(rest.undecided) if rest is not None else [],
        joint_limits=applied_limits(formulation),
        notes=list(rest.notes) if rest is not None else [],
    )
    if rest is None:
        add_turns(res, all_turns)  # the joints that wrap named (a curve is given over one turn)
    else:  # the search's note on the joints that wrap was written before the curves were added
        res.notes = [n + ONE_TURN if n.startswith(TURNS_NOTE) and not n.endswith(ONE_TURN) else n for n in res.notes]
    return res
