"""Closed-form inverse kinematics in interval arithmetic (families of :mod:`kinbox.formulation.families`).

Each family is a sequence of two subproblems, both on a joint's ``(c, s) = (cos, sin)``:

* ``SP_lin``: ``A c + B s = K`` on the unit circle (Paden-Kahan subproblem 3/4 reduced to one
  equation): with ``r2 = A^2 + B^2`` and ``D = r2 - K^2``, ``(c, s) = ((A K -+ B sqrt D) / r2,
  (B K +- A sqrt D) / r2)``: two roots when ``D > 0``, none when ``D < 0``;
* ``SP_rot``: the rotation about ``z`` taking the ``xy`` part of ``u`` to that of ``v`` (Paden-Kahan
  subproblem 1): ``(c, s) = (u.v, u x v) / |u_xy|^2``, one root when ``|u_xy| > 0``.

Everything is evaluated in interval arithmetic with outward rounding (every operation's result
moved outward by more than an ulp: :func:`_dn`, :func:`_up`), on the goal's numbers as intervals
(``err_r``, ``err_t``: bounds on the rounding of the goal frame). Where every ``r2``, every
``|u_xy|^2`` is proven positive and every ``D`` proven positive or negative, the number of roots
is proven (each branch is a distinct root: ``sqrt D > 0`` separates the two of a ``SP_lin``) and
each root's ``(c, s)`` lies in its enclosure; otherwise the pose is *undecided* (-1) and is
solved by the branch and prune. The algebra of the families is in
``docs/closed-form.md``; ``tests/search/test_closed_form.py`` checks the roots against the branch and
prune's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import jit as nb
from .certify import _K_UNIQUE, _krawczyk_full
from .cf_delta import NONE as NO_DELTA
from .cf_delta import NOT_PROVEN, Delta, delta_of, kernel_links, orthogonal_radii
from .template_rows import bind_rows, boxes_apart, core_row

#: the most roots a family has (two per SP_lin level, three levels)
MAX_ROOTS = 8
_E51 = 2.0**-51  # |x| * 2^-51 is at least two ulps of x: x -+ that is strictly beyond x's rounding
_ETA = 1e-300  # covers underflow


@nb.njit(cache=True)
def _dn(x):
    return x - (abs(x) * _E51 + _ETA)


@nb.njit(cache=True)
def _up(x):
    return x + (abs(x) * _E51 + _ETA)


@nb.njit(cache=True)
def cst(x):
    return (x, x)


@nb.njit(cache=True)
def iadd(a, b):
    if b[0] == 0.0 and b[1] == 0.0:  # exact (link matrices are mostly zeros and units)
        return a
    if a[0] == 0.0 and a[1] == 0.0:
        return b
    return (_dn(a[0] + b[0]), _up(a[1] + b[1]))


@nb.njit(cache=True)
def isub(a, b):
    return (_dn(a[0] - b[1]), _up(a[1] - b[0]))


@nb.njit(cache=True)
def ineg(a):
    return (-a[1], -a[0])


@nb.njit(cache=True)
def imul(a, b):
    p1 = a[0] * b[0]
    p2 = a[0] * b[1]
    p3 = a[1] * b[0]
    p4 = a[1] * b[1]
    return (_dn(min(min(p1, p2), min(p3, p4))), _up(max(max(p1, p2), max(p3, p4))))


@nb.njit(cache=True)
def iscale(k, a):
    if k == 0.0:
        return (0.0, 0.0)
    if k == 1.0:  # exact
        return a
    if k == -1.0:
        return (-a[1], -a[0])
    if k > 0.0:
        return (_dn(k * a[0]), _up(k * a[1]))
    return (_dn(k * a[1]), _up(k * a[0]))


@nb.njit(cache=True)
def isqr(a):
    if a[0] >= 0.0:
        return (_dn(a[0] * a[0]), _up(a[1] * a[1]))
    if a[1] <= 0.0:
        return (_dn(a[1] * a[1]), _up(a[0] * a[0]))
    return (0.0, _up(max(a[0] * a[0], a[1] * a[1])))


@nb.njit(cache=True)
def isqrt(a):  # for a[0] > 0 (checked by the callers)
    return (_dn(math.sqrt(a[0])), _up(math.sqrt(a[1])))


@nb.njit(cache=True)
def idiv(a, b):  # for b not holding 0 (checked by the callers)
    p1 = a[0] / b[0]
    p2 = a[0] / b[1]
    p3 = a[1] / b[0]
    p4 = a[1] / b[1]
    return (_dn(min(min(p1, p2), min(p3, p4))), _up(max(max(p1, p2), max(p3, p4))))


# -- vectors: tuples of three intervals --------------------------------------------------------
@nb.njit(cache=True)
def cvec(a):
    return ((a[0], a[0]), (a[1], a[1]), (a[2], a[2]))


@nb.njit(cache=True)
def vadd(u, v):
    return (iadd(u[0], v[0]), iadd(u[1], v[1]), iadd(u[2], v[2]))


@nb.njit(cache=True)
def vsub(u, v):
    return (isub(u[0], v[0]), isub(u[1], v[1]), isub(u[2], v[2]))


@nb.njit(cache=True)
def vscale(k, u):  # an interval k
    return (imul(k, u[0]), imul(k, u[1]), imul(k, u[2]))


@nb.njit(cache=True)
def vdot(u, v):
    return iadd(iadd(imul(u[0], v[0]), imul(u[1], v[1])), imul(u[2], v[2]))


@nb.njit(cache=True)
def vnorm2(u):
    return iadd(iadd(isqr(u[0]), isqr(u[1])), isqr(u[2]))


# -- link rotations: a binary64 matrix (3, 3) or an enclosure (3, 3, 2) ------------------------
def lent(M, i, j):
    """Entry ``(i, j)`` of a link rotation: a float of a binary64 matrix ``(3, 3)``, an interval
    ``(lo, hi)`` of an enclosure ``(3, 3, 2)`` (:func:`kinbox.search.cf_delta.kernel_links`).
    Compiled code only (:func:`_lent`): a kernel is compiled once per kind, the binary64 one
    exactly as it was before enclosures (the same operations)."""
    raise NotImplementedError("lent is called from compiled code only")


@nb.overload(lent)
def _lent(M, i, j):
    if M.ndim == 2:

        def scalar(M, i, j):
            return M[i, j]

        return scalar

    def interval(M, i, j):
        return (M[i, j, 0], M[i, j, 1])

    return interval


def lsc(k, a):
    """``k a`` for an interval ``a`` and ``k`` a float (:func:`iscale`) or an interval (a point
    interval by :func:`iscale`, exact for 0 and +-1; else :func:`imul`). Compiled code only."""
    raise NotImplementedError("lsc is called from compiled code only")


@nb.overload(lsc)
def _lsc(k, a):
    from numba import types

    if isinstance(k, types.Float):

        def scalar(k, a):
            return iscale(k, a)

        return scalar

    def interval(k, a):
        if k[0] == k[1]:
            return iscale(k[0], a)
        return imul(k, a)

    return interval


def ival(x):
    """A float ``x`` as the interval ``(x, x)``, an interval as itself. Compiled code only."""
    raise NotImplementedError("ival is called from compiled code only")


@nb.overload(ival)
def _ival(x):
    from numba import types

    if isinstance(x, types.Float):

        def scalar(x):
            return (x, x)

        return scalar

    def interval(x):
        return x

    return interval


def lexact(x):
    """An entry the family's structure fixes exactly (the ``+-1`` of a link between parallel
    lines), as a float: of an enclosure, its lower end, the enclosure being a point there
    (:func:`kinbox.search.cf_delta.kernel_links` keeps such entries exact;
    tests/search/test_cf_twist.py::test_kernel_links_keep_the_structure_exact). Compiled code only."""
    raise NotImplementedError("lexact is called from compiled code only")


@nb.overload(lexact)
def _lexact(x):
    from numba import types

    if isinstance(x, types.Float):

        def scalar(x):
            return x

        return scalar

    def interval(x):
        return x[0]

    return interval


@nb.njit(cache=True, inline="always")  # literal indices: inlined, not compiled once per literal
def lrowv(M, k):
    """Row ``k`` of a link rotation: a tuple of its entries (:func:`lent`)."""
    return (lent(M, k, 0), lent(M, k, 1), lent(M, k, 2))


@nb.njit(cache=True, inline="always")  # literal indices: inlined, not compiled once per literal
def lcolv(M, k):
    """Column ``k`` of a link rotation: a tuple of its entries (:func:`lent`)."""
    return (lent(M, 0, k), lent(M, 1, k), lent(M, 2, k))


@nb.njit(cache=True)
def fmv(M, v):
    """``M v`` for a link rotation ``M`` (binary64 or enclosed: :func:`lent`)."""
    return (
        iadd(iadd(lsc(lent(M, 0, 0), v[0]), lsc(lent(M, 0, 1), v[1])), lsc(lent(M, 0, 2), v[2])),
        iadd(iadd(lsc(lent(M, 1, 0), v[0]), lsc(lent(M, 1, 1), v[1])), lsc(lent(M, 1, 2), v[2])),
        iadd(iadd(lsc(lent(M, 2, 0), v[0]), lsc(lent(M, 2, 1), v[1])), lsc(lent(M, 2, 2), v[2])),
    )


@nb.njit(cache=True)
def fmtv(M, v):
    """``M^T v`` for a link rotation ``M`` (binary64 or enclosed: :func:`lent`)."""
    return (
        iadd(iadd(lsc(lent(M, 0, 0), v[0]), lsc(lent(M, 1, 0), v[1])), lsc(lent(M, 2, 0), v[2])),
        iadd(iadd(lsc(lent(M, 0, 1), v[0]), lsc(lent(M, 1, 1), v[1])), lsc(lent(M, 2, 1), v[2])),
        iadd(iadd(lsc(lent(M, 0, 2), v[0]), lsc(lent(M, 1, 2), v[1])), lsc(lent(M, 2, 2), v[2])),
    )


@nb.njit(cache=True)
def imv(R, v):
    """``R v`` for an interval matrix given by its rows."""
    return (vdot(R[0], v), vdot(R[1], v), vdot(R[2], v))


@nb.njit(cache=True)
def imtv(R, v):
    """``R^T v`` for an interval matrix given by its rows."""
    return vadd(vadd(vscale(v[0], R[0]), vscale(v[1], R[1])), vscale(v[2], R[2]))


@nb.njit(cache=True)
def rz(c, s, v):
    """``Rz(theta) v``."""
    return (isub(imul(c, v[0]), imul(s, v[1])), iadd(imul(s, v[0]), imul(c, v[1])), v[2])


@nb.njit(cache=True)
def rzt(c, s, v):
    """``Rz(theta)^T v``."""
    return (iadd(imul(c, v[0]), imul(s, v[1])), isub(imul(c, v[1]), imul(s, v[0])), v[2])


# -- subproblems -------------------------------------------------------------------------------
@nb.njit(cache=True)
def sp_lin(A, B, K, relax=False):
    """``A c + B s = K``, ``c^2 + s^2 = 1``: (status, c+, s+, c-, s-) with status 2 (two
    roots), 0 (none, proven) or -1 (undecided: ``r2`` or ``D`` not proven away from zero).
    ``relax``: where ``D`` holds zero (and ``r2`` is proven positive), status 3: none or two
    roots, each inside its enclosure (``sqrt D`` enclosed by ``[0, sqrt D_hi]``: the two
    enclosures overlap; a fold of a sweep, :mod:`kinbox.search.sweep`)."""
    r2 = iadd(isqr(A), isqr(B))
    z = (0.0, 0.0)
    D = isub(r2, isqr(K))
    if D[1] < 0.0:  # |A c + B s| <= sqrt(r2) < |K|: no root, whether r2 is away from zero or not
        return 0, z, z, z, z
    if not r2[0] > 0.0:
        return -1, z, z, z, z
    status = 2
    if not D[0] > 0.0:
        if not relax:
            return -1, z, z, z, z
        status = 3
        D = (0.0, D[1])
    q = (0.0, _up(math.sqrt(D[1]))) if status == 3 else isqrt(D)
    AK = imul(A, K)
    BK = imul(B, K)
    Bq = imul(B, q)
    Aq = imul(A, q)
    c1 = idiv(isub(AK, Bq), r2)
    s1 = idiv(iadd(BK, Aq), r2)
    c2 = idiv(iadd(AK, Bq), r2)
    s2 = idiv(isub(BK, Aq), r2)
    return status, c1, s1, c2, s2


@nb.njit(cache=True)
def sp_rot(u, v):
    """The rotation about ``z`` taking ``u``'s ``xy`` part to ``v``'s (their lengths equal at the
    exact numbers): (ok, c, s); not ok where ``|u_xy|^2`` is not proven positive."""
    n2 = iadd(isqr(u[0]), isqr(u[1]))
    z = (0.0, 0.0)
    if not n2[0] > 0.0:
        return False, z, z
    c = idiv(iadd(imul(u[0], v[0]), imul(u[1], v[1])), n2)
    s = idiv(isub(imul(u[0], v[1]), imul(u[1], v[0])), n2)
    return True, c, s


@nb.njit(cache=True)
def _lin_about(a, h):
    """``a . Rz(theta) h = A c + B s + C`` for vectors ``a``, ``h`` of floats or intervals: (A, B, C)."""
    A = iadd(imul(ival(a[0]), ival(h[0])), imul(ival(a[1]), ival(h[1])))
    B = isub(imul(ival(a[1]), ival(h[0])), imul(ival(a[0]), ival(h[1])))
    C = imul(ival(a[2]), ival(h[2]))
    return A, B, C


@nb.njit(cache=True)
def _lin_about_i(a, h):
    """``a . Rz(theta) h`` for interval vector ``h`` and ``a`` of floats or intervals (:func:`lsc`): (A, B, C)."""
    A = iadd(lsc(a[0], h[0]), lsc(a[1], h[1]))
    B = isub(lsc(a[1], h[0]), lsc(a[0], h[1]))
    C = lsc(a[2], h[2])
    return A, B, C


@nb.njit(cache=True)
def _rotated_by(n, w):
    """``n . Rz(theta)^T w = A c + B s + C`` for ``n`` of floats or intervals (:func:`lsc`) and interval ``w``: (A, B, C)."""
    A = iadd(lsc(n[0], w[0]), lsc(n[1], w[1]))
    B = isub(lsc(n[0], w[1]), lsc(n[1], w[0]))
    C = lsc(n[2], w[2])
    return A, B, C


@nb.njit(cache=True, inline="always")  # literal indices: inlined, not compiled once per literal
def _put(out, k, j, c, s):
    out[k, j, 0] = c[0]
    out[k, j, 1] = c[1]
    out[k, j, 2] = s[0]
    out[k, j, 3] = s[1]


@nb.njit(cache=True, inline="always")  # literal indices: inlined, not compiled once per literal
def mcol(M, k):
    """Column ``k`` of a float matrix or a link rotation (:func:`lent`) as an interval vector."""
    return (ival(lent(M, 0, k)), ival(lent(M, 1, k)), ival(lent(M, 2, k)))


@nb.njit(cache=True, inline="always")  # literal indices: inlined, not compiled once per literal
def mrow(M, k):
    """Row ``k`` of a float matrix or a link rotation (:func:`lent`) as an interval vector."""
    return (ival(lent(M, k, 0)), ival(lent(M, k, 1)), ival(lent(M, k, 2)))


@nb.njit(cache=True)
def ez_times(k):
    """``k e_z`` for an interval ``k``."""
    return ((0.0, 0.0), (0.0, 0.0), k)


@nb.njit(cache=True)
def _elbow(LR, Lt, d):
    """``f``, ``g`` of ``b(theta_3) = d2 e_z + L2.t + L2.R Rz(theta_3) g`` and ``f = L2.R^T
    (d2 e_z + L2.t)``, so that ``|b|^2 = |f|^2 + |g|^2 + 2 f . Rz(theta_3) g``."""
    base = vadd(mrow(Lt, 1), ez_times(cst(d[1])))
    f = fmtv(LR[1], base)
    g = vadd(vadd(mrow(Lt, 2), ez_times(cst(d[2]))), vscale(cst(d[3]), mcol(LR[2], 2)))
    return base, f, g


@nb.njit(cache=True)
def _b_of(LR, base, g, c3, s3):
    return vadd(base, fmv(LR[1], rz(c3, s3, g)))


@nb.njit(cache=True)
def _elbow_lin(f, g, target2):
    """``|b(theta_3)|^2 = target2`` as ``A c3 + B s3 = K``."""
    A = iscale(2.0, iadd(imul(f[0], g[0]), imul(f[1], g[1])))
    B = iscale(2.0, isub(imul(f[1], g[0]), imul(f[0], g[1])))
    K = isub(isub(isub(target2, vnorm2(f)), vnorm2(g)), iscale(2.0, imul(f[2], g[2])))
    return A, B, K


@nb.njit(cache=True, inline="always")
def _goal(Rlo, Rhi, tlo, thi):
    """The goal's rotation (rows) and translation as intervals."""
    R = (
        ((Rlo[0, 0], Rhi[0, 0]), (Rlo[0, 1], Rhi[0, 1]), (Rlo[0, 2], Rhi[0, 2])),
        ((Rlo[1, 0], Rhi[1, 0]), (Rlo[1, 1], Rhi[1, 1]), (Rlo[1, 2], Rhi[1, 2])),
        ((Rlo[2, 0], Rhi[2, 0]), (Rlo[2, 1], Rhi[2, 1]), (Rlo[2, 2], Rhi[2, 2])),
    )
    t = ((tlo[0], thi[0]), (tlo[1], thi[1]), (tlo[2], thi[2]))
    return R, t


