"""Closed-form IK: families read off the geometry, answers the same as the branch and prune's."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from kinbox.model.loading import load
from kinbox.pipeline import IK
from kinbox.search.cf_batch import run_batch
from kinbox.search.closed_form import POSE_CLOSED_FORM, TemplateCertifier
from tests.support.arms import ARMS, DATA, _angles, _ik, _poses, _same_sets


@pytest.mark.parametrize("robot,frame,lock,family", ARMS)
def test_family_detected(robot, frame, lock, family):
    ik = _ik(robot, frame, lock)
    assert ik.closed_form is not None and ik.closed_form.family.name == family


def test_detection_from_geometry_not_names():
    """A DH arm renamed is the same family; the same arm with one twist off by 1e-9 rad (a
    wrist that nearly meets) is none: its poses go to the branch and prune."""
    rows = json.loads((DATA / "irb120_dh.json").read_text())["dh"]
    renamed = [dict(r, name=f"q{k}") for k, r in enumerate(rows)]
    ik = IK(load({"kind": "dh-arm", "dh": renamed}), "tool")
    assert ik.closed_form is not None and ik.closed_form.family.name == "wrist-meet"
    bent = copy.deepcopy(rows)
    bent[4]["alpha"] += 1e-9
    bent[5]["a"] = 1e-9  # line 6 misses the wrist centre by a nanometre
    ik2 = IK(load({"kind": "dh-arm", "dh": bent}), "tool")
    assert ik2.closed_form is None or ik2.closed_form.family.name != "wrist-meet"


@pytest.mark.parametrize("robot,frame,lock,family", ARMS)
def test_same_answers_as_branch_and_prune(robot, frame, lock, family):
    ik = _ik(robot, frame, lock)
    closed = 0
    for pose in _poses(ik, 4, seed=7):
        fast = ik.solve(pose)
        slow = ik.solve(pose, closed_form=False)
        assert slow.stats["method"] == "branch-and-prune"
        assert fast.complete and slow.complete
        assert _same_sets(ik, fast, slow), (fast, slow)
        assert all(s.certified for s in fast.solutions) or fast.stats["method"] == "branch-and-prune"
        closed += fast.stats["method"] == "closed-form"
    assert closed >= 3  # random poses are regular


@pytest.mark.parametrize(
    "q",
    [
        [0.3, -1.2, 1.5, -0.8, 1e-9, 0.4],  # wrist 1e-9 from singular
        [0.3, -1.2, 1e-7, -0.8, 1.2, 0.4],  # elbow 1e-7 from straight
    ],
)  # the all-zero pose: tests/search/test_cf_fallback.py::test_all_zero_pose_is_a_curve
def test_near_singular_falls_back_and_loses_nothing(q):
    ik = IK("ur5", "tool0")
    pose = ik.pose_at(q)
    fast = ik.solve(pose)
    slow = ik.solve(pose, closed_form=False)
    assert fast.stats["method"] == "branch-and-prune"
    assert len(fast.solutions) == len(slow.solutions)
    assert len(fast.curves) == len(slow.curves)
    near = any(np.max(np.abs(np.angle(np.exp(1j * (_angles(ik, s.q) - np.array(q)))))) < 1e-5 for s in fast.solutions)
    assert near or fast.curves  # the pose's own q: a root, or on a curve (the all-zero pose)


@pytest.mark.parametrize("robot,frame,lock,family", ARMS[:2])
def test_batch_matches_single_poses(robot, frame, lock, family):
    ik = _ik(robot, frame, lock)
    cf = ik.closed_form
    poses = _poses(ik, 6, seed=3)
    R = np.array([p.rotation for p in poses])
    t = np.array([p.translation for p in poses])
    b = run_batch(cf, TemplateCertifier(ik.arm, cf.joints, cf.gamma), R, t)
    for k, pose in enumerate(poses):
        if b.status[k] != POSE_CLOSED_FORM:
            continue
        res = ik.solve(pose)
        assert res.stats["method"] == "closed-form"
        assert b.count[k] == len(res.solutions)
        rows = b.theta[b.first[k] : b.first[k] + b.count[k]] - cf.gamma
        for s in res.solutions:
            x = _angles(ik, s.q)
            order = [next(i for i, j in enumerate(ik.chain) if j == jj.jid) for jj in cf.joints]
            assert any(np.max(np.abs(np.angle(np.exp(1j * (r - x[order]))))) < 1e-6 for r in rows)
    assert np.all(b.residual < 1e-9)


def test_solve_array_and_solve_many_use_the_batch():
    ik = IK("ur5", "tool0")
    poses = _poses(ik, 5, seed=11) + [ik.pose_at([0.3, -1.2, 1.5, -0.8, 1e-9, 0.4])]
    import pinocchio as pin

    arr = np.array([pin.SE3ToXYZQUAT(p) for p in poses])
    ans = ik.solve_array(arr)
    many = ik.solve_many(poses)
    assert ans.method[-1] == "branch-and-prune" and many[-1].stats["method"] == "branch-and-prune"
    for k, res in enumerate(many):
        assert ans.count[k] == len(res.solutions)
        assert ans.method[k] == res.stats["method"]
        for s in res.solutions:
            x = _angles(ik, s.q)
            assert any(np.max(np.abs(np.angle(np.exp(1j * (r - x))))) < 1e-6 for r in ans.solutions(k))
    assert all(ans.complete)


@pytest.mark.parametrize("robot,frame,lock,family", ARMS)
def test_structure_read_from_the_other_end(robot, frame, lock, family):
    """The exact tests of a family, mirrored, hold on the reversed chain's numbers: the check
    that lets a family found on the reversed chain be used for the arm's own system."""
    from kinbox.formulation.arm import canonical
    from kinbox.formulation.families import _mirrored, family_of

    g = _ik(robot, frame, lock).arm.geometry
    assert family_of(g) == family
    assert _mirrored(canonical(g.chain.reverse()), family)


