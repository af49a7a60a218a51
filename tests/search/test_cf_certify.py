"""Krawczyk in the joint angles (kinbox.search.cf_certify) against Krawczyk on the kinbox
system (the same verdicts, the same roots) and against python-flint's ball arithmetic (each
proof box holds the root of the pose as given, computed to 200 bits)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from flint import arb, ctx

from kinbox.search import cf_certify as cc
from kinbox.search.cf_batch import run_batch
from kinbox.search.cf_delta import Delta
from kinbox.search.closed_form import POSE_CLOSED_FORM
from tests.support.arms import ARMS, _ik, _poses


def _batches(ik, poses):
    cf = ik.closed_form
    R = np.array([p.rotation for p in poses])
    t = np.array([p.translation for p in poses])
    V = np.array([pin.SE3ToXYZQUAT(p) for p in poses])
    return cf, V, run_batch(cf, cf.certifier, R, t, certificate="system"), run_batch(cf, cf.certifier, R, t, V=V, certificate="joint")


def _near_singular(ik):
    """Poses a few 1e-7..1e-12 rad from a singularity of the arm (a random configuration with
    one joint moved next to zero): where the closed form or a certificate may give up."""
    rng = np.random.default_rng(4)
    out = []
    for k in range(12):
        q = rng.uniform(-2.5, 2.5, 6)
        q[[2, 4][k % 2]] = 10.0 ** -rng.uniform(7, 12)
        out.append(q)
    return out


@pytest.mark.parametrize("robot,frame,lock,family", ARMS)
def test_same_verdicts_and_roots_as_krawczyk_on_the_system(robot, frame, lock, family):
    ik = _ik(robot, frame, lock)
    poses = _poses(ik, 40, seed=21)
    if robot == "ur5":
        poses += [ik.pose_at(q) for q in _near_singular(ik)]
    cf, V, sysb, jb = _batches(ik, poses)
    assert np.array_equal(sysb.status, jb.status)
    assert np.array_equal(sysb.count, jb.count)
    assert np.sum(jb.status == POSE_CLOSED_FORM) >= 35
    for k in range(len(poses)):
        a = sysb.theta[sysb.first[k] : sysb.first[k] + sysb.count[k]]
        b = jb.theta[jb.first[k] : jb.first[k] + jb.count[k]]
        assert np.array_equal(a, b)
    # each proof box is narrow and about the closed form's root (arm angles)
    jc = cf.joint_certifier
    th = np.empty_like(jb.theta)
    th[:, jc.perm] = jb.theta + jc.shift
    assert np.all(jb.jlo <= th) and np.all(th <= jb.jhi)
    assert np.max(jb.jhi - jb.jlo) < 1e-9


@pytest.mark.parametrize("robot,frame,lock,family", ARMS)
def test_the_joint_certificate_decides_every_pose_the_system_one_does(robot, frame, lock, family):
    """Every pose the closed form answers with Krawczyk on the kinbox system it answers with
    Krawczyk in the joint angles too (the constants' radii make a root's error bound wider;
    the proof boxes a decade apart of ``PROOF_GROWTH`` still find one next to a singularity),
    but a few next to a singularity whose root enclosures are too wide (over 1e-7) for a box in
    the joint angles to hold and be proven: there a box in the system's variables, whose rows
    are polynomials, still is (``test_an_enclosure_outside_its_proof_box_sends_the_pose_on``)."""
    ik = _ik(robot, frame, lock)
    poses = _poses(ik, 1500, seed=31)
    cf, _, sysb, jb = _batches(ik, poses)
    decided = sysb.status == POSE_CLOSED_FORM
    lost = np.nonzero(decided & (jb.status != POSE_CLOSED_FORM))[0]
    assert len(lost) <= 3
    for k in lost:
        n, enc, _ = cf.roots(poses[k].rotation, poses[k].translation)
        assert np.max(enc[:n, :, [1, 3]] - enc[:n, :, [0, 2]]) > 1e-7


def _arb_goal(v, g):
    """``G = C_0^-1 base M E^-1`` in ``arb`` (the arm's frames exact binary64 numbers; ``M``
    the pose of XYZQUAT ``v``, the rotation that of ``q / |q|``; inverted for a reversed chain)."""
    x, y, z, w = (arb(float(a)) for a in v[3:])
    s = 2 / (x * x + y * y + z * z + w * w)
    R = [
        [1 - s * (y * y + z * z), s * (x * y - z * w), s * (x * z + y * w)],
        [s * (x * y + z * w), 1 - s * (x * x + z * z), s * (y * z - x * w)],
        [s * (x * z - y * w), s * (y * z + x * w), 1 - s * (x * x + y * y)],
    ]
    M = (R, [arb(float(a)) for a in v[:3]])
    if g.chain.reversed:
        M = _inv(M)

    def const(T):
        return [[arb(float(a)) for a in row] for row in T.rotation], [arb(float(a)) for a in T.translation]

    return _mul(_mul(_inv(const(g.C0)), const(g.chain.base)), _mul(M, _inv(const(g.E))))


def _mul(A, B):
    RA, tA = A
    RB, tB = B
    R = [[sum((RA[r][k] * RB[k][c] for k in range(3)), arb(0)) for c in range(3)] for r in range(3)]
    return R, [sum((RA[r][k] * tB[k] for k in range(3)), arb(0)) + tA[r] for r in range(3)]


def _inv(A):
    R, t = A
    Rt = [[R[c][r] for c in range(3)] for r in range(3)]
    return Rt, [-sum((Rt[r][k] * t[k] for k in range(3)), arb(0)) for r in range(3)]


def _arb_links(g):
    """The template's binary64 links, exact, in ``arb``: ``(R, t)`` per link."""
    return [([[arb(float(a)) for a in row] for row in L.R], [arb(float(a)) for a in L.t]) for L in g.links]


