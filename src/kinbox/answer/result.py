"""Solutions in joint space: decoding, Pinocchio checks, JSON and a readable table.

``Result`` is what :func:`kinbox.ik` and :func:`kinbox.solve` return. Every solution carries
its Pinocchio configuration ``q`` (model order), the largest loop-closure residual measured
with Pinocchio forward kinematics (metres or radians), and whether the solver proved it
(``certified``). Positive-dimensional parts of the answer are ``components`` of dimension
>= 1 with their boxes; each curve's configurations in order are in ``curves`` (the one curve
view: :class:`Curve`). ``Result`` shares its base, :class:`~kinbox.search.outcome.Outcome`
(``status``, ``complete``, ``message``, ``stats``, ``to_json``, ``table``), with every kinbox
result.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pinocchio as pin

from ..formulation.pairs import family, joint_parts, part_limits
from ..formulation.protocol import MechanismFormulation
from ..search.outcome import Outcome, Stats
from ..search.point import SeededCertifier, point_certifier
from ..search.results import SolveResult
from ..search.status import BoxStatus, Status
from .components import Component, analyse
from .curve import Curve
from .platform import add_platform_poses, platform_table


@dataclass
class Solution:
    q: np.ndarray
    residual: float  # largest closure error from Pinocchio FK (m or rad)
    #: what the box around it is known to hold (the one status of every solution box:
    #: certified, within resolution of a root Newton reached, or uncertified)
    status: BoxStatus
    width: float  # width of the box known to hold it (system variables)
    x: np.ndarray = field(repr=False)  # the point in the system's variables
    #: the constraint Jacobian is rank-deficient here (a tangent, double or triple root, an arm
    #: at a singularity): no proof is possible, the root is reported once with its estimated
    #: multiplicity (None: not finite, a real point of a curve of complex solutions)
    singular: bool = False
    multiplicity: int | None = 1
    component: int = -1  # index in Result.components
    #: multiplicity None: the local dimension of the complex solution set through the point
    #: (1: a real point of a complex curve, like a UR5 at its home pose), or None if unknown
    complex_dimension: int | None = None
    #: a parallel mechanism's platform pose at ``q`` (:mod:`kinbox.answer.platform`), or None
    platform: dict | None = None
    #: against a scene: {"free", "clearance", "pairs"} (kinbox.answer.collision); None without one
    collision: dict | None = None
    #: uncertified: whether the number of roots within ``width`` is known (``multiplicity``);
    #: False: "roots within width, how many not known" (``roots_within: "not known"`` in JSON)
    count_known: bool = True

    def __post_init__(self) -> None:
        self.status = BoxStatus(self.status)

    @property
    def certified(self) -> bool:
        """Proven: the box of :attr:`width` around it holds exactly one root (Krawczyk)."""
        return self.status is BoxStatus.CERTIFIED

    def to_dict(self) -> dict:
        d: dict[str, Any] = {
            "q": [float(v) for v in self.q],
            "residual": float(self.residual),
            "certified": self.certified,
            "status": self.status.value,
            "width": float(self.width),
        }
        if self.platform is not None:
            d["platform"] = self.platform
        if self.singular:
            d.update(singular=True, multiplicity=self.multiplicity, complex_dimension=self.complex_dimension)
            if self.multiplicity is not None and self.multiplicity >= 2:
                # a cluster the precision cannot separate: this many roots within ``width``
                d["not_separated_within"] = float(self.width)
        if not self.certified and not self.count_known:
            # Newton from its boxes ends at points the precision does not separate
            d.update(not_separated_within=float(self.width), roots_within="not known")
        if self.collision is not None:
            d["collision"] = self.collision
        return d


#: configurations per curve written as its ``samples`` in JSON
MAX_SAMPLES = 200


@dataclass(repr=False)
class Result(Outcome):
    """All configurations found, with completeness, structure and statistics."""

    problem: str
    joint_names: list[str]
    status: Status
    message: str
    solutions: list[Solution]
    components: list[Component]
    stats: Stats
    raw: SolveResult = field(repr=False)
    #: the formulation's name (``"general"``, ``"planar"``, ``"arm"``, ``"invariants"``), as
    #: every result names it (:attr:`kinbox.answer.assembly.AssemblyResult.formulation` too)
    formulation: str = ""
    #: the formulation itself (:class:`~kinbox.formulation.protocol.MechanismFormulation`):
    #: its system, ``encode`` and ``decode``
    formulated: Any = field(repr=False, default=None)
    #: how to rebuild the problem: {"kind": "ik"|"solve", "robot"/"mechanism", ...}
    source: dict = field(default_factory=dict)
    #: joint name -> [lower, upper]: the model's limits the search kept to (joints of the
    #: system whose range is narrower than a full turn, and bounded prismatic joints)
    joint_limits: dict[str, list[float]] = field(default_factory=dict)
    #: component index -> its configurations in order (dimension 1)
    curves: dict[int, Curve[np.ndarray]] = field(default_factory=dict)
    #: solver boxes that hold no solution found in or near them (not ruled out either)
    undecided: list[int] = field(default_factory=list)
    #: what the answer means where that is not plain (fewer joints than a pose's six, ...):
    #: a line each, in the table and, when there are any, in the JSON
    notes: list[str] = field(default_factory=list)
    #: the scene the solutions were checked against (kinbox.answer.collision), {} without one
    scene: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.status = Status(self.status)
        if not self.formulation and self.formulated is not None:
            self.formulation = self.formulated.kind

    def __repr__(self) -> str:
        return f"Result(problem={self.problem!r}, status={self.status.value!r}, solutions={len(self.solutions)}, curves={len(self.curves)})"

    @property
    def mechanism(self):
        return self.formulated.mechanism

    def to_dict(self) -> dict:
        def qs(v):
            return [[float(a) for a in q] for q in v]

        comps = []
        sol_of = {s.component: k for k, s in enumerate(self.solutions)}
        for i, c in enumerate(self.components):
            d: dict = {"dimension": c.dimension, "boxes": len(c.boxes), "certified": c.certified, "rank": c.rank, "dof": c.dof}
            if c.dimension == 0:
                d.update(solution=sol_of.get(i), singular=c.singular, multiplicity=c.multiplicity, complex_dimension=c.complex_dimension)
            else:
                cv = self.curves.get(i)
                d["complete"] = c.complete
                if cv is not None:
                    d["polyline"] = qs(cv.polyline)
                    d["closed"] = bool(cv.closed[0]) if cv.closed else False
                    d["branches"] = [{"polyline": qs(b), "closed": bool(cl)} for b, cl in zip(cv.branches, cv.closed)]
                    d["bifurcations"] = qs(cv.bifurcations)
                    d["max_residual"] = float(cv.residual)
                    if cv.collision is not None:
                        d["collision"] = cv.collision
                d["samples"] = qs(cv.samples(MAX_SAMPLES) if cv is not None else [])
            comps.append(d)
        return {
            "problem": self.problem,
            "source": self.source,
            "joint_names": self.joint_names,
            **({"formulation": self.formulation} if self.formulation else {}),
            "status": self.status.value,
            "complete": self.complete,
            "message": self.message,
            "solutions": [s.to_dict() for s in self.solutions],
            "components": comps,
            "joint_limits": self.joint_limits,
            "stats": self.stats,
            "boxes": self._boxes_dict(),
            **({"scene": self.scene} if self.scene else {}),
            **({"notes": list(self.notes)} if self.notes else {}),
        }

    #: ``to_dict`` leaves the boxes out above this many (the JSON would be too large)
    MAX_JSON_BOXES = 20000

    def _boxes_dict(self) -> dict:
        """The solution boxes for plots (``kinbox plot``): bounds in the system's variables,
        rounded outward to 7 significant digits, and the component of each box."""
        raw = self.raw
        if raw is None or getattr(raw, "system", None) is None:
            return {"variables": [], "count": 0, "omitted": "no solver boxes in this result"}
        names = list(raw.system.names)
        n = len(raw.boxes)
        if n > self.MAX_JSON_BOXES:
            return {"variables": names, "count": n, "omitted": f"{n} boxes, more than {self.MAX_JSON_BOXES}: not written"}
        comp = [-1] * n
        for ci, c in enumerate(self.components):
            for b in c.boxes:
                comp[b] = ci

        def down(v: float) -> float:
            r = float(f"{v - 1e-6 * abs(v):.7g}")
            return r if r <= v else float(v)

        def up(v: float) -> float:
            r = float(f"{v + 1e-6 * abs(v):.7g}")
            return r if r >= v else float(v)

        return {
            "variables": names,
            "count": n,
            "lo": [[down(float(v)) for v in b.lo] for b in raw.boxes],
            "hi": [[up(float(v)) for v in b.hi] for b in raw.boxes],
            "component": comp,
            "status": [b.status.value for b in raw.boxes],
        }

    def table(self) -> str:
        lines = [
            f"{self.problem}: {len(self.solutions)} isolated solution(s), "
            f"{sum(1 for c in self.components if c.dimension >= 1)} positive-dimensional component(s); "
            f"{self.completeness()}"
        ]
        if self.solutions:
            labels, prefix = column_labels(joint_labels(self.formulated.mechanism.model))
            if prefix:
                lines.append(f"  (columns: joint names after {prefix!r})")
            scene = any(s.collision is not None for s in self.solutions)
            head = "  #  cert  residual   " + (" collision  clearance " if scene else "")
            lines.append(head + " ".join(f"{n:>10}" for n in labels))
            for k, s in enumerate(self.solutions):
                vals = " ".join(f"{v:10.6f}" for v in _per_joint(self, s.q))
                col = _collision_cell(s.collision) if scene else ""
                lines.append(f"{k + 1:3d}  {'yes' if s.certified else ' no'}  {s.residual:9.2e}  {col}{vals}")
            for k, s in enumerate(self.solutions):
                if s.singular:
                    c = self.components[s.component] if s.component >= 0 else None
                    m = (
                        f"multiplicity {s.multiplicity}"
                        if s.multiplicity is not None
                        else "multiplicity not finite: not an isolated root of the complex equations"
                        + (" (a real point of a complex curve)" if s.complex_dimension == 1 else "")
                    )
                    cluster = (
                        f" ({s.multiplicity} roots, real or complex, within {s.width:.1e} of each other, not separated at this precision)"
                        if s.multiplicity is not None and s.multiplicity >= 2
                        else ""
                    )
                    if not s.count_known:  # its boxes lead to other roots too (components._one_singular_root)
                        cluster = f" (roots, real or complex, within {s.width:.1e} of it, how many not known)"
                    lines.append(
                        f"  solution {k + 1} is singular (Jacobian rank {c.rank if c else '?'} of "
                        f"{st_vars(self)}): {m}; reported once, not certified" + cluster
                    )
                elif not s.certified and not s.count_known:
                    lines.append(
                        f"  solution {k + 1}: roots, real or complex, within {s.width:.1e} of it, how many not known "
                        "(not separated at this precision); not certified"
                    )
        lines.extend(platform_table(self))
        for i, c in enumerate(self.components):
            if c.dimension >= 1:
                cv = self.curves.get(i)
                pts = sum(len(b) for b in cv.branches) if cv else 0
                lines.append(
                    f"  component of dimension {c.dimension} (Jacobian rank {c.rank}, {c.dof} dof): "
                    f"{len(c.boxes)} boxes, {len(c.polylines)} branch(es), {pts} configurations, "
                    f"{len(c.bifurcations)} bifurcation point(s)" + ("" if c.complete else "; NOT followed to its end")
                )
                if cv is not None and cv.collision is not None:
                    lines.append("    " + _stretches_line(cv.collision))
        st = self.stats
        if st.get("unresolved_boxes"):
            lines.append(
                f"  {st['unresolved_boxes']} box(es) could not be ruled out but hold no solution "
                f"kinbox could find (a smaller sigma decides them)"
            )
        lines.extend(f"  note: {n}" for n in self.notes)
        lines.append(
            f"  {st.get('variables')} variables, {st.get('equations')} equations; "
            f"{st.get('boxes')} boxes ({st.get('empty')} empty, {st.get('split')} split), "
            f"{st.get('lps')} LPs, {st.get('seconds', 0):.3f} s" + _loading(st)
        )
        if st.get("collision"):
            lines.append("  " + _scene_line(st["collision"]))
        if st.get("dropped_joints"):
            lines.append(f"  left out: {', '.join(st['dropped_joints'])}")
        if self.joint_limits:
            lim = ", ".join(f"{n} [{lo:.4g}, {hi:.4g}]" for n, (lo, hi) in self.joint_limits.items())
            lines.append(f"  joint limits of the model applied (solutions outside them are not reported): {lim}")
        return "\n".join(lines)


def _stretches_line(branches: list[dict]) -> str:
    """One line on a curve's collision-free stretches (kinbox.answer.collision.split_branch)."""
    pieces = [st for b in branches for st in b["stretches"]]
    pts = sum(len(st["polyline"]) for st in pieces)
    total = sum(b["samples"] + b["inserted"] for b in branches)
    low = [st["clearance"] for st in pieces if st["clearance"] is not None]
    pairs = sorted({tuple(p) for b in branches for p in b["pairs"]})
    return (
        f"scene: {len(pieces)} collision-free stretch(es), {pts} of {total} configurations; "
        f"{sum(b['colliding_samples'] for b in branches)} in contact"
        + (f" ({', '.join(f'{a}-{b}' for a, b in pairs[:4])}{', ...' if len(pairs) > 4 else ''})" if pairs else "")
        + (f"; clearance along the stretches >= {min(low):.4f} m" if low else "")
    )


