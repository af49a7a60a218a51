"""A near-double real pair separated into two certified roots (kinbox.answer.separate,
kinbox.search.separate), checked against the 40-digit roots of the pose as given
(tests/support/oracles/mp_ik.py through tests/support/curves.py)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import kinbox
from kinbox.answer.separate import _region
from kinbox.formulation.arm import get_angle
from kinbox.search import separate as sep
from tests.support.curves import holds, judge, oracle_roots


def elbow(q3: float) -> list[float]:
    return [0.3, -1.2, q3, -0.8, 1.2, 0.4]


def solved(robot: str, q3: float, **opts):
    ik = kinbox.IK(robot, "tool0")
    goal = ik.pose_at(elbow(q3))
    return ik, goal, ik.solve(goal, **opts)


@pytest.mark.parametrize(
    "robot, path",
    [("ur5", "user"), pytest.param("ur5", "search", marks=pytest.mark.slow), pytest.param("ur10", "user", marks=pytest.mark.slow)],
)
def test_a_pair_1e_7_from_the_elbow_singularity_is_two_certified_roots(robot, path):
    """1e-7 from straight the elbow's two real roots (q3 = +-1.02e-7 on the UR5) were one
    uncertified point of multiplicity 2; now each is certified in its own box, the two boxes
    disjoint, each holding one 40-digit root."""
    ik, goal, res = solved(robot, 1e-7, closed_form=path == "user")
    assert len(res.solutions) == 2 and all(s.certified for s in res.solutions)
    assert res.stats["separated"] == 1
    rep = judge(ik, goal, res, elbow(1e-7), ur=robot)
    assert rep["real"] == 2 and rep["lost"] == rep["merged"] == rep["duplicates"] == rep["cert_missing"] == 0
    real, _ = oracle_roots(ik, goal, res, elbow(1e-7), ur=robot)
    held = [[k for k, r in enumerate(real) if holds(res, s, r)] for s in res.solutions]
    assert sorted(h[0] for h in held) == [0, 1] and all(len(h) == 1 for h in held)
    a, b = res.solutions
    assert float(np.max(np.abs(a.q - b.q))) > a.width + b.width  # the boxes are apart


def test_a_complex_pair_stays_one_point():
    """1e-9 from straight the pair is complex (q3 = +-2.97e-8 i): nothing to separate, the
    cluster stays, reaching both complex roots."""
    ik, goal, res = solved("ur5", 1e-9)
    (s,) = res.solutions
    assert not s.certified and s.multiplicity == 2 and "separated" not in res.stats
    rep = judge(ik, goal, res, elbow(1e-9), ur="ur5")
    assert (rep["real"], rep["complex"], rep["complex_in_clusters"]) == (0, 2, 2)


def _case(q3: float):
    ik, goal, res = solved("ur5", q3)
    s = res.solutions[0]
    g = ik.arm.geometry
    centre = np.array([get_angle(s.q, j) + gam for j, gam in zip(g.chain.joints, g.gamma)])
    region = _region(ik.arm, [res.raw.boxes[b] for b in res.components[s.component].boxes], centre)
    return sep.arm_constants(g, ik.arm.constants), pin.SE3ToXYZQUAT(goal), centre, region


def test_the_region_must_be_proven_empty_outside_the_two_boxes(monkeypatch):
    """The separation holds only if the cluster's region holds no root outside the two proof
    boxes: with the exclusion's budget spent before it is done, or with an exclusion that
    decides nothing (every piece left standing: a root it cannot rule out), nothing is
    separated; with both, the pair is."""
    cs, V, centre, region = _case(1e-7)
    got = sep.separate_pair(cs, V, centre, region)
    assert got is not None and got.boxes > 1
    monkeypatch.setattr(sep, "MAX_BOXES", got.boxes - 1)
    assert sep.separate_pair(cs, V, centre, region) is None
    monkeypatch.setattr(sep, "MAX_BOXES", 200)
    monkeypatch.setattr(sep, "excluded", lambda model, pre, W, lo, hi: np.zeros(len(lo), dtype=bool))
    assert sep.separate_pair(cs, V, centre, region) is None


def test_a_pair_the_enclosures_cannot_separate_stays_one_point():
    """1e-8 from straight (q3 = +-2.09e-8) the pair's curvature times its distance squared is
    below the enclosure of F (about 2e-16): the point stays, with its width reaching both."""
    ik, goal, res = solved("ur5", 1e-8)
    (s,) = res.solutions
    assert not s.certified and s.multiplicity == 2
    rep = judge(ik, goal, res, elbow(1e-8), ur="ur5")
    assert rep["real"] == 2 and rep["lost"] == 0
