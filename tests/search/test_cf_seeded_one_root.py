"""The seeded closed form answers only where its relaxed enclosures hold no more roots of the
model than there are of them (kinbox.search.cf_seeded._one_root_each): each in a Krawczyk box
of one root, or two by two a pair separated (kinbox.search.separate); else the pose goes to the
branch and prune, as it would without the seed. Roots against the 40-digit oracle."""

from __future__ import annotations

import numpy as np
import pytest

from kinbox.pipeline import IK
from kinbox.search.certify import Certifier
from kinbox.search.cf_seeded import _one_root_each, relaxed_roots, seeded_roots
from tests.support.curves import judge

SEEDED = "system, from Newton's point"


@pytest.fixture(scope="module")
def ur5() -> IK:
    return IK("ur5", "tool0")


def _clean(rep: dict) -> bool:
    return rep["lost"] == rep["merged"] == rep["cert_missing"] == rep["duplicates"] == 0 and rep["certified"] == rep["real"]


def test_a_merged_pair_is_answered_only_where_it_is_separated(ur5, monkeypatch):
    """Elbow 1e-6 from straight: two relaxed enclosures about a near-double pair (condition
    number about 1e7), where Krawczyk over a box holding an enclosure does not contract. Without
    the pose the check fails (no separation); with it the pair is separated in the two
    enclosures' boxes and the seed answers, its two roots the oracle's; with the separation
    failing, the pose goes to the branch and prune, which finds the same roots."""
    q = [0.3, -1.2, 1e-6, -0.8, 1.2, 0.4]
    pose = ur5.pose_at(q)
    cf = ur5.closed_form
    bound = relaxed_roots(cf, pose.rotation, pose.translation)
    assert bound is not None
    enc, keep = bound
    assert len(keep) == 2
    prob = ur5.problem(pose)
    V = np.asarray(prob.source["pose"], dtype=float)
    assert not _one_root_each(cf, pose.rotation, pose.translation, enc, keep)
    assert _one_root_each(cf, pose.rotation, pose.translation, enc, keep, V)
    args = (cf, Certifier(prob.system.compile()), pose.rotation, pose.translation, *prob.system.search_domain(), bound)
    assert seeded_roots(*args) is None
    batch = seeded_roots(*args, V)
    assert batch is not None and batch.count[0] == 2
    res = ur5.solve(pose)
    assert res.stats.get("certificate") == SEEDED
    assert _clean(judge(ur5, pose, res, np.array(q), ur="ur5"))
    with monkeypatch.context() as mp:
        mp.setattr("kinbox.search.separate.separate_pair", lambda *a: None)
        assert seeded_roots(*args, V) is None
        res = ur5.solve(pose)
    assert res.stats.get("certificate") != SEEDED and res.stats["method"] == "branch-and-prune"
    assert res.complete and len(res.solutions) == 2


def test_wide_relaxed_enclosures_send_the_pose_to_the_branch_and_prune(ur5):
    """Wrist 1e-6 from singular: the relaxed closed form bounds the count (8) with four
    enclosures a radian wide, where neither Krawczyk nor the separation applies; the pose goes to
    the branch and prune, whose 8 certified roots are the oracle's."""
    q = np.array([0.3, -1.2, 1.5, -0.8, 1e-6, 0.4])
    pose = ur5.pose_at(q)
    cf = ur5.closed_form
    bound = relaxed_roots(cf, pose.rotation, pose.translation)
    assert bound is not None and len(bound[1]) == 8
    V = np.asarray(ur5.problem(pose).source["pose"], dtype=float)
    assert not _one_root_each(cf, pose.rotation, pose.translation, *bound, V)
    narrow = [r for r in bound[1] if np.max(bound[0][r][:, 1] - bound[0][r][:, 0]) < 1e-9]
    assert len(narrow) == 4 and _one_root_each(cf, pose.rotation, pose.translation, bound[0], narrow)
    res = ur5.solve(pose)
    assert res.stats["method"] == "branch-and-prune" and res.complete
    assert _clean(judge(ur5, pose, res, q, ur="ur5"))