def _scene_line(c: dict) -> str:
    """The table's line on the scene: pairs checked and skipped, solutions dropped."""
    p, ch = c.get("pairs", {}), c.get("checks", {})
    return (
        f"scene {c.get('name')!r}: {p.get('active', 0)} active pairs ({p.get('world_fixed', 0)} world-fixed and "
        f"{p.get('out_of_reach', 0)} out-of-reach pairs skipped, {p.get('disabled', 0) + p.get('allowed', 0)} disabled or allowed); "
        f"per configuration checks: {ch.get('sphere_skipped', 0)} pairs cleared by bounding balls, {ch.get('hull_proofs', 0)} by "
        f"convex hulls, {ch.get('mesh_checked', 0)} on meshes"
        + (f"; {c['dropped']} solution(s) in contact dropped" if c.get("dropped") else "")
    )


def _collision_cell(c: dict | None) -> str:
    """The table's collision column: free or in contact, and the clearance in metres."""
    if c is None:
        return " " * 22
    d = c.get("clearance")
    return f"{'free' if c.get('free') else 'CONTACT':>9}  {d if d is not None else float('inf'):9.4f}   "


def _loading(stats: Stats) -> str:
    """What of the search's seconds went to loading compiled kernels: paid once per process (the
    first run after an install compiles them), so a one-pose run says it apart."""
    load = float(stats.get("load_seconds", 0.0))
    return f" ({load:.3f} s of it loading compiled kernels, once per process)" if load >= 0.0005 else ""


