"""The curves of a UR-family pose at a wrist singularity in closed form (kinbox.search.cf_curve,
kinbox.answer.cf_curve): the same curves as the branch and prune of the whole domain, every
point of either next to a point of the other, every point of the search's curves inside the
closed form's arc enclosures, the isolated roots of the other shoulder branch the same; a pose
next to the singularity is not taken for a curve."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from kinbox.pipeline import IK
from kinbox.search import cf_curve
from tests.support.arms import _angles, _same_sets


def _gap(P: np.ndarray, Q: np.ndarray) -> float:
    """Largest angle (any joint, modulo 2 pi) from a point of ``P`` to the nearest of ``Q``."""
    d = np.abs(P[:, None, :] - Q[None, :, :]) % (2.0 * math.pi)
    return float(np.minimum(d, 2.0 * math.pi - d).max(axis=2).min(axis=1).max())


def _points(ik: IK, res) -> np.ndarray:
    return np.array([_angles(ik, q) for cv in res.curves.values() for b in cv.branches for q in b])


class _Only:
    def __init__(self, solutions):
        self.solutions = solutions


def _in_enclosures(ik: IK, q: np.ndarray, boxes: list[np.ndarray], tol: float = 1e-9) -> bool:
    """Is ``q``'s (cos, sin) of every joint (the family's angles) inside one of ``boxes``?"""
    cf = ik.closed_form
    th = _angles(ik, q)[np.argsort(np.argsort(cf.idx_q))] + cf.gamma
    c, s = np.cos(th), np.sin(th)
    return any(
        bool(np.all(c >= b[:, 0] - tol) and np.all(c <= b[:, 1] + tol) and np.all(s >= b[:, 2] - tol) and np.all(s <= b[:, 3] + tol))
        for b in boxes
    )


def _compare(ik: IK, q) -> None:
    pose = ik.pose_at(q)
    fast = ik.solve(pose)
    slow = ik.solve(pose, closed_form=False)
    assert fast.stats["method"] == "closed-form curve" and fast.complete and slow.complete
    assert len(fast.curves) == len(slow.curves) >= 1
    A, B = _points(ik, fast), _points(ik, slow)
    # every point of either within a sampling step of the other's (the search's steps are longer)
    assert _gap(A, B) < 2 * cf_curve.STEP and _gap(B, A) < 2 * cf_curve.STEP
    assert max(cv.residual for cv in fast.curves.values()) < 1e-12
    # the closed form's enclosures hold every point of the search's curves
    wc = cf_curve.wrist_curves(ik.closed_form, pose.rotation, pose.translation)
    boxes = [b for c in wc.curves for b in c.boxes]
    assert all(_in_enclosures(ik, p, boxes) for cv in slow.curves.values() for br in cv.branches for p in br)
    # the isolated roots (the other shoulder branch): the same certified ones; the search's
    # flagged points are not roots the closed form missed (proven none there, or certified)
    assert _same_sets(ik, _Only([s for s in fast.solutions if s.certified]), _Only([s for s in slow.solutions if s.certified]))
    assert all(s.certified for s in fast.solutions)
    # the pose's own configuration is on a curve or one of the roots
    own = np.array(q, dtype=float)
    near_curve = _gap(own[None], A) < 2 * cf_curve.STEP
    assert near_curve or any(_gap(own[None], _angles(ik, s.q)[None]) < 1e-6 for s in fast.solutions)


def test_all_zero_pose_same_curve_as_the_search():
    """The all-zero UR5 pose: one curve (its two elbow branches joined at two folds), the
    other shoulder branch proven empty."""
    ik = IK("ur5", "tool0")
    _compare(ik, [0.0] * 6)
    res = ik.solve(ik.pose_at([0.0] * 6))
    assert not res.solutions and res.stats["fold_regions"] == 2
    # the curve's boxes (the arcs' enclosures on the system) hold every point of its polyline
    (comp,) = res.components
    boxes = [res.raw.boxes[b] for b in comp.boxes]
    assert boxes and all(b.status.value == "curve" for b in boxes)
    assert all(any(np.all(x >= b.lo) and np.all(x <= b.hi) for b in boxes) for x in comp.polylines[0])
    assert len(json.loads(res.to_json())["components"]) == 1


@pytest.mark.slow
@pytest.mark.parametrize(
    "robot,q",
    [
        ("ur5", [0.3, -1.2, 1.5, -0.8, 0.0, 0.4]),  # two curves (the elbow's branches apart), 4 roots on the other shoulder
        ("ur5", [1.0, -0.5, 0.7, 2.0, 0.0, -1.0]),
        ("ur5", [-2.0, 0.7, -0.4, 1.1, math.pi, -0.5]),  # joint 5 at pi
        ("ur10", [0.5, -1.0, 1.2, 0.3, 0.0, 2.0]),
        ("ur3", [-2.92, 0.09, -0.21, 2.62, 0.0, 0.09]),  # one curve (two folds), 4 roots
        # the elbow folded far: over the whole turn, or over wide arcs, joint 2's pivot holds zero
        ("ur5", [-2.699, -2.326, 2.817, 0.766, 0.0, 0.072]),
        ("ur3", [1.783, 0.861, 2.525, 1.606, 0.0, 0.91]),
    ],
)
def test_singular_poses_same_curves_as_the_search(robot, q):
    _compare(IK(robot, "tool0"), q)


@pytest.mark.parametrize("q5", [1e-9, -1e-7])
def test_next_to_the_singularity_is_not_a_curve(q5):
    """1e-9 and 1e-7 from the wrist singularity the pose has isolated roots: the singular arm's
    curve misses it by far more than the rounding, and the branch and prune answers."""
    ik = IK("ur5", "tool0")
    pose = ik.pose_at([0.3, -1.2, 1.5, -0.8, q5, 0.4])
    wc = cf_curve.wrist_curves(ik.closed_form, pose.rotation, pose.translation)
    res = ik.solve(pose)
    assert res.stats["method"] != "closed-form curve" and not res.curves
    assert len(res.solutions) == 8 and all(s.certified for s in res.solutions)
    assert wc is None or wc.curves  # the interval part alone cannot tell; the samples' closure does


def test_arcs_hold_the_singular_arms_configurations():
    """Configurations of the exactly singular arm (joint 5 at 0, joint 6 anywhere, joints 2-4
    from the curve's samples) close the pose to rounding, and each lies in an arc enclosure."""
    ik = IK("ur5", "tool0")
    pose = ik.pose_at([0.0] * 6)
    res = ik.solve(pose)
    wc = cf_curve.wrist_curves(ik.closed_form, pose.rotation, pose.translation)
    boxes = [b for c in wc.curves for b in c.boxes]
    qs = [q for cv in res.curves.values() for q in cv.branches[0]]
    assert len(qs) > 100
    assert all(_in_enclosures(ik, q, boxes) for q in qs[::7])
    # joint 6 covers the curve's range: from the fold at the pose's own configuration to the other
    q6 = np.array([_angles(ik, q)[5] for q in qs])
    assert q6.max() - q6.min() > 2.5


@pytest.mark.parametrize("q0", [[0.3, -1.2, 1.5, -0.8, None, 0.4], [0.0, 0.0, 0.0, 0.0, None, 0.0]])
def test_samples_close_the_rows_only_at_the_singularity(q0):
    """The singular arm's samples close the pose's rows within their slacks with joint 5 at 0
    and 1e-14 from it (inside the goal's enclosure), not 1e-13 and 1e-12 from it (the pose
    then has isolated roots the curve misses by more than the rounding)."""
    from kinbox.answer.cf_curve import curve_points

    ik = IK("ur5", "tool0")
    for e, curve in ((0.0, True), (1e-14, True), (1e-13, False), (-1e-12, False)):
        q = list(q0)
        q[4] = e
        pose = ik.pose_at(q)
        wc = cf_curve.wrist_curves(ik.closed_form, pose.rotation, pose.translation)
        assert wc is not None and wc.curves
        got = curve_points(ik.closed_form, [c.theta for c in wc.curves], pose, ik.problem(pose).system.compile())
        assert (got is not None) == curve, e
