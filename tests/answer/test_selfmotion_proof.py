"""The sweep's answer says where one root per enclosure between sampled points is not proven
(stats ``slabs_proven`` / ``slabs_unproven``, the message; kinbox.search.slab_proof)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import kinbox
from kinbox.answer import selfmotion as answer_selfmotion
from kinbox.search import slab_proof


@pytest.fixture(scope="module")
def panda():
    return kinbox.IK("panda", "panda_hand")


def _solve(ik, seed: int):
    m = ik.robot.model
    q = np.random.default_rng(seed).uniform(m.lowerPositionLimit[:7], m.upperPositionLimit[:7])
    goal = ik.pose_at(q)
    return ik.sweeper.solve(ik.problem(goal), goal)


def test_without_the_proof_every_decided_slab_is_flagged(panda, monkeypatch):
    """The proof off: every decided slab counted unproven, in the stats (and the JSON) and the
    message; with it on (its kernel replaced by a verdict per slab, every third one failing)
    the failures are counted, and the curves are the same."""
    monkeypatch.setattr(answer_selfmotion, "PROVE_SLABS", False)
    res = _solve(panda, 3)
    assert res is not None and res.complete
    st = res.stats
    assert st["slabs_proven"] == 0 and st["slabs_unproven"] > 0
    assert st["slabs_unproven"] + st["fold_slabs"] == st["slabs"]
    assert f"not proven on {st['slabs_unproven']}" in res.message
    assert json.loads(json.dumps(res.to_dict()["stats"], default=str))["slabs_unproven"] == st["slabs_unproven"]
    calls = []

    def verdict(self, a, b, n):
        calls.append((a, b))
        return len(calls) % 3 != 0

    monkeypatch.setattr(slab_proof.SlabProver, "prove", verdict)
    monkeypatch.setattr(answer_selfmotion, "PROVE_SLABS", True)
    on = _solve(panda, 3)
    assert on is not None
    assert on.stats["slabs_unproven"] == len(calls) // 3 and on.stats["slabs_proven"] == len(calls) - len(calls) // 3
    assert len(on.curves) == len(res.curves) and on.stats["curve_points"] == st["curve_points"]


@pytest.mark.slow
def test_the_proof_on_a_whole_sweep(panda):
    """The proof on a whole Panda sweep: nearly every decided slab proven, the rest counted."""
    m = panda.robot.model
    q = np.random.default_rng(3).uniform(m.lowerPositionLimit[:7], m.upperPositionLimit[:7])
    goal = panda.pose_at(q)
    sw = panda.sweeper
    from kinbox.problems.selfmotion import linear_goal

    lin = linear_goal(sw.values[:3], sw.frames(goal)[:3])
    lin.anchors = sw.anchors(goal)
    prob = panda.problem(goal)
    res = answer_selfmotion.sweep_result(
        sw.forms[0], lin, sw.swept, prob.formulation, prob.label, prob.sigma, prob.source, lambda q: 0.0, None, prove_slabs=True
    )
    assert res is not None
    st = res.stats
    decided = st["slabs"] - st["fold_slabs"]
    assert st["slabs_proven"] + st["slabs_unproven"] == decided
    assert st["slabs_proven"] >= 0.9 * decided