def st_vars(res: Result) -> int:
    return int(res.stats.get("variables", res.raw.system.n if res.raw is not None else 0))


def _per_joint(res: Result, q: np.ndarray) -> list[float]:
    """One number per joint for display: angles of continuous joints instead of (cos, sin)."""
    model = res.formulated.mechanism.model
    out = []
    for j in model.joints[1:]:
        v = q[j.idx_q : j.idx_q + j.nq]
        if j.nq == 2 and j.nv == 1:
            out.append(float(np.arctan2(v[1], v[0])))
        else:
            out.extend(float(a) for a in v)
    return out


def q_names(model: pin.Model) -> list[str]:
    """A name for every entry of a Pinocchio ``q`` (continuous joints: ``name.cos``, ``name.sin``)."""
    names = []
    for jid in range(1, model.njoints):
        j, n = model.joints[jid], model.names[jid]
        if j.nq == 1:
            names.append(n)
        elif j.nq == 2 and j.nv == 1:
            names += [f"{n}.cos", f"{n}.sin"]
        else:
            names.extend(f"{n}[{k}]" for k in range(j.nq))
    return names


def joint_labels(model: pin.Model) -> list[str]:
    """Column labels of :func:`_per_joint` (one per angle for continuous joints)."""
    out = []
    for jid in range(1, model.njoints):
        j, n = model.joints[jid], model.names[jid]
        out += [n] if (j.nq == 1 or (j.nq == 2 and j.nv == 1)) else [f"{n}[{k}]" for k in range(j.nq)]
    return out


