"""A root's enclosure wider than any box Krawczyk proves about the root: the joint-angle batch
proves that it holds no other root by a Jacobian regular over a box holding it
(kinbox.search.cf_certify.jacobian_regular), checked against the 40-digit roots of the pose as
given (tests/support/oracles/mp_ik.py)."""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pinocchio as pin

from kinbox.search import cf_certify as cc
from kinbox.search.cf_batch import run_batch
from kinbox.search.closed_form import POSE_CLOSED_FORM
from tests.support.arms import ARMS, _ik, _poses
from tests.support.oracles import mp_ik


def _goal(jc, v):
    """The pose ``v`` (XYZQUAT) as the kernels take it: ``(Gm, Gr, gtm, gtr)``."""
    FR, Ft, gS = np.empty((2, 2, 3, 3)), np.empty((2, 2, 3)), np.empty((6, 3, 3))
    cc.frames_mr(jc.AR, jc.At, jc.BR, jc.Bt, FR, Ft)
    G = np.empty((3, 3)), np.empty((3, 3)), np.empty(3), np.empty(3)
    cc.goal_mr_of(v, FR, Ft, jc.reversed, *G, gS)
    return G


def _arm_angles(cf, jc, r, chain):
    """A 40-digit root ``r`` (the chain's joints) in the arm template's angles (mp)."""
    th = [mp.mpf(0)] * 6
    for i, j in enumerate(cf.joints):
        q = r[chain.idx_q.index(j.idx_q)]
        th[int(jc.perm[i])] = q + mp.mpf(float(cf.gamma[i])) + mp.mpf(float(jc.shift[i]))
    return th


def _in_box(th, lo, hi) -> bool:
    """Is the angle vector ``th`` (mp, modulo 2 pi) in the box ``[lo, hi]``?"""
    for a, lo_i, hi_i in zip(th, lo, hi):
        mid = mp.mpf(float(0.5 * (lo_i + hi_i)))
        a = a - 2 * mp.pi * mp.nint((a - mid) / (2 * mp.pi))
        if not (mp.mpf(float(lo_i)) <= a <= mp.mpf(float(hi_i))):
            return False
    return True


def _grown_boxes_fail(jc, G, enc, ang, th2):
    """``True`` where the root's enclosure reaches past its proof box and no box of
    :data:`~kinbox.search.cf_certify.HOLD_GROWTH` times its reach about the proven root is
    proven: the enclosure is decided only by :func:`~kinbox.search.cf_certify.jacobian_regular`
    (its radii, or None)."""
    need = np.empty(6)
    if not cc.enclosure_reach(enc, ang, th2, jc.perm, jc.shift, need):
        return None
    ws = cc.workspace()
    klo, khi = np.empty(6), np.empty(6)
    for grow in cc.HOLD_GROWTH:
        rad = np.maximum(cc.PROOF_RADIUS * (1.0 + np.abs(th2)), grow * need)
        if cc.krawczyk6(th2, rad, jc.LR, jc.Lt, jc.d, *G, klo, khi, ws) == cc.CERT_UNIQUE:
            return None
    return need


