"""The closed form over a box of positions in centred (mean-value) form: tighter enclosures of
its discriminants near the workspace's border.

:func:`kinbox.search.closed_form.solve_branches` evaluates the closed form on the box's goal
enclosure in plain interval arithmetic: each quantity's enclosure over a box of width ``w`` is
wider than its range by an amount proportional to ``w`` (the dependency of the joint angles on
the position is lost at each step), so a discriminant that vanishes on the workspace's border
is not proven of one sign on a box whose distance to the border is below some fraction of its
width.

Here every quantity ``f`` of the closed form is carried as three enclosures
(:func:`cconst`, :func:`cadd`, :func:`cmul`, ...): of its value at the box's centre ``p_c``, of
its value over the box, and of its gradient ``df/dp`` over the box (forward differentiation in
interval arithmetic, outward rounded by the primitives of :mod:`kinbox.search.closed_form`).
By the mean-value theorem, ``f(p) ∈ f(p_c) + sum_j df/dp_j([box]) [-r_j, r_j]`` for every
position ``p`` of the box (``r`` its half widths) wherever ``f`` is differentiable over the
box; each step intersects that with the plain enclosure. Differentiability is proven along the
way: a square root or a quotient is formed only where its argument's enclosure over the box is
proven positive (the same tests that decide a branch). The centred form's excess over the
range is of the order of ``w^2``, not ``w``: a box is decided once its distance to the border
exceeds some multiple of ``w^2`` (``tests/workspace/test_centred.py`` checks the enclosures
against the closed form at points of the box, and the verdicts against the closed form at
sampled positions).

The three families of :mod:`kinbox.formulation.families` are written here, each mirroring its
steps in :mod:`kinbox.search.closed_form` one for one: lines 2, 3, 4 parallel and lines 5, 6
meeting (the UR series, code 3: :func:`planar_centred`), a spherical wrist with lines 1 and 2
meeting (code 1: :func:`meet_centred`) or lines 2 and 3 parallel (code 2:
:func:`parallel_centred`); the verdicts over boxes are :func:`centred_verdicts`.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..search.closed_form import MAX_ROOTS, _in_limits, cst, iadd, idiv, imul, ineg, iscale, isqr, isqrt, isub, solve_branches

#: families written in centred form (:func:`centred_verdicts`)
CENTRED_FAMILIES = (1, 2, 3)
#: a square's or a quotient's argument is used only where its enclosure over the box exceeds this
#: (far below any geometric quantity, far above underflow in the derivative's quotients)
TINY = 1e-100


@nb.njit(cache=True, inline="always")
def _meet(a, b):
    """The intersection of two enclosures of one number (the first where they miss, which exact
    arithmetic rules out)."""
    lo = max(a[0], b[0])
    hi = min(a[1], b[1])
    if lo > hi:
        return a
    return (lo, hi)


@nb.njit(cache=True)
def cconst(x):
    """A constant enclosed by the interval ``x``: ``(centre, box, d/dp_0, d/dp_1, d/dp_2)``."""
    z = (0.0, 0.0)
    return (x, x, z, z, z)


@nb.njit(cache=True)
def tight(a, r):
    """``a`` with its box enclosure intersected with the mean-value form about the centre."""
    m = a[0]
    for j in range(3):
        g = a[2 + j]
        if g[0] != 0.0 or g[1] != 0.0:
            m = iadd(m, imul(g, (-r[j], r[j])))
    return (a[0], _meet(a[1], m), a[2], a[3], a[4])


@nb.njit(cache=True, inline="always")
def _constant(a):
    """Is ``a``'s gradient zero (a constant over the box)?"""
    return a[2] == (0.0, 0.0) and a[3] == (0.0, 0.0) and a[4] == (0.0, 0.0)


@nb.njit(cache=True)
def cadd(a, b, r):
    s = (iadd(a[0], b[0]), iadd(a[1], b[1]), iadd(a[2], b[2]), iadd(a[3], b[3]), iadd(a[4], b[4]))
    # with a constant term the mean-value form is no tighter than the sum of the box enclosures
    return s if _constant(a) or _constant(b) else tight(s, r)


