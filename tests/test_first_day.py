"""What got in a new user's way on a first day, each from the case that showed it: negative
values after options, wall-time and CPU budgets, residual units and fewer-than-six-joint
answers, ambiguous frame names, multi-DOF locks and floating bases, the ``auto`` formulation of
constraint systems, under-constrained systems, ``check`` on planar mechanisms, platform poses,
joint ranges wider than a turn, and incomplete replay pages.

Answers are checked against Pinocchio forward kinematics or the published / hand-counted
figures named in each test, never against kinbox's own output alone.
"""

from __future__ import annotations

import json

import numpy as np
import pinocchio as pin
import pytest

from tests.test_cli import assert_usage_error, kinbox_cli, tool0


# -- negative values after an option ------------------------------------------------------------
@pytest.mark.parametrize("sep", [",", " "])
def test_negative_values_after_options(sep):
    """``--from-q -1.72,...`` (and with spaces), ``--pose -0.3 ...``, ``--lock J=-1`` and
    ``--set crank=-1`` are values, not options; the answers hold the goals (Pinocchio FK)."""
    q = [-1.72, 0.3, -0.2, 0.1, -0.2, 0.3]
    p = kinbox_cli("ik", "ur5", "--frame", "tool0", "--from-q", sep.join(map(str, q)), "--json", "--quiet")
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert any(np.allclose(s["q"], q, atol=1e-7) for s in d["solutions"])
    goal = tool0(q)
    pose = pin.SE3ToXYZQUAT(goal)
    pose[0] = -abs(pose[0])
    p = kinbox_cli("ik", "ur5", "--frame", "tool0", "--pose", *pose, "--json", "--quiet")
    assert p.returncode == 0, p.stderr
    goal = pin.XYZQUATToSE3(pose)
    for s in json.loads(p.stdout)["solutions"]:
        M = tool0(s["q"])
        assert np.linalg.norm(M.translation - goal.translation) < 1e-9
    p = kinbox_cli("ik", "ur5", "--frame", "tool0", "--from-q", ",".join(map(str, q)), "--lock", "shoulder_pan_joint=-1.72", "--json", "--quiet")
    assert p.returncode == 0, p.stderr
    sols = json.loads(p.stdout)["solutions"]
    assert sols and all(abs(s["q"][0] + 1.72) < 1e-12 for s in sols)
    p = kinbox_cli("solve", "four-bar", "--set", "crank=-1", "--json", "--quiet")
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["solutions"] and all(abs(s["q"][d["joint_names"].index("crank")] + 1) < 1e-12 for s in d["solutions"])


def test_an_option_after_an_option_is_still_an_error():
    """Only numbers are taken as values: ``--from-q -x`` is still a usage error."""
    assert_usage_error(kinbox_cli("ik", "ur5", "--frame", "tool0", "--from-q", "-x"), "--from-q")


# -- wall time and CPU time ----------------------------------------------------------------------
def test_cpu_limit_stops_the_search_incomplete():
    """Dietmeier's platform needs many CPU seconds: ``--cpu-limit 0.5`` stops it, the answer
    printed in full and marked incomplete (exit 4) with the CPU limit named; ``--time-limit``
    says in its help that it is wall time; ``--cpu-limit`` with worker processes is refused."""
    p = kinbox_cli("solve", "dietmeier", "--cpu-limit", "0.5", "--json", "--quiet")
    assert p.returncode == 4, p.stderr
    d = json.loads(p.stdout)
    assert d["complete"] is False and "CPU limit" in d["message"]
    assert d["stats"]["cpu_seconds"] < 30
    h = kinbox_cli("solve", "--help")
    assert "wall-clock" in " ".join(h.stdout.split()) and "--cpu-limit" in h.stdout
    assert_usage_error(kinbox_cli("solve", "dietmeier", "--cpu-limit", "1", "--workers", "2"), "--cpu-limit")
    assert_usage_error(kinbox_cli("solve", "dietmeier", "--cpu-limit", "0"), "--cpu-limit")