# Each step below returns ``(n, undecided, loose)``: the roots it wrote, whether a branch was
# skipped (``partial``), whether a relaxed enclosure was used (``relax``); ``n = -1`` where a
# branch is not decided and ``partial`` is False (the whole goal is then undecided).
@nb.njit(cache=True)
def _elbow_roots(LR, base, f, g, target, partial, relax):
    """Joints 3 and 2 that put the wrist centre at ``target`` (in link 1's frame, after joint
    1): ``|b(theta_3)| = |target|`` (SP_lin), then ``b`` turned onto ``target`` (SP_rot). Returns
    ``(n, undecided, loose, r0, r1)`` with the roots' ``(c2, s2, c3, s3)`` in ``r0``, ``r1``."""
    z = (0.0, 0.0)
    r0 = (z, z, z, z)
    r1 = (z, z, z, z)
    A3, B3, K3 = _elbow_lin(f, g, vnorm2(target))
    st3, c3a, s3a, c3b, s3b = sp_lin(A3, B3, K3, relax)
    loose = st3 == 3
    if st3 < 0:
        return (0 if partial else -1), True, loose, r0, r1
    n = 0
    undecided = False
    for i3 in range(min(st3, 2)):
        c3, s3 = (c3a, s3a) if i3 == 0 else (c3b, s3b)
        b = _b_of(LR, base, g, c3, s3)
        ok, c2, s2 = sp_rot(b, target)
        if not ok:
            if not partial:
                return -1, True, loose, r0, r1
            undecided = True
            continue
        if n == 0:
            r0 = (c2, s2, c3, s3)
        else:
            r1 = (c2, s2, c3, s3)
        n += 1
    return n, undecided, loose, r0, r1


