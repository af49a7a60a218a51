"""General 6R inverse kinematics by elimination and eigenvalues, proven complete or nothing.

The elimination of Raghavan and Roth (1993) in the matrix form of Manocha and Canny (1994),
written from the arm's canonical frames (:mod:`kinbox.formulation.arm`): the goal
``G = Rz(t1) L1 Rz(t2) Tz(d2) L2 ... L5 Rz(t6) Tz(d6)`` is rearranged as

    Tz(d2) L2 A3 A4 A5 = Rz(t2)^T L1^-1 Rz(t1)^T G A6^-1,

whose left side depends on ``t3, t4, t5`` and whose right side on ``t1, t2`` only. Of both
sides' point ``p`` and direction ``l`` (the image of the origin and of ``e_z``) the 14
quantities ``p, l, p.p, p.l, p x l, l (p.p) - 2 p (p.l)`` are taken. Written with the
identities of rotations (``R a x R b = R (a x b)``, ``a x (b x c) = b (a.c) - c (a.b)``) each is
a sum of products of factors in distinct angles, so that, as polynomials in ``(cos, sin)`` of
the angles, no square of an angle's cosine or sine ever appears (:func:`_lhs`, :func:`_rhs`):

    P(t3) X(t4, t5) = Q Y(t1, t2),

``X = (c4, s4, 1) x (c5, s5, 1)`` (9 monomials), ``Y`` the 8 non-constant monomials of
``(c1, s1, 1) x (c2, s2, 1)``, the entries of ``P`` affine in ``(c3, s3)``. Eliminating ``Y``
with 8 rows of ``Q`` leaves 6 equations ``S(t3) X = 0``; with the half-angle tangents ``x4, x5``
(homogeneous: ``x4 = tan(t4/2)`` at infinity is a point too) and the equations once more times
``x4``, a 12 x 12 matrix polynomial ``M(x3) = A0 + A1 x3 + A2 x3^2`` singular at every
``x3 = tan(t3 / 2)`` of a solution. ``det M`` has degree 24 and the factor ``(1 + x3^2)^4``
(``M(+-i)`` has a kernel of dimension 4 whatever the arm: the points at infinity of the
circle ``c3^2 + s3^2 = 1``), so its other roots, the roots of ``q = det M / (1 + x3^2)^4``, are at
most 16.

The eigenvalues of the pencil (numpy/scipy, floats) only *propose*. The proof, in outward
rounded midpoint-radius arithmetic on the goal's numbers as intervals:

1. ``P``, ``Q``, the elimination (``Z = Q_b Q_a^-1`` enclosed with a verified inverse: this also
   proves that ``Q`` has rank 8) and ``M``'s coefficients are enclosed for every goal in the
   goal's enclosure and every arm whose links lie within the radii of the model's exact links
   (:func:`link_radii`), the pose and the model as given among them
   (``tests/search/test_eigen6r_radii.py``);
2. for 16 candidate eigenvalues, a Krawczyk test on ``(lambda, v) -> M(lambda) v`` (``v_j = 1``)
   in complex disc arithmetic proves one eigenvalue in a disc about each; the discs are pairwise
   disjoint and hold neither ``i`` nor ``-i``. A disc with a real centre is symmetric about the
   real axis; a disc off the real axis proves its conjugate disc too. The discs then hold 16
   distinct roots of ``q``, which has at most 16: each holds exactly one, simple, the one in a
   symmetric disc is real (its conjugate is a root in the same disc), and ``q`` has no other
   root. ``deg q = 16`` also proves ``det A2 != 0``: no solution has ``t3 = pi`` (``x3`` at
   infinity, where ``A2`` would be singular);
3. a simple eigenvalue has a kernel of dimension one: ``x4, x5`` follow (the monomials of a
   point determine it), then ``Y`` (``Q`` has rank 8), so ``t1, t2``, and ``t6``: each real
   eigenvalue stands for at most one solution, and every real solution for one real eigenvalue.

Each real eigenvalue's solution, found by back substitution, is certified by Krawczyk in the
six joint angles on the pose as given (:func:`kinbox.search.cf_certify.krawczyk6`, as the
closed form's batch does), and the proof box's ``x3`` must lie in its eigenvalue's disc (so
the proof boxes are disjoint). Then every real solution is one of the certified roots and the
answer is complete. Anything short of that -- fewer than 16 eigenvalues proven, a disc holding
``+-i``, a root not certified -- and the pose goes to the branch and prune. The identities
above hold for rotations: they hold at the model's exact links, which the binary64 link
matrices and their radii enclose.

Per pose, the steps run compiled (:mod:`kinbox.search.eigen6r_kernel`, :func:`certify`) around
numpy's eigen-solver; the numpy functions here (:meth:`Eigen6R.matrices`, :func:`prove_count`,
:func:`certify_reference`, which certifies on the kinbox system) are the readable reference
they are checked against, and give the answer's boxes in the system's variables on demand.
``tests/search/test_eigen6r.py`` compares the answers with the branch and prune's.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg

from .. import interval as ivl
from . import eigen6r_kernel as K
from . import jit as nb
from .certify import _K_UNIQUE, _jacobian_into, _krawczyk_full, _lu_solve
from .closed_form import _encode
from .template_rows import bind_rows, boxes_apart, core_row

U = ivl.U
TINY = ivl.TINY
#: the degree of the general 6R problem: roots of ``q = det M / (1 + x3^2)^4``
DEGREE = 16
#: half-width of an eigenvalue's disc, relative to ``1 + |lambda|``: wider than the proof box
#: of its root's ``x3`` (:data:`kinbox.search.closed_form.PROOF_RADIUS`), narrower than the
#: gap between eigenvalues of generic poses
DISC_L = 1e-7
#: the eight eigenvalues of the factor (1 + x3^2)^4 lie this close to +-i (a fourfold
#: eigenvalue computed in floating point moves by about the fourth root of the rounding)
SPURIOUS = 1e-2
#: half-width of the eigenvector's entries in the proof, relative to ``1 + |v_i|``
DISC_V = 1e-7


def _gam(n: float) -> float:
    return n * U / (1.0 - n * U)


def _bump(r, n: int = 4):
    """A radius computed in floating point from ``n`` non-negative terms, made an upper bound."""
    return r * (1.0 + 2.0 * _gam(n + 2)) + TINY


_G5 = 2.0 * _gam(5)


def _tight(r, live):
    """:func:`_bump` where a result is not exactly zero (``live``: some operand is not an exact
    zero; a product or sum of exact zeros is an exact zero, and keeps the polynomial's support)."""
    return np.where(live, r * (1.0 + 2.0 * _gam(6)) + TINY, 0.0)


# ----------------------------------------------------------------------------------------------
# polynomials in (cos, sin) of angles, multilinear: a coefficient tensor over the basis
# (c, s, 1) of each angle, midpoint and radius
# ----------------------------------------------------------------------------------------------
_C, _S, _ONE = 0, 1, 2


class Trig:
    """A multilinear polynomial in ``(c_k, s_k)`` of ``k`` angles: coefficients ``m +- r`` over
    the basis ``(c, s, 1)`` of each angle (axis ``k``)."""

    __slots__ = ("m", "r")

    def __init__(self, m: np.ndarray, r: np.ndarray):
        self.m = m
        self.r = r

    @staticmethod
    def const(value: float, naxes: int, rad: float = 0.0) -> Trig:
        m = np.zeros((3,) * naxes)
        r = np.zeros((3,) * naxes)
        m[(_ONE,) * naxes] = value
        r[(_ONE,) * naxes] = rad
        return Trig(m, r)

    def deps(self) -> set[int]:
        out = set()
        k = self.m.ndim
        for ax in range(k):
            idx = tuple(slice(0, 2) if i == ax else slice(None) for i in range(k))
            if np.any(self.m[idx] != 0.0) or np.any(self.r[idx] != 0.0):
                out.add(ax)
        return out

    def support(self) -> np.ndarray:
        return (self.m != 0.0) | (self.r != 0.0)

    def __add__(self, o: Trig) -> Trig:
        m = self.m + o.m
        return Trig(m, _tight(self.r + o.r + U * np.abs(m), self.support() | o.support()))

    def __sub__(self, o: Trig) -> Trig:
        m = self.m - o.m
        return Trig(m, _tight(self.r + o.r + U * np.abs(m), self.support() | o.support()))

    def __neg__(self) -> Trig:
        return Trig(-self.m, self.r)

    def scale(self, c: float, cr: float = 0.0) -> Trig:
        """``c * self`` for ``c`` a float, or the interval ``c +- cr``."""
        m = c * self.m
        if cr == 0.0:
            return Trig(m, _tight(abs(c) * self.r + U * np.abs(m), self.support() if c != 0.0 else np.zeros(m.shape, dtype=bool)))
        r = abs(c) * self.r + cr * (np.abs(self.m) + self.r) + U * np.abs(m)
        return Trig(m, _tight(r, self.support()))

    def __mul__(self, o: Trig) -> Trig:
        """The product of polynomials in disjoint sets of angles (no square appears)."""
        da, db = self.deps(), o.deps()
        if da & db:
            raise ValueError("product of polynomials in the same angle")
        k = self.m.ndim
        ia = tuple(slice(None) if i in da else slice(_ONE, _ONE + 1) for i in range(k))
        ib = tuple(slice(None) if i in db else slice(_ONE, _ONE + 1) for i in range(k))
        am, ar, bm, br = self.m[ia], self.r[ia], o.m[ib], o.r[ib]
        pm = am * bm
        live = ((am != 0.0) | (ar != 0.0)) & ((bm != 0.0) | (br != 0.0))
        pr = _tight(np.abs(am) * br + ar * np.abs(bm) + ar * br + U * np.abs(pm), live)
        m = np.zeros_like(self.m)
        r = np.zeros_like(self.r)
        io = tuple(slice(None) if i in da | db else slice(_ONE, _ONE + 1) for i in range(k))
        m[io] = pm
        r[io] = pr
        return Trig(m, r)

    def times_basis(self, ax: int, which: int) -> Trig:
        """``c_ax * self`` (``which = 0``) or ``s_ax * self`` (1), ``self`` free of angle ``ax``: exact."""
        k = self.m.ndim
        src = tuple(_ONE if i == ax else slice(None) for i in range(k))
        dst = tuple(which if i == ax else slice(None) for i in range(k))
        m = np.zeros_like(self.m)
        r = np.zeros_like(self.r)
        m[dst] = self.m[src]
        r[dst] = self.r[src]
        return Trig(m, r)


Vec = list  # three Trig


def _ivec(mid, rad, naxes: int) -> Vec:
    return [Trig.const(float(mid[i]), naxes, float(rad[i])) for i in range(3)]


def _vadd(a: Vec, b: Vec) -> Vec:
    return [a[i] + b[i] for i in range(3)]


def _vsub(a: Vec, b: Vec) -> Vec:
    return [a[i] - b[i] for i in range(3)]


def _vscale(c: float, a: Vec) -> Vec:
    return [x.scale(c) for x in a]


def _vtimes(s: Trig, a: Vec) -> Vec:
    return [s * x for x in a]


def _dot(a: Vec, b: Vec) -> Trig:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a: Vec, b: Vec) -> Vec:
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _matvec(R: np.ndarray, v: Vec, Rr: np.ndarray | None = None) -> Vec:
    """``R v`` for the matrix ``R +- Rr`` (entrywise radii; None: exact)."""
    out = []
    for i in range(3):
        acc = None
        for j in range(3):
            rr = 0.0 if Rr is None else float(Rr[i, j])
            if R[i, j] == 0.0 and rr == 0.0:
                continue
            t = v[j].scale(float(R[i, j]), rr)
            acc = t if acc is None else acc + t
        out.append(acc if acc is not None else v[0].scale(0.0))
    return out


