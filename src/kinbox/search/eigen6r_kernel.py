"""The per-pose steps of the general 6R eigenvalue path (:mod:`kinbox.search.eigen6r`), compiled.

Two kernels per pose, with numpy's eigen-solver between them:

1. :func:`pencil_kernel`: the canonical goal and its enclosure, the goal's features, the right
   side's 14 quantities, the elimination (``Z = Q_b Q_a^-1`` with a verified inverse) and the
   coefficients ``A0, A1, A2`` of ``M(x3)`` in midpoint-radius arithmetic, and the companion
   matrix of ``M`` whose eigenvalues propose the roots;
2. :func:`proof_kernel`: the count proof (16 eigenvalues in pairwise disjoint discs free of
   ``+-i``: a complex candidate's disc off the real axis, proven in complex disc arithmetic
   with its conjugate; a real candidate's proven in real arithmetic to hold a real eigenvalue,
   its only root by the count), the back substitution of each real eigenvalue, its
   certification by Krawczyk in the six joint angles on the pose as given
   (:func:`kinbox.search.cf_certify.krawczyk6`), its ``x3`` in its eigenvalue's disc, and the
   joint limits.

Each step is that of the module docstring of :mod:`kinbox.search.eigen6r`, with the same
rigorous error bounds (Higham's ``gamma_n`` on every floating-point sum and product, the
radius itself made an upper bound by :func:`_bp`); the numpy functions there
(:meth:`~kinbox.search.eigen6r.Eigen6R.matrices`, :func:`~kinbox.search.eigen6r.prove_count`)
are the reference they are checked against (``tests/search/test_eigen6r.py``).
"""

from __future__ import annotations

import math

import numpy as np

from .. import interval as ivl
from . import jit as nb
from .certify import lu_inverse
from .cf_certify import CERT_UNIQUE, PROOF_GROWTH, goal_enclosure, goal_mr, krawczyk6, newton6, trig
from .closed_form import _frames, _in_limits, _up

U = ivl.U
TINY = ivl.TINY


@nb.njit(cache=True)
def _gam(n):
    """Higham's gamma_n = n u / (1 - n u)."""
    return n * U / (1.0 - n * U)


#: _bump's factor for ``n`` terms: ``1 + 2 gamma(n + 2)``
_F4 = 1.0 + 2.0 * _gam(6)
_G5 = 2.0 * _gam(5)
_F5 = 1.0 + 2.0 * _gam(7)
_F8 = 1.0 + 2.0 * _gam(10)
_F12 = 1.0 + 2.0 * _gam(14)
GOAL_ERR = 1e-14  # the closed form's (kinbox.search.closed_form.GOAL_ERR)
DEGREE = 16
SPURIOUS = 1e-2
DISC_L = 1e-7
DISC_V = 1e-7
PROOF_RADIUS = 1e-9

#: status of a pose (:func:`pencil_kernel`, :func:`proof_kernel`): 0 proven; else why not
OK = 0
NO_PIVOT = 1  # Q's chosen rows not proven regular
NOT_FINITE = 2  # A2 singular or the companion matrix not finite
NOT_16 = 3  # not 8 eigenvalues at +-i, or not 16 proven
NOT_PROVEN = 4  # a Krawczyk test on an eigenvalue failed
OVERLAP = 5  # two discs meet, or a disc holds +-i
NOT_CERTIFIED = 6  # a root not certified on the kinbox system
NOT_MINE = 7  # a root's x3 not inside its eigenvalue's disc
ON_LIMIT = 8  # a root on a joint limit, or not proven inside the domain


@nb.njit(cache=True)
def _bp(r):
    """A radius computed in floating point from a few non-negative terms, made an upper bound
    (:func:`kinbox.search.eigen6r._bump`)."""
    return r * _F4 + TINY


@nb.njit(cache=True)
def _mm_r(am, ar, bm, br, cm, cr):
    """``C = A B`` enclosed (:func:`kinbox.search.eigen6r._mm`), real (p, n) @ (n, q)."""
    p, n = am.shape
    q = bm.shape[1]
    g = 2.0 * _gam(2 * n + 4)
    f = 1.0 + 2.0 * _gam(2 * n + 6)
    for i in range(p):
        for j in range(q):
            s = 0.0
            e = 0.0
            r = 0.0
            for k in range(n):
                a, b = am[i, k], bm[k, j]
                s += a * b
                e += abs(a) * abs(b)
                r += abs(a) * br[k, j] + ar[i, k] * (abs(b) + br[k, j])
            cm[i, j] = s
            cr[i, j] = (r + g * e) * f + TINY + n * TINY


@nb.njit(cache=True)
def _mm_point_r(am, bm, br, cm, cr):
    """``C = A B`` enclosed for a point matrix ``A`` (:func:`kinbox.search.eigen6r._mm_point`)."""
    p, n = am.shape
    q = bm.shape[1]
    g = 2.0 * _gam(2 * n + 4)
    f = 1.0 + 2.0 * _gam(2 * n + 6)
    for i in range(p):
        for j in range(q):
            s = 0.0
            r = 0.0
            for k in range(n):
                a, b = am[i, k], bm[k, j]
                s += a * b
                r += abs(a) * (br[k, j] + g * abs(b))
            cm[i, j] = s
            cr[i, j] = r * f + TINY + n * TINY


