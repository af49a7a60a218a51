"""Seven-joint self-motions by the sweep of an end joint (kinbox.problems.selfmotion,
kinbox.answer.selfmotion, kinbox.search.sweep)."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

import kinbox
from kinbox.answer import selfmotion as answer_selfmotion
from kinbox.search import sweep as sweep_mod
from kinbox.search.sweep import DECIDED, RELAXED, UNDECIDED, Slab, cos_sin_range, solve_points, sweep


@pytest.fixture(scope="module")
def panda():
    return kinbox.IK("panda", "panda_hand")


def _goal(ik, seed: int):
    m = ik.robot.model
    q = np.random.default_rng(seed).uniform(m.lowerPositionLimit[:7], m.upperPositionLimit[:7])
    return q, ik.pose_at(q)


def _linear(ik, goal):
    sw = ik.sweeper
    from kinbox.problems.selfmotion import _frame, linear_goal

    return sw, linear_goal(sw.values[:3], [_frame(cf, goal) for cf in sw.forms[:3]])


def test_swept_joint_found_from_geometry(panda):
    """The Panda's last joint is swept: locked, the other six are a closed-form family (the
    detector's verdict, not a name); an arm of six joints has no sweeper."""
    sw = panda.sweeper
    assert sw is not None
    assert sw.swept.name == panda.robot.model.names[panda.chain[-1]]
    assert all(cf.family.name == sw.forms[0].family.name for cf in sw.forms)
    assert kinbox.IK("ur5", "tool0").sweeper is None


def test_cos_sin_range_encloses():
    rng = np.random.default_rng(3)
    for _ in range(200):
        a = rng.uniform(-7, 7)
        b = a + rng.uniform(0, 3)
        (cl, ch), (sl, sh) = cos_sin_range(a, b)
        for t in np.linspace(a, b, 50):
            assert cl <= math.cos(t) <= ch and sl <= math.sin(t) <= sh


def test_decided_slabs_hold_the_point_counts(panda):
    """On a decided slab every value of the swept joint has the slab's root count, and each
    root lies in its slab's enclosure path: point evaluations inside agree."""
    _, goal = _goal(panda, 1)
    sw, lin = _linear(panda, goal)
    cf = sw.forms[0]
    slabs, _ = sweep(cf, lin, sw.swept.lo, sw.swept.hi)
    assert slabs[0].a == sw.swept.lo and slabs[-1].b == sw.swept.hi
    assert all(s.b == t.a for s, t in zip(slabs, slabs[1:]))
    assert not any(s.kind == UNDECIDED for s in slabs)
    rng = np.random.default_rng(0)
    dec = [s for s in slabs if s.kind == DECIDED]
    picks = [dec[k] for k in rng.choice(len(dec), 60, replace=False)]
    ts = [rng.uniform(s.a, s.b) for s in picks]
    b = solve_points(cf, lin, np.array(ts), certify=False)
    assert [int(c) for c in b.count] == [s.count for s in picks]


def test_points_close_forward_kinematics(panda):
    """Every configuration of every curve puts the hand at the goal to rounding (Pinocchio),
    is inside the joint limits, and the configuration the goal came from lies on a curve."""
    q, goal = _goal(panda, 1)
    res = panda.solve(goal)
    assert res.stats["method"] == "sweep" and res.complete
    assert res.curves and not res.solutions
    m = panda.robot.model
    d = m.createData()
    fid = m.getFrameId("panda_hand")
    lo, hi = m.lowerPositionLimit, m.upperPositionLimit
    for cv in res.curves.values():
        for qq in cv.branches[0]:
            pin.framesForwardKinematics(m, d, qq)
            err = pin.log6(goal.actInv(d.oMf[fid])).vector
            assert np.abs(err).max() < 1e-12
            assert np.all(qq[:7] >= lo[:7] - 1e-12) and np.all(qq[:7] <= hi[:7] + 1e-12)
    gap = min(np.abs(np.array(cv.branches[0])[:, :7] - q[:7]).max(axis=1).min() for cv in res.curves.values())
    assert gap < answer_selfmotion.STEP
    assert res.stats["certified_points"] > 0.9 * res.stats["curve_points"]