@nb.njit(cache=True)
def csub(a, b, r):
    s = (isub(a[0], b[0]), isub(a[1], b[1]), isub(a[2], b[2]), isub(a[3], b[3]), isub(a[4], b[4]))
    return s if _constant(a) or _constant(b) else tight(s, r)


@nb.njit(cache=True)
def cneg(a):
    return (ineg(a[0]), ineg(a[1]), ineg(a[2]), ineg(a[3]), ineg(a[4]))


@nb.njit(cache=True)
def cscale(k, a):
    """``k a`` for a float ``k``."""
    return (iscale(k, a[0]), iscale(k, a[1]), iscale(k, a[2]), iscale(k, a[3]), iscale(k, a[4]))


@nb.njit(cache=True)
def cmul(a, b, r):
    if _constant(a) and _constant(b):
        return cconst(imul(a[1], b[1]))
    if _constant(a):  # a constant factor: the product of the box enclosures is as tight
        k = a[1]
        return (imul(k, b[0]), imul(k, b[1]), imul(k, b[2]), imul(k, b[3]), imul(k, b[4]))
    if _constant(b):
        k = b[1]
        return (imul(a[0], k), imul(a[1], k), imul(a[2], k), imul(a[3], k), imul(a[4], k))
    return tight(
        (
            imul(a[0], b[0]),
            imul(a[1], b[1]),
            iadd(imul(a[2], b[1]), imul(a[1], b[2])),
            iadd(imul(a[3], b[1]), imul(a[1], b[3])),
            iadd(imul(a[4], b[1]), imul(a[1], b[4])),
        ),
        r,
    )


@nb.njit(cache=True)
def csqr(a, r):
    t = iscale(2.0, a[1])
    return tight((isqr(a[0]), isqr(a[1]), imul(t, a[2]), imul(t, a[3]), imul(t, a[4])), r)


@nb.njit(cache=True)
def csqrt(a, r):
    """``sqrt a`` for ``a`` proven above :data:`TINY` over the box (the callers check)."""
    c = _meet(a[0], a[1])
    q = isqrt(a[1])
    q2 = iscale(2.0, q)
    return tight((isqrt(c), q, idiv(a[2], q2), idiv(a[3], q2), idiv(a[4], q2)), r)


@nb.njit(cache=True)
def cdiv(a, b, r):
    """``a / b`` for ``|b|`` proven above :data:`TINY` over the box (the callers check)."""
    bc = _meet(b[0], b[1])
    b2 = imul(b[1], b[1])
    return tight(
        (
            idiv(a[0], bc),
            idiv(a[1], b[1]),
            idiv(isub(imul(a[2], b[1]), imul(a[1], b[2])), b2),
            idiv(isub(imul(a[3], b[1]), imul(a[1], b[3])), b2),
            idiv(isub(imul(a[4], b[1]), imul(a[1], b[4])), b2),
        ),
        r,
    )


# -- vectors: tuples of three centred numbers --------------------------------------------------
@nb.njit(cache=True)
def vconst(v):
    """A float vector as constants."""
    return (cconst(cst(v[0])), cconst(cst(v[1])), cconst(cst(v[2])))


@nb.njit(cache=True)
def vadd(u, v, r):
    return (cadd(u[0], v[0], r), cadd(u[1], v[1], r), cadd(u[2], v[2], r))


@nb.njit(cache=True)
def vsub(u, v, r):
    return (csub(u[0], v[0], r), csub(u[1], v[1], r), csub(u[2], v[2], r))


@nb.njit(cache=True)
def vscale(k, u, r):
    """``k u`` for a centred number ``k``."""
    return (cmul(k, u[0], r), cmul(k, u[1], r), cmul(k, u[2], r))


@nb.njit(cache=True)
def vdot(u, v, r):
    return cadd(cadd(cmul(u[0], v[0], r), cmul(u[1], v[1], r), r), cmul(u[2], v[2], r), r)


@nb.njit(cache=True)
def vnorm2(u, r):
    return cadd(cadd(csqr(u[0], r), csqr(u[1], r), r), csqr(u[2], r), r)


@nb.njit(cache=True)
def _lin3(a0, a1, a2, u, r):
    """``a0 u_0 + a1 u_1 + a2 u_2`` for floats ``a``."""
    return cadd(cadd(cscale(a0, u[0]), cscale(a1, u[1]), r), cscale(a2, u[2]), r)