def column_labels(names: list[str], width: int = 10) -> tuple[list[str], str]:
    """Distinct column labels of at most ``width`` characters for ``names``, and the common
    prefix left out of them ("" if none): long names that share a prefix (``j2s6s200_joint_1``,
    ``j2s6s200_joint_2``, ...) would all read the same cut to ``width``."""

    def fits(labels):
        return len(set(labels)) == len(labels) and all(len(x) <= width for x in labels)

    cut = [n[:width] for n in names]
    if fits(cut) or len(names) < 2:
        return cut, ""
    pre = os.path.commonprefix(names)
    cuts = [k + 1 for k, c in enumerate(pre) if c in "_-/.: " and all(len(n) > k + 1 for n in names)]
    for k in cuts:  # the shortest prefix that makes the labels distinct
        cut = [n[k:][:width] for n in names]
        if fits(cut):
            return cut, pre[:k]
    prefix = pre[: cuts[-1]] if cuts else ""
    rest = [n[len(prefix) :] for n in names]
    head = (width - 1) // 2
    mid = [n if len(n) <= width else f"{n[:head]}~{n[len(n) - (width - 1 - head) :]}" for n in rest]
    if fits(mid):
        return mid, prefix
    return [f"{n[: width - 1 - len(str(i + 1))]}#{i + 1}" for i, n in enumerate(rest)], prefix


