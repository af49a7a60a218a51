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

from tests.support import paths as PATHS
from tests.support.cli import assert_usage_error, kinbox_cli, tool0, ur5_model


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
    lock = ("--lock", "shoulder_pan_joint=-1.72")
    p = kinbox_cli("ik", "ur5", "--frame", "tool0", "--from-q", ",".join(map(str, q)), *lock, "--json", "--quiet")
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


# -- frames, locks, floating bases, fewer than six joints (so100 of example-robot-data) ----------
def test_ambiguous_frame_names_are_refused_with_candidates():
    """so100 has a link ``gripper`` (on wrist_roll) and a joint ``gripper`` (the jaw's): a bare
    ``gripper`` is refused with both candidates named; ``gripper:body`` and ``gripper:joint``
    choose one, and the goal is the pose Pinocchio gives that frame."""
    p = kinbox_cli("ik", "so100", "--frame", "gripper", "--pose", 0, 0, 0.2, 0, 0, 0, 1)
    line = assert_usage_error(p, "ambiguous", "gripper:body", "gripper:joint")
    assert "wrist_roll" in line
    import kinbox

    ik = kinbox.IK("so100", "gripper:body", lock={"root_joint": [0, 0, 0, 0, 0, 0, 1]})
    m = ik.robot.model
    q = pin.neutral(m)
    q[7:12] = [0.1, 0.2, -0.3, 0.4, 0.5]
    d = m.createData()
    pin.framesForwardKinematics(m, d, q)
    body = next(f for f in range(m.nframes) if m.frames[f].name == "gripper" and m.frames[f].type == pin.FrameType.BODY)
    assert ik.pose_at(q).isApprox(d.oMf[body], 1e-12)
    assert ik.pose_at([0.1, 0.2, -0.3, 0.4, 0.5]).isApprox(d.oMf[body], 1e-12)
    jf = kinbox.IK("so100", "gripper:joint", lock={"root_joint": [0, 0, 0, 0, 0, 0, 1]})
    assert jf.robot.frame_anchor("gripper:joint")[0] == m.getJointId("gripper")


def test_floating_base_in_the_chain_is_refused():
    """so100's root is a free-flyer: an IK of its gripper relative to the world would search
    the base's six degrees of freedom too (11 unknowns for a pose). Refused in one line with
    the two ways out, which both work."""
    p = kinbox_cli("ik", "so100", "--frame", "gripper:body", "--from-q", "0.1,0.2,-0.3,0.4,0.5")
    assert_usage_error(p, "floating base", "--lock root_joint=0,0,0,0,0,0,1", "--base base")
    for extra in (["--lock", "root_joint=0,0,0,0,0,0,1"], ["--base", "base"]):
        p = kinbox_cli("ik", "so100", "--frame", "gripper:body", "--from-q", "0.1,0.2,-0.3,0.4,0.5", "--json", "--quiet", *extra)
        assert p.returncode == 0, p.stderr
        d = json.loads(p.stdout)
        assert d["complete"] and any(np.allclose(s["q"][7:12], [0.1, 0.2, -0.3, 0.4, 0.5], atol=1e-7) for s in d["solutions"])


def test_lock_takes_vectors():
    """``--lock root_joint=0,0,0.1,0,0,0,1`` holds a free-flyer at a pose (x y z qx qy qz qw):
    every solution keeps it; a wrong count is one line naming the joint."""
    arm = ("ik", "so100", "--frame", "gripper:body")
    p = kinbox_cli(*arm, "--lock", "root_joint=0,0,0.1,0,0,0,1", "--from-q", "0.1,0.2,-0.3,0.4,0.5", "--json", "--quiet")
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["source"]["lock"] == {"root_joint": [0, 0, 0.1, 0, 0, 0, 1]}
    assert d["solutions"] and all(np.allclose(s["q"][:7], [0, 0, 0.1, 0, 0, 0, 1], atol=1e-12) for s in d["solutions"])
    assert_usage_error(kinbox_cli(*arm, "--lock", "root_joint=0,0,1", "--pose", 0, 0, 0.2, 0, 0, 0, 1), "root_joint")


def test_fewer_than_six_joints_say_what_the_answer_means():
    """so100's arm has five joints up to its gripper link: a pose over-determines them; the
    answer holds the configuration the pose came from (Pinocchio FK) and says, in the table
    and the JSON, why its solutions are checked but not certified."""
    args = ("ik", "so100", "--frame", "gripper:body", "--base", "base", "--from-q", "0.1,0.2,-0.3,0.4,0.5", "--quiet")
    p = kinbox_cli(*args, "--json")
    d = json.loads(p.stdout)
    assert any("over-determines" in n and "5 degree(s) of freedom" in n for n in d["notes"])
    t = kinbox_cli(*args)
    assert "note: 5 degree(s) of freedom" in t.stdout
    ur = json.loads(kinbox_cli("ik", "ur5", "--frame", "tool0", "--from-q", "0.3,-1.2,1.5,-0.8,1.2,0.4", "--json", "--quiet").stdout)
    assert not any("over-determines" in n for n in ur.get("notes", []))