def test_a_regular_jacobian_decides_a_wide_enclosure():
    """Among 2,000 seeded random poses of the IRB 120-like arm, one next to a singularity whose
    roots' enclosures (over 1e-6 wide in the angles) no Krawczyk box about the root holds: the
    batch decides it in the closed form, each proof box holds its 40-digit root, each
    enclosure holds one 40-digit root, and the Jacobian is proven regular over a box holding
    the enclosure."""
    robot, frame, lock, _ = ARMS[1]
    ik = _ik(robot, frame, lock)
    cf = ik.closed_form
    jc = cf.joint_certifier
    poses = _poses(ik, 2000, seed=1)
    wide = []
    for k, p in enumerate(poses):
        n, enc, _ = cf.roots(p.rotation, p.translation)
        if n > 0 and np.max(enc[:n, :, [1, 3]] - enc[:n, :, [0, 2]]) > 1e-6:
            wide.append(k)
    assert wide
    R = np.array([poses[k].rotation for k in wide])
    t = np.array([poses[k].translation for k in wide])
    V = np.array([pin.SE3ToXYZQUAT(poses[k]) for k in wide])
    jb = run_batch(cf, cf.certifier, R, t, V=V, certificate="joint")
    chain = mp_ik.Chain(ik.robot.model, ik.frame)
    planted = 0
    for i, k in enumerate(wide):
        if jb.status[i] != POSE_CLOSED_FORM:
            continue
        n, enc, inside = cf.roots(R[i], t[i])
        G = _goal(jc, V[i])
        rows = range(jb.first[i], jb.first[i] + jb.count[i])
        needs = []
        for m in rows:
            th2 = 0.5 * (jb.jlo[m] + jb.jhi[m])
            # the root's enclosure: the one whose angles are the batch's root
            r = min(
                (r for r in range(n) if inside[r] == 1),
                key=lambda r: np.max(np.abs(np.angle(np.exp(1j * (_mid_angles(enc[r]) - jb.theta[m]))))),
            )
            ang = _mid_angles(enc[r])
            needs.append((m, r, th2, ang, _grown_boxes_fail(jc, G, enc[r], ang, th2)))
        if not any(nd is not None for *_, nd in needs):
            continue
        planted += 1
        mp.mp.dps = mp_ik.WORK
        seeds = []
        for q in ik.solve_array(V[i : i + 1]).solutions(0):
            seeds += mp_ik.wrist_and_elbow_seeds(q)
        real, _ = mp_ik.roots(chain, mp_ik.exact_pose(poses[k]), seeds)
        roots = [_arm_angles(cf, jc, x, chain) for x in real]
        ws = cc.workspace()
        v, w = np.empty(6), np.empty(6)
        for m, r, th2, _ang, need in needs:
            assert sum(_in_box(x, jb.jlo[m], jb.jhi[m]) for x in roots) == 1  # its proof box holds one 40-digit root
            held = [x for x in roots if _in_enclosure(x, enc[r], jc)]
            assert len(held) == 1 and _in_box(held[0], jb.jlo[m], jb.jhi[m])  # and its enclosure that one only
            if need is None:
                continue
            h = np.maximum(need, np.maximum(th2 - jb.jlo[m], jb.jhi[m] - th2)) * (1.0 + 2.0**-40)
            assert cc.jacobian_regular(th2, h, jc.LR, jc.Lt, jc.d, *G, ws, v, w)
        break
    assert planted == 1


def _mid_angles(enc):
    """The angles of an enclosure's ``(cos, sin)`` midpoints (the family's joints)."""
    return np.arctan2(0.5 * (enc[:, 2] + enc[:, 3]), 0.5 * (enc[:, 0] + enc[:, 1]))


def _in_enclosure(th, enc, jc) -> bool:
    """Do the cosines and sines of the arm angles ``th`` (mp) lie in the closed form's
    enclosure ``enc`` (the family's angles, shifted)?"""
    for i in range(6):
        a = th[int(jc.perm[i])] - mp.mpf(float(jc.shift[i]))
        c, s = mp.cos(a), mp.sin(a)
        if not (enc[i, 0] <= c <= enc[i, 1] and enc[i, 2] <= s <= enc[i, 3]):
            return False
    return True


def test_no_regular_jacobian_over_two_roots():
    """A UR5 1e-5 from its straight elbow: two 40-digit roots 2e-5 apart, and a box about
    their middle holding both (its Jacobian singular between them) is never proven regular,
    while a small box about either root alone (1e-3 of their distance) is."""
    ik = _ik(*ARMS[0][:3])
    cf = ik.closed_form
    jc = cf.joint_certifier
    q = np.array([0.3, -1.2, 1e-5, -0.8, 1.2, 0.4])
    goal = ik.pose_at(q)
    mp.mp.dps = mp_ik.WORK
    chain = mp_ik.Chain(ik.robot.model, ik.frame)
    real, _ = mp_ik.roots(chain, mp_ik.exact_pose(goal), mp_ik.wrist_and_elbow_seeds(q))
    th = [np.array([float(y) for y in _arm_angles(cf, jc, x, chain)]) for x in real]
    pairs = [(a, b) for i, a in enumerate(th) for b in th[i + 1 :] if np.max(np.abs(np.angle(np.exp(1j * (b - a))))) < 1e-3]
    assert len(pairs) >= 1
    G = _goal(jc, pin.SE3ToXYZQUAT(goal))
    ws = cc.workspace()
    v, w = np.empty(6), np.empty(6)
    for a, b in pairs:
        d = np.angle(np.exp(1j * (b - a)))
        dist = float(np.max(np.abs(d)))
        assert cc.jacobian_regular(a, np.full(6, 1e-3 * dist), jc.LR, jc.Lt, jc.d, *G, ws, v, w)
        assert not cc.jacobian_regular(a + 0.5 * d, np.abs(0.5 * d) + 0.1 * dist, jc.LR, jc.Lt, jc.d, *G, ws, v, w)
