"""Krawczyk in the six joint angles: a cheap certificate for a closed form's roots.

The IK problem of an arm of six revolute joints, in the canonical frames of its geometry
(:func:`kinbox.formulation.arm.canonical`: ``C_0^-1 C_6(theta) = Rz(theta_1) Tz(d_1) L_1 Rz(theta_2)
... L_5 Rz(theta_6) Tz(d_6)``), is ``T(theta) = G`` with ``G = C_0^-1 base M E^-1`` for the goal
``M``. Six of its twelve equations make a square system ``F(theta) = 0``:

* ``F_p = p(theta) - t_G`` (the position),
* ``F_o = 1/2 sum_k g_k x r_k`` (``g_k``, ``r_k`` the columns of ``R_G`` and ``R(theta)``), zero
  exactly where ``R R_G^T`` is symmetric: the identity, or a half turn, whose trace is ``-1``.

Over a box ``X`` where ``trace(R_G^T R(theta)) > -1`` is proven, the zeros of ``F`` are the
zeros of ``T(theta) = G`` -- for rotations that are exactly orthogonal, as the model's are.
The constants are those of **the model as given**: :mod:`kinbox.formulation.constants`
encloses its exact links ``L'_i`` and frames (exact rigid motions on the model's joint lines,
with the template's binary64 ``gamma`` and ``d``), and the kernels take each link entry as a
midpoint (the template's binary64 number) and a radius (0 to about 1e-16), the frames
``A = C_0^-1 base`` and ``B = E^-1`` as intervals; so ``F(m)`` and ``J`` below enclose those of
every arm within the radii, the model's among them, whose rotations are exactly orthogonal.
Its Jacobian is that of the joints' twists: ``dp/dtheta_i =
w_i x (p - o_i)`` and ``dF_o/dtheta_i = 1/2 (trace(R_G^T R) w_i - R R_G^T w_i)`` for joint
``i``'s axis ``w_i`` through ``o_i``. Everything is evaluated in outward-rounded interval
arithmetic (:mod:`kinbox.search.closed_form`'s, or midpoint-radius: ``J(m)`` in binary64 with a
bound of its error, :func:`_jacobian_radii`), over ``X`` (``J(X)``) and at its centre
(``F(m)``), with ``G`` an enclosure of the goal as given: the XYZQUAT's seven binary64 numbers
exactly, the rotation that of ``q / |q|`` in interval arithmetic, composed with the
enclosures of ``A`` and ``B``. ``cos`` and ``sin``
over an interval are ``cos(m) +- (r + 2^-50)`` (the libm result within an ulp, the function
1-Lipschitz). Then

    K(X) = m - Y F(m) + (I - Y J(X)) (X - m),     Y ~ mid(J(X))^-1,

``K(X) ⊂ int(X)`` and ``|I - Y J(X)| r < r`` prove that ``X`` holds exactly one zero
(Krawczyk; Moore) -- for every arm within the constants' radii, so for the model as given.
``tests/search/test_cf_certify.py`` checks the verdicts against Krawczyk on the kinbox system
and the boxes against python-flint's ball arithmetic (the root of the pose as given, on the
binary64 constants and on constants moved within their radii).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from .closed_form import (
    MAX_ROOTS,
    POSE_CLOSED_FORM,
    POSE_FALLBACK,
    _dn,
    _up,
    cst,
    iadd,
    idiv,
    imul,
    iscale,
    isqr,
    isub,
    pose_roots,
    root_angles,
)

#: bound on the error of ``math.cos`` / ``math.sin`` (libm: under an ulp of 1)
TRIG_ERR = 2.0**-50
#: verdicts
CERT_UNIQUE = 1
CERT_FAILED = 0


@nb.njit(cache=True)
def trig(th, rad):
    """Enclosures of ``cos`` and ``sin`` over ``[th - rad, th + rad]``."""
    c = math.cos(th)
    s = math.sin(th)
    e = rad + TRIG_ERR
    return (max(-1.0, _dn(c - e)), min(1.0, _up(c + e))), (max(-1.0, _dn(s - e)), min(1.0, _up(s + e)))


@nb.njit(cache=True)
def goal_enclosure(v, AR, At, BR, Bt, reversed_, GR, Gt):
    """Enclosure of ``G = A M B`` (``GR`` (3, 3, 2): columns; ``Gt`` (3, 2)) for the goal ``M``
    of XYZQUAT ``v`` (exact numbers; the rotation that of ``q / |q|``, inverted first for a
    reversed chain) and constant frames ``A``, ``B`` given as interval arrays ``AR`` (3, 3, 2)
    (rows), ``At`` (3, 2), ``BR`` (3, 3, 2) (rows), ``Bt`` (3, 2)."""
    goal_enclosure_into(v, AR, At, BR, Bt, reversed_, GR, Gt, np.empty((3, 3, 2)), np.empty((3, 3, 2)), np.empty((3, 2)), np.empty((3, 2)))


@nb.njit(cache=True)
def goal_enclosure_into(v, AR, At, BR, Bt, reversed_, GR, Gt, M, m, mt, u):
    """:func:`goal_enclosure` with its scratch arrays given (``M``, ``m`` (3, 3, 2), ``mt``,
    ``u`` (3, 2)): a batch allocates them once."""
    x, y, z, w = cst(v[3]), cst(v[4]), cst(v[5]), cst(v[6])
    n = iadd(iadd(isqr(x), isqr(y)), iadd(isqr(z), isqr(w)))
    s = idiv(cst(2.0), n)
    one = cst(1.0)
    e = (
        (isub(one, imul(s, iadd(isqr(y), isqr(z)))), imul(s, isub(imul(x, y), imul(z, w))), imul(s, iadd(imul(x, z), imul(y, w)))),
        (imul(s, iadd(imul(x, y), imul(z, w))), isub(one, imul(s, iadd(isqr(x), isqr(z)))), imul(s, isub(imul(y, z), imul(x, w)))),
        (imul(s, isub(imul(x, z), imul(y, w))), imul(s, iadd(imul(y, z), imul(x, w))), isub(one, imul(s, iadd(isqr(x), isqr(y))))),
    )
    for r in range(3):
        for c in range(3):
            a = e[c][r] if reversed_ else e[r][c]
            M[r, c, 0], M[r, c, 1] = a
    for r in range(3):
        if reversed_:  # -R^T t
            acc = cst(0.0)
            for k in range(3):
                acc = iadd(acc, iscale(v[k], (M[r, k, 0], M[r, k, 1])))
            mt[r, 0], mt[r, 1] = -acc[1], -acc[0]
        else:
            mt[r, 0], mt[r, 1] = v[r], v[r]
    # A M (rows of A times M), then (A M) B; translation A (M tB + tM) + tA
    for r in range(3):
        for c in range(3):
            acc = cst(0.0)
            for k in range(3):
                acc = iadd(acc, imul((AR[r, k, 0], AR[r, k, 1]), (M[k, c, 0], M[k, c, 1])))
            m[r, c, 0], m[r, c, 1] = acc
    for r in range(3):
        acc = (mt[r, 0], mt[r, 1])
        for k in range(3):
            acc = iadd(acc, imul((M[r, k, 0], M[r, k, 1]), (Bt[k, 0], Bt[k, 1])))
        u[r, 0], u[r, 1] = acc
    for r in range(3):
        for c in range(3):
            acc = cst(0.0)
            for k in range(3):
                acc = iadd(acc, imul((m[r, k, 0], m[r, k, 1]), (BR[k, c, 0], BR[k, c, 1])))
            GR[c, r, 0], GR[c, r, 1] = acc  # column c, row r
        acc = (At[r, 0], At[r, 1])
        for k in range(3):
            acc = iadd(acc, imul((AR[r, k, 0], AR[r, k, 1]), (u[k, 0], u[k, 1])))
        Gt[r, 0], Gt[r, 1] = acc


@nb.njit(cache=True)
def _inverse(A, Y, M):
    """``Y ~ A^-1`` (6x6; Gauss-Jordan in place with partial pivoting, the row interchanges
    undone as column interchanges at the end; ``M``: scratch, its first row holds the pivots'
    rows); False if a pivot is zero. Any ``Y`` serves Krawczyk's test, whose bounds hold for
    every preconditioner (tests/search/test_cf_certify.py::test_inverse_is_the_inverse)."""
    n = A.shape[0]
    for i in range(n):
        for j in range(n):
            Y[i, j] = A[i, j]
    for k in range(n):
        p = k
        big = abs(Y[k, k])
        for i in range(k + 1, n):
            v = abs(Y[i, k])
            if v > big:
                p = i
                big = v
        if not big > 0.0:
            return False
        M[0, k] = p
        if p != k:
            for j in range(n):
                Y[k, j], Y[p, j] = Y[p, j], Y[k, j]
        inv = 1.0 / Y[k, k]
        Y[k, k] = 1.0
        for j in range(n):
            Y[k, j] *= inv
        for i in range(n):
            if i != k:
                f = Y[i, k]
                if f != 0.0:
                    Y[i, k] = 0.0
                    for j in range(n):
                        Y[i, j] -= f * Y[k, j]
    for k in range(n - 1, -1, -1):
        p = int(M[0, k])
        if p != k:
            for i in range(n):
                Y[i, k], Y[i, p] = Y[i, p], Y[i, k]
    return True


# -- midpoint-radius arithmetic: (m, r) holds every x with |x - m| <= r ------------------------
#: twice the unit roundoff: the rounding error of a result m is at most _U2 |m| (no underflow)
_U2 = 2.0**-52
#: a sum of at most 8 nonnegative floats computed in round-to-nearest is at least the exact sum
#: over (1 + 9u); times this factor, itself rounded, it is an upper bound
_UPF = 1.0 + 2.0**-49
#: covers underflow (every operation adds it to the radius)
_ETA = 1e-300
#: covers the roundings of a bound computed from nonnegative numbers in fewer than 100
#: operations (each off by at most a factor 1 + 2^-53): (1 + 2^-53)^100 < 1 + 2^-45
_SAFE = 1.0 + 2.0**-40


@nb.njit(cache=True, inline="always")
def mmul(am, ar, bm, br):
    m = am * bm
    return m, (abs(am) * br + ar * (abs(bm) + br) + _U2 * abs(m)) * _UPF + _ETA


@nb.njit(cache=True, inline="always")
def madd(am, ar, bm, br):
    m = am + bm
    return m, (ar + br + _U2 * abs(m)) * _UPF + _ETA


@nb.njit(cache=True, inline="always")
def msub(am, ar, bm, br):
    m = am - bm
    return m, (ar + br + _U2 * abs(m)) * _UPF + _ETA


@nb.njit(cache=True, inline="always")
def mscale(k, am, ar):
    """``k x`` for an exact float ``k``."""
    m = k * am
    return m, (abs(k) * ar + _U2 * abs(m)) * _UPF + _ETA


@nb.njit(cache=True)
def fk_mr(th, LR, Lt, d, Cm, Cr, tm, tr_, wm, wr, om, orr):
    """Forward kinematics at the point ``th`` (arm angles) in midpoint-radius arithmetic: the
    columns ``C[k, row]`` and position ``t`` of ``T(th)``, each joint's axis ``w[i]`` and a
    point ``o[i]`` of it (midpoints ``*m``, radii ``*r``). The links are enclosures of the
    model's exact ones: ``LR`` (5, 3, 3, 2) and ``Lt`` (5, 3, 2), midpoint ``[..., 0]`` and
    radius ``[..., 1]`` (:class:`JointCertifier`); the offsets ``d`` exact binary64 numbers.

    Each entry is a short dot product ``sum_k a_k x_k`` (``a`` a ``cos``/``sin`` within
    :data:`TRIG_ERR` or a link entry within its radius, ``x`` an entry within its radius),
    its radius from one formula: ``sum_k (|a_k| r_xk + r_ak (|x_k| + r_xk))`` for the inputs,
    ``u n`` times ``sum_k |a_k x_k|`` for the roundings of ``n <= 4`` terms, rounded up to
    ``2u`` (``_U2``) for two terms and ``4u`` for three or four,
    times :data:`_SAFE` for the roundings of the radius itself and ``_ETA`` for underflow
    (``tests/search/test_cf_certify.py::test_proof_boxes_hold_the_200_bit_root``)."""
    for k in range(3):
        for r in range(3):
            Cm[k, r] = 1.0 if k == r else 0.0
            Cr[k, r] = 0.0
        tm[k] = 0.0
        tr_[k] = 0.0
    for i in range(6):
        for r in range(3):
            wm[i, r] = Cm[2, r]
            wr[i, r] = Cr[2, r]
            om[i, r] = tm[r]
            orr[i, r] = tr_[r]
        c = math.cos(th[i])
        s = math.sin(th[i])
        ac, as_ = abs(c), abs(s)
        for r in range(3):
            x, xr = Cm[0, r], Cr[0, r]
            y, yr = Cm[1, r], Cr[1, r]
            e = TRIG_ERR * (abs(x) + abs(y) + xr + yr)
            a, b = c * x, s * y
            Cm[0, r] = a + b
            Cr[0, r] = (ac * xr + as_ * yr + e + _U2 * (abs(a) + abs(b))) * _SAFE + _ETA
            a, b = c * y, s * x
            Cm[1, r] = a - b
            Cr[1, r] = (ac * yr + as_ * xr + e + _U2 * (abs(a) + abs(b))) * _SAFE + _ETA
            if d[i] != 0.0:
                a, ar = mscale(d[i], Cm[2, r], Cr[2, r])
                tm[r], tr_[r] = madd(tm[r], tr_[r], a, ar)
        if i == 5:
            break
        for r in range(3):
            x0, r0, x1, r1, x2, r2 = Cm[0, r], Cr[0, r], Cm[1, r], Cr[1, r], Cm[2, r], Cr[2, r]
            # t + sum_k Lt_k C_k (an exact zero adds nothing)
            m, rad, rnd = tm[r], tr_[r], abs(tm[r])
            for k in range(3):
                lm, lr = Lt[i, k, 0], Lt[i, k, 1]
                if lm != 0.0 or lr != 0.0:
                    xm, xr = Cm[k, r], Cr[k, r]
                    a = lm * xm
                    m += a
                    rad += abs(lm) * xr + lr * (abs(xm) + xr)
                    rnd += abs(a)
            tm[r] = m
            tr_[r] = (rad + 2.0 * _U2 * rnd) * _SAFE + _ETA
            for cc in range(3):
                m, rad, rnd = 0.0, 0.0, 0.0
                lm, lr = LR[i, 0, cc, 0], LR[i, 0, cc, 1]
                if lm != 0.0 or lr != 0.0:
                    a = lm * x0
                    m += a
                    rad += abs(lm) * r0 + lr * (abs(x0) + r0)
                    rnd += abs(a)
                lm, lr = LR[i, 1, cc, 0], LR[i, 1, cc, 1]
                if lm != 0.0 or lr != 0.0:
                    a = lm * x1
                    m += a
                    rad += abs(lm) * r1 + lr * (abs(x1) + r1)
                    rnd += abs(a)
                lm, lr = LR[i, 2, cc, 0], LR[i, 2, cc, 1]
                if lm != 0.0 or lr != 0.0:
                    a = lm * x2
                    m += a
                    rad += abs(lm) * r2 + lr * (abs(x2) + r2)
                    rnd += abs(a)
                Cm[cc, r] = m
                Cr[cc, r] = (rad + 2.0 * _U2 * rnd) * _SAFE + _ETA


@nb.njit(cache=True, inline="always")
def _mcross(am, ar, bm, br, i, j):
    """Component ``(a x b)_k`` from ``a_i b_j - a_j b_i`` (``(i, j)`` = (1, 2), (2, 0), (0, 1))."""
    p, pr = mmul(am[i], ar[i], bm[j], br[j])
    q, qr = mmul(am[j], ar[j], bm[i], br[i])
    return msub(p, pr, q, qr)


@nb.njit(cache=True)
def _jacobian_radii(W, rw, B, rb, G, rG, C, rC, g, a, tr, rtr):
    """Bounds of the error of ``J(m)`` computed in binary64 by :func:`_at_point`: position rows
    ``w x b`` (``b = p - o``), orientation rows ``1/2 (tr w - R g)`` with ``g = R_G^T w``. The
    arguments bound the computed numbers' magnitudes and their distance to the exact ones
    (midpoint-radius forward kinematics): axes ``|w| <= W`` within ``rw``; ``p - o`` before
    its subtraction within ``rb`` (the subtraction's rounding added here), ``|b| <= B``; the
    goal's columns ``|G| <= G`` within ``rG``; the chain's rotation ``|R| <= C`` within ``rC``;
    the computed ``|g| <= g``, ``|R g| <= a``; the trace ``|tr|`` within ``rtr``. A product
    ``x y`` of numbers within ``ex``, ``ey`` of exact ones is within ``ex (|y| + ey) + |x| ey``;
    a sum or dot product of ``n <= 3`` terms computed in binary64 is within ``2 n u`` (``u =
    2^-53``, ``_U2 = 2u``) of the sum of its terms' absolute values. Each entry of a row is
    below the returned bound (``tests/search/test_cf_certify.py::test_jacobian_radii_bound_the_error``)."""
    eb = rb + _U2 * B  # p - o, the subtraction's rounding included
    # (w x b)_k = w_i b_j - w_j b_i: two products (their inputs' errors), two roundings each
    rp = 2.0 * (rw * (B + eb) + W * eb) + 3.0 * _U2 * (2.0 * W * B)
    # g_k = sum_q G_kq w_q: three products, a dot product's rounding
    eg = 3.0 * (rG * (W + rw) + G * rw) + 3.0 * _U2 * (3.0 * G * W)
    # (R g)_q = sum_k R_kq g_k, from the computed g (within eg)
    ea = 3.0 * (rC * (g + eg) + C * eg) + 3.0 * _U2 * (3.0 * C * g)
    # tr w_q - (R g)_q, then halved (exact)
    ro = 0.5 * (rtr * (W + rw) + tr * rw + ea + 2.0 * _U2 * (tr * W + a) * 2.0)
    return rp * _SAFE + 1e-290, ro * _SAFE + 1e-290


@nb.njit(cache=True)
def _at_point(th, LR, Lt, d, Gm, Gr, gtm, gtr, ws):
    """``F`` and ``J`` at the point ``th`` into ``ws``'s ``Fm``, ``Fr``, ``Jm``, ``Jr``: ``F`` in
    midpoint-radius arithmetic, ``J`` in binary64 from the midpoint-radius frames, each row's
    radius one bound of its entries' errors (:func:`_jacobian_radii`); and ``(trace, its
    radius, max_k |p - o_k|)`` there."""
    Cm, Cr, tm, tr_, wm, wr, om, orr, Fm, Fr, Jm, Jr, Y, GJ, om3, or3, pm, pr = ws
    fk_mr(th, LR, Lt, d, Cm, Cr, tm, tr_, wm, wr, om, orr)
    # F(m): position, then 1/2 sum_k g_k x r_k; trace(R_G^T R) = sum_k g_k . r_k
    for r in range(3):
        Fm[r], Fr[r] = msub(tm[r], tr_[r], gtm[r], gtr[r])
    om3[:] = 0.0
    or3[:] = 0.0
    trm, trr = 0.0, 0.0
    for k in range(3):
        for q in range(3):
            i, j = (q + 1) % 3, (q + 2) % 3
            a, ar = _mcross(Gm[k], Gr[k], Cm[k], Cr[k], i, j)
            om3[q], or3[q] = madd(om3[q], or3[q], a, ar)
            a, ar = mmul(Gm[k, q], Gr[k, q], Cm[k, q], Cr[k, q])
            trm, trr = madd(trm, trr, a, ar)
    for q in range(3):
        Fm[3 + q], Fr[3 + q] = mscale(0.5, om3[q], or3[q])
    # D: max_k |p - o_k| at m
    D = 0.0
    for k in range(6):
        acc = 0.0
        for q in range(3):
            v = abs(tm[q] - om[k, q]) + tr_[q] + orr[k, q]
            acc += v * v
        D = max(D, math.sqrt(acc * _UPF) * _UPF)
    # J(m): columns w_i x (p - o_i) and 1/2 (trace w_i - R (R_G^T w_i)), in binary64, and one
    # bound of the error per row block (_jacobian_radii): Krawczyk widens J(m) by L sum_j r_j
    # (about 1e-8), so a bound of J(m)'s error at the rounding level need not be entrywise
    Wmax, rw, Bmax, rb = 0.0, 0.0, 0.0, 0.0
    Gmax, rG, Cmax, rC, gmax, amax = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    for q in range(3):
        rb = max(rb, tr_[q])
        for k in range(3):
            Gmax = max(Gmax, abs(Gm[k, q]))
            rG = max(rG, Gr[k, q])
            Cmax = max(Cmax, abs(Cm[k, q]))
            rC = max(rC, Cr[k, q])
    ro = 0.0
    for i in range(6):
        for q in range(3):
            Wmax = max(Wmax, abs(wm[i, q]))
            rw = max(rw, wr[i, q])
            ro = max(ro, orr[i, q])
    rb += ro
    for i in range(6):
        b0, b1, b2 = tm[0] - om[i, 0], tm[1] - om[i, 1], tm[2] - om[i, 2]
        Bmax = max(Bmax, abs(b0), abs(b1), abs(b2))
        w0, w1, w2 = wm[i, 0], wm[i, 1], wm[i, 2]
        Jm[0, i] = w1 * b2 - w2 * b1
        Jm[1, i] = w2 * b0 - w0 * b2
        Jm[2, i] = w0 * b1 - w1 * b0
        g0 = Gm[0, 0] * w0 + Gm[0, 1] * w1 + Gm[0, 2] * w2
        g1 = Gm[1, 0] * w0 + Gm[1, 1] * w1 + Gm[1, 2] * w2
        g2 = Gm[2, 0] * w0 + Gm[2, 1] * w1 + Gm[2, 2] * w2
        gmax = max(gmax, abs(g0), abs(g1), abs(g2))
        for q in range(3):
            a = Cm[0, q] * g0 + Cm[1, q] * g1 + Cm[2, q] * g2
            amax = max(amax, abs(a))
            Jm[3 + q, i] = 0.5 * (trm * wm[i, q] - a)
    rp, ro_ = _jacobian_radii(Wmax, rw, Bmax, rb, Gmax, rG, Cmax, rC, gmax, amax, abs(trm), trr)
    for i in range(6):
        for q in range(3):
            Jr[q, i] = rp
            Jr[3 + q, i] = ro_
    return trm, trr, D


@nb.njit(cache=True)
def krawczyk6(th, rad, LR, Lt, d, Gm, Gr, gtm, gtr, klo, khi, ws):
    """Prove that the box ``X = th +- rad`` (arm angles) holds exactly one root of ``T(theta)
    = G`` (``Gm``/``Gr`` (3, 3): columns of ``R_G``, midpoints and radii; ``gtm``/``gtr``: its
    translation): :data:`CERT_UNIQUE` with ``K(X) ∩ X`` in ``klo``, ``khi``, else
    :data:`CERT_FAILED`. ``ws``: scratch of :func:`workspace`.

    ``F(m)`` and ``J(m)`` are enclosed in midpoint-radius arithmetic at the centre; over ``X``,
    ``|J(theta) - J(m)| <= L sum_j |theta_j - m_j|`` row by row, from the chain's second
    derivatives: a position row by ``D = max_k |p - o_k|`` over ``X`` (each ``d/dtheta_j`` of
    ``w_i x (p - o_i)`` is a unit vector crossed with a unit vector crossed with some ``p -
    o_k``), an orientation row by 4 (``|d trace(Q)| <= |[w]x|_F |Q|_F = sqrt 6``, ``|trace| <= 3``,
    ``|d (Q w_i)| <= 2``: ``(sqrt 6 + 3 + 2) / 2 < 4`` for the rotation ``Q = R R_G^T``), and
    ``trace(Q)`` over ``X`` is at least its value at ``m`` less ``sqrt 6 sum_j r_j``."""
    Cm, Cr, tm, tr_, wm, wr, om, orr, Fm, Fr, Jm, Jr, Y, GJ, om3, or3, pm, pr = ws
    sr = 0.0
    for j in range(6):
        sr += rad[j]
    sr *= _UPF
    if not sr < 1e-3:
        return CERT_FAILED
    trm, trr, D = _at_point(th, LR, Lt, d, Gm, Gr, gtm, gtr, ws)
    if not trm - trr - 2.5 * sr > 0.5:  # a half turn from the goal (trace -1) not ruled out
        return CERT_FAILED
    D = D / (1.0 - sr) * 1.0001  # over X (D_X <= D_m / (1 - sum r)); the factor covers D's roundings
    # J over X: J(m) within a radius the same across each row (_at_point), plus L sum r
    for q in range(6):
        L = D if q < 3 else 4.0
        rq = (Jr[q, 0] + L * sr) * _UPF
        for i in range(6):
            Jr[q, i] = rq
    if not _inverse(Jm, Y, GJ):
        return CERT_FAILED
    # the largest |J(m)| of each row (GJ's row 1: scratch past the pivots of _inverse): |Y|
    # |J(m)| bounded row by row, for the rounding of Y J(m)
    for k in range(6):
        mx = 0.0
        for j in range(6):
            mx = max(mx, abs(Jm[k, j]))
        GJ[1, k] = mx
    # s_r = |Y F(m)|_r + sum_j |I - Y J(X)|_rj rad_j, each an upper bound; K(X) ⊂ m +- s
    for r in range(6):
        b = 0.0
        ab = 0.0
        ea = 1.0  # >= sum_k |Y_rk| |J(m)_kj| + |I_rj| for every j
        er = 0.0  # >= sum_k |Y_rk| |J(X) - J(m)|_kj for every j
        for k in range(6):
            b += Y[r, k] * Fm[k]
            ab += abs(Y[r, k]) * (abs(Fm[k]) * 2.0**-49 + Fr[k])
            ea += abs(Y[r, k]) * GJ[1, k]
            er += abs(Y[r, k]) * Jr[k, 0]
        c = (ea * _UPF * 2.0**-49 + er * _UPF) * _UPF
        # sum_j |I - Y J(X)|_rj rad_j <= sum_j |e_rj| rad_j + c sum_j rad_j (sr bounds the sum)
        t = 0.0
        for j in range(6):
            e = 1.0 if r == j else 0.0
            for k in range(6):
                e -= Y[r, k] * Jm[k, j]
            t += abs(e) * rad[j]
        s = ((abs(b) + ab) * _UPF + t * _UPF + c * sr) * _UPF
        s = s * _UPF + _ETA
        if not s < rad[r] * (1.0 - _U2):
            return CERT_FAILED
        klo[r] = _dn(th[r] - s)
        khi[r] = _up(th[r] + s)
    return CERT_UNIQUE


@nb.njit(cache=True)
def newton6(th, LR, Lt, d, Gm, Gr, gtm, gtr, ws, steps, last):
    """``steps`` Newton steps on ``F`` from ``th`` (in place, floats: a better centre for
    :func:`krawczyk6` where the closed form's root is only known to a few digits, next to a
    singularity); ``last``: per angle, the larger of the last step and ``|Y| (|F| + r_F)`` at
    the new centre (how far its root may lie, from ``F``'s enclosure there, the constants'
    radii included: a step that converged says nothing of that). False if the Jacobian is
    singular."""
    Fm, Fr, Jm, Y, GJ = ws[8], ws[9], ws[10], ws[12], ws[13]
    for _ in range(steps):
        _at_point(th, LR, Lt, d, Gm, Gr, gtm, gtr, ws)
        if not _inverse(Jm, Y, GJ):
            return False
        for r in range(6):
            acc = 0.0
            for k in range(6):
                acc += Y[r, k] * Fm[k]
            last[r] = acc
        for r in range(6):
            th[r] -= last[r]
    _at_point(th, LR, Lt, d, Gm, Gr, gtm, gtr, ws)
    if not _inverse(Jm, Y, GJ):
        return False
    for r in range(6):
        acc = 0.0
        for k in range(6):
            acc += abs(Y[r, k]) * (abs(Fm[k]) + Fr[k])
        last[r] = max(abs(last[r]), acc)
    return True


def workspace():
    """Scratch arrays of :func:`krawczyk6`."""
    return (
        np.empty((3, 3)),
        np.empty((3, 3)),
        np.empty(3),
        np.empty(3),
        np.empty((6, 3)),
        np.empty((6, 3)),
        np.empty((6, 3)),
        np.empty((6, 3)),
        np.empty(6),
        np.empty(6),
        np.empty((6, 6)),
        np.empty((6, 6)),
        np.empty((6, 6)),
        np.empty((6, 12)),
        np.empty(3),
        np.empty(3),
        np.empty(3),
        np.empty(3),
    )


@nb.njit(cache=True)
def goal_mr(GR, Gt, Gm, Gr, gtm, gtr):
    """Midpoint-radius form of an interval goal (:func:`goal_enclosure`)."""
    for k in range(3):
        for q in range(3):
            lo, hi = GR[k, q, 0], GR[k, q, 1]
            m = 0.5 * lo + 0.5 * hi
            Gm[k, q] = m
            Gr[k, q] = _up(max(m - lo, hi - m))
        lo, hi = Gt[k, 0], Gt[k, 1]
        m = 0.5 * lo + 0.5 * hi
        gtm[k] = m
        gtr[k] = _up(max(m - lo, hi - m))


@nb.njit(cache=True)
def constant_frames(C0R, C0t, baseR, baset, ER, Et, AR, At, BR, Bt):
    """Enclosures of ``A = C_0^-1 base`` and ``B = E^-1`` (inverses ``(R^T, -R^T t)``) of exact
    binary64 frames: rows ``AR``, ``BR`` (3, 3, 2), translations ``At``, ``Bt`` (3, 2)."""
    ci = np.empty((3, 2))
    for r in range(3):  # -C0R^T C0t
        acc = cst(0.0)
        for k in range(3):
            acc = iadd(acc, imul(cst(C0R[k, r]), cst(C0t[k])))
        ci[r, 0], ci[r, 1] = -acc[1], -acc[0]
    for r in range(3):
        for c in range(3):
            acc = cst(0.0)
            for k in range(3):
                acc = iadd(acc, imul(cst(C0R[k, r]), cst(baseR[k, c])))
            AR[r, c, 0], AR[r, c, 1] = acc
        acc = (ci[r, 0], ci[r, 1])
        for k in range(3):
            acc = iadd(acc, imul(cst(C0R[k, r]), cst(baset[k])))
        At[r, 0], At[r, 1] = acc
    for r in range(3):
        acc = cst(0.0)
        for c in range(3):
            BR[r, c, 0] = ER[c, r]
            BR[r, c, 1] = ER[c, r]
            acc = iadd(acc, imul(cst(ER[c, r]), cst(Et[c])))
        Bt[r, 0], Bt[r, 1] = -acc[1], -acc[0]


def _widened(v: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Intervals ``[v - r, v + r]`` (last axis lo, hi), each end moved outward past its
    rounding (:func:`kinbox.search.closed_form._dn`, ``_up``)."""
    lo, hi = v - r, v + r
    return np.stack([lo - (np.abs(lo) * 2.0**-51 + 1e-300), hi + (np.abs(hi) * 2.0**-51 + 1e-300)], axis=-1)


