"""The closed form's goal widening for the links' radii (kinbox.search.cf_delta): a bound on how
far arms within the radii move the tool from the family's binary64 arm, checked against their
forward kinematics in 200-bit mpmath; the widened closed form holds every root of such an arm,
the unwidened one misses them."""

from __future__ import annotations

import mpmath
import numpy as np
import pytest

from kinbox.search import cf_delta
from kinbox.search.closed_form import MAX_ROOTS, _goal_arrays, solve_pose
from tests.support.arms import ARMS, _ik, _poses

#: an artificial radius, far above the rounding, so that the arms within it differ visibly
BIG = 1e-9


def _mp(a):
    return mpmath.matrix(np.asarray(a, dtype=float).tolist())


def _rz(th):
    c, s = mpmath.cos(th), mpmath.sin(th)
    return mpmath.matrix([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _fk(th, LR, Lt, d):
    """``Rz(th_1) Tz(d_1) L_1 ... L_5 Rz(th_6) Tz(d_6)`` at the working precision: (R, t)."""
    R = mpmath.eye(3)
    t = mpmath.matrix(3, 1)
    for i in range(6):
        R = R * _rz(th[i])
        t = t + R * mpmath.matrix([0, 0, d[i]])
        if i < 5:
            t = t + R * Lt[i]
            R = R * LR[i]
    return R, t


def _small_rotation(rng, phi):
    """An exact (200-bit) rotation by ``phi`` about a random axis: within ``phi`` of the identity
    entry by entry."""
    a = rng.normal(size=3)
    a = mpmath.matrix((a / np.linalg.norm(a)).tolist())
    K = mpmath.matrix([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return mpmath.eye(3) + mpmath.sin(phi) * K + (1 - mpmath.cos(phi)) * (K * K)


def _radii(r_links: float, r_frames: float) -> dict:
    z = (np.zeros((3, 3)), np.zeros(3))
    links = [(np.full((3, 3), r_links), np.full(3, r_links)) for _ in range(5)]
    if not r_links:
        return dict(links=[z] * 5, A=z, B=z)
    frame = (np.full((3, 3), r_frames), np.full(3, r_frames))
    return dict(links=links, A=frame, B=frame)


def _perturbed(rng, cf, r):
    """Links and frames moved within ``r`` entry by entry, rotations exactly orthogonal."""
    LR = [_mp(R) * _small_rotation(rng, 0.9 * r) for R in cf.LR]
    Lt = [_mp(t) + _mp(rng.uniform(-0.9 * r, 0.9 * r, 3)) for t in cf.Lt]
    AR, At, BR, Bt = cf._frame_arrays
    A = (_mp(AR) * _small_rotation(rng, 0.9 * r), _mp(At) + _mp(rng.uniform(-0.9 * r, 0.9 * r, 3)))
    B = (_mp(BR) * _small_rotation(rng, 0.9 * r), _mp(Bt) + _mp(rng.uniform(-0.9 * r, 0.9 * r, 3)))
    return LR, Lt, A, B


def _compose(A, M, B):
    """``A M B`` of (R, t) pairs."""
    (AR, At), (MR, Mt), (BR, Bt) = A, M, B
    return AR * MR * BR, AR * (MR * Bt + Mt) + At


@pytest.mark.parametrize("robot,frame,lock,family", ARMS)
def test_delta_bounds_every_arm_within_the_radii(robot, frame, lock, family):
    """Arms and goal frames moved within a radius (exactly orthogonal rotations): at random
    angles and goals, ``T'(theta) - T(theta)`` plus ``A' M B' - A M B`` within the bound, entry
    by entry, in 200-bit arithmetic; the bound at most a few times what the arms reach (not
    slack by decades), and zero radii give zero."""
    cf = _ik(robot, frame, lock).closed_form
    Bt = cf._frame_arrays[3]
    assert cf_delta.delta_of(cf.LR, cf.Lt, cf.d, _radii(0.0, 0.0), Bt) == cf_delta.Delta(0.0, 0.0, 0.0)
    D = cf_delta.delta_of(cf.LR, cf.Lt, cf.d, _radii(BIG, BIG), Bt)
    assert D.proven
    rng = np.random.default_rng(5)
    LRf, Ltf = [_mp(R) for R in cf.LR], [_mp(t) for t in cf.Lt]
    AR, At, BR, Bt_ = cf._frame_arrays
    Af, Bf = (_mp(AR), _mp(At)), (_mp(BR), _mp(Bt_))
    worst = 0.0
    with mpmath.workprec(200):
        for _ in range(6):
            LR, Lt, A, B = _perturbed(rng, cf, BIG)
            for _ in range(3):
                th = [mpmath.mpf(float(x)) for x in rng.uniform(-np.pi, np.pi, 6)]
                Rp, tp = _fk(th, LR, Lt, cf.d)
                R0, t0 = _fk(th, LRf, Ltf, cf.d)
                q = rng.normal(size=4)
                Mr = _mp(_quat(q / np.linalg.norm(q)))
                Mt = _mp(rng.uniform(-1.0, 1.0, 3))
                Gp, gp = _compose(A, (Mr, Mt), B)
                G0, g0 = _compose(Af, (Mr, Mt), Bf)
                tn = float(mpmath.norm(Mt))
                for i in range(3):
                    ht = abs(tp[i] - t0[i]) + abs(gp[i] - g0[i])
                    assert ht <= D.t0 + D.t1 * tn
                    worst = max(worst, float(ht) / (D.t0 + D.t1 * tn))
                    for j in range(3):
                        hr = abs(Rp[i, j] - R0[i, j]) + abs(Gp[i, j] - G0[i, j])
                        assert hr <= D.R
                        worst = max(worst, float(hr) / D.R)
    assert worst > 0.02


def _quat(q):
    x, y, z, w = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def test_a_link_rotation_not_a_signed_permutation_is_not_proven():
    """Only signed permutations are exactly orthogonal in binary64: any other link rotation is
    no arm, and without the radii of its polar factor (``delta_of``'s ``e``: the arm compared
    against is then theirs, tests/search/test_cf_twist.py) the bound is not proven and the
    goal's box decides nothing (every pose goes to the branch and prune)."""
    cf = _ik("ur5", "tool0", {}).closed_form
    assert cf_delta.signed_permutation(cf.LR[0]) and not cf_delta.signed_permutation(np.eye(3) * 0.5)
    c, s = np.cos(0.3), np.sin(0.3)
    LR = cf.LR.copy()
    LR[0] = LR[0] @ np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    D = cf_delta.delta_of(LR, cf.Lt, cf.d, None, cf._frame_arrays[3])
    assert not D.proven
    ik = _ik("ur5", "tool0", {})
    pose = _poses(ik, 1, seed=3)[0]
    boxes = _goal_arrays(pose.rotation[None], pose.translation[None], *cf._frame_arrays, cf.reversed, cf.tmag0, cf.delta)
    out = np.zeros((MAX_ROOTS, 6, 4))
    assert solve_pose(cf.code, cf.LR, cf.Lt, cf.d, *(b[0] for b in boxes), out, np.zeros((4, 3, 4))) == 8
    boxes = _goal_arrays(pose.rotation[None], pose.translation[None], *cf._frame_arrays, cf.reversed, cf.tmag0, D)
    assert solve_pose(cf.code, cf.LR, cf.Lt, cf.d, *(b[0] for b in boxes), out, np.zeros((4, 3, 4))) == -1


def _newton(th, LR, Lt, d, R, t, steps=30):
    """Newton on the six equations ``p(theta) = t``, ``1/2 sum_k (R(theta) e_k) x (R e_k) = 0``
    at the working precision (the Jacobian by central differences at that precision)."""
    th = [mpmath.mpf(x) for x in th]

    def F(x):
        Rx, tx = _fk(x, LR, Lt, d)
        o = mpmath.matrix(3, 1)
        for k in range(3):
            a, b = Rx[:, k], R[:, k]
            o += mpmath.matrix([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])
        return mpmath.matrix([tx[0] - t[0], tx[1] - t[1], tx[2] - t[2], o[0] / 2, o[1] / 2, o[2] / 2])

    h = mpmath.mpf(2) ** -80
    for _ in range(steps):
        f = F(th)
        J = mpmath.matrix(6, 6)
        for j in range(6):
            xp, xm = list(th), list(th)
            xp[j] += h
            xm[j] -= h
            J[:, j] = (F(xp) - F(xm)) / (2 * h)
        step = mpmath.lu_solve(J, -f)
        th = [th[i] + step[i] for i in range(6)]
        if mpmath.norm(step) < mpmath.mpf(2) ** -180:
            break
    return th


def _held(enc, th) -> bool:
    """Is a root's ``(cos, sin)`` in a closed-form enclosure ``enc`` (6, 4)?"""
    return all(enc[i, 0] <= float(mpmath.cos(th[i])) <= enc[i, 1] and enc[i, 2] <= float(mpmath.sin(th[i])) <= enc[i, 3] for i in range(6))


def test_the_widened_goal_holds_the_perturbed_arms_roots():
    """UR5 with its upper arm 1e-9 m longer than the family's binary64 constants say (an
    artificial radius on one link length): the closed form on the unwidened goal misses the
    perturbed arm's roots (found by 200-bit Newton), the goal widened by the bound holds each
    of them in a root's enclosure, with the same count."""
    ik = _ik("ur5", "tool0", {})
    cf = ik.closed_form
    radii = _radii(0.0, 0.0)
    rt = np.zeros(3)
    rt[0] = BIG
    radii["links"] = list(radii["links"])
    radii["links"][1] = (np.zeros((3, 3)), rt)
    D = cf_delta.delta_of(cf.LR, cf.Lt, cf.d, radii, cf._frame_arrays[3])
    assert D.proven and D.t0 >= BIG and D.R == 0.0
    Lt = [_mp(t) for t in cf.Lt]
    Lt[1][0] += BIG
    LR = [_mp(R) for R in cf.LR]
    rng = np.random.default_rng(11)
    th0 = rng.uniform(-2.0, 2.0, 6)
    th0[2], th0[4] = 1.1, 0.9  # away from the elbow and wrist singularities
    with mpmath.workprec(200):
        Rm, tm = _fk([mpmath.mpf(float(x)) for x in th0], LR, Lt, cf.d)
        # the canonical goal of the perturbed arm at th0, as the binary64 goal of a pose
        GR = np.array([[float(Rm[i, j]) for j in range(3)] for i in range(3)])
        Gt = np.array([float(tm[i]) for i in range(3)])
        G = _frame_goal(cf, GR, Gt)  # the pose, rounded: its goal within GOAL_ERR of (Rm, tm)
        out = np.zeros((MAX_ROOTS, 6, 4))
        scratch = np.zeros((4, 3, 4))
        narrow = _goal_arrays(G[0][None], G[1][None], *cf._frame_arrays, cf.reversed, cf.tmag0)
        wide = _goal_arrays(G[0][None], G[1][None], *cf._frame_arrays, cf.reversed, cf.tmag0, D)
        n = solve_pose(cf.code, cf.LR, cf.Lt, cf.d, *(b[0] for b in narrow), out, scratch)
        assert n == 8
        roots = []
        for k in range(n):
            c, s = 0.5 * (out[k, :, 0] + out[k, :, 1]), 0.5 * (out[k, :, 2] + out[k, :, 3])
            th = _newton(np.arctan2(s, c), LR, Lt, cf.d, Rm, tm)
            Rx, tx = _fk(th, LR, Lt, cf.d)
            assert mpmath.norm(tx - tm) < 1e-40 and mpmath.mnorm(Rx - Rm, 1) < 1e-40
            roots.append(th)
        assert all(not any(_held(out[k], th) for k in range(n)) for th in roots)  # every one missed
        assert solve_pose(cf.code, cf.LR, cf.Lt, cf.d, *(b[0] for b in wide), out, scratch) == 8
        assert all(any(_held(out[k], th) for k in range(8)) for th in roots)


def _frame_goal(cf, GR, Gt):
    """The pose ``M`` whose canonical goal ``A M B`` is ``(GR, Gt)``: ``M = A^-1 G B^-1``
    (binary64; the test's goal is then that pose's, rounded as every pose is)."""
    AR, At, BR, Bt = cf._frame_arrays
    assert not cf.reversed
    Ai = np.linalg.inv(AR)
    Bi = np.linalg.inv(BR)
    MR = Ai @ GR @ Bi
    Mt = Ai @ (Gt - At) - MR @ Bt
    return MR, Mt
