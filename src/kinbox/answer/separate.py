"""A near-double pair reported as two certified roots where they can be told apart.

An answer of the branch and prune reports a pair of roots closer than its boxes resolve as one
uncertified point of multiplicity 2 ("2 roots, real or complex, within d"). For an arm of six
revolute joints with Krawczyk in the joint angles (:class:`~kinbox.search.cf_certify.JointCertifier`),
:func:`separate_clusters` hands each such point to :func:`kinbox.search.separate.separate_pair`
with the region its boxes cover (each box's joint angles, from its cosine and sine variables);
where that proves two roots, each alone in a disjoint box, and no other root in the region, the
point is replaced by the two certified solutions. Otherwise (a complex pair, a pair closer than
the enclosures separate, a budget hit) the point stays as it was
(``tests/answer/test_separate.py``).
"""

from __future__ import annotations

import math

import numpy as np

from ..formulation.arm import ArmTemplate, _is_var, get_angle, put_angle, var_index
from ..search.status import BoxStatus
from .components import Component
from .result import Result, Solution, max_residual
from .turns import add_turns

#: how :func:`kinbox.answer.turns.add_turns` starts its note
TURNS_NOTE = "joints with a range wider than a turn"

#: a separated root this close (radians, any joint) to another reported solution is not taken
#: as new: the cluster stays
APART = 1e-6


def _angle_hull(c: tuple[float, float], s: tuple[float, float], centre: float) -> tuple[float, float] | None:
    """The angles ``theta`` with ``cos theta`` in ``c`` and ``sin theta`` in ``s``, as an
    interval about ``centre``: over a box of the plane clear of the origin, within an angle
    below a half turn, the angle's extremes are at the box's corners (``atan2`` within a few
    ulps; 8 of them added). None where the box reaches the origin or spans too wide."""
    (c0, c1), (s0, s1) = c, s
    if c0 <= 0.0 <= c1 and s0 <= 0.0 <= s1:
        return None
    angs = []
    for x in (c0, c1):
        for y in (s0, s1):
            a = math.atan2(y, x) - centre
            angs.append(a - 2.0 * math.pi * round(a / (2.0 * math.pi)))
    lo, hi = min(angs), max(angs)
    if not hi - lo < 1.0:
        return None
    pad = 8.0 * np.spacing(max(abs(centre) + abs(lo), abs(centre) + abs(hi), 1.0)) + 1e-300
    return float(np.nextafter(centre + lo - pad, -np.inf)), float(np.nextafter(centre + hi + pad, np.inf))


def _region(arm: ArmTemplate, boxes: list, centre: np.ndarray) -> list | None:
    """Each box's joint angles (geometry angles, one interval per joint about ``centre``), or
    None where a joint has no cosine and sine variables."""
    out = []
    for b in boxes:
        lo, hi = np.empty(6), np.empty(6)
        for i, jv in enumerate(arm.jvars):
            if jv.c is None or jv.s is None or not _is_var(jv.c) or not _is_var(jv.s):
                return None
            ic, is_ = var_index(jv.c), var_index(jv.s)
            h = _angle_hull((float(b.lo[ic]), float(b.hi[ic])), (float(b.lo[is_]), float(b.hi[is_])), float(centre[i]))
            if h is None:
                return None
            lo[i], hi[i] = h
        out.append((lo, hi))
    return out


def separate_clusters(res: Result, arm, joint_certifier, pose: np.ndarray, exact: dict | None = None) -> Result:
    """``res`` with each uncertified point of multiplicity 2 replaced by two certified roots
    where :func:`~kinbox.search.separate.separate_pair` proves them (module docstring); ``pose``
    the goal's XYZQUAT as given; ``exact`` the model's exact links and frames
    (``enclose_links(..., keep_exact=True)`` of :mod:`kinbox.formulation.constants`; None: the
    template's constants with their radii). Changes ``res`` in place and returns it."""
    if joint_certifier is None or not isinstance(arm, ArmTemplate) or len(arm.jvars) != 6 or not res.complete:
        return res
    g = arm.geometry
    if any(j.kind != "revolute" for j in g.chain.joints):
        return res
    targets = [k for k, s in enumerate(res.solutions) if not s.certified and s.multiplicity == 2 and s.component >= 0]
    if not targets:
        return res
    from ..search.separate import arm_constants, separate_pair

    cs = arm_constants(g, arm.constants, exact)

    mech = res.formulated.mechanism
    data = mech.model.createData()
    V = np.asarray(pose, dtype=float)
    replaced = 0
    new_sols: list[Solution] = []
    for k, s in enumerate(res.solutions):
        if k not in targets:
            new_sols.append(s)
            continue
        comp = res.components[s.component]
        centre = np.array([get_angle(s.q, j) + gam for j, gam in zip(g.chain.joints, g.gamma)])
        region = _region(arm, [res.raw.boxes[b] for b in comp.boxes], centre)
        sep = separate_pair(cs, V, centre, region) if region is not None else None
        pair = _solutions(res, g, sep, region, s, data) if sep is not None and region is not None else None
        if pair is None:
            new_sols.append(s)
            continue
        a, b = pair
        a.component = s.component
        res.components[s.component] = Component(0, comp.boxes, True, rank=comp.rank + comp.dof, dof=0, point=a.x, width=a.width)
        b.component = len(res.components)
        res.components.append(Component(0, comp.boxes, True, rank=comp.rank + comp.dof, dof=0, point=b.x, width=b.width))
        new_sols += [a, b]
        replaced += 1
    if replaced:
        res.solutions = new_sols
        res.stats["solutions"] = len(new_sols)
        res.stats["certified"] = sum(x.certified for x in new_sols)
        res.stats["singular"] = sum(x.singular for x in new_sols)
        res.stats["separated"] = replaced
    return res


def _solutions(res: Result, g, sep, region: list, s: Solution, data) -> tuple[Solution, Solution] | None:
    """The two certified solutions of a separated pair, or None where a root lies outside the
    cluster's region or next to another reported solution."""
    out = []
    mech = res.formulated.mechanism
    for theta, lo, hi in zip(sep.theta, sep.lo, sep.hi):
        if not any(np.all((rl <= lo) & (hi <= rh)) for rl, rh in region):
            return None
        q = np.array(s.q, dtype=float)
        for j, gam, th in zip(g.chain.joints, g.gamma, theta):
            put_angle(q, j, float(th) - gam)
        for o in res.solutions:
            if o is not s and o.q.shape == q.shape:
                gap = np.abs(np.angle(np.exp(1j * (np.asarray(o.q) - q))))
                if float(np.max(gap)) <= APART:
                    return None
        # the box's width in the joint angles; the cosine and sine of each, 1-Lipschitz, vary
        # no more over it, so it bounds them too (the system's variables' reading of a width)
        width = float(np.max(hi - lo))
        x = res.formulated.encode(q)
        out.append(Solution(q, max_residual(mech, q, data), BoxStatus.CERTIFIED, width, x))
    return out[0], out[1]


def turns_again(res: Result, all_turns: bool) -> None:
    """The joints that wrap named and counted again over ``res``'s solutions as they are now
    (:func:`kinbox.answer.turns.add_turns`; with ``all_turns`` every copy listed), its earlier
    note replaced: after a separation the count covers both roots
    (``tests/answer/test_separate.py::test_every_turn_of_both_roots``)."""
    res.notes = [n for n in res.notes if not n.startswith(TURNS_NOTE)]
    add_turns(res, all_turns)
