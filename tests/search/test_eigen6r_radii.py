"""The general 6R eigenvalue path's count proof covers the model and pose as given: the pencil
``M(x3) = A0 + A1 x3 + A2 x3^2`` is enclosed (``Am +- Ar``) for every arm whose links lie within
the radii of the model's exact links (``formulation/constants.py``) and every goal within the
goal's enclosure, so the 16 discs hold the eigenvalues of the exact problem.

The reference is python-flint's ball arithmetic at 200 bits on a build that shares no code with
kinbox's: the 14 quantities of both sides evaluated by products of exact rigid motions at the
nodes ``(c, s) = (1, 0), (0, 1), (-1, 0)`` of each angle and interpolated (each is multilinear in
the angles' ``(c, s, 1)``), then the same rows eliminated and the same half-angle map; its
eigenvalues by ``acb_mat.eig``."""

from __future__ import annotations

import itertools

import numpy as np
import pinocchio as pin
import pytest

flint = pytest.importorskip("flint")
from flint import acb, acb_mat, arb, arb_mat, ctx, fmpz  # noqa: E402

import kinbox  # noqa: E402
from kinbox.formulation.constants import enclose_links  # noqa: E402
from kinbox.search import eigen6r as E  # noqa: E402
from kinbox.search import eigen6r_kernel as K  # noqa: E402
from tests.support import fuzz_arms as fa  # noqa: E402

PREC = 200
NODES = ((1, 0), (0, 1), (-1, 0))  # (c, s) per angle: exact rotations
#: (c, s, 1) at the nodes, inverted: coefficients over (c, s, 1) from the node values
VINV = np.linalg.inv(np.array([[c, s, 1.0] for c, s in NODES]))  # entries 0, +-1/2, 1: exact


def _exact(t) -> arb:
    """A raw mpmath number ``(sign, man, exp, bc)`` as an exact arb."""
    sign, man, exp, _ = t
    v = arb(fmpz(int(man))) * arb(2) ** int(exp)
    return -v if sign else v


def _ball(x) -> arb:
    """An mpmath interval as an arb ball holding it."""
    lo, hi = x._mpi_
    return _exact(lo).union(_exact(hi))


def _mat(rows) -> list:
    return [[r[j] for j in range(3)] for r in rows]


def _mul(A, B):
    return [[sum((A[i][k] * B[k][j] for k in range(3)), arb(0)) for j in range(3)] for i in range(3)]


def _mv(A, v):
    return [sum((A[i][k] * v[k] for k in range(3)), arb(0)) for i in range(3)]


class Frame:
    """A rigid motion ``(R, t)`` in arb."""

    def __init__(self, R, t):
        self.R, self.t = R, t

    def __mul__(self, o: Frame) -> Frame:
        return Frame(_mul(self.R, o.R), [a + b for a, b in zip(_mv(self.R, o.t), self.t)])

    def inverse(self) -> Frame:  # of a rotation (exact links, the goal's quaternion)
        Rt = [[self.R[j][i] for j in range(3)] for i in range(3)]
        return Frame(Rt, [-a for a in _mv(Rt, self.t)])


def _rz(c, s) -> Frame:
    z, o = arb(0), arb(1)
    return Frame([[arb(c), arb(-s), z], [arb(s), arb(c), z], [z, z, o]], [z, z, z])


def _tz(d: float) -> Frame:
    z, o = arb(0), arb(1)
    return Frame([[o, z, z], [z, o, z], [z, z, o]], [z, z, arb(d)])


def _quantities(F: Frame) -> list:
    """``p, l, p.p, p.l, p x l, l (p.p) - 2 p (p.l)`` of the frame's origin and ``z`` axis."""
    p = F.t
    ll = [F.R[i][2] for i in range(3)]
    pp = sum((x * x for x in p), arb(0))
    pl = sum((x * y for x, y in zip(p, ll)), arb(0))
    pxl = [p[1] * ll[2] - p[2] * ll[1], p[2] * ll[0] - p[0] * ll[2], p[0] * ll[1] - p[1] * ll[0]]
    last = [ll[i] * pp - 2 * p[i] * pl for i in range(3)]
    return [*p, *ll, pp, pl, *pxl, *last]


def _interpolate(values: dict, naxes: int) -> np.ndarray:
    """Coefficients (14, 3, ..., 3) over ``(c, s, 1)`` per angle of the quantities given at the
    nodes (``values[(n1, n2, ...)]``: 14 arbs)."""
    out = np.empty((14,) + (3,) * naxes, dtype=object)
    for r in range(14):
        for basis in itertools.product(range(3), repeat=naxes):
            acc = arb(0)
            for nodes in itertools.product(range(3), repeat=naxes):
                w = 1.0
                for b, n in zip(basis, nodes):
                    w *= VINV[b, n]
                if w != 0.0:
                    acc += arb(w) * values[nodes][r]
            out[(r,) + basis] = acc
    return out