@nb.njit(cache=True)
def _position_meet(LR, base, f, g, t, roots_pos, partial, relax):
    """Joints 1-3 of a wrist whose lines 1 and 2 meet (code 1): ``|w|`` decides joint 3, the
    height joint 2, then joint 1 turns onto the wrist centre; roots into ``roots_pos``."""
    A3, B3, K3 = _elbow_lin(f, g, vnorm2(t))
    st3, c3a, s3a, c3b, s3b = sp_lin(A3, B3, K3, relax)
    loose = st3 == 3
    if st3 < 0:
        return (0 if partial else -1), True, loose
    nz = lrowv(LR[0], 2)  # L1.R^T e_z
    npos = 0
    undecided = False
    for i3 in range(min(st3, 2)):
        c3, s3 = (c3a, s3a) if i3 == 0 else (c3b, s3b)
        b = _b_of(LR, base, g, c3, s3)
        A2, B2, C2 = _lin_about_i(nz, b)
        st2, c2a, s2a, c2b, s2b = sp_lin(A2, B2, isub(t[2], C2), relax)
        loose = loose or st2 == 3
        if st2 < 0:
            if not partial:
                return -1, True, loose
            undecided = True
            continue
        for i2 in range(min(st2, 2)):
            c2, s2 = (c2a, s2a) if i2 == 0 else (c2b, s2b)
            u = fmv(LR[0], rz(c2, s2, b))
            ok, c1, s1 = sp_rot(u, t)
            if not ok:
                if not partial:
                    return -1, True, loose
                undecided = True
                continue
            _put(roots_pos, npos, 0, c1, s1)
            _put(roots_pos, npos, 1, c2, s2)
            _put(roots_pos, npos, 2, c3, s3)
            npos += 1
    return npos, undecided, loose


@nb.njit(cache=True)
def _position_parallel(LR, Lt, d, base, f, g, t, roots_pos, partial, relax):
    """Joints 1-3 of a wrist whose lines 2 and 3 are parallel (code 2): the offset along line
    2 decides joint 1, then :func:`_elbow_roots`; roots into ``roots_pos``."""
    nn = lcolv(LR[0], 2)  # line 2 in link 1's frame
    bz = iadd(iadd(cst(d[1]), cst(Lt[1][2])), lsc(lent(LR[1], 2, 2), g[2]))
    A1, B1, C1 = _rotated_by(nn, t)
    K1 = isub(iadd(bz, vdot(mcol(LR[0], 2), mrow(Lt, 0))), C1)
    st1, c1a, s1a, c1b, s1b = sp_lin(A1, B1, K1, relax)
    loose = st1 == 3
    if st1 < 0:
        return (0 if partial else -1), True, loose
    npos = 0
    undecided = False
    for i1 in range(min(st1, 2)):
        c1, s1 = (c1a, s1a) if i1 == 0 else (c1b, s1b)
        r = fmtv(LR[0], vsub(rzt(c1, s1, t), mrow(Lt, 0)))
        m, und, lz, r0, r1 = _elbow_roots(LR, base, f, g, r, partial, relax)
        loose = loose or lz
        if m < 0:
            return -1, True, loose
        undecided = undecided or und
        for i in range(m):
            c2, s2, c3, s3 = r0 if i == 0 else r1
            _put(roots_pos, npos, 0, c1, s1)
            _put(roots_pos, npos, 1, c2, s2)
            _put(roots_pos, npos, 2, c3, s3)
            npos += 1
    return npos, undecided, loose


@nb.njit(cache=True)
def _wrist(LR, R, Rez, roots_pos, npos, out, partial, relax):
    """Joints 4-6 of a spherical wrist for each of the ``npos`` positions in ``roots_pos``:
    ``W = R3^T R = Rz(theta_4) L4.R Rz(theta_5) L5.R Rz(theta_6)``; roots into ``out``."""
    a = lrowv(LR[3], 2)  # L4.R^T e_z
    h = lcolv(LR[4], 2)  # L5.R e_z
    A5, B5, C5 = _lin_about(a, h)
    n = 0
    undecided = False
    loose = False
    for k in range(npos):
        c1 = (roots_pos[k, 0, 0], roots_pos[k, 0, 1])
        s1 = (roots_pos[k, 0, 2], roots_pos[k, 0, 3])
        c2 = (roots_pos[k, 1, 0], roots_pos[k, 1, 1])
        s2 = (roots_pos[k, 1, 2], roots_pos[k, 1, 3])
        c3 = (roots_pos[k, 2, 0], roots_pos[k, 2, 1])
        s3 = (roots_pos[k, 2, 2], roots_pos[k, 2, 3])
        # W e_z = R3^T R e_z, W^T e_z = R^T R3 e_z
        Wez = fmtv(LR[2], rzt(c3, s3, fmtv(LR[1], rzt(c2, s2, fmtv(LR[0], rzt(c1, s1, Rez))))))
        z3 = rz(c1, s1, fmv(LR[0], rz(c2, s2, fmv(LR[1], rz(c3, s3, mcol(LR[2], 2))))))
        WTez = imtv(R, z3)
        st5, c5a, s5a, c5b, s5b = sp_lin(A5, B5, isub(Wez[2], C5), relax)
        loose = loose or st5 == 3
        if st5 < 0:
            if not partial:
                return -1, True, loose
            undecided = True
            continue
        for i5 in range(min(st5, 2)):
            c5, s5 = (c5a, s5a) if i5 == 0 else (c5b, s5b)
            m = fmv(LR[3], rz(c5, s5, mcol(LR[4], 2)))
            ok, c4, s4 = sp_rot(m, Wez)
            if not ok and relax:  # a wrist singularity: joints 4 and 6 anywhere on their circles
                ok, loose = True, True
                c4, s4 = (-1.0, 1.0), (-1.0, 1.0)
            if not ok:
                if not partial:
                    return -1, True, loose
                undecided = True
                continue
            kk = fmtv(LR[4], rzt(c5, s5, mrow(LR[3], 2)))
            ok, cp, sp = sp_rot(kk, WTez)
            if not ok and relax:  # a wrist singularity: joints 4 and 6 anywhere on their circles
                ok, loose = True, True
                cp, sp = (-1.0, 1.0), (-1.0, 1.0)
            if not ok:
                if not partial:
                    return -1, True, loose
                undecided = True
                continue
            for j in range(3):
                for e in range(4):
                    out[n, j, e] = roots_pos[k, j, e]
            _put(out, n, 3, c4, s4)
            _put(out, n, 4, c5, s5)
            _put(out, n, 5, cp, ineg(sp))
            n += 1
    return n, undecided, loose


@nb.njit(cache=True)
def _planar_target(LR, Lt, d, R, t, c1, s1, c5, s5, c6, s6):
    """Lines 2, 3, 4 parallel (code 3), joints 1, 5, 6 given: the wrist centre ``Xt`` in link
    1's frame (after joint 1) and the image ``Xex`` of the goal's ``x`` axis there."""
    ex = ((1.0, 1.0), (0.0, 0.0), (0.0, 0.0))
    # T45 = L4 Rz5 Tz(d5) L5 Rz6 Tz(d6): R45^T v and t45
    t45 = vadd(
        mrow(Lt, 3),
        fmv(LR[3], rz(c5, s5, vadd(vadd(ez_times(cst(d[4])), mrow(Lt, 4)), vscale(cst(d[5]), mcol(LR[4], 2))))),
    )
    R45t_t45 = rzt(c6, s6, fmtv(LR[4], rzt(c5, s5, fmtv(LR[3], t45))))
    R45t_ex = rzt(c6, s6, fmtv(LR[4], rzt(c5, s5, fmtv(LR[3], ex))))
    Xt = fmtv(LR[0], vsub(rzt(c1, s1, vsub(t, imv(R, R45t_t45))), mrow(Lt, 0)))
    Xex = fmtv(LR[0], rzt(c1, s1, imv(R, R45t_ex)))
    return Xt, Xex


