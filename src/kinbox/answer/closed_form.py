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
every root whatever the pose (singular roots, curves). ``tests/search/test_closed_form.py`` compares
both on random poses of each family.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import cast

import numpy as np
import pinocchio as pin

from ..errors import InputError
from ..search import jit as nb
from ..search.cf_batch import run_batch
from ..search.closed_form import POSE_CLOSED_FORM, Batch, ClosedForm
from ..search.loading import load_clock
from ..search.outcome import Stats
from ..search.solver import SolutionBox, SolveResult
from ..search.status import BoxStatus, Status
from .components import Component
from .result import Result, Solution, build_result, max_residual
from .turns import add_turns


def boxes_of(batch: Batch, k: int) -> list[SolutionBox] | None:
    """The certified solution boxes of pose ``k`` of a batch, or None (the pose falls back)."""
    if batch.status[k] != POSE_CLOSED_FORM or batch.certificate != "system":
        return None
    out = []
    for m in range(batch.first[k], batch.first[k] + batch.count[k]):
        lo, hi = batch.lo[m].copy(), batch.hi[m].copy()
        out.append(SolutionBox(lo, hi, batch.x[m].copy(), BoxStatus.CERTIFIED, float(batch.residual[m]), (lo.copy(), hi.copy())))
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
    all_turns: bool = False,
) -> Result | None:
    """The complete answer of one pose from the closed form (pose ``k`` of ``batch`` if given,
    else ``formulation.goal`` solved now), or None (see the module docstring). Joints wider
    than a turn are handled as in a search's answer (:func:`kinbox.answer.turns.add_turns`)."""
    t0, c0 = time.perf_counter(), time.process_time()
    load = 0.0
    if batch is None:
        goal = formulation.goal
        with load_clock() as clock:  # the kernels' loading, once per process, reported apart
            batch = run_batch(cf, cf.certifier, goal.rotation[None], goal.translation[None])
        load = clock.seconds
        k = 0
    boxes = boxes_of(batch, k)
    if boxes is None:
        return None
    seconds = time.perf_counter() - t0
    # the keys of a search's stats (kinbox.search.solver.Collector), for the same JSON: no box
    stats: dict[str, object] = dict(boxes=0, empty=0, split=0, solutions=len(boxes), certified=len(boxes), lps=0, krawczyk=len(boxes))
    stats.update(seconds=seconds, cpu_seconds=time.process_time() - c0, load_seconds=load, max_pending=0, **formulation.system.summary())
    stats.update(method="closed-form", family=cf.family.name)
    raw = SolveResult(Status.COMPLETE, "closed form: every root proven and certified", boxes, [], cast(Stats, stats), formulation.system)
    res = build_result(label, raw, formulation, sigma, polish=polish, source=source)
    add_turns(res, all_turns)
    return res


@dataclass
class BatchAnswer:
    """Every solution of a batch of poses as flat arrays: the solutions of pose ``k`` are rows
    ``first[k] : first[k] + count[k]`` of ``q`` (joint values of the chain's moving joints, in
    model order: :attr:`joints`; angles for continuous joints), ``certified`` and ``singular``. ``method[k]``: ``"closed-form"``
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
    multiple of 2 pi into its limits if narrower than a turn, else into ``(-pi, pi]`` (as
    :func:`kinbox.formulation.pairs.wrap_angle`)."""
    order = getattr(cf, "model_order", None)  # kept by a ClosedForm; the eigenvalue path's solver has none
    if order is None:
        order = np.argsort(cf.idx_q)
        names = [cf.joints[i].name for i in order]
    else:
        names = list(cf.model_names)
    out = np.empty((theta.shape[0], 6))
    _wrap(theta, cf.gamma, cf.lo, cf.hi, cf.unbounded, order, out)
    return out, names


