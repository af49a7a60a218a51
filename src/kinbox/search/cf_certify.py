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
exactly, the rotation that of ``q / |q|`` in midpoint-radius arithmetic (:func:`goal_mr_of`;
:func:`goal_enclosure` in interval arithmetic), composed with the enclosures of ``A`` and ``B``. ``cos`` and ``sin``
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

import numpy as np

from . import jit as nb
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
    ``u`` (3, 2))."""
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


@nb.njit(cache=True, inline="always")
def _inverse(A, Y, M):
    """``Y ~ A^-1`` (6x6; Gauss-Jordan in place with partial pivoting, the row interchanges
    undone as column interchanges at the end; ``M``: scratch, its first row holds the pivots'
    rows); False if a pivot is zero. Any ``Y`` serves Krawczyk's test, whose bounds hold for
    every preconditioner (tests/search/test_cf_certify.py::test_inverse_is_the_inverse)."""
    for i in range(6):
        for j in range(6):
            Y[i, j] = A[i, j]
    for k in range(6):
        p = k
        big = abs(Y[k, k])
        for i in range(k + 1, 6):
            v = abs(Y[i, k])
            if v > big:
                p = i
                big = v
        if not big > 0.0:
            return False
        M[0, k] = p
        if p != k:
            for j in range(6):
                Y[k, j], Y[p, j] = Y[p, j], Y[k, j]
        inv = 1.0 / Y[k, k]
        Y[k, k] = 1.0
        for j in range(6):
            Y[k, j] *= inv
        for i in range(6):
            if i != k:
                f = Y[i, k]
                Y[i, k] = 0.0
                for j in range(6):
                    Y[i, j] -= f * Y[k, j]
    for k in range(5, -1, -1):
        p = int(M[0, k])
        if p != k:
            for i in range(6):
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


@nb.njit(cache=True, inline="always")
def fk_mr(th, LR, Lt, d, Cm, tm, wm, om, cs, er):
    """Forward kinematics at the point ``th`` (arm angles) in midpoint-radius arithmetic with one
    radius per row: the columns ``Cm[k, row]`` and position ``tm`` of ``T(th)``, each joint's
    axis ``wm[i]`` and a point ``om[i]`` of it, in binary64, and ``cs[i]`` the binary64 ``cos``
    and ``sin`` of ``th[i]`` (each within :data:`TRIG_ERR`: :func:`box_trig_at`); ``er`` (4, 3):
    every entry of row ``r`` of the rotation within ``er[0, r]`` of the exact one, of the
    position within ``er[1, r]``, of row ``r`` of every axis within ``er[2, r]`` and of every
    point within ``er[3, r]``. The links are enclosures of the model's exact ones: ``LR`` (5,
    3, 3, 2) and ``Lt`` (5, 3, 2), midpoint ``[..., 0]`` and radius ``[..., 1]``
    (:class:`JointCertifier`); the offsets ``d`` exact binary64 numbers.

    The joints and links act on the columns, so a row's entries mix with the same row's only.
    Each entry is a short dot product ``sum_k a_k x_k`` (``a`` a ``cos``/``sin`` within
    :data:`TRIG_ERR` or a link entry within its radius, ``x`` an entry of the row within its
    radius ``rho``), its error below ``sum_k (|a_k| rho + r_ak (|x_k| + rho))`` for the inputs
    and ``u n`` times ``sum_k |a_k x_k|`` for the roundings of ``n <= 4`` terms (rounded up to
    ``2u`` for two terms and ``4u`` for three or four), bounded over the row with the link's
    largest column sums ``sum_k |a_k|``, ``sum_k r_ak``; times :data:`_SAFE` for the roundings
    of the radius itself and ``_ETA`` for underflow
    (``tests/search/test_cf_certify.py::test_forward_kinematics_radii_hold_the_200_bit_frames``)."""
    for k in range(3):
        for r in range(3):
            Cm[k, r] = 1.0 if k == r else 0.0
        tm[k] = 0.0
        er[0, k] = 0.0
        er[1, k] = 0.0
    for i in range(6):
        for r in range(3):
            wm[i, r] = Cm[2, r]
            om[i, r] = tm[r]
        if i == 5:  # the radii grow joint by joint: the last ones bound them all
            for r in range(3):
                er[2, r] = er[0, r]
                er[3, r] = er[1, r]
        c = math.cos(th[i])
        s = math.sin(th[i])
        cs[i, 0] = c
        cs[i, 1] = s
        ac, as_ = abs(c), abs(s)
        di = d[i]
        for r in range(3):
            # columns 0, 1 turned: c x + s y, c y - s x (two terms); then t + d C_2 (two terms)
            x, y, rho = Cm[0, r], Cm[1, r], er[0, r]
            a, b = c * x, s * y
            p, q = c * y, s * x
            Cm[0, r] = a + b
            Cm[1, r] = p - q
            rnd = max(abs(a) + abs(b), abs(p) + abs(q))
            rho2 = (TRIG_ERR * (abs(x) + abs(y) + 2.0 * rho) + (ac + as_) * rho + _U2 * rnd) * _SAFE + _ETA
            er[0, r] = max(rho2, rho)  # column 2 keeps rho
            if di != 0.0:
                z = di * Cm[2, r]
                tr = tm[r]
                tm[r] = tr + z
                er[1, r] = (er[1, r] + abs(di) * rho + _U2 * (abs(tr) + abs(z))) * _SAFE + _ETA
        if i == 5:
            break
        # the link: t + sum_k Lt_k C_k (four terms), C'_cc = sum_k LR_k,cc C_k (three terms)
        l0, l1, l2 = Lt[i, 0, 0], Lt[i, 1, 0], Lt[i, 2, 0]
        a1 = abs(l0) + abs(l1) + abs(l2)
        ar = Lt[i, 0, 1] + Lt[i, 1, 1] + Lt[i, 2, 1]
        L1, Lr = 0.0, 0.0
        for cc in range(3):
            L1 = max(L1, abs(LR[i, 0, cc, 0]) + abs(LR[i, 1, cc, 0]) + abs(LR[i, 2, cc, 0]))
            Lr = max(Lr, LR[i, 0, cc, 1] + LR[i, 1, cc, 1] + LR[i, 2, cc, 1])
        for r in range(3):
            x0, x1, x2, rho = Cm[0, r], Cm[1, r], Cm[2, r], er[0, r]
            X = max(abs(x0), abs(x1), abs(x2))
            p0, p1, p2 = l0 * x0, l1 * x1, l2 * x2
            tr = tm[r]
            tm[r] = tr + (p0 + p1 + p2)
            er[1, r] = (er[1, r] + a1 * rho + ar * (X + rho) + 2.0 * _U2 * (abs(tr) + abs(p0) + abs(p1) + abs(p2))) * _SAFE + _ETA
            rnd = 0.0
            for cc in range(3):
                q0, q1, q2 = LR[i, 0, cc, 0] * x0, LR[i, 1, cc, 0] * x1, LR[i, 2, cc, 0] * x2
                Cm[cc, r] = q0 + q1 + q2
                rnd = max(rnd, abs(q0) + abs(q1) + abs(q2))
            er[0, r] = (L1 * rho + Lr * (X + rho) + 2.0 * _U2 * rnd) * _SAFE + _ETA


@nb.njit(cache=True, inline="always")
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


@nb.njit(cache=True, inline="always")
def _at_point(th, LR, Lt, d, Gm, Gr, gtm, gtr, ws):
    """``F`` and ``J`` at the point ``th`` into ``ws``'s ``Fm``, ``Fr``, ``Jm``, ``Jr``: ``F`` in
    midpoint-radius arithmetic on :func:`fk_mr`'s frames (each entry a short dot product, its
    radius :func:`mdot3`'s formula over the matrix's one radius), ``J`` in binary64, each row's
    radius one bound of its entries' errors (:func:`_jacobian_radii`); and ``(trace, its
    radius, max_k |p - o_k|)`` there."""
    Cm, tm, wm, om, Fm, Fr, Jm, Jr, Y, GJ, cs, er = ws
    fk_mr(th, LR, Lt, d, Cm, tm, wm, om, cs, er)
    # F(m): position, then 1/2 sum_k g_k x r_k (six terms); trace(R_G^T R) = sum_k g_k . r_k (nine)
    for r in range(3):
        m = tm[r] - gtm[r]
        Fm[r] = m
        Fr[r] = (er[1, r] + gtr[r] + _U2 * abs(m)) * _UPF + _ETA
    trm, tra, tri = 0.0, 0.0, 0.0
    Gmax, rG, Cmax = 0.0, 0.0, 0.0
    for q in range(3):
        i, j = (q + 1) % 3, (q + 2) % 3
        ri, rj, rq = er[0, i], er[0, j], er[0, q]
        o, oa, oi = 0.0, 0.0, 0.0
        for k in range(3):
            p1 = Gm[k, i] * Cm[k, j]
            p2 = Gm[k, j] * Cm[k, i]
            o += p1 - p2
            oa += abs(p1) + abs(p2)
            oi += abs(Gm[k, i]) * rj + Gr[k, i] * (abs(Cm[k, j]) + rj) + abs(Gm[k, j]) * ri + Gr[k, j] * (abs(Cm[k, i]) + ri)
            p = Gm[k, q] * Cm[k, q]
            trm += p
            tra += abs(p)
            tri += abs(Gm[k, q]) * rq + Gr[k, q] * (abs(Cm[k, q]) + rq)
            Gmax = max(Gmax, abs(Gm[k, q]))
            rG = max(rG, Gr[k, q])
            Cmax = max(Cmax, abs(Cm[k, q]))
        Fm[3 + q] = 0.5 * o
        Fr[3 + q] = 0.5 * (oi + 4.0 * _U2 * oa) * _SAFE + _ETA
    trr = (tri + 6.0 * _U2 * tra) * _SAFE + _ETA
    rho = max(er[0, 0], er[0, 1], er[0, 2])
    tau = max(er[1, 0], er[1, 1], er[1, 2])
    rw = max(er[2, 0], er[2, 1], er[2, 2])
    ro = max(er[3, 0], er[3, 1], er[3, 2])
    # D: max_k |p - o_k| at m
    D = 0.0
    for k in range(6):
        acc = 0.0
        for q in range(3):
            v = abs(tm[q] - om[k, q]) + er[1, q] + er[3, q]
            acc += v * v
        D = max(D, math.sqrt(acc * _UPF) * _UPF)
    # J(m): columns w_i x (p - o_i) and 1/2 (trace w_i - R (R_G^T w_i)), in binary64, and one
    # bound of the error per row block (_jacobian_radii): Krawczyk widens J(m) by L sum_j r_j
    # (about 1e-8), so a bound of J(m)'s error at the rounding level need not be entrywise
    Wmax, Bmax, gmax, amax = 0.0, 0.0, 0.0, 0.0
    rb = tau + ro
    for i in range(6):
        b0, b1, b2 = tm[0] - om[i, 0], tm[1] - om[i, 1], tm[2] - om[i, 2]
        Bmax = max(Bmax, abs(b0), abs(b1), abs(b2))
        w0, w1, w2 = wm[i, 0], wm[i, 1], wm[i, 2]
        Wmax = max(Wmax, abs(w0), abs(w1), abs(w2))
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
    rp, ro_ = _jacobian_radii(Wmax, rw, Bmax, rb, Gmax, rG, Cmax, rho, gmax, amax, abs(trm), trr)
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
    return krawczyk_reach(th, rad, LR, Lt, d, Gm, Gr, gtm, gtr, klo, khi, ws, 1e-3)


@nb.njit(cache=True)
def _jacobian_over(th, sr, LR, Lt, d, Gm, Gr, gtm, gtr, ws):
    """``J`` over the box of radii summing to ``sr`` (below 1) about ``th``: ``J(m)`` in
    ``ws``'s ``Jm`` within the radii ``Jr`` (the same across each row), widened by ``L sr`` row
    by row (:func:`krawczyk6`'s bounds), ``Y`` its inverse and ``GJ[1]`` the largest ``|J(m)|``
    of each row (scratch past the pivots of ``_inverse``). Returns (``J(m)`` inverted, the
    trace of ``R R_G^T`` at ``m`` less its radius)."""
    Jm, Jr, Y, GJ = ws[6], ws[7], ws[8], ws[9]
    trm, trr, D = _at_point(th, LR, Lt, d, Gm, Gr, gtm, gtr, ws)
    D = D / (1.0 - sr) * 1.0001  # over X (D_X <= D_m / (1 - sum r)); the factor covers D's roundings
    for q in range(6):
        L = D if q < 3 else 4.0
        rq = (Jr[q, 0] + L * sr) * _UPF
        for i in range(6):
            Jr[q, i] = rq
    if not _inverse(Jm, Y, GJ):
        return False, trm - trr
    for k in range(6):
        mx = 0.0
        for j in range(6):
            mx = max(mx, abs(Jm[k, j]))
        GJ[1, k] = mx
    return True, trm - trr


@nb.njit(cache=True)
def krawczyk_reach(th, rad, LR, Lt, d, Gm, Gr, gtm, gtr, klo, khi, ws, reach):
    """:func:`krawczyk6` on a box whose radii sum to less than ``reach`` (below 1: its bounds
    hold for any such box, ``D_X <= D_m / (1 - sum r)``; the orientation rows' bound 4 and the
    trace's ``sqrt 6`` per radian do not depend on the box)."""
    Fm, Fr, Jm, Jr, Y, GJ = ws[4], ws[5], ws[6], ws[7], ws[8], ws[9]
    sr = 0.0
    for j in range(6):
        sr += rad[j]
    sr *= _UPF
    if not sr < reach:
        return CERT_FAILED
    ok, tr = _jacobian_over(th, sr, LR, Lt, d, Gm, Gr, gtm, gtr, ws)
    if not tr - 2.5 * sr > 0.5:  # a half turn from the goal (trace -1) not ruled out
        return CERT_FAILED
    if not ok:
        return CERT_FAILED
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
        y0, y1, y2, y3, y4, y5 = Y[r, 0], Y[r, 1], Y[r, 2], Y[r, 3], Y[r, 4], Y[r, 5]
        t = 0.0
        for j in range(6):
            e = (1.0 if r == j else 0.0) - (y0 * Jm[0, j] + y1 * Jm[1, j] + y2 * Jm[2, j] + y3 * Jm[3, j] + y4 * Jm[4, j] + y5 * Jm[5, j])
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
    Fm, Fr, Jm, Y, GJ = ws[4], ws[5], ws[6], ws[8], ws[9]
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
    """Scratch arrays of :func:`krawczyk6`: ``(Cm, tm, wm, om, Fm, Fr, Jm, Jr, Y, GJ, cs, er)``."""
    return (
        np.empty((3, 3)),
        np.empty(3),
        np.empty((6, 3)),
        np.empty((6, 3)),
        np.empty(6),
        np.empty(6),
        np.empty((6, 6)),
        np.empty((6, 6)),
        np.empty((6, 6)),
        np.empty((6, 12)),
        np.empty((6, 2)),
        np.empty((4, 3)),
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


@nb.njit(cache=True, inline="always")
def mdot3(a0, a1, a2, ar0, ar1, ar2, b0, b1, b2, br0, br1, br2):
    """``sum_k a_k b_k`` of three midpoint-radius products: the inputs' errors ``sum_k (|a_k|
    r_bk + r_ak (|b_k| + r_bk))``, the roundings of three terms ``4u sum_k |a_k b_k|``
    (:func:`fk_mr`'s formula), times :data:`_SAFE` and plus :data:`_ETA`."""
    p0, p1, p2 = a0 * b0, a1 * b1, a2 * b2
    m = p0 + p1 + p2
    r = abs(a0) * br0 + ar0 * (abs(b0) + br0) + abs(a1) * br1 + ar1 * (abs(b1) + br1) + abs(a2) * br2 + ar2 * (abs(b2) + br2)
    return m, (r + 2.0 * _U2 * (abs(p0) + abs(p1) + abs(p2))) * _SAFE + _ETA


@nb.njit(cache=True)
def frames_mr(AR, At, BR, Bt, FR, Ft):
    """Midpoint-radius form of the constant frames ``A``, ``B`` (interval arrays of
    :class:`JointCertifier`): ``FR[0]``, ``FR[1]`` (2, 3, 3) the rows of ``A``, ``B``
    (``[0]`` midpoints, ``[1]`` radii), ``Ft`` (2, 2, 3) their translations."""
    for f in range(2):
        R, t = (AR, At) if f == 0 else (BR, Bt)
        for r in range(3):
            for c in range(3):
                lo, hi = R[r, c, 0], R[r, c, 1]
                m = 0.5 * lo + 0.5 * hi
                FR[f, 0, r, c] = m
                FR[f, 1, r, c] = _up(max(m - lo, hi - m))
            lo, hi = t[r, 0], t[r, 1]
            m = 0.5 * lo + 0.5 * hi
            Ft[f, 0, r] = m
            Ft[f, 1, r] = _up(max(m - lo, hi - m))


@nb.njit(cache=True, inline="always")
def _one_minus(b):
    return msub(1.0, 0.0, b[0], b[1])


@nb.njit(cache=True, inline="always")
def _times(am, ar, b):
    return mmul(am, ar, b[0], b[1])


@nb.njit(cache=True, inline="always")
def _mput(Mm, Mr, r, c, transposed, v):
    """Entry ``(r, c)`` (``(c, r)`` if ``transposed``) of a midpoint-radius matrix."""
    if transposed:
        Mm[c, r], Mr[c, r] = v[0], v[1]
    else:
        Mm[r, c], Mr[r, c] = v[0], v[1]


@nb.njit(cache=True)
def goal_mr_of(v, FR, Ft, reversed_, Gm, Gr, gtm, gtr, S):
    """:func:`goal_enclosure` then :func:`goal_mr` in midpoint-radius arithmetic throughout:
    ``G = A M B`` for the goal ``M`` of XYZQUAT ``v`` (the rotation that of ``q / |q|``,
    ``2 / |q|^2`` an interval turned midpoint-radius, the entries by :func:`mmul`, :func:`madd`;
    inverted first for a reversed chain), the products by :func:`mdot3`, with the constant
    frames ``FR``, ``Ft`` of :func:`frames_mr`. Columns ``Gm``/``Gr`` (3, 3), translation
    ``gtm``/``gtr``; ``S`` (6, 3, 3): scratch
    (``tests/search/test_cf_certify.py::test_goal_enclosure_holds_the_200_bit_goal``)."""
    x, y, z, w = v[3], v[4], v[5], v[6]
    xi, yi, zi, wi = cst(x), cst(y), cst(z), cst(w)
    n = iadd(iadd(isqr(xi), isqr(yi)), iadd(isqr(zi), isqr(wi)))
    sl, sh = idiv(cst(2.0), n)
    sm = 0.5 * sl + 0.5 * sh
    sr = _up(max(sm - sl, sh - sm))
    xx, xxr = mmul(x, 0.0, x, 0.0)
    yy, yyr = mmul(y, 0.0, y, 0.0)
    zz, zzr = mmul(z, 0.0, z, 0.0)
    xy, xyr = mmul(x, 0.0, y, 0.0)
    xz, xzr = mmul(x, 0.0, z, 0.0)
    yz, yzr = mmul(y, 0.0, z, 0.0)
    xw, xwr = mmul(x, 0.0, w, 0.0)
    yw, ywr = mmul(y, 0.0, w, 0.0)
    zw, zwr = mmul(z, 0.0, w, 0.0)
    Mm, Mr, Wm, Wr = S[0], S[1], S[2], S[3]
    um, ur = S[4, 0], S[4, 1]
    mt, mtr = S[5, 0], S[5, 1]
    # R = I + s (...) entry by entry (rows); M = R, or R^T for a reversed chain
    d0, d0r = madd(yy, yyr, zz, zzr)
    d1, d1r = madd(xx, xxr, zz, zzr)
    d2, d2r = madd(xx, xxr, yy, yyr)
    _mput(Mm, Mr, 0, 0, reversed_, _one_minus(mmul(sm, sr, d0, d0r)))
    _mput(Mm, Mr, 1, 1, reversed_, _one_minus(mmul(sm, sr, d1, d1r)))
    _mput(Mm, Mr, 2, 2, reversed_, _one_minus(mmul(sm, sr, d2, d2r)))
    _mput(Mm, Mr, 0, 1, reversed_, _times(sm, sr, msub(xy, xyr, zw, zwr)))
    _mput(Mm, Mr, 1, 0, reversed_, _times(sm, sr, madd(xy, xyr, zw, zwr)))
    _mput(Mm, Mr, 0, 2, reversed_, _times(sm, sr, madd(xz, xzr, yw, ywr)))
    _mput(Mm, Mr, 2, 0, reversed_, _times(sm, sr, msub(xz, xzr, yw, ywr)))
    _mput(Mm, Mr, 1, 2, reversed_, _times(sm, sr, msub(yz, yzr, xw, xwr)))
    _mput(Mm, Mr, 2, 1, reversed_, _times(sm, sr, madd(yz, yzr, xw, xwr)))
    for r in range(3):
        if reversed_:  # -R^T t = -M t
            a, ar = mdot3(Mm[r, 0], Mm[r, 1], Mm[r, 2], Mr[r, 0], Mr[r, 1], Mr[r, 2], v[0], v[1], v[2], 0.0, 0.0, 0.0)
            mt[r], mtr[r] = -a, ar
        else:
            mt[r], mtr[r] = v[r], 0.0
    # W = A M; u = tM + M tB; G = W B (columns of G); tG = tA + A u
    Am, Ar, Bm, Br = FR[0, 0], FR[0, 1], FR[1, 0], FR[1, 1]
    btm, btr = Ft[1, 0], Ft[1, 1]
    for r in range(3):
        for c in range(3):
            Wm[r, c], Wr[r, c] = mdot3(
                Am[r, 0], Am[r, 1], Am[r, 2], Ar[r, 0], Ar[r, 1], Ar[r, 2], Mm[0, c], Mm[1, c], Mm[2, c], Mr[0, c], Mr[1, c], Mr[2, c]
            )
        a, ar = mdot3(Mm[r, 0], Mm[r, 1], Mm[r, 2], Mr[r, 0], Mr[r, 1], Mr[r, 2], btm[0], btm[1], btm[2], btr[0], btr[1], btr[2])
        um[r], ur[r] = madd(mt[r], mtr[r], a, ar)
    for r in range(3):
        for c in range(3):
            Gm[c, r], Gr[c, r] = mdot3(
                Wm[r, 0], Wm[r, 1], Wm[r, 2], Wr[r, 0], Wr[r, 1], Wr[r, 2], Bm[0, c], Bm[1, c], Bm[2, c], Br[0, c], Br[1, c], Br[2, c]
            )
        a, ar = mdot3(Am[r, 0], Am[r, 1], Am[r, 2], Ar[r, 0], Ar[r, 1], Ar[r, 2], um[0], um[1], um[2], ur[0], ur[1], ur[2])
        gtm[r], gtr[r] = madd(Ft[0, 0, r], Ft[0, 1, r], a, ar)


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
def box_trig_at(th, klo, khi, cs, perm, shift, csh, bt):
    """Enclosures ``bt`` (6, 4) of ``cos`` and ``sin`` of the family's angles over the proof box
    ``[klo, khi]`` (arm angles) about ``th``, as ``(c, s)`` intervals, from ``cs`` (6, 2): the
    binary64 ``cos`` and ``sin`` of ``th`` that :func:`fk_mr` computed there, each within
    :data:`TRIG_ERR` (no function evaluated again). Over the box, ``cos`` and ``sin`` of the arm
    angle lie within ``e = r + TRIG_ERR`` of them (``r`` the box's half-width about ``th``; both
    1-Lipschitz). A family angle ``theta - sigma`` (``sigma = shift[i]``, exact) has ``cos =
    cos theta cos sigma + sin theta sin sigma`` (``sin`` likewise), with ``csh`` (6, 2) the
    binary64 ``cos``, ``sin`` of ``sigma`` (within :data:`TRIG_ERR`): the computed sum is within
    ``e (|c_sigma| + |s_sigma| + 2 TRIG_ERR) + TRIG_ERR (|c| + |s|)`` and its rounding ``4u``
    of the sum of its terms' magnitudes
    (``tests/search/test_cf_certify.py::test_box_trig_holds_the_200_bit_functions``). Computed
    once per proof box, then compared with every other root's enclosure (:func:`_apart`)."""
    for i in range(6):
        a = perm[i]
        r = _up(max(th[a] - klo[a], khi[a] - th[a]))
        e = _up(r + TRIG_ERR)
        c, s = cs[a, 0], cs[a, 1]
        if shift[i] == 0.0:
            cm, cr, sm, sr = c, e, s, e
        else:
            ch, sh = csh[i, 0], csh[i, 1]
            base = e * (abs(ch) + abs(sh) + 2.0 * TRIG_ERR) + TRIG_ERR * (abs(c) + abs(s))
            p, q = c * ch, s * sh
            cm = p + q
            cr = (base + 2.0**-51 * (abs(p) + abs(q))) * _SAFE + _ETA
            p, q = s * ch, c * sh
            sm = p - q
            sr = (base + 2.0**-51 * (abs(p) + abs(q))) * _SAFE + _ETA
        bt[i, 0] = max(-1.0, _dn(cm - cr))
        bt[i, 1] = min(1.0, _up(cm + cr))
        bt[i, 2] = max(-1.0, _dn(sm - sr))
        bt[i, 3] = min(1.0, _up(sm + sr))


@nb.njit(cache=True)
def _apart(bt, enc):
    """Is a proof box, its ``cos`` and ``sin`` enclosed in ``bt`` (:func:`box_trig_at`), proven
    apart from a closed-form root's enclosure ``enc`` (6, 4) (``(c, s)`` intervals of the
    family's angles): some joint's ``cos`` or ``sin`` over the box disjoint from the root's?"""
    for i in range(6):
        if bt[i, 1] < enc[i, 0] or enc[i, 1] < bt[i, 0] or bt[i, 3] < enc[i, 2] or enc[i, 3] < bt[i, 2]:
            return True
    return False


#: a root enclosure this much inside a proof box is held by it (the roundings of the test)
_HOLD_SLOP = 2.0**-48
#: where a proof box does not hold a root's enclosure, boxes these many times the enclosure's
#: reach about the proven root (its Krawczyk box's middle, where ``F`` is about zero) are proven
#: in turn: a box barely larger than the enclosure keeps the Jacobian's spread small next to a
#: singularity, where the enclosure is wide
HOLD_GROWTH = (1.125, 1.5, 3.0)


@nb.njit(cache=True)
def enclosure_reach(enc, ang, th, perm, shift, need, tight=True):
    """How far from the proof box's centre ``th`` (arm angles) the roots in a closed-form
    root's enclosure ``enc`` (6, 4) may lie: ``need[perm[i]]`` (an upper bound) for each of the
    family's angles ``i``. The enclosure holds ``(cos, sin)`` within ``rho`` of its computed
    centre ``m`` (``rho`` its half-diagonal about ``m``), whose angle is ``ang[i]``
    (:func:`root_angles`); a unit vector within ``rho`` of ``m`` makes an angle at most
    ``asin(rho / |m|) <= 1.05 rho / |m|`` with it (``rho / |m| <= 0.3``), and the arm angle is
    the family's plus ``shift[i]``. Without ``tight`` (the batch's first test, no square root
    nor division): ``rho`` at most the sum of the half-widths, ``|m|`` at least its larger
    coordinate, asked to be at least 0.5, and ``rho <= 0.15``. False where ``rho / |m|`` is
    not that small
    (``tests/search/test_cf_certify.py::test_enclosure_reach_holds_the_enclosures_angles``)."""
    for i in range(6):
        cm = 0.5 * (enc[i, 0] + enc[i, 1])
        sm = 0.5 * (enc[i, 2] + enc[i, 3])
        rc = max(enc[i, 1] - cm, cm - enc[i, 0])
        rs = max(enc[i, 3] - sm, sm - enc[i, 2])
        if tight:
            rho = math.sqrt(rc * rc + rs * rs) * (1.0 + _HOLD_SLOP)
            m = math.sqrt(cm * cm + sm * sm) * (1.0 - _HOLD_SLOP)
            if not rho <= 0.3 * m:
                return False
            h = 1.05 * rho / m * (1.0 + _HOLD_SLOP)
        else:  # |m| >= max(|cm|, |sm|) >= 0.5: 1.05 rho / |m| <= 2.1 rho, no division
            rho = (rc + rs) * (1.0 + _HOLD_SLOP)
            if not (rho <= 0.15 and max(abs(cm), abs(sm)) >= 0.5):
                return False
            h = 2.1 * rho * (1.0 + _HOLD_SLOP)
        a = perm[i]
        # |ang + shift - th| (ang within a few ulps of the exact angle of m) plus h
        need[a] = (abs((ang[i] + shift[i]) - th[a]) + h + 4.0 * _U2 * (4.0 + abs(th[a]))) * (1.0 + _HOLD_SLOP)
    return True


@nb.njit(cache=True)
def enclosure_held(enc, ang, th, rad, perm, shift, need, tight=True):
    """Does the box ``th +- rad`` (arm angles) hold every root in the closed-form root's
    enclosure ``enc`` (:func:`enclosure_reach`)?"""
    if not enclosure_reach(enc, ang, th, perm, shift, need, tight):
        return False
    for i in range(6):
        if not need[i] < rad[i]:
            return False
    return True


#: power-iteration steps for the weights of :func:`jacobian_regular`'s proof
REGULAR_STEPS = 8


@nb.njit(cache=True)
def jacobian_regular(th, h, LR, Lt, d, Gm, Gr, gtm, gtr, ws, v, w):
    """Is every matrix of ``J(H)`` regular over the box ``H = th +- h`` (arm angles)? Then
    ``F`` is one to one on ``H`` (``F(a) - F(b) = M (a - b)`` with each row of ``M`` a row of
    ``J`` at a point of the segment, so ``M`` in ``J(H)``; ``H`` convex): ``H`` holds at most
    one zero of ``F``, so at most one root of ``T(theta) = G`` (every root is a zero of ``F``;
    the trace is not needed), for every arm and goal within the radii (:func:`krawczyk6`'s
    enclosures). Proven by weights ``v > 0`` with ``|I - Y J(H)| v < v`` (then the spectral
    radius of ``|I - Y J(H)|`` is below one, so ``Y J`` and ``J`` are regular), each entry
    ``|I - Y J(H)|_rj`` bounded as :func:`krawczyk6` bounds it, ``|e_rj| + c_r`` with ``e = I -
    Y J(m)`` in binary64 and ``c_r`` its rounding plus ``|Y_r| L sum h``; ``v`` from
    :data:`REGULAR_STEPS` steps of power iteration from ones (any ``v`` that passes is a proof).
    Unlike Krawczyk's ``|I - Y J(X)| r < r``, the weights need not be the box's radii: a
    root enclosure wide in the angles next to a wrist singularity and narrow in joint 5
    makes a box Krawczyk cannot contract
    (``tests/search/test_cf_regular.py::test_a_regular_jacobian_decides_a_wide_enclosure``).
    ``v``, ``w``: scratch (6,)."""
    Jm, Jr, Y, GJ = ws[6], ws[7], ws[8], ws[9]
    sr = 0.0
    for j in range(6):
        if not h[j] >= 0.0:
            return False
        sr += h[j]
    sr *= _UPF
    if not sr < 1e-3:
        return False
    ok, _tr = _jacobian_over(th, sr, LR, Lt, d, Gm, Gr, gtm, gtr, ws)
    if not ok:
        return False
    # |e_rj| of I - Y J(m) in binary64 (row r in GJ[2 + r // 2], columns 6 (r % 2) + j); c_r (GJ[0, r]): krawczyk6's c
    for r in range(6):
        ea = 1.0
        erj = 0.0
        for k in range(6):
            ea += abs(Y[r, k]) * GJ[1, k]
            erj += abs(Y[r, k]) * Jr[k, 0]
        GJ[0, r] = (ea * _UPF * 2.0**-49 + erj * _UPF) * _UPF
        for j in range(6):
            e = (1.0 if r == j else 0.0) - (
                Y[r, 0] * Jm[0, j] + Y[r, 1] * Jm[1, j] + Y[r, 2] * Jm[2, j] + Y[r, 3] * Jm[3, j] + Y[r, 4] * Jm[4, j] + Y[r, 5] * Jm[5, j]
            )
            GJ[2 + r // 2, 6 * (r % 2) + j] = abs(e)
    for j in range(6):
        v[j] = 1.0
    for _ in range(REGULAR_STEPS):  # towards the Perron vector of the bound (floats: a guess)
        sv = 0.0
        for j in range(6):
            sv += v[j]
        big = 0.0
        for r in range(6):
            acc = GJ[0, r] * sv
            for j in range(6):
                acc += GJ[2 + r // 2, 6 * (r % 2) + j] * v[j]
            w[r] = acc
            big = max(big, acc)
        if not (big > 0.0 and big < np.inf):
            return False
        for r in range(6):
            v[r] = max(w[r] / big, 2.0**-20)
    sv = 0.0
    for j in range(6):
        sv += v[j]
    sv *= _UPF
    for r in range(6):  # the proof: each row of |I - Y J(H)| v below v, rounded up
        t = 0.0
        for j in range(6):
            t += GJ[2 + r // 2, 6 * (r % 2) + j] * v[j]
        s = (t * _UPF + GJ[0, r] * sv) * _UPF
        s = s * _UPF + _ETA
        if not s < v[r] * (1.0 - _U2):
            return False
    return True


@nb.njit(cache=True)
def _alone_in_enclosure(encr, ang, th, rad, klo, khi, perm, shift, need, th2, rad2, klo2, khi2, LR, Lt, d, Gm, Gr, gtm, gtr, ws):
    """No other root in the enclosure ``encr`` of the root proven in ``[klo, khi]`` (Krawczyk
    about ``th`` with radii ``rad``): the enclosure lies in that proof's ``X``, or in a box about
    the proven root (the middle of its Krawczyk box) reaching past the enclosure, proven the same
    way (``tests/search/test_cf_certify.py::test_an_enclosure_outside_its_proof_box_sends_the_pose_on``),
    or in a box about it over which ``F`` is one to one (:func:`jacobian_regular`: the box holds
    the proven root and no other zero of ``F``, so no other root; ``scratch`` for it: ``klo2``,
    ``khi2``) (``tests/search/test_cf_regular.py::test_a_regular_jacobian_decides_a_wide_enclosure``)."""
    if enclosure_held(encr, ang, th, rad, perm, shift, need, False):  # the quick bound, else the tight one
        return True
    for i in range(6):
        th2[i] = 0.5 * (klo[i] + khi[i])
    if not enclosure_reach(encr, ang, th2, perm, shift, need):
        return False
    for grow in HOLD_GROWTH:
        for i in range(6):
            rad2[i] = max(PROOF_RADIUS * (1.0 + abs(th2[i])), grow * need[i])
        if krawczyk6(th2, rad2, LR, Lt, d, Gm, Gr, gtm, gtr, klo2, khi2, ws) == CERT_UNIQUE:
            return True
    # or F one to one over the box about th2 holding the enclosure and the proven root's box
    for i in range(6):
        rad2[i] = max(need[i], th2[i] - klo[i], khi[i] - th2[i]) * (1.0 + _HOLD_SLOP)
    return jacobian_regular(th2, rad2, LR, Lt, d, Gm, Gr, gtm, gtr, ws, klo2, khi2)


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
    :func:`kinbox.search.closed_form.family_tag` of the closed form's code.

    The closed form's enclosures hold every root of the model as given (its goal widened by
    :mod:`kinbox.search.cf_delta`); each root's enclosure must lie inside a box where Krawczyk
    proved one root of the model as given (the proof box's ``X``, or a box grown to hold the
    enclosure, :func:`enclosure_held`), so that it holds no other: else the pose goes to the
    branch and prune
    (``tests/search/test_cf_certify.py::test_an_enclosure_outside_its_proof_box_sends_the_pose_on``)."""
    N = Rlo.shape[0]
    enc = np.zeros((MAX_ROOTS, 6, 4))
    scratch = np.zeros((4, 3, 4))
    ws = (
        np.empty((3, 3)), np.empty(3), np.empty((6, 3)), np.empty((6, 3)), np.empty(6), np.empty(6),
        np.empty((6, 6)), np.empty((6, 6)), np.empty((6, 6)), np.empty((6, 12)), np.empty((6, 2)), np.empty((4, 3)),
    )  # fmt: skip
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
    need = np.empty(6)
    rad2 = np.empty(6)
    th2 = np.empty(6)
    klo2 = np.empty(6)
    khi2 = np.empty(6)
    bt = np.empty((6, 4))
    csh = np.empty((6, 2))  # cos, sin of the shifts (box_trig_at)
    for i in range(6):
        csh[i, 0] = math.cos(shift[i])
        csh[i, 1] = math.sin(shift[i])
    FR, Ft, gS = np.empty((2, 2, 3, 3)), np.empty((2, 2, 3)), np.empty((6, 3, 3))
    frames_mr(jAR, jAt, jBR, jBt, FR, Ft)
    m_out = 0
    for k in range(N):
        first[k] = m_out
        count[k] = 0
        nr = pose_roots(family, LR, Lt, d, limits, Rlo[k], Rhi[k], tlo[k], thi[k], enc, scratch, inside)
        if nr < 0:
            status[k] = POSE_FALLBACK
            continue
        goal_mr_of(V[k], FR, Ft, jrev, Gm, Gr, gtm, gtr, gS)
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
            box_trig_at(th, klo, khi, ws[10], perm, shift, csh, bt)
            for j in range(nr):
                if j != r and not _apart(bt, enc[j]):
                    ok = False
                    break
            if not ok:
                break
            if not _alone_in_enclosure(
                enc[r], ang, th, rad, klo, khi, perm, shift, need, th2, rad2, klo2, khi2, jLR, jLt, jd, Gm, Gr, gtm, gtr, ws
            ):
                ok = False
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