def _arb_fk(th, g, links=None):
    """``Rz(th_1) Tz(d_1) L_1 ... L_5 Rz(th_6) Tz(d_6)`` in ``arb`` (``links``: default the
    template's, :func:`_arb_links`)."""
    links = links or _arb_links(g)
    T = ([[arb(1) if r == c else arb(0) for c in range(3)] for r in range(3)], [arb(0)] * 3)
    for i in range(6):
        c, s = th[i].cos(), th[i].sin()
        T = _mul(T, ([[c, -s, arb(0)], [s, c, arb(0)], [arb(0), arb(0), arb(1)]], [arb(0), arb(0), arb(float(g.d[i]))]))
        if i < 5:
            T = _mul(T, links[i])
    return T


def _arb_root(th0, g, G, links=None):
    """Newton in 200-bit balls on the position and the skew part of ``R_G^T R`` (the float
    Jacobian by differences): the root near ``th0``, the largest of these six equations there,
    and the largest entry of ``T - G`` (the other equations hold to the rounding of the arm's
    constant frames, whose rotations are orthogonal to an ulp or so)."""

    def F(th):
        R, t = _arb_fk(th, g, links)
        RG, tG = G
        E = [[sum((RG[k][r] * R[k][c] for k in range(3)), arb(0)) for c in range(3)] for r in range(3)]
        return [t[0] - tG[0], t[1] - tG[1], t[2] - tG[2], E[2][1] - E[1][2], E[0][2] - E[2][0], E[1][0] - E[0][1]]

    th = [arb(float(a)) for a in th0]
    h = 1e-7
    J = np.empty((6, 6))
    f0 = np.array([float(v.mid()) for v in F(th)])
    for j in range(6):
        tj = list(th)
        tj[j] = tj[j] + h
        J[:, j] = (np.array([float(v.mid()) for v in F(tj)]) - f0) / h
    for _ in range(12):
        f = np.array([float(v.mid()) for v in F(th)])
        step = np.linalg.solve(J, f)
        th = [a - arb(float(b)) for a, b in zip(th, step)]
    six = max(abs(float(v.mid())) for v in F(th))
    R, t = _arb_fk(th, g, links)
    RG, tG = G
    off = max(
        max(abs(float((R[r][c] - RG[r][c]).mid())) for r in range(3) for c in range(3)),
        max(abs(float((t[r] - tG[r]).mid())) for r in range(3)),
    )
    return th, six, off