@nb.njit(cache=True)
def _inverse(A, out):
    """``out = A^-1`` by Gauss-Jordan with partial pivoting (complex); False where a pivot is
    zero or the result is not finite. Floating point: callers verify what they use."""
    n = A.shape[0]
    M = A.copy()
    for i in range(n):
        for j in range(n):
            out[i, j] = 1.0 if i == j else 0.0
    for c in range(n):
        p = c
        best = abs(M[c, c])
        for r in range(c + 1, n):
            if abs(M[r, c]) > best:
                best, p = abs(M[r, c]), r
        if not best > 0.0:
            return False
        if p != c:
            for j in range(n):
                M[c, j], M[p, j] = M[p, j], M[c, j]
                out[c, j], out[p, j] = out[p, j], out[c, j]
        piv = M[c, c]
        for j in range(n):
            M[c, j] = M[c, j] / piv
            out[c, j] = out[c, j] / piv
        for r in range(n):
            if r != c:
                f = M[r, c]
                if f != 0.0:
                    for j in range(n):
                        M[r, j] -= f * M[c, j]
                        out[r, j] -= f * out[c, j]
    for i in range(n):
        for j in range(n):
            if not np.isfinite(out[i, j].real) or not np.isfinite(out[i, j].imag):
                return False
    return True


# ----------------------------------------------------------------------------------------------
# kernel 1: the pencil
# ----------------------------------------------------------------------------------------------
@nb.njit(cache=True)
def _goal(R, t, v, AR, At, BR, Bt, reversed_, tmag0, iAR, iAt, iBR, iBt, GR, Gt, Gm, Gr, tm, tr):
    """The canonical goal frame ``GR, Gt`` and its enclosure, midpoint and radius: the
    closed form's (:meth:`kinbox.search.eigen6r.EigenSolver.goal`: the binary64 frame widened
    by :data:`GOAL_ERR`), widened further where needed to hold the goal of the pose as given
    (:func:`kinbox.search.cf_certify.goal_enclosure` of the XYZQUAT ``v`` with the model's
    constant frames ``iAR, iAt, iBR, iBt`` as intervals; ``tests/search/test_eigen6r_radii.py``)."""
    tn = np.empty(1)
    _frames(R, t, AR, At, BR, Bt, reversed_, GR, Gt, tn)
    GRj = np.empty((3, 3, 2))
    Gtj = np.empty((3, 2))
    goal_enclosure(v, iAR, iAt, iBR, iBt, reversed_, GRj, Gtj)
    et = GOAL_ERR * (tmag0 + tn[0]) + 1e-300
    for i in range(3):
        for j in range(3):
            lo, hi = GR[0, i, j] - GOAL_ERR, GR[0, i, j] + GOAL_ERR
            Gm[i, j] = 0.5 * (lo + hi)
            need = max(Gm[i, j] - GRj[j, i, 0], GRj[j, i, 1] - Gm[i, j])  # column j, row i
            Gr[i, j] = _bp(max(0.5 * (hi - lo) + U * abs(Gm[i, j]), need))
        lo, hi = Gt[0, i] - et, Gt[0, i] + et
        tm[i] = 0.5 * (lo + hi)
        need = max(tm[i] - Gtj[i, 0], Gtj[i, 1] - tm[i])
        tr[i] = _bp(max(0.5 * (hi - lo) + U * abs(tm[i]), need))
    return tn[0]


@nb.njit(cache=True)
def _mr_add(am, ar, bm, br):
    m = am + bm
    return m, _bp(ar + br + U * abs(m))


@nb.njit(cache=True)
def _mr_sub(am, ar, bm, br):
    m = am - bm
    return m, _bp(ar + br + U * abs(m))


@nb.njit(cache=True)
def _mr_mul(am, ar, bm, br):
    m = am * bm
    return m, _bp(abs(am) * br + ar * (abs(bm) + br) + U * abs(m))


@nb.njit(cache=True)
def _features(pm, pr, lm, lr, fm, fr):
    """The goal's features (:func:`kinbox.search.eigen6r._features`) into ``fm, fr`` (18, 1)."""
    # p.p and p.l: (a0 b0 + a1 b1) + a2 b2
    a0, r0 = _mr_mul(pm[0], pr[0], pm[0], pr[0])
    a1, r1 = _mr_mul(pm[1], pr[1], pm[1], pr[1])
    a2, r2 = _mr_mul(pm[2], pr[2], pm[2], pr[2])
    s, sr = _mr_add(a0, r0, a1, r1)
    pp, ppr = _mr_add(s, sr, a2, r2)
    a0, r0 = _mr_mul(pm[0], pr[0], lm[0], lr[0])
    a1, r1 = _mr_mul(pm[1], pr[1], lm[1], lr[1])
    a2, r2 = _mr_mul(pm[2], pr[2], lm[2], lr[2])
    s, sr = _mr_add(a0, r0, a1, r1)
    pl, plr = _mr_add(s, sr, a2, r2)
    fm[0, 0], fr[0, 0] = 1.0, 0.0
    for k in range(3):
        fm[1 + k, 0], fr[1 + k, 0] = pm[k], pr[k]
        fm[4 + k, 0], fr[4 + k, 0] = lm[k], lr[k]
    fm[7, 0], fr[7, 0] = pp, ppr
    fm[8, 0], fr[8, 0] = pl, plr
    for k in range(3):
        i, j = (k + 1) % 3, (k + 2) % 3
        a, ar = _mr_mul(pm[i], pr[i], lm[j], lr[j])
        b, br = _mr_mul(pm[j], pr[j], lm[i], lr[i])
        fm[9 + k, 0], fr[9 + k, 0] = _mr_sub(a, ar, b, br)
        fm[12 + k, 0], fr[12 + k, 0] = _mr_mul(lm[k], lr[k], pp, ppr)
        fm[15 + k, 0], fr[15 + k, 0] = _mr_mul(pm[k], pr[k], pl, plr)