class JointCertifier:
    """What :func:`krawczyk6` needs of one arm: its template's geometry (forward orientation)
    with the model's exact constants enclosed, the goal's constant frames as enclosures, and
    the map from a family's canonical angles (:class:`kinbox.search.closed_form.ClosedForm`) to
    the geometry's: ``theta_geom[perm[i]] = theta_family[i] + shift[i]``.

    ``constants`` (:attr:`kinbox.formulation.arm.ArmTemplate.constants`, the radii of
    :func:`kinbox.formulation.constants.enclose_links`) bound the distance of the model's exact
    links ``L'_i`` and frames ``A' = C'_0^-1 base'``, ``B' = E'^-1`` to the binary64 ones: the
    links enter :func:`fk_mr` as midpoint and radius, ``A`` and ``B`` as the binary64 frames
    plus and minus their radii, so a certificate holds for the model as given
    (``tests/search/test_cf_certify.py::test_the_certificate_covers_every_model_within_the_radii``).
    Without them (None: a chain :mod:`~kinbox.formulation.constants` does not enclose) the
    radii are zero and the binary64 constants are taken as exact."""

    def __init__(self, geometry, family_joints, family_gamma, constants: dict | None = None):
        g = geometry
        if any(j.kind != "revolute" for j in g.chain.joints):
            raise ValueError("revolute joints only")
        LR = np.array([L.R for L in g.links], dtype=float)
        Lt = np.array([L.t for L in g.links], dtype=float)
        rR, rt = np.zeros_like(LR), np.zeros_like(Lt)
        if constants is not None:
            for i, (a, b) in enumerate(constants["links"]):
                rR[i], rt[i] = a, b
        self.LR = np.ascontiguousarray(np.stack([LR, rR], axis=-1))
        self.Lt = np.ascontiguousarray(np.stack([Lt, rt], axis=-1))
        self.d = np.ascontiguousarray(np.asarray(g.d, dtype=float))
        self.gamma = np.ascontiguousarray(np.asarray(g.gamma, dtype=float))
        self.AR = np.empty((3, 3, 2))
        self.At = np.empty((3, 2))
        self.BR = np.empty((3, 3, 2))
        self.Bt = np.empty((3, 2))
        C0, base, E = g.C0, g.chain.base, g.E
        if constants is None:
            constant_frames(
                np.ascontiguousarray(C0.rotation), np.ascontiguousarray(C0.translation),
                np.ascontiguousarray(base.rotation), np.ascontiguousarray(base.translation),
                np.ascontiguousarray(E.rotation), np.ascontiguousarray(E.translation),
                self.AR, self.At, self.BR, self.Bt,
            )  # fmt: skip
        else:  # the radii are distances to these binary64 products (constants.enclose_links)
            pairs = ((C0.inverse() * base, constants["A"], self.AR, self.At), (E.inverse(), constants["B"], self.BR, self.Bt))
            for F, (rFR, rFt), XR, Xt in pairs:
                XR[...] = _widened(np.asarray(F.rotation), rFR)
                Xt[...] = _widened(np.asarray(F.translation), rFt)
        self.reversed = bool(g.chain.reversed)
        index = {j.jid: i for i, j in enumerate(g.chain.joints)}
        self.perm = np.array([index[j.jid] for j in family_joints], dtype=np.int64)
        self.shift = np.array([g.gamma[index[j.jid]] - family_gamma[i] for i, j in enumerate(family_joints)], dtype=float)

    def kernel_args(self):
        return (self.LR, self.Lt, self.d, self.AR, self.At, self.BR, self.Bt, self.reversed, self.perm, self.shift)


