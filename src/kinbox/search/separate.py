"""Two certified roots out of a near-double real pair of a six-revolute arm.

Next to a singularity where two real roots meet (a UR elbow 1e-7 from straight: ``q3 = +-1.02e-7``)
the search stops at boxes of sigma and reports the pair as one uncertified point of multiplicity 2.
Neither the search's Krawczyk nor :func:`kinbox.search.cf_certify.krawczyk6` can tell the two
apart: the Jacobian's smallest singular value at a root is ``2 a delta`` (``a`` the curvature along
the near-null direction, ``delta`` half the pair's distance: 1.6e-8 there), so a proof box needs
``F(m)`` to some 1e-16 and ``J`` over the box to its true spread along that direction, where the
binary64 kernels enclose ``F(m)`` to 6e-15..3e-14 and bound ``J``'s spread by a Lipschitz constant
35 times the curvature. Here, about a centre ``c`` (the cluster's point, exact binary64 angles):

* ``F(c)``, ``J(c)`` and the second derivatives ``H(c)`` of the six-angle system of
  :mod:`~kinbox.search.cf_certify` (same equations, frames and goal ``G = A M B``) are enclosed
  in 128-bit interval arithmetic (``mpmath.iv``) on the model's exact links and frames where
  they are given (:class:`Constants` ``exact``: 120-bit enclosures of
  :mod:`kinbox.formulation.constants`), so their radii are the arithmetic's (1e-35), else on
  the template's binary64 constants with their radii (every arm within them, the model as
  given among them; about 2e-16 on ``F``);
* every third derivative is bounded by ``D = max_k |p - o_k|`` (position rows: three unit axes
  crossed with some ``p - o_k``) or ``3/2`` (orientation rows: ``1/2 sum_k |g_k|`` times three
  unit axes crossed with a unit column), ``D`` over the region ``D(c) / (1 - |theta - c|_1)``
  (:data:`~kinbox.search.cf_certify` ``krawczyk6``'s argument), so with ``d = theta - c``
  ``F(theta) in F(c) + J(c) d + 1/2 d^T H(c) d +- M3 |d|_1^3 / 6`` and
  ``J(theta) in J(c) + sum_i H_i(c) d_i +- M3 |d|_1^2 / 2`` (Taylor with Lagrange's remainder);
* these Taylor models are evaluated over boxes in binary64 interval arithmetic rounded outward
  (``d`` is small: the cancellation that makes a near-double pair hard is all inside the
  128-bit ``F(c)``, ``J(c)``, ``H(c)``), in the variables ``z`` of ``theta = c + B z`` with
  ``B`` the right singular vectors of ``J(c)`` (:meth:`Model.rotated`: the near-null
  direction is one variable, so a box's spread of ``J`` along it is not summed with the
  others'), and with the preconditioner multiplied into ``J(c)`` and ``H(c)`` before any
  interval widening, so the curvature along the near-null direction is kept, not replaced by a
  bound of its absolute values.

:func:`separate_pair` finds the two real roots (the quadratic along the near-null direction,
then Newton on the model; a negative discriminant is a complex pair: nothing to separate),
proves each by Krawczyk on boxes grown about it (:data:`GROWTH`), requires the two boxes
disjoint, and proves that the region the cluster stands for holds no other root: its boxes are
bisected (:data:`MAX_BOXES`, a counter) until each piece lies in a proof box or is excluded by
the mean-value form of the preconditioned system (``0 notin W F(m) + W J(X) (X - m)`` in some
row; ``W`` the inverse singular values times ``U^T`` at ``c``, its last row ``u_6^T``).
Anything short of that returns None and the cluster stays as it was
(``tests/answer/test_separate.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

#: bits of the interval arithmetic of ``F(c)``, ``J(c)``, ``H(c)``
PREC = 128
#: proof boxes about a root: half-widths ``rho (|v_6| + floor)`` for ``rho`` these fractions of
#: the pair's distance along the near-null direction ``v_6``
GROWTH = (0.02, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4)
FLOORS = (0.3, 0.1, 0.01, 1e-3)
#: boxes the exclusion may look at before it gives up (a counter: same answer on every run)
MAX_BOXES = 20000
#: Newton steps on the model from each side of the pair
NEWTON_STEPS = 30
#: orientation rows' third derivatives: 1/2 sum_k |g_k| with |g_k| <= 1 (the goal's radii
#: rounded up generously)
M3_ORIENTATION = 1.5 * (1.0 + 1e-6)


# -- binary64 intervals rounded outward: pairs (lo, hi) of arrays ---------------------------------
def _out(lo, hi):
    return np.nextafter(lo, -np.inf), np.nextafter(hi, np.inf)


def _add(a, b):
    return _out(a[0] + b[0], a[1] + b[1])


def _sub(a, b):
    return _out(a[0] - b[1], a[1] - b[0])


def _mul(a, b):
    p = (a[0] * b[0], a[0] * b[1], a[1] * b[0], a[1] * b[1])
    return _out(np.minimum(np.minimum(p[0], p[1]), np.minimum(p[2], p[3])), np.maximum(np.maximum(p[0], p[1]), np.maximum(p[2], p[3])))


def _sum(a, axis):
    """Sum along ``axis``: the binary64 sums of the ends, each moved out by a bound of the
    rounding of ``n`` terms (``n u sum |x|``, ``u = 2^-53``), itself rounded up."""
    lo, hi = a
    n = lo.shape[axis]
    elo = (n * 2.0**-52) * np.sum(np.abs(lo), axis=axis) * (1.0 + 2.0**-40) + 1e-300
    ehi = (n * 2.0**-52) * np.sum(np.abs(hi), axis=axis) * (1.0 + 2.0**-40) + 1e-300
    return _out(np.sum(lo, axis=axis) - elo, np.sum(hi, axis=axis) + ehi)


def _pm(r):
    """``[-r, r]`` for a nonnegative bound ``r``."""
    r = np.nextafter(np.asarray(r, dtype=float), np.inf)
    return -r, r


def _mag(a):
    return np.maximum(np.abs(a[0]), np.abs(a[1]))


# -- the Taylor model about c, in 128-bit intervals ---------------------------------------------------
def _cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


@dataclass
class Model:
    """``F``, ``J`` and ``H`` at ``c`` (geometry angles) as binary64 intervals (``(lo, hi)``;
    ``H[q, j, i] = d^2 F_q / d theta_j d theta_i``), ``D`` an upper bound of ``max_k |p - o_k|``
    at ``c`` and ``trace`` a lower bound of ``trace(R_G^T R)`` there."""

    c: np.ndarray
    F: tuple
    J: tuple
    H: tuple
    D: float
    trace: float
    #: the variables: ``theta = c + B z`` (identity: the angles' offsets from ``c``), and the
    #: 1-norms of ``B``'s columns (``|theta - c|_1 <= sum_j n_j |z_j|``)
    B: np.ndarray = field(default_factory=lambda: np.eye(6))
    n: np.ndarray = field(default_factory=lambda: np.ones(6))

    def rotated(self, B: np.ndarray) -> Model:
        """The same model in the variables ``z`` of ``theta = c + B z``: ``J B`` and ``H``
        contracted with ``B`` on both sides (interval products with the exact ``B``)."""
        Bi = (B, B)
        J = _sum(_mul((self.J[0][:, :, None], self.J[1][:, :, None]), (Bi[0][None], Bi[1][None])), axis=1)
        H1 = _sum(_mul((self.H[0][:, :, :, None], self.H[1][:, :, :, None]), (Bi[0][None, None], Bi[1][None, None])), axis=2)  # [q, j, i']
        H = _sum(_mul((H1[0][:, :, None, :], H1[1][:, :, None, :]), (Bi[0][None, :, :, None], Bi[1][None, :, :, None])), axis=1)
        n = np.nextafter(np.sum(np.abs(B), axis=0) * (1.0 + 2.0**-40), np.inf)
        return Model(self.c, self.F, J, H, self.D, self.trace, B, n)

    def theta(self, lo, hi):
        """Enclosure of ``c + B z`` over the boxes ``[lo, hi]`` (N, 6)."""
        t = _sum(_mul((self.B[None], self.B[None]), (lo[:, None, :], hi[:, None, :])), axis=2)
        return _add((self.c[None], self.c[None]), t)

    def m3(self, l1):
        """Per row, a bound of every third derivative of ``F`` within ``|theta - c|_1 <= l1``
        (array ``l1``, one per box: shape (N, 6))."""
        pos = self.D / (1.0 - l1) * (1.0 + 2.0**-40)
        pos = np.nextafter(pos, np.inf)
        return np.stack([pos, pos, pos, *(np.full_like(pos, M3_ORIENTATION),) * 3], axis=-1)


@dataclass
class Constants:
    """The arm's constants as :class:`~kinbox.search.cf_certify.JointCertifier` encloses them,
    without its rounding of each end outward (exact here: the 128-bit arithmetic takes
    midpoint and radius as they are): the links ``LR`` (5, 3, 3, 2), ``Lt`` (5, 3, 2)
    (midpoint, radius), the offsets ``d``, the frames ``A = C_0^-1 base`` and ``B = E^-1`` as
    (rotation, its radii, translation, its radii), and whether the chain is reversed."""

    LR: np.ndarray
    Lt: np.ndarray
    d: np.ndarray
    A: tuple
    B: tuple
    reversed: bool
    #: the model's exact links and frames themselves where known (``enclose_links(...,
    #: keep_exact=True)`` of :mod:`kinbox.formulation.constants`: ``exact_links``, ``A``,
    #: ``B`` in 120-bit intervals): then they replace the midpoints and radii above, and
    #: ``F(c)`` is enclosed to the arithmetic's precision instead of the radii's 1e-16
    exact: dict | None = None


def arm_constants(geometry, constants: dict | None, exact: dict | None = None) -> Constants:
    """:class:`Constants` of an arm's geometry (:class:`kinbox.formulation.arm.Geometry`) and its
    enclosure of the model's exact constants (:attr:`kinbox.formulation.arm.ArmTemplate.constants`;
    None: the binary64 ones taken as exact, the frames' products enclosed in 128 bits)."""
    g = geometry
    LR = np.array([L.R for L in g.links], dtype=float)
    Lt = np.array([L.t for L in g.links], dtype=float)
    rR, rt = np.zeros_like(LR), np.zeros_like(Lt)
    frames: list[tuple] = []
    if constants is not None:
        for i, (a, b) in enumerate(constants["links"]):
            rR[i], rt[i] = a, b
        for F, (rFR, rFt) in ((g.C0.inverse() * g.chain.base, constants["A"]), (g.E.inverse(), constants["B"])):
            frames.append((np.array(F.rotation), np.asarray(rFR, dtype=float), np.array(F.translation), np.asarray(rFt, dtype=float)))
    else:
        frames = [("product", g.C0, g.chain.base), ("inverse", g.E)]
    return Constants(
        np.stack([LR, rR], axis=-1),
        np.stack([Lt, rt], axis=-1),
        np.asarray(g.d, dtype=float),
        frames[0],
        frames[1],
        bool(g.chain.reversed),
        exact,
    )


