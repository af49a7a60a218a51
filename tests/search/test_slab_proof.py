"""The sweep's decided slabs proven to hold one root of the model per enclosure for every angle
(kinbox.search.slab_proof): Krawczyk over pieces of the slab, its wide boxes agreeing with
krawczyk6 where both apply, the verdicts checked at points inside the slabs."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import kinbox
from kinbox.problems.selfmotion import linear_goal
from kinbox.search import slab_proof
from kinbox.search import sweep as sw_mod
from kinbox.search.cf_certify import CERT_UNIQUE, krawczyk6, workspace
from kinbox.search.closed_form import MAX_ROOTS, root_angles, solve_pose


def _setup(arm: str, frame: str, seed: int):
    ik = kinbox.IK(arm, frame)
    sw = ik.sweeper
    m = ik.robot.model
    rng = np.random.default_rng(seed)
    q = rng.uniform(m.lowerPositionLimit[: m.nq], m.upperPositionLimit[: m.nq]) if arm == "panda" else rng.uniform(-1, 1, m.nq)
    goal = ik.pose_at(q)
    lin = linear_goal(sw.values[:3], sw.frames(goal)[:3])
    lin.anchors = sw.anchors(goal)
    return sw, lin


def _start(sw, lin) -> float:
    """The first angle of the widest decided slab with roots (away from folds)."""
    slabs, _ = sw_mod.sweep(sw.forms[0], lin, sw.swept.lo, sw.swept.hi)
    return max((s for s in slabs if s.kind == sw_mod.DECIDED and s.count > 0), key=lambda s: s.b - s.a).a


ARMS = [("panda", "panda_hand", 3), pytest.param("tests/data/arms/skew_shoulder7_dh.json", "tool", 5, marks=pytest.mark.slow)]


@pytest.mark.parametrize("arm,frame,seed", ARMS)
def test_decided_slabs_are_proven_and_hold_their_count_inside(arm, frame, seed):
    """A stretch of the swept joint: most decided slabs proven; inside each proven slab, at
    three angles, the point closed form finds the slab's count, each root's enclosure in one of
    the proof's boxes of the piece about it (Krawczyk at that angle alone agrees)."""
    sw, lin = _setup(arm, frame, seed)
    cf = sw.forms[0]
    lo = _start(sw, lin)
    slabs, _ = sw_mod.sweep(cf, lin, lo, lo + 0.05, prove=True)
    dec = [s for s in slabs if s.kind == sw_mod.DECIDED and s.count > 0]
    assert dec and sum(s.proven for s in dec) >= 0.5 * len(dec)
    out = np.zeros((MAX_ROOTS, 6, 4))
    sc = np.zeros((4, 3, 4))
    jc = cf.joint_certifier
    ws = workspace()
    for s in [s for s in dec if s.proven][:5]:
        for t in np.linspace(s.a, s.b, 3):
            box = sw_mod.widened(cf, lin.enclosure(t, t))
            assert solve_pose(cf.code, cf.LR, cf.Lt, cf.d, *box, out, sc) == s.count
            pr = slab_proof.SlabProver(cf, lin, sw_mod.widened)
            bx, _, G = pr._boxes(t, t)
            ang, klo, khi = np.zeros(6), np.zeros(6), np.zeros(6)
            for k in range(s.count):
                root_angles(out[k], ang)
                rad = 1e-6 * (1.0 + np.abs(ang))
                assert krawczyk6(ang.copy(), rad, jc.LR, jc.Lt, jc.d, *G, klo, khi, ws) == CERT_UNIQUE


def test_the_wide_test_agrees_with_krawczyk6_on_small_boxes():
    """On boxes whose radii sum below 1e-3, krawczyk_wide and krawczyk6 give the same verdict
    and the same box; past 1e-3 krawczyk6 declines and the wide test may still prove."""
    sw, lin = _setup("panda", "panda_hand", 3)
    cf = sw.forms[0]
    jc = cf.joint_certifier
    t = _start(sw, lin)
    pr = slab_proof.SlabProver(cf, lin, sw_mod.widened)
    _, pbox, G = pr._boxes(t, t + 1e-4)
    out = np.zeros((MAX_ROOTS, 6, 4))
    n = solve_pose(cf.code, cf.LR, cf.Lt, cf.d, *pbox, out, np.zeros((4, 3, 4)))
    assert n > 0
    ws = workspace()
    ang = np.zeros(6)
    wide_only = 0
    for k in range(n):
        root_angles(out[k], ang)
        for r in (1e-5, 1e-4, 1.5e-4, 1e-3):
            rad = np.full(6, r)
            a = (np.zeros(6), np.zeros(6))
            b = (np.zeros(6), np.zeros(6))
            v6 = krawczyk6(ang.copy(), rad, jc.LR, jc.Lt, jc.d, *G, *a, ws)
            vw = slab_proof.krawczyk_wide(ang.copy(), rad, jc.LR, jc.Lt, jc.d, *G, *b, ws)
            if 6 * r * (1 + 2.0**-40) < 1e-3:
                assert v6 == vw
                if v6 == CERT_UNIQUE:
                    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
            else:
                assert v6 != CERT_UNIQUE
                wide_only += vw == CERT_UNIQUE
    assert wide_only > 0