def applied_limits(formulation) -> dict[str, list[float]]:
    """The model's limits that constrain the search: joints of the system with a revolute range
    narrower than a full turn, or a bounded prismatic range."""
    model = formulation.mechanism.model
    out: dict[str, list[float]] = {}
    for name in formulation.joint_vars:
        if not model.existJointName(name):
            continue
        j = model.joints[model.getJointId(name)]
        if j.nq != 1 or j.nv != 1:
            continue
        (part,) = joint_parts(j, name)
        lo, hi = part_limits(model, part)
        if family(part.kind).limits_search(part, lo, hi):
            out[name] = [float(lo[0]), float(hi[0])]
    return out


def max_residual(mech, q: np.ndarray, data=None) -> float:
    res = mech.closure_residuals(q, data)
    return max((max(p, r) for _, p, r in res), default=0.0)


def root_status(c: Component, boxes: list) -> BoxStatus:
    """The status of an isolated root's component: certified (a proof, the search's or the
    answer's), else within resolution if a box of it is, else uncertified."""
    if c.certified:
        return BoxStatus.CERTIFIED
    if any(boxes[b].status is BoxStatus.WITHIN_RESOLUTION for b in c.boxes):
        return BoxStatus.WITHIN_RESOLUTION
    return BoxStatus.UNCERTIFIED


