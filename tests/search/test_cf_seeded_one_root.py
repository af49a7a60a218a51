"""The seeded closed form answers only where each relaxed enclosure holds one root of the model
(kinbox.search.cf_seeded._one_root_each): a near-double pair, whose two roots share both
relaxed enclosures, goes to the branch and prune, as it would without the seed; where the
enclosures are apart, Krawczyk proves one root in each."""

from __future__ import annotations

import numpy as np
import pytest

from kinbox.pipeline import IK
from kinbox.search.certify import Certifier
from kinbox.search.cf_seeded import _one_root_each, relaxed_roots, seeded_roots


@pytest.fixture(scope="module")
def ur5() -> IK:
    return IK("ur5", "tool0")


def test_a_merged_pair_is_not_answered_by_the_seed(ur5, monkeypatch):
    """Elbow 1e-6 from straight: the relaxed bound is 2, two enclosures 1e-6 wide about a pair
    whose Jacobian's condition number is about 1e7; Krawczyk over a box holding an enclosure
    does not contract there, so one root per enclosure is not proven: no seeded answer (its
    proof boxes would meet the bound, monkeypatched below), and the branch and prune finds the
    same two roots."""
    q = [0.3, -1.2, 1e-6, -0.8, 1.2, 0.4]
    pose = ur5.pose_at(q)
    cf = ur5.closed_form
    bound = relaxed_roots(cf, pose.rotation, pose.translation)
    assert bound is not None
    enc, keep = bound
    assert len(keep) == 2
    assert not _one_root_each(cf, pose.rotation, pose.translation, enc, keep)
    prob = ur5.problem(pose)
    args = (cf, Certifier(prob.system.compile()), pose.rotation, pose.translation, *prob.system.search_domain())
    assert seeded_roots(*args) is None
    with monkeypatch.context() as mp:  # without the check the seed answers with the bound
        mp.setattr("kinbox.search.cf_seeded._one_root_each", lambda *a: True)
        batch = seeded_roots(*args)
        assert batch is not None and batch.count[0] == 2
    res = ur5.solve(pose)
    assert res.stats.get("certificate") != "system, from Newton's point"
    assert res.complete and len(res.solutions) == 2


@pytest.mark.parametrize("q", [[0.3, -1.2, 1.5, -0.8, 1e-6, 0.4], [0.3, -1.2, 1e-3, -0.8, 1.2, 0.4]])
def test_apart_enclosures_each_hold_one_root(ur5, q):
    """Where the relaxed enclosures that are narrow are apart (a generic root next to the
    relaxed ones), Krawczyk proves one root in each of them: the check fails only through the
    relaxed, wide ones."""
    pose = ur5.pose_at(q)
    cf = ur5.closed_form
    bound = relaxed_roots(cf, pose.rotation, pose.translation)
    assert bound is not None
    enc, keep = bound
    narrow = [r for r in keep if np.max(enc[r][:, 1] - enc[r][:, 0]) < 1e-9]
    assert narrow
    assert _one_root_each(cf, pose.rotation, pose.translation, enc, narrow)