# -- constraint systems: auto formulation, under-constrained systems -------------------------------
def _regular_simplex(n: int, edge: float = 1.0, plane: bool = False) -> dict:
    """``n`` free points, every pair at ``edge`` (a triangle, a tetrahedron); with ``plane``,
    the first three on the fixed plane z = 0."""
    import itertools

    pts = [f"p{i}" for i in range(1, n + 1)]
    ents: dict = {p: {"type": "point"} for p in pts}
    cons = [{"type": "distance", "entities": [a, b], "value": edge} for a, b in itertools.combinations(pts, 2)]
    if plane:
        ents["P"] = {"type": "plane", "fixed": {"point": [0, 0, 0], "normal": [0, 0, 1]}}
        cons += [{"type": "incident", "entities": [p, "P"]} for p in pts[:3]]
    out = {"kind": "constraints", "name": f"simplex{n}", "entities": ents, "constraints": cons}
    return out | ({"bounds": 5.0} if plane else {})


@pytest.mark.parametrize("n, shapes", [(3, 1), (4, 2)])
def test_auto_formulation_never_refuses(tmp_path, n, shapes):
    """Three free points with three distances, four with six: ``auto`` solves them (the
    distance formulation needs five points, so it is not picked); every pair of points of each
    assembly is at the given distance; a tetrahedron has two mirror images, a triangle one.
    ``--formulation distances`` asked for by name is still refused in one line."""
    path = tmp_path / "s.json"
    path.write_text(json.dumps(_regular_simplex(n, 1.5)))
    p = kinbox_cli("solve", path, "--json", "--quiet")
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["complete"] and d["formulation"] == "coordinates" and len(d["solutions"]) == shapes
    for s in d["solutions"]:
        X = np.array([s["entities"][f"p{i}"] for i in range(1, n + 1)])
        D = np.linalg.norm(X[:, None] - X[None], axis=2)
        assert np.allclose(D[np.triu_indices(n, 1)], 1.5, atol=1e-12)
    assert_usage_error(kinbox_cli("solve", path, "--formulation", "distances"), "five points")


def test_underconstrained_system_is_refused_at_once(tmp_path):
    """A tetrahedron with one face on a plane moves in that plane (3 degrees of freedom, as
    ``kinbox check`` counts): ``solve`` refuses it in one line naming the degrees of freedom
    and what to fix, before any search (no time limit needed to end it)."""
    path = tmp_path / "t.json"
    path.write_text(json.dumps(_regular_simplex(4, plane=True)))
    c = json.loads(kinbox_cli("check", path, "--json").stdout)
    assert c["dof"] == c["generic_dof"] == 3
    line = assert_usage_error(kinbox_cli("solve", path), "under-constrained", "3 degrees of freedom", "fix")
    assert "p4" in line
    # a triangle on the plane with one corner fixed turns about it: a curve, solved
    sys2 = _regular_simplex(3, plane=True)
    sys2["entities"]["p1"] = {"type": "point", "fixed": [0, 0, 0]}
    path.write_text(json.dumps(sys2))
    p = kinbox_cli("solve", path, "--json", "--quiet", "--time-limit", "120")
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert [c["dimension"] for c in d["components"] if c["dimension"] > 0]


# -- kinbox check on planar mechanisms ------------------------------------------------------------
def test_check_counts_planar_mechanisms_in_the_plane():
    """The four-bar and the 3-RPR move in a plane: counted there (a point closure is two
    conditions), the four-bar's mobility is 1 (0 with its crank set) and the 3-RPR's is 0, not
    negative; configurations met from several starts are counted once: the four-bar with its
    crank set has the two assemblies of the circle-intersection oracle, the 3-RPR at most its
    six assembly modes. Bricard's spatial loop is still counted in space."""
    from tests.support.oracles.planar import four_bar_assemblies

    ROBOTS = PATHS.ROBOTS
    fb = json.loads((ROBOTS / "four-bar.json").read_text())
    d = json.loads(kinbox_cli("check", "four-bar", "--json").stdout)
    assert d["planar"] and d["counted_mobility"] == 1 and set(d["mobility_at_solutions"]) == {"1"}
    d = json.loads(kinbox_cli("check", "four-bar", "--set", "crank=0.7", "--json").stdout)
    modes = len(four_bar_assemblies(fb["ground"], fb["crank"], fb["coupler"], fb["rocker"], 0.7))
    assert d["counted_mobility"] == 0 and d["distinct_configurations"] == modes == 2
    p = kinbox_cli("check", ROBOTS / "3-rpr.json")
    assert "in the plane" in p.stdout and "= 0" in p.stdout and "= -" not in p.stdout
    d = json.loads(kinbox_cli("check", ROBOTS / "3-rpr.json", "--json").stdout)
    assert d["counted_mobility"] == 0 and 1 <= d["distinct_configurations"] <= 6
    assert sum(d["mobility_at_solutions"].values()) == d["distinct_configurations"]
    d = json.loads(kinbox_cli("check", "bricard", "--json").stdout)
    assert not d["planar"] and d["counted_mobility"] == 0