@nb.njit(cache=True)
def _planar(LR, Lt, d, R, t, Rez, base, f, g, out, roots_pos, partial, relax):
    """Lines 2, 3, 4 parallel, lines 5 and 6 meet (code 3): the offset along line 2 decides
    joint 1, the axis of lines 2-4 joint 5, then joint 6, and :func:`_elbow_roots` joints 3 and
    2; joint 4 closes the plane's angle. Roots into ``out``."""
    z2, z3 = lexact(lent(LR[1], 2, 2)), lexact(lent(LR[2], 2, 2))  # +-1: lines 2, 3, 4 parallel
    sigma = z2 * z3
    nn = lcolv(LR[0], 2)  # line 2 in link 1's frame
    o5 = vsub(t, vscale(cst(d[5]), Rez))
    hz = iadd(iadd(cst(d[1]), cst(Lt[1][2])), iscale(z2, iadd(iadd(cst(d[2]), cst(Lt[2][2])), iscale(z3, cst(d[3])))))
    Kc = iadd(hz, iscale(sigma, iadd(cst(Lt[3][2]), imul(cst(d[4]), ival(lent(LR[3], 2, 2))))))
    A1, B1, C1 = _rotated_by(nn, o5)
    K1 = isub(iadd(Kc, vdot(mcol(LR[0], 2), mrow(Lt, 0))), C1)
    st1, c1a, s1a, c1b, s1b = sp_lin(A1, B1, K1, relax)
    loose = st1 == 3
    if st1 < 0:
        return (0 if partial else -1), True, loose
    A5, B5, C5 = _lin_about(lrowv(LR[3], 2), lcolv(LR[4], 2))
    n = 0
    undecided = False
    for i1 in range(min(st1, 2)):
        c1, s1 = (c1a, s1a) if i1 == 0 else (c1b, s1b)
        zeta = fmtv(LR[0], rzt(c1, s1, Rez))
        st5, c5a, s5a, c5b, s5b = sp_lin(A5, B5, isub(iscale(sigma, zeta[2]), C5), relax)
        loose = loose or st5 == 3
        if st5 < 0:
            if not partial:
                return -1, True, loose
            undecided = True
            continue
        rho = imtv(R, rz(c1, s1, mcol(LR[0], 2)))
        for i5 in range(min(st5, 2)):
            c5, s5 = (c5a, s5a) if i5 == 0 else (c5b, s5b)
            kk = fmtv(LR[4], rzt(c5, s5, mrow(LR[3], 2)))
            ok, cp, sp = sp_rot(kk, (iscale(sigma, rho[0]), iscale(sigma, rho[1]), iscale(sigma, rho[2])))
            if not ok:
                if not partial:
                    return -1, True, loose
                undecided = True
                continue
            c6, s6 = cp, ineg(sp)
            Xt, Xex = _planar_target(LR, Lt, d, R, t, c1, s1, c5, s5, c6, s6)
            m, und, lz, r0, r1 = _elbow_roots(LR, base, f, g, Xt, partial, relax)
            loose = loose or lz
            if m < 0:
                return -1, True, loose
            undecided = undecided or und
            for i in range(m):
                c2, s2, c3, s3 = r0 if i == 0 else r1
                col = fmtv(LR[2], rzt(c3, s3, fmtv(LR[1], rzt(c2, s2, Xex))))
                _put(out, n, 0, c1, s1)
                _put(out, n, 1, c2, s2)
                _put(out, n, 2, c3, s3)
                _put(out, n, 3, col[0], col[1])
                _put(out, n, 4, c5, s5)
                _put(out, n, 5, c6, s6)
                n += 1
    return n, undecided, loose


def family_tag(code: int) -> tuple:
    """A value whose numba type names the family ``code`` (a tuple of ``code`` zeros). A kernel
    given it in place of the integer code is compiled with that family's steps only
    (:func:`family_roots`): an arm's first answer does not compile the other families'."""
    return (0,) * code


def family_roots(family, LR, Lt, d, R, t, Rez, base, f, g, out, roots_pos, partial, relax):
    """Every root of the goal ``(R, t)`` by the steps of ``family`` (the integer code, or its
    :func:`family_tag`), into ``out``: ``(n, undecided, loose)`` as the steps return them.
    Compiled code only (:func:`_family_roots`)."""
    raise NotImplementedError("family_roots is called from compiled code only")


@nb.njit(cache=True, inline="always")
def _spherical_meet(LR, Lt, d, R, t, Rez, base, f, g, out, roots_pos, partial, relax):
    npos, undecided, loose = _position_meet(LR, base, f, g, t, roots_pos, partial, relax)
    if npos < 0:
        return -1, True, loose
    n, und, lz = _wrist(LR, R, Rez, roots_pos, npos, out, partial, relax)
    return n, undecided or und, loose or lz


@nb.njit(cache=True, inline="always")
def _spherical_parallel(LR, Lt, d, R, t, Rez, base, f, g, out, roots_pos, partial, relax):
    npos, undecided, loose = _position_parallel(LR, Lt, d, base, f, g, t, roots_pos, partial, relax)
    if npos < 0:
        return -1, True, loose
    n, und, lz = _wrist(LR, R, Rez, roots_pos, npos, out, partial, relax)
    return n, undecided or und, loose or lz


@nb.overload(family_roots, inline="always")
def _family_roots(family, LR, Lt, d, R, t, Rez, base, f, g, out, roots_pos, partial, relax):
    """The family's steps chosen when compiling where ``family`` is a :func:`family_tag`, at run
    time where it is the integer code."""
    from numba import types

    if isinstance(family, types.UniTuple):
        step = {1: _spherical_meet, 2: _spherical_parallel, 3: _planar}[family.count]

        def tagged(family, LR, Lt, d, R, t, Rez, base, f, g, out, roots_pos, partial, relax):
            return step(LR, Lt, d, R, t, Rez, base, f, g, out, roots_pos, partial, relax)

        return tagged

    def by_code(family, LR, Lt, d, R, t, Rez, base, f, g, out, roots_pos, partial, relax):
        if family == 1:  # lines 1 and 2 meet, and a spherical wrist
            return _spherical_meet(LR, Lt, d, R, t, Rez, base, f, g, out, roots_pos, partial, relax)
        if family == 2:  # lines 2 and 3 parallel, and a spherical wrist
            return _spherical_parallel(LR, Lt, d, R, t, Rez, base, f, g, out, roots_pos, partial, relax)
        if family == 3:  # lines 2, 3, 4 parallel, lines 5 and 6 meet
            return _planar(LR, Lt, d, R, t, Rez, base, f, g, out, roots_pos, partial, relax)
        return -1, True, False

    return by_code


@nb.njit(cache=True, inline="always")
def solve_branches(code, LR, Lt, d, Rlo, Rhi, tlo, thi, out, roots_pos, partial, relax=False):
    """Every root of one goal ``G = (R, t)`` (in the canonical frame of the family's chain,
    entries as intervals ``[lo, hi]``) into ``out[k, joint] = (c_lo, c_hi, s_lo, s_hi)`` of the
    canonical angle ``theta`` (``roots_pos``: scratch (4, 3, 4)); ``code``: the family's code
    or its :func:`family_tag`. Returns ``(n, undecided)``:
    with ``partial`` False, the number of roots and False, or ``(-1, True)`` at the first branch
    not decided; with ``partial`` True, a branch not decided is skipped, the others' roots are
    kept (each proven, with its enclosure) and ``undecided`` says one was skipped. ``relax``
    (:func:`sp_lin`): a discriminant holding zero gives both of its roots' enclosures (each root
    there or absent), and so does a wrist singularity (joints 4 and 6 on their whole circles);
    the count is then returned as ``-2 - count`` (an upper bound on the roots, every root in one
    of the enclosures: the folds of :mod:`kinbox.search.sweep`).

    Inlined where it is called from compiled code; the steps are compiled once whatever the
    callers pass (``bool()`` turns a literal flag into a run-time boolean)."""
    R, t = _goal(Rlo, Rhi, tlo, thi)
    Rez = (R[0][2], R[1][2], R[2][2])  # R e_z
    base, f, g = _elbow(LR, Lt, d)
    n, undecided, loose = family_roots(code, LR, Lt, d, R, t, Rez, base, f, g, out, roots_pos, bool(partial), bool(relax))
    if n < 0:
        return -1, True
    return (-2 - n if loose else n), undecided


@nb.njit(cache=True, inline="always")
def solve_pose(code, LR, Lt, d, Rlo, Rhi, tlo, thi, out, roots_pos, relax=False):
    """Every root of one goal ``G = (R, t)`` (:func:`solve_branches`): the number of roots, or -1
    where a branch is not decided (``relax``: ``-2 - count`` where a relaxed enclosure was used)."""
    n, _ = solve_branches(code, LR, Lt, d, Rlo, Rhi, tlo, thi, out, roots_pos, False, relax)
    return n


# ----------------------------------------------------------------------------------------------
# one arm: goal frames, joint limits, joint values
# ----------------------------------------------------------------------------------------------
#: relative bound on the rounding of the goal frame in canonical coordinates (a product of four
#: frames, each entry a sum of three products per factor: some tens of roundings of unit-size
#: numbers), applied to the rotation entries and, times the sum of the frames' translations,
#: to the translation
GOAL_ERR = 1e-14
#: limit rows of joints narrower than a turn are those of the formulation
#: (:func:`kinbox.formulation.pairs.revolute_angle`): ``cos(mid) c + sin(mid) s >= cos(half) - pad``
LIMIT_PAD = 8 * np.finfo(float).eps


