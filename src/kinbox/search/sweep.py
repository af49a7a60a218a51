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
class Anchors:
    """The exact canonical goal (rotation and translation, 12 entries) of the pose as given at
    three lock values ``v_k``, each within its radius of ``G[k]`` (the arm template's
    enclosure, :meth:`kinbox.formulation.arm.ArmTemplate.params_enclosure`, on the model's
    exact constants), where the six joints' exact frames do not depend on the lock value: each
    entry is then exactly ``a + b cos t + c sin t``, so its value at ``t`` is
    ``sum_k w_k(t) G[k]`` with ``w(t) = (1, cos t, sin t) A^-1``, ``A`` the rows
    ``(1, cos v_k, sin v_k)``, whose inverse is enclosed (``Ainv +- Ainv_r``)."""

    G: np.ndarray  # (3, 12)
    Gr: np.ndarray  # (3, 12)
    Ainv: np.ndarray  # (3, 3)
    Ainv_r: np.ndarray  # (3, 3)
    _coef: tuple[np.ndarray, np.ndarray] | None = None

    @classmethod
    def of(cls, values, G, Gr) -> Anchors:
        from mpmath import iv

        old = iv.prec
        iv.prec = 120
        try:
            A = [[iv.mpf(1), iv.cos(iv.mpf(float(v))), iv.sin(iv.mpf(float(v)))] for v in values]

            def cof(i, j):  # the cofactor of A[i][j]
                r = [x for x in range(3) if x != i]
                c = [x for x in range(3) if x != j]
                m = A[r[0]][c[0]] * A[r[1]][c[1]] - A[r[0]][c[1]] * A[r[1]][c[0]]
                return m if (i + j) % 2 == 0 else -m

            det = A[0][0] * cof(0, 0) + A[0][1] * cof(0, 1) + A[0][2] * cof(0, 2)
            Ai = [[cof(j, i) / det for j in range(3)] for i in range(3)]  # the adjugate over det
            lo = np.array([[float(Ai[i][j].a) for j in range(3)] for i in range(3)])
            hi = np.array([[float(Ai[i][j].b) for j in range(3)] for i in range(3)])
        finally:
            iv.prec = old
        lo, hi = np.nextafter(lo, -np.inf), np.nextafter(hi, np.inf)
        mid = 0.5 * (lo + hi)
        rad = np.nextafter(np.maximum(mid - lo, hi - mid), np.inf)
        return cls(np.asarray(G, dtype=float), np.asarray(Gr, dtype=float), mid, rad)

    def coefficients(self) -> tuple[np.ndarray, np.ndarray]:
        """``(a, b, c) = A^-1 G`` per entry enclosed: midpoints and radii (3, 12), computed once."""
        if self._coef is None:
            g = 2.0 * _GAM3
            cm = self.Ainv @ self.G
            cr = _bump(np.abs(self.Ainv) @ self.Gr + self.Ainv_r @ (np.abs(self.G) + self.Gr) + g * (np.abs(self.Ainv) @ np.abs(self.G)))
            self._coef = (cm, cr)
        return self._coef

    def enclosure(self, cl: float, ch: float, sl: float, sh: float) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds (12,) of the exact goal's entries for every ``t`` with
        ``cos t`` in ``[cl, ch]`` and ``sin t`` in ``[sl, sh]``: ``a + b cos t + c sin t``
        (:meth:`coefficients`) in midpoint-radius arithmetic."""
        cm, cr = self.coefficients()
        Cm, Sm = 0.5 * (cl + ch), 0.5 * (sl + sh)
        Cr = (0.5 * (ch - cl) + 2.0**-52 * max(abs(cl), abs(ch))) * _RGROW
        Sr = (0.5 * (sh - sl) + 2.0**-52 * max(abs(sl), abs(sh))) * _RGROW
        a1, a2 = np.abs(cm[1]), np.abs(cm[2])
        mid = cm[0] + cm[1] * Cm + cm[2] * Sm
        rad = cr[0] + a1 * Cr + cr[1] * (abs(Cm) + Cr) + a2 * Sr + cr[2] * (abs(Sm) + Sr)
        rad = (rad + 2.0 * _GAM3 * (np.abs(cm[0]) + a1 * abs(Cm) + a2 * abs(Sm))) * _RGROW + 1e-300
        return np.nextafter(mid - rad, -np.inf), np.nextafter(mid + rad, np.inf)

    def params(self, ts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per sample ``ts[k]`` the arm template's parameters
        (:meth:`~kinbox.formulation.arm.ArmTemplate.params`) of the exact goal at ``t = ts[k]``:
        binary64 midpoints and radii, ``(N, NPARAMS)`` each."""
        g = 2.0 * _GAM3
        c, s = np.cos(ts), np.sin(ts)
        u = np.stack([np.ones_like(ts), c, s], axis=1)  # (N, 3)
        ur = np.zeros_like(u)
        ur[:, 1:] = TRIG_ERR
        au = np.abs(u)
        wm = u @ self.Ainv
        wr = _bump(ur @ np.abs(self.Ainv) + (au + ur) @ self.Ainv_r + g * (au @ np.abs(self.Ainv)))
        aw = np.abs(wm)
        gm = wm @ self.G  # (N, 12)
        gr = _bump(aw @ self.Gr + wr @ (np.abs(self.G) + self.Gr) + g * (aw @ np.abs(self.G)))
        R, Rr = gm[:, :9].reshape(-1, 3, 3), gr[:, :9].reshape(-1, 3, 3)
        t, tr = gm[:, 9:], gr[:, 9:]
        # R^T t, t.t and R^T (-y, x, 0) in midpoint-radius arithmetic
        Rtm = np.einsum("kij,ki->kj", R, t)
        Rtr = np.einsum("kij,ki->kj", np.abs(R), tr) + np.einsum("kij,ki->kj", Rr, np.abs(t) + tr)
        Rtr = _bump(Rtr + g * np.einsum("kij,ki->kj", np.abs(R), np.abs(t)))
        ttm = np.sum(t * t, axis=1)
        ttr = _bump(np.sum(2.0 * np.abs(t) * tr + tr * tr, axis=1) + g * ttm)
        v = np.stack([-t[:, 1], t[:, 0]], axis=1)
        vr = np.stack([tr[:, 1], tr[:, 0]], axis=1)
        Rvm = np.einsum("kij,ki->kj", R[:, :2], v)
        Rvr = np.einsum("kij,ki->kj", np.abs(R[:, :2]), vr) + np.einsum("kij,ki->kj", Rr[:, :2], np.abs(v) + vr)
        Rvr = _bump(Rvr + g * np.einsum("kij,ki->kj", np.abs(R[:, :2]), np.abs(v)))
        mid = np.concatenate([np.ones((len(ts), 1)), gm, Rtm, ttm[:, None], Rvm], axis=1)
        rad = np.concatenate([np.zeros((len(ts), 1)), gr, Rtr, ttr[:, None], Rvr], axis=1)
        return mid, rad


