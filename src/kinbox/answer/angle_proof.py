"""Uncertified roots of a six-revolute arm answered through the general formulation, proven in
the joint angles.

A UR5 1e-9 from its wrist singularity through ``formulation="general"`` ends with the four roots
next to the singularity as uncertified points, each standing for a cluster of boxes along the
valley of near-solutions of the singular arm's self-motion (some 0.1 wide), and 1e-10 from it
two of them only in undecided boxes: in the formulation's 28 variables no box about them is
proven (:mod:`kinbox.answer.newton_proof`). Where the arm's joints are six revolute ones, each
with its cosine and sine among the system's variables, :func:`certify_in_angles` proves such a
root in the six joint angles (:func:`kinbox.search.angle_root.prove_root`: the model's exact
constants, 128-bit Taylor model, Krawczyk in the rotated angles) from

* each uncertified isolated root of the answer, and
* each cluster of undecided boxes (those whose boxes close the equations best first), from
  the points of its boxes that close the equations best among those :data:`AWAY` from every
  reported root (:data:`STARTS` of them, :data:`MAX_PROOFS` proofs in all, the points' first);

and reports it certified only where nothing is lost or doubled:

* its angles lie within the point's reach (an uncertified point: its ``width`` in each angle,
  doubled as for a width in the system's variables) or inside the joint-angle hull of a box of
  the cluster (an undecided cluster: the search kept every root in its boxes);
* it is no root reported already (:data:`APART` from every other solution in every angle, and
  outside every other uncertified point's reach);
* the boxes the point stood for are moved to the answer's undecided boxes: a proof about one
  root says nothing of the rest of its cluster, which stays reported as not ruled out.

The solution's ``width`` bounds every system variable over the proof's enclosure: the sum of
its widths in the angles (each cosine, sine and frame entry moves no more than the angles'
total). ``tests/answer/test_angle_proof.py`` checks the proofs against the 40-digit roots.
"""

from __future__ import annotations

import numpy as np

from ..formulation.arm import ArmTemplate, get_angle, put_angle
from ..search.status import BoxStatus
from .components import Component
from .result import Result, Solution, max_residual
from .separate import _angle_hull

#: a proven root this close (radians, any joint) to another reported solution is that solution
APART = 1e-6
#: points of an undecided cluster's boxes a proof is started from, the best closing first
STARTS = 4
#: a start of an undecided cluster is this far (system variables) from every reported root
AWAY = 1e-2
#: proofs tried in one answer, from its points first, then from its undecided clusters (a
#: counter: the same answer on every run; some 0.06 s each)
MAX_PROOFS = 64


def _angle_vars(res: Result, g) -> list[tuple[int, int]] | None:
    """The system's (cosine, sine) variable indices of each joint of the chain, or None."""
    names = list(res.formulated.system.names)
    out = []
    for j in g.chain.joints:
        name = getattr(j, "name", None)
        try:
            out.append((names.index(f"c[{name}]"), names.index(f"s[{name}]")))
        except ValueError:
            return None
    return out