#: half-width of the proof box about a root, relative to ``1 + |theta|``
PROOF_RADIUS = 1e-9
#: where that box is not proven (next to a singularity), boxes these many times how far the
#: root may lie from Newton's point (:func:`newton6`'s ``last``): the window between a box too
#: small for the error of ``F(m)`` (``|Y|`` times it, the constants' radii included) and one too
#: large for the Jacobian's spread is a decade or so wide there, so the steps are close
#: (tests/search/test_cf_certify.py::test_the_joint_certificate_decides_every_pose_the_system_one_does)
PROOF_GROWTH = (2.0, 10.0, 1e2, 1e3, 1e4)


@nb.njit(cache=True)
def box_trig(klo, khi, perm, shift, bt):
    """Enclosures ``bt`` (6, 4) of ``cos`` and ``sin`` of the family's angles over the box
    ``[klo, khi]`` (arm angles), as ``(c, s)`` intervals: computed once per proof box, then
    compared with every other root's enclosure (:func:`_apart`)."""
    for i in range(6):
        a = perm[i]
        mid = 0.5 * klo[a] + 0.5 * khi[a]
        th = mid - shift[i]  # rounded: off by at most 2^-52 |th| (added to the radius)
        r = _up(max(mid - klo[a], khi[a] - mid) + abs(th) * 2.0**-51 + abs(mid) * 2.0**-51)
        c, s = trig(th, r)
        bt[i, 0], bt[i, 1], bt[i, 2], bt[i, 3] = c[0], c[1], s[0], s[1]