@pytest.mark.parametrize("robot,frame,lock,family", [ARMS[0], ARMS[3]])
def test_proof_boxes_hold_the_200_bit_root(robot, frame, lock, family):
    ik = _ik(robot, frame, lock)
    poses = _poses(ik, 3, seed=5)
    cf, V, _, jb = _batches(ik, poses)
    g = ik.arm.geometry
    jc = cf.joint_certifier
    old = ctx.prec
    ctx.prec = 200
    try:
        checked = 0
        for k in range(len(poses)):
            G = _arb_goal(V[k], g)
            for m in range(jb.first[k], jb.first[k] + jb.count[k]):
                th0 = np.empty(6)
                th0[jc.perm] = jb.theta[m] + jc.shift
                th, six, off = _arb_root(th0, g, G)
                assert six < 1e-50 and off < 1e-14
                for i in range(6):
                    assert arb(float(jb.jlo[m, i])) < th[i] < arb(float(jb.jhi[m, i]))
                checked += 1
        assert checked >= 6
    finally:
        ctx.prec = old


def _roots_with_goals(poses, V, jb, jc, g):
    """Each root of the joint batch ``jb`` as ``(th0, G, goal)``: its joint angles in the model's
    order, the 200-bit goal of its pose and that goal's midpoint-radius enclosure
    ``(Gm, Gr, gtm, gtr)`` as the kernels take it (arrays reused from pose to pose)."""
    GR, Gt = np.empty((3, 3, 2)), np.empty((3, 2))
    Gm, Gr, gtm, gtr = np.empty((3, 3)), np.empty((3, 3)), np.empty(3), np.empty(3)
    for p in range(len(poses)):
        cc.goal_enclosure(V[p], jc.AR, jc.At, jc.BR, jc.Bt, jc.reversed, GR, Gt)
        cc.goal_mr(GR, Gt, Gm, Gr, gtm, gtr)
        G = _arb_goal(V[p], g)
        for m in range(jb.first[p], jb.first[p] + jb.count[p]):
            th0 = np.empty(6)
            th0[jc.perm] = jb.theta[m] + jc.shift
            yield th0, G, (Gm, Gr, gtm, gtr)


def _inside(lo, hi, th) -> bool:
    return all(arb(float(lo[i])) < th[i] < arb(float(hi[i])) for i in range(6))


def test_the_certificate_covers_every_model_within_the_radii():
    """The links enter Krawczyk as midpoint and radius: with a radius of 1e-12 on the longest
    link translation, the proof box holds the root of the arm whose link is 1e-12 longer or
    shorter (200-bit Newton); the same proof without that radius gives a box of a few ulps
    about the binary64 arm's root, which misses both."""
    ik = _ik(*ARMS[0][:3])
    poses = _poses(ik, 2, seed=9)
    cf, V, _, jb = _batches(ik, poses)
    g = ik.arm.geometry
    jc = cf.joint_certifier
    i, k = np.unravel_index(np.argmax(np.abs(jc.Lt[..., 0])), jc.Lt.shape[:2])
    delta = 1e-12
    Lt_wide = jc.Lt.copy()
    Lt_wide[i, k, 1] += delta
    Lt_bare = jc.Lt.copy()
    Lt_bare[..., 1] = 0.0
    LR_bare = jc.LR.copy()
    LR_bare[..., 1] = 0.0
    ws = cc.workspace()
    old = ctx.prec
    ctx.prec = 200
    try:
        checked = 0
        for th0, G, goal in _roots_with_goals(poses, V, jb, jc, g):
            rad = cc.PROOF_RADIUS * (1 + np.abs(th0))
            wlo, whi, blo, bhi = np.empty(6), np.empty(6), np.empty(6), np.empty(6)
            assert cc.krawczyk6(th0, rad, jc.LR, Lt_wide, jc.d, *goal, wlo, whi, ws) == cc.CERT_UNIQUE
            assert cc.krawczyk6(th0, rad, LR_bare, Lt_bare, jc.d, *goal, blo, bhi, ws) == cc.CERT_UNIQUE
            for sign in (1, -1):
                links = _arb_links(g)
                links[i][1][k] = links[i][1][k] + sign * arb(delta)
                th, six, _ = _arb_root(th0, g, G, links)
                assert six < 1e-50
                assert _inside(wlo, whi, th)
                assert not _inside(blo, bhi, th)
                checked += 1
        assert checked >= 8
    finally:
        ctx.prec = old