@nb.njit(cache=True)
def fmv(M, v, r):
    """``M v`` for a float matrix ``M``."""
    return (_lin3(M[0, 0], M[0, 1], M[0, 2], v, r), _lin3(M[1, 0], M[1, 1], M[1, 2], v, r), _lin3(M[2, 0], M[2, 1], M[2, 2], v, r))


@nb.njit(cache=True)
def fmtv(M, v, r):
    """``M^T v`` for a float matrix ``M``."""
    return (_lin3(M[0, 0], M[1, 0], M[2, 0], v, r), _lin3(M[0, 1], M[1, 1], M[2, 1], v, r), _lin3(M[0, 2], M[1, 2], M[2, 2], v, r))


@nb.njit(cache=True)
def imv(R, v, r):
    """``R v`` for a matrix of centred numbers given by its rows."""
    return (vdot(R[0], v, r), vdot(R[1], v, r), vdot(R[2], v, r))


@nb.njit(cache=True)
def imtv(R, v, r):
    """``R^T v`` for a matrix of centred numbers given by its rows."""
    return vadd(vadd(vscale(v[0], R[0], r), vscale(v[1], R[1], r), r), vscale(v[2], R[2], r), r)


@nb.njit(cache=True)
def rz(c, s, v, r):
    """``Rz(theta) v``."""
    return (csub(cmul(c, v[0], r), cmul(s, v[1], r), r), cadd(cmul(s, v[0], r), cmul(c, v[1], r), r), v[2])


@nb.njit(cache=True)
def rzt(c, s, v, r):
    """``Rz(theta)^T v``."""
    return (cadd(cmul(c, v[0], r), cmul(s, v[1], r), r), csub(cmul(c, v[1], r), cmul(s, v[0], r), r), v[2])


# -- subproblems -------------------------------------------------------------------------------
@nb.njit(cache=True)
def sp_lin(A, B, K, r):
    """:func:`kinbox.search.closed_form.sp_lin` in centred form: (status, c+, s+, c-, s-) with
    status 2 (two roots over the whole box), 0 (none anywhere in the box) or -1 (undecided)."""
    z = cconst((0.0, 0.0))
    r2 = cadd(csqr(A, r), csqr(B, r), r)
    D = csub(r2, csqr(K, r), r)
    if D[1][1] < 0.0:
        return 0, z, z, z, z
    if not (r2[1][0] > TINY and D[1][0] > TINY):
        return -1, z, z, z, z
    q = csqrt(D, r)
    AK = cmul(A, K, r)
    BK = cmul(B, K, r)
    Bq = cmul(B, q, r)
    Aq = cmul(A, q, r)
    c1 = cdiv(csub(AK, Bq, r), r2, r)
    s1 = cdiv(cadd(BK, Aq, r), r2, r)
    c2 = cdiv(cadd(AK, Bq, r), r2, r)
    s2 = cdiv(csub(BK, Aq, r), r2, r)
    return 2, c1, s1, c2, s2


@nb.njit(cache=True)
def sp_rot(u, v, r):
    """:func:`kinbox.search.closed_form.sp_rot` in centred form: (ok, c, s); not ok where
    ``|u_xy|^2`` is not proven above :data:`TINY` over the box."""
    n2 = cadd(csqr(u[0], r), csqr(u[1], r), r)
    z = cconst((0.0, 0.0))
    if not n2[1][0] > TINY:
        return False, z, z
    c = cdiv(cadd(cmul(u[0], v[0], r), cmul(u[1], v[1], r), r), n2, r)
    s = cdiv(csub(cmul(u[0], v[1], r), cmul(u[1], v[0], r), r), n2, r)
    return True, c, s


@nb.njit(cache=True)
def _put(out, k, j, c, s):
    """A root's ``(c, s)`` enclosures over the box into ``out[k, j]``."""
    out[k, j, 0] = c[1][0]
    out[k, j, 1] = c[1][1]
    out[k, j, 2] = s[1][0]
    out[k, j, 3] = s[1][1]


