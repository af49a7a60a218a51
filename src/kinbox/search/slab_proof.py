"""One root of the model in each enclosure of a sweep's decided slab, for every angle of it.

A decided slab of :func:`kinbox.search.sweep.sweep` is ``[a, b]`` of the swept joint where the
interval closed form, run on the goal box ``B`` of the slab (every goal ``G(t)``, ``t`` in it,
widened by the arm's ``Delta``), proved every pivot and discriminant away from zero: for every
rigid goal in ``B`` the family's binary64 arm has ``n`` roots, the ``k``-th a continuous
function ``theta_k`` of the goal (its branch). Every root ``x`` of the model as given at
``t`` is one of them: ``x = theta_j(G')`` at ``G' = T_b64(x)``, within ``Delta`` of ``G(t)``.
That each branch holds ONE root of the model is proven here, piece by piece of the slab:

* on a piece ``s = [a', b']`` the closed form is run again on its goal box ``B_s`` (widened by
  ``Delta`` and by :func:`_eps` more, rounded outward) and must be decided with ``n`` roots;
  and at its middle ``t_m`` on the point's goal box: ``n`` enclosures ``E_k`` (same branches,
  same order: the exact ``G(t_m)`` is in both boxes, so every discriminant has the same sign);
* about each ``E_k``'s root, after Newton's steps on the middle of ``B_s``, Krawczyk in the six
  joint angles (:func:`krawczyk_wide`, :func:`kinbox.search.cf_certify.krawczyk6`'s on wider boxes) with the goal the whole of ``B_s``
  and the links the model's enclosed ones (their binary64 midpoints are the family's arm)
  proves a box ``X_k`` holding exactly one root for every arm within the links' radii and
  every goal in ``B_s``; ``X_k`` must hold ``E_k`` (:func:`~kinbox.search.cf_certify.enclosure_held`),
  and the ``X_k`` are pairwise apart (some joint, modulo a turn).

Then for every ``t`` in ``s`` each ``X_k`` holds exactly one root of the model and there are no
others: a root ``x = theta_j(G')`` of the model is reached from ``theta_j(G(t_m))``, in
``E_j``, in ``X_j``, along rigid goals inside ``B_s`` (``G(tau)`` from ``t_m`` to ``t``, then
``G(t)`` to ``G'`` with the rotation along the geodesic: within ``_eps`` of the segment); along
the path ``theta_j`` stays a root of the binary64 arm, which is in ``X_j`` at the start, and can
only leave ``X_j`` through its boundary, where Krawczyk's ``K(X_j) ⊂ int X_j`` puts none. So
the slab's count is the model's for every ``t`` in it, each root a continuous function of
``t`` (``X_k``'s Jacobians are regular) on branch ``k``: the branch matching of
:mod:`kinbox.answer.selfmotion` between sampled points is right there. A piece where a step
fails is cut by how far its roots move (:func:`prove_slab`, compiled with the goal boxes:
:func:`goal_box`), at most :data:`MAX_PIECES` pieces per slab (counters, never time); a slab
not proven so is flagged (``Slab.proven`` False; ``stats["slabs_unproven"]`` of the answer,
which counts every decided slab where the proof is off, its default:
:data:`kinbox.answer.selfmotion.PROVE_SLABS`). Near a fold the roots move fast and the pieces
are many: some tens per slab, the sweep some twenty times slower (docs/soundness.md).
``tests/search/test_slab_proof.py`` checks it.
"""

from __future__ import annotations

import math

import numpy as np

from . import jit as nb
from .cf_certify import (
    CERT_UNIQUE,
    PROOF_RADIUS,
    JointCertifier,
    enclosure_reach,
    krawczyk_reach,
    newton6,
    workspace,
)
from .closed_form import MAX_ROOTS, ClosedForm, _dn, _up, root_angles, solve_pose

__all__ = ["MAX_PIECES", "SlabProver"]

#: at most this many pieces of one slab are tried (bisection, depth first)
MAX_PIECES = 256
#: Newton steps at a piece's middle
NEWTON_STEPS = 3
#: Krawczyk's boxes: these many times how far the roots may lie over the piece (newton6's reach)
GROWTH = (1.5, 3.0)
#: Krawczyk's boxes here: the sum of their radii below this
MAX_REACH = 0.1
#: a piece whose boxes' radii sum to more than this is cut to about this much reach: Krawczyk's
#: contraction over the Jacobian's spread holds to a few 1e-3 on the arms of the tests
TARGET_REACH = 5e-4