def _frame(iv, f):
    """A frame of :class:`Constants` as 128-bit intervals: rotation rows, translation."""
    if isinstance(f[0], str) and f[0] == "product":  # C0^-1 base = (C0R^T bR, C0R^T (bt - C0t))
        C0, b = f[1], f[2]
        cR = [[iv.mpf(float(C0.rotation[k, r])) for k in range(3)] for r in range(3)]  # rows of C0R^T
        bR, bt, ct = np.array(b.rotation), np.array(b.translation), np.array(C0.translation)
        R = [[sum((cR[r][k] * float(bR[k, c]) for k in range(3)), iv.mpf(0)) for c in range(3)] for r in range(3)]
        t = [sum((cR[r][k] * (iv.mpf(float(bt[k])) - float(ct[k])) for k in range(3)), iv.mpf(0)) for r in range(3)]
        return R, t
    if isinstance(f[0], str) and f[0] == "inverse":  # E^-1 = (ER^T, -ER^T Et)
        E = f[1]
        ER, Et = np.array(E.rotation), np.array(E.translation)
        R = [[iv.mpf(float(ER[c, r])) for c in range(3)] for r in range(3)]
        t = [-sum((R[r][k] * float(Et[k]) for k in range(3)), iv.mpf(0)) for r in range(3)]
        return R, t
    Rm, Rr, tm, tr = f
    R = [[iv.mpf(float(Rm[r, c])) + iv.mpf([-float(Rr[r, c]), float(Rr[r, c])]) for c in range(3)] for r in range(3)]
    t = [iv.mpf(float(tm[r])) + iv.mpf([-float(tr[r]), float(tr[r])]) for r in range(3)]
    return R, t