@nb.njit(cache=True)
def _elbow_roots(LR, base, f, g, target, r):
    """Joints 3 and 2 that put the wrist centre at ``target`` (:func:`kinbox.search.closed_form._elbow_roots`;
    ``base``, ``f``, ``g`` of :func:`_fg`). Returns ``(m, undecided, r0, r1)``: the roots' ``(c2, s2, c3, s3)``."""
    # |b(theta_3)|^2 = |target|^2 as A c3 + B s3 = K (f, g constants)
    A = cconst(iscale(2.0, iadd(imul(f[0], g[0]), imul(f[1], g[1]))))
    B = cconst(iscale(2.0, isub(imul(f[1], g[0]), imul(f[0], g[1]))))
    fn = iadd(iadd(isqr(f[0]), isqr(f[1])), isqr(f[2]))
    gn = iadd(iadd(isqr(g[0]), isqr(g[1])), isqr(g[2]))
    k0 = iadd(iadd(fn, gn), iscale(2.0, imul(f[2], g[2])))
    K = csub(vnorm2(target, r), cconst(k0), r)
    z = cconst((0.0, 0.0))
    r0 = (z, z, z, z)
    r1 = (z, z, z, z)
    st3, c3a, s3a, c3b, s3b = sp_lin(A, B, K, r)
    if st3 < 0:
        return 0, True, r0, r1
    m = 0
    undecided = False
    base_c = (cconst(base[0]), cconst(base[1]), cconst(base[2]))
    g_c = (cconst(g[0]), cconst(g[1]), cconst(g[2]))
    for i3 in range(st3):
        c3, s3 = (c3a, s3a) if i3 == 0 else (c3b, s3b)
        b = vadd(base_c, fmv(LR[1], rz(c3, s3, g_c, r), r), r)
        ok, c2, s2 = sp_rot(b, target, r)
        if not ok:
            undecided = True
            continue
        if m == 0:
            r0 = (c2, s2, c3, s3)
        else:
            r1 = (c2, s2, c3, s3)
        m += 1
    return m, undecided, r0, r1