def _eps(delta_r: float) -> float:
    """How far the rotation geodesic between two rotations whose entries differ by at most
    ``delta_r`` strays from their segment, entry by entry: the angle between them is at most
    ``3 delta_r`` (the Frobenius norm of the difference), the stray at most its square."""
    return 9.0 * delta_r * delta_r * (1.0 + 2.0**-40) + 1e-300


@nb.njit(cache=True)
def krawczyk_wide(th, rad, LR, Lt, d, Gm, Gr, gtm, gtr, klo, khi, ws):
    """:func:`~kinbox.search.cf_certify.krawczyk6`'s test on a box whose radii sum to at most
    :data:`MAX_REACH` (krawczyk6 stops at 1e-3): its bounds hold for any sum below 1 -- ``|p -
    o_k|`` over ``X`` grows by at most ``D_X sum_j r_j`` (``d(p - o_k)/dtheta_j = w_j x (p -
    o_j)``), so ``D_X <= D_m / (1 - sum r)``; the orientation rows' bound 4 and the trace's
    ``sqrt 6`` per radian do not depend on the box
    (``tests/search/test_slab_proof.py::test_the_wide_test_agrees_with_krawczyk6_on_small_boxes``)."""
    return krawczyk_reach(th, rad, LR, Lt, d, Gm, Gr, gtm, gtr, klo, khi, ws, MAX_REACH)


@nb.njit(cache=True)
def _apart_mod_turn(th, rad, m, k):
    """Boxes ``th[m] +- rad[m]`` and ``th[k] +- rad[k]`` disjoint in some angle, modulo a turn."""
    for i in range(6):
        d = abs(th[m, i] - th[k, i]) % (2.0 * math.pi)  # exact; the float turn is within 3e-16 of a turn
        d = min(d, 2.0 * math.pi - d)
        if d * (1.0 - 2.0**-50) - 1e-14 > rad[m, i] + rad[k, i]:
            return True
    return False


@nb.njit(cache=True)
def prove_piece(code, LR, Lt, d, box, pbox, n, G, jLR, jLt, jd, perm, shift, out, scratch, ws, th, rad, need, step, ang):
    """Krawczyk's boxes (see the module's text) for one piece: ``box`` its goal box (``Rlo,
    Rhi, tlo, thi``, widened), ``pbox`` its middle's, ``G`` (``Gm, Gr, gtm, gtr``) the piece's box
    as :func:`krawczyk_wide`'s goal (columns of the rotation). 0.0 where every step holds,
    else the sum of the radii of the first box that failed (``inf`` where there is none)."""
    fail = np.inf
    if solve_pose(code, LR, Lt, d, box[0], box[1], box[2], box[3], out, scratch) != n:
        return fail
    if solve_pose(code, LR, Lt, d, pbox[0], pbox[1], pbox[2], pbox[3], out, scratch) != n:
        return fail
    Gm, Gr, gtm, gtr = G
    klo = np.empty(6)
    khi = np.empty(6)
    for k in range(n):
        root_angles(out[k], ang)
        x = th[k]
        for i in range(6):
            x[perm[i]] = ang[i] + shift[i]
        if not newton6(x, jLR, jLt, jd, Gm, Gr, gtm, gtr, ws, NEWTON_STEPS, step):
            return fail
        if not enclosure_reach(out[k], ang, x, perm, shift, need):
            return fail
        ok = False
        for g, grow in enumerate(GROWTH):
            sr = 0.0
            for i in range(6):
                rad[k, i] = max(PROOF_RADIUS * (1.0 + abs(x[i])), grow * abs(step[i]), 1.0625 * need[i])
                sr += rad[k, i]
            if g == 0:
                fail = sr
            if krawczyk_wide(x, rad[k], jLR, jLt, jd, Gm, Gr, gtm, gtr, klo, khi, ws) == CERT_UNIQUE:
                ok = True
                break
        if not ok:
            return fail
        for j in range(k):
            if not _apart_mod_turn(th, rad, j, k):
                return np.inf
    return 0.0


#: the anchors' and the linear goal's roundings (:mod:`kinbox.search.sweep`'s constants)
_GAM3 = 3.0 * 2.0**-53 / (1.0 - 3.0 * 2.0**-53)
_RGROW = 1.0 + 1e-12
_SUM_UP = 1.0 + 2.0**-48