def _rz(ax: int, v: Vec, transpose: bool = False) -> Vec:
    """``Rz(t_ax) v`` (or its transpose) for ``v`` free of angle ``ax``."""
    c0, s0 = v[0].times_basis(ax, _C), v[0].times_basis(ax, _S)
    c1, s1 = v[1].times_basis(ax, _C), v[1].times_basis(ax, _S)
    if transpose:
        return [c0 + s1, c1 - s0, v[2]]
    return [c0 - s1, s0 + c1, v[2]]


def _quantities(p: Vec, l: Vec, pp: Trig, pl: Trig, pxl: Vec, last: Vec) -> list[Trig]:
    return [*p, *l, pp, pl, *pxl, *last]


def _offset(d: float, t: np.ndarray, rt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``d e_z + t`` for a link's translation ``t +- rt`` (exact ``d``): midpoint and radius
    (the sum in ``z`` rounded once)."""
    m = np.array([t[0], t[1], d + t[2]], dtype=float)
    r = np.array(rt, dtype=float).copy()
    if d != 0.0 and t[2] != 0.0:
        r[2] = _bump(r[2] + U * abs(m[2]))
    return m, r


def _lhs(LR, Lt, d, rR=None, rt=None) -> list[Trig]:
    """The 14 quantities of ``Tz(d2) L2 A3 A4 A5`` as polynomials in angles 3, 4, 5 (axes 0, 1, 2),
    for the links ``LR +- rR``, ``Lt +- rt`` (entrywise radii: every arm within them whose link
    rotations are rotations; None: the binary64 numbers as exact): the identities of rotations
    used below hold at the exact links, so the enclosure holds their quantities
    (``tests/search/test_eigen6r_radii.py``)."""
    n = 3
    rR = np.zeros_like(LR) if rR is None else rR
    rt = np.zeros_like(Lt) if rt is None else rt
    u = _ivec(*_offset(d[2], Lt[2], rt[2]), n)
    e = _ivec(*_offset(d[3], Lt[3], rt[3]), n)
    f = _ivec(*_offset(d[4], Lt[4], rt[4]), n)
    g = _ivec(LR[4][:, 2], rR[4][:, 2], n)  # a column of L5's rotation
    gxf = _cross(g, f)
    fxg = [-x for x in gxf]
    ee_ff = _dot(e, e) + _dot(f, f)
    fg = _dot(f, g)

    def R4(v):
        return _matvec(LR[2], _rz(1, v), rR[2])

    def R5(v):
        return _matvec(LR[3], _rz(2, v), rR[3])

    R5f, R5g = R5(f), R5(g)
    w = _vadd(e, R5f)  # t5
    m = R5g
    wm = _dot(e, R5g) + fg
    wxm = _vadd(_cross(e, R5g), R5(fxg))
    R4m = R4(m)
    p1 = _vadd(u, R4(w))  # p' (t4, t5)
    l1 = R4m
    uu = _dot(u, u)
    ww = ee_ff + _dot(e, R5f).scale(2.0)
    pp1 = uu + ww + _dot(u, R4(w)).scale(2.0)
    uR4m = _dot(u, R4m)
    pl1 = uR4m + wm
    pxl1 = _vadd(_cross(u, R4m), R4(wxm))
    inner5 = _vadd(
        _vadd(_vtimes(ee_ff, R5g), _vscale(2.0, _cross(e, R5(gxf)))),
        _vsub(_vscale(-2.0, _vtimes(_dot(e, R5g), e)), _vadd(_vscale(2.0, _vtimes(fg, e)), _vscale(2.0, _vtimes(fg, R5f)))),
    )  # m |w|^2 - 2 w (w.m)
    mxw = [-x for x in wxm]
    last1 = _vadd(
        _vadd(_vtimes(uu, R4m), _vscale(-2.0, _vtimes(uR4m, u))),
        _vadd(_vadd(_vscale(-2.0, _vtimes(wm, u)), _vscale(2.0, _cross(u, R4(mxw)))), R4(inner5)),
    )  # l' (p'.p') - 2 p' (p'.l')
    k = _ivec(*_offset(d[1], Lt[1], rt[1]), n)

    def S(v):
        return _matvec(LR[1], _rz(0, v), rR[1])

    Sp, Sl = S(p1), S(l1)
    kk = _dot(k, k)
    p = _vadd(k, Sp)
    pp = kk + pp1 + _dot(k, Sp).scale(2.0)
    kSl = _dot(k, Sl)
    pl = kSl + pl1
    pxl = _vadd(_cross(k, Sl), S(pxl1))
    lxp1 = [-x for x in pxl1]
    last = _vadd(
        _vadd(S(last1), _vtimes(kk, Sl)),
        _vsub(_vscale(2.0, _cross(k, S(lxp1))), _vadd(_vscale(2.0, _vtimes(kSl, k)), _vscale(2.0, _vtimes(pl1, k)))),
    )
    return _quantities(p, Sl, pp, pl, pxl, last)


class MR:
    """Midpoint-radius arrays (elementwise, broadcasting), outward rounded."""

    __slots__ = ("m", "r")

    def __init__(self, m, r):
        self.m = m
        self.r = r

    def __add__(self, o: MR) -> MR:
        m = self.m + o.m
        return MR(m, _bump(self.r + o.r + U * np.abs(m)))

    def __sub__(self, o: MR) -> MR:
        m = self.m - o.m
        return MR(m, _bump(self.r + o.r + U * np.abs(m)))

    def __mul__(self, o: MR) -> MR:
        m = self.m * o.m
        return MR(m, _bump(np.abs(self.m) * o.r + self.r * (np.abs(o.m) + o.r) + U * np.abs(m)))

    def scale(self, c: float, cr: float = 0.0) -> MR:
        """``c * self`` for ``c`` a float, or the interval ``c +- cr``."""
        m = c * self.m
        if cr == 0.0:
            return MR(m, _bump(abs(c) * self.r + U * np.abs(m)))
        return MR(m, _bump(abs(c) * self.r + cr * (np.abs(self.m) + self.r) + U * np.abs(m)))

    def fmat(self, M: np.ndarray) -> MR:
        """``M @ self`` along axis 0 for a float 3 x 3 ``M``."""
        m = M @ self.m
        aM = np.abs(M)
        return MR(m, _bump(aM @ (self.r + _G5 * np.abs(self.m)), 5))

    def __getitem__(self, k) -> MR:
        return MR(self.m[k], self.r[k])

    def plus_exact_product(self) -> MR:
        """``self`` as computed by one rounded product per entry: its rounding added to the radius."""
        return MR(self.m, _bump(self.r + U * np.abs(self.m)))


def _rzt1(v: MR) -> MR:
    """``Rz(t1)^T v`` of a constant vector: coefficients over ``(c1, s1, 1)`` (exact placement)."""
    m = np.zeros((3, 3))
    r = np.zeros((3, 3))
    m[0, 0], m[0, 1], m[1, 0], m[1, 1], m[2, 2] = v.m[0], v.m[1], v.m[1], -v.m[0], v.m[2]
    r[0, 0], r[0, 1], r[1, 0], r[1, 1], r[2, 2] = v.r[0], v.r[1], v.r[1], v.r[0], v.r[2]
    return MR(m, r)


def _cross_mr(a: MR, b: MR) -> MR:
    """Cross product along axis 0 (broadcasting the rest)."""
    i, j = [1, 2, 0], [2, 0, 1]
    return a[i] * b[j] - a[j] * b[i]


def _dot_mr(a: MR, b: MR) -> MR:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


#: the right side is linear in these quantities of the goal (:func:`_rhs_map`, :func:`_features`):
#: 1, p (3), l (3), p.p, p.l, p x l (3), l (p.p) (3), p (p.l) (3)
_F_ONE, _F_P, _F_L, _F_PP, _F_PL, _F_PXL, _F_LPP, _F_PPL, NFEAT = 0, 1, 4, 7, 8, 9, 12, 15, 18


def _feat_vec(first: int) -> MR:
    """The feature-linear vector whose component ``i`` is feature ``first + i``: (3, NFEAT)."""
    m = np.zeros((3, NFEAT))
    m[0, first], m[1, first + 1], m[2, first + 2] = 1.0, 1.0, 1.0
    return MR(m, np.zeros_like(m))


def _feat_scalar(f: int) -> MR:
    m = np.zeros(NFEAT)
    m[f] = 1.0
    return MR(m, np.zeros_like(m))


def _rzt1_f(v: MR) -> MR:
    """``Rz(t1)^T v`` of a feature-linear vector (3, F): (3 xyz, 3 basis (c1, s1, 1), F), exact."""
    sh = (3, 3) + v.m.shape[1:]
    m = np.zeros(sh)
    r = np.zeros(sh)
    m[0, 0], m[0, 1], m[1, 0], m[1, 1], m[2, 2] = v.m[0], v.m[1], v.m[1], -v.m[0], v.m[2]
    r[0, 0], r[0, 1], r[1, 0], r[1, 1], r[2, 2] = v.r[0], v.r[1], v.r[1], v.r[0], v.r[2]
    return MR(m, r)


def _fcross(a: np.ndarray, v: MR, ar: np.ndarray) -> MR:
    """``a x v`` for the vector ``a +- ar`` and a vector ``v`` (axis 0)."""
    i, j = [1, 2, 0], [2, 0, 1]
    A = a[:, None, None] if v.m.ndim == 3 else a[:, None]
    Ar = ar[:, None, None] if v.m.ndim == 3 else ar[:, None]

    def prod(x, y):  # A_x v_y
        return MR(A[x] * v.m[y], np.abs(A[x]) * v.r[y] + Ar[x] * (np.abs(v.m[y]) + v.r[y])).plus_exact_product()

    return prod(i, j) - prod(j, i)


def _fdot(a: np.ndarray, v: MR, ar: np.ndarray) -> MR:
    """``a . v`` for the vector ``a +- ar`` (axis 0 of ``v``)."""
    acc = None
    for i in range(3):
        t = v[i].scale(float(a[i]), float(ar[i]))
        acc = t if acc is None else acc + t
    assert acc is not None
    return acc


def _rhs_map(LR, Lt, rR=None, rt=None) -> tuple[np.ndarray, np.ndarray]:
    """The right side's 14 quantities over ``(c1, s1, 1) x (c2, s2, 1)`` as linear maps of the
    goal's features (``_F_*``): midpoints and radii (14, 9, NFEAT), from the link 1 numbers
    ``LR[0] +- rR[0]``, ``Lt[0] +- rt[0]`` (None: the binary64 numbers as exact).

    With ``q = Rz(t1)^T p``, ``n = Rz(t1)^T l``, ``e = -L1.t`` and ``T = Rz(t2)^T L1.R^T``:
    point ``T (q + e)``, direction ``T n``, ``p.p + e.e + 2 e.q``, ``p.l + e.n``, cross
    ``T (Rz(t1)^T (p x l) + e x n)``, and ``T (n (p.p + e.e) + 2 e x (n x q) - 2 q (p.l) - 2 e (p.l)
    - 2 e (e.n))`` with ``n x q = -Rz(t1)^T (p x l)``."""
    e = -np.asarray(Lt[0], dtype=float)
    er = np.zeros(3) if rt is None else np.asarray(rt[0], dtype=float)
    L1Tr = np.zeros((3, 3)) if rR is None else np.ascontiguousarray(np.asarray(rR[0], dtype=float).T)
    Ev = MR(e, er)
    ee = _dot_mr(Ev, Ev)
    one = _feat_scalar(_F_ONE)
    q = _rzt1_f(_feat_vec(_F_P))  # (3, 3, F)
    n = _rzt1_f(_feat_vec(_F_L))
    pxl = _rzt1_f(_feat_vec(_F_PXL))
    e_one = np.zeros((3, 3, NFEAT))
    e_one[:, 2, _F_ONE] = e
    e_one_r = np.zeros((3, 3, NFEAT))
    e_one_r[:, 2, _F_ONE] = er
    E = MR(e_one, e_one_r)  # e as a polynomial: at t1's "1", feature 1
    e_pl = np.zeros((3, 3, NFEAT))
    e_pl[:, 2, _F_PL] = e
    e_pl_r = np.zeros((3, 3, NFEAT))
    e_pl_r[:, 2, _F_PL] = er
    EPL = MR(e_pl, e_pl_r)
    en = _fdot(e, n, er)  # (3, F)
    eq = _fdot(e, q, er)
    Vp = q + E
    Vl = n
    Vpxl = pxl + _fcross(e, n, er)
    e_en = MR(
        e[:, None, None] * en.m[None], np.abs(e)[:, None, None] * en.r[None] + er[:, None, None] * (np.abs(en.m) + en.r)[None]
    ).plus_exact_product()
    Vlast = (
        _rzt1_f(_feat_vec(_F_LPP))
        + n * ee
        - _fcross(e, pxl, er).scale(2.0)
        - _rzt1_f(_feat_vec(_F_PPL)).scale(2.0)
        - EPL.scale(2.0)
        - e_en.scale(2.0)
    )
    L1T = np.ascontiguousarray(LR[0].T)

    def T(V: MR) -> tuple[np.ndarray, np.ndarray]:  # Rz(t2)^T L1^T V: (3 xyz, 9, F)
        am = np.tensordot(L1T, V.m, axes=1)
        ar = _bump(np.tensordot(np.abs(L1T), V.r + _G5 * np.abs(V.m), axes=1) + np.tensordot(L1Tr, np.abs(V.m) + V.r, axes=1), 8)
        m = np.zeros((3, 3, 3, NFEAT))
        r = np.zeros((3, 3, 3, NFEAT))
        m[0, :, 0], m[0, :, 1], m[1, :, 0], m[1, :, 1], m[2, :, 2] = am[0], am[1], am[1], -am[0], am[2]
        r[0, :, 0], r[0, :, 1], r[1, :, 0], r[1, :, 1], r[2, :, 2] = ar[0], ar[1], ar[1], ar[0], ar[2]
        return m.reshape(3, 9, NFEAT), r.reshape(3, 9, NFEAT)

    def scalar(sv: MR) -> tuple[np.ndarray, np.ndarray]:  # (3 basis of t1, F): at t2's "1"
        m = np.zeros((3, 3, NFEAT))
        r = np.zeros((3, 3, NFEAT))
        m[:, 2] = sv.m
        r[:, 2] = sv.r
        return m.reshape(1, 9, NFEAT), r.reshape(1, 9, NFEAT)

    def at_one(sv: MR) -> MR:  # a t1-free feature scalar (F,) as (3 basis, F)
        m = np.zeros((3, NFEAT))
        r = np.zeros((3, NFEAT))
        m[2], r[2] = sv.m, sv.r
        return MR(m, r)

    pp = at_one(_feat_scalar(_F_PP) + one * ee) + eq.scale(2.0)
    pl = at_one(_feat_scalar(_F_PL)) + en
    parts = [T(Vp), T(Vl), scalar(pp), scalar(pl), T(Vpxl), T(Vlast)]
    return np.concatenate([x[0] for x in parts]), np.concatenate([x[1] for x in parts])


def _features(ph, prad, lh, lrad) -> tuple[np.ndarray, np.ndarray]:
    """The goal's features (``_F_*``) of ``H``'s point ``ph +- prad`` and direction ``lh +- lrad``."""
    P = MR(np.asarray(ph, dtype=float), np.asarray(prad, dtype=float))
    L = MR(np.asarray(lh, dtype=float), np.asarray(lrad, dtype=float))
    pp = _dot_mr(P, P)
    pl = _dot_mr(P, L)
    pxl = _cross_mr(P, L)
    lpp = L * pp
    ppl = P * pl
    m = np.concatenate([[1.0], P.m, L.m, [pp.m], [pl.m], pxl.m, lpp.m, ppl.m])
    r = np.concatenate([[0.0], P.r, L.r, [pp.r], [pl.r], pxl.r, lpp.r, ppl.r])
    return m, r


def _rhs(LR, Lt, ph, prad, lh, lrad, rmap=None) -> tuple[np.ndarray, np.ndarray]:
    """The 14 quantities of ``Rz(t2)^T L1^-1 Rz(t1)^T H`` (``H``'s point ``ph +- prad`` and
    direction ``lh +- lrad``) over ``(c1, s1, 1) x (c2, s2, 1)``: midpoints and radii (14, 9)
    (``rmap``: :func:`_rhs_map` of the links, if computed already)."""
    Mm, Mr = _rhs_map(LR, Lt) if rmap is None else rmap
    fm, fr = _features(ph, prad, lh, lrad)
    Rm, Rr = _mm(Mm.reshape(-1, NFEAT), Mr.reshape(-1, NFEAT), fm[:, None], fr[:, None])
    return Rm.reshape(14, 9), Rr.reshape(14, 9)


# ----------------------------------------------------------------------------------------------
# midpoint-radius matrices (real or complex), rigorous products
# ----------------------------------------------------------------------------------------------
def _mm(am, ar, bm, br):
    """Enclosure of ``A B`` for ``A = am +- ar``, ``B = bm +- br`` (real or complex midpoints,
    real radii; batched over leading axes)."""
    n = am.shape[-1]
    cm = am @ bm
    aa, ab = np.abs(am), np.abs(bm)
    err = 2.0 * _gam(2 * n + 4) * (aa @ ab)
    r = aa @ br + ar @ (ab + br) + err
    return cm, _bump(r, 2 * n + 4) + n * TINY


def _mm_point(am, bm, br):
    """``A B`` for a point matrix ``A``."""
    n = am.shape[-1]
    cm = am @ bm
    aa = np.abs(am)
    r = aa @ (br + 2.0 * _gam(2 * n + 4) * np.abs(bm))
    return cm, _bump(r, 2 * n + 4) + n * TINY


def _madd(am, ar, bm, br, sign: float = 1.0):
    m = am + sign * bm
    return m, _bump(ar + br + 2.0 * U * np.abs(m))


# ----------------------------------------------------------------------------------------------
# one arm
# ----------------------------------------------------------------------------------------------
def _half_angle() -> np.ndarray:
    """``(c, s, 1) (1 + x^2) = T (1, x, x^2)``: rows c, s, 1."""
    return np.array([[1.0, 0.0, -1.0], [0.0, 2.0, 0.0], [1.0, 0.0, 1.0]])


_TH = _half_angle()
#: X basis (i4, i5) -> monomials x4^a x5^b, a, b in 0..2 (times (1 + x4^2)(1 + x5^2)): exact
_TX = np.einsum("ia,jb->ijab", _TH, _TH).reshape(9, 9)


def link_radii(geom, constants: dict | None) -> tuple[np.ndarray, np.ndarray]:
    """Entrywise bounds ``(rR, rt)`` (5, 3, 3), (5, 3) of the distance of the model's exact
    links to the binary64 ones (``constants``: :attr:`kinbox.formulation.arm.ArmTemplate.constants`;
    None: zeros, the binary64 links taken as exact)."""
    rR = np.zeros((len(geom.links), 3, 3))
    rt = np.zeros((len(geom.links), 3))
    if constants is not None:
        for i, (a, b) in enumerate(constants["links"]):
            rR[i], rt[i] = a, b
    return rR, rt


class Eigen6R:
    """The elimination of one arm (:func:`eigen6r_of`): the left side's polynomials, fixed, in
    midpoint-radius arithmetic on the links as enclosures (``constants``: the radii of the
    model's exact links, :func:`link_radii`), so that ``P`` and the right side's map hold those
    of the model as given."""

    def __init__(self, geom, constants: dict | None = None):
        self.geometry = geom
        self.LR = np.array([L.R for L in geom.links], dtype=float)
        self.Lt = np.array([L.t for L in geom.links], dtype=float)
        self.d = np.array(geom.d, dtype=float)
        self.gamma = np.array(geom.gamma, dtype=float)
        #: radii of the model's exact links about ``LR``, ``Lt`` (zero: taken as exact)
        self.rR, self.rt = link_radii(geom, constants)
        lhs = _lhs(self.LR, self.Lt, self.d, self.rR, self.rt)
        self.rmap = _rhs_map(self.LR, self.Lt, self.rR, self.rt)
        # P[k3, row, x]: rows of the 14 quantities, x = 3 * i4 + i5
        self.Pm = np.stack([q.m.reshape(3, 9) for q in lhs], axis=1)
        self.Pr = np.stack([q.r.reshape(3, 9) for q in lhs], axis=1)
        # the structure: every product was of distinct angles (checked by Trig), so P holds all

    def goal_hand(self, Gm, Gr, tm, tr):
        """``H = G A6^-1``'s point and direction (midpoint, radius) from the canonical goal."""
        d6 = float(self.d[5])
        lm = Gm[:, 2].copy()
        lr = Gr[:, 2].copy()
        pm = tm - d6 * lm
        pr = _bump(tr + abs(d6) * lr + 2.0 * U * (np.abs(tm) + abs(d6) * np.abs(lm)))
        return pm, pr, lm, lr

    def matrices(self, Gm, Gr, tm, tr):
        """``(A0, A1, A2)`` of ``M(x3)`` (midpoints (3, 12, 12) and radii) and the elimination
        ``(Pm, Pr, Qm, Qr, rows)``, or None where ``Q``'s 8 chosen rows are not proven regular."""
        pm, pr, lm, lr = self.goal_hand(Gm, Gr, tm, tr)
        Rm, Rr = _rhs(self.LR, self.Lt, pm, pr, lm, lr, self.rmap)  # (14, 9), y = 3 * i1 + i2
        Pm = self.Pm.copy()
        Pr = self.Pr.copy()
        # the constant of the right side moves left: P[1][:, (1, 1)] -= R[:, (1, 1)]
        Pm[_ONE, :, 8] = self.Pm[_ONE, :, 8] - Rm[:, 8]
        Pr[_ONE, :, 8] = _bump(self.Pr[_ONE, :, 8] + Rr[:, 8] + 2.0 * U * np.abs(Pm[_ONE, :, 8]))
        Qm, Qr = Rm[:, :8], Rr[:, :8]
        # rows scaled by powers of two (exact) to a unit largest entry
        big = np.maximum(np.abs(Qm).max(axis=1), np.abs(Pm).max(axis=(0, 2)))
        sc = np.exp2(-np.round(np.log2(np.maximum(big, 1e-300))))
        Qm, Qr = Qm * sc[:, None], Qr * sc[:, None]
        Pm, Pr = Pm * sc[None, :, None], Pr * sc[None, :, None]
        _, _, piv = scipy.linalg.qr(Qm.T, pivoting=True)
        a, b = np.sort(piv[:8]), np.sort(piv[8:])
        Qa_m, Qa_r, Qb_m, Qb_r = Qm[a], Qr[a], Qm[b], Qr[b]
        try:
            Rinv = np.linalg.inv(Qa_m)
        except np.linalg.LinAlgError:
            return None
        # Z Qa = Qb: Z = Z0 + E, E Qa = F, E = F R + E (I - Qa R)
        Z0 = Qb_m @ Rinv
        ZQm, ZQr = _mm_point(Z0, Qa_m, Qa_r)
        Fm, Fr = _madd(Qb_m, Qb_r, ZQm, ZQr, -1.0)
        QRm, QRr = _mm(Qa_m, Qa_r, Rinv, np.zeros_like(Rinv))
        Cabs = _bump(np.abs(np.eye(8) - QRm) + QRr + 2.0 * U * np.abs(QRm))
        col = _bump(Cabs.sum(axis=0), 8)
        nc = float(col.max())
        if not nc < 0.5:
            return None
        FRm, FRr = _mm(Fm, Fr, Rinv, np.zeros_like(Rinv))
        fr_abs = _bump(np.abs(FRm) + FRr)
        enorm = _bump(fr_abs.max(axis=1) / (1.0 - nc) * (1.0 + 4 * U), 4)  # per row of E
        Em = FRm
        Er = _bump(FRr + enorm[:, None] * col[None, :])
        Zm, Zr = _madd(Z0, np.zeros_like(Z0), Em, Er)
        # S_k = P_b,k - Z P_a,k (k = c, s, 1), then times the half-angle map of x4, x5
        Sm = np.empty((3, 6, 9))
        Sr = np.empty((3, 6, 9))
        for kk in range(3):
            ZPm, ZPr = _mm(Zm, Zr, Pm[kk][a], Pr[kk][a])
            Sm[kk], Sr[kk] = _madd(Pm[kk][b], Pr[kk][b], ZPm, ZPr, -1.0)
        Tm, Tr = _mm(Sm, Sr, np.broadcast_to(_TX, (3, 9, 9)), np.zeros((3, 9, 9)))  # (3, 6, 9): monomials 3a + b
        # 12 x 12: rows (eq, times 1 | times x4), columns x4^a x5^b, a in 0..3, b in 0..2 -> 3a + b
        Bm = np.zeros((3, 12, 12))
        Br = np.zeros((3, 12, 12))
        Bm[:, :6, :9] = Tm
        Br[:, :6, :9] = Tr
        Bm[:, 6:, 3:] = Tm
        Br[:, 6:, 3:] = Tr
        A0m, A0r = _madd(Bm[_C], Br[_C], Bm[_ONE], Br[_ONE])
        A1m, A1r = 2.0 * Bm[_S], 2.0 * Br[_S]
        A2m, A2r = _madd(Bm[_ONE], Br[_ONE], Bm[_C], Br[_C], -1.0)
        return (np.stack([A0m, A1m, A2m]), np.stack([A0r, A1r, A2r])), (Pm, Qm, a, b)


def eigen_candidates(Am: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The 24 eigenvalues of ``A0 + A1 x + A2 x^2`` and the first 12 components of their
    eigenvectors (the companion linearization's ``v``), in floating point; all infinite where
    ``A2`` cannot be inverted (an eigenvalue at infinity, or near it)."""
    A0, A1, A2 = Am
    n = 12
    try:
        S = np.linalg.solve(A2, np.hstack([A0, A1]))
    except np.linalg.LinAlgError:
        return np.full(2 * n, np.inf + 0j), np.zeros((n, 2 * n), dtype=complex)
    L = np.zeros((2 * n, 2 * n))
    L[:n, n:] = np.eye(n)
    L[n:, :n] = -S[:, :n]
    L[n:, n:] = -S[:, n:]
    if not np.all(np.isfinite(L)):
        return np.full(2 * n, np.inf + 0j), np.zeros((n, 2 * n), dtype=complex)
    w, V = np.linalg.eig(L)
    return w, V[:n]


# ----------------------------------------------------------------------------------------------
# the proof: Krawczyk on (lambda, v) in complex disc arithmetic
# ----------------------------------------------------------------------------------------------
def _poly_at(Am, Ar, lm, lr):
    """Enclosure of ``M(lambda)`` and ``M'(lambda)`` for discs ``lambda = lm +- lr`` (batched:
    ``lm``, ``lr`` of shape (K,)); returns (K, 12, 12) midpoints and radii."""
    lm = lm[:, None, None]
    lr = lr[:, None, None]
    al = np.abs(lm)
    # M = (A2 lambda + A1) lambda + A0; M' = 2 A2 lambda + A1
    t1m = Am[2] * lm
    t1r = _bump(Ar[2] * (al + lr) + np.abs(Am[2]) * lr + 4.0 * U * np.abs(t1m))
    s1m, s1r = _madd(t1m, t1r, np.broadcast_to(Am[1], t1m.shape), np.broadcast_to(Ar[1], t1m.shape))
    t2m = s1m * lm
    t2r = _bump(s1r * (al + lr) + np.abs(s1m) * lr + 4.0 * U * np.abs(t2m))
    Mm, Mr = _madd(t2m, t2r, np.broadcast_to(Am[0], t2m.shape), np.broadcast_to(Ar[0], t2m.shape))
    dm = 2.0 * t1m
    dr = 2.0 * t1r
    Dm, Dr = _madd(dm, dr, np.broadcast_to(Am[1], dm.shape), np.broadcast_to(Ar[1], dm.shape))
    return Mm, Mr, Dm, Dr


def prove_eigenvalues(Am, Ar, lam, V):
    """Krawczyk for each candidate ``(lam[k], V[:, k])``: (ok (K,) bool, disc centres, disc
    radii). Unknowns ``z = (lambda, v without v_j)``, ``F(z) = M(lambda) v`` with ``v_j = 1``."""
    K = lam.shape[0]
    n = 12
    V = V / V[np.argmax(np.abs(V), axis=0), np.arange(K)]  # v_j = 1 at the largest entry
    jj = np.argmax(np.abs(V), axis=0)
    # one Newton step in floating point on the midpoint data
    Mm, _, Dm, _ = _poly_at(Am, np.zeros_like(Am), lam, np.zeros(K))
    Fv = np.einsum("kij,jk->ki", Mm, V)
    J = Mm.copy()
    J[np.arange(K), :, jj] = np.einsum("kij,jk->ki", Dm, V)  # column j: d/dlambda
    try:
        dz = np.linalg.solve(J, Fv[..., None])[..., 0]
    except np.linalg.LinAlgError:
        return np.zeros(K, dtype=bool), lam, np.zeros(K)
    lam = lam - dz[np.arange(K), jj]
    dv = dz.copy()
    dv[np.arange(K), jj] = 0.0
    V = V - dv.T
    # discs: lambda +- DISC_L (1 + |lambda|), v_i +- DISC_V (1 + |v_i|), widened (epsilon
    # inflation) where the data's radius needs more
    rho = np.empty((K, n))
    rho[:] = DISC_V * (1.0 + np.abs(V.T))
    rho[np.arange(K), jj] = DISC_L * (1.0 + np.abs(lam))
    # F at the centre, enclosed over the data
    M0m, M0r, D0m, _ = _poly_at(Am, Ar, lam, np.zeros(K))
    Vt = V.T[..., None]  # (K, 12, 1)
    F0m, F0r = _mm(M0m, M0r, Vt, np.zeros(Vt.shape))
    # preconditioner: the inverse of J at the centre (midpoint data)
    Jc = M0m.copy()
    Jc[np.arange(K), :, jj] = np.einsum("kij,jk->ki", D0m, V)
    try:
        Rp = np.linalg.inv(Jc)
    except np.linalg.LinAlgError:
        return np.zeros(K, dtype=bool), lam, rho[np.arange(K), jj]
    RFm, RFr = _mm_point(Rp, F0m, F0r)
    shift = _bump(np.abs(RFm[..., 0]) + RFr[..., 0])
    rho = np.maximum(rho, 2.0 * shift)
    ok = np.zeros(K, dtype=bool)
    for _ in range(3):
        lr = rho[np.arange(K), jj]
        # J over the discs: columns M(Lambda) e_i (i != j) and M'(Lambda) v at column j
        MXm, MXr, DXm, DXr = _poly_at(Am, Ar, lam, lr)
        vr = rho.copy()
        vr[np.arange(K), jj] = 0.0  # v_j = 1 exactly
        Jv_m, Jv_r = _mm(DXm, DXr, Vt, vr[..., None])
        Jm = MXm.copy()
        Jr = MXr.copy()
        Jm[np.arange(K), :, jj] = Jv_m[..., 0]
        Jr[np.arange(K), :, jj] = Jv_r[..., 0]
        # K(X) - z = -R F(z) + (I - R J(X)) (X - z): inside X, strictly, in every component
        RJm, RJr = _mm_point(Rp, Jm, Jr)
        Cabs = _bump(np.abs(np.eye(n)[None] - RJm) + RJr + 2.0 * U * np.abs(RJm))
        spread = _bump(np.einsum("kij,kj->ki", Cabs, rho), n)
        reach = _bump(shift + spread)
        ok = np.all(reach < rho, axis=1) & np.all(np.isfinite(reach), axis=1)
        if ok.all():
            break
        grow = ~ok & np.all(np.isfinite(reach), axis=1)
        rho[grow] = np.maximum(rho[grow], 2.0 * reach[grow])
    return ok, lam, rho[np.arange(K), jj]


def prove_count(Am, Ar):
    """The proof of steps 1-2 (module docstring): the real eigenvalues' discs ``(centres,
    radii, eigenvectors)`` when 16 eigenvalues are proven (every real root of ``q`` in one of
    them), else None."""
    out = _prove_count(Am, Ar)
    return None if out is None else out[:3]


def count_discs(Am, Ar) -> tuple[np.ndarray, np.ndarray] | None:
    """The 16 discs of :func:`prove_count` (centres, radii), real and complex: each holds
    exactly one root of ``q`` for every pencil in ``Am +- Ar``; None where not proven."""
    out = _prove_count(Am, Ar)
    return None if out is None else out[3]


def _prove_count(Am, Ar):
    w, V = eigen_candidates(Am)
    finite = np.isfinite(w)
    if finite.sum() < 24:
        return None
    # the 4 nearest i and the 4 nearest -i are the factor (1 + x^2)^4
    near_i = np.argsort(np.abs(w - 1j))[:4]
    near_mi = np.argsort(np.abs(w + 1j))[:4]
    spur = set(near_i) | set(near_mi)
    if len(spur) != 8 or max(np.abs(w[near_i] - 1j).max(), np.abs(w[near_mi] + 1j).max()) > SPURIOUS:
        return None  # not the structure of the elimination (a degenerate arm): no proof tried
    keep = [k for k in range(24) if k not in spur]
    lam = w[keep]
    vec = V[:, keep]
    tol = 1e-6 * (1.0 + np.abs(lam))
    real = np.abs(lam.imag) <= tol
    upper = (~real) & (lam.imag > 0)
    lower = (~real) & (lam.imag < 0)
    if upper.sum() != lower.sum():
        return None
    sel = np.flatnonzero(real | upper)
    cand = lam[sel].copy()
    cvec = vec[:, sel].copy()
    isreal = real[sel]
    cand[isreal] = cand[isreal].real
    cvec[:, isreal] = cvec[:, isreal].real
    ok, centres, radii = prove_eigenvalues(Am, Ar, cand.astype(complex), cvec.astype(complex))
    if not np.all(ok):
        return None
    centres = centres.copy()
    # a real candidate's disc must be symmetric: its centre real (the Newton step keeps it
    # real on real data); a complex one's disc off the real axis
    for k in range(len(centres)):
        if isreal[k]:
            if centres[k].imag != 0.0:
                return None
        elif not abs(centres[k].imag) * (1.0 - 4.0 * U) > radii[k] * (1.0 + 4.0 * U):
            return None
    discs = [(c, r) for c, r in zip(centres, radii)] + [(c.conjugate(), r) for c, r, re_ in zip(centres, radii, isreal) if not re_]
    if len(discs) != DEGREE:
        return None
    # pairwise disjoint, and free of +-i (|c1 - c2| rounded: within a few ulps)
    C = np.array([c for c, _ in discs] + [1j, -1j])
    Rd = np.array([r for _, r in discs] + [0.0, 0.0])
    gap = np.abs(C[:, None] - C[None, :]) * (1.0 - 4.0 * U)
    need = (Rd[:, None] + Rd[None, :]) * (1.0 + 4.0 * U)
    apart = gap > need
    np.fill_diagonal(apart, True)
    if not apart.all():
        return None
    idx = np.flatnonzero(isreal)
    return centres[idx].real, radii[idx], cvec[:, idx].real, (C[:DEGREE], Rd[:DEGREE])


# ----------------------------------------------------------------------------------------------
# back substitution: the angles of a real eigenvalue
# ----------------------------------------------------------------------------------------------
def _angle_pair(v: np.ndarray, axis: int) -> float:
    """The angle of ``x = tan(t / 2)`` (homogeneous ``(x : w)``) from the monomial vector ``v``
    (``v[3a + b] = x4^a w4^(3-a) x5^b w5^(2-b)``)."""
    V = v.reshape(4, 3)
    if axis == 0:  # ratios of consecutive powers of x4 along a column
        best, num, den = -1.0, 0.0, 1.0
        for b in range(3):
            for a in range(3):
                s = V[a + 1, b] ** 2 + V[a, b] ** 2
                if s > best:
                    best, num, den = s, V[a + 1, b], V[a, b]
    else:
        best, num, den = -1.0, 0.0, 1.0
        for a in range(4):
            for b in range(2):
                s = V[a, b + 1] ** 2 + V[a, b] ** 2
                if s > best:
                    best, num, den = s, V[a, b + 1], V[a, b]
    return 2.0 * math.atan2(num, den)


def _rz_batch(theta: np.ndarray) -> np.ndarray:
    c, s = np.cos(theta), np.sin(theta)
    R = np.zeros(theta.shape + (3, 3))
    R[..., 0, 0], R[..., 0, 1], R[..., 1, 0], R[..., 1, 1], R[..., 2, 2] = c, -s, s, c, 1.0
    return R


def back_substitute(e6: Eigen6R, Pm, Qm, x3: np.ndarray, V: np.ndarray, G: np.ndarray) -> np.ndarray:
    """Canonical angles (k, 6) of the solutions of real eigenvalues ``x3`` (k,) with kernel
    vectors ``V`` (12, k), in floating point (the certification polishes them by Newton steps on
    the kinbox system): ``t3`` from ``x3``, ``t4, t5`` from the monomials of ``v``, ``t1, t2``
    from ``Q Y = P X`` (least squares), ``t6`` from the goal's rotation."""
    k = len(x3)
    th = np.zeros((k, 6))
    th[:, 2] = 2.0 * np.arctan(x3)
    for i in range(k):
        th[i, 3] = _angle_pair(V[:, i], 0)
        th[i, 4] = _angle_pair(V[:, i], 1)
    b = np.stack([np.cos(th), np.sin(th), np.ones_like(th)], axis=2)  # (k, 6, 3): (c, s, 1)
    X = np.einsum("ka,kb->kab", b[:, 3], b[:, 4]).reshape(k, 9)
    B = np.einsum("kc,crx,kx->rk", b[:, 2], Pm, X)
    Y = np.linalg.lstsq(Qm, B, rcond=None)[0]  # (8, k): y = 3 i1 + i2, i = c, s, 1
    th[:, 0] = np.arctan2(Y[5], Y[2])  # (s1, 1), (c1, 1)
    th[:, 1] = np.arctan2(Y[7], Y[6])  # (1, s2), (1, c2)
    Rz = _rz_batch(th[:, :5])
    R = Rz[:, 0]
    for i in range(1, 5):
        R = R @ e6.LR[i - 1] @ Rz[:, i]
    R = R @ e6.LR[4]
    W = np.swapaxes(R, 1, 2) @ G  # = Rz(t6) at the solution
    th[:, 5] = np.arctan2(W[:, 1, 0], W[:, 0, 0])
    return th


# ----------------------------------------------------------------------------------------------
# certification on the kinbox system: the closed form's compiled Krawczyk on the arm template
# bound at the pose (:class:`kinbox.search.closed_form.TemplateCertifier`)
# ----------------------------------------------------------------------------------------------
@nb.njit(cache=True)
def certify_kernel(
    thetas, p, pm,
    coef_indptr, coef_indices, coef_data, const, zmag, indptr, cols, rows_of, mi, mj, nonlin, t_flat, t_var,
    g_slope, core_slack, dom_lo, dom_hi, fixed, cvar, svar, shift, def_target, def_start, def_param, def_coef, def_a, def_b,
    tiny, u, radius, x_out, klo_out, khi_out, res_out, inside,
):  # fmt: skip
    """Krawczyk on the arm template bound at pose ``p`` about each row of ``thetas`` (canonical
    angles, encoded as :meth:`kinbox.formulation.arm.ArmTemplate.encode` does, Newton-polished
    on the core rows): True where every root is proven unique in its box and the boxes are
    pairwise disjoint; ``inside[m]``: root ``m``'s box lies in the system's domain. As the closed form's batch, the rows are those
    of the bound system (no enclosure of the pose's parameters: docs/soundness.md)."""
    n = fixed.shape[0]
    n_core = const.shape[0]
    ne = zmag.shape[0]
    npar = p.shape[0]
    c = np.empty(n_core)
    slack = np.empty(n_core)
    no_err = np.zeros(n_core)
    Ax = np.zeros((n_core, n))
    data = np.empty(ne)
    t_coef = np.empty(t_flat.shape[0])
    t_abs = np.empty(t_flat.shape[0])
    ap = np.empty(npar)
    bind_rows(
        p, pm, no_err, const, coef_indptr, coef_indices, coef_data, zmag, rows_of, cols, nonlin, core_slack, tiny,
        ap, c, slack, data, Ax, t_coef, t_abs,
    )  # fmt: skip
    x = np.empty(n)
    lo = np.empty(n)
    hi = np.empty(n)
    F = np.empty(n_core)
    J = np.empty((n_core, n))
    dx = np.empty(n)
    for m in range(thetas.shape[0]):
        _encode(thetas[m], p, fixed, cvar, svar, shift, def_target, def_start, def_param, def_coef, def_a, def_b, x)
        for _it in range(3):  # Newton on the core rows from the back substitution's point
            for rr in range(n_core):
                F[rr] = core_row(rr, c, data, x, indptr, cols, mi, mj)
            _jacobian_into(J, x, Ax, t_flat, t_var, t_coef)
            if not _lu_solve(J, F, dx):
                return False
            for i in range(n):
                x[i] -= dx[i]
        for i in range(n):
            w = radius * (1.0 + abs(x[i]))
            lo[i] = x[i] - w
            hi[i] = x[i] + w
        st, klo, khi, _e = _krawczyk_full(
            lo, hi, x, Ax, t_flat, t_var, t_coef, t_abs, g_slope, slack, no_err, no_err, False, tiny, u, mi, mj, indptr, cols, data, c
        )
        if st != _K_UNIQUE:
            return False
        inside[m] = True
        for i in range(n):
            if klo[i] < dom_lo[i] or khi[i] > dom_hi[i]:
                inside[m] = False
        res = 0.0
        for rr in range(n_core):
            res = max(res, abs(core_row(rr, c, data, x, indptr, cols, mi, mj)))
        for i in range(n):
            x_out[m, i] = x[i]
            klo_out[m, i] = klo[i]
            khi_out[m, i] = khi[i]
        res_out[m] = res
        for prev in range(m):
            if not boxes_apart(klo_out, khi_out, prev, klo, khi):
                return False
    return True


def x3_enclosure(clo: float, chi: float, slo: float, shi: float) -> tuple[float, float] | None:
    """Enclosure of ``tan(t / 2) = s / (1 + c)`` over ``c in [clo, chi]``, ``s in [slo, shi]``
    (None where ``1 + c`` is not proven positive)."""
    dlo = ivl.down(1.0 + clo)
    dhi = ivl.up(1.0 + chi)
    if not dlo > 0.0:
        return None
    q = [slo / dlo, slo / dhi, shi / dlo, shi / dhi]
    return float(ivl.down(min(q))), float(ivl.up(max(q)))


# ----------------------------------------------------------------------------------------------
# one pose, end to end
# ----------------------------------------------------------------------------------------------
def limit_rows(joints, gamma) -> np.ndarray:
    """The limit row of each joint in canonical angles, as the closed form's
    (:class:`kinbox.search.closed_form.ClosedForm`): (limited, cos mid, sin mid, cos half - pad)."""
    from ..formulation.pairs import revolute_is_limited
    from .closed_form import LIMIT_PAD

    lim = np.zeros((6, 4))
    for i, j in enumerate(joints):
        lo, hi = j.lo + gamma[i], j.hi + gamma[i]
        if revolute_is_limited(lo, hi, j.unbounded):
            mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
            lim[i] = (1.0, math.cos(mid), math.sin(mid), math.cos(half) - LIMIT_PAD)
    return lim


class Candidates:
    """What the eigenvalue proof gives for one pose: the canonical angles of each real
    eigenvalue's solution (back substitution, polished) and the eigenvalue's disc."""

    def __init__(self, theta: np.ndarray, centre: np.ndarray, radius: np.ndarray):
        self.theta = theta
        self.centre = centre
        self.radius = radius


class EigenSolver:
    """The eigenvalue path of one arm of six revolute joints, in the canonical frames of its
    template (:class:`kinbox.formulation.arm.ArmTemplate` or
    :class:`kinbox.formulation.arm_invariants.InvariantsTemplate`)."""

    def __init__(self, arm):
        from .cf_certify import JointCertifier, workspace
        from .closed_form import TemplateCertifier

        geom = arm.geometry
        self.arm = arm
        self.e6 = Eigen6R(geom, arm.constants)
        self.joints = geom.chain.joints
        gamma = np.asarray(geom.gamma, dtype=float)
        tc = TemplateCertifier(arm, self.joints, gamma)
        #: Krawczyk on the arm template's system, compiled (None: not square)
        self.certifier = tc if tc.ok and np.all(tc.cvar >= 0) and np.all(tc.svar >= 0) else None
        self.limits = limit_rows(self.joints, gamma)
        # the joints as the closed form's answers read them (kinbox.answer.closed_form.configurations)
        self.gamma = gamma
        self.idx_q = np.array([j.idx_q for j in self.joints], dtype=np.int64)
        self.unbounded = np.array([j.unbounded for j in self.joints], dtype=np.bool_)
        self.lo = np.array([j.lo for j in self.joints], dtype=float)
        self.hi = np.array([j.hi for j in self.joints], dtype=float)
        self.q_ref = np.asarray(geom.chain.q_ref, dtype=float)
        g = geom
        self.A = g.C0.inverse() * g.chain.base
        self.B = g.E.inverse()
        self.reversed = g.chain.reversed
        self.tmag0 = float(np.linalg.norm(self.A.translation) + np.linalg.norm(self.B.translation))
        # the compiled kernels' constant arguments (kinbox.search.eigen6r_kernel)
        e6 = self.e6
        c = np.ascontiguousarray
        self._frame = (c(self.A.rotation, dtype=float), c(self.A.translation, dtype=float),
                       c(self.B.rotation, dtype=float), c(self.B.translation, dtype=float), bool(self.reversed), self.tmag0)  # fmt: skip
        self._left = (float(e6.d[5]), c(e6.rmap[0].reshape(-1, NFEAT)), c(e6.rmap[1].reshape(-1, NFEAT)), c(e6.Pm), c(e6.Pr), c(_TX))
        self._LR = c(e6.LR)
        #: Krawczyk in the six joint angles on the pose as given (:mod:`kinbox.search.cf_certify`)
        self.joint = JointCertifier(geom, self.joints, gamma, arm.constants)
        self._jargs = self.joint.kernel_args()
        self._ws = workspace()

    def pencil(self, R: np.ndarray, t: np.ndarray, V: np.ndarray | None = None) -> tuple[int, dict]:
        """Kernel 1 (:func:`kinbox.search.eigen6r_kernel.pencil_kernel`) for goal ``(R, t)``
        (the pose of XYZQUAT ``V``, that of ``(R, t)`` if not given): (status, arrays)."""
        v = _xyzquat(R, t) if V is None else np.ascontiguousarray(V, dtype=float).reshape(7)
        j = self._jargs
        out = dict(
            GR=np.empty((1, 3, 3)), Gt=np.empty((1, 3)), Gm=np.empty((3, 3)), Pm=np.empty((3, 14, 9)), Qm=np.empty((14, 8)),
            a=np.empty(8, dtype=np.int64), Rinv=np.empty((8, 8)), Am=np.empty((3, 12, 12)), Ar=np.empty((3, 12, 12)), L=np.empty((24, 24)),
        )  # fmt: skip
        R1 = np.ascontiguousarray(R, dtype=float).reshape(1, 3, 3)
        t1 = np.ascontiguousarray(t, dtype=float).reshape(1, 3)
        bufs = (out["GR"], out["Gt"], out["Gm"], out["Pm"], out["Qm"], out["a"], out["Rinv"], out["Am"], out["Ar"], out["L"])
        st = K.pencil_kernel(R1, t1, v, *self._frame, j[3], j[4], j[5], j[6], *self._left, *bufs)
        return int(st), out

    def goal(self, R: np.ndarray, t: np.ndarray):
        """The canonical goal frame, midpoint and radius (the closed form's enclosure)."""
        from .closed_form import _goal_arrays

        Rlo, Rhi, tlo, thi = _goal_arrays(
            R[None], t[None], self.A.rotation, self.A.translation, self.B.rotation, self.B.translation, self.reversed, self.tmag0
        )
        Gm = 0.5 * (Rlo[0] + Rhi[0])
        Gr = _bump(0.5 * (Rhi[0] - Rlo[0]) + U * np.abs(Gm))
        tm = 0.5 * (tlo[0] + thi[0])
        tr = _bump(0.5 * (thi[0] - tlo[0]) + U * np.abs(tm))
        return Gm, Gr, tm, tr

    def candidates(self, R: np.ndarray, t: np.ndarray) -> Candidates | None:
        """Steps 1-3 of the proof (module docstring) for goal ``(R, t)`` and each real
        eigenvalue's solution; None where the proof fails (the pose goes to the branch and prune)."""
        Gm, Gr, tm, tr = self.goal(np.asarray(R, dtype=float), np.asarray(t, dtype=float))
        mats = self.e6.matrices(Gm, Gr, tm, tr)
        if mats is None:
            return None
        (Am, Ar), (Pm, Qm, _a, _b) = mats
        proof = prove_count(Am, Ar)
        if proof is None:
            return None
        centres, radii, vecs = proof
        thetas = back_substitute(self.e6, Pm, Qm, np.asarray(centres, dtype=float), vecs, Gm)
        return Candidates(thetas, centres, radii)


class Certified:
    """The certified roots of one pose within the joint limits: canonical angles, system points,
    proof boxes (each proven to hold exactly one root of the system), residuals."""

    def __init__(self, theta, x, lo, hi, residual):
        self.theta = theta
        self.x = x
        self.lo = lo
        self.hi = hi
        self.residual = residual


class Roots:
    """The certified roots of one pose within the joint limits (:func:`certify`): canonical
    angles ``theta`` (k, 6) and their proof boxes ``lo, hi`` in the canonical angles, each
    proven to hold exactly one root of the pose as given (Krawczyk in the joint angles)."""

    def __init__(self, theta: np.ndarray, lo: np.ndarray, hi: np.ndarray):
        self.theta = theta
        self.lo = lo
        self.hi = hi


def _xyzquat(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    import pinocchio as pin

    V = pin.SE3ToXYZQUAT(pin.SE3(np.asarray(R, dtype=float), np.asarray(t, dtype=float)))
    return np.ascontiguousarray(V, dtype=float).reshape(7)


def certify(es: EigenSolver, R: np.ndarray, t: np.ndarray, V: np.ndarray | None = None) -> Roots | None:
    """Every root of the goal within the joint limits, each certified, proven complete (module
    docstring), or None (the pose goes to the branch and prune): the compiled kernels
    (:mod:`kinbox.search.eigen6r_kernel`) around numpy's eigen-solver. The goal is its XYZQUAT
    ``V`` (that of ``(R, t)`` if not given): the eigenvalue proof encloses the rotation of its
    quaternion and the joint certificate the pose ``V`` as given."""
    v = _xyzquat(R, t) if V is None else np.ascontiguousarray(V, dtype=float).reshape(7)
    Rq = np.empty((1, 3, 3))
    K.quaternion_rotation(v, Rq)
    st, m = es.pencil(Rq, v[:3], v)
    if st != K.OK:
        return None
    try:
        w, vecs = np.linalg.eig(m["L"])
    except np.linalg.LinAlgError:
        return None
    theta = np.empty((DEGREE, 6))
    lo = np.empty((DEGREE, 6))
    hi = np.empty((DEGREE, 6))
    st, k = K.proof_kernel(m["Am"], m["Ar"], w.astype(complex), np.ascontiguousarray(vecs, dtype=complex), es._LR, m["Pm"], m["a"],
                           m["Rinv"], m["Gm"], v, es._jargs, es._ws, es.limits, theta, lo, hi)  # fmt: skip
    if st != K.OK:
        return None
    return Roots(theta[:k], lo[:k], hi[:k])


def certify_reference(es: EigenSolver, R: np.ndarray, t: np.ndarray) -> Certified | None:
    """:func:`certify` in numpy (:meth:`EigenSolver.candidates`, then the compiled Krawczyk
    test): the reference the compiled kernels are checked against (tests/search/test_eigen6r.py)."""
    from .closed_form import _in_limits

    tc = es.certifier
    if tc is None:
        return None
    R = np.asarray(R, dtype=float)
    t = np.asarray(t, dtype=float)
    cand = es.candidates(R, t)
    if cand is None:
        return None
    k = len(cand.centre)
    P, PM = tc.params(R[None], t[None])
    n = tc.n
    x = np.zeros((k, n))
    lo = np.zeros((k, n))
    hi = np.zeros((k, n))
    res = np.zeros(k)
    inside = np.zeros(k, dtype=np.bool_)
    args = (cand.theta, P[0], PM[0], *tc.kernel_args(), TINY, U, PROOF_RADIUS, x, lo, hi, res, inside)
    if not certify_kernel(*args):
        return None
    c3, s3 = int(tc.cvar[2]), int(tc.svar[2])
    keep = []
    for i in range(k):
        enc = x3_enclosure(lo[i, c3], hi[i, c3], lo[i, s3], hi[i, s3])
        c, rad = float(cand.centre[i]), float(cand.radius[i])
        if enc is None or not (c - rad < enc[0] and enc[1] < c + rad):
            return None  # the root is not proven to be this eigenvalue's
        box = np.stack([lo[i, tc.cvar], hi[i, tc.cvar], lo[i, tc.svar], hi[i, tc.svar]], axis=1)
        verdict = _in_limits(box, es.limits)
        if verdict < 0:
            return None  # a root on a joint limit
        if verdict > 0:
            if not inside[i]:
                return None  # within the limit rows, not proven inside the domain
            keep.append(i)
    kk = np.array(keep, dtype=np.int64)
    return Certified(cand.theta[kk], x[kk], lo[kk], hi[kk], res[kk])


#: half-width of a root's proof box, relative to ``1 + |x|`` (the closed form's)
PROOF_RADIUS = 1e-9


def eigen_solver_of(arm) -> EigenSolver | None:
    """The eigenvalue path of an arm template of six revolute joints, or None."""
    from ..formulation.arm import ArmTemplate

    if not isinstance(arm, ArmTemplate):
        return None
    geom = arm.geometry
    if len(geom.chain.joints) != 6 or any(j.kind != "revolute" for j in geom.chain.joints):
        return None
    if geom.d[0] != 0.0 or geom.gamma[0] != 0.0:
        return None
    try:
        es = EigenSolver(arm)
    except ValueError:  # a product in one angle: not the structure of the derivation
        return None
    return es if es.certifier is not None else None