@nb.njit(cache=True)
def _pivot_rows(Qm, a, b):
    """8 of the 14 rows of ``Qm`` (14, 8) by Gram-Schmidt with pivoting on the largest remaining
    norm (the choice of a QR with column pivoting of ``Qm^T``), sorted into ``a``; the other 6
    sorted into ``b``. A heuristic only: the inverse of the rows chosen is verified."""
    m, n = Qm.shape
    W = Qm.copy()
    used = np.zeros(m, dtype=np.bool_)
    for _step in range(n):
        best, p = -1.0, 0
        for r in range(m):
            if not used[r]:
                s = 0.0
                for j in range(n):
                    s += W[r, j] * W[r, j]
                if s > best:
                    best, p = s, r
        used[p] = True
        nrm = math.sqrt(best)
        if nrm > 0.0:
            for r in range(m):
                if not used[r]:
                    d = 0.0
                    for j in range(n):
                        d += W[r, j] * W[p, j]
                    d /= nrm * nrm
                    for j in range(n):
                        W[r, j] -= d * W[p, j]
    ia, ib = 0, 0
    for r in range(m):
        if used[r]:
            a[ia] = r
            ia += 1
        else:
            b[ib] = r
            ib += 1


@nb.njit(cache=True)
def _scale_rows(Pm, Pr, Qm, Qr):
    """Rows scaled by powers of two (exact) to a unit largest entry."""
    for r in range(14):
        big = 0.0
        for j in range(8):
            big = max(big, abs(Qm[r, j]))
        for k in range(3):
            for x in range(9):
                big = max(big, abs(Pm[k, r, x]))
        sc = 2.0 ** (-math.floor(math.log2(max(big, 1e-300)) + 0.5))
        for j in range(8):
            Qm[r, j] *= sc
            Qr[r, j] *= sc
        for k in range(3):
            for x in range(9):
                Pm[k, r, x] *= sc
                Pr[k, r, x] *= sc


@nb.njit(cache=True)
def _eliminate(Qm, Qr, a, b, Rinv, Zm, Zr):
    """``Z`` with ``Z Q_a = Q_b`` enclosed (6, 8), from the floating-point inverse ``Rinv`` of
    ``Q_a`` verified (:meth:`kinbox.search.eigen6r.Eigen6R.matrices`: ``Z = Z0 + E``,
    ``E Q_a = F``, ``E = F R + E (I - Q_a R)``); False where ``|I - Q_a R|`` is not below 1/2."""
    Qa_m = np.empty((8, 8))
    Qa_r = np.empty((8, 8))
    Qb_m = np.empty((6, 8))
    Qb_r = np.empty((6, 8))
    for i in range(8):
        for j in range(8):
            Qa_m[i, j], Qa_r[i, j] = Qm[a[i], j], Qr[a[i], j]
    for i in range(6):
        for j in range(8):
            Qb_m[i, j], Qb_r[i, j] = Qm[b[i], j], Qr[b[i], j]
    if not lu_inverse(Qa_m, Rinv):
        return False
    zero8 = np.zeros((8, 8))
    Z0 = np.zeros((6, 8))
    for i in range(6):
        for j in range(8):
            acc = 0.0
            for q in range(8):
                acc += Qb_m[i, q] * Rinv[q, j]
            Z0[i, j] = acc
    ZQm = np.empty((6, 8))
    ZQr = np.empty((6, 8))
    _mm_point_r(Z0, Qa_m, Qa_r, ZQm, ZQr)
    Fm = np.empty((6, 8))
    Fr = np.empty((6, 8))
    for i in range(6):
        for j in range(8):
            Fm[i, j] = Qb_m[i, j] - ZQm[i, j]
            Fr[i, j] = _bp(Qb_r[i, j] + ZQr[i, j] + 2.0 * U * abs(Fm[i, j]))
    QRm = np.empty((8, 8))
    QRr = np.empty((8, 8))
    _mm_r(Qa_m, Qa_r, Rinv, zero8, QRm, QRr)
    col = np.zeros(8)
    for i in range(8):
        for j in range(8):
            e = (1.0 if i == j else 0.0) - QRm[i, j]
            col[j] += _bp(abs(e) + QRr[i, j] + 2.0 * U * abs(QRm[i, j]))
    nc = 0.0
    for j in range(8):
        col[j] = col[j] * _F8 + TINY
        nc = max(nc, col[j])
    if not nc < 0.5:
        return False
    FRm = np.empty((6, 8))
    FRr = np.empty((6, 8))
    _mm_r(Fm, Fr, Rinv, zero8, FRm, FRr)
    for i in range(6):
        big = 0.0
        for j in range(8):
            big = max(big, _bp(abs(FRm[i, j]) + FRr[i, j]))
        enorm = _bp(big / (1.0 - nc) * (1.0 + 4 * U))
        for j in range(8):
            er = _bp(FRr[i, j] + enorm * col[j])
            Zm[i, j] = Z0[i, j] + FRm[i, j]
            Zr[i, j] = _bp(er + 2.0 * U * abs(Zm[i, j]))
    return True


@nb.njit(cache=True)
def _coefficients(Pm, Pr, Zm, Zr, a, b, TX, Am, Ar):
    """``A0, A1, A2`` of ``M(x3)`` (3, 12, 12) from ``S_k = P_b,k - Z P_a,k`` (k = c, s, 1)
    times the half-angle map of ``x4, x5`` (:meth:`kinbox.search.eigen6r.Eigen6R.matrices`)."""
    Pa_m = np.empty((8, 9))
    Pa_r = np.empty((8, 9))
    ZPm = np.empty((6, 9))
    ZPr = np.empty((6, 9))
    Sm = np.empty((6, 9))
    Sr = np.empty((6, 9))
    Tm = np.empty((3, 6, 9))
    Tr = np.empty((3, 6, 9))
    zero9 = np.zeros((9, 9))
    for k in range(3):
        for i in range(8):
            for x in range(9):
                Pa_m[i, x], Pa_r[i, x] = Pm[k, a[i], x], Pr[k, a[i], x]
        _mm_r(Zm, Zr, Pa_m, Pa_r, ZPm, ZPr)
        for i in range(6):
            for x in range(9):
                m = Pm[k, b[i], x] - ZPm[i, x]
                Sm[i, x] = m
                Sr[i, x] = _bp(Pr[k, b[i], x] + ZPr[i, x] + 2.0 * U * abs(m))
        _mm_r(Sm, Sr, TX, zero9, Tm[k], Tr[k])
    for q in range(3):
        for i in range(12):
            for j in range(12):
                Am[q, i, j] = 0.0
                Ar[q, i, j] = 0.0
    # 12 x 12: rows (eq, times 1 | times x4), columns x4^a x5^b -> 3a + b; (c, s, 1) of t3 in
    # x3: c = (1 - x^2), s = 2x, 1 = (1 + x^2) (times 1 + x^2)
    for h in range(2):
        for i in range(6):
            for x in range(9):
                r, c = i + 6 * h, x + 3 * h
                m0 = Tm[0, i, x] + Tm[2, i, x]
                Am[0, r, c] = m0
                Ar[0, r, c] = _bp(Tr[0, i, x] + Tr[2, i, x] + 2.0 * U * abs(m0))
                Am[1, r, c] = 2.0 * Tm[1, i, x]
                Ar[1, r, c] = 2.0 * Tr[1, i, x]
                m2 = Tm[2, i, x] - Tm[0, i, x]
                Am[2, r, c] = m2
                Ar[2, r, c] = _bp(Tr[2, i, x] + Tr[0, i, x] + 2.0 * U * abs(m2))