def exact_pencil(links, d, H: Frame, a, scale) -> list:
    """``A0, A1, A2`` (arb_mat 12 x 12) of the arm with exact links ``links`` (Frames),
    offsets ``d`` and hand frame ``H = G A6^-1``, eliminated with the rows ``a`` of ``Q``, each
    row of ``P, Q`` times ``scale`` (the kernel's powers of two)."""
    L = [Frame(R, t) for R, t in links]
    left = {}
    for n3, n4, n5 in itertools.product(range(3), repeat=3):
        F = _tz(d[1]) * L[1]
        for n, k in ((n3, 2), (n4, 3), (n5, 4)):
            F = F * _rz(*NODES[n]) * _tz(d[k]) * L[k]
        left[(n3, n4, n5)] = _quantities(F)
    P = _interpolate(left, 3)  # (14, k3, i4, i5)
    right = {}
    for n1, n2 in itertools.product(range(3), repeat=2):
        F = _rz(*NODES[n2]).inverse() * L[0].inverse() * _rz(*NODES[n1]).inverse() * H
        right[(n1, n2)] = _quantities(F)
    R = _interpolate(right, 2).reshape(14, 9)  # y = 3 i1 + i2
    Pk = [[[P[r, k, x // 3, x % 3] for x in range(9)] for r in range(14)] for k in range(3)]
    for r in range(14):
        Pk[2][r][8] = Pk[2][r][8] - R[r, 8]  # the right side's constant moves left
    Pk = [[[v * scale[r] for v in Pk[k][r]] for r in range(14)] for k in range(3)]
    Q = [[R[r, j] * scale[r] for j in range(8)] for r in range(14)]
    b = [r for r in range(14) if r not in set(a)]
    Qa = arb_mat([Q[r] for r in a])
    Qb = arb_mat([Q[r] for r in b])
    Z = Qa.transpose().solve(Qb.transpose()).transpose()  # Z Qa = Qb
    TX = arb_mat([[float(v) for v in row] for row in E._TX])
    T = []
    for k in range(3):
        S = arb_mat([Pk[k][r] for r in b]) - Z * arb_mat([Pk[k][r] for r in a])
        T.append(S * TX)
    B = []
    for k in range(3):
        M = arb_mat(12, 12)
        for h in range(2):
            for i in range(6):
                for x in range(9):
                    M[i + 6 * h, x + 3 * h] = T[k][i, x]
        B.append(M)
    return [B[0] + B[2], 2 * B[1], B[2] - B[0]]


def _within(A, Am, Ar) -> bool:
    """Every entry of the ball matrix ``A`` inside ``Am +- Ar``."""
    for q in range(3):
        for i in range(12):
            for j in range(12):
                if not (A[q][i, j] - arb(float(Am[q, i, j]))).abs_upper() <= arb(float(Ar[q, i, j])):
                    return False
    return True


def eigenvalues(A) -> list:
    """The 16 eigenvalues of ``det M`` other than the eight at ``+-i`` (balls)."""
    A2inv = A[2].inv()
    C = acb_mat(24, 24)
    for i in range(12):
        C[i, 12 + i] = 1
    S0, S1 = A2inv * A[0], A2inv * A[1]
    for i in range(12):
        for j in range(12):
            C[12 + i, j] = -S0[i, j]
            C[12 + i, 12 + j] = -S1[i, j]
    w = C.eig(multiple=True)
    out = [x for x in w if min(abs(complex(x.mid()) - 1j), abs(complex(x.mid()) + 1j)) > 1e-3]
    assert len(out) == 16
    return out


def _in_a_disc(lam: acb, C: np.ndarray, Rd: np.ndarray) -> bool:
    return any(bool((lam - acb(complex(c))).abs_upper() < arb(float(r))) for c, r in zip(C, Rd))


def _exact_model(ik) -> tuple[list, Frame, Frame]:
    """The model's exact links ``L'_i`` and constant frames ``A' = C'_0^-1 base``, ``B' = E'^-1``
    (formulation/constants.py, 120-bit intervals) as arb balls."""
    es = ik.eigen6r
    ex = enclose_links(es.arm.geometry, es.arm.mechanism, ik.frame, ik.base, keep_exact=True)

    def frame(F) -> Frame:
        return Frame(_mat([[_ball(F.R[i][j]) for j in range(3)] for i in range(3)]), [_ball(x) for x in F.t])

    return [(F.R, F.t) for F in map(frame, ex["exact_links"])], frame(ex["A"]), frame(ex["B"])


def _hand(es, v, A: Frame, B: Frame) -> Frame:
    """``H = G A6^-1`` of the XYZQUAT ``v``, ``G = A M B`` (the goal's rotation that of its
    unit quaternion, inverted first for a reversed chain)."""
    x, y, z, w = (arb(float(c)) for c in v[3:])
    s = 2 / (x * x + y * y + z * z + w * w)
    M = Frame(
        [
            [1 - s * (y * y + z * z), s * (x * y - z * w), s * (x * z + y * w)],
            [s * (x * y + z * w), 1 - s * (x * x + z * z), s * (y * z - x * w)],
            [s * (x * z - y * w), s * (y * z + x * w), 1 - s * (x * x + y * y)],
        ],
        [arb(float(c)) for c in v[:3]],
    )
    if es.reversed:
        M = M.inverse()
    return A * M * B * _tz(-float(es.e6.d[5]))


def _scale(links, H, Qm) -> list:
    """The kernel's row scales (powers of two) from its scaled ``Q`` against the exact one."""
    Q = exact_pencil_rhs(links, H)
    out = []
    for r in range(14):
        j = int(np.argmax(np.abs(Qm[r])))
        out.append(2.0 ** round(np.log2(abs(Qm[r, j] / float(Q[r][j].mid())))))
    return out


def exact_pencil_rhs(links, H) -> list:
    L = [Frame(R, t) for R, t in links]
    right = {}
    for n1, n2 in itertools.product(range(3), repeat=2):
        F = _rz(*NODES[n2]).inverse() * L[0].inverse() * _rz(*NODES[n1]).inverse() * H
        right[(n1, n2)] = _quantities(F)
    R = _interpolate(right, 2).reshape(14, 9)
    return [[R[r, j] for j in range(8)] for r in range(14)]


@pytest.fixture
def high_precision():
    old = ctx.prec
    ctx.prec = PREC
    yield
    ctx.prec = old


def _case(seed: int, tmp_path):
    case = fa.make_case("general_6r", seed, tmp_path)
    ik = kinbox.IK(case.robot, case.frame)
    assert ik.eigen6r is not None
    return case, ik


@pytest.mark.parametrize("seed", [1, pytest.param(3, marks=pytest.mark.slow)])
def test_the_pencil_encloses_the_exact_problem(seed, tmp_path, high_precision):
    """The compiled pencil ``Am +- Ar`` holds, entry by entry, the pencil of the model as given
    (its exact links) and the pose as given (its XYZQUAT, the constant frames' enclosures),
    built in ball arithmetic; the 16 discs of the count proof hold its 16 eigenvalues."""
    case, ik = _case(seed, tmp_path)
    es = ik.eigen6r
    links, Ax, Bx = _exact_model(ik)
    rng = np.random.default_rng(seed)
    goals = [case.goal] + [ik.pose_at(fa.config_from_values(case.model, rng.uniform(-3, 3, 6))) for _ in range(2)]
    proven = 0
    for goal in goals:
        v = pin.SE3ToXYZQUAT(goal)
        Rq = np.empty((1, 3, 3))
        K.quaternion_rotation(np.ascontiguousarray(v), Rq)
        st, m = es.pencil(Rq, v[:3], v)
        assert st == K.OK
        H = _hand(es, v, Ax, Bx)
        A = exact_pencil(links, es.e6.d, H, list(m["a"]), _scale(links, H, m["Qm"]))
        assert _within(A, m["Am"], m["Ar"])
        discs = E.count_discs(m["Am"], m["Ar"])
        if discs is None:
            continue
        proven += 1
        for lam in eigenvalues(A):
            assert _in_a_disc(lam, *discs)
    assert proven >= 2


def test_the_pencil_holds_every_arm_within_the_radii(tmp_path, high_precision):
    """With the links' translations given a radius ``rho`` (1e-9 m), the pencil's enclosure holds
    the pencils of arms whose translations are moved by ``+-rho/2`` (built in ball arithmetic)
    and its discs their eigenvalues; the enclosure computed without that radius does not hold
    them (the radius is what covers the arms within it)."""
    case, ik = _case(1, tmp_path)
    es = ik.eigen6r
    rho = 1e-9
    exact, Ax, Bx = _exact_model(ik)
    c = dict(es.arm.constants)
    c["links"] = [(rR, rt + rho) for rR, rt in c["links"]]
    wide = E.Eigen6R(es.arm.geometry, c)
    Gm, Gr, tm, tr = es.goal(case.goal.rotation, case.goal.translation)
    mats = wide.matrices(Gm, Gr, tm, tr)
    plain = es.e6.matrices(Gm, Gr, tm, tr)
    assert mats is not None and plain is not None
    (Am, Ar), (_, Qm, a, _) = mats
    assert np.array_equal(Am, plain[0][0]) and np.array_equal(a, plain[1][2])
    discs = E.count_discs(Am, Ar)
    assert discs is not None
    v = pin.SE3ToXYZQUAT(case.goal)
    H = _hand(es, v, Ax, Bx)
    rng = np.random.default_rng(7)
    for _ in range(2):
        moved = [(R, [x + arb(float(rng.choice([-0.5, 0.5]) * rho)) for x in t]) for R, t in exact]
        A = exact_pencil(moved, es.e6.d, H, [int(r) for r in a], _scale(moved, H, Qm))
        assert _within(A, Am, Ar)
        assert not _within(A, *plain[0])
        assert all(_in_a_disc(lam, *discs) for lam in eigenvalues(A))