@nb.njit(cache=True)
def _cos_sin(a, b):
    """:func:`kinbox.search.sweep.cos_sin_range` compiled: ``(cl, ch, sl, sh)``."""
    c0, c1, s0, s1 = math.cos(a), math.cos(b), math.sin(a), math.sin(b)
    cl, ch, sl, sh = min(c0, c1), max(c0, c1), min(s0, s1), max(s0, s1)
    h = 0.5 * math.pi
    k0 = int(math.ceil(a / h)) - 1
    for k in range(k0, k0 + int((b - a) / h) + 3):
        x = h * k
        if a <= x <= b:
            c, s = math.cos(x), math.sin(x)
            cl, ch, sl, sh = min(cl, c), max(ch, c), min(sl, s), max(sh, s)
    e = 4e-16
    return max(cl - e, -1.0), min(ch + e, 1.0), max(sl - e, -1.0), min(sh + e, 1.0)


@nb.njit(cache=True)
def goal_box(a, b, M, err, anc, cm, cr, delta, eps, lo, hi):
    """The sweep's goal box over ``[a, b]`` into ``lo``, ``hi`` (12,: the rotation's rows, the
    translation), compiled: :meth:`kinbox.search.sweep.LinearGoal.enclosure` (``M`` (3, 12) the
    linear goal's ``G0, G1, G2``, padded by ``err``; with ``anc``, the hull with the anchors'
    enclosure of coefficients ``cm +- cr``), then :func:`kinbox.search.sweep.widened` by
    ``delta = (R, t0, t1)``, then every bound moved out by ``eps`` (each step rounded outward:
    ``tests/search/test_slab_proof.py::test_the_compiled_goal_box_holds_the_sweeps``)."""
    cl, ch, sl, sh = _cos_sin(a, b)
    Cm, Sm = 0.5 * (cl + ch), 0.5 * (sl + sh)
    Cr = (0.5 * (ch - cl) + 2.0**-52 * max(abs(cl), abs(ch))) * _RGROW
    Sr = (0.5 * (sh - sl) + 2.0**-52 * max(abs(sl), abs(sh))) * _RGROW
    for q in range(12):
        m0, m1, m2 = M[0, q], M[1, q], M[2, q]
        pad = err * (abs(m0) + abs(m1) + abs(m2) + 1.0)
        lo[q] = m0 + min(cl * m1, ch * m1) + min(sl * m2, sh * m2) - pad
        hi[q] = m0 + max(cl * m1, ch * m1) + max(sl * m2, sh * m2) + pad
        if anc:
            a1, a2 = abs(cm[1, q]), abs(cm[2, q])
            mid = cm[0, q] + cm[1, q] * Cm + cm[2, q] * Sm
            r = cr[0, q] + a1 * Cr + cr[1, q] * (abs(Cm) + Cr) + a2 * Sr + cr[2, q] * (abs(Sm) + Sr)
            r = (r + 2.0 * _GAM3 * (abs(cm[0, q]) + a1 * abs(Cm) + a2 * abs(Sm))) * _RGROW + 1e-300
            lo[q] = min(lo[q], _dn(mid - r))
            hi[q] = max(hi[q], _up(mid + r))
    dR, dt0, dt1 = delta[0], delta[1], delta[2]
    if dR != 0.0 or dt0 != 0.0 or dt1 != 0.0:
        tn = 0.0
        for q in range(9, 12):
            v = max(abs(lo[q]), abs(hi[q]))
            tn += v * v
        tn = math.sqrt(tn) * _SUM_UP
        et = (dt0 + dt1 * tn) * _SUM_UP
        for q in range(12):
            w = dR * _SUM_UP if q < 9 else et
            lo[q] = _dn(lo[q] - w)
            hi[q] = _up(hi[q] + w)
    if eps > 0.0:
        for q in range(12):
            lo[q] = _dn(lo[q] - eps)
            hi[q] = _up(hi[q] + eps)


@nb.njit(cache=True)
def _split(lo, hi, Rlo, Rhi, tlo, thi):
    for r in range(3):
        for c in range(3):
            Rlo[r, c], Rhi[r, c] = lo[3 * r + c], hi[3 * r + c]
        tlo[r], thi[r] = lo[9 + r], hi[9 + r]