def _goal(iv, V, cs: Constants):
    """``G = A M B`` for the goal ``M`` of XYZQUAT ``V`` (the rotation that of ``q / |q|``,
    inverted first for a reversed chain), in 128-bit intervals: columns, translation (the
    formula of :func:`kinbox.search.cf_certify.goal_enclosure`)."""
    x, y, z, w = (iv.mpf(float(v)) for v in V[3:7])
    s = 2 / (x * x + y * y + z * z + w * w)
    e = [
        [1 - s * (y * y + z * z), s * (x * y - z * w), s * (x * z + y * w)],
        [s * (x * y + z * w), 1 - s * (x * x + z * z), s * (y * z - x * w)],
        [s * (x * z - y * w), s * (y * z + x * w), 1 - s * (x * x + y * y)],
    ]
    if cs.reversed:
        M = [[e[c][r] for c in range(3)] for r in range(3)]
        mt = [-sum((M[r][k] * float(V[k]) for k in range(3)), iv.mpf(0)) for r in range(3)]
    else:
        M = e
        mt = [iv.mpf(float(V[r])) for r in range(3)]
    if cs.exact is not None:
        AR, At, BR, Bt = cs.exact["A"].R, cs.exact["A"].t, cs.exact["B"].R, cs.exact["B"].t
    else:
        AR, At = _frame(iv, cs.A)
        BR, Bt = _frame(iv, cs.B)

    def mm(P, Q):
        return [[sum((P[r][k] * Q[k][c] for k in range(3)), iv.mpf(0)) for c in range(3)] for r in range(3)]

    def mv(P, v):
        return [sum((P[r][k] * v[k] for k in range(3)), iv.mpf(0)) for r in range(3)]

    G = mm(mm(AR, M), BR)
    u = [a + b for a, b in zip(mt, mv(M, Bt))]
    gt = [a + b for a, b in zip(At, mv(AR, u))]
    return [[G[r][k] for r in range(3)] for k in range(3)], gt


