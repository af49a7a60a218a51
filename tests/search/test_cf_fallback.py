"""The poses the closed form does not decide are searched inside its relaxed enclosures
(kinbox.search.cf_fallback): every root planted next to a singularity lies in a box, and the
search inside the boxes finds what the search of the whole domain finds."""

from __future__ import annotations

import numpy as np
import pytest

from kinbox.pipeline import IK
from kinbox.problems.ik import _as_configuration
from kinbox.search.cf_fallback import _fold_cut, folded_enclosures, joint_enclosures, system_boxes
from kinbox.search.closed_form import solve_pose
from tests.support.arms import ARMS, _angles, _ik, _same_sets


def _family_theta(ik: IK, q: np.ndarray) -> np.ndarray:
    """The closed form's canonical angles of a Pinocchio ``q``."""
    cf = ik.closed_form
    model = ik.robot.model
    out = []
    for i, j in enumerate(cf.joints):
        jm = model.joints[j.jid]
        a = np.arctan2(q[jm.idx_q + 1], q[jm.idx_q]) if jm.nq == 2 else q[jm.idx_q]
        out.append(a + cf.gamma[i])
    return np.array(out)


def _in_a_box(ik: IK, q: np.ndarray, boxes) -> bool:
    """Is configuration ``q`` (its joints' cosines and sines in the system's angles) inside one
    of ``boxes``?"""
    tc = ik.closed_form.certifier
    th = _family_theta(ik, q)
    for lo, hi in boxes:
        ok = True
        for i in range(6):
            for var, v in ((tc.cvar[i], np.cos(th[i] + tc.shift[i])), (tc.svar[i], np.sin(th[i] + tc.shift[i]))):
                ok = ok and (var < 0 or lo[var] <= v <= hi[var])
        if ok:
            return True
    return False


def _undecided(ik: IK, pose) -> bool:
    cf = ik.closed_form
    Rlo, Rhi, tlo, thi = (np.ascontiguousarray(a[0]) for a in cf.goal_arrays(pose.rotation[None], pose.translation[None]))
    return solve_pose(cf.code, cf.LR, cf.Lt, cf.d, Rlo, Rhi, tlo, thi, np.zeros((8, 6, 4)), np.zeros((4, 3, 4))) < 0


@pytest.mark.parametrize("robot,frame,lock,family", ARMS[:3])
def test_planted_roots_near_singularities_lie_in_a_box(robot, frame, lock, family):
    """Random configurations within the limits moved 1e-5 to 1e-10 from a wrist singularity (joint 5 at 0) and,
    on the UR5, the elbow from straight: each lies in a box of its own pose, and most of those
    poses are ones the closed form does not decide (the relaxed steps are what is tested)."""
    ik = _ik(robot, frame, lock)
    rng = np.random.default_rng(5)
    model = ik.robot.model
    idx = [model.joints[j].idx_q for j in ik.chain]
    lo = np.maximum(model.lowerPositionLimit[idx], -np.pi)
    hi = np.minimum(model.upperPositionLimit[idx], np.pi)
    undecided = 0
    n = 0
    for k in range(24):
        q = rng.uniform(lo, hi)  # within the limits: a root of its pose
        eps = 10.0 ** rng.uniform(-10, -5) * rng.choice([-1.0, 1.0])
        if k % 3 == 0 or family != "parallel":
            q[4] = eps
        elif k % 3 == 1:
            q[2] = eps
        else:
            q[2], q[4] = eps, -eps
        pose = ik.pose_at(q)
        qa = _as_configuration(ik.robot.model, q, ik.chain)
        got = folded_enclosures(ik.closed_form, pose.rotation, pose.translation)
        if got is None:
            continue  # the whole domain is searched
        encs, pairs = got
        prob = ik.problem(pose)
        boxes = system_boxes(ik.closed_form, encs, *prob.system.search_domain(), pairs=pairs)
        assert boxes is not None
        assert _in_a_box(ik, qa, boxes), (k, q)
        undecided += _undecided(ik, pose)
        n += 1
    assert n >= 16 and undecided >= 8


class _Only:
    def __init__(self, solutions):
        self.solutions = solutions


def _certified(res) -> _Only:
    return _Only([s for s in res.solutions if s.certified])


