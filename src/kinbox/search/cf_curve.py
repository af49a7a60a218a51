"""The curve of an arm of three parallel axes at a wrist singularity, in closed form.

On the ``parallel`` family (lines 2, 3, 4 parallel, lines 5 and 6 meeting: the UR series) the
closed form (:func:`~kinbox.search.closed_form.solve_branches`) takes joint 1 from the offset
along line 2, joint 5 from the axis of lines 2-4 (``A5 c5 + B5 s5 = K5``), joint 6 from the
rotation taking ``kk`` to the goal's ``rho`` (``sp_rot``), and joints 3, 2, 4 from a planar arm.
At a wrist singularity joint 5's discriminant is zero: joint 5 is at the double root
``theta5*`` and line 6 is parallel to lines 2-4. Then ``|kk_xy|`` is zero and joint 6 is free:
for every value ``t`` of it the planar arm of joints 2, 3, 4 places the rest, two elbow
branches where its discriminant ``D3(t)`` is positive, none where it is negative, the two
joined where it changes sign (a fold). The configurations form curves with ``t`` as parameter.

:func:`wrist_curves` evaluates that algebra in interval arithmetic over arcs of ``t``
(:func:`singular_arc`), with joint 5's relaxed enclosure (both roots of its discriminant
holding zero, as :func:`~kinbox.search.cf_fallback.parallel_enclosures` takes it): each
arc's boxes hold every root of the pose with joint 6 in the arc, so together with joint 1's
proven branches they hold every root. An arc is *decided* where ``D3`` is proven positive (two
roots for every ``t`` of it, each a continuous function of ``t``: the same formula, ``sqrt D3 >
0`` keeping them apart) or negative (none); arcs where ``D3`` holds zero (or a pivot of the
elbow or of joint 2 does) are cut in two down to :data:`FOLD_WIDTH` and what is left is a *fold
region*. The curve is sampled at points of the
decided arcs (joint 5 at ``theta5*``, joint 6 at ``t``: a point of the singular arm's curve,
closing the pose's equations to rounding only where the pose is singular; the answer stage
checks that, :mod:`kinbox.answer.cf_curve`), refined until consecutive samples are at most
:data:`STEP` apart in every joint. Each run of two-root arcs between two folds is one closed
curve (one branch out, the other back); a run all around the circle is two. A branch of joint
1 whose wrist is not singular keeps its relaxed enclosures (``others``), which the branch and
prune searches. Anything else -- joint 1 undecided (a shoulder pivot holding zero), a fold
region next to two roots on both sides (a tangency), an elbow or joint-2 pivot holding zero on
an arc cut down to :data:`FOLD_WIDTH`, too many arcs, a joint whose limits are narrower than a
turn, the other branch's boxes too near the curves' joint 1 -- returns None and the pose goes
to the branch and prune as before.
``tests/search/test_cf_curve.py`` checks the curves against the branch and prune's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from . import jit as nb
from .closed_form import (
    _b_of,
    _elbow,
    _elbow_lin,
    _lin_about,
    _planar_target,
    _rotated_by,
    cst,
    fmtv,
    iadd,
    imtv,
    imul,
    iscale,
    isub,
    mcol,
    mrow,
    rz,
    rzt,
    sp_lin,
    sp_rot,
    vdot,
    vscale,
    vsub,
)

#: arcs joint 6's turn is cut into first
ARCS = 64
#: an arc where the elbow's discriminant holds zero is cut in two down to this width
FOLD_WIDTH = 1e-7
#: largest step between consecutive samples of a curve, in any joint (radians) ...
STEP = 0.05
#: ... down to this width of ``t`` (next to a fold the elbow turns like ``sqrt(t - t_fold)``)
STEP_WIDTH = 1e-7
#: the most arcs and samples of one pose (beyond them: the branch and prune)
MAX_ARCS = 4096
MAX_SAMPLES = 20000

#: :func:`singular_arc`'s codes
NO_SHOULDER = -1  # joint 1 not decided (a shoulder singularity)
NO_BRANCH = -2  # joint 1 has no such branch
EMPTY = -3  # this branch of joint 1 holds no root (joint 5's discriminant proven negative)
NOT_SINGULAR = -4  # this branch's wrist is not singular (or not provably so): isolated roots
DEGENERATE = -5  # another pivot holds zero (the elbow's, joint 2's)


@nb.njit(cache=True)
def singular_arc(LR, Lt, d, Rlo, Rhi, tlo, thi, i1, c6, s6, c5p, s5p, point5, classify, out):
    """Branch ``i1`` of joint 1, joint 6's ``(cos, sin)`` in ``c6``, ``s6`` (intervals): where
    its wrist is singular (joint 5's discriminant holds zero and ``|kk_xy|^2`` holds zero),
    ``st3`` of the elbow (2: two roots, 0: none, 3: its discriminant holds zero) and the two
    roots' enclosures of every joint in ``out[0]``, ``out[1]`` ((6, 4): ``c_lo, c_hi, s_lo,
    s_hi``); else a negative code (:data:`NO_SHOULDER` ...). Joint 5 is the hull of its two
    relaxed roots, or the point ``(c5p, s5p)`` with ``point5`` (a sample of the singular arm).
    ``classify``: 3
    where the wrist is singular, without the elbow (joint 6 is then not used)."""
    R = (
        ((Rlo[0, 0], Rhi[0, 0]), (Rlo[0, 1], Rhi[0, 1]), (Rlo[0, 2], Rhi[0, 2])),
        ((Rlo[1, 0], Rhi[1, 0]), (Rlo[1, 1], Rhi[1, 1]), (Rlo[1, 2], Rhi[1, 2])),
        ((Rlo[2, 0], Rhi[2, 0]), (Rlo[2, 1], Rhi[2, 1]), (Rlo[2, 2], Rhi[2, 2])),
    )
    t = ((tlo[0], thi[0]), (tlo[1], thi[1]), (tlo[2], thi[2]))
    Rez = (R[0][2], R[1][2], R[2][2])
    base, f, g = _elbow(LR, Lt, d)
    sigma = LR[1][2, 2] * LR[2][2, 2]
    nn = LR[0][:, 2]
    o5 = vsub(t, vscale(cst(d[5]), Rez))
    hz = iadd(iadd(cst(d[1]), cst(Lt[1][2])), iscale(LR[1][2, 2], iadd(iadd(cst(d[2]), cst(Lt[2][2])), iscale(LR[2][2, 2], cst(d[3])))))
    Kc = iadd(hz, iscale(sigma, iadd(cst(Lt[3][2]), imul(cst(d[4]), cst(LR[3][2, 2])))))
    A1, B1, C1 = _rotated_by(nn, o5)
    K1 = isub(iadd(Kc, vdot(mcol(LR[0], 2), mrow(Lt, 0))), C1)
    st1, c1a, s1a, c1b, s1b = sp_lin(A1, B1, K1, False)
    if st1 < 0:
        return NO_SHOULDER
    if i1 >= st1:
        return NO_BRANCH
    c1, s1 = (c1a, s1a) if i1 == 0 else (c1b, s1b)
    for k in range(2):
        out[k, 0, 0] = c1[0]
        out[k, 0, 1] = c1[1]
        out[k, 0, 2] = s1[0]
        out[k, 0, 3] = s1[1]
    A5, B5, C5 = _lin_about(LR[3][2, :], LR[4][:, 2])
    zeta = fmtv(LR[0], rzt(c1, s1, Rez))
    st5, c5a, s5a, c5b, s5b = sp_lin(A5, B5, isub(iscale(sigma, zeta[2]), C5), True)
    if st5 == 0:
        return EMPTY
    if st5 != 3:
        return NOT_SINGULAR
    c5 = (min(c5a[0], c5b[0]), max(c5a[1], c5b[1]))
    s5 = (min(s5a[0], s5b[0]), max(s5a[1], s5b[1]))
    for k in range(2):
        out[k, 4, 0] = c5[0]
        out[k, 4, 1] = c5[1]
        out[k, 4, 2] = s5[0]
        out[k, 4, 3] = s5[1]
    rho = imtv(R, rz(c1, s1, mcol(LR[0], 2)))
    kk = fmtv(LR[4], rzt(c5, s5, mrow(LR[3], 2)))
    ok, _, _ = sp_rot(kk, (iscale(sigma, rho[0]), iscale(sigma, rho[1]), iscale(sigma, rho[2])))
    if ok:  # joint 6 is decided: the wrist is not singular
        return NOT_SINGULAR
    if classify:
        return 3
    if point5:
        c5, s5 = (c5p, c5p), (s5p, s5p)
    Xt, Xex = _planar_target(LR, Lt, d, R, t, c1, s1, c5, s5, c6, s6)
    A3, B3, K3 = _elbow_lin(f, g, iadd(iadd(imul(Xt[0], Xt[0]), imul(Xt[1], Xt[1])), imul(Xt[2], Xt[2])))
    st3, c3a, s3a, c3b, s3b = sp_lin(A3, B3, K3, True)
    if st3 == 0:
        return 0
    if st3 < 0:  # the elbow's r2 holds zero
        return DEGENERATE
    for k in range(2):
        c3, s3 = (c3a, s3a) if k == 0 else (c3b, s3b)
        b = _b_of(LR, base, g, c3, s3)
        ok2, c2, s2 = sp_rot(b, Xt)
        if not ok2:
            return DEGENERATE
        col = fmtv(LR[2], rzt(c3, s3, fmtv(LR[1], rzt(c2, s2, Xex))))
        vals = ((c1, s1), (c2, s2), (c3, s3), (col[0], col[1]), (c5, s5), (c6, s6))
        for j in range(6):
            out[k, j, 0] = vals[j][0][0]
            out[k, j, 1] = vals[j][0][1]
            out[k, j, 2] = vals[j][1][0]
            out[k, j, 3] = vals[j][1][1]
    return st3


@dataclass
class WristCurve:
    """One closed curve: ``theta`` (m, 6) the family's angles of its samples in order (the last
    joins the first), ``boxes`` the enclosures ((6, 4) each) of the arcs it passes through."""

    theta: np.ndarray
    boxes: list[np.ndarray] = field(default_factory=list)


@dataclass
class WristCurves:
    """The curves of a wrist-singular pose and what was evaluated to prove them."""

    curves: list[WristCurve]
    #: the joint-1 branches whose wrist is singular, and those proven empty
    singular_branches: list[int]
    arcs: int
    fold_regions: int
    evaluations: int
    #: the relaxed enclosures ((6, 4) each) of the joint-1 branches whose wrist is not singular,
    #: where isolated roots can be (:func:`kinbox.search.cf_fallback.folded_enclosures`'), and
    #: their pair ids (the two boxes of a relaxed elbow)
    others: list[np.ndarray] = field(default_factory=list)
    other_pairs: list[int] = field(default_factory=list)


def _arc(a: float, b: float) -> tuple[tuple[float, float], tuple[float, float]]:
    """Enclosures of ``(cos, sin)`` over ``[a, b]`` (as :func:`kinbox.search.cf_fallback.arc_box`)."""
    from .cf_fallback import arc_box

    box = np.zeros((6, 4))
    arc_box(a, b, box, 5)
    return (box[5, 0], box[5, 1]), (box[5, 2], box[5, 3])


class _Branch:
    """Evaluations of one singular branch ``i1`` of joint 1."""

    def __init__(self, cf, goal, i1: int, c5: float, s5: float):
        self.cf, self.goal, self.i1, self.c5, self.s5 = cf, goal, i1, c5, s5
        self.out = np.zeros((2, 6, 4))
        self.evaluations = 0

    def eval(self, cs, point: bool) -> tuple[int, np.ndarray]:
        cf = self.cf
        (c6, s6) = cs
        self.evaluations += 1
        st = singular_arc(cf.LR, cf.Lt, cf.d, *self.goal, self.i1, c6, s6, self.c5, self.s5, point, False, self.out)
        return st, self.out.copy()

    def sample(self, t: float) -> np.ndarray | None:
        """The two roots' angles (2, 6) at ``t``, or None where the elbow's discriminant is not
        proven positive there."""
        t = math.remainder(t, 2.0 * math.pi)
        c, s = math.cos(t), math.sin(t)
        e = 1e-15
        st, out = self.eval(((c - e, c + e), (s - e, s + e)), True)
        if st != 2:
            return None
        th = np.arctan2(0.5 * (out[:, :, 2] + out[:, :, 3]), 0.5 * (out[:, :, 0] + out[:, :, 1]))
        th[:, 4] = math.atan2(self.s5, self.c5)
        th[:, 5] = t
        return th


def _branch_curves(br: _Branch) -> tuple[list[WristCurve], int, int] | None:
    """The curves of one singular branch (see the module's text), the number of arcs and of
    fold regions; None where the structure is not the one described there."""
    # arcs: (a, b, st3, boxes)
    todo = [(-math.pi + k * 2.0 * math.pi / ARCS, -math.pi + (k + 1) * 2.0 * math.pi / ARCS) for k in range(ARCS)]
    arcs: list[tuple[float, float, int, np.ndarray]] = []
    while todo:
        a, b = todo.pop()
        st, ev = br.eval(_arc(a, b), False)
        if st == DEGENERATE and b - a > FOLD_WIDTH:  # the elbow's or joint 2's pivot holds zero over the arc
            st = 3
        if st < 0:
            return None
        if st == 3 and b - a > FOLD_WIDTH:
            m = 0.5 * (a + b)
            todo += [(a, m), (m, b)]
        else:
            arcs.append((a, b, st, ev))
        if len(arcs) + len(todo) > MAX_ARCS:
            return None
    arcs.sort(key=lambda x: x[0])
    # group into runs of equal kind: 2 (two roots), 0 (none), 3 (fold region)
    runs: list[list[tuple[float, float, int, np.ndarray]]] = []
    for arc in arcs:
        if runs and runs[-1][-1][2] == arc[2]:
            runs[-1].append(arc)
        else:
            runs.append([arc])
    if len(runs) > 1 and runs[0][0][2] == runs[-1][-1][2]:  # the turn closes: join the last run to the first
        runs[0] = runs.pop() + runs[0]
    kinds = [r[0][2] for r in runs]
    folds = kinds.count(3)
    if len(runs) == 1:
        if kinds[0] == 0:
            return [], len(arcs), 0
        if kinds[0] != 2:
            return None
        curves = _sampled(br, runs[0], wrap=True)
        if curves is None:
            return None
        return [WristCurve(c, [o[k] for *_, o in runs[0]]) for k, c in enumerate(curves)], len(arcs), 0
    n = len(runs)
    found: list[WristCurve] = []
    for i, run in enumerate(runs):
        left, right = kinds[(i - 1) % n], kinds[(i + 1) % n]
        if kinds[i] == 3:
            # a fold region: two roots on exactly one side
            if sorted((left, right)) != [0, 2]:
                return None
            continue
        if kinds[i] == 0:
            continue
        if left != 3 or right != 3:
            return None
        got = _sampled(br, run, wrap=False)
        if got is None:
            return None
        up, down = got
        theta = np.vstack([up, down[::-1]])  # out along one branch, back along the other
        boxes = [o[k] for *_, o in runs[(i - 1) % n] for k in (0, 1)]
        boxes += [o[k] for *_, o in run for k in (0, 1)] + [o[k] for *_, o in runs[(i + 1) % n] for k in (0, 1)]
        found.append(WristCurve(theta, boxes))
    return found, len(arcs), folds


def _sampled(br: _Branch, run: list, wrap: bool) -> tuple[np.ndarray, np.ndarray] | None:
    """Both roots along a run of two-root arcs, sampled at the arcs' ends and refined until
    consecutive samples are within :data:`STEP` in every joint; (m, 6) each, in ``t`` order
    (``wrap``: the run goes all around, its last end is its first)."""
    ts = [run[0][0]] + [b for _, b, _, _ in run]
    for k in range(1, len(ts)):  # a run across t = pi: t kept increasing
        while ts[k] < ts[k - 1]:
            ts[k] += 2.0 * math.pi
    pts: dict[float, np.ndarray] = {}
    for t in ts:
        p = br.sample(t)
        if p is None:
            return None
        pts[t] = p
    order = ts
    while True:
        P = np.array([pts[t] for t in order])
        d = np.abs(np.diff(P, axis=0)) % (2.0 * math.pi)
        gap = np.minimum(d, 2.0 * math.pi - d).max(axis=(1, 2))
        T = np.array(order)
        wide = (gap > STEP) & (np.diff(T) > STEP_WIDTH)
        if not wide.any():
            break
        for m in 0.5 * (T[:-1][wide] + T[1:][wide]):
            p = br.sample(float(m))
            if p is None:
                return None
            pts[float(m)] = p
        if len(pts) > MAX_SAMPLES:
            return None
        order = sorted(pts)
    P = np.array([pts[t] for t in order])
    if wrap:
        P = P[:-1]
    return P[:, 0], P[:, 1]


def wrist_curves(cf, R: np.ndarray, t: np.ndarray, accept=None) -> WristCurves | None:
    """The curves of the goal ``(R, t)`` of the ``parallel`` family at a wrist singularity (see
    the module's text), or None (then the branch and prune answers the pose). A branch of joint
    1 whose wrist is not singular keeps its relaxed enclosures (``others``: the branch and
    prune searches them). ``accept``: called on the first samples found ((2, 6) angles) before
    the arcs are evaluated; False gives None at once (a pose next to the singularity, whose
    isolated roots the singular arm's curve misses)."""
    if cf.code != 3 or np.any(cf.limits[:, 0] != 0.0):
        return None  # a joint narrower than a turn would cut the curves at its limits: not done here
    if cf.LR.ndim != 3:
        return None  # enclosed links (cf_delta.kernel_links): singular_arc takes binary64 ones only
    goal = tuple(np.ascontiguousarray(x[0]) for x in cf.goal_arrays(R[None], t[None]))
    scratch = np.zeros((2, 6, 4))
    curves: list[WristCurve] = []
    singular: list[int] = []
    shoulder: list[np.ndarray] = []  # each branch's joint-1 enclosure
    arcs = folds = evals = 0
    for i1 in range(2):
        st = singular_arc(cf.LR, cf.Lt, cf.d, *goal, i1, (-1.0, 1.0), (-1.0, 1.0), 0.0, 0.0, False, True, scratch)
        evals += 1
        if st == NO_BRANCH:
            break
        shoulder.append(scratch[0, 0].copy())
        if st < 0 and st not in (NOT_SINGULAR, EMPTY):
            return None
        if st < 0:
            continue
        singular.append(i1)
        # joint 5's double root: the midpoint of its enclosure
        c5 = 0.5 * (scratch[0, 4, 0] + scratch[0, 4, 1])
        s5 = 0.5 * (scratch[0, 4, 2] + scratch[0, 4, 3])
        nrm = math.hypot(c5, s5)
        br = _Branch(cf, goal, i1, c5 / nrm, s5 / nrm)
        if accept is not None:
            probe = next((p for p in (br.sample(k * math.pi / 4.0) for k in range(-3, 5)) if p is not None), None)
            if probe is not None and not accept(probe):
                return None
        got = _branch_curves(br)
        evals += br.evaluations
        if got is None:
            return None
        cs, na, nf = got
        curves += cs
        arcs += na
        folds += nf
    if not singular:
        return None
    from .cf_fallback import folded_enclosures

    rest = folded_enclosures(cf, R, t)
    if rest is None:
        return None
    encs, pairs = rest
    keep: list[int] = []
    for k, e in enumerate(encs):
        mine = [i1 for i1, c in enumerate(shoulder) if _meets(e[0], c)]
        if len(mine) != 1:
            return None  # joint 1's branches not told apart
        if mine[0] not in singular:
            # a branch whose wrist is not singular: isolated roots, searched in its box widened
            # as cf_fallback.system_boxes widens it, which must stay off the curves' joint 1
            if any(_meets(_widened(e[0]), shoulder[i1]) for i1 in singular):
                return None
            keep.append(k)
    new = {k: i for i, k in enumerate(keep)}
    others = [encs[k] for k in keep]
    other_pairs = [new.get(pairs[k], -1) if pairs[k] >= 0 else -1 for k in keep]
    return WristCurves(curves, singular, arcs, folds, evals, others, other_pairs)


def _widened(a: np.ndarray) -> np.ndarray:
    """A joint's ``(c_lo, c_hi, s_lo, s_hi)`` widened as :func:`kinbox.search.cf_fallback.system_boxes`
    widens a box's variables (by :data:`~kinbox.search.cf_fallback.WIDEN` times the width plus
    :data:`~kinbox.search.cf_fallback.PAD`; the system's angles are these turned, which only
    moves the enclosure), and a little more."""
    from .cf_fallback import PAD, WIDEN

    wc = 2.0 * (WIDEN * (a[1] - a[0]) + PAD)
    ws = 2.0 * (WIDEN * (a[3] - a[2]) + PAD)
    w = max(wc, ws) + (a[1] - a[0]) + (a[3] - a[2])  # a turn of the (c, s) pair mixes the two widths
    return np.array([a[0] - w, a[1] + w, a[2] - w, a[3] + w])


def _meets(a: np.ndarray, b: np.ndarray) -> bool:
    """Do two joints' ``(c_lo, c_hi, s_lo, s_hi)`` enclosures meet?"""
    return bool(a[0] <= b[1] and b[0] <= a[1] and a[2] <= b[3] and b[2] <= a[3])


def curve_boxes(cf, encs: list[np.ndarray], lo0: np.ndarray, hi0: np.ndarray, params, points: np.ndarray, comp) -> list:
    """The arcs' enclosures ``encs`` (the family's ``(c, s)`` per joint) as curve boxes of the
    kinbox system (:func:`kinbox.search.cf_fallback.system_boxes`), exactly one box each: with
    the variables the template defines enclosed over it where that is not empty, else over the
    domain (the whole domain where even that is empty: an enclosure holding no root), each
    with the sample of ``points`` (the curve's system points) inside it, else its middle, as
    its point."""
    from .boxes import SolutionBox
    from .cf_fallback import system_boxes
    from .status import BoxStatus

    out = []
    for e in encs:
        got = system_boxes(cf, [e], lo0, hi0, params) or system_boxes(cf, [e], lo0, hi0, None)
        lo, hi = got[0] if got else (lo0.copy(), hi0.copy())
        inside = np.all((points >= lo) & (points <= hi), axis=1)
        x = points[int(np.argmax(inside))] if inside.any() else 0.5 * (lo + hi)
        res = float(np.max(np.abs(comp.eval_eqs(x)), initial=0.0))
        out.append(SolutionBox(lo, hi, x, BoxStatus.CURVE, res, (lo.copy(), hi.copy())))
    return out