@nb.njit(cache=True)
def _companion(Am, L):
    """The companion matrix (24, 24) of ``A0 + A1 x + A2 x^2`` (``A2^-1`` applied); False where
    ``A2`` cannot be inverted or the matrix is not finite."""
    A2inv = np.empty((12, 12))
    if not lu_inverse(Am[2], A2inv):
        return False
    for i in range(24):
        for j in range(24):
            L[i, j] = 0.0
    for i in range(12):
        L[i, 12 + i] = 1.0
    for i in range(12):
        for j in range(12):
            s0 = 0.0
            s1 = 0.0
            for k in range(12):
                s0 += A2inv[i, k] * Am[0, k, j]
                s1 += A2inv[i, k] * Am[1, k, j]
            L[12 + i, j] = -s0
            L[12 + i, 12 + j] = -s1
    for i in range(24):
        for j in range(24):
            if not np.isfinite(L[i, j]):
                return False
    return True


@nb.njit(cache=True)
def pencil_kernel(R, t, v, AR, At, BR, Bt, reversed_, tmag0, iAR, iAt, iBR, iBt, d6, rmap_m, rmap_r, P0m, P0r, TX,
                  GR, Gt, Gm, Pm, Qm, a, Rinv, Am, Ar, L):  # fmt: skip
    """Kernel 1 (module docstring) for goal ``(R, t)`` ((1, 3, 3), (1, 3)), the rotation and
    translation of the XYZQUAT ``v`` (:func:`_goal`): fills the canonical goal ``GR, Gt`` (its
    midpoint ``Gm``), the scaled ``P`` and ``Q`` (midpoints), the rows ``a`` of ``Q`` inverted
    (``Rinv``), ``M``'s coefficients ``Am, Ar`` (enclosures over the goal's enclosure and the
    links' radii, carried by ``rmap_*`` and ``P0*``) and the companion matrix ``L``; returns
    the status (:data:`OK` or why not)."""
    Gr = np.empty((3, 3))
    tm = np.empty(3)
    tr = np.empty(3)
    _goal(R, t, v, AR, At, BR, Bt, reversed_, tmag0, iAR, iAt, iBR, iBt, GR, Gt, Gm, Gr, tm, tr)
    # H = G A6^-1: its point and direction
    pm = np.empty(3)
    pr = np.empty(3)
    lm = np.empty(3)
    lr = np.empty(3)
    for i in range(3):
        lm[i], lr[i] = Gm[i, 2], Gr[i, 2]
        pm[i] = tm[i] - d6 * lm[i]
        pr[i] = _bp(tr[i] + abs(d6) * lr[i] + 2.0 * U * (abs(tm[i]) + abs(d6) * abs(lm[i])))
    fm = np.empty((18, 1))
    fr = np.empty((18, 1))
    _features(pm, pr, lm, lr, fm, fr)
    Rm = np.empty((126, 1))
    Rr = np.empty((126, 1))
    _mm_r(rmap_m, rmap_r, fm, fr, Rm, Rr)  # the right side's 14 quantities (14 x 9)
    Pr = np.empty((3, 14, 9))
    Qr = np.empty((14, 8))
    for k in range(3):
        for r in range(14):
            for x in range(9):
                Pm[k, r, x], Pr[k, r, x] = P0m[k, r, x], P0r[k, r, x]
    for r in range(14):
        # the constant of the right side moves left
        m = P0m[2, r, 8] - Rm[9 * r + 8, 0]
        Pm[2, r, 8] = m
        Pr[2, r, 8] = _bp(P0r[2, r, 8] + Rr[9 * r + 8, 0] + 2.0 * U * abs(m))
        for j in range(8):
            Qm[r, j], Qr[r, j] = Rm[9 * r + j, 0], Rr[9 * r + j, 0]
    _scale_rows(Pm, Pr, Qm, Qr)
    b = np.empty(6, dtype=np.int64)
    _pivot_rows(Qm, a, b)
    Zm = np.empty((6, 8))
    Zr = np.empty((6, 8))
    if not _eliminate(Qm, Qr, a, b, Rinv, Zm, Zr):
        return NO_PIVOT
    _coefficients(Pm, Pr, Zm, Zr, a, b, TX, Am, Ar)
    if not _companion(Am, L):
        return NOT_FINITE
    return OK


# ----------------------------------------------------------------------------------------------
# kernel 2: the proof, the back substitution, the certification
# ----------------------------------------------------------------------------------------------
@nb.njit(cache=True)
def _ub(z):
    """``|re| + |im|``: at least ``|z|`` (for rounding terms, where the factor of at most
    ``sqrt(2)`` costs nothing)."""
    return abs(z.real) + abs(z.imag)