@pytest.mark.parametrize("robot,frame,lock,family", ARMS)
def test_system_enclosure_holds_the_roots_system_points(robot, frame, lock, family):
    """The enclosure of the system points of a root's enclosure (``system_enclosure``: joints
    from the enclosure, auxiliary variables through their definitions over the goal box, each
    coefficient within its error) holds the certified point of each root, and is narrow on
    generic poses (the enclosure's width, not the domain's); a joint shifted from the family's
    angle gives none."""
    from kinbox.search.closed_form import system_enclosure

    ik = _ik(robot, frame, lock)
    cf = ik.closed_form
    tc = cf.certifier
    poses = _poses(ik, 6, seed=41)
    R = np.array([p.rotation for p in poses])
    t = np.array([p.translation for p in poses])
    batch = run_batch(cf, tc, R, t, certificate="system")
    Rlo, Rhi, tlo, thi = cf.goal_arrays(R, t)
    pl, ph = np.empty(20), np.empty(20)
    el, eh = np.empty(tc.n), np.empty(tc.n)
    args = (tc.fixed, tc.cvar, tc.svar, tc.shift, tc.def_target, tc.def_start, tc.def_param, tc.def_coef, tc.def_a, tc.def_b, tc.def_err)
    checked = 0
    for k in range(len(poses)):
        if batch.status[k] != POSE_CLOSED_FORM:
            continue
        n, enc, inside = cf.roots(R[k], t[k])
        rows = batch.first[k] + np.arange(batch.count[k])
        for r, m in zip([r for r in range(n) if inside[r] == 1], rows):
            assert system_enclosure(enc[r], Rlo[k], Rhi[k], tlo[k], thi[k], *args, pl, ph, el, eh)
            x = batch.x[m]
            assert np.all(el <= x) and np.all(x <= eh)
            assert np.max(eh - el) < 1e-6
            checked += 1
    assert checked >= 8
    shifted = tc.shift.copy()
    shifted[2] = 0.5
    a2 = args[:3] + (shifted,) + args[4:]
    assert not system_enclosure(enc[0], Rlo[0], Rhi[0], tlo[0], thi[0], *a2, pl, ph, el, eh)
