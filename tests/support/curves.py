"""An answer against the 40-digit roots of its pose, as counts (tests/answer/test_curves.py,
scripts/soundness_sweep.py).

The answer is judged by what it reports, whichever path produced it (the closed form, the
eigenvalue path, the branch and prune): each :class:`~kinbox.answer.result.Solution` with its
``q``, ``width`` and status, and each curve's points. Nothing path-internal (the solver's boxes,
the formulation's variables) is read: a closed-form answer has no solver boxes, and a check of
them would call its roots lost.

What a solution's ``width`` says about the roots: a certified solution's proof box holds ``q``
and exactly one root; the box is ``width`` wide in the joint angles where the answer says its
certificate is in the joint angles (``stats["certificate"] == "joint angles"``: the closed form
and the eigenvalue path), else in the system's variables, where the cosine and sine of each
joint angle are within ``width`` of those of ``q``: its angle then within ``2 width``
(``2 asin(sqrt(2) w / 2) <= 2 w`` for ``w <= 1``). An uncertified point stands for every root
within the same distance of it (a cluster the precision cannot separate: ``multiplicity`` roots,
real or complex, ``not_separated_within`` its width in the JSON), or, where it says the count
is not known (``count_known`` False, ``roots_within: "not known"``), for the roots within that
distance, however many: it must still reach one.
"""

from __future__ import annotations

import mpmath as mp
import numpy as np

from tests.support.oracles import mp_ik

#: ulps of an angle allowed on top of a box's reach: ``q`` is the box's point rounded once more
#: (an offset added, a turn of 2 pi)
ULPS = 8


def _gaps(q: np.ndarray, root) -> list:
    """Per joint, the distance modulo 2 pi of the exact root to the binary64 ``q`` (mp)."""
    return [abs(mp_ik.wrap(mp.mpf(float(a)) - b)) for a, b in zip(np.asarray(q, dtype=float)[:6], root)]


def reach(res, s) -> float:
    """How far in each joint angle a root can be from ``s.q`` and still be in the box ``s``
    reports (module docstring)."""
    return float(s.width) * (1.0 if res.stats.get("certificate") == "joint angles" else 2.0)


def holds(res, s, root) -> bool:
    """Whether the box the answer reports for solution ``s`` reaches the exact ``root``."""
    r = reach(res, s)
    return all(g <= r + ULPS * np.spacing(max(1.0, abs(float(a)))) for g, a in zip(_gaps(s.q, root), s.q))


def _complex_within(q: np.ndarray, root, r: float) -> bool:
    """Whether every joint of the complex ``root`` is within ``r`` (modulus, real part modulo
    2 pi) of the binary64 ``q``."""
    return all(abs(mp.mpc(mp_ik.wrap(mp.re(b) - mp.mpf(float(a))), mp.im(b))) <= r for a, b in zip(np.asarray(q, dtype=float)[:6], root))


def stated(s) -> int | None:
    """The number of roots an uncertified point says it stands for: its multiplicity, or None
    (none stated) where it is not finite or the point says the count is not known."""
    return s.multiplicity if getattr(s, "count_known", True) else None


def _angle_gap(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(np.angle(np.exp(1j * (np.asarray(a)[:6] - np.asarray(b)[:6]))))))