def test_no_proof_where_the_goal_box_leaves_the_roots_apart():
    """The same slabs with the arm's Delta a metre: the closed form is not decided on the
    pieces' goal boxes, and no slab is proven (the prover says so rather than stay silent)."""
    sw, lin = _setup("panda", "panda_hand", 3)
    cf = sw.forms[0]
    lo = _start(sw, lin)
    slabs, _ = sw_mod.sweep(cf, lin, lo, lo + 0.01, prove=True)
    dec = [s for s in slabs if s.kind == sw_mod.DECIDED and s.count > 0]
    assert dec and any(s.proven for s in dec)
    old = cf.delta
    try:
        cf.delta = dataclasses.replace(old, R=1.0, t0=1.0)
        pr = slab_proof.SlabProver(cf, lin, sw_mod.widened)
        assert pr.ok and not any(pr.prove(s.a, s.b, s.count) for s in dec)
    finally:
        cf.delta = old


@pytest.mark.parametrize("arm,frame,seed", ARMS)
def test_the_compiled_goal_box_holds_the_sweeps(arm, frame, seed):
    """goal_box (compiled) holds the sweep's own box over the same angles -- LinearGoal.enclosure
    then widened -- and the eps of the proof on top, at most some ulps wider."""
    sw, lin = _setup(arm, frame, seed)
    cf = sw.forms[0]
    pr = slab_proof.SlabProver(cf, lin, sw_mod.widened)
    M, err, anc, cm, cr, delta, eps = pr.goal_args()
    lo, hi = np.empty(12), np.empty(12)
    rng = np.random.default_rng(0)
    for _ in range(50):
        a = rng.uniform(sw.swept.lo, sw.swept.hi)
        b = min(a + 10.0 ** rng.uniform(-7, -1), sw.swept.hi)
        for x, y in ((a, b), (a, a)):
            slab_proof.goal_box(x, y, M, err, anc, cm, cr, delta, eps, lo, hi)
            Rlo, Rhi, tlo, thi = sw_mod.widened(cf, lin.enclosure(x, y))
            ref_lo = np.concatenate([Rlo.ravel(), tlo])
            ref_hi = np.concatenate([Rhi.ravel(), thi])
            assert np.all(lo <= ref_lo - eps) and np.all(hi >= ref_hi + eps)
            assert np.all(ref_lo - lo <= eps + 1e-14) and np.all(hi - ref_hi <= eps + 1e-14)


def test_proven_slabs_hold_one_40_digit_root_per_enclosure():
    """Panda (last joint swept): at the middle of proven slabs, the six-joint arm locked there
    exactly (the swept joint's rotation folded into the tool, tests/support/oracles/mp_ik.py):
    Newton at 64 digits from each closed-form root converges to a root whose joint values lie
    in that root's enclosure, the roots distinct, as many as the slab's count."""
    import mpmath as mp

    from kinbox.answer.closed_form import joint_values
    from tests.support.oracles import mp_ik

    ik = kinbox.IK("panda", "panda_hand")
    sw, lin = _setup("panda", "panda_hand", 3)
    cf = sw.forms[0]
    m = ik.robot.model
    q = np.random.default_rng(3).uniform(m.lowerPositionLimit[: m.nq], m.upperPositionLimit[: m.nq])
    goal = ik.pose_at(q)
    lo = _start(sw, lin)
    slabs, _ = sw_mod.sweep(cf, lin, lo, lo + 0.01, prove=True)
    proven = [s for s in slabs if s.kind == sw_mod.DECIDED and s.proven and s.count > 0]
    assert proven
    chain = mp_ik.Chain(m, "panda_hand")
    assert chain.idx_q[-1] == sw.swept.idx_q
    out = np.zeros((MAX_ROOTS, 6, 4))
    for s in proven[:: max(1, len(proven) // 3)]:
        t = 0.5 * (s.a + s.b)
        (Rp, tp), ax = chain.place[-1], chain.axes[-1]
        Rt, tt = chain.tool
        rot = Rp * mp_ik._rot(ax, mp.mpf(t))
        six = mp_ik.Chain.__new__(mp_ik.Chain)
        six.joints, six.idx_q, six.axes, six.place = chain.joints[:-1], chain.idx_q[:-1], chain.axes[:-1], chain.place[:-1]
        six.tool = (rot * Rt, tp + rot * tt)
        box = sw_mod.widened(cf, lin.enclosure(t, t))
        n = solve_pose(cf.code, cf.LR, cf.Lt, cf.d, *box, out, np.zeros((4, 3, 4)))
        assert n == s.count
        theta = np.zeros((n, 6))
        for k in range(n):
            root_angles(out[k], theta[k])
        vals, _ = joint_values(cf, theta)
        found = []
        for k in range(n):
            real, _ = mp_ik.roots(six, mp_ik.exact_pose(goal), [vals[k]])
            assert len(real) == 1
            r = np.array([float(v) for v in real[0]])
            gap = np.abs(np.angle(np.exp(1j * (r - vals[k]))))
            half = 0.5 * np.max(out[k, :, 1::2] - out[k, :, 0::2], axis=1)  # cos and sin half-widths
            assert np.all(gap <= 2.0 * half + 1e-12), (gap, half)
            assert all(np.max(np.abs(np.angle(np.exp(1j * (r - f))))) > 1e-9 for f in found)
            found.append(r)
