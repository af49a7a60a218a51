"""The batch's poses that Krawczyk in the joint angles leaves undecided are tried with Krawczyk on
the kinbox system before the branch and prune (kinbox.answer.closed_form._by_the_system),
checked against the 40-digit roots of the pose as given (tests/support/oracles/mp_ik.py)."""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pinocchio as pin

from kinbox.answer.closed_form import poses_array
from kinbox.pipeline import parse_pose
from kinbox.search.cf_batch import run_batch
from kinbox.search.closed_form import POSE_CLOSED_FORM
from tests.support.arms import ARMS, _ik, _poses, _same_sets
from tests.support.oracles import mp_ik


def test_the_system_decides_what_the_joint_proof_leaves():
    """Among 1,200 seeded random poses of the IRB 120-like arm, one next to a singularity that
    the joint angles' proof sends on and the system's decides: ``solve_array`` answers it in
    the closed form (alone and in the batch), with the 40-digit roots within the limits, each
    once, and as many as the branch and prune finds."""
    ik = _ik(*ARMS[1][:3])
    cf = ik.closed_form
    poses = _poses(ik, 1200, seed=1)
    R, t, V = poses_array(np.array([pin.SE3ToXYZQUAT(p) for p in poses]), parse_pose)  # as solve_array reads them
    jb = run_batch(cf, cf.certifier, R, t, V=V, certificate="joint")
    sb = run_batch(cf, cf.certifier, R, t, certificate="system")
    left = np.flatnonzero((jb.status != POSE_CLOSED_FORM) & (sb.status == POSE_CLOSED_FORM))
    assert len(left) >= 1
    k = int(left[0])
    ans = ik.solve_array(V)
    assert all(ans.method[int(j)] == "closed-form" for j in left)
    one = ik.solve_array(V[k : k + 1])
    assert one.method == ["closed-form"] and one.complete[0]
    assert np.array_equal(one.solutions(0), ans.solutions(k))
    mp.mp.dps = mp_ik.WORK
    chain = mp_ik.Chain(ik.robot.model, ik.frame)
    seeds = [s for q in one.solutions(0) for s in mp_ik.wrist_and_elbow_seeds(q)]
    real, _ = mp_ik.roots(chain, mp_ik.exact_pose(poses[k]), seeds)
    model = ik.robot.model
    lo, hi = model.lowerPositionLimit, model.upperPositionLimit
    exact = [np.array([float(v) for v in r]) for r in real]
    within = [q for q in exact if np.all(_moved_into(q, lo, hi) >= lo) and np.all(_moved_into(q, lo, hi) <= hi)]
    got = one.solutions(0)
    assert len(got) == len(within) >= 1
    for q in got:  # each reported configuration next to one 40-digit root, no two the same
        d = [np.max(np.abs(np.angle(np.exp(1j * (q - e))))) for e in within]
        assert sorted(d)[0] < 1e-8 and (len(d) == 1 or sorted(d)[1] > 1e-3)
    bp = ik.solve(poses[k], closed_form=False)
    assert bp.complete and len(bp.solutions) == len(got)


def _moved_into(q, lo, hi):
    """``q`` with each angle moved by whole turns towards the middle of its limits."""
    mid = 0.5 * (lo + hi)
    return q + 2 * np.pi * np.round((mid - q) / (2 * np.pi))


def test_the_poses_left_are_searched_inside_the_enclosures():
    """A UR5 1e-7 from its wrist singularity leaves both kernels: ``solve_array`` answers it by
    the branch and prune inside the closed form's enclosures (``within_enclosures``), with the
    configurations of the whole domain's search."""
    ik = _ik(*ARMS[0][:3])
    pose = ik.pose_at([0.3, -1.2, 1.5, -0.8, 1e-7, 0.4])
    inside = ik.solve(pose, closed_form=False, within_enclosures=True)
    whole = ik.solve(pose, closed_form=False)
    assert inside.stats["searched"]["closed-form enclosures"] >= 1 and "searched" not in whole.stats
    assert inside.complete and whole.complete and _same_sets(ik, inside, whole)
    ans = ik.solve_array(pin.SE3ToXYZQUAT(pose)[None, :])
    assert ans.method == ["branch-and-prune"] and ans.count[0] == len(whole.solutions) == 8