def build_result(
    problem: str, raw: SolveResult, formulation: MechanismFormulation, sigma: float, polish=None, source: dict | None = None
) -> Result:
    """Turn solver boxes into joint-space solutions and components.

    The boxes are grouped by :func:`kinbox.answer.components.analyse`; every isolated root is one
    :class:`Solution` (certified, or flagged singular with its estimated multiplicity), every
    curve an ordered polyline of configurations. Each configuration is decoded to a Pinocchio
    ``q`` and its closures measured with Pinocchio forward kinematics. ``polish(q) -> q``
    optionally refines a configuration with Pinocchio (e.g. Newton on the closure residual)
    before it is checked.
    """
    mech = formulation.mechanism
    model = mech.model
    # a certified solution box around a regular root the solver left uncertified, or None
    # the general formulation's roots next to a singularity: certified from Newton's point
    # where the search's boxes are not (tests/answer/test_newton_proof.py)
    seeded = SeededCertifier(raw.system) if getattr(formulation, "kind", None) == "general" else None
    st = analyse(raw.system, raw.boxes, sigma, prover=point_certifier(raw.system), seeded=seeded)
    comps = st.components

    def to_q(x: np.ndarray) -> np.ndarray:
        q = formulation.decode(x)
        return polish(q) if polish is not None else q

    scratch = model.createData()  # Pinocchio's data for the residuals of every configuration
    sols: list[Solution] = []
    curves: dict[int, Curve[np.ndarray]] = {}
    # a formulation may hold a joint without a variable (a function of the others, such as the
    # invariants formulation's joint 6): its limits are checked here, at each isolated root
    admissible = formulation.admissible if formulation.limits_after else None
    outside = 0
    for ci, c in enumerate(comps):
        if c.dimension == 0 and c.point is not None:
            if admissible is not None and not admissible(c.point, 0.0 if c.certified else c.width):
                outside += 1
                continue
            q = to_q(c.point)
            sols.append(
                Solution(
                    q,
                    max_residual(mech, q, scratch),
                    root_status(c, raw.boxes),
                    c.width,
                    c.point,
                    singular=c.singular,
                    multiplicity=c.multiplicity,
                    component=ci,
                    complex_dimension=c.complex_dimension,
                    count_known=c.count_known,
                )
            )
        elif c.dimension >= 1:
            branches = []
            for pl, closed in zip(c.polylines, c.closed):
                qs = [to_q(x) for x in pl]
                branches.append((qs, closed, max((max_residual(mech, q, scratch) for q in qs), default=0.0)))
            branches.sort(key=lambda b: -len(b[0]))
            bif = [to_q(x) for x in c.bifurcations]
            curves[ci] = Curve(
                branches=[b[0] for b in branches],
                closed=[b[1] for b in branches],
                residual=max((b[2] for b in branches), default=0.0),
                bifurcations=bif,
            )
    stats = raw.stats.copy()
    stats["dropped_joints"] = list(formulation.dropped_joints)
    stats["solutions"] = len(sols)
    if admissible is not None:
        stats["outside_limits"] = outside
    stats["unresolved_boxes"] = len(st.undecided)
    stats["certified"] = sum(s.certified for s in sols)
    stats["singular"] = sum(s.singular for s in sols)
    stats["curve_corrections"] = st.corrections
    res = Result(
        problem=problem,
        joint_names=q_names(model),
        status=raw.status,
        message=raw.message,
        solutions=sols,
        components=comps,
        stats=stats,
        raw=raw,
        formulated=formulation,
        source=source or {},
        curves=curves,
        undecided=st.undecided,
        joint_limits=applied_limits(formulation),
    )
    add_platform_poses(res)
    return res