class ClosedForm:
    """The closed form of one arm's family (:func:`kinbox.formulation.families.detect`)."""

    def __init__(self, family, arm=None):
        from ..formulation.pairs import revolute_is_limited

        self.family = family
        g = family.geometry
        self.joints = g.chain.joints
        self.code = family.code
        #: the code as a type for the batch kernels (:func:`family_tag`)
        self.family_tag = family_tag(family.code)
        #: the family's link rotations (5, 3, 3); once the bound ``delta`` is proven, the kernels'
        #: links (:func:`kinbox.search.cf_delta.kernel_links`): enclosures (5, 3, 3, 2) of the
        #: orthogonal polar factors where a link rotation is not a signed permutation
        self.LR = np.ascontiguousarray(family.LR)
        radii_e = [orthogonal_radii(R) for R in self.LR]
        self._ortho = None if any(r is None for r in radii_e) else np.array(radii_e)
        self.Lt = np.ascontiguousarray(family.Lt)
        self.d = np.ascontiguousarray(family.d)
        self.gamma = np.ascontiguousarray(family.gamma)
        # the limit row of each joint, in canonical angles: (limited, cos mid, sin mid, cos half - pad)
        lim = np.zeros((6, 4))
        for i, j in enumerate(self.joints):
            lo, hi = j.lo + self.gamma[i], j.hi + self.gamma[i]
            if revolute_is_limited(lo, hi, j.unbounded):
                mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
                lim[i] = (1.0, math.cos(mid), math.sin(mid), math.cos(half) - LIMIT_PAD)
        self.limits = lim
        self.idx_q = np.array([j.idx_q for j in self.joints], dtype=np.int64)
        #: the family's joints in model order (indices into ``joints``) and their names
        self.model_order = np.argsort(self.idx_q)
        self.model_names = [self.joints[i].name for i in self.model_order]
        self.unbounded = np.array([j.unbounded for j in self.joints], dtype=np.bool_)
        self.lo = np.array([j.lo for j in self.joints])
        self.hi = np.array([j.hi for j in self.joints])
        self.q_ref = np.asarray(g.chain.q_ref, dtype=float)
        # goal -> canonical goal frame: G = A * oriented(goal) * B
        self.A = g.C0.inverse() * g.chain.base
        self.B = g.E.inverse()
        #: A's and B's numbers as contiguous arrays, read from Pinocchio once (goal_arrays)
        self._frame_arrays = tuple(
            np.ascontiguousarray(a, dtype=float) for a in (self.A.rotation, self.A.translation, self.B.rotation, self.B.translation)
        )
        self.reversed = g.chain.reversed
        self.tmag0 = float(np.linalg.norm(self.A.translation) + np.linalg.norm(self.B.translation))
        #: the goal's widening that holds the model's exact arm (:mod:`kinbox.search.cf_delta`):
        #: the radii of the model's constants on the family's own geometry (the arm's, or none
        #: enclosed for a family read off the reversed chain: not proven)
        if arm is None:
            radii = None
        elif g is arm.geometry:
            radii = arm.constants
        else:
            radii = False
        self.delta = NOT_PROVEN if radii is False else delta_of(self.LR, self.Lt, self.d, radii, self._frame_arrays[3], self._ortho)
        if self.delta.proven and self._ortho is not None:  # the links the kernels take: enclosures of the polar factors where needed
            self.LR = kernel_links(self.LR, self._ortho)
        #: Krawczyk on the arm template's system (None: no template, or not square)
        self.certifier: TemplateCertifier | None = None
        #: Krawczyk in the six joint angles (:class:`kinbox.search.cf_certify.JointCertifier`), the
        #: batch's default: set by :func:`kinbox.search.cf_batch.closed_form` (None: not built)
        self.joint_certifier: object | None = None
        if arm is not None:
            tc = TemplateCertifier(arm, self.joints, self.gamma)
            self.certifier = tc if tc.ok else None

    def goal_arrays(self, R: np.ndarray, t: np.ndarray):
        """Enclosures of the canonical goal frame of goals ``(R, t)`` (arrays (N, 3, 3), (N, 3)):
        ``(Rlo, Rhi, tlo, thi)``."""
        AR, At, BR, Bt = self._frame_arrays
        return _goal_arrays(R, t, AR, At, BR, Bt, self.reversed, self.tmag0, self.delta)

    def roots(self, R: np.ndarray, t: np.ndarray):
        """Roots of one goal: (count or -1, enclosures (8, 6, 4), in_limits (8,) int: 1 inside,
        0 outside, -1 undecided)."""
        out = np.zeros((MAX_ROOTS, 6, 4))
        Rlo, Rhi, tlo, thi = self.goal_arrays(R[None], t[None])
        n = solve_pose(self.code, self.LR, self.Lt, self.d, Rlo[0], Rhi[0], tlo[0], thi[0], out, np.zeros((4, 3, 4)))
        inside = np.zeros(MAX_ROOTS, dtype=np.int64)
        for k in range(max(n, 0)):
            inside[k] = _in_limits(out[k], self.limits)
        return n, out, inside

    def configuration(self, enc: np.ndarray) -> np.ndarray:
        """The Pinocchio ``q`` of a root (its enclosure's midpoint), locked joints at their values."""
        from ..formulation.arm import put_angle

        q = self.q_ref.copy()
        for i, j in enumerate(self.joints):
            c = 0.5 * (enc[i, 0] + enc[i, 1])
            s = 0.5 * (enc[i, 2] + enc[i, 3])
            put_angle(q, j, math.atan2(s, c) - self.gamma[i])
        return q


@nb.njit(cache=True)
def _in_limits(enc, limits):
    """1 if every limited joint's root is proven inside its limit row, 0 if one is proven
    outside, -1 if undecided (a root on a limit, to the enclosures' width)."""
    verdict = 1
    for i in range(6):
        if limits[i, 0] == 0.0:
            continue
        v = isub(iadd(iscale(limits[i, 1], (enc[i, 0], enc[i, 1])), iscale(limits[i, 2], (enc[i, 2], enc[i, 3]))), cst(limits[i, 3]))
        if v[1] < 0.0:
            return 0
        if not v[0] > 0.0:
            verdict = -1
    return verdict


def _goal_arrays(R, t, AR, At, BR, Bt, reversed_, tmag0, delta: Delta = NO_DELTA):
    """``G = A M B`` for ``M = (R, t)`` (or its inverse for a reversed chain), with bounds: the
    rounding of ``G`` (:data:`GOAL_ERR`) and ``delta``, how far the model's exact arm moves the
    tool from the family's binary64 arm (:mod:`kinbox.search.cf_delta`), so that the closed
    form's enclosures hold every root of the model as given
    (``tests/search/test_cf_delta.py::test_the_widened_goal_holds_the_perturbed_arms_roots``)."""
    R = np.ascontiguousarray(R, dtype=float)
    t = np.ascontiguousarray(t, dtype=float)
    N = R.shape[0]
    GR = np.empty((N, 3, 3))
    Gt = np.empty((N, 3))
    tn = np.empty(N)
    _frames(
        R, t, np.ascontiguousarray(AR), np.ascontiguousarray(At), np.ascontiguousarray(BR), np.ascontiguousarray(Bt), reversed_, GR, Gt, tn
    )
    er = goal_widening(delta)
    et = goal_widening(delta, tmag0, tn)[:, None]
    return GR - er, GR + er, Gt - et, Gt + et


def goal_widening(delta: Delta, tmag0: float | None = None, tn=None):
    """The half-width of the closed form's goal box: of a rotation entry (``tmag0`` None),
    else of a translation entry for goals of translation length ``tn`` (a float or an array):
    :data:`GOAL_ERR` for the rounding and ``delta`` (:func:`_goal_arrays`), the sum made an
    upper bound."""
    if tmag0 is None:
        return (GOAL_ERR + delta.R) * _SUM_UP
    return (GOAL_ERR * (tmag0 + tn) + delta.t0 + delta.t1 * tn) * _SUM_UP + 1e-300


#: a sum of a few non-negative floats, times this, is at least the exact sum
_SUM_UP = 1.0 + 2.0**-48


@nb.njit(cache=True)
def _frames(R, t, AR, At, BR, Bt, reversed_, GR, Gt, tn):
    """``G = A M B`` per goal ``M = (R, t)`` (inverted first for a reversed chain); ``tn``:
    ``|t|`` of the (oriented) goal."""
    M = np.empty((3, 3))
    m = np.empty(3)
    AM = np.empty((3, 3))
    for k in range(R.shape[0]):
        for i in range(3):
            for j in range(3):
                M[i, j] = R[k, j, i] if reversed_ else R[k, i, j]
        for i in range(3):
            if reversed_:
                m[i] = -(M[i, 0] * t[k, 0] + M[i, 1] * t[k, 1] + M[i, 2] * t[k, 2])
            else:
                m[i] = t[k, i]
        tn[k] = math.sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2])
        for i in range(3):
            for j in range(3):
                AM[i, j] = AR[i, 0] * M[0, j] + AR[i, 1] * M[1, j] + AR[i, 2] * M[2, j]
        for i in range(3):
            for j in range(3):
                GR[k, i, j] = AM[i, 0] * BR[0, j] + AM[i, 1] * BR[1, j] + AM[i, 2] * BR[2, j]
            Gt[k, i] = AM[i, 0] * Bt[0] + AM[i, 1] * Bt[1] + AM[i, 2] * Bt[2] + AR[i, 0] * m[0] + AR[i, 1] * m[1] + AR[i, 2] * m[2] + At[i]