@nb.njit(cache=True)
def _poly_at(Am, Ar, lm, lr, Mm, Mr, Dm, Dr):
    """Enclosures of ``M(lambda)`` and ``M'(lambda)`` over the disc ``lm +- lr``
    (:func:`kinbox.search.eigen6r._poly_at`): ``M = (A2 lambda + A1) lambda + A0``,
    ``M' = 2 A2 lambda + A1``."""
    al = abs(lm)
    for i in range(12):
        for j in range(12):
            t1m = Am[2, i, j] * lm
            t1r = _bp(Ar[2, i, j] * (al + lr) + abs(Am[2, i, j]) * lr + 4.0 * U * _ub(t1m))
            s1m = t1m + Am[1, i, j]
            s1r = _bp(t1r + Ar[1, i, j] + 2.0 * U * _ub(s1m))
            t2m = s1m * lm
            t2r = _bp(s1r * (al + lr) + (abs(s1m) * lr if lr != 0.0 else 0.0) + 4.0 * U * _ub(t2m))
            m = t2m + Am[0, i, j]
            Mm[i, j] = m
            Mr[i, j] = _bp(t2r + Ar[0, i, j] + 2.0 * U * _ub(m))
            d = 2.0 * t1m + Am[1, i, j]
            Dm[i, j] = d
            Dr[i, j] = _bp(2.0 * t1r + Ar[1, i, j] + 2.0 * U * _ub(d))


@nb.njit(cache=True)
def _matvec_c(am, ar, bm, br, cm, cr):
    """``c = A b`` enclosed, complex midpoints, real radii (:func:`kinbox.search.eigen6r._mm`
    with one column)."""
    p, n = am.shape
    g = 2.0 * _gam(2 * n + 4)
    f = 1.0 + 2.0 * _gam(2 * n + 6)
    ab = np.empty(n)
    for k in range(n):
        ab[k] = abs(bm[k])
    for i in range(p):
        s = am[i, 0] * 0.0
        e = 0.0
        r = 0.0
        for k in range(n):
            a = am[i, k]
            s += a * bm[k]
            aa = abs(a)
            e += aa * ab[k]
            r += aa * br[k] + ar[i, k] * (ab[k] + br[k])
        cm[i] = s
        cr[i] = (r + g * e) * f + TINY + n * TINY


@nb.njit(cache=True)
def _mm_point_c(am, aa, bm, br, cm, cr):
    """``C = A B`` enclosed for a complex point matrix ``A`` (``aa = |A|``,
    :func:`kinbox.search.eigen6r._mm_point`)."""
    p, n = am.shape
    q = bm.shape[1]
    g = 2.0 * _gam(2 * n + 4)
    f = 1.0 + 2.0 * _gam(2 * n + 6)
    w = np.empty((n, q))
    for k in range(n):
        for j in range(q):
            w[k, j] = br[k, j] + g * abs(bm[k, j])
    for i in range(p):
        for j in range(q):
            s = am[i, 0] * 0.0
            r = 0.0
            for k in range(n):
                s += am[i, k] * bm[k, j]
                r += aa[i, k] * w[k, j]
            cm[i, j] = s
            cr[i, j] = r * f + TINY + n * TINY


@nb.njit(cache=True)
def _cmatvec(A, v):
    """``A v`` in floating point."""
    n = A.shape[0]
    out = np.empty(n, dtype=v.dtype)
    for i in range(n):
        acc = v[0] * 0.0
        for j in range(A.shape[1]):
            acc += A[i, j] * v[j]
        out[i] = acc
    return out