# -- platform poses ---------------------------------------------------------------------------------
def _legs_hold(data: dict, x: np.ndarray, R: np.ndarray) -> float:
    """Largest |‖x + R b_i − a_i‖ − l_i| of a platform file's legs at the platform pose (x, R)."""
    A = np.array(data["base_points"], float)
    B = np.array(data["platform_points"], float)
    if A.shape[1] == 2:
        A, B = np.c_[A, np.zeros(len(A))], np.c_[B, np.zeros(len(B))]
    L = np.array(data["leg_lengths"], float)
    return float(np.max(np.abs(np.linalg.norm(x + B @ R.T - A, axis=1) - L)))


def test_platforms_answer_with_the_platform_pose():
    """The 3-RPR's six assembly modes come with the platform's (x, y, phi), the Stewart
    platform's with its position and quaternion, in the JSON and the table: every leg of the
    file has its length at that pose (the file's anchor points, no kinbox code)."""
    ROBOTS = PATHS.ROBOTS
    rpr = json.loads((ROBOTS / "3-rpr.json").read_text())
    p = kinbox_cli("solve", ROBOTS / "3-rpr.json", "--json", "--quiet")
    d = json.loads(p.stdout)
    assert d["complete"] and len(d["solutions"]) == 6
    for s in d["solutions"]:
        x, y, phi = s["platform"]["planar"]
        R = np.array([[np.cos(phi), -np.sin(phi), 0], [np.sin(phi), np.cos(phi), 0], [0, 0, 1]])
        assert _legs_hold(rpr, np.array([x, y, 0.0]), R) < 1e-9
        M = pin.XYZQUATToSE3(np.array(s["platform"]["pose"]))
        assert np.allclose(M.rotation, R, atol=1e-12) and np.allclose(M.translation, [x, y, 0], atol=1e-12)
    t = kinbox_cli("solve", ROBOTS / "3-rpr.json", "--quiet").stdout
    assert "platform pose (frame 'platform'" in t and "x y phi" in t
    # the Stewart platform's pose at a configuration whose leg lengths are measured from it
    from kinbox.answer.platform import platform_poses
    from kinbox.model.loading import load

    dm = json.loads((ROBOTS / "dietmeier.json").read_text())
    mech = load("dietmeier")
    goal = pin.SE3(pin.rpy.rpyToMatrix(0.3, -0.2, 0.5), np.array([0.9, 0.2, -0.1]))
    A, B = np.array(dm["base_points"], float), np.array(dm["platform_points"], float)
    dm["leg_lengths"] = list(np.linalg.norm(goal.translation + B @ goal.rotation.T - A, axis=1))
    q = pin.neutral(mech.model)
    q[:7] = pin.SE3ToXYZQUAT(goal)
    (pose,) = platform_poses(mech, [q])
    M = pin.XYZQUATToSE3(np.array(pose["pose"]))
    assert "planar" not in pose and M.isApprox(goal, 1e-12)
    assert _legs_hold(dm, M.translation, M.rotation) < 1e-12