def taylor_model(cs: Constants, V: np.ndarray, c: np.ndarray) -> Model:
    """:class:`Model` of the six-angle system of :mod:`kinbox.search.cf_certify` for the goal
    ``V`` (XYZQUAT as given) at the angles ``c``, with the arm's constants ``cs``."""
    from mpmath import iv

    LR, Lt, d = cs.LR, cs.Lt, cs.d
    old = iv.prec
    iv.prec = PREC
    try:

        def mr(m, r):
            return iv.mpf([float(m), float(m)]) + iv.mpf([-float(r), float(r)])

        g, gt = _goal(iv, V, cs)
        one, zero = iv.mpf(1), iv.mpf(0)
        C = [[one if k == r else zero for r in range(3)] for k in range(3)]  # columns
        t = [zero, zero, zero]
        w, o = [], []
        for i in range(6):
            w.append(list(C[2]))
            o.append(list(t))
            th = iv.mpf([float(c[i]), float(c[i])])
            co, si = iv.cos(th), iv.sin(th)
            C = [[co * C[0][r] + si * C[1][r] for r in range(3)], [co * C[1][r] - si * C[0][r] for r in range(3)], C[2]]
            if d[i] != 0.0:
                t = [t[r] + float(d[i]) * C[2][r] for r in range(3)]
            if i == 5:
                break
            if cs.exact is not None:
                L = cs.exact["exact_links"][i]
                lt, lr = L.t, L.R
            else:
                lt = [mr(Lt[i, k, 0], Lt[i, k, 1]) for k in range(3)]
                lr = [[mr(LR[i, k, cc, 0], LR[i, k, cc, 1]) for cc in range(3)] for k in range(3)]
            t = [t[r] + lt[0] * C[0][r] + lt[1] * C[1][r] + lt[2] * C[2][r] for r in range(3)]
            C = [[lr[0][cc] * C[0][r] + lr[1][cc] * C[1][r] + lr[2][cc] * C[2][r] for r in range(3)] for cc in range(3)]
        p = t
        F = [p[r] - gt[r] for r in range(3)]
        acc = [zero, zero, zero]
        for k in range(3):
            x = _cross(g[k], C[k])
            acc = [acc[q] + x[q] for q in range(3)]
        F += [acc[q] / 2 for q in range(3)]
        trace = sum((g[k][r] * C[k][r] for k in range(3) for r in range(3)), zero)
        Dup = 0.0
        for k in range(6):
            Dup = max(Dup, float(iv.sqrt(sum(((p[r] - o[k][r]) ** 2 for r in range(3)), zero)).b))
        po = [[p[r] - o[j][r] for r in range(3)] for j in range(6)]
        wxpo = [_cross(w[j], po[j]) for j in range(6)]  # d p / d theta_j
        wxr = [[_cross(w[j], C[k]) for k in range(3)] for j in range(6)]  # d r_k / d theta_j

        def orient(cols):  # 1/2 sum_k g_k x cols_k
            s = [zero, zero, zero]
            for k in range(3):
                x = _cross(g[k], cols[k])
                s = [s[q] + x[q] for q in range(3)]
            return [s[q] / 2 for q in range(3)]

        J = [[None] * 6 for _ in range(6)]
        for j in range(6):
            col = wxpo[j] + orient(wxr[j])
            for q in range(6):
                J[q][j] = col[q]
        H = [[[None] * 6 for _ in range(6)] for _ in range(6)]
        for i in range(6):
            for j in range(i, 6):  # the joint i nearer the base: it turns joint j's terms
                col = _cross(w[i], wxpo[j]) + orient([_cross(w[i], wxr[j][k]) for k in range(3)])
                for q in range(6):
                    H[q][j][i] = H[q][i][j] = col[q]

        def lohi(xs):
            a = np.array([float(x.a) for x in xs])
            b = np.array([float(x.b) for x in xs])
            return _out(a, b)  # float() rounds to nearest: one more step out

        Fi = lohi(F)
        Ji = tuple(v.reshape(6, 6) for v in lohi([J[q][j] for q in range(6) for j in range(6)]))
        Hi = tuple(v.reshape(6, 6, 6) for v in lohi([H[q][j][i] for q in range(6) for j in range(6) for i in range(6)]))
        Dup = float(np.nextafter(Dup, np.inf))
        tr = float(np.nextafter(float(trace.a), -np.inf))
    finally:
        iv.prec = old
    return Model(np.asarray(c, dtype=float).copy(), Fi, Ji, Hi, Dup, tr)