def configurations(cf: ClosedForm, theta: np.ndarray) -> np.ndarray:
    """Pinocchio ``q`` of each row of canonical angles (the chain's joints by
    :func:`joint_values`, continuous joints as (cos, sin), locked joints at their values)."""
    qf, _ = joint_values(cf, theta)
    order = np.argsort(cf.idx_q)
    Q = np.tile(cf.q_ref, (len(theta), 1))
    for c, i in enumerate(order):
        j = cf.joints[i]
        if j.unbounded:
            Q[:, j.idx_q] = np.cos(qf[:, c])
            Q[:, j.idx_q + 1] = np.sin(qf[:, c])
        else:
            Q[:, j.idx_q] = qf[:, c]
    return Q


@nb.njit(cache=True)
def _wrap(theta, gamma, lo, hi, unbounded, order, out):
    two_pi = 2.0 * math.pi
    for m in range(theta.shape[0]):
        for c in range(6):
            i = order[c]
            a = theta[m, i] - gamma[i]
            if (not unbounded[i]) and math.isfinite(lo[i]) and math.isfinite(hi[i]) and hi[i] - lo[i] < two_pi:
                mid = 0.5 * (lo[i] + hi[i])
                out[m, c] = a + two_pi * np.round((mid - a) / two_pi)
            else:
                r = a - two_pi * np.round(a / two_pi)
                out[m, c] = math.pi if r <= -math.pi else r


def solve_array(
    cf: ClosedForm, R: np.ndarray, t: np.ndarray, fallback, certify: bool | str = True, V: np.ndarray | None = None
) -> BatchAnswer:
    """Every solution of goals ``(R, t)`` ((N, 3, 3), (N, 3); ``V`` their XYZQUAT, the poses as
    given): the compiled closed form for the poses it decides
    (:func:`kinbox.search.cf_batch.run_batch`), ``fallback(k)`` (a :class:`Result`) for the
    others. ``certify``: each root also by Krawczyk in the joint angles (True, ``"joint"``) or
    on the kinbox system (``"system"``); False: the interval closed form is the only proof."""
    mode = "joint" if certify is True else (certify or "none")
    batch = run_batch(cf, cf.certifier, R, t, V=V, certificate=mode)
    N = len(batch.status)
    qf, names = joint_values(cf, batch.theta)
    ok = batch.status == POSE_CLOSED_FORM
    count = np.where(ok, batch.count, 0)
    parts_q = [qf]
    extra_first = {}
    m = len(qf)
    for p, q in _by_the_system(cf, R, t, ok, mode):
        parts_q.append(q)
        extra_first[p] = m
        count[p] = len(q)
        m += len(q)
        ok[p] = True
    method = ["closed-form" if o else "branch-and-prune" for o in ok]
    complete = ok.copy()
    curves = np.zeros(N, dtype=np.int64)
    parts_c = [np.ones(m, dtype=bool)]
    parts_s = [np.zeros(m, dtype=bool)]
    undecided = np.flatnonzero(~ok)
    ordered = [cf.joints[i] for i in np.argsort(cf.idx_q)] if len(undecided) else []

    def angles(q: np.ndarray) -> list[float]:  # a continuous joint's (cos, sin) as its angle
        return [math.atan2(q[j.idx_q + 1], q[j.idx_q]) if j.unbounded else float(q[j.idx_q]) for j in ordered]

    for k in undecided:
        res = fallback(int(k))
        complete[k] = res.complete
        curves[k] = len(res.curves)
        if res.solutions:
            parts_q.append(np.array([angles(s.q) for s in res.solutions]))
            parts_c.append(np.array([s.certified for s in res.solutions]))
            parts_s.append(np.array([s.singular for s in res.solutions]))
        extra_first[int(k)] = m
        count[k] = len(res.solutions)
        m += len(res.solutions)
    first = batch.first.copy()
    for kk, f in extra_first.items():
        first[kk] = f
    if len(parts_q) == 1:  # every pose by the closed form: the arrays as they are
        return BatchAnswer(names, first, count, qf, parts_c[0], parts_s[0], method, complete, curves)
    return BatchAnswer(
        names, first, count, np.concatenate(parts_q).reshape(-1, 6), np.concatenate(parts_c), np.concatenate(parts_s),
        method, complete, curves,
    )  # fmt: skip