def _uncertified(res) -> _Only:
    return _Only([s for s in res.solutions if not s.certified])


@pytest.mark.parametrize(
    "q",
    [
        [0.3, -1.2, 1.5, -0.8, 1e-9, 0.4],  # wrist 1e-9 from singular
        [0.3, -1.2, 1.5, -0.8, -1e-7, 0.4],
        [0.3, -1.2, 1e-7, -0.8, 1.2, 0.4],  # elbow 1e-7 from straight
        [-2.0, 0.7, -1e-7, 1.1, 1e-8, -0.5],  # both
    ],
)
def test_search_in_the_enclosures_finds_what_the_whole_search_finds(q):
    ik = IK("ur5", "tool0")
    pose = ik.pose_at(q)
    fast = ik.solve(pose)
    slow = ik.solve(pose, closed_form=False)
    assert "closed-form enclosures" in fast.stats["searched"]
    assert "searched" not in slow.stats
    assert fast.complete and slow.complete
    # certified roots are exact roots in boxes of at most some 1e-9: compared well below the
    # 2e-7 between the two roots of the elbow pair the separation certifies
    assert _same_sets(ik, _certified(fast), _certified(slow), tol=2e-8), (fast, slow)
    # a box at the resolution (neither certified nor a curve) stands for the roots within its
    # width of it: the two searches may pick different points of it
    wide = max([1e-3] + [s.width for s in fast.solutions + slow.solutions if not s.certified])
    assert _same_sets(ik, _uncertified(fast), _uncertified(slow), tol=wide), (fast, slow)
    assert len(fast.curves) == len(slow.curves)
    # the pose's own q: a certified root, or within the width of a box at the resolution
    assert any(
        np.max(np.abs(np.angle(np.exp(1j * (_angles(ik, s.q) - np.array(q)))))) < (1e-6 if s.certified else max(1e-3, s.width))
        for s in fast.solutions
    )


def test_all_zero_pose_is_a_curve():
    """The all-zero UR5 pose (shoulder, elbow and wrist singular): one curve of configurations
    (joints 2, 3, 4 and 6 parallel); the flagged point the whole search also returns (residual
    1e-12, elbow straight on the other shoulder branch) is proven no root by the closed form
    (its elbow discriminant is below zero), and lies in no box."""
    ik = IK("ur5", "tool0")
    pose = ik.pose_at([0.0] * 6)
    fast = ik.solve(pose)
    slow = ik.solve(pose, closed_form=False)
    assert fast.complete and len(fast.curves) == len(slow.curves) == 1
    encs = joint_enclosures(ik.closed_form, pose.rotation, pose.translation)
    boxes = system_boxes(ik.closed_form, encs, *ik.problem(pose).system.search_domain())
    for s in slow.solutions:
        assert not s.certified
        if not any(_same_sets(ik, _Only([s]), _Only([f])) for f in fast.solutions):
            assert not _in_a_box(ik, s.q, boxes)
    assert _in_a_box(ik, np.zeros(6), boxes)  # the pose's own configuration, on the curve


def test_fold_cut_covers_both_boxes_and_shares_a_face():
    """The two boxes of a relaxed elbow (overlapping in a slab where they meet) become their
    hull cut in two: every point of either box is in a half, the halves meet in one face;
    boxes apart, or whose hull the merge takes, are left as they are."""
    rng = np.random.default_rng(2)
    a = (np.array([0.0, -1.0, 0.2]), np.array([0.55, 1.0, 0.9]))
    b = (np.array([0.5, -0.8, 0.0]), np.array([1.0, 0.9, 0.7]))
    lo, hi = _fold_cut(a, b)
    for box in (a, b):
        for p in rng.uniform(box[0], box[1], (200, 3)):
            assert any(np.all(h[0] <= p) and np.all(p <= h[1]) for h in (lo, hi))
    inter = np.minimum(lo[1], hi[1]) - np.maximum(lo[0], hi[0])
    assert np.sum(inter == 0) == 1 and np.all(inter >= 0)
    far = (a[0] + 2.0, a[1] + 2.0)
    assert _fold_cut(a, far) == (a, far)
    near = (a[0] + 0.01, a[1] + 0.01)
    assert _fold_cut(a, near) == (a, near)
