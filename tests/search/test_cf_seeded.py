"""The closed form's roots next to a singularity certified on the kinbox system from Newton's
point (kinbox.search.cf_seeded): the same roots as the search of the whole domain, each proof
box holding its root and apart from the other roots' enclosures; nothing where the closed form
does not count the roots."""

from __future__ import annotations

import numpy as np
import pytest

from kinbox.pipeline import IK
from kinbox.search.certify import Certifier
from kinbox.search.cf_seeded import relaxed_roots, seeded_roots
from tests.support.arms import _angles

SEEDED = "system, from Newton's point"


def _planted(ik: IK, n: int, seed: int, eps_range: tuple[float, float]) -> list[np.ndarray]:
    """Random UR5 configurations with the elbow ``eps`` from straight (``|eps|`` log-uniform)."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        q = rng.uniform(-np.pi, np.pi, 6)
        q[2] = 10.0 ** rng.uniform(*eps_range) * rng.choice([-1.0, 1.0])
        out.append(q)
    return out


def _covers(ik: IK, fast, slow) -> bool:
    """Is every root of ``fast`` a certified root of ``slow`` (to 1e-6) or within 1e-3 of one of
    its flagged roots, and every root of ``slow`` one of ``fast``'s (to 1e-6 if certified, else
    1e-3)?"""

    def close(a, b, tol):
        return np.max(np.abs(np.angle(np.exp(1j * (_angles(ik, a.q) - _angles(ik, b.q)))))) < tol

    def tol(s):
        return 1e-6 if s.certified else 1e-3

    return all(any(close(f, s, tol(s)) for s in slow.solutions) for f in fast.solutions) and all(
        any(close(f, s, tol(s)) for f in fast.solutions) for s in slow.solutions
    )


@pytest.fixture(scope="module")
def ur5() -> IK:
    return IK("ur5", "tool0")


def test_near_double_roots_are_certified_and_are_the_whole_searchs(ur5):
    """Elbows 1e-6 to 3e-6 from straight (near-double roots, the Jacobian's condition number
    about 1e7): where the closed form counts the roots and the seeded certificate answers, the
    answer is complete, every root certified, and the same set as the search of the whole
    domain's: its certified roots, and the roots its boxes at the resolution stand for (a
    near-double pair the search does not separate, flagged singular, is two certified roots
    here); most such poses are answered so."""
    qs = [np.array([0.3, -1.2, 1e-6, -0.8, 1.2, 0.4])] + _planted(ur5, 7, 11, (-6.0, -5.5))
    seeded = 0
    for q in qs:
        pose = ur5.pose_at(q)
        fast = ur5.solve(pose)
        if fast.stats.get("certificate") != SEEDED:
            continue
        seeded += 1
        slow = ur5.solve(pose, closed_form=False)
        assert fast.complete and slow.complete
        assert fast.stats["method"] == "closed-form"
        assert all(s.certified for s in fast.solutions)
        assert _covers(ur5, fast, slow), (q, fast, slow)
        assert max(s.residual for s in fast.solutions) < 1e-12
    assert seeded >= 6


def test_each_proof_box_holds_its_root_and_the_roots_are_the_bound(ur5):
    """The seeded boxes of the elbow 1e-6 pose: as many as the relaxed closed form's bound on the
    roots within the limits, Newton's point and the search's certified root inside each, the
    boxes pairwise disjoint and narrow."""
    q = [0.3, -1.2, 1e-6, -0.8, 1.2, 0.4]
    pose = ur5.pose_at(q)
    prob = ur5.problem(pose)
    V = np.asarray(prob.source["pose"], dtype=float)
    bound = relaxed_roots(ur5.closed_form, pose.rotation, pose.translation)
    batch = seeded_roots(
        ur5.closed_form, Certifier(prob.system.compile()), pose.rotation, pose.translation, *prob.system.search_domain(), bound, V
    )
    assert batch is not None and bound is not None
    assert batch.count[0] == len(bound[1]) == 2
    slow = ur5.solve(pose, closed_form=False)
    for m in range(2):
        lo, hi, x = batch.lo[m], batch.hi[m], batch.x[m]
        assert np.all(lo <= x) and np.all(x <= hi)
        assert not np.any(hi - lo > 1e-5)
        assert sum(bool(np.all(lo <= s.x) and np.all(s.x <= hi)) for s in slow.solutions) == 1
    assert np.any(batch.hi[0] < batch.lo[1]) or np.any(batch.hi[1] < batch.lo[0])


@pytest.mark.parametrize("q", [[0.3, -1.2, 1e-8, -0.8, 1.2, 0.4], [0.3, -1.2, 1.5, -0.8, 1e-8, 0.4], [0.0] * 6])
def test_nothing_where_the_closed_form_does_not_count_the_roots(ur5, q):
    """An elbow 1e-8 from straight (its discriminant holds zero), a wrist 1e-8 from singular (its
    pivot holds zero), the all-zero pose: no seeded answer, the pose goes to the branch and prune
    (the all-zero pose, exactly singular, to its curves in closed form: tests/search/test_cf_curve.py)."""
    pose = ur5.pose_at(q)
    prob = ur5.problem(pose)
    cert = Certifier(prob.system.compile())
    assert seeded_roots(ur5.closed_form, cert, pose.rotation, pose.translation, *prob.system.search_domain()) is None
    assert ur5.solve(pose).stats["method"] == ("closed-form curve" if not any(q) else "branch-and-prune")