@nb.njit(cache=True)
def planar_centred(LR, Lt, d, R, t, r, out):
    """Every branch of the closed form of lines 2, 3, 4 parallel and lines 5, 6 meeting
    (:func:`kinbox.search.closed_form._planar`, code 3) decided over the box, in centred form:
    ``R`` the goal's rotation (rows of centred constants), ``t`` its translation (centred
    numbers of the position), ``r`` the box's half widths. Returns ``(n, undecided)``: the roots
    of the branches proven over the whole box written into ``out`` (each an enclosure over the
    box), and whether a branch was skipped."""
    # the same constants as _planar, in plain interval arithmetic (they do not move with the box)
    sigma = LR[1][2, 2] * LR[2][2, 2]
    nn = LR[0][:, 2]
    Rez = (R[0][2], R[1][2], R[2][2])
    hz = iadd(iadd(cst(d[1]), cst(Lt[1][2])), iscale(LR[1][2, 2], iadd(iadd(cst(d[2]), cst(Lt[2][2])), iscale(LR[2][2, 2], cst(d[3])))))
    Kc = iadd(hz, iscale(sigma, iadd(cst(Lt[3][2]), imul(cst(d[4]), cst(LR[3][2, 2])))))
    o5 = vsub(t, vscale(cconst(cst(d[5])), Rez, r), r)
    # joint 1: n . Rz(theta_1)^T o5 = K1 - ...: A c + B s + C
    A1 = cadd(cscale(nn[0], o5[0]), cscale(nn[1], o5[1]), r)
    B1 = csub(cscale(nn[0], o5[1]), cscale(nn[1], o5[0]), r)
    C1 = cscale(nn[2], o5[2])
    lt0 = Lt[0]
    k1 = iadd(Kc, iadd(iadd(imul(cst(LR[0][0, 2]), cst(lt0[0])), imul(cst(LR[0][1, 2]), cst(lt0[1]))), imul(cst(LR[0][2, 2]), cst(lt0[2]))))
    K1 = csub(cconst(k1), C1, r)
    st1, c1a, s1a, c1b, s1b = sp_lin(A1, B1, K1, r)
    if st1 < 0:
        return 0, True
    # joint 5: a . Rz(theta_5) h with a, h floats
    a5 = LR[3][2, :]
    h5 = LR[4][:, 2]
    A5 = cconst(iadd(imul(cst(a5[0]), cst(h5[0])), imul(cst(a5[1]), cst(h5[1]))))
    B5 = cconst(isub(imul(cst(a5[1]), cst(h5[0])), imul(cst(a5[0]), cst(h5[1]))))
    C5 = cconst(imul(cst(a5[2]), cst(h5[2])))
    base, f, g = _fg(LR, Lt, d)
    n = 0
    undecided = False
    lr0z = vconst(LR[0][:, 2])
    lr3 = vconst(LR[3][2, :])
    lt0v = vconst(Lt[0])
    for i1 in range(st1):
        c1, s1 = (c1a, s1a) if i1 == 0 else (c1b, s1b)
        zeta = fmtv(LR[0], rzt(c1, s1, Rez, r), r)
        st5, c5a, s5a, c5b, s5b = sp_lin(A5, B5, csub(cscale(sigma, zeta[2]), C5, r), r)
        if st5 < 0:
            undecided = True
            continue
        rho = imtv(R, rz(c1, s1, lr0z, r), r)
        for i5 in range(st5):
            c5, s5 = (c5a, s5a) if i5 == 0 else (c5b, s5b)
            kk = fmtv(LR[4], rzt(c5, s5, lr3, r), r)
            ok, cp, sp = sp_rot(kk, (cscale(sigma, rho[0]), cscale(sigma, rho[1]), cscale(sigma, rho[2])), r)
            if not ok:
                undecided = True
                continue
            c6, s6 = cp, cneg(sp)
            # the wrist centre and the goal's x axis in link 1's frame (_planar_target)
            ex = (cconst((1.0, 1.0)), cconst((0.0, 0.0)), cconst((0.0, 0.0)))
            v45 = vadd(vadd(vconst((0.0, 0.0, d[4])), vconst(Lt[4]), r), vscale(cconst(cst(d[5])), vconst(LR[4][:, 2]), r), r)
            t45 = vadd(vconst(Lt[3]), fmv(LR[3], rz(c5, s5, v45, r), r), r)
            R45t_t45 = rzt(c6, s6, fmtv(LR[4], rzt(c5, s5, fmtv(LR[3], t45, r), r), r), r)
            R45t_ex = rzt(c6, s6, fmtv(LR[4], rzt(c5, s5, fmtv(LR[3], ex, r), r), r), r)
            Xt = fmtv(LR[0], vsub(rzt(c1, s1, vsub(t, imv(R, R45t_t45, r), r), r), lt0v, r), r)
            Xex = fmtv(LR[0], rzt(c1, s1, imv(R, R45t_ex, r), r), r)
            m, und, r0, r1 = _elbow_roots(LR, base, f, g, Xt, r)
            undecided = undecided or und
            for i in range(m):
                c2, s2, c3, s3 = r0 if i == 0 else r1
                col = fmtv(LR[2], rzt(c3, s3, fmtv(LR[1], rzt(c2, s2, Xex, r), r), r), r)
                _put(out, n, 0, c1, s1)
                _put(out, n, 1, c2, s2)
                _put(out, n, 2, c3, s3)
                _put(out, n, 3, col[0], col[1])
                _put(out, n, 4, c5, s5)
                _put(out, n, 5, c6, s6)
                n += 1
    return n, undecided


@nb.njit(cache=True)
def _fg(LR, Lt, d):
    """``base``, ``f``, ``g`` of :func:`kinbox.search.closed_form._elbow` (constants of the arm), as intervals."""
    base = (cst(Lt[1][0]), cst(Lt[1][1]), iadd(cst(Lt[1][2]), cst(d[1])))
    M = LR[1]
    f = (
        iadd(iadd(iscale(M[0, 0], base[0]), iscale(M[1, 0], base[1])), iscale(M[2, 0], base[2])),
        iadd(iadd(iscale(M[0, 1], base[0]), iscale(M[1, 1], base[1])), iscale(M[2, 1], base[2])),
        iadd(iadd(iscale(M[0, 2], base[0]), iscale(M[1, 2], base[1])), iscale(M[2, 2], base[2])),
    )
    N = LR[2]
    g = (
        iadd(iadd(cst(Lt[2][0]), (0.0, 0.0)), imul(cst(d[3]), cst(N[0, 2]))),
        iadd(iadd(cst(Lt[2][1]), (0.0, 0.0)), imul(cst(d[3]), cst(N[1, 2]))),
        iadd(iadd(cst(Lt[2][2]), cst(d[2])), imul(cst(d[3]), cst(N[2, 2]))),
    )
    return base, f, g