def test_a_box_without_a_root_is_not_certified():
    """The same test on the box moved off the root by 100 of its radii, or on another pose's
    goal, proves nothing."""
    ik = _ik(*ARMS[0][:3])
    poses = _poses(ik, 2, seed=9)
    cf, V, _, jb = _batches(ik, poses)
    jc = cf.joint_certifier
    ws = cc.workspace()
    GR, Gt = np.empty((3, 3, 2)), np.empty((3, 2))
    Gm, Gr, gtm, gtr = np.empty((3, 3)), np.empty((3, 3)), np.empty(3), np.empty(3)
    cc.goal_enclosure(V[0], jc.AR, jc.At, jc.BR, jc.Bt, jc.reversed, GR, Gt)
    cc.goal_mr(GR, Gt, Gm, Gr, gtm, gtr)
    th = np.empty(6)
    th[jc.perm] = jb.theta[0] + jc.shift
    rad = cc.PROOF_RADIUS * (1 + np.abs(th))
    klo, khi = np.empty(6), np.empty(6)
    assert cc.krawczyk6(th, rad, jc.LR, jc.Lt, jc.d, Gm, Gr, gtm, gtr, klo, khi, ws) == cc.CERT_UNIQUE
    for i in range(6):
        moved = th.copy()
        moved[i] += 100 * rad[i]
        assert cc.krawczyk6(moved, rad, jc.LR, jc.Lt, jc.d, Gm, Gr, gtm, gtr, klo, khi, ws) == cc.CERT_FAILED
    cc.goal_enclosure(V[1], jc.AR, jc.At, jc.BR, jc.Bt, jc.reversed, GR, Gt)
    cc.goal_mr(GR, Gt, Gm, Gr, gtm, gtr)
    assert cc.krawczyk6(th, rad, jc.LR, jc.Lt, jc.d, Gm, Gr, gtm, gtr, klo, khi, ws) == cc.CERT_FAILED


def test_single_pose_answer_is_whole_on_demand():
    """``IK.solve`` of a pose the closed form decides: certified in the joint angles, its bound
    system and solver record built when asked for (the same roots, boxes on the kinbox
    system), the JSON and a pickle as those of any answer."""
    import pickle

    ik = _ik(*ARMS[0][:3])
    pose = _poses(ik, 1, seed=13)[0]
    res = ik.solve(pose)
    assert res.stats["method"] == "closed-form" and res.stats["certificate"] == "joint angles"
    assert res.complete and all(s.certified and s.residual < 1e-9 for s in res.solutions)
    assert len(res.raw.boxes) == len(res.solutions) and all(b.certified for b in res.raw.boxes)
    for s in res.solutions:  # the system point of each solution decodes to its configuration
        q = res.formulated.decode(s.x)
        assert np.max(np.abs(np.angle(np.exp(1j * (q - s.q))))) < 1e-9
    d = res.to_dict()
    assert len(d["solutions"]) == len(res.solutions)
    back = pickle.loads(pickle.dumps(res))
    assert [list(s.q) for s in back.solutions] == [list(s.q) for s in res.solutions]
    again = ik.solve(pose, all_turns=True)
    assert len(again.solutions) == res.stats["configurations_within_limits"]


def _arb_jacobian(th, g, G):
    """``J`` of the six equations at ``th`` in ``arb``: columns ``w_i x (p - o_i)`` and ``1/2
    (trace(R_G^T R) w_i - R R_G^T w_i)`` (``w_i``, ``o_i``: joint ``i``'s axis and origin)."""
    links = _arb_links(g)
    T = ([[arb(1) if r == c else arb(0) for c in range(3)] for r in range(3)], [arb(0)] * 3)
    axes = []
    for i in range(6):
        axes.append(([T[0][r][2] for r in range(3)], list(T[1])))
        c, s = th[i].cos(), th[i].sin()
        T = _mul(T, ([[c, -s, arb(0)], [s, c, arb(0)], [arb(0), arb(0), arb(1)]], [arb(0), arb(0), arb(float(g.d[i]))]))
        if i < 5:
            T = _mul(T, links[i])
    R, p = T
    RG, _ = G
    tr = sum((RG[r][c] * R[r][c] for r in range(3) for c in range(3)), arb(0))
    J = [[None] * 6 for _ in range(6)]
    for i, (w, o) in enumerate(axes):
        b = [p[q] - o[q] for q in range(3)]
        for q in range(3):
            a, c = (q + 1) % 3, (q + 2) % 3
            J[q][i] = w[a] * b[c] - w[c] * b[a]
        gw = [sum((RG[r][k] * w[r] for r in range(3)), arb(0)) for k in range(3)]  # R_G^T w
        for q in range(3):
            J[3 + q][i] = (tr * w[q] - sum((R[q][k] * gw[k] for k in range(3)), arb(0))) / 2
    return J