# -- joint ranges wider than a turn -------------------------------------------------------------------
def test_joints_wider_than_a_turn_list_their_copies():
    """A UR5 of example-robot-data has five joints of range +-2 pi: each of its 8 solutions
    stands for every q + 2 pi k within the limits, counted independently here; the answer names
    those joints and the count, and --all-turns lists them all, each inside the limits and
    placing the tool at the goal (Pinocchio FK), none twice."""
    q0 = [0.3, -1.2, 1.5, -0.8, 1.2, 0.4]
    args = ("ik", "ur5", "--frame", "tool0", "--from-q", ",".join(map(str, q0)), "--json", "--quiet")
    d = json.loads(kinbox_cli(*args).stdout)
    m = ur5_model()
    lo, hi = m.lowerPositionLimit, m.upperPositionLimit
    wide = [i for i in range(6) if hi[i] - lo[i] > 2 * np.pi + 1e-9]
    assert sorted(d["stats"]["wrapping_joints"]) == sorted(m.names[i + 1] for i in wide)
    count = 0
    for s in d["solutions"]:
        q = np.array(s["q"])
        assert np.all(q >= lo - 1e-12) and np.all(q <= hi + 1e-12)
        count += int(np.prod([sum(1 for k in range(-3, 4) if lo[i] <= q[i] + 2 * np.pi * k <= hi[i]) for i in wide]))
    assert d["stats"]["configurations_within_limits"] == count > len(d["solutions"]) == 8
    assert any("wider than a turn" in n for n in d["notes"])
    a = json.loads(kinbox_cli(*args, "--all-turns").stdout)
    assert len(a["solutions"]) == count
    goal = tool0(q0)
    Q = np.array([s["q"] for s in a["solutions"]])
    assert np.all(Q >= lo - 1e-12) and np.all(Q <= hi + 1e-12)
    assert min(np.linalg.norm(Q[i] - Q[j]) for i in range(len(Q)) for j in range(i)) > 1e-3
    for q in Q[:: max(1, len(Q) // 40)]:
        M = tool0(q)
        assert np.linalg.norm(M.translation - goal.translation) < 1e-9 and np.linalg.norm(pin.log3(M.rotation.T @ goal.rotation)) < 1e-9


def test_a_range_wider_than_a_turn_off_centre_keeps_solutions_inside():
    """A UR5 whose wrist_3 range is [0.5, 7.2] (wider than a turn, not around 0): the solution
    listed by default for that joint is inside the limits, not the copy in (-pi, pi]."""
    import kinbox
    from kinbox.model.loading import load

    mech = load("ur5")
    j = mech.model.joints[mech.model.getJointId("wrist_3_joint")]
    mech.model.lowerPositionLimit[j.idx_q], mech.model.upperPositionLimit[j.idx_q] = 0.5, 7.2
    ik = kinbox.IK(mech, "tool0")
    res = ik.solve(ik.pose_at([0.3, -1.2, 1.5, -0.8, 1.2, -0.4]))
    assert len(res.solutions) == 8
    for s in res.solutions:
        assert 0.5 <= s.q[j.idx_q] <= 7.2 and s.residual < 1e-9


# -- replay pages of incomplete answers ------------------------------------------------------------
def test_an_incomplete_answer_s_page_says_so(tmp_path):
    """A search stopped by its box budget (the four-bar, --max-boxes 2): the replay page's
    label says INCOMPLETE with the reason; a complete answer's title does not."""
    from kinbox.viz.scene import prepare

    p = kinbox_cli("solve", "four-bar", "--set", "crank=0.7", "--json", "--quiet", "--max-boxes", "2")
    assert json.loads(p.stdout)["complete"] is False
    path, out = tmp_path / "r.json", tmp_path / "r.html"
    path.write_text(p.stdout)
    r = kinbox_cli("replay", path, "--html", out)
    assert r.returncode == 0, r.stderr
    assert "INCOMPLETE (box budget of 2 reached)" in out.read_text()
    done = json.loads(kinbox_cli("solve", "four-bar", "--set", "crank=0.7", "--json", "--quiet").stdout)
    assert done["complete"] and "INCOMPLETE" not in prepare(done).title


# -- residuals of constraint systems --------------------------------------------------------------------
def test_assembly_residuals_print_in_units():
    """The table of a constraint system says what its residual is (a constraint's deviation:
    a length or an angle) and prints one below the rounding of the coordinates as 0, not as a
    meaningless 1e-34; the JSON keeps the number."""
    from kinbox.answer.assembly import Assembly, _residual_text
    from kinbox.formulation.geometry import Placement
    from kinbox.search.status import BoxStatus

    line = Placement("line", np.array([0.0, 0.3, 1.0]), np.array([1.0, 0.0, 0.0]))
    assert _residual_text(Assembly({"L": line}, {}, BoxStatus.CERTIFIED, 1.3e-34)) == "0"
    assert _residual_text(Assembly({"L": line}, {}, BoxStatus.CERTIFIED, 2.5e-9)) == "2.5e-09"
    t = kinbox_cli("solve", "tangent-lines", "--quiet").stdout
    assert "residual: the largest deviation of a constraint" in t and "radians" in t
    import re

    for r in re.findall(r", residual (\S+)", t):
        assert r == "0" or float(r) > 1e-15


# -- the first run after an install ------------------------------------------------------------------
def test_a_cold_kernel_cache_is_told(tmp_path):
    """With an empty numba cache (a fresh install) kinbox can tell that its first solve will
    compile (the command then says so on a terminal); reading the cache compiles nothing."""
    import os
    import subprocess
    import sys

    code = "from kinbox.search.loading import kernels_cached; print(kernels_cached())"
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip() == "False"
    assert not list(tmp_path.rglob("*.nbc"))