def _by_the_system(cf: ClosedForm, R: np.ndarray, t: np.ndarray, ok: np.ndarray, mode: str) -> list[tuple[int, np.ndarray]]:
    """The poses the batch with Krawczyk in the joint angles (``mode`` ``"joint"``) left
    undecided (``~ok``) that Krawczyk on the kinbox system decides
    (:func:`kinbox.search.cf_batch.run_batch`, ``certificate="system"``, on those poses alone):
    ``(pose, its joint values)`` each. Next to a singularity a root's enclosure can be too wide
    for a box in the joint angles to hold and be proven, while a box in the system's variables,
    whose rows are polynomials, still is: those poses then need no branch and prune
    (``tests/answer/test_cf_second_chance.py::test_the_system_decides_what_the_joint_proof_leaves``)."""
    tc = cf.certifier
    left = np.flatnonzero(~ok)
    if mode != "joint" or not len(left) or tc is None or not tc.ok:
        return []
    sub = run_batch(cf, tc, R[left], t[left], certificate="system")
    out = []
    for i, k in enumerate(left):
        if sub.status[i] == POSE_CLOSED_FORM:
            f = int(sub.first[i])
            out.append((int(k), joint_values(cf, sub.theta[f : f + int(sub.count[i])])[0]))
    return out