@pytest.mark.parametrize("robot,frame,lock,family", [ARMS[0], ARMS[3]])
def test_jacobian_radii_bound_the_error(robot, frame, lock, family):
    """``J(m)`` is computed in binary64 with one error bound per row block
    (``cf_certify._jacobian_radii``): every entry within it of the Jacobian of the binary64
    arm computed in 200-bit balls, at the closed form's roots and at points off them; the
    bound is at the rounding level (Krawczyk adds about 1e-8 to it)."""
    ik = _ik(robot, frame, lock)
    poses = _poses(ik, 2, seed=17)
    cf, V, _, jb = _batches(ik, poses)
    g = ik.arm.geometry
    jc = cf.joint_certifier
    ws = cc.workspace()
    LR_bare = jc.LR.copy()
    LR_bare[..., 1] = 0.0
    Lt_bare = jc.Lt.copy()
    Lt_bare[..., 1] = 0.0
    rng = np.random.default_rng(3)
    old = ctx.prec
    ctx.prec = 200
    try:
        checked = 0
        for th0, G, goal in _roots_with_goals(poses, V, jb, jc, g):
            for th in (th0, th0 + rng.uniform(-0.5, 0.5, 6)):
                cc._at_point(th, LR_bare, Lt_bare, jc.d, *goal, ws)
                Jm, Jr = ws[6], ws[7]
                J = _arb_jacobian([arb(float(a)) for a in th], g, G)
                for q in range(6):
                    assert Jr[q, 0] < 1e-11
                    for i in range(6):
                        assert Jr[q, i] == Jr[q, 0]
                        err = abs(J[q][i] - arb(float(Jm[q, i])))
                        assert err < arb(float(Jr[q, i])), (q, i, float(err.mid()), Jr[q, i])
                checked += 1
        assert checked >= 8
    finally:
        ctx.prec = old


def test_inverse_is_the_inverse():
    """``cf_certify._inverse`` (Gauss-Jordan in place, rows interchanged by partial pivoting)
    against numpy's, on well and badly scaled matrices and ones whose first pivot is zero; a
    singular matrix has none."""
    rng = np.random.default_rng(8)
    Y, M = np.empty((6, 6)), np.empty((6, 12))
    for k in range(300):
        A = rng.normal(size=(6, 6)) * (10.0 ** rng.uniform(-2, 2, 6))
        if k % 3 == 0:
            A[0, 0] = 0.0
        assert cc._inverse(A, Y, M)
        ref = np.linalg.inv(A)
        assert np.allclose(Y, ref, rtol=1e-9, atol=1e-12 * np.max(np.abs(ref)))
    A = rng.normal(size=(6, 6))
    A[:, 4] = 0.0
    assert not cc._inverse(A, Y, M)


def _arb_frames(th, g):
    """The rotation's columns, the position, each joint's axis and a point of it at ``th``, in
    ``arb`` (the template's binary64 links exact): what :func:`cf_certify.fk_mr` encloses."""
    links = _arb_links(g)
    T = ([[arb(1) if r == c else arb(0) for c in range(3)] for r in range(3)], [arb(0)] * 3)
    axes, points = [], []
    for i in range(6):
        axes.append([T[0][r][2] for r in range(3)])
        points.append(list(T[1]))
        c, s = th[i].cos(), th[i].sin()
        T = _mul(T, ([[c, -s, arb(0)], [s, c, arb(0)], [arb(0), arb(0), arb(1)]], [arb(0), arb(0), arb(float(g.d[i]))]))
        if i < 5:
            T = _mul(T, links[i])
    return T[0], T[1], axes, points