def test_undecided_slab_falls_back(panda, monkeypatch):
    """A slab the closed form decides not even relaxed (a pivot holding zero): no sweep
    answer, and the pose goes to the branch and prune."""
    _, goal = _goal(panda, 1)
    sw, lin = _linear(panda, goal)
    real = sweep_mod.sweep

    def with_undecided(cf, goal, lo, hi, **kw):
        slabs, runs = real(cf, goal, lo, hi, **kw)
        k = next(i for i, s in enumerate(slabs) if s.kind == RELAXED)
        slabs[k] = Slab(slabs[k].a, slabs[k].b, UNDECIDED, -1)
        return slabs, runs

    monkeypatch.setattr(answer_selfmotion, "sweep", with_undecided)
    prob = panda.problem(goal)
    assert sw.solve(prob, goal) is None


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2])
def test_agrees_with_branch_and_prune(panda, seed):
    """The same curves as the branch and prune: as many, every point of either within a
    sampling step of the other's."""
    _, goal = _goal(panda, seed)
    res = panda.solve(goal)
    bp = panda.solve(goal, closed_form=False, time_limit=3000)
    assert res.stats["method"] == "sweep" and bp.complete
    assert len(res.curves) == len(bp.curves) and not bp.solutions

    def pts(r):
        return np.array([q[:7] for cv in r.curves.values() for b in cv.branches for q in b])

    A, B = pts(res), pts(bp)
    gap = max(max(np.abs(B - a).max(axis=1).min() for a in A), max(np.abs(A - b).max(axis=1).min() for b in B))
    assert gap < 2 * answer_selfmotion.STEP


@pytest.fixture(scope="module")
def shoulder7():
    """A seven-joint arm whose first joint only gives a closed-form family (locked, the other
    six are an IRB 120): the sweep of the first joint, on the six rooted at a frame on it."""
    from tests.support.paths import DATA

    return kinbox.IK(str(DATA / "arms" / "skew_shoulder7_dh.json"), "tool")


def test_first_joint_sweep_closes_forward_kinematics(shoulder7):
    """The swept first joint's curves: every configuration puts the tool at the goal to
    rounding (Pinocchio, the seven-joint model with the world as base), inside the limits; the
    configuration the goal came from lies on a curve; the points are certified."""
    q, goal = _goal(shoulder7, 3)
    res = shoulder7.solve(goal)
    assert res.stats["method"] == "sweep" and res.complete
    assert res.stats["swept_joint"] == shoulder7.robot.model.names[shoulder7.chain[0]]
    assert res.curves and not res.solutions
    m = shoulder7.robot.model
    d = m.createData()
    fid = m.getFrameId("tool")
    lo, hi = m.lowerPositionLimit, m.upperPositionLimit
    for cv in res.curves.values():
        for qq in cv.branches[0]:
            pin.framesForwardKinematics(m, d, qq)
            assert np.abs(pin.log6(goal.actInv(d.oMf[fid])).vector).max() < 1e-12
            assert np.all(qq >= lo - 1e-12) and np.all(qq <= hi + 1e-12)
    gap = min(np.abs(np.array(cv.branches[0]) - q).max(axis=1).min() for cv in res.curves.values())
    assert gap < answer_selfmotion.STEP
    assert res.stats["certified_points"] > 0.9 * res.stats["curve_points"]


@pytest.mark.slow
def test_first_joint_sweep_agrees_with_branch_and_prune(shoulder7):
    """The swept first joint's curves are the branch and prune's: as many, every point of
    either within a sampling step of the other's."""
    _, goal = _goal(shoulder7, 3)
    res = shoulder7.solve(goal)
    bp = shoulder7.solve(goal, closed_form=False, time_limit=3000)
    assert res.stats["method"] == "sweep" and bp.complete
    assert len(res.curves) == len(bp.curves) and not bp.solutions

    def pts(r):
        return np.array([q for cv in r.curves.values() for b in cv.branches for q in b])

    A, B = pts(res), pts(bp)
    gap = max(max(np.abs(B - a).max(axis=1).min() for a in A), max(np.abs(A - b).max(axis=1).min() for b in B))
    assert gap < 2 * answer_selfmotion.STEP