@nb.njit(cache=True)
def _wrist(LR, R, Rez, c1, s1, c2, s2, c3, s3, r, out, n):
    """Joints 4-6 of a spherical wrist for one position root (:func:`kinbox.search.closed_form._wrist`):
    the roots written to ``out`` from ``n`` on. Returns ``(n, undecided)``."""
    a = LR[3][2, :]
    h = LR[4][:, 2]
    A5 = cconst(iadd(imul(cst(a[0]), cst(h[0])), imul(cst(a[1]), cst(h[1]))))
    B5 = cconst(isub(imul(cst(a[1]), cst(h[0])), imul(cst(a[0]), cst(h[1]))))
    C5 = cconst(imul(cst(a[2]), cst(h[2])))
    undecided = False
    Wez = fmtv(LR[2], rzt(c3, s3, fmtv(LR[1], rzt(c2, s2, fmtv(LR[0], rzt(c1, s1, Rez, r), r), r), r), r), r)
    z3 = rz(c1, s1, fmv(LR[0], rz(c2, s2, fmv(LR[1], rz(c3, s3, vconst(LR[2][:, 2]), r), r), r), r), r)
    WTez = imtv(R, z3, r)
    st5, c5a, s5a, c5b, s5b = sp_lin(A5, B5, csub(Wez[2], C5, r), r)
    if st5 < 0:
        return n, True
    for i5 in range(st5):
        c5, s5 = (c5a, s5a) if i5 == 0 else (c5b, s5b)
        m = fmv(LR[3], rz(c5, s5, vconst(LR[4][:, 2]), r), r)
        ok, c4, s4 = sp_rot(m, Wez, r)
        if not ok:
            undecided = True
            continue
        kk = fmtv(LR[4], rzt(c5, s5, vconst(LR[3][2, :]), r), r)
        ok, cp, sp = sp_rot(kk, WTez, r)
        if not ok:
            undecided = True
            continue
        _put(out, n, 0, c1, s1)
        _put(out, n, 1, c2, s2)
        _put(out, n, 2, c3, s3)
        _put(out, n, 3, c4, s4)
        _put(out, n, 4, c5, s5)
        _put(out, n, 5, cp, cneg(sp))
        n += 1
    return n, undecided


@nb.njit(cache=True)
def meet_centred(LR, Lt, d, R, t, r, out):
    """Lines 1 and 2 meeting and a spherical wrist (code 1; :func:`kinbox.search.closed_form._position_meet`,
    then :func:`_wrist`), in centred form: ``(n, undecided)`` as :func:`planar_centred`."""
    base, f, g = _fg(LR, Lt, d)
    A3 = cconst(iscale(2.0, iadd(imul(f[0], g[0]), imul(f[1], g[1]))))
    B3 = cconst(iscale(2.0, isub(imul(f[1], g[0]), imul(f[0], g[1]))))
    fn = iadd(iadd(isqr(f[0]), isqr(f[1])), isqr(f[2]))
    gn = iadd(iadd(isqr(g[0]), isqr(g[1])), isqr(g[2]))
    K3 = csub(vnorm2(t, r), cconst(iadd(iadd(fn, gn), iscale(2.0, imul(f[2], g[2])))), r)
    st3, c3a, s3a, c3b, s3b = sp_lin(A3, B3, K3, r)
    if st3 < 0:
        return 0, True
    Rez = (R[0][2], R[1][2], R[2][2])
    nz = LR[0][2, :]
    base_c = (cconst(base[0]), cconst(base[1]), cconst(base[2]))
    g_c = (cconst(g[0]), cconst(g[1]), cconst(g[2]))
    n = 0
    undecided = False
    for i3 in range(st3):
        c3, s3 = (c3a, s3a) if i3 == 0 else (c3b, s3b)
        b = vadd(base_c, fmv(LR[1], rz(c3, s3, g_c, r), r), r)
        A2 = cadd(cscale(nz[0], b[0]), cscale(nz[1], b[1]), r)
        B2 = csub(cscale(nz[1], b[0]), cscale(nz[0], b[1]), r)
        C2 = cscale(nz[2], b[2])
        st2, c2a, s2a, c2b, s2b = sp_lin(A2, B2, csub(t[2], C2, r), r)
        if st2 < 0:
            undecided = True
            continue
        for i2 in range(st2):
            c2, s2 = (c2a, s2a) if i2 == 0 else (c2b, s2b)
            u = fmv(LR[0], rz(c2, s2, b, r), r)
            ok, c1, s1 = sp_rot(u, t, r)
            if not ok:
                undecided = True
                continue
            n, und = _wrist(LR, R, Rez, c1, s1, c2, s2, c3, s3, r, out, n)
            undecided = undecided or und
    return n, undecided


