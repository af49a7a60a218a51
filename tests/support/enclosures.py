"""The 40-digit check of the general formulation's boxes: every root of the pose as given (complex
Newton in mpmath) against the certified solver boxes of a branch-and-prune answer (an answer of
any path is judged by what it reports: :mod:`tests.support.curves`)."""

from __future__ import annotations

import mpmath as mp
import numpy as np

from tests.support.oracles import mp_ik


def general_check(ik, goal, res, extra_seeds=(), chain=None, roots=None) -> dict:
    """The 40-digit roots against the solver boxes of an answer of the general formulation
    (``formulation="general"``, whose variables ``c[joint]``, ``s[joint]`` are the cosine and sine of each joint's angle):
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