@nb.njit(cache=True)
def _mr(lo, hi, Gm, Gr, gtm, gtr):
    """Midpoint-radius goal of krawczyk6 (columns of the rotation) from a box (12,)."""
    for r in range(3):
        for c in range(3):
            m = 0.5 * lo[3 * r + c] + 0.5 * hi[3 * r + c]
            Gm[c, r] = m
            Gr[c, r] = _up(max(m - lo[3 * r + c], hi[3 * r + c] - m))
        m = 0.5 * lo[9 + r] + 0.5 * hi[9 + r]
        gtm[r] = m
        gtr[r] = _up(max(m - lo[9 + r], hi[9 + r] - m))


@nb.njit(cache=True)
def prove_slab(a, b, n, gargs, code, LR, Lt, d, jLR, jLt, jd, perm, shift, max_pieces):
    """:func:`prove_piece` over pieces of ``[a, b]`` (``n`` roots; ``gargs = (M, err, anc, cm,
    cr, delta, eps)`` of :func:`goal_box`): a piece that fails is cut into as many equal pieces
    as its boxes' reach over :data:`TARGET_REACH` (at least two), depth first, at most
    ``max_pieces`` tried or pending (the stack's size). Returns ``(proven, pieces tried)``."""
    M, err, anc, cm, cr, delta, eps = gargs
    out = np.zeros((MAX_ROOTS, 6, 4))
    scratch = np.zeros((4, 3, 4))
    ws = (
        np.empty((3, 3)), np.empty(3), np.empty((6, 3)), np.empty((6, 3)), np.empty(6), np.empty(6),
        np.empty((6, 6)), np.empty((6, 6)), np.empty((6, 6)), np.empty((6, 12)), np.empty((6, 2)), np.empty((4, 3)),
    )  # fmt: skip
    th, rad = np.zeros((MAX_ROOTS, 6)), np.zeros((MAX_ROOTS, 6))
    need, step, ang = np.zeros(6), np.zeros(6), np.zeros(6)
    lo, hi, plo, phi = np.empty(12), np.empty(12), np.empty(12), np.empty(12)
    Rlo, Rhi, tlo, thi = np.empty((3, 3)), np.empty((3, 3)), np.empty(3), np.empty(3)
    pRlo, pRhi, ptlo, pthi = np.empty((3, 3)), np.empty((3, 3)), np.empty(3), np.empty(3)
    Gm, Gr, gtm, gtr = np.empty((3, 3)), np.empty((3, 3)), np.empty(3), np.empty(3)
    slo, shi = np.empty(max_pieces + 1), np.empty(max_pieces + 1)
    top = 0
    slo[0], shi[0] = a, b
    top = 1
    tried = 0
    while top > 0:
        top -= 1
        p0, p1 = slo[top], shi[top]
        if tried >= max_pieces:
            return False, tried
        tried += 1
        goal_box(p0, p1, M, err, anc, cm, cr, delta, eps, lo, hi)
        _split(lo, hi, Rlo, Rhi, tlo, thi)
        _mr(lo, hi, Gm, Gr, gtm, gtr)
        m = 0.5 * (p0 + p1)
        goal_box(m, m, M, err, anc, cm, cr, delta, 0.0, plo, phi)
        _split(plo, phi, pRlo, pRhi, ptlo, pthi)
        reach = prove_piece(code, LR, Lt, d, (Rlo, Rhi, tlo, thi), (pRlo, pRhi, ptlo, pthi), n, (Gm, Gr, gtm, gtr),
                            jLR, jLt, jd, perm, shift, out, scratch, ws, th, rad, need, step, ang)  # fmt: skip
        if reach == 0.0:
            continue
        k = 2
        if reach < MAX_REACH * 64:
            k = max(2, int(math.ceil(reach / TARGET_REACH)))
        k = min(k, max_pieces - tried - top)  # every piece pending stays within the budget (and the stack)
        if k < 2:
            return False, tried
        for i in range(k - 1, -1, -1):  # the first piece on top
            x0 = p0 + (p1 - p0) * i / k
            x1 = p0 + (p1 - p0) * (i + 1) / k if i + 1 < k else p1
            if not x0 < x1:
                return False, tried
            slo[top], shi[top] = x0, x1
            top += 1
    return True, tried