@nb.njit(cache=True)
def parallel_centred(LR, Lt, d, R, t, r, out):
    """Lines 2 and 3 parallel and a spherical wrist (code 2; :func:`kinbox.search.closed_form._position_parallel`,
    then :func:`_wrist`), in centred form: ``(n, undecided)`` as :func:`planar_centred`."""
    base, f, g = _fg(LR, Lt, d)
    nn = LR[0][:, 2]
    bz = iadd(iadd(cst(d[1]), cst(Lt[1][2])), iscale(LR[1][2, 2], g[2]))
    A1 = cadd(cscale(nn[0], t[0]), cscale(nn[1], t[1]), r)
    B1 = csub(cscale(nn[0], t[1]), cscale(nn[1], t[0]), r)
    C1 = cscale(nn[2], t[2])
    lt0 = Lt[0]
    k1 = iadd(bz, iadd(iadd(imul(cst(LR[0][0, 2]), cst(lt0[0])), imul(cst(LR[0][1, 2]), cst(lt0[1]))), imul(cst(LR[0][2, 2]), cst(lt0[2]))))
    st1, c1a, s1a, c1b, s1b = sp_lin(A1, B1, csub(cconst(k1), C1, r), r)
    if st1 < 0:
        return 0, True
    Rez = (R[0][2], R[1][2], R[2][2])
    lt0v = vconst(Lt[0])
    n = 0
    undecided = False
    for i1 in range(st1):
        c1, s1 = (c1a, s1a) if i1 == 0 else (c1b, s1b)
        tr = fmtv(LR[0], vsub(rzt(c1, s1, t, r), lt0v, r), r)
        m, und, r0, r1 = _elbow_roots(LR, base, f, g, tr, r)
        undecided = undecided or und
        for i in range(m):
            c2, s2, c3, s3 = r0 if i == 0 else r1
            n, und = _wrist(LR, R, Rez, c1, s1, c2, s2, c3, s3, r, out, n)
            undecided = undecided or und
    return n, undecided


@nb.njit(cache=True)
def verdict_of(enc, n, undecided, limits):
    """A box's verdict from the ``n`` root enclosures ``enc[:n]`` a closed form proved over it
    (``n < 0``: no branch): 1 (inside) when a root is proven within the limits, 0 (outside) when
    no branch is undecided and every root is proven beyond a limit or there is none, else -1.
    Guarded by tests/workspace/test_centred.py's verdicts next to the border."""
    every_out = n >= 0 and not undecided
    for m in range(max(n, 0)):
        v = _in_limits(enc[m], limits)
        if v == 1:
            return 1
        if v != 0:
            every_out = False
    return 0 if every_out else -1


