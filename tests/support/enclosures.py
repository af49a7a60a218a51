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
