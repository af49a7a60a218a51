"""The seven-joint sweep's slabs are run on goal boxes widened by the links' radii
(kinbox.search.sweep.widened, kinbox.search.cf_delta): their enclosures hold every root of the
model as given, not only of the family's binary64 arm."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import kinbox
from kinbox.problems.selfmotion import _frame, linear_goal
from kinbox.search import sweep as sw_mod
from kinbox.search.cf_delta import Delta


@pytest.fixture(scope="module")
def panda():
    return kinbox.IK("panda", "panda_hand")


def _goal(panda, seed):
    sw = panda.sweeper
    m = panda.robot.model
    q = np.random.default_rng(seed).uniform(m.lowerPositionLimit[:7], m.upperPositionLimit[:7])
    goal = panda.pose_at(q)
    lin = linear_goal(sw.values[:3], [_frame(cf, goal) for cf in sw.forms[:3]])
    lin.anchors = sw.anchors(goal)
    return sw, lin


def test_slabs_are_widened_by_the_links_radii(panda):
    """``widened`` moves each bound out by the arm's bound (rotation entries by ``R``,
    translations by ``t0 + t1 |t|``); the sweep runs on it: the arm's own (about 1e-15) decides
    slabs, a bound of a metre decides none."""
    sw, lin = _goal(panda, 5)
    cf = sw.forms[0]
    assert cf.delta.proven and 0.0 < cf.delta.R < 1e-14
    box = lin.enclosure(sw.swept.lo + 0.2, sw.swept.lo + 0.3)
    w = sw_mod.widened(cf, box)
    tn = float(np.linalg.norm(np.maximum(np.abs(box[2]), np.abs(box[3]))))
    assert np.all(box[0] - w[0] >= cf.delta.R) and np.all(w[1] - box[1] >= cf.delta.R)
    assert np.all(box[2] - w[2] >= cf.delta.t0 + cf.delta.t1 * tn) and np.all(w[3] - box[3] >= cf.delta.t0)
    lo, hi = sw.swept.lo + 0.1, sw.swept.lo + 0.4
    slabs, _ = sw_mod.sweep(cf, lin, lo, hi, min_width=2.0**-6)
    assert any(s.kind == sw_mod.DECIDED for s in slabs)
    wide = dataclasses.replace(cf.delta, R=1.0, t0=1.0)
    old = cf.delta
    try:
        cf.delta = wide
        slabs, _ = sw_mod.sweep(cf, lin, lo, hi, min_width=2.0**-6)
    finally:
        cf.delta = old
    assert not any(s.kind == sw_mod.DECIDED for s in slabs)


def test_no_widening_without_radii():
    """An arm whose binary64 constants are the model (no radii): the box as it is."""
    box = (np.zeros((3, 3)), np.ones((3, 3)), np.zeros(3), np.ones(3))

    class CF:
        delta = Delta(0.0, 0.0, 0.0)

    assert all(a is b for a, b in zip(sw_mod.widened(CF(), box), box))