@pytest.mark.parametrize("robot,frame,lock,family", [ARMS[0], ARMS[3]])
def test_forward_kinematics_radii_hold_the_200_bit_frames(robot, frame, lock, family):
    """``fk_mr``'s one radius per row (rotation, position, axes, points): every entry within it
    of the binary64 arm's frames computed in 200-bit balls, at the closed form's roots and at
    points off them; the radii at the rounding level, and a hundredth of them misses some entry
    (the bound, :data:`cf_certify.TRIG_ERR` eight ulps wide, is not slack by two decades)."""
    ik = _ik(robot, frame, lock)
    poses = _poses(ik, 2, seed=17)
    cf, V, _, jb = _batches(ik, poses)
    g = ik.arm.geometry
    jc = cf.joint_certifier
    LR_bare = jc.LR.copy()
    LR_bare[..., 1] = 0.0
    Lt_bare = jc.Lt.copy()
    Lt_bare[..., 1] = 0.0
    Cm, tm, wm, om, cs, er = np.empty((3, 3)), np.empty(3), np.empty((6, 3)), np.empty((6, 3)), np.empty((6, 2)), np.empty((4, 3))
    rng = np.random.default_rng(3)
    old = ctx.prec
    ctx.prec = 200
    try:
        checked, worst = 0, 0.0
        for th0, _, _ in _roots_with_goals(poses, V, jb, jc, g):
            for th in (th0, th0 + rng.uniform(-0.5, 0.5, 6)):
                cc.fk_mr(th, LR_bare, Lt_bare, jc.d, Cm, tm, wm, om, cs, er)
                R, t, axes, points = _arb_frames([arb(float(a)) for a in th], g)
                assert np.all(er < 1e-13)
                for r in range(3):
                    pairs = [(R[r][k], Cm[k, r], er[0, r]) for k in range(3)] + [(t[r], tm[r], er[1, r])]
                    pairs += [(axes[i][r], wm[i, r], er[2, r]) for i in range(6)] + [(points[i][r], om[i, r], er[3, r]) for i in range(6)]
                    for exact, mid, rad in pairs:
                        err = abs(exact - arb(float(mid)))
                        assert err < arb(float(rad)), (r, float(err.mid()), rad)
                        if rad > 0.0:
                            worst = max(worst, float(err.mid()) / rad)
                for i in range(6):
                    assert abs(cs[i, 0] - np.cos(th[i])) <= cc.TRIG_ERR and abs(cs[i, 1] - np.sin(th[i])) <= cc.TRIG_ERR
                checked += 1
        assert checked >= 8
        assert worst > 0.01
    finally:
        ctx.prec = old


@pytest.mark.parametrize("robot,frame,lock,family", [ARMS[0], ARMS[3]])
def test_goal_enclosure_holds_the_200_bit_goal(robot, frame, lock, family):
    """``goal_mr_of`` (midpoint-radius throughout; a reversed chain's goal inverted first) holds
    the goal computed in 200-bit balls, within radii at the rounding level and not slack by a
    factor 20; the same as the interval enclosure ``goal_enclosure`` within the two's radii."""
    ik = _ik(robot, frame, lock)
    poses = _poses(ik, 20, seed=23)
    V = np.array([pin.SE3ToXYZQUAT(p) for p in poses])
    V[:, 3:] *= 1.0 + 1e-9 * np.random.default_rng(2).uniform(-1, 1, (len(poses), 1))  # q / |q| with |q| != 1
    g = ik.arm.geometry
    jc = ik.closed_form.joint_certifier
    FR, Ft, S = np.empty((2, 2, 3, 3)), np.empty((2, 2, 3)), np.empty((6, 3, 3))
    cc.frames_mr(jc.AR, jc.At, jc.BR, jc.Bt, FR, Ft)
    Gm, Gr, gtm, gtr = np.empty((3, 3)), np.empty((3, 3)), np.empty(3), np.empty(3)
    GR, Gt = np.empty((3, 3, 2)), np.empty((3, 2))
    old = ctx.prec
    ctx.prec = 200
    try:
        worst = 0.0
        for v in V:
            cc.goal_mr_of(v, FR, Ft, jc.reversed, Gm, Gr, gtm, gtr, S)
            cc.goal_enclosure(v, jc.AR, jc.At, jc.BR, jc.Bt, jc.reversed, GR, Gt)
            RG, tG = _arb_goal(v, g)
            assert np.all(Gr < 1e-14) and np.all(gtr < 1e-14)
            for r in range(3):
                pairs = [(RG[r][c], Gm[c, r], Gr[c, r], GR[c, r]) for c in range(3)] + [(tG[r], gtm[r], gtr[r], Gt[r])]
                for exact, mid, rad, box in pairs:
                    err = abs(exact - arb(float(mid)))
                    assert err < arb(float(rad))
                    assert box[0] - rad <= mid <= box[1] + rad
                    worst = max(worst, float(err.mid()) / rad)
        assert worst > 0.05
    finally:
        ctx.prec = old


