"""Workspaces with the tool's orientation free or within a cone (kinbox.workspace.free): the
enclosures and the verdicts checked against Pinocchio's forward kinematics at sampled
configurations, never against themselves."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kinbox import cli
from kinbox.pipeline import IK
from kinbox.workspace import INSIDE, OUTSIDE, reach
from kinbox.workspace.free import FreeReach

CONE = (0.0, 0.0, -1.0, 0.6)


@pytest.fixture(scope="module")
def ur5():
    ik = IK("ur5", "tool0", formulation="arm")
    return ik, FreeReach(ik), FreeReach(ik, CONE)


def _sample(ik, fr, n, seed):
    """Positions and tool axes of ``n`` random configurations within the joint limits, by
    Pinocchio's forward kinematics."""
    rng = np.random.default_rng(seed)
    P, U = [], []
    for _ in range(n):
        M = ik.pose_at(fr.fk.configuration(rng.uniform(fr.fk.lo, fr.fk.hi)))
        P.append(M.translation)
        U.append(M.rotation[:, 2])
    return np.array(P), np.array(U)


def test_the_enclosures_hold_the_forward_kinematics(ur5):
    ik, fr, _ = ur5
    fk = fr.fk
    rng = np.random.default_rng(0)
    for _ in range(60):
        a, b = rng.uniform(fk.lo, fk.hi), rng.uniform(fk.lo, fk.hi)
        lo = np.minimum(a, b)
        hi = lo + (np.maximum(a, b) - lo) * rng.uniform(0, 1, 6) ** 3
        pm, pr, um, ur = fk.enclose(lo, hi)
        for _ in range(10):
            M = ik.pose_at(fk.configuration(rng.uniform(lo, hi)))
            assert np.all(np.abs(M.translation - pm) <= pr)
            assert np.all(np.abs(M.rotation[:, 2] - um) <= ur)


def test_verdicts_agree_with_sampled_configurations(ur5):
    """No sampled position lies in a box proven outside; the witness of an inside box reaches its
    centre within the limits (with the tool axis in the cone for a cone)."""
    ik, fr, frc = ur5
    P, U = _sample(ik, fr, 4000, 1)
    boxes = [
        ((1.2, 1.2, 1.2), (1.3, 1.3, 1.3)),  # beyond the reach
        ((0.9, 0.2, 0.5), (1.0, 0.3, 0.6)),  # just beyond it
        ((0.3, 0.1, 0.2), (0.35, 0.15, 0.25)),
        ((0.4, -0.2, 0.0), (0.45, -0.15, 0.05)),
    ]
    seen = set()
    for r, in_cone in ((fr, np.ones(len(P), bool)), (frc, U @ np.array(CONE[:3]) >= math.cos(CONE[3]))):
        for lo, hi in boxes:
            lo, hi = np.array(lo), np.array(hi)
            v, w, _ = r.decide(lo, hi, 0.05)
            seen.add(v)
            if v == OUTSIDE:
                hit = np.all((P >= lo) & (P <= hi), axis=1) & in_cone
                assert not hit.any()
            if v == INSIDE:
                M = ik.pose_at(w)
                assert np.allclose(M.translation, 0.5 * (lo + hi), atol=1e-9)
                if r is frc:
                    assert M.rotation[:, 2] @ np.array(CONE[:3]) >= math.cos(CONE[3])
    assert {INSIDE, OUTSIDE} <= seen


@pytest.mark.slow
def test_a_paving_is_sound_against_sampled_configurations(ur5):
    ik, fr, _ = ur5
    pv = reach("ur5", "tool0", "any", region=(0.5, -0.1, 0.2, 1.1, 0.1, 0.4), resolution=0.1)
    assert pv.complete and pv.counts()["outside"] > 0 and pv.counts()["inside"] > 0
    P, _ = _sample(ik, fr, 20000, 2)
    for lo, hi, v in zip(pv.lo, pv.hi, pv.verdict):
        if v == OUTSIDE:
            assert not np.all((P >= lo) & (P <= hi), axis=1).any()


def test_the_command_paves_any_orientation_and_a_cone(capsys):
    region = ["--region", "0.3", "0.1", "0.2", "0.35", "0.15", "0.25", "--resolution", "0.05"]
    assert cli.main(["reach", "ur5", "--frame", "tool0", "--any-orientation", *region]) == 0
    assert "inside" in capsys.readouterr().out
    assert cli.main(["reach", "ur5", "--frame", "tool0", "--cone", "0", "0", "-1", "0.6", *region, "--json"]) == 0
    assert '"cone": [0.0, 0.0, -1.0, 0.6]' in capsys.readouterr().out


@pytest.mark.parametrize(
    "extra, says",
    [
        (["--cone", "0", "0", "0", "0.5"], "nonzero direction"),
        (["--cone", "0", "0", "1", "0.5", "--any-orientation"], "once"),
        (["--any-orientation", "--orientation", "0", "0", "0", "1"], "once"),
    ],
)
def test_bad_orientation_arguments_are_one_line(extra, says, capsys):
    assert cli.main(["reach", "ur5", "--frame", "tool0", *extra]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and says in err[0]


@pytest.mark.slow
def test_the_search_decides_where_no_closed_form_is_used(ur5):
    """method="search": inside by the fixed-orientation search and parametric Krawczyk test."""
    ik, _, _ = ur5
    fr = FreeReach(ik, method="search")
    lo, hi = np.array([0.3, 0.1, 0.2]), np.array([0.32, 0.12, 0.22])
    v, w, st = fr.decide(lo, hi, 0.05)
    assert v == INSIDE and st["centre_solves"] == 0 and st["krawczyk"] > 0
    assert np.allclose(ik.pose_at(w).translation, 0.5 * (lo + hi), atol=1e-9)
    v, w, _ = fr.decide(np.full(3, 1.2), np.full(3, 1.3), 0.05)
    assert v == OUTSIDE