# -- the model over boxes -----------------------------------------------------------------------------
def _offset(model: Model, lo, hi):
    """The boxes ``[lo, hi]`` (N, 6) of the variables ``z`` and a bound of ``|theta - c|_1``
    over each (N,)."""
    l1 = np.sum(model.n * np.maximum(np.abs(lo), np.abs(hi)), axis=-1) * (1.0 + 2.0**-40)
    return (lo, hi), np.nextafter(l1, np.inf)


def f_at(model: Model, m: np.ndarray):
    """Enclosure of ``F`` at the points ``m`` (N, 6): the model's value there."""
    d, l1 = _offset(model, m, m)
    F0 = (np.broadcast_to(model.F[0], m.shape), np.broadcast_to(model.F[1], m.shape))
    lin = _sum(_mul((model.J[0][None], model.J[1][None]), (d[0][:, None, :], d[1][:, None, :])), axis=2)
    # 1/2 d^T H_q d: (H d) first, then with d
    Hd = _sum(_mul((model.H[0][None], model.H[1][None]), (d[0][:, None, None, :], d[1][:, None, None, :])), axis=3)  # (N,6,6)
    quad = _sum(_mul(Hd, (d[0][:, None, :], d[1][:, None, :])), axis=2)
    quad = _mul(quad, (np.full(1, 0.5), np.full(1, 0.5)))
    rem = _pm(model.m3(l1) * (l1**3)[:, None] / 6.0 * (1.0 + 2.0**-40))
    return _add(_add(_add(F0, lin), quad), rem)