def test_box_trig_holds_the_200_bit_functions():
    """``box_trig_at``: ``cos`` and ``sin`` of the family's angles (arm angles less their shift)
    over a proof box, from the binary64 ``cos``, ``sin`` at its centre, hold those of the box's
    ends and centre computed in 200-bit balls, with and without a shift; boxes a hair wide and
    wide ones, about angles near 0, pi/2 and pi."""
    rng = np.random.default_rng(6)
    perm = np.array([3, 0, 1, 2, 5, 4], dtype=np.int64)
    bt = np.empty((6, 4))
    old = ctx.prec
    ctx.prec = 200
    try:
        for k in range(60):
            th = rng.uniform(-np.pi, np.pi, 6)
            th[k % 6] = [0.0, np.pi / 2, np.pi, -np.pi / 2][k % 4] + rng.uniform(-1e-12, 1e-12)
            shift = rng.uniform(-3, 3, 6) if k % 2 else np.zeros(6)
            half = 10.0 ** rng.uniform(-15, -3, 6)
            lo, hi = th - half, th + half * rng.uniform(0.2, 1.0, 6)
            cs = np.stack([np.cos(th), np.sin(th)], axis=1)
            csh = np.stack([np.cos(shift), np.sin(shift)], axis=1)
            cc.box_trig_at(th, lo, hi, cs, perm, shift, csh, bt)
            for i in range(6):
                a = perm[i]
                for x in (lo[a], th[a], hi[a]):
                    phi = arb(float(x)) - arb(float(shift[i]))
                    assert arb(float(bt[i, 0])) < phi.cos() < arb(float(bt[i, 1]))
                    assert arb(float(bt[i, 2])) < phi.sin() < arb(float(bt[i, 3]))
                assert bt[i, 1] - bt[i, 0] < 4 * (hi[a] - lo[a]) + 1e-14
    finally:
        ctx.prec = old