@nb.njit(cache=True)
def _params(GR, Gt, tn, tmag0, P, PM):
    """:meth:`ArmTemplate.params` and :meth:`ArmTemplate.param_magnitudes` of goal frames."""
    for k in range(GR.shape[0]):
        P[k, 0] = 1.0
        PM[k, 0] = 1.0
        for i in range(3):
            for j in range(3):
                P[k, 1 + 3 * i + j] = GR[k, i, j]
                PM[k, 1 + 3 * i + j] = 1.0
        x, y, z = Gt[k, 0], Gt[k, 1], Gt[k, 2]
        P[k, 10], P[k, 11], P[k, 12] = x, y, z
        for j in range(3):
            P[k, 13 + j] = GR[k, 0, j] * x + GR[k, 1, j] * y + GR[k, 2, j] * z
            P[k, 17 + j] = GR[k, 0, j] * (-y) + GR[k, 1, j] * x
        P[k, 16] = x * x + y * y + z * z
        tm = tmag0 + tn[k]
        for j in range(3):
            PM[k, 10 + j] = tm
            PM[k, 13 + j] = 3.0 * tm
            PM[k, 17 + j] = 3.0 * tm
        PM[k, 16] = 3.0 * tm * tm


# ----------------------------------------------------------------------------------------------
# certification on the kinbox system, compiled: the arm template bound and tested per root
# ----------------------------------------------------------------------------------------------
class TemplateCertifier:
    """Krawczyk (:func:`kinbox.search.certify._krawczyk_full`, the search's own test) on the
    arm template's system bound at each pose, inside compiled code: the binding of
    :meth:`kinbox.formulation.template.Template.bind` (coefficients ``coef @ p``, constants,
    the core rows' slack) and the system point of a configuration
    (:meth:`kinbox.formulation.arm.ArmTemplate.encode`) as arrays."""

    def __init__(self, arm, family_joints, family_gamma):
        from .. import interval as ivl
        from ..formulation.arm import _is_var, var_index
        from ..formulation.errfloat import err
        from ..formulation.template import TEMPLATE_CORE_SLACK

        self.arm = arm
        T = arm.template
        f = T.freeze()
        n = T.n
        n_core = f["n_core"]
        self.ok = n_core == n and n > 0
        self.n = n
        ne = int(f["indptr"][n_core])
        coef = f["coef"][:ne].tocsr()
        self.coef_indptr = np.ascontiguousarray(coef.indptr, dtype=np.int64)
        self.coef_indices = np.ascontiguousarray(coef.indices, dtype=np.int64)
        self.coef_data = np.ascontiguousarray(coef.data, dtype=float)
        self.const = np.ascontiguousarray(f["const"][:n_core], dtype=float)
        self.zmag = np.ascontiguousarray(f["zmag"][:ne], dtype=float)
        self.indptr = np.ascontiguousarray(f["indptr"][: n_core + 1], dtype=np.int64)
        cols = np.ascontiguousarray(f["cols"][:ne], dtype=np.int64)
        rows = np.ascontiguousarray(f["rows"][:ne], dtype=np.int64)
        self.cols = cols
        self.rows_of = rows
        self.mi = np.ascontiguousarray(f["mi"], dtype=np.int64)
        self.mj = np.ascontiguousarray(f["mj"], dtype=np.int64)
        nonlin = cols >= n
        k = cols[nonlin] - n
        r = rows[nonlin]
        self.nonlin = np.flatnonzero(nonlin).astype(np.int64)
        self.t_flat = np.ascontiguousarray(np.concatenate([r * n + self.mi[k], r * n + self.mj[k]]), dtype=np.int64)
        self.t_var = np.ascontiguousarray(np.concatenate([self.mj[k], self.mi[k]]), dtype=np.int64)
        self.g_slope = float(ivl.gamma(int(np.bincount(self.t_flat).max(initial=0)) + 3))
        self.core_slack = TEMPLATE_CORE_SLACK
        lo0, hi0 = T.vars.search_domain()
        self.dom_lo = np.ascontiguousarray(lo0, dtype=float)
        self.dom_hi = np.ascontiguousarray(hi0, dtype=float)
        # encode: fixed values, joint (c, s) variables, then the definitions in order
        fixed = np.full(n, np.nan)
        for i, v in arm.fixed.items():
            fixed[i] = v
        self.fixed = fixed
        tj = {j.jid: i for i, j in enumerate(arm.geometry.chain.joints)}
        cvar = np.full(6, -1, dtype=np.int64)
        svar = np.full(6, -1, dtype=np.int64)
        shift = np.zeros(6)
        for i, j in enumerate(family_joints):
            ti = tj[j.jid]
            jv = arm.jvars[ti]
            if jv.c is not None and _is_var(jv.c):
                cvar[i] = var_index(jv.c)
            if jv.s is not None and _is_var(jv.s):
                svar[i] = var_index(jv.s)
            shift[i] = arm.geometry.gamma[ti] - family_gamma[i]
        self.cvar, self.svar, self.shift = cvar, svar, shift
        prog = []  # (target, param, coef, a, b) with a, b = -1 for no factor
        errs: list[float] = []
        starts = [0]
        targets = []
        for i, e in arm.defs:
            targets.append(i)
            for kk, ex in e.items():
                for key, v in ex.terms.items():
                    a = key[0] if len(key) >= 1 else -1
                    b = key[1] if len(key) >= 2 else -1
                    # the coefficient's error (the model's constants), infinite for a third
                    # factor this program leaves out (system_enclosure then holds nothing)
                    e = err(v) if len(key) <= 2 or float(v) == 0.0 else math.inf
                    prog.append((kk, v, a, b))
                    errs.append(e)
            starts.append(len(prog))
        self.def_target = np.array(targets, dtype=np.int64)
        self.def_start = np.array(starts, dtype=np.int64)
        pr = np.array(prog, dtype=float).reshape(-1, 4)
        self.def_param = np.ascontiguousarray(pr[:, 0], dtype=np.int64)
        self.def_coef = np.ascontiguousarray(pr[:, 1])
        self.def_a = np.ascontiguousarray(pr[:, 2], dtype=np.int64)
        self.def_b = np.ascontiguousarray(pr[:, 3], dtype=np.int64)
        self.def_err = np.ascontiguousarray(np.array(errs, dtype=float).reshape(-1))
        g = arm.geometry
        A = g.C0.inverse() * g.chain.base
        B = g.E.inverse()
        self.AR, self.At = np.ascontiguousarray(A.rotation), np.ascontiguousarray(A.translation)
        self.BR, self.Bt = np.ascontiguousarray(B.rotation), np.ascontiguousarray(B.translation)
        self.reversed = bool(g.chain.reversed)
        self.tmag0 = sum(float(np.linalg.norm(T.translation)) for T in (g.C0, g.chain.base, g.E))

    def params(self, R: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`ArmTemplate.params` and :meth:`ArmTemplate.param_magnitudes` of goals
        ``(R, t)`` (arrays (N, 3, 3), (N, 3)) at once."""
        from ..formulation.arm import NPARAMS, P_R, P_T, P_TT, P_U, P_V

        assert (P_R, P_T, P_U, P_TT, P_V, NPARAMS) == (1, 10, 13, 16, 17, 20)  # the layout _params writes
        R = np.ascontiguousarray(R, dtype=float)
        t = np.ascontiguousarray(t, dtype=float)
        N = R.shape[0]
        GR = np.empty((N, 3, 3))
        Gt = np.empty((N, 3))
        tn = np.empty(N)
        _frames(R, t, self.AR, self.At, self.BR, self.Bt, self.reversed, GR, Gt, tn)
        P = np.empty((N, NPARAMS))
        PM = np.empty((N, NPARAMS))
        _params(GR, Gt, tn, self.tmag0, P, PM)
        return P, PM

    def model_errors(self, R: np.ndarray, t: np.ndarray, P: np.ndarray, PM: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per goal, ``Compiled.merr`` and ``Compiled.mgrad`` of the core rows bound at ``P``
        (:meth:`params`): the distance of ``P`` to the enclosure of the pose as given
        (:meth:`ArmTemplate.params_enclosure`, the pose read as its XYZQUAT) added to that
        enclosure's radius, and the template's constants
        (:func:`kinbox.formulation.template.model_errors`)."""
        import pinocchio as pin  # noqa: PLC0415 (the pose as an SE3, as the search reads it)

        from ..formulation.template import model_errors

        N = P.shape[0]
        PRAD = np.empty_like(P)
        for k in range(N):
            pe, rad = self.arm.params_enclosure(pin.SE3(np.asarray(R[k]), np.asarray(t[k])))
            PRAD[k] = np.nextafter(np.abs(P[k] - pe) * (1.0 + 2.0**-52), np.inf) + rad
        PRAD[:, 0] = 0.0
        merr, mgrad = model_errors(self.arm.template.freeze(), P, np.maximum(np.abs(P), PM), PRAD)
        nc = self.const.shape[0]
        return merr[:, :nc], mgrad[:, :nc]

    def kernel_args(self):
        return (
            self.coef_indptr,
            self.coef_indices,
            self.coef_data,
            self.const,
            self.zmag,
            self.indptr,
            self.cols,
            self.rows_of,
            self.mi,
            self.mj,
            self.nonlin,
            self.t_flat,
            self.t_var,
            self.g_slope,
            self.core_slack,
            self.dom_lo,
            self.dom_hi,
            self.fixed,
            self.cvar,
            self.svar,
            self.shift,
            self.def_target,
            self.def_start,
            self.def_param,
            self.def_coef,
            self.def_a,
            self.def_b,
        )


@nb.njit(cache=True)
def _encode(theta, p, fixed, cvar, svar, shift, def_target, def_start, def_param, def_coef, def_a, def_b, x):
    n = x.shape[0]
    for i in range(n):
        x[i] = fixed[i] if not np.isnan(fixed[i]) else 0.0
    for i in range(6):
        th = theta[i] + shift[i]
        if cvar[i] >= 0:
            x[cvar[i]] = math.cos(th)
        if svar[i] >= 0:
            x[svar[i]] = math.sin(th)
    for d in range(def_target.shape[0]):
        acc = 0.0
        for e in range(def_start[d], def_start[d + 1]):
            v = p[def_param[e]] * def_coef[e]
            if def_a[e] >= 0:
                v *= x[def_a[e]]
            if def_b[e] >= 0:
                v *= x[def_b[e]]
            acc += v
        x[def_target[d]] = acc


@nb.njit(cache=True)
def encode_rows(theta, p, fixed, cvar, svar, shift, def_target, def_start, def_param, def_coef, def_a, def_b, x):
    """:func:`_encode` of each row of ``theta`` into the rows of ``x``."""
    for r in range(x.shape[0]):
        _encode(theta[r], p, fixed, cvar, svar, shift, def_target, def_start, def_param, def_coef, def_a, def_b, x[r])


#: status of a pose in a batch
POSE_CLOSED_FORM = 0  # every root proven, certified: the answer is complete
POSE_FALLBACK = 1  # undecided: the branch and prune answers this pose
#: half-width of the proof box about a root, relative to ``1 + |x|``
PROOF_RADIUS = 1e-9
#: where the proof box does not hold a root's enclosure, boxes these many times the
#: enclosure's reach about the proven root are proven in turn (:func:`_alone_in_system_enclosure`;
#: :data:`kinbox.search.cf_certify.HOLD_GROWTH` in the joint angles)
HOLD_GROWTH = (1.125, 1.5, 3.0)


@nb.njit(cache=True, inline="always")
def pose_roots(family, LR, Lt, d, limits, Rlo, Rhi, tlo, thi, enc, scratch, inside):
    """The closed form of one goal of a batch (:func:`solve_pose`) and each root's limit verdict
    in ``inside`` (:func:`_in_limits`): the number of roots, or -1 where the pose goes to the
    branch and prune (a branch undecided, or a root on a limit)."""
    nr = solve_pose(family, LR, Lt, d, Rlo, Rhi, tlo, thi, enc, scratch)
    if nr < 0:
        return -1
    undecided = False
    for r in range(nr):
        inside[r] = _in_limits(enc[r], limits)
        if inside[r] < 0:
            undecided = True
    return -1 if undecided else nr


@nb.njit(cache=True, inline="always")
def root_angles(enc, theta):
    """The canonical angles of a root (the midpoint of its ``(c, s)`` enclosure ``enc`` (6, 4))."""
    for i in range(6):
        cm = 0.5 * (enc[i, 0] + enc[i, 1])
        sm = 0.5 * (enc[i, 2] + enc[i, 3])
        theta[i] = math.atan2(sm, cm)


@nb.njit(cache=True)
def _held_by(el, eh, lo, hi):
    """Is the box ``[el, eh]`` inside ``[lo, hi]`` (False for a NaN)?"""
    for i in range(el.shape[0]):
        if not (el[i] >= lo[i] and eh[i] <= hi[i]):
            return False
    return True


@nb.njit(cache=True)
def _rows_krawczyk(lo, hi, x, rows, merr, mgrad):
    """Krawczyk on the bound template's rows over the box ``[lo, hi]`` about ``x``
    (:func:`kinbox.search.certify._krawczyk_full`): its status and ``K(X) ∩ X``. ``rows``: the
    rows bound at the pose (:func:`solve_batch_kernel`'s ``(Ax, t_flat, t_var, t_coef, t_abs,
    g_slope, slack, tiny, u, mi, mj, indptr, cols, data, c)``); the rows of the pose as given
    and of the model's constants lie within ``merr``, ``mgrad`` of them (docs/soundness.md,
    "What a certificate covers")."""
    Ax, t_flat, t_var, t_coef, t_abs, g_slope, slack, tiny, u, mi, mj, indptr, cols, data, c = rows
    st, klo, khi, _e = _krawczyk_full(
        lo, hi, x, Ax, t_flat, t_var, t_coef, t_abs, g_slope, slack, merr, mgrad, False, tiny, u, mi, mj, indptr, cols, data, c
    )
    return st, klo, khi


@nb.njit(cache=True)
def _alone_in_system_enclosure(el, eh, lo, hi, klo, khi, x2, lo2, hi2, rows, merr, mgrad):
    """No other root in a root's enclosure of system points ``[el, eh]``
    (:func:`system_enclosure`), the root proven in ``[klo, khi]`` by Krawczyk over ``[lo, hi]``:
    the enclosure lies in that box, or in a box :data:`HOLD_GROWTH` times its reach about the
    proven root (the middle of its Krawczyk box) proven the same way (:func:`_rows_krawczyk`;
    :func:`kinbox.search.cf_certify._alone_in_enclosure` in the joint angles)
    (``tests/search/test_cf_certify.py::test_an_enclosure_outside_its_proof_box_sends_the_pose_on``)."""
    if _held_by(el, eh, lo, hi):
        return True
    n = el.shape[0]
    for i in range(n):
        x2[i] = 0.5 * (klo[i] + khi[i])
    for grow in HOLD_GROWTH:
        for i in range(n):
            w = max(PROOF_RADIUS * (1.0 + abs(x2[i])), grow * max(x2[i] - el[i], eh[i] - x2[i]) * (1.0 + 2.0**-48))
            lo2[i] = x2[i] - w
            hi2[i] = x2[i] + w
        st2, _l, _h = _rows_krawczyk(lo2, hi2, x2, rows, merr, mgrad)
        if st2 == _K_UNIQUE and _held_by(el, eh, lo2, hi2):
            return True
    return False


@nb.njit(cache=True)
def system_enclosure(
    enc, Rlo, Rhi, tlo, thi, fixed, cvar, svar, shift, def_target, def_start, def_param, def_coef, def_a, def_b, def_err, pl, ph, el, eh
):  # fmt: skip
    """An enclosure ``[el, eh]`` of the arm template's system points of every root whose
    canonical angles lie in a closed-form root's enclosure ``enc`` (6, 4), for every goal in
    the box ``(Rlo, Rhi, tlo, thi)``: joints' ``(cos, sin)`` from ``enc``, the parameters
    (:func:`_params`) in interval arithmetic over the goal box (``pl``, ``ph``: scratch (20,)),
    each auxiliary variable its definition (:func:`_encode`'s program, each coefficient within
    its error ``def_err`` of the model's) over those, fixed variables their values. False where
    it is not computed: a joint whose template angle is shifted from the family's
    (``tests/search/test_closed_form.py::test_system_enclosure_holds_the_roots_system_points``)."""
    n = el.shape[0]
    for i in range(n):
        if not np.isnan(fixed[i]):
            el[i] = fixed[i]
            eh[i] = fixed[i]
        else:
            el[i] = -np.inf
            eh[i] = np.inf
    for i in range(6):
        if shift[i] != 0.0:
            return False
        if cvar[i] >= 0:
            el[cvar[i]], eh[cvar[i]] = enc[i, 0], enc[i, 1]
        if svar[i] >= 0:
            el[svar[i]], eh[svar[i]] = enc[i, 2], enc[i, 3]
    R, t = _goal(Rlo, Rhi, tlo, thi)
    pl[0], ph[0] = 1.0, 1.0
    for i in range(3):
        for j in range(3):
            pl[1 + 3 * i + j], ph[1 + 3 * i + j] = R[i][j]
        pl[10 + i], ph[10 + i] = t[i]
    for j in range(3):
        pl[13 + j], ph[13 + j] = iadd(iadd(imul(R[0][j], t[0]), imul(R[1][j], t[1])), imul(R[2][j], t[2]))
        pl[17 + j], ph[17 + j] = iadd(imul(R[0][j], ineg(t[1])), imul(R[1][j], t[0]))
    pl[16], ph[16] = vnorm2(t)
    for dd in range(def_target.shape[0]):
        acc = (0.0, 0.0)
        for e in range(def_start[dd], def_start[dd + 1]):
            k = def_coef[e]
            ke = def_err[e]
            if k == 0.0 and ke == 0.0:
                continue
            v = imul((_dn(k - ke), _up(k + ke)) if ke > 0.0 else (k, k), (pl[def_param[e]], ph[def_param[e]]))
            if def_a[e] >= 0:
                v = imul(v, (el[def_a[e]], eh[def_a[e]]))
            if def_b[e] >= 0:
                v = imul(v, (el[def_b[e]], eh[def_b[e]]))
            acc = iadd(acc, v)
        if not acc[0] <= acc[1]:
            return False
        tg = def_target[dd]
        el[tg] = max(el[tg], acc[0])  # a joint's (cos, sin) is also its definition's value
        eh[tg] = min(eh[tg], acc[1])
    return True


@nb.njit(cache=True)
def solve_batch_kernel(
    family, LR, Lt, d, gamma_f, limits,
    Rlo, Rhi, tlo, thi, P, PM, MERR, MGRAD,
    coef_indptr, coef_indices, coef_data, const, zmag, indptr, cols, rows_of, mi, mj, nonlin, t_flat, t_var,
    g_slope, core_slack, dom_lo, dom_hi, fixed, cvar, svar, shift, def_target, def_start, def_param, def_coef, def_a, def_b, def_err,
    tiny, u, certify,
    status, first, count, theta_out, x_out, klo_out, khi_out, res_out,
):  # fmt: skip
    """Every pose of a batch: closed form, limits, and (``certify``) Krawczyk on the bound
    template per root. Roots of pose ``k`` are rows ``first[k] .. first[k] + count[k]`` of the
    outputs (canonical angles of the family's joints, system points, proof boxes, residuals).
    ``family``: :func:`family_tag` of the closed form's code."""
    N = Rlo.shape[0]
    n = fixed.shape[0]
    n_core = const.shape[0]
    enc = np.zeros((MAX_ROOTS, 6, 4))
    scratch = np.zeros((4, 3, 4))
    inside = np.empty(MAX_ROOTS, dtype=np.int64)
    lo = np.empty(n)
    hi = np.empty(n)
    data = np.empty(zmag.shape[0])
    c = np.empty(n_core)
    slack = np.empty(n_core)
    Ax = np.zeros((n_core, n))
    t_coef = np.empty(t_flat.shape[0])
    t_abs = np.empty(t_flat.shape[0])
    x = np.empty(n)
    theta = np.empty(6)
    ap = np.empty(P.shape[1])
    pl = np.empty(20)
    ph = np.empty(20)
    el = np.empty(n)
    eh = np.empty(n)
    lo2 = np.empty(n)
    hi2 = np.empty(n)
    x2 = np.empty(n)
    rows = (Ax, t_flat, t_var, t_coef, t_abs, g_slope, slack, tiny, u, mi, mj, indptr, cols, data, c)
    m_out = 0
    for k in range(N):
        first[k] = m_out
        count[k] = 0
        nr = pose_roots(family, LR, Lt, d, limits, Rlo[k], Rhi[k], tlo[k], thi[k], enc, scratch, inside)
        if nr < 0:
            status[k] = POSE_FALLBACK
            continue
        if certify:  # bind the template at this pose
            bind_rows(
                P[k], PM[k], MERR[k], const, coef_indptr, coef_indices, coef_data, zmag, rows_of, cols, nonlin, core_slack, tiny,
                ap, c, slack, data, Ax, t_coef, t_abs,
            )  # fmt: skip
        ok = True
        m0 = m_out
        for r in range(nr):
            if inside[r] == 0:
                continue
            root_angles(enc[r], theta)
            for i in range(6):
                theta_out[m_out, i] = theta[i]
            if certify:
                _encode(theta, P[k], fixed, cvar, svar, shift, def_target, def_start, def_param, def_coef, def_a, def_b, x)
                for i in range(n):
                    w = PROOF_RADIUS * (1.0 + abs(x[i]))
                    lo[i] = x[i] - w
                    hi[i] = x[i] + w
                # the rows of the pose as given and of the model's constants lie within
                # MERR, MGRAD of the rows as bound (docs/soundness.md, "What a certificate covers")
                st, klo, khi = _rows_krawczyk(lo, hi, x, rows, MERR[k], MGRAD[k])
                if st != _K_UNIQUE:
                    ok = False
                    break
                for i in range(n):
                    if klo[i] < dom_lo[i] or khi[i] > dom_hi[i]:
                        ok = False
                # no other root of the model as given in the root's enclosure: its system
                # points lie in the proof's box X, or in a larger box proven the same way
                if ok and not system_enclosure(
                    enc[r], Rlo[k], Rhi[k], tlo[k], thi[k], fixed, cvar, svar, shift, def_target, def_start, def_param, def_coef,
                    def_a, def_b, def_err, pl, ph, el, eh,
                ):  # fmt: skip
                    ok = False
                if ok and not _alone_in_system_enclosure(el, eh, lo, hi, klo, khi, x2, lo2, hi2, rows, MERR[k], MGRAD[k]):
                    ok = False
                res = 0.0  # residual of the core rows at x
                for rr in range(n_core):
                    res = max(res, abs(core_row(rr, c, data, x, indptr, cols, mi, mj)))
                for i in range(n):
                    x_out[m_out, i] = x[i]
                    klo_out[m_out, i] = klo[i]
                    khi_out[m_out, i] = khi[i]
                res_out[m_out] = res
                for prev in range(m0, m_out):  # disjoint proofs: distinct roots
                    if not boxes_apart(klo_out, khi_out, prev, klo, khi):
                        ok = False
            if not ok:
                break
            m_out += 1
        if not ok:
            m_out = m0
            status[k] = POSE_FALLBACK
            continue
        status[k] = POSE_CLOSED_FORM
        count[k] = m_out - m0
    return m_out


@dataclass
class Batch:
    """Roots of a batch of poses as flat arrays: the roots of pose ``k`` are rows
    ``first[k] : first[k] + count[k]``; ``status[k]`` is :data:`POSE_CLOSED_FORM` (complete:
    every root proven by the closed form and, with ``certified``, by Krawczyk on the kinbox
    system) or :data:`POSE_FALLBACK` (to be solved by the branch and prune)."""

    status: np.ndarray  # (N,) int
    first: np.ndarray  # (N,) int
    count: np.ndarray  # (N,) int
    theta: np.ndarray  # (M, 6) canonical angles of the family's joints
    x: np.ndarray  # (M, n) system points (certified only)
    lo: np.ndarray  # (M, n) Krawczyk boxes, each proven to hold exactly one root
    hi: np.ndarray
    residual: np.ndarray  # (M,) largest core row at x
    certified: bool
    #: how the roots were certified: "system" (Krawczyk on the kinbox system: ``x``, ``lo``,
    #: ``hi``), "joint" (Krawczyk in the joint angles: ``jlo``, ``jhi``) or None
    certificate: str | None = None
    jlo: np.ndarray | None = None  # (M, 6) proof boxes in the arm template's canonical angles
    jhi: np.ndarray | None = None


_NO_CERTIFIER: list = []


def _no_certifier() -> tuple:
    """Kernel arguments standing for no certifier (built once)."""
    if not _NO_CERTIFIER:
        i0, f0 = np.zeros(0, dtype=np.int64), np.zeros(0)
        i1 = np.zeros(1, dtype=np.int64)
        m6 = np.full(6, -1, dtype=np.int64)
        _NO_CERTIFIER.append(
            (
                i1,
                i1,
                np.zeros(1),
                np.zeros((0, 1)),
                f0,
                i1,
                i0,
                i0,
                i1,
                i1,
                i0,
                i0,
                i0,
                0.0,
                0.0,
                f0,
                f0,
                f0,
                m6,
                m6,
                np.zeros(6),
                i0,
                i1,
                i0,
                f0,
                i0,
                i0,
            )
        )
    return _NO_CERTIFIER[0]


def call_batch_kernel(cf: ClosedForm, limits, goals, P, PM, MERR, MGRAD, args, n: int, certify: bool) -> Batch:
    """:func:`solve_batch_kernel` on goal enclosures ``goals = (Rlo, Rhi, tlo, thi)`` with the
    bound parameters ``P``, ``PM``, their model errors and the certifier's ``args`` (``n``
    system variables), into a :class:`Batch`."""
    from .. import interval as ivl

    Rlo, Rhi, tlo, thi = goals
    N = Rlo.shape[0]
    status = np.zeros(N, dtype=np.int64)
    first = np.zeros(N, dtype=np.int64)
    count = np.zeros(N, dtype=np.int64)
    M = MAX_ROOTS * N
    theta = np.zeros((M, 6))
    x = np.zeros((M if certify else 0, n))
    klo = np.zeros((M if certify else 0, n))
    khi = np.zeros((M if certify else 0, n))
    res = np.zeros(M if certify else 0)
    # the definitions' coefficient errors of the certifier whose arguments these are (unknown:
    # infinite, no enclosure held: system_enclosure)
    tc = cf.certifier
    def_err = tc.def_err if tc is not None and tc.def_coef is args[24] else np.full(len(args[24]), np.inf)
    m = solve_batch_kernel(
        cf.family_tag, cf.LR, cf.Lt, cf.d, cf.gamma, limits, Rlo, Rhi, tlo, thi, P, PM, MERR, MGRAD, *args, def_err,
        ivl.TINY, ivl.U, certify,
        status, first, count, theta, x, klo, khi, res,
    )  # fmt: skip
    return Batch(status, first, count, theta[:m], x[:m], klo[:m], khi[:m], res[:m], certify, "system" if certify else None)
