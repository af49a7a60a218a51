"""The one-pose path of ``IK.solve_array`` and ``IK.solve`` (kinbox.answer.cf_pose) against the batch path."""

from __future__ import annotations

import pickle
import threading
from types import SimpleNamespace

import numpy as np
import pinocchio as pin
import pytest

from kinbox.answer.cf_pose import OnePose
from kinbox.answer.turns import wrapping_joints
from kinbox.errors import InputError
from kinbox.search.cf_batch import run_batch
from kinbox.search.closed_form import POSE_CLOSED_FORM
from tests.support.arms import ARMS, _ik, _poses

#: a UR5 pose 1e-9 from its wrist singularity: the closed form leaves it to the branch and prune
NEAR_SINGULAR = [0.3, -1.2, 1.5, -0.8, 1e-9, 0.4]


def _xyzquat(poses) -> np.ndarray:
    return np.array([pin.SE3ToXYZQUAT(p) for p in poses])


@pytest.mark.parametrize("robot,frame,lock,family", ARMS)
@pytest.mark.parametrize("certify", [True, False])
def test_one_pose_path_is_the_batch_path(robot, frame, lock, family, certify):
    """Each pose alone through the one-pose path gives what the batch of all of them gives for
    it, bit for bit (roots, certified and singular flags, method, completeness), whatever came
    before it in the reused buffers; a pose the closed form leaves to the branch and prune is
    not taken (None) and ``solve_array`` answers it by the batch path."""
    ik = _ik(robot, frame, lock)
    P = _xyzquat(_poses(ik, 40, seed=5))
    if robot == "ur5":
        P = np.vstack([P, _xyzquat([ik.pose_at(NEAR_SINGULAR)])])
    whole = ik.solve_array(P, certify=certify)
    mode = "joint" if certify else "none"
    one = OnePose(ik.closed_form, mode)
    taken = 0
    for k in range(len(P)):
        a = one.solve(P[k : k + 1])
        if whole.method[k] != "closed-form":
            assert a is None
            continue
        taken += 1
        assert a is not None and a.method == ["closed-form"]
        assert a.joints == whole.joints
        assert a.count.tolist() == [whole.count[k]] and a.first.tolist() == [0]
        assert np.array_equal(a.q, whole.solutions(k))
        rows = slice(whole.first[k], whole.first[k] + whole.count[k])
        assert np.array_equal(a.certified, whole.certified[rows]) and np.array_equal(a.singular, whole.singular[rows])
        assert a.complete.tolist() == [True] and a.curves.tolist() == [0]
        b = ik.solve_array(P[k : k + 1], certify=certify)  # the public entry: the same
        assert np.array_equal(b.q, a.q) and b.method == a.method
    assert taken >= 30  # random poses are regular
    if robot == "ur5":
        assert whole.method[-1] == "branch-and-prune"
        alone = ik.solve_array(P[-1:], certify=certify)
        assert alone.method == ["branch-and-prune"] and alone.count[0] == whole.count[-1]


@pytest.mark.parametrize("robot,frame,lock,family", ARMS)
def test_one_pose_record_has_the_batch_certificates(robot, frame, lock, family):
    """The one-pose kernel record (what ``IK.solve`` builds its answer from) holds the batch's
    roots and proof boxes bit for bit, and ``IK.solve`` answers from it as before: its
    solutions' proof widths those of the record, the answer the same as the one built from the
    whole batch's record (its solutions, residuals, joints wider than a turn)."""
    ik = _ik(robot, frame, lock)
    poses = _poses(ik, 12, seed=9)
    P = _xyzquat(poses)
    cf = ik.closed_form
    R = np.array([p.rotation for p in poses])
    t = np.array([p.translation for p in poses])
    batch = run_batch(cf, cf.certifier, R, t, V=P, certificate="joint")
    one = OnePose(cf, "joint")
    assert batch.jlo is not None and batch.jhi is not None
    for k in range(len(P)):
        b = one.batch(P[k], R[k])  # the rotation as IK.solve gives it
        if batch.status[k] != POSE_CLOSED_FORM:
            assert b is None
            continue
        assert b is not None and b.jlo is not None and b.jhi is not None
        rows = slice(batch.first[k], batch.first[k] + batch.count[k])
        assert b.count[0] == batch.count[k]
        assert np.array_equal(b.theta, batch.theta[rows])
        assert np.array_equal(b.jlo, batch.jlo[rows]) and np.array_equal(b.jhi, batch.jhi[rows])
        res = ik.solve(poses[k])
        assert res.stats["method"] == "closed-form" and res.complete
        assert all(s.certified for s in res.solutions)
        assert sorted(s.width for s in res.solutions) == sorted(np.max(b.jhi - b.jlo, axis=1).tolist())
        # the answer built from pose k of the whole batch (the path of solve_many's batches): the same
        ref = ik._closed_form_fast(poses[k], {"policy": "quick"}, batch, k)
        assert ref is not None and len(ref.solutions) == len(res.solutions)
        for s, r in zip(res.solutions, ref.solutions, strict=True):
            assert np.array_equal(s.q, r.q) and s.width == r.width and s.residual == r.residual and s.status == r.status
        assert res.stats.get("wrapping_joints") == ref.stats.get("wrapping_joints")
        assert res.stats.get("configurations_within_limits") == ref.stats.get("configurations_within_limits")
        assert res.notes == ref.notes
        got = wrapping_joints(SimpleNamespace(formulated=res.formulated))  # found on the answer itself
        assert res.stats.get("wrapping_joints", {}) == {n: [lo, hi] for n, (_, lo, hi) in got.items()}


