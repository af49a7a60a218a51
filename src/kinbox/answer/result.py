"""Solutions in joint space: decoding, Pinocchio checks, JSON and a readable table.

``Result`` is what :func:`kinbox.ik` and :func:`kinbox.solve` return. Every solution carries
its Pinocchio configuration ``q`` (model order), the largest loop-closure residual measured
with Pinocchio forward kinematics (metres or radians), and whether the solver proved it
(``certified``). Positive-dimensional parts of the answer are ``components`` of dimension
>= 1 with their boxes and sample configurations along them.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pinocchio as pin

from ..errors import KinboxError
from ..formulation.pairs import revolute_is_limited
from ..search.solver import BoxProcessor, SolveResult, SolverOptions
from .components import Component, components


@dataclass
class Solution:
    q: np.ndarray
    residual: float  # largest closure error from Pinocchio FK (m or rad)
    certified: bool
    width: float  # width of the box known to hold it (system variables)
    x: np.ndarray = field(repr=False)  # the point in the system's variables

    def to_dict(self) -> dict:
        return {"q": [float(v) for v in self.q], "residual": float(self.residual),
                "certified": bool(self.certified), "width": float(self.width)}


@dataclass
class Result:
    """All configurations found, with completeness, structure and statistics."""

    problem: str
    joint_names: list[str]
    complete: bool
    message: str
    solutions: list[Solution]
    components: list[Component]
    samples: dict[int, list[np.ndarray]]  # component index -> q samples (dimension >= 1)
    stats: dict
    raw: SolveResult = field(repr=False)
    formulation: Any = field(repr=False, default=None)
    #: how to rebuild the problem: {"kind": "ik"|"solve", "robot"/"mechanism", ...}
    source: dict = field(default_factory=dict)
    #: joint name -> [lower, upper]: the model's limits the search kept to (joints of the
    #: system whose range is narrower than a full turn, and bounded prismatic joints)
    joint_limits: dict[str, list[float]] = field(default_factory=dict)

    @property
    def success(self) -> bool:
        return self.complete

    @property
    def mechanism(self):
        return self.formulation.mechanism

    def to_dict(self) -> dict:
        comps = []
        for i, c in enumerate(self.components):
            d: dict = {"dimension": c.dimension, "boxes": len(c.boxes), "certified": c.certified}
            if c.dimension >= 1:
                d["bifurcation_boxes"] = len(c.bifurcations)
                d["samples"] = [[float(v) for v in q] for q in self.samples.get(i, [])]
            comps.append(d)
        return {
            "problem": self.problem,
            "source": self.source,
            "joint_names": self.joint_names,
            "complete": self.complete,
            "message": self.message,
            "solutions": [s.to_dict() for s in self.solutions],
            "components": comps,
            "joint_limits": self.joint_limits,
            "stats": self.stats,
            "boxes": self._boxes_dict(),
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
            return {"variables": names, "count": n,
                    "omitted": f"{n} boxes, more than {self.MAX_JSON_BOXES}: not written"}
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

        return {"variables": names, "count": n,
                "lo": [[down(float(v)) for v in b.lo] for b in raw.boxes],
                "hi": [[up(float(v)) for v in b.hi] for b in raw.boxes],
                "component": comp}

    def to_json(self, indent: int | None = 1) -> str:
        return json.dumps(self.to_dict(), indent=indent)

    def table(self) -> str:
        lines = [f"{self.problem}: {len(self.solutions)} isolated solution(s), "
                 f"{sum(1 for c in self.components if c.dimension >= 1)} positive-dimensional component(s); "
                 f"{'complete' if self.complete else 'INCOMPLETE'} ({self.message})"]
        if self.solutions:
            labels, prefix = column_labels(joint_labels(self.formulation.mechanism.model))
            if prefix:
                lines.append(f"  (columns: joint names after {prefix!r})")
            lines.append("  #  cert  residual   " + " ".join(f"{n:>10}" for n in labels))
            for k, s in enumerate(self.solutions):
                vals = " ".join(f"{v:10.6f}" for v in _per_joint(self, s.q))
                lines.append(f"{k + 1:3d}  {'yes' if s.certified else ' no'}  {s.residual:9.2e}  {vals}")
        for c in self.components:
            if c.dimension >= 1:
                lines.append(f"  component of dimension {c.dimension}: {len(c.boxes)} boxes, "
                             f"{len(c.bifurcations)} possible bifurcation box(es)")
        st = self.stats
        if st.get("unresolved_boxes"):
            lines.append(f"  {st['unresolved_boxes']} box(es) could not be ruled out but hold no solution "
                         f"kinbox could find (a smaller sigma decides them)")
        lines.append(f"  {st.get('variables')} variables, {st.get('equations')} equations; "
                     f"{st.get('boxes')} boxes ({st.get('empty')} empty, {st.get('split')} split), "
                     f"{st.get('lps')} LPs, {st.get('seconds', 0):.3f} s")
        if st.get("dropped_joints"):
            lines.append(f"  left out: {', '.join(st['dropped_joints'])}")
        if self.joint_limits:
            lim = ", ".join(f"{n} [{lo:.4g}, {hi:.4g}]" for n, (lo, hi) in self.joint_limits.items())
            lines.append(f"  joint limits of the model applied (solutions outside them are not reported): {lim}")
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.table()


def _per_joint(res: Result, q: np.ndarray) -> list[float]:
    """One number per joint for display: angles of continuous joints instead of (cos, sin)."""
    model = res.formulation.mechanism.model
    out = []
    for j in model.joints[1:]:
        v = q[j.idx_q: j.idx_q + j.nq]
        if j.nq == 2 and j.nv == 1:
            out.append(float(np.arctan2(v[1], v[0])))
        else:
            out.extend(float(a) for a in v)
    return out


#: an uncertified box counts as a solution only if a point of it closes every loop this well
MAX_POLISHED = 200  # uncertified boxes polished per isolated component (the rest count as unresolved)
UNRESOLVED = 1e-8


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
    prefix = pre[:cuts[-1]] if cuts else ""
    rest = [n[len(prefix):] for n in names]
    head = (width - 1) // 2
    mid = [n if len(n) <= width else f"{n[:head]}~{n[len(n) - (width - 1 - head):]}" for n in rest]
    if fits(mid):
        return mid, prefix
    return [f"{n[:width - 1 - len(str(i + 1))]}#{i + 1}" for i, n in enumerate(rest)], prefix


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
        lo, hi = float(model.lowerPositionLimit[j.idx_q]), float(model.upperPositionLimit[j.idx_q])
        short = j.shortname()
        prismatic = "Prismatic" in short or short.startswith("JointModelP")
        if (prismatic and np.isfinite(lo) and np.isfinite(hi)) or (not prismatic and revolute_is_limited(lo, hi)):
            out[name] = [lo, hi]
    return out


def max_residual(mech, q: np.ndarray) -> float:
    res = mech.closure_residuals(q)
    return max((max(p, r) for _, p, r in res), default=0.0)


def _holds(box, x: np.ndarray) -> bool:
    """Does the solver box hold the system point ``x`` (up to a relative 1e-9)?"""
    pad = 1e-9 * (1.0 + np.abs(x))
    return bool(np.all(x >= box.lo - pad) and np.all(x <= box.hi + pad))


def _same_q(model: pin.Model, q1: np.ndarray, q2: np.ndarray, tol: float = 1e-8) -> bool:
    return float(np.max(np.abs(pin.difference(model, q1, q2)), initial=0.0)) < tol


def _proof_box(prover: BoxProcessor, formulation, q: np.ndarray):
    """A certified solution box (a Krawczyk proof, with the solver's domain and inequality
    checks) around the system point of the configuration ``q``, or ``None``."""
    try:
        x = formulation.encode(q)
    except (KinboxError, ValueError):
        return None
    r = 1e-9 * (1.0 + np.abs(x))
    o = prover.process(x - r, x + r)
    if o.solution is not None and o.solution.certified:
        return o.solution
    return None


def build_result(problem: str, raw: SolveResult, formulation, sigma: float,
                 polish=None, max_samples: int = 200, source: dict | None = None) -> Result:
    """Turn solver boxes into joint-space solutions and components.

    ``polish(q) -> q`` optionally refines a configuration with Pinocchio (e.g. Newton on the
    closure residual) before it is checked.
    """
    mech = formulation.mechanism
    model = mech.model
    comps = components(raw.system, raw.boxes, sigma)
    sols: list[Solution] = []
    samples: dict[int, list[np.ndarray]] = {}
    unresolved = 0
    prover = None
    limits: list[np.ndarray] = []  # where Newton takes the uncertified solutions kept so far
    # certified boxes are distinct proven solutions (the solver merged duplicates), taken
    # first; every uncertified box is polished too: a cluster next to a certified solution may
    # hold a second, nearby one (near-singular pairs); duplicates are merged below
    cands = [(raw.boxes[i], True) for c in comps if c.dimension == 0 for i in c.boxes if raw.boxes[i].certified]
    for c in comps:
        if c.dimension == 0:
            unc = sorted((raw.boxes[i] for i in c.boxes if not raw.boxes[i].certified), key=lambda b: b.residual)
            unresolved += max(0, len(unc) - MAX_POLISHED)  # not tried: counted, never dropped silently
            cands += [(b, False) for b in unc[:MAX_POLISHED]]
    for b, cert in cands:
        q = formulation.decode(b.x)
        if polish is not None:
            q = polish(q)
        s = Solution(q, max_residual(mech, q), cert, b.width, b.x)
        if not cert and any(o.certified and _holds(b, o.x) for o in sols):
            # the box touches a proven solution (a neighbour of its box): near a singular
            # root points up to a box width away close the loop to 1e-8 too
            continue
        dup = next((o for o in sols if _same_q(model, s.q, o.q)), None)
        if dup is not None:
            dup.certified = dup.certified or s.certified
            if not cert and not _holds(b, dup.x):
                # polishing left the box for a solution found elsewhere: whatever the box
                # holds was not found; say so instead of dropping it
                unresolved += 1
            continue
        if not cert and s.residual > UNRESOLVED:
            # a box the solver could not rule out, but no solution was found in it:
            # not reported as a solution; counted in stats["unresolved_boxes"]
            unresolved += 1
            continue
        if not cert:
            if prover is None:
                prover = BoxProcessor(raw.system, SolverOptions(lp=False))
            # near a singular root, points a little away from it close the loop to 1e-8
            # too: one that Newton takes to a certified solution approximates that one
            # (or, at a double root that nothing certifies, the same point as another one)
            x = prover.cert.newton(b.x, iters=40)
            if np.max(np.abs(prover.cert.F(x)), initial=0.0) <= 1e-12:
                qn = formulation.decode(x)
                near = [o for o in sols if o.certified and _same_q(model, qn, o.q)]
                if near:  # Newton went to a proven solution: the box's own, or not found
                    unresolved += 0 if any(_holds(b, o.x) for o in near) else 1
                    continue
                if any(_same_q(model, qn, o, 1e-6) for o in limits):
                    continue
                limits.append(qn)
                rn = max_residual(mech, qn)
                if rn < s.residual:
                    s.q, s.residual = qn, rn
            # the solver's box was too wide to prove (e.g. it also touched a curve);
            # the polished point may still be proven: Krawczyk on a tiny box around it
            proof = _proof_box(prover, formulation, q)
            if proof is not None:
                s.certified, s.width = True, proof.width
        sols.append(s)
    for ci, c in enumerate(comps):
        if c.dimension >= 1:
            idx = c.boxes
            step = max(1, len(idx) // max_samples)
            samples[ci] = [formulation.decode(raw.boxes[i].x) for i in idx[::step]]
    stats = dict(raw.stats)
    stats["dropped_joints"] = list(getattr(formulation, "dropped_joints", []))
    stats["solutions"] = len(sols)
    stats["unresolved_boxes"] = unresolved
    stats["certified"] = sum(s.certified for s in sols)
    return Result(problem=problem, joint_names=q_names(model), complete=raw.complete,
                  message=raw.message, solutions=sols, components=comps, samples=samples,
                  stats=stats, raw=raw, formulation=formulation, source=source or {},
                  joint_limits=applied_limits(formulation))