def oracle_roots(ik, goal, res, q, chain=None, ur: str | None = None) -> tuple[list, list]:
    """The 40-digit roots of ``goal`` (real, complex), complex Newton from ``q``, the closed form
    of the published UR geometry (``ur``), every reported point and points along every curve,
    each with its wrist and elbow flips."""
    # the closed form of the published UR geometry is off from the URDF's by ~1e-11, and at a
    # wrist below 1e-12 it takes theta6 = 0: starting points independent of kinbox
    from tests.support.oracles.ur_ik import ur_ik

    chain = chain or mp_ik.Chain(ik.robot.model, ik.frame)
    starts = [q]
    if ur is not None:
        starts += ur_ik(ur, goal.homogeneous, tol=1e-6, singular="zero")
    starts += [s.q for s in res.solutions]
    for c in res.curves.values():
        for br in c.branches:
            starts += list(br[:: max(1, len(br) // 40)])
    seeds: list = []
    for s in starts:
        seeds += mp_ik.wrist_and_elbow_seeds(np.asarray(s, dtype=float)[:6])
    # a pair that has become complex is reached only from complex starts: next to each point
    # reported uncertified, a few steps into the complex directions (a fixed generator)
    rng = np.random.default_rng(0)
    for s in res.solutions:
        if not s.certified:
            for t in (1e-7, 1e-6, 1e-5):
                for d in rng.normal(size=(4, 6)):
                    seeds.append(np.asarray(s.q, dtype=float)[:6] + 1j * t * d / np.linalg.norm(d))
    return mp_ik.roots(chain, mp_ik.exact_pose(goal), seeds)


def judge(ik, goal, res, q, chain=None, ur: str | None = None, roots: tuple | None = None) -> dict:
    """The answer ``res`` of the pose ``goal`` (reached at ``q``; ``ur``: a UR arm's name, whose
    closed form gives more starting points; ``roots``: the oracle's ``(real, complex)`` roots
    of an earlier call) against its 40-digit roots, as counts (``scripts/soundness_sweep.py``
    prints them): ``real``/``complex`` roots of the oracle; ``found`` reported points,
    ``certified``, ``clusters`` (uncertified points standing for several roots), ``uncounted``
    (uncertified points whose count of roots is not known), ``curves``,
    ``undecided`` boxes; ``duplicates`` (two reported points whose boxes reach each other, or
    a reported point on a reported curve); ``lost`` (a real root in no certified box and
    within no uncertified point's reach, and per uncertified point the real roots it reaches
    beyond its multiplicity); ``merged`` (a certified box that reaches two real roots: it claims
    exactly one); ``complex_in_clusters`` (complex roots within an uncertified point's reach);
    ``cluster_over`` (per uncertified point, the roots, real and complex, it reaches beyond its
    multiplicity); ``cluster_short`` (a complex root within ten times an uncertified point's
    reach but outside every one: the width it states is too small for its pair); ``phantom``
    (an uncertified point that reaches no root, real or complex);
    ``cert_missing`` (a certified box holding no root); ``max_cert_distance`` (the largest
    distance in joint space between a certified point and the 40-digit root its box holds)."""
    real, cplx = roots if roots is not None else oracle_roots(ik, goal, res, q, chain=chain, ur=ur)
    sols = res.solutions
    curves = [c for c in res.curves.values()]
    dup = 0
    for i in range(len(sols)):
        for j in range(i):
            if _angle_gap(sols[i].q, sols[j].q) <= max(reach(res, sols[i]), reach(res, sols[j]), 1e-12):
                dup += 1
    for s in sols:
        if any(_angle_gap(s.q, p) <= max(reach(res, s), 1e-9) for c in curves for br in c.branches for p in br):
            dup += 1
    held = [[k for k, r in enumerate(real) if holds(res, s, r)] for s in sols]
    missing = sum(1 for s, h in zip(sols, held) if s.certified and not h)
    merged = sum(1 for s, h in zip(sols, held) if s.certified and len(h) > 1)
    dist = 0.0
    for s, h in zip(sols, held):
        if s.certified and h:
            dist = max(dist, min(float(max(_gaps(s.q, real[k]))) for k in h))
    certified = {k for s, h in zip(sols, held) if s.certified for k in h}
    reached = {k for s, h in zip(sols, held) if not s.certified for k in h}
    lost = len(set(range(len(real))) - certified - reached)
    # a cluster stands for ``multiplicity`` roots: the real roots it reaches beyond that are lost
    for s, h in zip(sols, held):
        k = stated(s)
        if not s.certified and k is not None:
            lost += max(0, len(set(h) - certified) - k)
    # a cluster says "k roots, real or complex, within its width": the roots it reaches, real and
    # complex, beyond its k are under-counted; a complex root next to a cluster and outside its
    # reach (within ten times) is a cluster whose width is too small for the pair it stands for
    creach = [[k for k, r in enumerate(cplx) if _complex_within(s.q, r, reach(res, s))] for s in sols]
    over = 0
    for s, h, c in zip(sols, held, creach):
        k = stated(s)
        if not s.certified and k is not None:
            over += max(0, len(set(h) - certified) + len(c) - k)
    # an uncertified point that reaches no root, real or complex: it reports a root where the
    # oracle finds none (next to a valley of near-solutions: a point of the valley's floor)
    phantom = sum(1 for s, h, c in zip(sols, held, creach) if not s.certified and not h and not c)
    short = 0
    for k, r in enumerate(cplx):
        near = [s for s in sols if not s.certified and _complex_within(s.q, r, 10 * reach(res, s))]
        if near and not any(k in c for s, c in zip(sols, creach) if not s.certified):
            short += 1
    roots_out = []
    for r in real:
        qs = np.array([float(v) for v in r])
        roots_out.append(
            {
                "q": qs,
                "in_certified_box": any(s.certified and holds(res, s, r) for s in sols),
                "distance": min((_angle_gap(s.q, qs) for s in sols), default=np.inf),
            }
        )
    return dict(
        real=len(real),
        complex=len(cplx),
        found=len(sols),
        certified=sum(1 for s in sols if s.certified),
        clusters=sum(1 for s in sols if not s.certified and (s.multiplicity or 0) >= 2),
        uncounted=sum(1 for s in sols if not s.certified and not getattr(s, "count_known", True)),
        curves=len(curves),
        undecided=int(res.stats.get("unresolved_boxes", 0) or 0),
        duplicates=dup,
        lost=lost,
        merged=merged,
        complex_in_clusters=sum(1 for k in range(len(cplx)) if any(k in c for s, c in zip(sols, creach) if not s.certified)),
        cluster_over=over,
        cluster_short=short,
        phantom=phantom,
        cert_missing=missing,
        max_cert_distance=dist,
        roots=roots_out,
    )
