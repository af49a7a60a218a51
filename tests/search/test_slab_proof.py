"""The sweep's decided slabs proven to hold one root of the model per enclosure for every angle
(kinbox.search.slab_proof): Krawczyk over pieces of the slab, its wide boxes agreeing with
krawczyk6 where both apply, the verdicts checked at points inside the slabs."""

from __future__ import annotations

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


ARMS = [("panda", "panda_hand", 3), ("tests/data/arms/skew_shoulder7_dh.json", "tool", 5)]


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
    """A slab whose goal box is widened by a metre: the closed form is not decided on its
    pieces, and no slab is proven (the prover says so rather than stay silent)."""
    sw, lin = _setup("panda", "panda_hand", 3)
    cf = sw.forms[0]
    lo = _start(sw, lin)
    slabs, _ = sw_mod.sweep(cf, lin, lo, lo + 0.01, prove=True)
    dec = [s for s in slabs if s.kind == sw_mod.DECIDED and s.count > 0]
    assert dec and any(s.proven for s in dec)

    def wide(cf, box):
        Rlo, Rhi, plo, phi = sw_mod.widened(cf, box)
        return Rlo, Rhi, plo - 1.0, phi + 1.0

    pr = slab_proof.SlabProver(cf, lin, wide)
    assert not any(pr.prove(s.a, s.b, s.count) for s in dec)
