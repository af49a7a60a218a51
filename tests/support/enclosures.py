"""The 40-digit check of an IK answer: every root of the pose as given (complex Newton in mpmath)
against the certified boxes kinbox reports."""

from __future__ import annotations

import mpmath as mp
import numpy as np

from tests.support.oracles import mp_ik


def _joint_vars(arm):
    """(joint index, gamma, variable of cos, variable of sin) of the arm's revolute joints whose
    cosine and sine are variables of the system."""
    out = []
    for j, jv, gam in zip(arm.geometry.chain.joints, arm.jvars, arm.geometry.gamma):
        ic = [k[0] for k, v in jv.c.terms.items() if len(k) == 1 and v == 1.0 and len(jv.c.terms) == 1]
        is_ = [k[0] for k, v in jv.s.terms.items() if len(k) == 1 and v == 1.0 and len(jv.s.terms) == 1]
        if ic and is_:
            out.append((j.idx_q, float(gam), ic[0], is_[0]))
    return out


def oracle_check(ik, goal, res, extra_seeds=(), chain=None) -> dict:
    """The 40-digit roots of the pose (Newton from kinbox's answer, its curves and
    ``extra_seeds``) against kinbox's answer: per oracle root, the certified box holding it (its
    cosines and sines of the joint angles, at 60 digits), or the distance to the nearest
    reported point."""
    chain = chain or mp_ik.Chain(ik.robot.model, ik.frame)
    g = mp_ik.exact_pose(goal)
    seeds = []
    for s in [*extra_seeds, *(sol.q for sol in res.solutions)]:
        seeds += mp_ik.wrist_and_elbow_seeds(np.asarray(s, dtype=float)[:6])
    for c in res.components:
        for pl in c.polylines:
            for x in pl[:: max(1, len(pl) // 40)]:
                seeds.append(ik.arm.decode(x)[:6])
    real, cplx = mp_ik.roots(chain, g, seeds)
    jv = _joint_vars(ik.arm)
    report = {"real": len(real), "complex": len(cplx), "roots": []}
    for r in real:
        qs = np.array([float(v) for v in r])
        best = None
        for b in res.raw.boxes:
            if not b.certified:
                continue
            lo, hi = b.enclosure
            inside = True
            for iq, gam, ic, is_ in jv:
                th = r[iq] + mp.mpf(gam)
                for i, val in ((ic, mp.cos(th)), (is_, mp.sin(th))):
                    if not (mp.mpf(float(lo[i])) <= val <= mp.mpf(float(hi[i]))):
                        inside = False
            if inside:
                best = b
        dist = min((float(np.max(np.abs(np.angle(np.exp(1j * (s.q[:6] - qs)))))) for s in res.solutions), default=np.inf)
        report["roots"].append({"q": qs, "in_certified_box": best is not None, "width": best.width if best else None, "distance": dist})
    return report


def general_check(ik, goal, res, extra_seeds=(), chain=None, roots=None) -> dict:
    """:func:`oracle_check` for an answer of the general formulation (``formulation="general"``,
    whose variables ``c[joint]``, ``s[joint]`` are the cosine and sine of each joint's angle):
    per 40-digit root, whether a certified box holds its cosines and sines (at 60 digits),
    and its distance to the nearest certified box (0 inside; in the box's variables).
    ``roots``: the oracle's ``(real, complex)`` roots of an earlier call, to check another
    answer of the same pose against them."""
    chain = chain or mp_ik.Chain(ik.robot.model, ik.frame)
    if roots is None:
        g = mp_ik.exact_pose(goal)
        seeds = []
        for s in [*extra_seeds, *(sol.q for sol in res.solutions)]:
            seeds += mp_ik.wrist_and_elbow_seeds(np.asarray(s, dtype=float)[:6])
        roots = mp_ik.roots(chain, g, seeds)
    real, cplx = roots
    names = res.raw.system.names
    model = ik.robot.model
    cols = []
    for j, iq in zip(chain.joints, chain.idx_q):
        nm = model.names[j]
        cols.append((iq, names.index(f"c[{nm}]"), names.index(f"s[{nm}]")))
    report = {"real": len(real), "complex": len(cplx), "roots": [], "oracle": roots}
    mp.mp.dps = 60
    for r in real:
        best, gap = None, np.inf
        for b in res.raw.boxes:
            if not b.certified:
                continue
            lo, hi = b.enclosure
            d = mp.mpf(0)
            for iq, ic, is_ in cols:
                for i, val in ((ic, mp.cos(r[iq])), (is_, mp.sin(r[iq]))):
                    d = max(d, mp.mpf(float(lo[i])) - val, val - mp.mpf(float(hi[i])))
            if d <= 0:
                best, gap = b, 0.0
            gap = min(gap, float(d))
        report["roots"].append(
            {"q": np.array([float(v) for v in r]), "in_certified_box": best is not None, "width": best.width if best else None, "gap": gap}
        )
    return report