def precondition(model: Model, W: np.ndarray):
    """``W J(c)`` (6, 6) and ``W H_i(c)`` ((6, 6, 6): ``[r, j, i]``) as intervals, for
    :func:`wj_over`."""
    Wi = (W, W)
    WJ = _sum(_mul((Wi[0][:, :, None], Wi[1][:, :, None]), (model.J[0][None], model.J[1][None])), axis=1)
    WH = _sum(_mul((Wi[0][:, :, None, None], Wi[1][:, :, None, None]), (model.H[0][None], model.H[1][None])), axis=1)
    return WJ, WH, np.abs(W)


def wj_over(model: Model, pre, lo, hi):
    """Enclosure of ``W J(theta)`` over each box ``[lo, hi]`` (N, 6): ``W J(c) + sum_i W H_i(c)
    (X_i - c_i) +- |W| M3 |X - c|_1^2 / 2``."""
    WJ, WH, aW = pre
    d, l1 = _offset(model, lo, hi)
    lin = _sum(_mul((WH[0][None], WH[1][None]), (d[0][:, None, None, :], d[1][:, None, None, :])), axis=3)
    # J(theta) B: each entry of J within M3_q |theta - c|_1^2 / 2, times column j's 1-norm
    rem = (model.m3(l1) * (l1**2)[:, None] / 2.0) * (1.0 + 2.0**-40)  # (N, 6) per row of J
    wrem = _pm(np.einsum("rq,nq,j->nrj", aW, rem, model.n) * (1.0 + 2.0**-30))
    out = _add((WJ[0][None], WJ[1][None]), lin)
    return _add(out, wrem)


def krawczyk(model: Model, m: np.ndarray, rad: np.ndarray):
    """Krawczyk's test on the box ``m +- rad`` with ``Y ~ J(m)^-1``: ``(lo, hi)`` of ``K(X)``
    if it lies inside the box (exactly one zero of ``F`` there), else None."""
    lo, hi = _out(m - rad, m + rad)
    Jm = 0.5 * (model.J[0] + model.J[1]) + np.einsum("qji,i->qj", 0.5 * (model.H[0] + model.H[1]), m)
    try:
        Y = np.linalg.inv(Jm)
    except np.linalg.LinAlgError:
        return None
    if not np.all(np.isfinite(Y)):
        return None
    pre = precondition(model, Y)
    F = f_at(model, m[None])
    YF = _sum(_mul((Y[None], Y[None]), (F[0][:, None, :], F[1][:, None, :])), axis=2)
    YJ = wj_over(model, pre, lo[None], hi[None])
    eye = np.eye(6)[None]
    IYJ = _sub((eye, eye), YJ)
    xm = _sub((lo[None], hi[None]), (m[None], m[None]))
    mv = _sum(_mul(IYJ, (xm[0][:, None, :], xm[1][:, None, :])), axis=2)
    K = _add(_sub((m[None], m[None]), YF), mv)
    Klo, Khi = K[0][0], K[1][0]
    if np.all(Klo > lo) and np.all(Khi < hi):
        return Klo, Khi
    return None