@nb.njit(cache=True)
def _prove_one(Am, Ar, lam, v):
    """Krawczyk on ``(lambda, v) -> M(lambda) v`` (``v_j`` fixed at the largest entry) about
    the candidate ``(lam, v)`` after one Newton step (:func:`kinbox.search.eigen6r.prove_eigenvalues`;
    the step's ``J^-1`` is the preconditioner): (proven, the disc's centre and radius, the
    eigenvector's centre). Complex ``lam, v``: a zero ``(lambda, v)`` in the complex discs; real
    ``lam, v`` (the same code in real arithmetic): a real zero in the real intervals, so a real
    eigenvalue in ``lam +- radius`` (that it is the disc's only root follows from the count,
    :func:`prove_count_kernel`)."""
    n = 12
    jj = 0
    for i in range(n):
        if abs(v[i]) > abs(v[jj]):
            jj = i
    piv = v[jj]
    for i in range(n):
        v[i] = v[i] / piv
    # one Newton step in floating point on the midpoint data
    Mm = np.empty((n, n), dtype=v.dtype)
    Mr = np.empty((n, n))
    Dm = np.empty((n, n), dtype=v.dtype)
    Dr = np.empty((n, n))
    Jinv = np.empty((n, n), dtype=v.dtype)
    _poly_at(Am, Ar, lam, 0.0, Mm, Mr, Dm, Dr)
    Fv = _cmatvec(Mm, v)
    Dv = _cmatvec(Dm, v)
    for i in range(n):
        Mm[i, jj] = Dv[i]
    if not _inverse(Mm, Jinv):
        return False, lam, 0.0, v
    dz = _cmatvec(Jinv, Fv)
    lam = lam - dz[jj]
    for i in range(n):
        if i != jj:
            v[i] = v[i] - dz[i]
    rho = np.empty(n)
    for i in range(n):
        rho[i] = DISC_V * (1.0 + abs(v[i]))
    rho[jj] = DISC_L * (1.0 + abs(lam))
    # F at the centre, enclosed over the data; the preconditioner R: J^-1 before the step
    # (any matrix keeps Krawczyk sound)
    F0m = np.empty(n, dtype=v.dtype)
    F0r = np.empty(n)
    _poly_at(Am, Ar, lam, 0.0, Mm, Mr, Dm, Dr)
    _matvec_c(Mm, Mr, v, np.zeros(n), F0m, F0r)
    Rp = Jinv
    Ra = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            Ra[i, j] = abs(Rp[i, j])
    RFm = np.empty((n, 1), dtype=v.dtype)
    RFr = np.empty((n, 1))
    F0m2 = np.empty((n, 1), dtype=v.dtype)
    F0r2 = np.empty((n, 1))
    for i in range(n):
        F0m2[i, 0], F0r2[i, 0] = F0m[i], F0r[i]
    _mm_point_c(Rp, Ra, F0m2, F0r2, RFm, RFr)
    shift = np.empty(n)
    for i in range(n):
        shift[i] = _bp(abs(RFm[i, 0]) + RFr[i, 0])
        rho[i] = max(rho[i], 2.0 * shift[i])
    Jvm = np.empty(n, dtype=v.dtype)
    Jvr = np.empty(n)
    vr = np.empty(n)
    RJm = np.empty((n, n), dtype=v.dtype)
    RJr = np.empty((n, n))
    reach = np.empty(n)
    for _it in range(3):
        # J over the discs: columns M(Lambda) e_i (i != j) and M'(Lambda) v at column j
        _poly_at(Am, Ar, lam, rho[jj], Mm, Mr, Dm, Dr)
        for i in range(n):
            vr[i] = rho[i]
        vr[jj] = 0.0  # v_j fixed
        _matvec_c(Dm, Dr, v, vr, Jvm, Jvr)
        for i in range(n):
            Mm[i, jj] = Jvm[i]
            Mr[i, jj] = Jvr[i]
        # K(X) - z = -R F(z) + (I - R J(X)) (X - z): inside X, strictly, in every component
        _mm_point_c(Rp, Ra, Mm, Mr, RJm, RJr)
        ok = True
        for i in range(n):
            spread = 0.0
            for j in range(n):
                e = abs((1.0 if i == j else 0.0) - RJm[i, j])
                spread += _bp(e + RJr[i, j] + 2.0 * U * _ub(RJm[i, j])) * rho[j]
            reach[i] = _bp(shift[i] + (spread * _F12 + TINY))
            if not np.isfinite(reach[i]):
                return False, lam, rho[jj], v
            if not reach[i] < rho[i]:
                ok = False
        if ok:
            return True, lam, rho[jj], v
        for i in range(n):
            rho[i] = max(rho[i], 2.0 * reach[i])
    return False, lam, rho[jj], v


@nb.njit(cache=True)
def _spurious(w):
    """Indices of the 16 eigenvalues of ``q``: all but the 4 nearest ``i`` and the 4 nearest
    ``-i`` (the factor ``(1 + x3^2)^4``), or an empty array where those 8 are not 8 distinct
    ones within :data:`SPURIOUS` of ``+-i``."""
    spur = np.zeros(24, dtype=np.bool_)
    for sign in (1.0, -1.0):
        d = np.empty(24)
        for k in range(24):
            d[k] = abs(w[k] - complex(0.0, sign))
        taken = np.zeros(24, dtype=np.bool_)
        for _q in range(4):  # the 4 nearest, by selection (the first of equals)
            k = -1
            for j in range(24):
                if not taken[j] and (k < 0 or d[j] < d[k]):
                    k = j
            taken[k] = True
            if spur[k] or not d[k] <= SPURIOUS:
                return np.empty(0, dtype=np.int64)
            spur[k] = True
    keep = np.empty(16, dtype=np.int64)
    m = 0
    for k in range(24):
        if not spur[k]:
            keep[m] = k
            m += 1
    return keep


@nb.njit(cache=True)
def prove_count_kernel(Am, Ar, w, V, centres, radii, vecs):
    """Steps 1-2 of the proof (:func:`kinbox.search.eigen6r.prove_count`) from the eigenvalues
    ``w`` (24) and eigenvectors ``V`` (24, 24) of the companion matrix: the real eigenvalues'
    discs into ``centres``, ``radii``, their eigenvectors into the columns of ``vecs``;
    returns (status, how many real)."""
    for k in range(24):
        if not (np.isfinite(w[k].real) and np.isfinite(w[k].imag)):
            return NOT_FINITE, 0
    keep = _spurious(w)
    if keep.shape[0] != DEGREE:
        return NOT_16, 0
    nup, nlo = 0, 0
    for k in keep:
        if abs(w[k].imag) > 1e-6 * (1.0 + abs(w[k])):
            if w[k].imag > 0:
                nup += 1
            else:
                nlo += 1
    if nup != nlo:
        return NOT_16, 0
    C = np.empty(DEGREE + 2, dtype=np.complex128)
    Rd = np.empty(DEGREE + 2)
    nd = 0
    nreal = 0
    for k in keep:
        real = not abs(w[k].imag) > 1e-6 * (1.0 + abs(w[k]))
        if not real and w[k].imag < 0:
            continue
        if real:
            # a real zero in real intervals: a real eigenvalue in the disc about a real centre
            vr = np.empty(12)
            for i in range(12):
                vr[i] = V[i, k].real
            ok, lamr, rad, vr = _prove_one(Am, Ar, w[k].real, vr)
            if not ok:
                return NOT_PROVEN, 0
            centres[nreal], radii[nreal] = lamr, rad
            for i in range(12):
                vecs[i, nreal] = vr[i]
            nreal += 1
            C[nd], Rd[nd] = complex(lamr, 0.0), rad
            nd += 1
            continue
        v = np.empty(12, dtype=np.complex128)
        for i in range(12):
            v[i] = V[i, k]
        ok, lam, rad, v = _prove_one(Am, Ar, w[k], v)
        if not ok:
            return NOT_PROVEN, 0
        # a complex candidate's disc off the real axis: it proves its conjugate's too
        if not abs(lam.imag) * (1.0 - 4.0 * U) > rad * (1.0 + 4.0 * U):
            return OVERLAP, 0
        C[nd], Rd[nd] = lam, rad
        C[nd + 1], Rd[nd + 1] = lam.conjugate(), rad
        nd += 2
    if nd != DEGREE:
        return NOT_16, 0
    C[nd], Rd[nd] = 1j, 0.0
    C[nd + 1], Rd[nd + 1] = -1j, 0.0
    # pairwise disjoint, and free of +-i (|c1 - c2| rounded: within a few ulps)
    for i in range(nd + 2):
        for j in range(i + 1, nd + 2):
            if not abs(C[i] - C[j]) * (1.0 - 4.0 * U) > (Rd[i] + Rd[j]) * (1.0 + 4.0 * U):
                return OVERLAP, 0
    return OK, nreal


