"""Workspace pavings (kinbox.workspace): each verdict checked against the ordinary IK and
Pinocchio's forward kinematics, never against itself."""

from __future__ import annotations

import json

import numpy as np
import pinocchio as pin
import pytest

from kinbox import cli
from kinbox.pipeline import IK
from kinbox.workspace import BOUNDARY, INSIDE, OUTSIDE, Paving, Reach, reach

Q = np.array([0.3, -1.2, 1.5, -0.8, 1.2, 0.4])


@pytest.fixture(scope="module")
def ur5():
    ik = IK("ur5", "tool0", formulation="arm")
    goal = ik.pose_at(Q)
    quat = pin.SE3ToXYZQUAT(goal)[3:]
    return ik, Reach(ik, quat), goal


def test_a_box_beyond_the_reach_is_outside(ur5):
    ik, r, goal = ur5
    v, w, st = r.decide(np.array([2.0, 2.0, 2.0]), np.array([2.1, 2.1, 2.1]), 0.05)
    assert v == OUTSIDE and w is None and st["searches"] >= 1


def test_a_box_about_a_reached_pose_is_inside_and_its_witness_reaches_the_centre(ur5):
    ik, r, goal = ur5
    lo, hi = goal.translation - 0.004, goal.translation + 0.004
    v, w, _ = r.decide(lo, hi, 0.05)
    assert v == INSIDE
    reached = ik.pose_at(w)
    assert np.allclose(reached.translation, 0.5 * (lo + hi), atol=1e-9)
    assert np.allclose(reached.rotation, goal.rotation, atol=1e-9)


@pytest.mark.slow
def test_every_verdict_agrees_with_the_ik_at_sampled_positions(ur5):
    """Points of outside boxes have no IK solution, points of inside boxes have a certified one
    (the IK of each point is solved independently of the paving)."""
    ik, r, goal = ur5
    c = goal.translation
    d = c / np.linalg.norm(c)  # a bar from the reached pose out beyond the arm's reach
    region = np.concatenate([np.minimum(c, c + d) - 0.02, np.maximum(c, c + d) + 0.02])
    quat = pin.SE3ToXYZQUAT(goal)[3:]
    pv = reach("ur5", "tool0", quat, region=region, resolution=0.06)
    assert pv.complete
    counts = pv.counts()
    assert counts["inside"] > 0 and counts["outside"] > 0
    rng = np.random.default_rng(3)
    for lo, hi, v in zip(pv.lo, pv.hi, pv.verdict):
        if v == BOUNDARY:
            continue
        for _ in range(2):
            t = rng.uniform(lo, hi)
            res = ik.solve(np.concatenate([t, quat]))
            assert res.complete
            if v == OUTSIDE:
                assert not res.solutions
            else:
                assert any(s.certified for s in res.solutions)


@pytest.mark.slow
def test_the_paving_is_the_same_over_two_workers(ur5):
    ik, r, goal = ur5
    quat = pin.SE3ToXYZQUAT(goal)[3:]
    region = np.concatenate([goal.translation - 0.1, goal.translation + 0.1])
    a = reach("ur5", "tool0", quat, region=region, resolution=0.1)
    b = reach("ur5", "tool0", quat, region=region, resolution=0.1, workers=2)
    assert np.array_equal(a.lo, b.lo) and np.array_equal(a.hi, b.hi) and np.array_equal(a.verdict, b.verdict)


def test_save_and_load_keep_the_paving(tmp_path, ur5):
    ik, r, goal = ur5
    quat = pin.SE3ToXYZQUAT(goal)[3:]
    region = np.concatenate([goal.translation - 0.05, goal.translation + 0.05])
    pv = reach("ur5", "tool0", quat, region=region, resolution=0.1)
    for name in ("map.npz", "map.json"):
        pv.save(str(tmp_path / name))
        back = Paving.load(str(tmp_path / name))
        assert np.array_equal(back.verdict, pv.verdict) and np.array_equal(back.lo, pv.lo)
        assert back.volumes() == pytest.approx(pv.volumes())
        assert back.meta["frame"] == "tool0"


def test_the_command_writes_prints_and_plots(tmp_path, capsys):
    out = tmp_path / "m.npz"
    argv = ["reach", "ur5", "--frame", "tool0", "--orientation", "1", "0", "0", "0"]
    argv += ["--region", "0.3", "0.0", "0.1", "0.4", "0.1", "0.2", "--resolution", "0.1", "--out", str(out), "--json"]
    assert cli.main(argv) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["kind"] == "workspace" and d["complete"] is True
    assert {b["verdict"] for b in d["boxes"]} <= {"inside", "outside", "boundary"}
    assert sum(d["volumes"][k] for k in ("inside", "outside", "boundary")) == pytest.approx(0.001)
    png = tmp_path / "m.png"
    assert cli.main(["plot", str(out), "-o", str(png)]) == 0
    assert png.stat().st_size > 1000


@pytest.mark.parametrize(
    "extra, says",
    [
        (["--region", "0", "0", "0", "0", "1", "1"], "region"),
        (["--resolution", "-1"], "resolution"),
        (["--orientation", "1", "1", "0", "0"], "norm 1"),
    ],
)
def test_bad_arguments_are_one_line(extra, says, capsys):
    assert cli.main(["reach", "ur5", "--frame", "tool0", *extra]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and says in err[0]