@nb.njit(cache=True)
def _apart(bt, enc):
    """Is a proof box, its ``cos`` and ``sin`` enclosed in ``bt`` (:func:`box_trig`), proven
    apart from a closed-form root's enclosure ``enc`` (6, 4) (``(c, s)`` intervals of the
    family's angles): some joint's ``cos`` or ``sin`` over the box disjoint from the root's?"""
    for i in range(6):
        if bt[i, 1] < enc[i, 0] or enc[i, 1] < bt[i, 0] or bt[i, 3] < enc[i, 2] or enc[i, 3] < bt[i, 2]:
            return True
    return False


@nb.njit(cache=True)
def solve_batch_joint(
    family, LR, Lt, d, limits, Rlo, Rhi, tlo, thi, V,
    jLR, jLt, jd, jAR, jAt, jBR, jBt, jrev, perm, shift,
    status, first, count, theta_out, klo_out, khi_out,
):  # fmt: skip
    """Every pose of a batch (closed form and limits as
    :func:`kinbox.search.closed_form.solve_batch_kernel`), each root kept certified by
    :func:`krawczyk6` on the pose ``V[k]`` (XYZQUAT) and proven to be that root: its proof box
    apart from every other root's enclosure (the closed form's roots are all the roots, each in
    its enclosure). Proof boxes (arm angles) in ``klo_out``, ``khi_out``. ``family``:
    :func:`kinbox.search.closed_form.family_tag` of the closed form's code."""
    N = Rlo.shape[0]
    enc = np.zeros((MAX_ROOTS, 6, 4))
    scratch = np.zeros((4, 3, 4))
    ws = (
        np.empty((3, 3)), np.empty((3, 3)), np.empty(3), np.empty(3), np.empty((6, 3)), np.empty((6, 3)),
        np.empty((6, 3)), np.empty((6, 3)), np.empty(6), np.empty(6), np.empty((6, 6)), np.empty((6, 6)), np.empty((6, 6)),
        np.empty((6, 12)), np.empty(3), np.empty(3), np.empty(3), np.empty(3),
    )  # fmt: skip
    GR = np.empty((3, 3, 2))
    Gt = np.empty((3, 2))
    Gm = np.empty((3, 3))
    Gr = np.empty((3, 3))
    gtm = np.empty(3)
    gtr = np.empty(3)
    th = np.empty(6)
    rad = np.empty(6)
    klo = np.empty(6)
    khi = np.empty(6)
    step = np.empty(6)
    ang = np.empty(6)
    inside = np.empty(MAX_ROOTS, dtype=np.int64)
    bt = np.empty((6, 4))
    gM, gm, gmt, gu = np.empty((3, 3, 2)), np.empty((3, 3, 2)), np.empty((3, 2)), np.empty((3, 2))
    m_out = 0
    for k in range(N):
        first[k] = m_out
        count[k] = 0
        nr = pose_roots(family, LR, Lt, d, limits, Rlo[k], Rhi[k], tlo[k], thi[k], enc, scratch, inside)
        if nr < 0:
            status[k] = POSE_FALLBACK
            continue
        goal_enclosure_into(V[k], jAR, jAt, jBR, jBt, jrev, GR, Gt, gM, gm, gmt, gu)
        goal_mr(GR, Gt, Gm, Gr, gtm, gtr)
        ok = True
        m0 = m_out
        for r in range(nr):
            if inside[r] == 0:
                continue
            root_angles(enc[r], ang)
            for i in range(6):
                theta_out[m_out, i] = ang[i]
                th[perm[i]] = ang[i] + shift[i]
            for i in range(6):
                rad[i] = PROOF_RADIUS * (1.0 + abs(th[i]))
            if krawczyk6(th, rad, jLR, jLt, jd, Gm, Gr, gtm, gtr, klo, khi, ws) != CERT_UNIQUE:
                # next to a singularity the closed form's root is known to fewer digits: a few
                # Newton steps, then boxes PROOF_GROWTH times how far its root may lie
                if not newton6(th, jLR, jLt, jd, Gm, Gr, gtm, gtr, ws, 3, step):
                    ok = False
                    break
                big = 0.0
                for i in range(6):
                    big = max(big, abs(step[i]))
                proven = False
                for grow in PROOF_GROWTH:
                    for i in range(6):
                        rad[i] = max(PROOF_RADIUS * (1.0 + abs(th[i])), grow * big)
                    if krawczyk6(th, rad, jLR, jLt, jd, Gm, Gr, gtm, gtr, klo, khi, ws) == CERT_UNIQUE:
                        proven = True
                        break
                if not proven:
                    ok = False
                    break
                for i in range(6):
                    theta_out[m_out, i] = th[perm[i]] - shift[i]
            box_trig(klo, khi, perm, shift, bt)
            for j in range(nr):
                if j != r and not _apart(bt, enc[j]):
                    ok = False
                    break
            if not ok:
                break
            for i in range(6):
                klo_out[m_out, i] = klo[i]
                khi_out[m_out, i] = khi[i]
            m_out += 1
        if not ok:
            m_out = m0
            status[k] = POSE_FALLBACK
            continue
        status[k] = POSE_CLOSED_FORM
        count[k] = m_out - m0
    return m_out
