"""A seven-joint arm's self-motion from a sweep of one end joint (:mod:`kinbox.search.sweep`).

The swept joint's range is cut into slabs. On a *decided* slab the closed form proves the
number of roots of the other six joints for every value ``t`` of the swept joint, each root a
continuous function of ``t``: the self-motion there is exactly those branches, sampled at the
slab's ends and between them (no two samples of a branch more than :data:`STEP` apart in any
joint) and joined branch by branch. On a *relaxed* slab (width at most
:data:`kinbox.search.sweep.MIN_WIDTH`, a fold where two roots meet) every root lies inside the
relaxed enclosures; the samples are joined there by nearest roots after the value where the
count changes is narrowed down to :data:`FOLD_WIDTH` by point evaluations: the roots that go on
are matched across it, the two that meet are joined to each other. Where that matching is not
clear, or a slab is undecided, :func:`sweep_result` returns None and the pose is answered by
the branch and prune. Samples outside a joint's limits are dropped, and where a branch leaves
its limits the crossing is narrowed down to :data:`LIMIT_WIDTH` in ``t``.

Every sample is a root of the six-joint system at its ``t`` and is certified by Krawczyk on it
where the proof succeeds (``stats["certified_points"]``); its closure is measured with
Pinocchio. ``tests/answer/test_selfmotion.py`` compares the curves with the branch and prune's.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any, cast

import numpy as np

from ..search.closed_form import POSE_CLOSED_FORM, ClosedForm
from ..search.outcome import Stats
from ..search.results import SolveResult
from ..search.status import Status
from ..search.sweep import DECIDED, RELAXED, LinearGoal, Slab, solve_points, sweep
from .closed_form import joint_values
from .components import Component
from .result import Curve, Result, applied_limits, q_names

#: largest step between consecutive samples of a branch, in any joint (radians)
STEP = 0.05
#: ... down to this width of ``t``: a branch that turns faster (the arm at a singularity of its
#: seven joints, two axes in line) keeps a longer step there
STEP_WIDTH = 1e-6
#: a change of the root count is narrowed down to this width of ``t``
FOLD_WIDTH = 1e-12
#: roots on either side of a count change closer than this (any joint, radians) are one branch
SAME_BRANCH = 1e-7
#: a branch's crossing of a joint limit is narrowed down to this width of ``t``
LIMIT_WIDTH = 1e-9
#: at most this many rounds of refinement (steps, folds, limits)
ROUNDS = 60
#: prove each decided slab's one root per enclosure between sampled points by default? Off: the
#: proof costs some tens of times the sweep (docs/soundness.md), and the answer says where it is
#: not proven (``stats["slabs_unproven"]``, ``tests/answer/test_selfmotion_proof.py``)
PROVE_SLABS = False


def _angle_gap(a: np.ndarray, b: np.ndarray) -> float:
    d = np.abs(a - b) % (2.0 * math.pi)
    return float(np.max(np.minimum(d, 2.0 * math.pi - d))) if len(d) else 0.0


def _gaps(L: np.ndarray, R: np.ndarray) -> np.ndarray:
    """``[i, j]``: the largest angle between root ``L[i]`` and root ``R[j]`` over the joints."""
    d = np.abs(L[:, None, :] - R[None, :, :]) % (2.0 * math.pi)
    return np.minimum(d, 2.0 * math.pi - d).max(axis=2) if L.size and R.size else np.zeros((len(L), len(R)))


class _Samples:
    """Roots at sample values of ``t``: ``roots[t]`` an array (count, 6) of canonical angles."""

    def __init__(self, cf: ClosedForm, goal: LinearGoal):
        self.cf, self.goal = cf, goal
        self.roots: dict[float, np.ndarray] = {}
        #: values where the point evaluation is not decided (on a fold, to the rounding)
        self.failed: set[float] = set()
        self.evaluations = 0

    def add(self, ts) -> None:
        ts = sorted({float(t) for t in ts if float(t) not in self.roots and float(t) not in self.failed})
        if not ts:
            return
        b = solve_points(self.cf, self.goal, np.array(ts), certify=False)
        self.evaluations += len(ts)
        for k, t in enumerate(ts):
            if b.status[k] == POSE_CLOSED_FORM:
                self.roots[t] = b.theta[b.first[k] : b.first[k] + b.count[k]]
            else:  # not decided at this point (on a fold to the rounding): no sample here
                self.failed.add(t)


def _matching(L: np.ndarray, R: np.ndarray) -> tuple[list[tuple[int, int]], list[tuple[int, int]], list[tuple[int, int]]] | None:
    """Across a count change: pairs (left, right) of one branch (closer than
    :data:`SAME_BRANCH`, or with equal counts clearly nearer than any other root on either
    side; mutually nearest), and the roots left over on each side paired to each other
    (mutually nearest: the two roots of a fold), or None if that is not clear."""
    D = _gaps(L, R)
    lr = []
    used_r: set[int] = set()
    for i in range(len(L)):
        if not len(R):
            break
        j = int(np.argmin(D[i]))
        if int(np.argmin(D[:, j])) != i or j in used_r:
            continue
        others = np.concatenate([np.delete(D[i], j), np.delete(D[:, j], i)])
        second = float(others.min()) if others.size else math.inf
        if D[i, j] <= SAME_BRANCH or (len(L) == len(R) and D[i, j] < 0.25 * second):
            lr.append((i, j))
            used_r.add(j)
    used_l = {i for i, _ in lr}
    rest_l = [i for i in range(len(L)) if i not in used_l]
    rest_r = [j for j in range(len(R)) if j not in used_r]

    def pairs(X: np.ndarray, idx: list[int]) -> list[tuple[int, int]] | None:
        if len(idx) % 2:
            return None
        G = _gaps(X[idx], X[idx])
        np.fill_diagonal(G, math.inf)
        out = []
        for a in range(len(idx)):
            b = int(np.argmin(G[a]))
            if int(np.argmin(G[b])) != a:  # not mutually nearest
                return None
            if a < b:
                out.append((idx[a], idx[b]))
        return out

    pl, pr = pairs(L, rest_l), pairs(R, rest_r)
    if pl is None or pr is None:
        return None
    return lr, pl, pr


def sweep_result(
    cf: ClosedForm,
    goal: LinearGoal,
    swept,  # the swept joint: a ChainJoint-like (idx_q, lo, hi)
    formulation,
    label: str,
    sigma: float,
    source: dict,
    residual: Callable[[np.ndarray], float],
    polish: Callable[[np.ndarray], np.ndarray] | None = None,
    prove_slabs: bool | None = None,
) -> Result | None:
    """The self-motion of one pose (see the module docstring), or None. ``prove_slabs``: prove
    each decided slab's one root per enclosure for every ``t`` (:mod:`kinbox.search.slab_proof`);
    the decided slabs where that is not proven are counted in ``stats["slabs_unproven"]``
    (None: :data:`PROVE_SLABS`)."""
    t0, c0 = time.perf_counter(), time.process_time()
    lo, hi = float(swept.lo), float(swept.hi)
    slabs, runs = sweep(cf, goal, lo, hi, prove=PROVE_SLABS if prove_slabs is None else prove_slabs)
    if any(s.kind not in (DECIDED, RELAXED) for s in slabs):
        return None
    smp = _Samples(cf, goal)
    bounds = sorted({s.a for s in slabs} | {s.b for s in slabs})
    inner = [s.a + (s.b - s.a) * k / 8.0 for s in slabs if s.kind == RELAXED for k in range(1, 8)]
    smp.add(bounds + inner)

    def slab_of(a: float, b: float) -> Slab:
        m = 0.5 * (a + b)
        k = int(np.searchsorted(starts, m, side="right")) - 1
        return slabs[max(k, 0)]

    starts = np.array([s.a for s in slabs])
    order = np.argsort(cf.idx_q)
    jl, jh = cf.lo[order], cf.hi[order]
    limited = np.array([(not cf.unbounded[i]) and math.isfinite(cf.lo[i]) and math.isfinite(cf.hi[i]) for i in order])
    values: dict[float, np.ndarray] = {}
    within: dict[float, np.ndarray] = {}

    def look(t: float) -> None:
        if t not in values:
            v = joint_values(cf, smp.roots[t])[0] if len(smp.roots[t]) else np.zeros((0, 6))
            values[t] = v
            within[t] = np.all(~limited | ((v >= jl) & (v <= jh)), axis=1)

    Decision = tuple[bool, list[tuple[int, int]] | None, list[tuple[int, int]], list[tuple[int, int]]]

    def decide(a: float, b: float) -> Decision:
        """Between two consecutive samples: (split it?, links, fold pairs at a, at b); links
        None where the samples cannot be joined (split, or fail if too narrow)."""
        L, R = smp.roots[a], smp.roots[b]
        look(a)
        look(b)
        if slab_of(a, b).kind == DECIDED and len(L) == len(R):
            gap = float(np.max(_gaps(L, R).diagonal(), initial=0.0))
            cross = bool(np.any(within[a] != within[b]))
            return (gap > STEP and b - a > STEP_WIDTH) or (cross and b - a > LIMIT_WIDTH), [(k, k) for k in range(len(L))], [], []
        m = _matching(L, R)
        wide = b - a > FOLD_WIDTH and 0.5 * (a + b) not in smp.failed
        if m is None or (wide and (len(L) != len(R) or m[1] or m[2])):
            return wide, None, [], []
        lr, pl, pr = m
        gap = max((_angle_gap(L[i], R[j]) for i, j in lr), default=0.0)
        return gap > STEP and wide and b - a > STEP_WIDTH, lr, pl, pr

    decided: dict[tuple[float, float], Decision] = {}
    # refine: branch steps and limit crossings in decided slabs, count changes elsewhere
    links: dict[tuple[float, float], list[tuple[int, int]]] = {}
    folds: list[tuple[float, int, int]] = []
    for _ in range(ROUNDS):
        ts = sorted(smp.roots)
        new = []
        links.clear()
        folds.clear()
        failed = False
        for a, b in zip(ts, ts[1:]):
            if (a, b) not in decided or (decided[(a, b)][0] and 0.5 * (a + b) in smp.failed):
                decided[(a, b)] = decide(a, b)
            split, lr, pl, pr = decided[(a, b)]
            if split:
                new.append(0.5 * (a + b))
            if lr is None:
                failed = failed or not split
                continue
            links[(a, b)] = lr
            folds.extend((a, i, k) for i, k in pl)
            folds.extend((b, j, k) for j, k in pr)
        if failed:
            return None
        if not new:
            break
        smp.add(new)
    else:
        return None
    # nodes, edges, components
    ts = sorted(smp.roots)
    ok = {(t, k) for t in ts for k in range(len(smp.roots[t])) if within[t][k]}
    adj: dict[tuple[float, int], list[tuple[float, int]]] = {n: [] for n in ok}

    def link(u, v):
        if u in ok and v in ok and v not in adj[u]:
            adj[u].append(v)
            adj[v].append(u)

    for (a, b), pairs in links.items():
        for i, j in pairs:
            link((a, i), (b, j))
    for t, i, k in folds:
        link((t, i), (t, k))
    if any(len(v) > 2 for v in adj.values()):
        return None
    polylines: list[tuple[list[tuple[float, int]], bool]] = []
    seen: set[tuple[float, int]] = set()
    for start in sorted(ok, key=lambda n: (len(adj[n]) != 1, n)):
        if start in seen:
            continue
        path = [start]
        seen.add(start)
        prev, cur = None, start
        while True:
            nxt = [v for v in adj[cur] if v != prev and v not in seen]
            if not nxt:
                break
            prev, cur = cur, nxt[0]
            path.append(cur)
            seen.add(cur)
        closed = len(path) > 2 and start in adj[cur]
        if len(path) >= 2:
            polylines.append((path, closed))
    # certify the samples on curves (Krawczyk on the six-joint system at each t)
    on_curve = sorted({t for p, _ in polylines for t, _k in p})
    cert = solve_points(cf, goal, np.array(on_curve), certify=True) if on_curve else None
    proven = {t: bool(cert.status[k] == POSE_CLOSED_FORM and cert.certified) for k, t in enumerate(on_curve)} if cert else {}
    q0 = np.asarray(cf.q_ref, dtype=float)
    names = [cf.joints[i] for i in order]

    def config(t: float, k: int) -> np.ndarray:
        from ..formulation.arm import put_angle

        q = q0.copy()
        for c, j in enumerate(names):
            put_angle(q, j, values[t][k][c])
        q[swept.idx_q] = t
        return polish(q) if polish is not None else q

    comps: list[Component] = []
    curves: dict[int, Curve] = {}
    worst = 0.0
    n_cert = 0
    for path, closed in sorted(polylines, key=lambda p: -len(p[0])):
        qs = [config(t, k) for t, k in path]
        r = max(residual(q) for q in qs)
        worst = max(worst, r)
        certified = all(proven.get(t, False) for t, _ in path)
        n_cert += sum(proven.get(t, False) for t, _ in path)
        ci = len(comps)
        comps.append(
            Component(1, [], certified, rank=formulation.system.n - 1, dof=1, polylines=[np.array(qs)], closed=[closed], complete=True)
        )
        curves[ci] = Curve(branches=[qs], closed=[closed], residual=r, bifurcations=[])
    n_points = sum(len(p) for p, _ in polylines)
    stats: dict[str, Any] = dict(boxes=0, empty=0, split=0, solutions=0, certified=0, lps=0, krawczyk=len(on_curve))
    stats.update(
        seconds=time.perf_counter() - t0,
        cpu_seconds=time.process_time() - c0,
        load_seconds=0.0,
        max_pending=0,
        method="sweep",
        family=cf.family.name,
        swept_joint=swept.name,
        slabs=len(slabs),
        fold_slabs=sum(s.kind == RELAXED for s in slabs),
        slabs_proven=sum(s.kind == DECIDED and s.proven for s in slabs),
        slabs_unproven=sum(s.kind == DECIDED and not s.proven for s in slabs),
        closed_form_runs=runs,
        point_evaluations=smp.evaluations,
        curve_points=n_points,
        certified_points=n_cert,
        unresolved_boxes=0,
        singular=0,
        dropped_joints=[],
        **formulation.system.summary(),
    )
    msg = (
        f"sweep of {swept.name}: {len(slabs)} slabs proven by the closed form "
        f"({stats['fold_slabs']} at folds, bounded by relaxed enclosures)"
        + (f"; one root per enclosure between samples not proven on {stats['slabs_unproven']}" if stats["slabs_unproven"] else "")
    )
    typed = cast(Stats, stats)
    raw = SolveResult(Status.COMPLETE, msg, [], [], typed, formulation.system)
    mech = formulation.mechanism
    return Result(
        problem=label,
        joint_names=q_names(mech.model),
        status=Status.COMPLETE,
        message=msg,
        solutions=[],
        components=comps,
        stats=typed,
        raw=raw,
        formulated=formulation,
        source=source,
        curves=curves,
        undecided=[],
        joint_limits=applied_limits(formulation),
    )