def _box_angles(box, iv: list[tuple[int, int]], centre: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    lo, hi = np.empty(6), np.empty(6)
    for k, (ic, is_) in enumerate(iv):
        h = _angle_hull((float(box.lo[ic]), float(box.hi[ic])), (float(box.lo[is_]), float(box.hi[is_])), float(centre[k]))
        if h is None:
            return None
        lo[k], hi[k] = h
    return lo, hi


def certify_in_angles(res: Result, arm, pose: np.ndarray, exact: dict | None = None) -> Result:
    """``res`` (an answer through the general formulation) with its uncertified isolated roots
    and the roots of its undecided clusters proven in the joint angles where they can be
    (module docstring); ``pose`` the goal's XYZQUAT as given, ``exact`` the model's exact links
    and frames (as :func:`kinbox.answer.separate.separate_clusters` takes them). Changes
    ``res`` in place and returns it."""
    if not isinstance(arm, ArmTemplate) or len(arm.jvars) != 6 or res.formulated is None:
        return res
    g = arm.geometry
    if any(j.kind != "revolute" for j in g.chain.joints):
        return res
    iv = _angle_vars(res, g)
    if iv is None:
        return res
    from ..search.angle_root import prove_root
    from ..search.separate import arm_constants

    cs = arm_constants(g, arm.constants, exact)
    V = np.asarray(pose, dtype=float)
    mech = res.formulated.mechanism
    data = mech.model.createData()
    boxes = res.raw.boxes
    gamma = np.asarray(g.gamma, dtype=float)
    n = len(res.formulated.system.names)
    undecided = set(res.undecided)

    def angles(q: np.ndarray) -> np.ndarray:
        return np.array([get_angle(q, j) + gam for j, gam in zip(g.chain.joints, g.gamma)])

    def to_q(theta: np.ndarray, like: np.ndarray) -> np.ndarray:
        q = np.array(like, dtype=float)
        for j, gam, th in zip(g.chain.joints, g.gamma, theta):
            put_angle(q, j, float(th) - gam)
        return q

    def new(q: np.ndarray, others: list[Solution]) -> bool:
        # no other solution is that root: a certified one within APART, an uncertified one
        # within its reach (it stands for the roots there)
        for o in others:
            gap = float(np.max(np.abs(np.angle(np.exp(1j * (np.asarray(o.q) - q)))))) if o.q.shape == q.shape else np.inf
            if gap <= APART or (not o.certified and gap <= 2.0 * o.width):
                return False
        return True

    def solution(r, like: np.ndarray, comp: int) -> Solution:
        q = to_q(r.theta, like)
        return Solution(
            q, max_residual(mech, q, data), BoxStatus.CERTIFIED, float(np.sum(r.hi - r.lo)), res.formulated.encode(q), component=comp
        )

    proven = 0
    sols = list(res.solutions)
    tries = 0
    for k, s in enumerate(sols):
        if s.certified or s.component < 0 or s.q.shape[0] < 6 or tries >= MAX_PROOFS:
            continue
        tries += 1
        c = angles(s.q)
        r = prove_root(cs, V, c)
        if r is None or float(np.max(np.maximum(r.hi - c, c - r.lo))) > 2.0 * s.width:
            continue
        got = solution(r, s.q, s.component)
        if not new(got.q, sols[:k] + sols[k + 1 :]):
            continue
        comp = res.components[s.component]
        undecided |= set(comp.boxes)
        res.components[s.component] = Component(0, [], True, rank=n, dof=0, point=got.x, width=got.width)
        sols[k] = got
        proven += 1
    if undecided:
        from .components import _clusters

        # the clusters whose boxes close the equations best first: the counter goes to them
        clusters = sorted(_clusters(boxes, sorted(undecided), 0.0), key=lambda cl: min(float(boxes[i].residual) for i in cl))
        for cl in clusters:
            # starts away from the roots reported already (Newton from next to one goes to it)
            X = np.array([boxes[i].x for i in cl], dtype=float)
            away = np.ones(len(cl), dtype=bool)
            for o in sols:
                if o.x is not None and np.shape(o.x) == X.shape[1:]:
                    away &= np.max(np.abs(X - np.asarray(o.x, dtype=float)), axis=1) > AWAY
            order = sorted((i for i, a in zip(cl, away) if a), key=lambda i: float(boxes[i].residual))
            L = np.array([boxes[i].lo for i in cl], dtype=float)
            H = np.array([boxes[i].hi for i in cl], dtype=float)
            found: list[np.ndarray] = []
            used = 0
            where = {b: k for k, b in enumerate(cl)}
            for i in order:
                if tries >= MAX_PROOFS or used >= STARTS:
                    break
                if any(float(np.max(np.abs(X[where[i]] - f))) <= AWAY for f in found):
                    continue  # next to the root this cluster gave already
                tries += 1
                used += 1
                like = res.formulated.decode(np.asarray(boxes[i].x, dtype=float))
                r = prove_root(cs, V, angles(like))
                if r is None:
                    continue
                got = solution(r, like, len(res.components))
                # the root lies in a box of the cluster (the search kept it there): the boxes
                # whose variables reach its point, then their joint angles about it
                pad = 1e-9 * (1.0 + np.abs(got.x))
                near = np.flatnonzero(np.all((L - pad <= got.x) & (got.x <= H + pad), axis=1))
                # the system's cosines and sines are of the joint angles (geometry angles
                # less the offsets gamma), the subtraction's rounding padded outward
                qlo = np.nextafter(np.nextafter(r.lo - gamma, -np.inf), -np.inf)
                qhi = np.nextafter(np.nextafter(r.hi - gamma, np.inf), np.inf)
                if not any(
                    (h := _box_angles(boxes[cl[b]], iv, r.theta - gamma)) is not None and np.all(h[0] <= qlo) and np.all(qhi <= h[1])
                    for b in near
                ):
                    continue
                if not new(got.q, sols):
                    continue
                res.components.append(Component(0, [], True, rank=n, dof=0, point=got.x, width=got.width))
                sols.append(got)
                found.append(got.x)
                proven += 1
    if proven:
        res.solutions = sols
        res.undecided = sorted(undecided)
        res.stats["solutions"] = len(sols)
        res.stats["certified"] = sum(x.certified for x in sols)
        res.stats["unresolved_boxes"] = len(res.undecided)
        res.stats["proven_in_angles"] = proven
    return res
