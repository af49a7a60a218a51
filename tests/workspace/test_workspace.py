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


@pytest.fixture(scope="module", params=["search", "auto"])
def ur5(request):
    """The UR5 decided by the search and the parametric Krawczyk test, and by its closed form."""
    ik = IK("ur5", "tool0", formulation="arm")
    goal = ik.pose_at(Q)
    quat = pin.SE3ToXYZQUAT(goal)[3:]
    return ik, Reach(ik, quat, request.param), goal


def test_a_box_beyond_the_reach_is_outside(ur5):
    ik, r, goal = ur5
    v, w, st = r.decide(np.array([2.0, 2.0, 2.0]), np.array([2.1, 2.1, 2.1]), 0.05)
    assert v == OUTSIDE and w is None
    assert st["searches"] >= 1 if r.method == "search" else st["closed_form"] >= 1


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
    pv = reach("ur5", "tool0", quat, region=region, resolution=0.06, method=r.method)
    assert pv.complete
    counts = pv.counts()
    assert counts["inside"] > 0 and counts["outside"] > 0
    rng = np.random.default_rng(3)
    for lo, hi, v in zip(pv.lo, pv.hi, pv.verdict):
        if v == BOUNDARY:
            continue
        for _ in range(2):
            t = rng.uniform(lo, hi)
            res = ik.solve(np.concatenate([t, quat]), closed_form=False)  # the branch and prune
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


def test_closed_form_verdicts_agree_with_the_branch_and_prune_at_sampled_positions():
    """The closed form's set inversion on a region across the UR5's outer border, tool pointing
    down: random points of inside boxes have a certified root, of outside boxes none, by the
    branch and prune (not the closed form)."""
    ik = IK("ur5", "tool0", formulation="arm")
    quat = (1.0, 0.0, 0.0, 0.0)
    pv = reach("ur5", "tool0", quat, region=(0.55, -0.1, -0.1, 1.05, 0.1, 0.1), resolution=0.05)
    assert pv.complete
    c = pv.counts()
    assert c["inside"] > 0 and c["outside"] > 0
    rng = np.random.default_rng(5)
    for lo, hi, v in zip(pv.lo, pv.hi, pv.verdict):
        if v == BOUNDARY:
            continue
        t = rng.uniform(lo, hi)
        res = ik.solve(np.concatenate([t, quat]), closed_form=False)
        assert res.complete
        assert (v == INSIDE) == any(s.certified for s in res.solutions), (lo, hi, v)


def test_partial_branches_keep_what_the_whole_answer_keeps():
    """solve_branches(partial=True) returns the decided roots of a box; where every branch is
    decided it is the whole answer (solve_pose), and a wide box keeps some branches only."""
    from kinbox.search.closed_form import MAX_ROOTS, solve_branches, solve_pose

    ik = IK("ur5", "tool0", formulation="arm")
    cf = ik.closed_form
    goal = ik.pose_at(Q)
    Rlo, Rhi, tlo, thi = cf.goal_arrays(goal.rotation[None], goal.translation[None])
    a, b = np.zeros((MAX_ROOTS, 6, 4)), np.zeros((MAX_ROOTS, 6, 4))
    n = solve_pose(cf.code, cf.LR, cf.Lt, cf.d, Rlo[0], Rhi[0], tlo[0], thi[0], a, np.zeros((4, 3, 4)))
    m, undecided = solve_branches(cf.code, cf.LR, cf.Lt, cf.d, Rlo[0], Rhi[0], tlo[0], thi[0], b, np.zeros((4, 3, 4)), True)
    assert n == m == 8 and not undecided and np.array_equal(a, b)
    wide = 0.2
    n = solve_pose(cf.code, cf.LR, cf.Lt, cf.d, Rlo[0], Rhi[0], tlo[0] - wide, thi[0] + wide, a, np.zeros((4, 3, 4)))
    m, undecided = solve_branches(cf.code, cf.LR, cf.Lt, cf.d, Rlo[0], Rhi[0], tlo[0] - wide, thi[0] + wide, b, np.zeros((4, 3, 4)), True)
    assert n == -1 and undecided and 0 <= m < 8


def test_boxes_proven_in_pieces_agree_with_the_branch_and_prune():
    """Boxes at the resolution across the UR5's outer border (tool down) that the closed form
    decides only in pieces (eighths of eighths): points of an inside box, its corners among them,
    have a certified root by the branch and prune, points of an outside box none; an inside
    box's witness reaches its centre."""
    ik = IK("ur5", "tool0", formulation="arm")
    quat = (1.0, 0.0, 0.0, 0.0)
    r = Reach(ik, quat)
    deep = {INSIDE: [], OUTSIDE: []}
    for x in np.arange(0.80, 0.99, 0.0025):
        lo = np.array([x, 0.03, 0.02])
        hi = lo + 0.05
        if r.closed_form_verdict(lo, hi) is not None:
            continue
        st = {"closed_form": 0}
        v, w = r.closed_form_pieces(lo, hi, st)
        if v != BOUNDARY and st["closed_form"] > 8:  # the eighths alone did not decide it
            deep[v].append((lo, hi, w))
    assert deep[INSIDE] and deep[OUTSIDE]
    rng = np.random.default_rng(7)
    for v, boxes in deep.items():
        for lo, hi, w in boxes[:2]:
            corners = [np.where(np.array(k, dtype=bool), hi, lo) for k in np.ndindex(2, 2, 2)]
            for t in [*corners[::3], rng.uniform(lo, hi)]:
                res = ik.solve(np.concatenate([t, quat]), closed_form=False)
                assert res.complete
                assert (v == INSIDE) == any(s.certified for s in res.solutions), (lo, hi, v, t)
            if v == INSIDE:
                assert np.allclose(ik.pose_at(w).translation, 0.5 * (lo + hi), atol=1e-9)