@nb.njit(cache=True)
def _angle_pair(v, axis):
    """The angle of ``x = tan(t / 2)`` (homogeneous ``(x : w)``) from the monomial vector ``v``
    (``v[3a + b] = x4^a w4^(3-a) x5^b w5^(2-b)``): the ratio of consecutive powers with the
    largest entries (:func:`kinbox.search.eigen6r._angle_pair`)."""
    best, num, den = -1.0, 0.0, 1.0
    if axis == 0:
        for b in range(3):
            for a in range(3):
                hi, lo = v[3 * (a + 1) + b], v[3 * a + b]
                s = hi * hi + lo * lo
                if s > best:
                    best, num, den = s, hi, lo
    else:
        for a in range(4):
            for b in range(2):
                hi, lo = v[3 * a + b + 1], v[3 * a + b]
                s = hi * hi + lo * lo
                if s > best:
                    best, num, den = s, hi, lo
    return 2.0 * math.atan2(num, den)


@nb.njit(cache=True)
def _mul3(A, B):
    """``A = A B`` (3 x 3)."""
    for i in range(3):
        a0, a1, a2 = A[i, 0], A[i, 1], A[i, 2]
        for j in range(3):
            A[i, j] = a0 * B[0, j] + a1 * B[1, j] + a2 * B[2, j]


@nb.njit(cache=True)
def _rz_into(th, out):
    c, s = math.cos(th), math.sin(th)
    out[0, 0], out[0, 1], out[0, 2] = c, -s, 0.0
    out[1, 0], out[1, 1], out[1, 2] = s, c, 0.0
    out[2, 0], out[2, 1], out[2, 2] = 0.0, 0.0, 1.0


@nb.njit(cache=True)
def back_substitute_kernel(LR, Pm, a, Rinv, x3, vecs, Gm, k, th):
    """Canonical angles (rows of ``th``) of the solutions of the ``k`` real eigenvalues ``x3``
    with kernel vectors (columns of ``vecs``), in floating point
    (:func:`kinbox.search.eigen6r.back_substitute`; ``Y`` from the 8 rows of ``Q`` inverted)."""
    Rz = np.empty((3, 3))
    for m in range(k):
        th[m, 2] = 2.0 * math.atan(x3[m])
        th[m, 3] = _angle_pair(vecs[:, m], 0)
        th[m, 4] = _angle_pair(vecs[:, m], 1)
        c2, s2 = math.cos(th[m, 2]), math.sin(th[m, 2])
        b2 = (c2, s2, 1.0)
        X = np.empty(9)
        for i4 in range(3):
            f4 = math.cos(th[m, 3]) if i4 == 0 else (math.sin(th[m, 3]) if i4 == 1 else 1.0)
            for i5 in range(3):
                f5 = math.cos(th[m, 4]) if i5 == 0 else (math.sin(th[m, 4]) if i5 == 1 else 1.0)
                X[3 * i4 + i5] = f4 * f5
        Y = np.zeros(8)
        for i in range(8):
            r = a[i]
            acc = 0.0
            for c in range(3):
                for x in range(9):
                    acc += b2[c] * Pm[c, r, x] * X[x]
            for j in range(8):
                Y[j] += Rinv[j, i] * acc
        th[m, 0] = math.atan2(Y[5], Y[2])  # (s1, 1), (c1, 1)
        th[m, 1] = math.atan2(Y[7], Y[6])  # (1, s2), (1, c2)
        _rz_into(th[m, 0], Rz)
        R = np.empty((3, 3))
        _rz_into(th[m, 0], R)
        for i in range(1, 5):
            _mul3(R, LR[i - 1])
            _rz_into(th[m, i], Rz)
            _mul3(R, Rz)
        _mul3(R, LR[4])
        # Rz(t6) = R^T G: its first column
        c6 = R[0, 0] * Gm[0, 0] + R[1, 0] * Gm[1, 0] + R[2, 0] * Gm[2, 0]
        s6 = R[0, 1] * Gm[0, 0] + R[1, 1] * Gm[1, 0] + R[2, 1] * Gm[2, 0]
        th[m, 5] = math.atan2(s6, c6)


@nb.njit(cache=True)
def _x3_inside(clo, chi, slo, shi, c, rad):
    """``tan(t / 2) = s / (1 + c)`` over ``c in [clo, chi]``, ``s in [slo, shi]`` proven inside
    the real segment ``[c - rad, c + rad]`` of an eigenvalue's disc
    (:func:`kinbox.search.eigen6r.x3_enclosure`)."""
    dlo = np.nextafter(1.0 + clo, -np.inf)
    dhi = np.nextafter(1.0 + chi, np.inf)
    if not dlo > 0.0:
        return False
    q0, q1, q2, q3 = slo / dlo, slo / dhi, shi / dlo, shi / dhi
    elo = np.nextafter(min(min(q0, q1), min(q2, q3)), -np.inf)
    ehi = np.nextafter(max(max(q0, q1), max(q2, q3)), np.inf)
    # the disc's ends rounded inward: up(fl(c - rad)) >= c - rad, down(fl(c + rad)) <= c + rad
    return np.nextafter(c - rad, np.inf) < elo and ehi < np.nextafter(c + rad, -np.inf)