def poses_array(poses, parse_pose) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rotations (N, 3, 3), translations (N, 3) and XYZQUAT (N, 7) of an (N, 7) array of poses
    ``x y z qx qy qz qw`` (or a list of ``pin.SE3``, each checked by ``parse_pose``), validated
    as :func:`kinbox.pipeline.parse_pose` validates one."""
    if isinstance(poses, (list, tuple)) and poses and isinstance(poses[0], pin.SE3):
        goals = [parse_pose(p) for p in poses]
        V = np.array([pin.SE3ToXYZQUAT(g) for g in goals])
        return np.array([g.rotation for g in goals]), np.array([g.translation for g in goals]), V
    try:
        v = np.asarray(poses, dtype=float)
    except (TypeError, ValueError):
        raise InputError("poses must be an (N, 7) array of numbers (x y z qx qy qz qw)") from None
    if v.ndim != 2 or v.shape[1] != 7:
        raise InputError(f"poses must be an (N, 7) array (x y z qx qy qz qw), got shape {v.shape}")
    bad = np.flatnonzero(~np.all(np.isfinite(v), axis=1))
    if len(bad):
        raise InputError(f"pose {int(bad[0])} has non-finite numbers: {v[bad[0]].tolist()}")
    R = np.empty((len(v), 3, 3))
    bad = _quaternions(np.ascontiguousarray(v), R)
    if bad >= 0:
        nq = float(np.linalg.norm(v[bad, 3:]))
        raise InputError(f"pose {bad}: quaternion (qx qy qz qw) = {v[bad, 3:].tolist()} is not unit (norm {nq:.6g})")
    return R, np.ascontiguousarray(v[:, :3]), np.ascontiguousarray(v)


@nb.njit(cache=True)
def _quaternions(v, R):
    """Rotations of the unit quaternions ``v[:, 3:7]`` (normalised, as :func:`parse_pose`) into
    ``R``; the first row whose norm is more than 1e-6 from 1 (else -1)."""
    for k in range(v.shape[0]):
        n = np.sqrt(v[k, 3] ** 2 + v[k, 4] ** 2 + v[k, 5] ** 2 + v[k, 6] ** 2)
        if not abs(n - 1.0) <= 1e-6:
            return k
        x, y, z, w = v[k, 3] / n, v[k, 4] / n, v[k, 5] / n, v[k, 6] / n
        R[k, 0, 0] = 1 - 2 * (y * y + z * z)
        R[k, 0, 1] = 2 * (x * y - z * w)
        R[k, 0, 2] = 2 * (x * z + y * w)
        R[k, 1, 0] = 2 * (x * y + z * w)
        R[k, 1, 1] = 1 - 2 * (x * x + z * z)
        R[k, 1, 2] = 2 * (y * z - x * w)
        R[k, 2, 0] = 2 * (x * z - y * w)
        R[k, 2, 1] = 2 * (y * z + x * w)
        R[k, 2, 2] = 1 - 2 * (x * x + y * y)
    return -1


def _itself(x):
    return x


class LazyFormulation:
    """The formulation of a pose the closed form answered: its mechanism (the arm with the
    goal) and joints at once, the bound system (:meth:`ArmTemplate.formulation`) on first use
    of anything else (``system``, ``decode``, ...). Pickled as the bound formulation."""

    def __init__(self, arm, mechanism, goal: pin.SE3):
        self.mechanism = mechanism
        self.goal = goal
        self.joint_vars = arm.joint_vars
        self.dropped_joints = arm.dropped_joints
        self.kind = arm.kind
        self._arm = arm
        self._real = None

    def bound(self):
        if self._real is None:
            self._real = self._arm.formulation(self.mechanism, self.goal)
        return self._real

    def __getattr__(self, name: str):
        if name.startswith("__") or name in ("_arm", "_real"):
            raise AttributeError(name)
        return getattr(self.bound(), name)

    def __reduce__(self):
        return (_itself, (self.bound(),))


class LazyRaw:
    """The solver-style record (:class:`~kinbox.search.results.SolveResult`) of a fast answer
    (the closed form's, the eigenvalue path's), built on first use from ``boxes()``, the roots
    certified once more by Krawczyk on the kinbox system, for what reads boxes in the system's
    variables (plots, JSON). Its ``status``, ``message`` and ``stats`` are at hand."""

    def __init__(self, boxes: Callable[[], list], formulation: LazyFormulation, message: str, stats: Stats):
        self.status = Status.COMPLETE
        self.message = message
        self.stats = stats
        self.pending: list = []
        self.state = None
        self._boxes = boxes
        self._formulation = formulation
        self._real: SolveResult | None = None

    @property
    def complete(self) -> bool:
        return True

    def real(self) -> SolveResult:
        if self._real is None:
            self._real = SolveResult(Status.COMPLETE, self.message, self._boxes(), [], self.stats, self._formulation.system)
        return self._real

    def __getattr__(self, name: str):
        if name.startswith("__") or name in ("_boxes", "_formulation", "_real"):
            raise AttributeError(name)
        return getattr(self.real(), name)

    def __reduce__(self):
        return (_itself, (self.real(),))


def _system_boxes(cf: ClosedForm, goal: pin.SE3) -> list:
    """The closed form's roots of ``goal`` certified on the kinbox system, as solver boxes."""
    batch = run_batch(cf, cf.certifier, goal.rotation[None], goal.translation[None])
    return boxes_of(batch, 0) or []


@dataclass
class ArmFacts:
    """What every closed-form answer of one IK shares, computed once: the problem's label,
    the names of ``q``'s entries, the limits kept to, the system's size (``summary``)."""

    label: str
    joint_names: list[str]
    joint_limits: dict
    summary: dict
    n: int
    #: the joints wider than a turn (:func:`kinbox.answer.turns.wrapping_joints`), None: found per answer
    wrapping: dict | None = None