#: ``math.cos`` / ``math.sin`` (numpy's) within an ulp of 1 (:data:`kinbox.search.cf_certify.TRIG_ERR`)
TRIG_ERR = 2.0**-50
_GAM3 = 3.0 * 2.0**-53 / (1.0 - 3.0 * 2.0**-53)


#: a radius computed from a few non-negative float terms, times this: an upper bound
_RGROW = 1.0 + 1e-12


def _bump(r: np.ndarray) -> np.ndarray:
    """A radius computed in floating point from a few non-negative terms, made an upper bound."""
    return np.nextafter(r * (1.0 + 1e-12), np.inf) + 1e-300


@dataclass
class LinearGoal:
    """The canonical goal frame as a function of the locked joint's value ``t``:
    ``R(t) = R0 + cos t R1 + sin t R2``, ``p(t) = p0 + cos t p1 + sin t p2``."""

    R: tuple[np.ndarray, np.ndarray, np.ndarray]
    p: tuple[np.ndarray, np.ndarray, np.ndarray]
    err: float = LINEAR_GOAL_ERR
    #: the pose as given at three lock values (:class:`Anchors`), or None (not enclosed)
    anchors: Anchors | None = None
    _holds: bool | None = None

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

    def _pad_holds_exact(self) -> bool:
        """Does the pad hold the exact goal at every ``t``? Per entry, the linear goal's
        coefficients ``M`` and the anchors' enclosed ``(a, b, c)`` differ by ``D = sum |M_i -
        a_i| + r_i``, so the two goals by at most ``D`` at any ``t``; the pad less the rounding
        of :meth:`enclosure`'s sums (some ulps of ``sum |M_i|``) covers that where ``D`` is below
        ``(err - 8 u) (sum |M_i| + 1)``. Checked once."""
        if self._holds is None:
            assert self.anchors is not None
            cm, cr = self.anchors.coefficients()
            M = np.stack([np.concatenate([X.ravel(), x]) for X, x in zip(self.R, self.p)])  # (3, 12)
            D = np.sum(np.abs(M - cm) + cr, axis=0) * _RGROW
            S = np.sum(np.abs(M), axis=0)
            self._holds = bool(np.all(D <= (self.err - 8.0 * 2.0**-53) * (S + 1.0)))
        return self._holds

    def at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        c, s = math.cos(t), math.sin(t)
        return self.R[0] + c * self.R[1] + s * self.R[2], self.p[0] + c * self.p[1] + s * self.p[2]

    def enclosure(self, a: float, b: float):
        """``(Rlo, Rhi, plo, phi)`` holding the frame for every ``t`` in ``[a, b]``: the
        linear goal's values padded by ``err``, and the exact goal of the pose as given where
        the anchors enclose it (:meth:`Anchors.enclosure`)."""
        (cl, ch), (sl, sh) = cos_sin_range(a, b)

        def lin(M):
            lo = M[0] + np.minimum(cl * M[1], ch * M[1]) + np.minimum(sl * M[2], sh * M[2])
            hi = M[0] + np.maximum(cl * M[1], ch * M[1]) + np.maximum(sl * M[2], sh * M[2])
            pad = self.err * (np.abs(M[0]) + np.abs(M[1]) + np.abs(M[2]) + 1.0)
            return lo - pad, hi + pad

        Rlo, Rhi = lin(self.R)
        plo, phi = lin(self.p)
        if self.anchors is not None and not self._pad_holds_exact():  # the exact goal's enclosure
            lo, hi = self.anchors.enclosure(cl, ch, sl, sh)
            Rlo, Rhi = np.minimum(Rlo, lo[:9].reshape(3, 3)), np.maximum(Rhi, hi[:9].reshape(3, 3))
            plo, phi = np.minimum(plo, lo[9:]), np.maximum(phi, hi[9:])
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
    one of the relaxed enclosures: a fold) or UNDECIDED. ``proven``: a decided slab whose
    enclosures each hold exactly one root of the model for every ``t`` in it
    (:mod:`kinbox.search.slab_proof`); False where that is not proven."""

    a: float
    b: float
    kind: int
    count: int
    proven: bool = False


def sweep(
    cf: ClosedForm, goal: LinearGoal, lo: float, hi: float, min_width: float = MIN_WIDTH, prove: bool = False
) -> tuple[list[Slab], int]:
    """The slabs of ``[lo, hi]`` in order, and the number of interval closed forms run; with
    ``prove``, each decided slab's one root per enclosure proven or not
    (:class:`~kinbox.search.slab_proof.SlabProver`, its pieces counted in ``runs``)."""
    from .slab_proof import SlabProver

    prover = SlabProver(cf, goal, widened) if prove else None
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
        box = widened(cf, goal.enclosure(a, b))
        n = solve_pose(cf.code, cf.LR, cf.Lt, cf.d, *box, out, scratch)
        if n >= 0:
            slabs.append(Slab(a, b, DECIDED, int(n), prover is not None and prover.prove(a, b, int(n))))
        elif b - a > min_width:
            mid = 0.5 * (a + b)
            stack.append((mid, b))
            stack.append((a, mid))
        else:
            runs += 1
            r = solve_pose(cf.code, cf.LR, cf.Lt, cf.d, *box, out, scratch, True)
            slabs.append(Slab(a, b, RELAXED, -2 - int(r)) if r <= -2 else Slab(a, b, UNDECIDED, -1))
    return slabs, runs + (2 * prover.pieces if prover is not None else 0)


def widened(cf: ClosedForm, box: tuple) -> tuple:
    """A goal box ``(Rlo, Rhi, plo, phi)`` widened by ``cf.delta``, how far the model's exact
    arm moves the tool from the family's binary64 arm (:mod:`kinbox.search.cf_delta`): the
    slabs' enclosures then hold every root of the model as given
    (``tests/search/test_sweep.py::test_slabs_are_widened_by_the_links_radii``)."""
    d = cf.delta
    if d.R == 0.0 and d.t0 == 0.0 and d.t1 == 0.0:
        return box
    Rlo, Rhi, plo, phi = box
    tn = math.sqrt(float(np.sum(np.maximum(np.abs(plo), np.abs(phi)) ** 2))) * _SUM_UP
    er = d.R * _SUM_UP
    et = (d.t0 + d.t1 * tn) * _SUM_UP
    lo, hi = -np.inf, np.inf
    return np.nextafter(Rlo - er, lo), np.nextafter(Rhi + er, hi), np.nextafter(plo - et, lo), np.nextafter(phi + et, hi)


#: a sum of a few non-negative floats, times this, is at least the exact sum
_SUM_UP = 1.0 + 2.0**-48


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
        Rlo[k], Rhi[k], tlo[k], thi[k] = widened(cf, goal.enclosure(t, t))
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
        # each t the pose as given with the swept joint exactly at t, where the anchors enclose
        # it (tests/search/test_sweep_goal.py), else the linear goal's own value
        PRAD = np.zeros_like(P)
        if goal.anchors is not None:
            P, PRAD = goal.anchors.params(ts)
        merr, mgrad = model_errors(tc.arm.template.freeze(), P, np.maximum(np.abs(P), PM), PRAD)
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


__all__ = ["PROOF_RADIUS", "Anchors", "LinearGoal", "Slab", "solve_points", "sweep"]
