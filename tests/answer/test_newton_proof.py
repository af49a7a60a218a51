"""The general formulation's roots next to a wrist singularity, certified from Newton's point
(kinbox.answer.newton_proof, kinbox.search.seeded) and checked against roots computed at 40
digits (tests/support/oracles/mp_ik.py, complex Newton on the pose as given)."""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pytest

import kinbox
from kinbox.problems.run import run
from kinbox.search.point import SeededCertifier
from tests.support.curves import holds, judge
from tests.support.oracles import mp_ik


def _near_q(q: list[float], radius: float):
    """A UR5's pose of ``q`` through the general formulation, searched within ``radius`` of
    ``q``'s system point only (the valley of near-solutions next to the root at ``q``)."""
    ik = kinbox.IK("ur5", "tool0", formulation="general")
    goal = ik.pose_at(q)
    prob = ik.problem(goal)
    x = prob.formulation.encode(np.array(q))
    lo0, hi0 = prob.system.search_domain()
    res = run(prob, within=[(np.maximum(x - radius, lo0), np.minimum(x + radius, hi0))], policy="quick")
    return ik, goal, res


def test_a_valley_is_no_curve_in_the_general_formulation(monkeypatch):
    """1e-7 from the wrist singularity, through the general formulation, the root at ``q`` lies
    at the end of a valley of near-solutions along the singular arm's self-motion. Gauss-Newton
    slid the valley's points onto the root, and the valley was reported as a curve in its place
    (``components.CLOSURE_SLIDE``); its boxes left undecided, Newton's limit in them was reported
    uncertified with the valley's width (2e-3); proven from Newton's point, it is certified in
    a box that holds the 40-digit root, and the valley's boxes the proof does not settle stay
    undecided."""
    q = [0.3, -1.2, 1.5, -0.8, 1e-7, 0.4]
    ik, goal, res = _near_q(q, 0.05)
    assert not res.curves
    assert len(res.solutions) == 1 and res.solutions[0].certified
    mp.mp.dps = mp_ik.WORK
    real, _ = mp_ik.roots(mp_ik.Chain(ik.robot.model, ik.frame), mp_ik.exact_pose(goal), [np.array(q)])
    assert len(real) == 1 and holds(res, res.solutions[0], real[0])
    assert res.solutions[0].width < 1e-6
    n_boxes = len(res.raw.boxes)
    held = {i for c in res.components for i in c.boxes}
    assert held | set(res.undecided) == set(range(n_boxes)), "every box of the search is in the answer"
    # without the proof the same root is a point with the valley's width
    monkeypatch.setattr(SeededCertifier, "prove", lambda self, x: None)
    _, _, res0 = _near_q(q, 0.05)
    assert len(res0.solutions) == 1 and not res0.solutions[0].certified and res0.solutions[0].width > 1e-4


@pytest.mark.slow
@pytest.mark.parametrize("q5, certified", [(1e-7, 8), (1e-8, 8)])
def test_the_general_formulation_certifies_the_roots_next_to_the_wrist(q5, certified):
    """A UR5 1e-7 and 1e-8 from its wrist singularity through the general formulation: every
    root reported, each certified box holding its 40-digit root, no configuration twice, no
    curve. The four roots next to the singularity were a curve in their place (1e-7) and
    uncertified points with the width of their clusters, 0.01 to 0.05 (1e-8); 1e-8 from it one
    of them is not proven in the formulation's variables (no box about Newton's point is) and
    is proven in the joint angles (kinbox.answer.angle_proof)."""
    q = [0.3, -1.2, 1.5, -0.8, q5, 0.4]
    ik = kinbox.IK("ur5", "tool0", formulation="general")
    goal = ik.pose_at(q)
    res = ik.solve(goal, closed_form=False)
    rep = judge(ik, goal, res, q, ur="ur5")
    assert rep["real"] == 8 and rep["found"] == 8
    assert rep["duplicates"] == 0 and rep["lost"] == 0 and rep["curves"] == 0
    assert rep["cert_missing"] == 0 and rep["merged"] == 0 and rep["phantom"] == 0
    assert rep["certified"] == certified