def fast_result(
    cf: ClosedForm,
    arm,
    facts: ArmFacts,
    mech,
    goal: pin.SE3,
    V: np.ndarray,
    source: dict,
    all_turns: bool = False,
    batch: Batch | None = None,
    k: int = 0,
) -> Result | None:
    """The complete answer of one pose from the closed form (pose ``k`` of ``batch``, a
    :func:`~kinbox.search.cf_batch.run_batch` with ``certificate="joint"``, if given), each
    root certified by Krawczyk in the joint angles (:mod:`kinbox.search.cf_certify`), or None
    (the pose goes to the other paths). Each solution is checked with Pinocchio's forward
    kinematics (its residual); the bound system and the solver-style record are built only if
    asked for (:class:`LazyFormulation`, :class:`LazyRaw`). A solution's ``width`` is that of
    its proof box in the joint angles."""
    t0, c0 = time.perf_counter(), time.process_time()
    load = 0.0
    if batch is None:
        with load_clock() as clock:
            batch = run_batch(cf, cf.certifier, goal.rotation[None], goal.translation[None], V=V[None], certificate="joint")
        load, k = clock.seconds, 0
    if batch.status[k] != POSE_CLOSED_FORM or batch.certificate != "joint" or batch.jlo is None or batch.jhi is None:
        return None
    f0, m = int(batch.first[k]), int(batch.count[k])
    theta, jlo, jhi = batch.theta[f0 : f0 + m], batch.jlo[f0 : f0 + m], batch.jhi[f0 : f0 + m]
    widths = np.max(jhi - jlo, axis=1) if m else np.zeros(m)
    stats = dict(method="closed-form", family=cf.family.name, certificate="joint angles")
    boxes = partial(_system_boxes, cf, goal)
    message = "closed form: every root proven and certified"
    return certified_answer(cf, arm, facts, mech, goal, theta, widths, stats, message, boxes, source, all_turns, (t0, c0, load))


def certified_answer(
    owner,
    arm,
    facts: ArmFacts,
    mech,
    goal: pin.SE3,
    theta: np.ndarray,
    widths: np.ndarray,
    method: dict,
    message: str,
    boxes: Callable[[], list],
    source: dict,
    all_turns: bool,
    clock: tuple[float, float, float],
) -> Result:
    """The complete answer of a fast path (the closed form's, the eigenvalue path's) from its
    certified roots: ``theta`` (m, 6) the family's angles, ``widths`` their proof boxes' widths,
    ``owner`` what holds the joints' map and the certifier (:func:`configurations`), ``method``
    the stats naming the path, ``boxes`` the roots certified on the kinbox system (built on first
    use, :class:`LazyRaw`), ``clock`` the wall and CPU times at the start and the kernels'
    loading seconds. Each solution is checked with Pinocchio's forward kinematics."""
    t0, c0, load = clock
    m = len(theta)
    x = np.zeros((m, facts.n))
    tc = owner.certifier
    if tc is not None and m:
        from ..search.closed_form import encode_rows

        P, _ = tc.params(goal.rotation[None], goal.translation[None])
        encode_rows(theta, P[0], tc.fixed, tc.cvar, tc.svar, tc.shift, tc.def_target, tc.def_start, tc.def_param, tc.def_coef,
                    tc.def_a, tc.def_b, x)  # fmt: skip
    Q = configurations(owner, theta)
    sols = []
    comps = []
    for r in range(m):
        width = float(widths[r])
        sols.append(Solution(Q[r], math.nan, BoxStatus.CERTIFIED, width, x[r], component=r))  # residual below, after the turns
        comps.append(Component(0, [r], True, rank=facts.n, dof=0, point=x[r], width=width))
    seconds = time.perf_counter() - t0
    stats: dict[str, object] = dict(boxes=0, empty=0, split=0, solutions=m, certified=m, lps=0, krawczyk=m)
    stats.update(seconds=seconds, cpu_seconds=time.process_time() - c0, load_seconds=load, max_pending=0, **facts.summary)
    stats.update(method)
    stats.update(dropped_joints=list(arm.dropped_joints), unresolved_boxes=0, singular=0, curve_corrections=0)
    form = LazyFormulation(arm, mech, goal)
    res = Result(
        problem=facts.label,
        joint_names=facts.joint_names,
        status=Status.COMPLETE,
        message=message,
        solutions=sols,
        components=comps,
        stats=cast(Stats, stats),
        raw=LazyRaw(boxes, form, message, cast(Stats, stats)),  # type: ignore[arg-type]  # a SolveResult on first use
        formulated=form,
        source=source,
        joint_limits=dict(facts.joint_limits),
    )
    add_turns(res, all_turns, facts.wrapping)  # the residual of each solution it moves or copies
    data = mech.model.createData()
    for s in res.solutions:
        if math.isnan(s.residual):
            s.residual = max_residual(mech, s.q, data)
    return res
