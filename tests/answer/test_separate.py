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
    roots = oracle_roots(ik, goal, res, elbow(1e-7), ur=robot)
    rep = judge(ik, goal, res, elbow(1e-7), roots=roots)
    assert rep["real"] == 2 and rep["lost"] == rep["merged"] == rep["duplicates"] == rep["cert_missing"] == 0
    held = [[k for k, r in enumerate(roots[0]) if holds(res, s, r)] for s in res.solutions]
    assert sorted(h[0] for h in held) == [0, 1] and all(len(h) == 1 for h in held)
    a, b = res.solutions
    assert float(np.max(np.abs(a.q - b.q))) > a.width + b.width  # the boxes are apart


def test_a_complex_pair_stays_one_point():
    """1e-9 from straight the pair is complex (q3 = +-2.97e-8 i): the model's quadratic along
    the near-null direction has no real root, nothing is separated and the cluster stays
    (tests/answer/test_curves.py::test_a_pair_the_precision_cannot_separate_is_reported_as_one
    checks its width against the 40-digit complex pair)."""
    ik, goal, res = solved("ur5", 1e-9)
    (s,) = res.solutions
    assert not s.certified and s.multiplicity == 2 and "separated" not in res.stats
    g = ik.arm.geometry
    centre = np.array([get_angle(s.q, j) + gam for j, gam in zip(g.chain.joints, g.gamma)])
    model = sep.taylor_model(sep.arm_constants(g, ik.arm.constants), pin.SE3ToXYZQUAT(goal), centre)
    assert sep._pair(model) is None


def _case(q3: float):
    """The separation's inputs on the template's constants with their radii (no exact links):
    the cluster as the search leaves it (``closed_form=False`` and the hook bypassed)."""
    ik = kinbox.IK("ur5", "tool0")
    goal = ik.pose_at(elbow(q3))
    prob = ik.problem(goal)
    res = prob.solve()
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


def test_the_model_as_given_separates_what_the_radii_do_not():
    """1e-8 from straight (q3 = +-2.09e-8 on the UR5) the pair's curvature times its half
    distance squared, about 4e-17, is below the 2e-16 that the template's constants' radii
    leave on F: on those the pair is not separated; on the model's exact links and frames
    (120-bit enclosures) it is, into two disjoint boxes."""
    cs, V, centre, region = _case(1e-8)
    assert sep.separate_pair(cs, V, centre, region) is None
    _, _, res = solved("ur5", 1e-8)
    assert len(res.solutions) == 2 and all(s.certified for s in res.solutions)
    a, b = res.solutions
    assert float(np.max(np.abs(a.q - b.q))) > a.width + b.width
    # each box against the 40-digit roots: tests/answer/test_curves.py::test_elbow_sweep (slow)


def test_no_box_holding_a_root_is_excluded():
    """The exclusion is sound where it matters: boxes of every size from 3e-9 to 1e-6 about
    either root of the pair (Newton's point on the model, within some 6e-10 of its root along
    the near-null direction: the model's rounding over the smallest singular value), also
    shifted so the root sits off centre, are never proven empty, on the template's constants
    with their radii and on the model's exact ones."""
    cs, V, centre, region = _case(1e-7)
    ik = kinbox.IK("ur5", "tool0")
    from kinbox.formulation.constants import enclose_links

    exact = enclose_links(ik.arm.geometry, ik.arm.mechanism, "tool0", None, keep_exact=True)
    for consts in (cs, sep.arm_constants(ik.arm.geometry, ik.arm.constants, exact)):
        m0 = sep.taylor_model(consts, V, centre)
        _, _, Vt = np.linalg.svd(0.5 * (m0.J[0] + m0.J[1]))
        model = m0.rotated(np.ascontiguousarray(Vt.T))
        got = sep._pair(model)
        assert got is not None
        U, S, _ = np.linalg.svd(0.5 * (model.J[0] + model.J[1]))
        W = np.diag(np.concatenate([1.0 / S[:5], [1.0]])) @ U.T
        pre = sep.precondition(model, W)
        lo, hi = [], []
        for x in got[:2]:
            for r in 10.0 ** np.arange(-8.5, -5.9, 0.25):
                for shift in (0.0, 0.5, -0.5):
                    lo.append(x - r + shift * r)
                    hi.append(x + r + shift * r)
        assert not np.any(sep.excluded(model, pre, W, np.array(lo), np.array(hi)))


def test_every_turn_of_both_roots():
    """A UR5's joints range over two turns: each separated root stands for its copies q + 2 pi k
    within the limits, counted over both roots (twice the cluster's count), and with
    ``all_turns`` every copy of both is listed, none twice."""
    ik = kinbox.IK("ur5", "tool0")
    goal = ik.pose_at(elbow(1e-7))
    one = ik.solve(goal)
    every = ik.solve(goal, all_turns=True)
    n = one.stats["configurations_within_limits"]
    assert len(one.solutions) == 2 and n == len(every.solutions) == 64
    assert sum(1 for x in one.notes if "range wider than a turn" in x) == 1
    assert all(s.certified for s in every.solutions)
    qs = np.array([s.q for s in every.solutions])
    gaps = np.max(np.abs(qs[:, None, :] - qs[None, :, :]), axis=2) + np.eye(len(qs))
    assert float(np.min(gaps)) > 1e-8