def _signed_permutations(LR: np.ndarray) -> bool:
    """Are the family's binary64 link rotations exactly orthogonal (signed permutations), as
    Krawczyk's bounds take every arm within the links' radii to be?"""
    return bool(np.all(np.isin(LR, (-1.0, 0.0, 1.0))) and all(np.array_equal(R.T @ R, np.eye(3)) for R in LR))


class SlabProver:
    """:func:`prove_piece` over the pieces of a sweep's slabs, for one closed form ``cf`` and
    linear goal ``goal`` (:class:`kinbox.search.sweep.LinearGoal`); ``widened``: the sweep's
    goal widening (:func:`kinbox.search.sweep.widened`). ``ok`` False where the proof cannot
    apply: no joint certifier, links that are not the family's arm's, or a ``Delta`` not proven."""

    def __init__(self, cf: ClosedForm, goal, widened) -> None:
        self.cf, self.goal, self.widened = cf, goal, widened
        jc = cf.joint_certifier
        self.ok = (
            isinstance(jc, JointCertifier)
            and cf.delta.proven
            and np.array_equal(jc.perm, np.arange(6))
            and not np.any(jc.shift)
            and np.array_equal(jc.LR[..., 0], cf.LR)
            and np.array_equal(jc.Lt[..., 0], cf.Lt)
            and np.array_equal(jc.d, cf.d)
            and _signed_permutations(cf.LR)
        )
        self.jargs = (jc.LR, jc.Lt, jc.d, jc.perm, jc.shift) if self.ok and isinstance(jc, JointCertifier) else None
        self.eps = _eps(cf.delta.R)
        self.out = np.zeros((MAX_ROOTS, 6, 4))
        self.scratch = np.zeros((4, 3, 4))
        self.ws = workspace()
        self.th = np.zeros((MAX_ROOTS, 6))
        self.rad = np.zeros((MAX_ROOTS, 6))
        self.v6 = tuple(np.zeros(6) for _ in range(3))
        #: pieces tried over every slab
        self.pieces = 0
        self._gargs: tuple | None = None

    def _boxes(self, a: float, b: float):
        Rlo, Rhi, tlo, thi = self.widened(self.cf, self.goal.enclosure(a, b))
        e = self.eps
        box = (np.nextafter(Rlo - e, -np.inf), np.nextafter(Rhi + e, np.inf), np.nextafter(tlo - e, -np.inf), np.nextafter(thi + e, np.inf))
        Gm = 0.5 * box[0] + 0.5 * box[1]
        Gr = np.nextafter(np.maximum(Gm - box[0], box[1] - Gm), np.inf)
        gtm = 0.5 * box[2] + 0.5 * box[3]
        gtr = np.nextafter(np.maximum(gtm - box[2], box[3] - gtm), np.inf)
        G = (np.ascontiguousarray(Gm.T), np.ascontiguousarray(Gr.T), gtm, gtr)
        m = 0.5 * (a + b)
        pbox = tuple(np.ascontiguousarray(x) for x in self.widened(self.cf, self.goal.enclosure(m, m)))
        return tuple(np.ascontiguousarray(x) for x in box), pbox, G

    def goal_args(self) -> tuple:
        """``(M, err, anc, cm, cr, delta, eps)`` of :func:`goal_box` for this goal and arm."""
        g = self.goal
        M = np.ascontiguousarray(np.stack([np.concatenate([X.ravel(), x]) for X, x in zip(g.R, g.p)]))
        anc = g.anchors is not None and not g._pad_holds_exact()
        cm, cr = g.anchors.coefficients() if g.anchors is not None else (np.zeros((3, 12)), np.zeros((3, 12)))
        d = self.cf.delta
        delta = np.array([d.R, d.t0, d.t1])
        return (M, float(g.err), bool(anc), np.ascontiguousarray(cm), np.ascontiguousarray(cr), delta, float(self.eps))

    def prove(self, a: float, b: float, n: int) -> bool:
        """Is every piece of the decided slab ``[a, b]`` (``n`` roots) proven, within
        :data:`MAX_PIECES` pieces (:func:`prove_slab`)?"""
        if not self.ok or n == 0:
            return self.ok
        assert self.jargs is not None
        if self._gargs is None:
            self._gargs = self.goal_args()
        cf = self.cf
        ok, tried = prove_slab(a, b, n, self._gargs, cf.code, cf.LR, cf.Lt, cf.d, *self.jargs, MAX_PIECES)
        self.pieces += int(tried)
        return bool(ok)
