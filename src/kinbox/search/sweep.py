"""A sweep of one joint of a seven-joint arm through the closed form of the other six.

Locking the first or last joint of a seven-joint chain at ``t`` leaves a six-joint arm whose
geometry does not depend on ``t``: only the canonical goal frame does, through the rotation of
the locked joint, so each entry of the goal frame is ``G0 + cos t G1 + sin t G2``
(:class:`LinearGoal`). Over an interval ``T`` of ``t`` the goal frame is then enclosed by
interval arithmetic, and the interval closed form (:func:`kinbox.search.closed_form.solve_pose`)
run on that enclosure either proves every pivot and discriminant away from zero -- the root
count is then the same for every ``t`` in ``T`` and each root is a continuous function of
``t`` inside its enclosure (a *decided* slab) -- or not, and ``T`` is bisected down to a width.
The slabs left are evaluated once more with the discriminants relaxed (a fold of the
self-motion, where two roots meet: every root of the slab is then inside one of the relaxed
enclosures); a slab where even that fails (a pivot holding zero) is *undecided* and the
caller answers the pose by the branch and prune. ``tests/search/test_sweep.py`` checks the
slabs against point evaluations.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .closed_form import MAX_ROOTS, PROOF_RADIUS, Batch, ClosedForm, _params, call_batch_kernel, solve_pose

#: bound on the rounding of ``G0 + c G1 + s G2`` (and of the three frames it is solved from),
#: relative to ``|G0| + |G1| + |G2| + 1``: some tens of roundings of unit-size numbers
LINEAR_GOAL_ERR = 1e-13
#: slabs are bisected down to this width (radians) before the relaxed evaluation
MIN_WIDTH = 2.0**-16
#: the joint's range is first cut into this many slabs
FIRST_SLABS = 64

DECIDED, RELAXED, UNDECIDED = 0, 1, 2


@dataclass
class LinearGoal:
    """The canonical goal frame as a function of the locked joint's value ``t``:
    ``R(t) = R0 + cos t R1 + sin t R2``, ``p(t) = p0 + cos t p1 + sin t p2``."""

    R: tuple[np.ndarray, np.ndarray, np.ndarray]
    p: tuple[np.ndarray, np.ndarray, np.ndarray]
    err: float = LINEAR_GOAL_ERR

    @classmethod
    def from_frames(cls, frames: list[tuple[float, np.ndarray, np.ndarray]]) -> LinearGoal:
        """From the frames at ``t = 0, a, -a`` (``(t, R, p)`` each, in that order)."""
        (_, Ra, pa), (a, Rb, pb), (_, Rc, pc) = frames
        c, s = math.cos(a), math.sin(a)

        def split(X0, Xp, Xm):
            X2 = (Xp - Xm) / (2.0 * s)
            X1 = (X0 - 0.5 * (Xp + Xm)) / (1.0 - c)
            return X0 - X1, X1, X2

        return cls(split(Ra, Rb, Rc), split(pa, pb, pc))

    def at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        c, s = math.cos(t), math.sin(t)
        return self.R[0] + c * self.R[1] + s * self.R[2], self.p[0] + c * self.p[1] + s * self.p[2]

    def enclosure(self, a: float, b: float):
        """``(Rlo, Rhi, plo, phi)`` holding the frame for every ``t`` in ``[a, b]``."""
        (cl, ch), (sl, sh) = cos_sin_range(a, b)

        def lin(M):
            lo = M[0] + np.minimum(cl * M[1], ch * M[1]) + np.minimum(sl * M[2], sh * M[2])
            hi = M[0] + np.maximum(cl * M[1], ch * M[1]) + np.maximum(sl * M[2], sh * M[2])
            pad = self.err * (np.abs(M[0]) + np.abs(M[1]) + np.abs(M[2]) + 1.0)
            return lo - pad, hi + pad

        Rlo, Rhi = lin(self.R)
        plo, phi = lin(self.p)
        return Rlo, Rhi, plo, phi


def cos_sin_range(a: float, b: float) -> tuple[tuple[float, float], tuple[float, float]]:
    """Enclosures of ``cos`` and ``sin`` over ``[a, b]`` (extremes at multiples of pi/2
    inside; the library's cos and sin are within an ulp, covered by the pad)."""
    cs = [math.cos(a), math.cos(b)]
    ss = [math.sin(a), math.sin(b)]
    k0 = math.ceil(a / (0.5 * math.pi)) - 1
    for k in range(k0, k0 + int((b - a) / (0.5 * math.pi)) + 3):
        x = 0.5 * math.pi * k
        if a <= x <= b:
            cs.append(math.cos(x))
            ss.append(math.sin(x))
    e = 4e-16
    return (max(min(cs) - e, -1.0), min(max(cs) + e, 1.0)), (max(min(ss) - e, -1.0), min(max(ss) + e, 1.0))


@dataclass
class Slab:
    """``[a, b]`` of the swept joint: ``kind`` DECIDED (``count`` roots for every ``t`` in it,
    each a continuous function of ``t``), RELAXED (at most ``count`` roots, every root inside
    one of the relaxed enclosures: a fold) or UNDECIDED."""

    a: float
    b: float
    kind: int
    count: int


def sweep(cf: ClosedForm, goal: LinearGoal, lo: float, hi: float, min_width: float = MIN_WIDTH) -> tuple[list[Slab], int]:
    """The slabs of ``[lo, hi]`` in order, and the number of interval closed forms run."""
    out = np.zeros((MAX_ROOTS, 6, 4))
    scratch = np.zeros((4, 3, 4))
    step = (hi - lo) / FIRST_SLABS
    stack = [(lo + step * (k + 1) if k + 1 < FIRST_SLABS else hi, lo + step * k) for k in range(FIRST_SLABS)]
    stack = [(a, b) for b, a in stack][::-1]
    slabs: list[Slab] = []
    runs = 0
    while stack:
        a, b = stack.pop()
        runs += 1
        n = solve_pose(cf.code, cf.LR, cf.Lt, cf.d, *goal.enclosure(a, b), out, scratch)  # type: ignore[call-arg]  # numba's stub
        if n >= 0:
            slabs.append(Slab(a, b, DECIDED, int(n)))
        elif b - a > min_width:
            mid = 0.5 * (a + b)
            stack.append((mid, b))
            stack.append((a, mid))
        else:
            runs += 1
            r = solve_pose(cf.code, cf.LR, cf.Lt, cf.d, *goal.enclosure(a, b), out, scratch, True)  # type: ignore[call-arg]
            slabs.append(Slab(a, b, RELAXED, -2 - int(r)) if r <= -2 else Slab(a, b, UNDECIDED, -1))
    return slabs, runs


def solve_points(cf: ClosedForm, goal: LinearGoal, ts: np.ndarray, certify: bool = True) -> Batch:
    """Every root at each value ``ts[k]`` of the swept joint, in the closed form's order (no
    joint limits applied); with ``certify`` (and the arm's certifier), instead the roots
    inside the limits, each certified by Krawczyk on the six-joint system (status
    :data:`~kinbox.search.closed_form.POSE_CLOSED_FORM` where every one is):
    :func:`kinbox.search.closed_form.solve_batch_kernel` on the frames ``goal.at(t)`` and
    their enclosures."""
    from .closed_form import _no_certifier

    ts = np.asarray(ts, dtype=float)
    N = len(ts)
    Rlo = np.empty((N, 3, 3))
    Rhi = np.empty((N, 3, 3))
    tlo = np.empty((N, 3))
    thi = np.empty((N, 3))
    GR = np.empty((N, 3, 3))
    Gt = np.empty((N, 3))
    for k, t in enumerate(ts):
        Rlo[k], Rhi[k], tlo[k], thi[k] = goal.enclosure(t, t)
        GR[k], Gt[k] = goal.at(t)
    tc = cf.certifier if certify else None
    ok = tc is not None
    if ok:
        assert tc is not None
        from ..formulation.arm import NPARAMS

        P = np.empty((N, NPARAMS))
        PM = np.empty((N, NPARAMS))
        _params(GR, Gt, np.linalg.norm(Gt, axis=1), cf.tmag0, P, PM)
        from ..formulation.template import model_errors

        # the template's constants as enclosures of the model's (docs/soundness.md); the goal at
        # each t is the linear goal's own value, as the sweep's slabs take it
        merr, mgrad = model_errors(tc.arm.template.freeze(), P, np.maximum(np.abs(P), PM), np.zeros_like(P))
        nc = tc.const.shape[0]
        MERR, MGRAD = np.ascontiguousarray(merr[:, :nc]), np.ascontiguousarray(mgrad[:, :nc])
        args = tc.kernel_args()
        n = tc.n
    else:
        P = PM = np.zeros((N, 1))
        MERR = MGRAD = np.zeros((N, 0))
        args = _no_certifier()
        n = 0
    limits = cf.limits if ok else np.zeros((6, 4))  # certified: the roots inside the limits
    return call_batch_kernel(cf, limits, (Rlo, Rhi, tlo, thi), P, PM, MERR, MGRAD, args, n, ok)


__all__ = ["PROOF_RADIUS", "LinearGoal", "Slab", "solve_points", "sweep"]