def excluded(model: Model, pre, W: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Per box ``[lo, hi]`` (N, 6): proven to hold no zero of ``F`` (the mean-value form of
    ``W F``: some row of ``W F(m) + W J(X) (X - m)`` misses 0)."""
    m = 0.5 * lo + 0.5 * hi
    F = f_at(model, m)
    WF = _sum(_mul((W[None], W[None]), (F[0][:, None, :], F[1][:, None, :])), axis=2)
    WJ = wj_over(model, pre, lo, hi)
    xm = _sub((lo, hi), (m, m))
    mv = _sum(_mul(WJ, (xm[0][:, None, :], xm[1][:, None, :])), axis=2)
    G = _add(WF, mv)
    return np.any((G[0] > 0.0) | (G[1] < 0.0), axis=1)


# -- the pair -----------------------------------------------------------------------------------------
@dataclass
class Separated:
    """Two roots, each proven alone in its box (geometry angles): points ``theta`` (2, 6),
    Krawczyk's boxes ``lo``/``hi`` (2, 6) (``K(X)``, inside the proof boxes), and the work done."""

    theta: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    boxes: int


def newton_on_model(model: Model, x: np.ndarray, steps: int = NEWTON_STEPS) -> np.ndarray | None:
    """``steps`` Newton steps on the model's midpoint Taylor polynomial from ``x`` (None if a
    step fails or leaves the finite numbers)."""
    Fm = 0.5 * (model.F[0] + model.F[1])
    Jm = 0.5 * (model.J[0] + model.J[1])
    Hm = 0.5 * (model.H[0] + model.H[1])
    for _ in range(steps):
        d = x
        f = Fm + Jm @ d + 0.5 * np.einsum("qji,j,i->q", Hm, d, d)
        J = Jm + np.einsum("qji,i->qj", Hm, d)
        try:
            step = np.linalg.solve(J, f)
        except np.linalg.LinAlgError:
            return None
        x = x - step
        if not np.all(np.isfinite(x)):
            return None
    return x


def _pair(model: Model) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """The two real roots of the model next to ``c`` and the near-null direction, or None (a
    complex pair, or Newton not converging to two points)."""
    Fm = 0.5 * (model.F[0] + model.F[1])
    Jm = 0.5 * (model.J[0] + model.J[1])
    Hm = 0.5 * (model.H[0] + model.H[1])
    U, S, Vt = np.linalg.svd(Jm)
    v, u = Vt[-1], U[:, -1]
    # the other directions solved to first order: F(c + t v + e) ~ 0, then u^T F along t
    # g(t) = g0 + g1 t + g2 t^2 with the transverse correction of the linear part
    e0 = -sum(Vt[i] * (U[:, i] @ Fm) / S[i] for i in range(5))  # F's regular part solved to first order
    g0 = u @ (Fm + Jm @ e0 + 0.5 * np.einsum("qji,j,i->q", Hm, e0, e0))
    g1 = u @ (Jm @ v + np.einsum("qji,j,i->q", Hm, v, e0))
    g2 = 0.5 * u @ np.einsum("qji,j,i->q", Hm, v, v)
    disc = g1 * g1 - 4.0 * g0 * g2
    if not disc > 0.0 or g2 == 0.0:
        return None
    sq = math.sqrt(disc)
    roots = []
    for t in ((-g1 - sq) / (2.0 * g2), (-g1 + sq) / (2.0 * g2)):
        x = newton_on_model(model, e0 + t * v)
        if x is None:
            return None
        roots.append(x)
    a, b = roots
    if not np.max(np.abs(a - b)) > 0.0:
        return None
    return a, b, v


def _to_z(model: Model, region: list) -> tuple[np.ndarray, np.ndarray]:
    """Boxes of ``z`` holding ``B^-1 (theta - c)`` for every ``theta`` of each region box:
    ``B^T (theta - c)`` widened by ``delta / (1 - delta)`` of its magnitude, ``delta`` a bound
    of ``|B^T B - I|_inf`` (``B^-1 = (B^T B)^-1 B^T``)."""
    Bt = model.B.T
    P = _sum(_mul((Bt[:, :, None], Bt[:, :, None]), (model.B[None], model.B[None])), axis=1)
    eye = np.eye(6)
    E = _sub(P, (eye, eye))
    delta = float(np.max(np.sum(_mag(E), axis=1))) * (1.0 + 2.0**-40)
    if not delta < 0.5:
        raise ValueError("basis far from orthogonal")
    lo = np.array([r[0] for r in region])
    hi = np.array([r[1] for r in region])
    d = (_sub((lo, lo), (model.c[None], model.c[None]))[0], _sub((hi, hi), (model.c[None], model.c[None]))[1])
    z = _sum(_mul((Bt[None], Bt[None]), (d[0][:, None, :], d[1][:, None, :])), axis=2)
    w = np.max(_mag(z), axis=1) * (delta / (1.0 - delta)) * (1.0 + 2.0**-30)
    return _out(z[0] - w[:, None], z[1] + w[:, None])


def separate_pair(cs: Constants, V: np.ndarray, c: np.ndarray, region: list[tuple[np.ndarray, np.ndarray]]) -> Separated | None:
    """Two certified roots in place of a cluster of multiplicity 2 (module docstring): ``c``
    its point (geometry angles), ``region`` the boxes (geometry angles, each holding the
    angles of one of the cluster's boxes) known to hold every root the cluster stands for.
    None unless both roots are proven, their boxes disjoint and inside the region, and the
    region proven to hold no other root. The work is done in the variables ``z`` of ``theta =
    c + B z``, ``B`` the right singular vectors of ``J(c)``: there the near-null direction is
    one variable, so the boxes' spread of ``J`` along it is not summed with the others'."""
    if not region:
        return None
    model0 = taylor_model(cs, V, c)
    l1max = max(float(np.sum(np.maximum(np.abs(lo - c), np.abs(hi - c)))) for lo, hi in region)
    # a half turn from the goal (trace -1), where F has zeros that are no roots, ruled out
    # over the region (trace falls by at most sqrt 6 per radian)
    if not model0.trace - 3.0 * l1max > 0.5 or not l1max < 1e-3:
        return None
    _, _, Vt = np.linalg.svd(0.5 * (model0.J[0] + model0.J[1]))
    model = model0.rotated(np.ascontiguousarray(Vt.T))
    zlo, zhi = _to_z(model, region)
    got = _pair(model)
    if got is None:
        return None
    a, b, v = got
    dist = float(abs(v @ (a - b)))
    proofs = []
    for x in (a, b):
        found = None
        for fl in FLOORS:
            for f in GROWTH:
                rad = f * dist * (np.abs(v) + fl)
                k = krawczyk(model, x, rad)
                if k is not None:
                    found = (x, x - rad, x + rad, k)
                    break
            if found is not None:
                break
        if found is None:
            return None
        proofs.append(found)
    (xa, la, ha, ka), (xb, lb, hb, kb) = proofs
    # the roots' boxes in the angles: disjoint, each inside a box of the region
    tl, th = model.theta(np.array([ka[0], kb[0]]), np.array([ka[1], kb[1]]))
    if not np.any((th[0] < tl[1]) | (th[1] < tl[0])):
        return None
    for r in range(2):
        if not any(np.all((rl <= tl[r]) & (th[r] <= rh)) for rl, rh in region):
            return None
    # the region holds no root outside the two proof boxes: bisection, a counter its budget
    U, S, _ = np.linalg.svd(0.5 * (model.J[0] + model.J[1]))
    W = np.diag(np.concatenate([1.0 / S[:5], [1.0]])) @ U.T
    pre = precondition(model, W)
    pending = [(zlo[k], zhi[k]) for k in range(len(zlo))]
    seen = 0
    while pending:
        if seen + len(pending) > MAX_BOXES:
            return None
        seen += len(pending)
        lo = np.array([p[0] for p in pending])
        hi = np.array([p[1] for p in pending])
        inside = np.all((lo >= la) & (hi <= ha), axis=1) | np.all((lo >= lb) & (hi <= hb), axis=1)
        out = excluded(model, pre, W, lo, hi)
        pending = []
        for n in np.flatnonzero(~(inside | out)):
            w = hi[n] - lo[n]
            k = int(np.argmax(w))
            mid = 0.5 * lo[n, k] + 0.5 * hi[n, k]
            if not lo[n, k] < mid < hi[n, k]:
                return None
            h1 = hi[n].copy()
            h1[k] = mid
            l2 = lo[n].copy()
            l2[k] = mid
            pending += [(lo[n], h1), (l2, hi[n])]
    points = c[None] + np.array([xa, xb]) @ model.B.T
    return Separated(points, tl, th, seen)