def test_answers_do_not_share_the_buffers():
    """An answer's arrays are its own: the next pose does not change them."""
    ik = _ik(*ARMS[0][:3])
    P = _xyzquat(_poses(ik, 2, seed=1))
    a = ik.solve_array(P[:1])
    q = a.q.copy()
    b = ik.solve_array(P[1:2])
    assert not np.array_equal(a.q, b.q)
    assert np.array_equal(a.q, q)


def test_bad_single_poses_are_refused_as_in_a_batch():
    ik = _ik(*ARMS[0][:3])
    good = _xyzquat(_poses(ik, 1, seed=2))
    ik.solve_array(good)  # the one-pose path built and bound
    for bad, words in (
        (np.array([[np.nan, 0, 0, 0, 0, 0, 1.0]]), "non-finite"),
        (np.array([[0.1, 0, 0, 0, 0, np.inf, 1.0]]), "non-finite"),
        (np.array([[0.1, 0, 0, 0, 0, 0, 2.0]]), "not unit"),
    ):
        with pytest.raises(InputError, match=words):
            ik.solve_array(bad)
    with pytest.raises(InputError, match="shape"):
        ik.solve_array(good[0])  # (7,), not (1, 7): refused as before


def test_one_pose_path_is_one_call_at_a_time_and_pickles():
    """While another call holds the buffers the one-pose path is not taken (the batch path
    answers); a pickled IK gets its own buffers."""
    ik = _ik(*ARMS[0][:3])
    P = _xyzquat(_poses(ik, 1, seed=4))
    ref = ik.solve_array(P)
    one = ik._one_pose("joint")
    assert one is not None and one.bound
    lock = one._lock
    assert lock.acquire()
    try:
        assert one.solve(P) is None
        got: list = []
        th = threading.Thread(target=lambda: got.append(ik.solve_array(P)))
        th.start()
        th.join()
        assert np.array_equal(got[0].q, ref.q)
    finally:
        lock.release()
    ik2 = pickle.loads(pickle.dumps(ik))
    assert np.array_equal(ik2.solve_array(P).q, ref.q)


def test_solve_leaves_the_callers_pose_as_given():
    """A pose array whose quaternion is a little off unit is normalised for the answer, not in
    the caller's array."""
    ik = _ik(*ARMS[0][:3])
    v = _xyzquat(_poses(ik, 1, seed=6))[0]
    v[3:] *= 1.0 + 4e-7
    given = v.copy()
    res = ik.solve(v)
    assert res.complete and res.solutions
    assert np.array_equal(v, given)


def test_options_are_judged_per_options():
    """The fast path's verdict on the options, kept per options, does not carry over to other
    options: a resolution the search refuses is refused after the default options were taken,
    and ``closed_form=False`` asks for the search."""
    ik = _ik(*ARMS[0][:3])
    pose = _poses(ik, 1, seed=8)[0]
    assert ik.solve(pose).stats["method"] == "closed-form"
    assert ik.solve(pose).stats["method"] == "closed-form"
    with pytest.raises(InputError, match="too large"):
        ik.solve(pose, sigma=0.7)
    with pytest.raises(InputError, match="too large"):
        ik.solve(pose, sigma=0.7)
    assert ik.solve(pose, closed_form=False).stats["method"] == "branch-and-prune"
    assert ik.solve(pose, sigma=1e-3).stats["method"] == "closed-form"


@pytest.mark.parametrize("first", ["solve", "solve_array"])
def test_first_call_goes_through_each_kernel(first):
    """The one-pose path's first call runs each of its kernels through its
    :class:`~kinbox.search.jit.Kernel` (then binds them): the build of the ahead-of-time module
    (:mod:`kinbox.problems.aot`) sees every signature the path calls, whichever entry comes first."""
    from kinbox.answer.closed_form import _quaternions, _wrap
    from kinbox.search.cf_certify import solve_batch_joint
    from kinbox.search.closed_form import _frames

    ik = _ik(*ARMS[0][:3])
    pose = _poses(ik, 1, seed=10)[0]
    kernels = (_quaternions, _frames, solve_batch_joint, _wrap)
    before = [sum(k.calls) for k in kernels]
    if first == "solve":
        ik.solve(pose)
    else:
        ik.solve_array(_xyzquat([pose]))
    assert all(sum(k.calls) > b for k, b in zip(kernels, before, strict=True))
    one = ik._one_pose("joint")
    assert one is not None and one.bound