def test_enclosure_reach_holds_the_enclosures_angles():
    """Every angle whose ``(cos, sin)`` lies in an enclosure lies within ``enclosure_reach``'s
    bound (and its quick bound, without square roots, above it) of the proof box's centre
    (arm angles: shifted, the centre moved as Newton moves it), sampled densely over boxes of
    widths 1e-12 to 1e-2; an enclosure too wide to bound an angle (half-diagonal over 0.3 of
    its centre's length) is not held."""
    rng = np.random.default_rng(8)
    need = np.empty(6)
    perm = np.array([3, 0, 1, 5, 2, 4], dtype=np.int64)
    tight = 0.0
    for trial in range(200):
        true = rng.uniform(-np.pi, np.pi, 6)
        w = 10.0 ** rng.uniform(-12, -2, 6)
        enc = np.empty((6, 4))
        enc[:, 0] = np.cos(true) - w * rng.uniform(0.1, 1.0, 6)
        enc[:, 1] = np.cos(true) + w * rng.uniform(0.1, 1.0, 6)
        enc[:, 2] = np.sin(true) - w * rng.uniform(0.1, 1.0, 6)
        enc[:, 3] = np.sin(true) + w * rng.uniform(0.1, 1.0, 6)
        shift = np.where(rng.uniform(size=6) < 0.5, 0.0, rng.uniform(-1.0, 1.0, 6))
        ang = np.arctan2(0.5 * (enc[:, 2] + enc[:, 3]), 0.5 * (enc[:, 0] + enc[:, 1]))
        th = np.empty(6)
        th[perm] = ang + shift + rng.uniform(-1e-7, 1e-7, 6) * (trial % 2)
        quick = np.empty(6)
        assert cc.enclosure_reach(enc, ang, th, perm, shift, quick, False)
        assert cc.enclosure_reach(enc, ang, th, perm, shift, need)
        assert np.all(need <= quick)
        for i in range(6):
            phi = true[i] + np.linspace(-3.0, 3.0, 2001) * w[i]
            inside = (enc[i, 0] <= np.cos(phi)) & (np.cos(phi) <= enc[i, 1]) & (enc[i, 2] <= np.sin(phi)) & (np.sin(phi) <= enc[i, 3])
            d = np.abs(np.angle(np.exp(1j * (phi[inside] + shift[i] - th[perm[i]]))))
            assert np.all(d <= need[perm[i]])
            tight = max(tight, float(d.max()) / need[perm[i]])
        rad = need * 1.01
        assert cc.enclosure_held(enc, ang, th, rad, perm, shift, need)
        rad[perm[0]] = need[perm[0]] * 0.99
        assert not cc.enclosure_held(enc, ang, th, rad, perm, shift, need)
    assert tight > 0.5  # the bound is not slack by a factor of two
    enc = np.tile([0.4, 1.0, -0.3, 0.3], (6, 1))  # half-diagonal 0.42 about (0.7, 0)
    assert not cc.enclosure_reach(enc, np.zeros(6), np.zeros(6), np.arange(6), np.zeros(6), need)


@pytest.mark.parametrize("certificate", ["joint", "system"])
def test_an_enclosure_outside_its_proof_box_sends_the_pose_on(certificate):
    """A root's enclosure must lie in a box where Krawczyk proved one root: the goal widened to
    3e-9 makes some enclosures wider than the proof boxes (1e-9), and a larger box proven about
    each keeps every generic pose in the closed form with the same roots; widened to 1e-4 the
    closed form still decides, but no box holding the enclosures is proven: every such pose
    goes to the branch and prune."""
    ik = _ik("ur5", "tool0", {})
    cf = ik.closed_form
    poses = _poses(ik, 12, seed=31)
    R = np.array([p.rotation for p in poses])
    t = np.array([p.translation for p in poses])
    V = np.array([pin.SE3ToXYZQUAT(p) for p in poses])
    base = run_batch(cf, cf.certifier, R, t, V=V, certificate=certificate)
    assert np.all(base.status == POSE_CLOSED_FORM)
    old = cf.delta
    need = np.empty(6)
    jc = cf.joint_certifier
    try:
        cf.delta = Delta(3e-9, 3e-9, 0.0)
        wide = run_batch(cf, cf.certifier, R, t, V=V, certificate=certificate)
        outside = 0
        for k in range(len(poses)):
            n, enc, _ = cf.roots(R[k], t[k])
            for r in range(n):
                ang = np.arctan2(0.5 * (enc[r, :, 2] + enc[r, :, 3]), 0.5 * (enc[r, :, 0] + enc[r, :, 1]))
                th = np.empty(6)
                th[jc.perm] = ang + jc.shift
                rad = cc.PROOF_RADIUS * (1.0 + np.abs(th))
                outside += not cc.enclosure_held(enc[r], ang, th, rad, jc.perm, jc.shift, need)
        assert outside > 0  # the larger boxes were needed
        assert np.sum(wide.status == POSE_CLOSED_FORM) >= 10
        ok = wide.status == POSE_CLOSED_FORM
        assert np.array_equal(wide.count[ok], base.count[ok])
        cf.delta = Delta(1e-4, 1e-4, 0.0)
        decided = [k for k in range(len(poses)) if cf.roots(R[k], t[k])[0] >= 0]
        assert decided
        wider = run_batch(cf, cf.certifier, R, t, V=V, certificate=certificate)
        assert np.all(wider.status[decided] != POSE_CLOSED_FORM)
    finally:
        cf.delta = old