@nb.njit(cache=True)
def centred_verdicts(code, LR, Lt, d, limits, Rlo, Rhi, tlo, thi, J, r, todo, out):
    """The closed form over each box ``k`` with ``todo[k]`` in centred form: ``Rlo``/``Rhi``
    the goal's rotation (the same over the box), ``tlo``/``thi`` the canonical goal's
    translation at the box's centre, ``J`` (3 x 3 x 2, intervals) its derivative by the
    position, ``r[k]`` the box's half widths. ``out[k]``: 1 when a branch proven over the whole
    box has a root proven within the limits (inside), 0 when every branch is decided and each
    root is proven beyond a limit or there is none (outside), else left as it is."""
    enc = np.zeros((MAX_ROOTS, 6, 4))
    for k in range(out.shape[0]):
        if not todo[k] or code < 1 or code > 3:
            continue
        rk = (r[k, 0], r[k, 1], r[k, 2])
        R = (
            (cconst((Rlo[k, 0, 0], Rhi[k, 0, 0])), cconst((Rlo[k, 0, 1], Rhi[k, 0, 1])), cconst((Rlo[k, 0, 2], Rhi[k, 0, 2]))),
            (cconst((Rlo[k, 1, 0], Rhi[k, 1, 0])), cconst((Rlo[k, 1, 1], Rhi[k, 1, 1])), cconst((Rlo[k, 1, 2], Rhi[k, 1, 2]))),
            (cconst((Rlo[k, 2, 0], Rhi[k, 2, 0])), cconst((Rlo[k, 2, 1], Rhi[k, 2, 1])), cconst((Rlo[k, 2, 2], Rhi[k, 2, 2]))),
        )
        ts = []
        for i in range(3):
            c = (tlo[k, i], thi[k, i])
            v = c
            for j in range(3):
                v = iadd(v, imul((J[i, j, 0], J[i, j, 1]), (-rk[j], rk[j])))
            ts.append((c, v, (J[i, 0, 0], J[i, 0, 1]), (J[i, 1, 0], J[i, 1, 1]), (J[i, 2, 0], J[i, 2, 1])))
        t = (ts[0], ts[1], ts[2])
        if code == 3:
            n, undecided = planar_centred(LR, Lt, d, R, t, rk, enc)
        elif code == 2:
            n, undecided = parallel_centred(LR, Lt, d, R, t, rk, enc)
        else:
            n, undecided = meet_centred(LR, Lt, d, R, t, rk, enc)
        verdict = verdict_of(enc, n, undecided, limits)
        if verdict >= 0:
            out[k] = verdict


@nb.njit(cache=True)
def box_translation(tlo, thi, absJ, r, k, lo, hi):
    """Into ``lo``, ``hi``: box ``k``'s canonical goal translation ``[tlo, thi] +- |J| r_k``, the
    move of the goal over the box, its radius rounded outward (``tests/workspace/test_centred.py``
    checks the verdicts built on it at sampled positions)."""
    for i in range(3):
        rad = 0.0
        for j in range(3):
            rad += absJ[i, j] * r[k, j]
        rad = rad * (1.0 + 1e-12) + 1e-300
        lo[i] = tlo[k, i] - rad
        hi[i] = thi[k, i] + rad


@nb.njit(cache=True)
def relaxed_outside(code, LR, Lt, d, limits, Rlo, Rhi, tlo, thi, absJ, r, out):
    """Boxes ``k`` with ``out[k] < 0`` proven outside by the relaxed closed form
    (:func:`kinbox.search.closed_form.solve_branches` with ``relax``): a discriminant that
    holds zero over the box gives both of its roots' enclosures (each root there or absent) and
    the branch goes on; when no branch is left undecided and each enclosure is proven beyond a
    joint limit, or there is none, no position of the box is reached (``out[k] = 0``). Where two
    borders of the workspace meet (a branch's first discriminant changes sign across the box and
    a later one is negative wherever the first is not) this proves what no branch proven over the
    whole box can. The goal's translation over the box as in :func:`kinbox.workspace.arm._verdicts`."""
    enc = np.zeros((MAX_ROOTS, 6, 4))
    scratch = np.zeros((4, 3, 4))
    lo = np.empty(3)
    hi = np.empty(3)
    for k in range(out.shape[0]):
        if out[k] >= 0:
            continue
        box_translation(tlo, thi, absJ, r, k, lo, hi)
        scratch[:] = 0.0
        n, undecided = solve_branches(code, LR, Lt, d, Rlo[k], Rhi[k], lo, hi, enc, scratch, False, True)
        if n == -1 or undecided:
            continue
        count = n if n >= 0 else -2 - n
        every_out = True
        for m in range(count):
            if _in_limits(enc[m], limits) != 0:
                every_out = False
                break
        if every_out:
            out[k] = 0


__all__ = ["CENTRED_FAMILIES", "centred_verdicts", "relaxed_outside", "meet_centred", "parallel_centred", "planar_centred"]
