"""An answer against the 40-digit roots of its pose, as counts (tests/answer/test_curves.py,
scripts/soundness_sweep.py)."""

from __future__ import annotations

import numpy as np

from tests.support.enclosures import oracle_check


def _angle_gap(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(np.angle(np.exp(1j * (np.asarray(a)[:6] - np.asarray(b)[:6]))))))


def judge(ik, goal, res, q, chain=None, ur: str | None = None) -> dict:
    """The answer ``res`` of the pose ``goal`` (reached at ``q``; ``ur``: a UR arm's name, whose
    closed form gives more starting points) against its 40-digit roots,
    as counts (``scripts/soundness_sweep.py`` prints them): ``real``/``complex`` roots of the
    oracle; ``found`` reported points, ``certified``, ``clusters`` (uncertified points standing
    for several roots), ``curves``, ``undecided`` boxes; ``duplicates`` (two reported points
    closer than their widths, or a certified root on a reported curve); ``lost`` (a real root
    in no certified box and within no uncertified point's width, or a cluster whose
    multiplicity is below the roots it stands for); ``cert_missing`` (a certified box holding
    no root); ``max_cert_distance`` (the largest distance in joint space between a certified
    point and the 40-digit root its box holds)."""
    # starting points independent of kinbox: the closed form of the published UR geometry (off
    # from the URDF's by ~1e-11, and at a wrist below 1e-12 it takes theta6 = 0): Newton at 40
    # digits from each
    from tests.support.oracles.ur_ik import ur_ik

    seeds = [q]
    if ur is not None:
        seeds += ur_ik(ur, goal.homogeneous, tol=1e-6, singular="zero")
    rep = oracle_check(ik, goal, res, seeds, chain=chain)
    sols = res.solutions
    dup = 0
    for i in range(len(sols)):
        for j in range(i):
            if _angle_gap(sols[i].q, sols[j].q) <= max(sols[i].width, sols[j].width, 1e-12):
                dup += 1
    curves = [c for c in res.components if c.dimension >= 1]
    for s in sols:
        if s.certified and any(_angle_gap(s.q, ik.arm.decode(x)) <= max(s.width, 1e-9) for c in curves for pl in c.polylines for x in pl):
            dup += 1
    missing, dist = 0, 0.0
    for s in sols:
        if not s.certified:
            continue
        held = [r for r in rep["roots"] if r["in_certified_box"] and _angle_gap(s.q, r["q"]) <= s.width + 1e-12]
        if not held:
            missing += 1
        else:
            dist = max(dist, min(_angle_gap(s.q, r["q"]) for r in held))
    lost = 0
    for r in rep["roots"]:
        if r["in_certified_box"]:
            continue
        near = [s for s in sols if not s.certified and _angle_gap(s.q, r["q"]) <= max(s.width, 1e-9)]
        if not near:
            lost += 1
            continue
        k = sum(1 for o in rep["roots"] if _angle_gap(o["q"], near[0].q) <= max(near[0].width, 1e-9))
        if near[0].multiplicity is not None and near[0].multiplicity < k:
            lost += 1
    return dict(
        real=rep["real"],
        complex=rep["complex"],
        found=len(sols),
        certified=sum(1 for s in sols if s.certified),
        clusters=sum(1 for s in sols if not s.certified and (s.multiplicity or 0) >= 2),
        curves=len(curves),
        undecided=int(res.stats.get("unresolved_boxes", 0) or 0),
        duplicates=dup,
        lost=lost,
        cert_missing=missing,
        max_cert_distance=dist,
        roots=rep["roots"],
    )