@nb.njit(cache=True)
def quaternion_rotation(v, R):
    """``R[0]`` = the rotation of the unit quaternion ``v[3:7]`` normalised, in floating point
    (within a few ulps of the exact rotation of ``q / |q|``, far inside the goal's enclosure
    :data:`GOAL_ERR`): the pose the joint certificate encloses (:func:`kinbox.search.cf_certify.goal_enclosure`)."""
    n = math.sqrt(v[3] ** 2 + v[4] ** 2 + v[5] ** 2 + v[6] ** 2)
    x, y, z, w = v[3] / n, v[4] / n, v[5] / n, v[6] / n
    R[0, 0, 0] = 1 - 2 * (y * y + z * z)
    R[0, 0, 1] = 2 * (x * y - z * w)
    R[0, 0, 2] = 2 * (x * z + y * w)
    R[0, 1, 0] = 2 * (x * y + z * w)
    R[0, 1, 1] = 1 - 2 * (x * x + z * z)
    R[0, 1, 2] = 2 * (y * z - x * w)
    R[0, 2, 0] = 2 * (x * z - y * w)
    R[0, 2, 1] = 2 * (y * z + x * w)
    R[0, 2, 2] = 1 - 2 * (x * x + y * y)


@nb.njit(cache=True)
def _certify6(th, jargs, Gm, Gr, gtm, gtr, ws, klo, khi):
    """Krawczyk in the six joint angles (:func:`kinbox.search.cf_certify.krawczyk6`, the
    model's constants as enclosures) about the back substitution's angles ``th`` after two
    Newton steps (in place), the box widened as the closed form's batch widens it where the
    first fails (:data:`kinbox.search.cf_certify.PROOF_GROWTH` times how far the root may lie);
    False where no box is proven."""
    LR, Lt, d = jargs[0], jargs[1], jargs[2]
    step = np.empty(6)
    rad = np.empty(6)
    if not newton6(th, LR, Lt, d, Gm, Gr, gtm, gtr, ws, 2, step):
        return False
    for i in range(6):
        rad[i] = PROOF_RADIUS * (1.0 + abs(th[i]))
    if krawczyk6(th, rad, LR, Lt, d, Gm, Gr, gtm, gtr, klo, khi, ws) == CERT_UNIQUE:
        return True
    big = 0.0
    for i in range(6):
        big = max(big, abs(step[i]))
    for grow in PROOF_GROWTH:
        for i in range(6):
            rad[i] = max(PROOF_RADIUS * (1.0 + abs(th[i])), grow * big)
        if krawczyk6(th, rad, LR, Lt, d, Gm, Gr, gtm, gtr, klo, khi, ws) == CERT_UNIQUE:
            return True
    return False


@nb.njit(cache=True)
def _box_trig(klo, khi, box):
    """Enclosures ``(c, s)`` (6, 4) of each angle over the proof box ``[klo, khi]``."""
    for i in range(6):
        mid = 0.5 * klo[i] + 0.5 * khi[i]
        r = _up(max(mid - klo[i], khi[i] - mid) + abs(mid) * 2.0**-51)
        c, s = trig(mid, r)
        box[i, 0], box[i, 1] = c
        box[i, 2], box[i, 3] = s


@nb.njit(cache=True)
def proof_kernel(Am, Ar, w, V, LR, Pm, a, Rinv, Gm, v, jargs, ws, limits, theta, klo_out, khi_out):
    """Kernel 2 (module docstring) from the eigenvalues ``w`` and eigenvectors ``V`` of
    :func:`pencil_kernel`'s companion matrix: the roots within the joint limits, each
    certified by Krawczyk in the joint angles on the pose as given (XYZQUAT ``v``;
    ``jargs``: :meth:`kinbox.search.cf_certify.JointCertifier.kernel_args` of the arm's own
    geometry, whose angles are the canonical ones) into the first rows of ``theta`` and the
    proof boxes ``klo_out, khi_out``; returns (status, how many). ``ws``: scratch of
    :func:`kinbox.search.cf_certify.workspace`."""
    centres = np.empty(DEGREE)
    radii = np.empty(DEGREE)
    vecs = np.empty((12, DEGREE))
    st, k = prove_count_kernel(Am, Ar, w, V, centres, radii, vecs)
    if st != OK:
        return st, 0
    th = np.empty((k, 6))
    back_substitute_kernel(LR, Pm, a, Rinv, centres, vecs, Gm, k, th)
    GRj = np.empty((3, 3, 2))
    Gtj = np.empty((3, 2))
    G6m = np.empty((3, 3))
    G6r = np.empty((3, 3))
    gtm = np.empty(3)
    gtr = np.empty(3)
    goal_enclosure(v, jargs[3], jargs[4], jargs[5], jargs[6], jargs[7], GRj, Gtj)
    goal_mr(GRj, Gtj, G6m, G6r, gtm, gtr)
    klo = np.empty(6)
    khi = np.empty(6)
    box = np.empty((6, 4))
    kept = 0
    for i in range(k):
        t6 = np.empty(6)
        for j in range(6):
            t6[j] = th[i, j]
        if not _certify6(t6, jargs, G6m, G6r, gtm, gtr, ws, klo, khi):
            return NOT_CERTIFIED, 0
        _box_trig(klo, khi, box)
        if not _x3_inside(box[2, 0], box[2, 1], box[2, 2], box[2, 3], centres[i], radii[i]):
            return NOT_MINE, 0  # the root is not proven to be this eigenvalue's
        verdict = _in_limits(box, limits)
        if verdict < 0:
            return ON_LIMIT, 0  # a root on a joint limit
        if verdict > 0:
            for j in range(6):
                theta[kept, j] = t6[j]
                klo_out[kept, j], khi_out[kept, j] = klo[j], khi[j]
            kept += 1
    return OK, kept
