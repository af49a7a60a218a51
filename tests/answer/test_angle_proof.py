"""The general formulation's roots 1e-9 and 1e-10 from a UR5's wrist singularity, proven in the
joint angles (kinbox.answer.angle_proof, kinbox.search.angle_root) and checked against roots
computed at 40 digits (tests/support/oracles/mp_ik.py, complex Newton on the pose as given)."""

from __future__ import annotations

import copy

import mpmath as mp
import numpy as np
import pytest

import kinbox
from kinbox.answer import angle_proof
from tests.support.curves import holds
from tests.support.oracles import mp_ik


def _near_q(q: list[float], radius: float):
    """A UR5's pose of ``q`` through the general formulation, searched within ``radius`` of
    ``q``'s system point only (the valley of near-solutions next to the root at ``q``)."""
    ik = kinbox.IK("ur5", "tool0", formulation="general")
    goal = ik.pose_at(q)
    prob = ik.problem(goal)
    x = prob.formulation.encode(np.array(q))
    lo0, hi0 = prob.system.search_domain()
    res = ik.solve(goal, closed_form=False, within=[(np.maximum(x - radius, lo0), np.minimum(x + radius, hi0))])
    return ik, goal, res


def _proven_next_to_the_wrist(q5: float, monkeypatch) -> None:
    q = [0.3, -1.2, 1.5, -0.8, q5, 0.4]
    before: list[list[bool]] = []
    real_proof = angle_proof.certify_in_angles

    lost: list = []

    def spy(res, *a, **k):
        before.append([s.certified for s in res.solutions])
        # the same answer with the point's boxes undecided and the point gone (the root lies
        # only in boxes the answer reports as not ruled out, as 1e-10 from the singularity)
        alt = copy.copy(res)
        alt.solutions, alt.components, alt.stats = [], [], dict(res.stats)
        alt.undecided = sorted(set(res.undecided) | {i for c in res.components for i in c.boxes})
        lost.append(real_proof(alt, *a, **k))
        return real_proof(res, *a, **k)

    monkeypatch.setattr(angle_proof, "certify_in_angles", spy)
    ik, goal, res = _near_q(q, 0.05)
    # without the angles' proof the search's cluster is one uncertified point
    assert before == [[False]]
    assert not res.curves
    assert len(res.solutions) == 1 and res.solutions[0].certified
    mp.mp.dps = mp_ik.WORK
    real, _ = mp_ik.roots(mp_ik.Chain(ik.robot.model, ik.frame), mp_ik.exact_pose(goal), [np.array(q)])
    assert len(real) == 1 and holds(res, res.solutions[0], real[0])
    assert res.solutions[0].width < 1e-12
    held = {i for c in res.components for i in c.boxes}
    assert held | set(res.undecided) == set(range(len(res.raw.boxes))), "every box of the search is in the answer"
    # from undecided boxes alone: the same root, proven
    (alt,) = lost
    assert len(alt.solutions) == 1 and alt.solutions[0].certified and holds(alt, alt.solutions[0], real[0])
    assert set(alt.undecided) == set(range(len(res.raw.boxes)))


def test_a_root_next_to_the_wrist_is_proven_in_the_angles(monkeypatch):
    """1e-9 from the wrist singularity no box about the root is proven in the general
    formulation's 28 variables: the search's cluster of boxes along the valley (0.09 wide) is
    one uncertified point. In the six joint angles the root is proven, in a box that holds its
    40-digit root, and every box of the cluster stays in the answer, as not ruled out; from
    the cluster's boxes alone, undecided, the same root is proven."""
    _proven_next_to_the_wrist(1e-9, monkeypatch)


@pytest.mark.slow
def test_a_root_closer_to_the_wrist_is_proven_in_the_angles(monkeypatch):
    """The same 1e-10 from the wrist singularity."""
    _proven_next_to_the_wrist(1e-10, monkeypatch)


@pytest.mark.slow
def test_every_root_next_to_the_wrist_is_certified():
    """A UR5 1e-9 from its wrist singularity through the general formulation, the whole pose
    (some 200 s of CPU): every root certified, each box holding its 40-digit root, no
    configuration twice, no point standing for no root, no curve. The four roots next to the
    singularity were uncertified points, and 94 points of multiplicity 0 along the valley were
    reported as singular roots (1e-8 from it: tests/answer/test_newton_proof.py)."""
    q5 = 1e-9
    from tests.support.curves import judge

    q = [0.3, -1.2, 1.5, -0.8, q5, 0.4]
    ik = kinbox.IK("ur5", "tool0", formulation="general")
    goal = ik.pose_at(q)
    res = ik.solve(goal, closed_form=False)
    rep = judge(ik, goal, res, q, ur="ur5")
    assert rep["real"] == 8 and rep["certified"] == 8 and rep["lost"] == 0
    assert rep["duplicates"] == 0 and rep["curves"] == 0 and rep["phantom"] == 0
    assert rep["cert_missing"] == 0 and rep["merged"] == 0
