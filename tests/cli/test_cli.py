"""End-to-end tests of the ``kinbox`` command line: ``kinbox.cli.main`` in this process (a new
interpreter per call cost most of this file's time), and once as a subprocess
(``python -m kinbox.cli``), where nothing but the JSON may reach stdout.

Outputs are checked against independent references: UR configurations with Pinocchio forward
kinematics on the example-robot-data model and the closed-form UR oracle, the four-bar with the
circle-intersection oracle, the general 6R loop with the published count. Bad input must end
with exit status 2 and exactly one line ``kinbox: error: ...`` on stderr (no traceback).
"""

from __future__ import annotations

import gc
import io
import json
import math
import os
import re
import subprocess
import sys
import time

import numpy as np
import pinocchio as pin
import pytest

from tests.support import paths as PATHS
from tests.support.cli import assert_usage_error, kinbox_cli, kinbox_process, pose_error, tool0
from tests.support.oracles.planar import four_bar_assemblies, four_bar_relative_angles
from tests.support.oracles.ur_ik import same_mod_2pi, ur_ik

ROBOTS = PATHS.ROBOTS
REFERENCE = PATHS.DATA / "reference"
README_Q = [0.3, -1.2, 1.5, -0.8, 1.2, 0.4]


# ----------------------------------------------------------------------------------------------
# kinbox ik
# ----------------------------------------------------------------------------------------------
BLAS_THREADS = """
import sys
from kinbox.cli import command
assert "numpy" not in sys.modules  # else OPENBLAS_NUM_THREADS would come too late
sys.argv = ["kinbox", "info", "ur5"]
code = command()
from threadpoolctl import threadpool_info
print(code, sorted({p["num_threads"] for p in threadpool_info() if p["internal_api"] == "openblas"}))
"""


@pytest.mark.parametrize("given, threads", [(None, "[1]"), ("2", "[2]")])
def test_the_program_starts_openblas_with_one_thread_unless_told(given, threads):
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    if given is not None:
        env["OPENBLAS_NUM_THREADS"] = given
    p = subprocess.run([sys.executable, "-c", BLAS_THREADS], capture_output=True, text=True, env=env, timeout=120)
    assert p.returncode == 0, p.stderr
    assert p.stdout.split("\n")[-2] == f"0 {threads}"


def test_a_time_limit_leaves_out_loading_the_kernels(monkeypatch):
    """The first run after an install compiles the kernels (tens of seconds): ``--time-limit``
    does not count it. Here compiling them takes 1.5 s, longer than the limit."""
    import kinbox.pipeline

    load = kinbox.pipeline.load_kernels

    def slow_compile():
        load()
        time.sleep(1.5)

    monkeypatch.setattr(kinbox.pipeline, "compile_kernels", slow_compile)
    p = kinbox_cli("ik", "ur5", "--frame", "tool0", "--from-q", ",".join(map(str, README_Q)), "--time-limit", 1.0, "--json")
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["complete"] is True and len(d["solutions"]) == 8


def test_the_program_exits_with_main_s_status_after_its_quick_shutdown():
    """``kinbox`` (:func:`kinbox.cli.command`) freezes the collector before Python's shutdown:
    the status and the one-line error must be main's, and a caller of ``main`` keeps its
    collector as it was."""
    p = kinbox_process("ik", "ur5", "--frame", "no_such_frame", "--from-q", ",".join(map(str, README_Q)))
    assert p.returncode == 2 and "Traceback" not in p.stderr
    assert p.stderr.strip().count("\n") == 0 and "no_such_frame" in p.stderr
    frozen = gc.get_freeze_count()
    assert kinbox_cli("ik", "ur5", "--frame", "no_such_frame", "--from-q", ",".join(map(str, README_Q))).returncode == 2
    assert gc.get_freeze_count() == frozen


def test_ik_json():
    p = kinbox_process("ik", "ur5", "--frame", "tool0", "--from-q", ",".join(map(str, README_Q)), "--json", "--time-limit", 300, "--quiet")
    assert p.returncode == 0, p.stderr
    assert "Traceback" not in p.stderr
    d = json.loads(p.stdout)
    for key in ("problem", "joint_names", "complete", "solutions", "components", "stats"):
        assert key in d, key
    assert d["complete"] is True, d.get("message")
    assert d["joint_names"] == [
        "shoulder_pan_joint",
        "shoulder_lift_joint",
        "elbow_joint",
        "wrist_1_joint",
        "wrist_2_joint",
        "wrist_3_joint",
    ]
    for key in ("boxes", "empty", "split", "lps", "seconds", "variables", "equations", "dropped_joints"):
        assert key in d["stats"], key
    st = d["stats"]
    assert st["boxes"] >= st["empty"] + st["split"] and st["seconds"] >= 0 and st["dropped_joints"] == []
    assert isinstance(d["components"], list)
    for c in d["components"]:
        assert {"dimension", "boxes"} <= set(c) and c["dimension"] >= 0 and c["boxes"] >= 1
    goal = tool0(README_Q)
    ref = ur_ik("ur5", goal.homogeneous)
    sols = d["solutions"]
    assert len(sols) == len(ref) == 8
    for s in sols:
        assert set(s) >= {"q", "residual", "certified", "width"}
        assert len(s["q"]) == 6 and s["certified"] is True
        assert isinstance(s["residual"], float) and isinstance(s["width"], float)
        assert pose_error(tool0(s["q"]), goal) < 1e-10  # checked here, not s["residual"]
        assert sum(same_mod_2pi(s["q"], r, 1e-7) for r in ref) == 1
    assert any(same_mod_2pi(s["q"], README_Q, 1e-7) for s in sols)


_ROW = re.compile(r"^\s*(\d+)\s+(yes|no)\s+(\S+)\s+(.*)$")


def _table_rows(text: str) -> list[list[float]]:
    rows = []
    for line in text.splitlines():
        m = _ROW.match(line)
        if m:
            rows.append([float(v) for v in m.group(4).split()])
    return rows


def test_ik_table():
    q = [1.0, -0.3, 0.4, 1.2, 2.0, -0.5]
    p = kinbox_cli("ik", "ur5", "--frame", "tool0", "--from-q", " ".join(map(str, q)), "--time-limit", 300)
    assert p.returncode == 0, p.stderr
    out = p.stdout
    assert not out.lstrip().startswith("{")
    first = out.splitlines()[0]
    goal = tool0(q)
    n = len(ur_ik("ur5", goal.homogeneous))
    assert f"{n} isolated solution(s)" in first and "complete" in first and "INCOMPLETE" not in first, first
    assert "shoulder_p" in out  # joint names head the columns
    rows = _table_rows(out)
    assert len(rows) == n
    for r in rows:  # 6 printed decimals: the pose to ~1e-5
        assert len(r) == 6
        assert pose_error(tool0(r), goal) < 1e-4
    assert any(same_mod_2pi(r, q, 1e-5) for r in rows)


def test_ik_unreachable_pose():
    p = kinbox_cli("ik", "ur5", "--frame", "tool0", "--pose", 10, 0, 0, 0, 0, 0, 1, "--json", "--time-limit", 60)
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["complete"] is True and d["solutions"] == [] and d["components"] == []


@pytest.mark.parametrize("extra", [[], ["--formulation", "general"]], ids=["arm", "general"])
def test_ik_poses_file_json_lines(tmp_path, extra):
    goal = tool0(README_Q)
    f = tmp_path / "poses.txt"
    xyzquat = ", ".join(f"{v:.17g}" for v in pin.SE3ToXYZQUAT(goal))
    f.write_text(f"# a reachable pose, then an unreachable one\n{xyzquat}\n\n10 0 0 0 0 0 1  # too far\n")
    p = kinbox_cli("ik", "ur5", "--frame", "tool0", "--poses", f, "--json", "--time-limit", 300, *extra)
    assert p.returncode == 0, p.stderr
    first, second = [json.loads(line) for line in p.stdout.splitlines()]
    assert (first["line"], second["line"]) == (2, 4)
    want = ur_ik("ur5", goal.homogeneous)
    assert first["complete"] and len(first["solutions"]) == len(want) == 8
    assert any(same_mod_2pi(s["q"], README_Q) for s in first["solutions"])
    for s in first["solutions"]:
        assert pose_error(tool0(s["q"]), goal) < 1e-10
    assert second["complete"] is True and second["solutions"] == []


def test_error_poses_file_without_pose(tmp_path):
    f = tmp_path / "poses.txt"
    f.write_text("# nothing\n\n")
    assert_usage_error(kinbox_cli("ik", "ur5", "--frame", "tool0", "--poses", f), "no pose")


def test_poses_file_bad_lines_get_error_records(tmp_path):
    """A bad line costs only its own answer: an error record for it, every other line answered
    (and right), exit status 5, one line on stderr naming the first bad line."""
    goal = tool0(README_Q)
    xyzquat = " ".join(f"{v:.17g}" for v in pin.SE3ToXYZQUAT(goal))
    f = tmp_path / "poses.txt"
    f.write_text(f"0.3 0.2 0.4 0 1 0\n{xyzquat}\n0.3 0.2 x 0 1 0 0\n")
    p = kinbox_cli("ik", "ur5", "--frame", "tool0", "--poses", f, "--json", "--time-limit", 300)
    assert p.returncode == 5, p.stderr
    first, second, third = [json.loads(line) for line in p.stdout.splitlines()]
    assert first["line"] == 1 and "7 numbers" in first["error"] and set(first) == {"line", "error"}
    assert third["line"] == 3 and "not a list of numbers" in third["error"]
    assert second["line"] == 2 and second["complete"] and len(second["solutions"]) == 8
    for s in second["solutions"]:
        assert pose_error(tool0(s["q"]), goal) < 1e-10
    lines = p.stderr.splitlines()
    assert len(lines) == 1 and "2 of 3 lines" in lines[0] and "line 1" in lines[0] and "exit status 5" in lines[0]


def _without_times(record: dict) -> dict:
    for k in ("seconds", "cpu_seconds", "load_seconds"):
        record.get("stats", {}).pop(k, None)
    return record


def test_poses_over_workers_equal_serial(tmp_path):
    """``--poses --workers 2`` spreads the poses over two processes: the same records (each pose
    solved as alone, box for box), in the order of the file, error records included."""
    qs = [README_Q, [-1.0, -0.5, 2.0, 0.3, -1.0, 2.0], [2.0, 0.7, -1.1, 0.2, 0.5, -2.5], [0.1, 0.2, 0.3, 0.4, 0.5, 0.6]]
    rows = [" ".join(f"{v:.17g}" for v in pin.SE3ToXYZQUAT(tool0(q))) for q in qs]
    f = tmp_path / "poses.txt"
    f.write_text("\n".join([rows[0], rows[1], "1 2 3", rows[2], "10 0 0 0 0 0 1", rows[3]]) + "\n")
    base = ("ik", "ur5", "--frame", "tool0", "--poses", f, "--json", "--quiet", "--time-limit", 300)
    serial, spread = kinbox_cli(*base), kinbox_cli(*base, "--workers", 2)
    assert serial.returncode == spread.returncode == 5, (serial.stderr, spread.stderr)
    a = [_without_times(json.loads(line)) for line in serial.stdout.splitlines()]
    b = [_without_times(json.loads(line)) for line in spread.stdout.splitlines()]
    assert [r["line"] for r in b] == [1, 2, 3, 4, 5, 6]
    assert a == b
    assert [len(r.get("solutions", [])) for r in b] == [8, 8, 0, 8, 0, 8]
    assert spread.stderr == serial.stderr


def test_error_poses_file_missing(tmp_path):
    assert_usage_error(kinbox_cli("ik", "ur5", "--frame", "tool0", "--poses", tmp_path / "nope.txt"), "nope.txt")


def test_ik_lock_json():
    """``--lock`` holds the joint: every solution keeps it, and verifies by FK."""
    import example_robot_data as erd

    m = erd.load("panda").model
    q = pin.neutral(m)
    q[:7] = [0.1, -0.4, 0.2, -2.1, 0.1, 1.7, 0.5]
    data = m.createData()
    pin.forwardKinematics(m, data, q)
    goal = pin.SE3(pin.updateFramePlacement(m, data, m.getFrameId("panda_hand")))
    pose = pin.SE3ToXYZQUAT(goal)
    p = kinbox_cli("ik", "panda", "--frame", "panda_hand", "--lock", "panda_joint7=0.5", "--pose", *pose, "--json", "--time-limit", 300)
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["complete"] is True and d["solutions"]
    for s in d["solutions"]:
        qs = np.array(s["q"])
        assert qs[6] == pytest.approx(0.5, abs=1e-12)
        pin.forwardKinematics(m, data, qs)
        assert pose_error(pin.SE3(pin.updateFramePlacement(m, data, m.getFrameId("panda_hand"))), goal) < 1e-10
    assert any(np.max(np.abs(np.array(s["q"])[:7] - q[:7])) < 1e-7 for s in d["solutions"])


# ----------------------------------------------------------------------------------------------
# kinbox solve / list
# ----------------------------------------------------------------------------------------------
def test_solve_four_bar_set_crank():
    fb = json.loads((ROBOTS / "four-bar.json").read_text())
    angle = 0.7
    p = kinbox_cli("solve", "four-bar", "--set", f"crank={angle}", "--json", "--time-limit", 60)
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["complete"] is True
    ref = four_bar_assemblies(fb["ground"], fb["crank"], fb["coupler"], fb["rocker"], angle)
    assert len(d["solutions"]) == len(ref) == 2
    names = d["joint_names"]
    got = sorted(tuple(s["q"][names.index(n)] for n in ("crank", "coupler", "rocker")) for s in d["solutions"])
    want = sorted(four_bar_relative_angles(angle, a) for a in ref)
    for g, w in zip(got, want):
        assert max(abs(math.remainder(a - b, 2 * math.pi)) for a, b in zip(g, w)) < 1e-9, (got, want)


def test_solve_four_bar_table():
    p = kinbox_cli("solve", "four-bar", "--set", "crank=0.7", "--time-limit", 60)
    assert p.returncode == 0, p.stderr
    assert p.stdout.splitlines()[0].startswith("solve four-bar: 2 isolated solution(s)")
    assert len(_table_rows(p.stdout)) == 2


def test_solve_general_6r_table():
    expected = json.loads((REFERENCE / "general_6r.json").read_text())["expected"]["real_solutions"]
    p = kinbox_cli("solve", "general-6r", "--time-limit", 120)
    assert p.returncode == 0, p.stderr
    first = p.stdout.splitlines()[0]
    assert f"{expected} isolated solution(s)" in first and "INCOMPLETE" not in first, first
    rows = _table_rows(p.stdout)
    assert len(rows) == expected and all(len(r) == 6 for r in rows)


@pytest.mark.parametrize("legs", ["squared", "vector"])
def test_solve_3rpr_legs(legs):
    """Both leg formulations give the 6 assembly modes of the built-in 3-RPR (sextic oracle in
    test_linkage)."""
    p = kinbox_cli("solve", "3-rpr", "--legs", legs, "--json", "--time-limit", 120)
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["complete"] and len(d["solutions"]) == 6 and all(s["certified"] for s in d["solutions"])


def test_budget_hint_only_for_mobile_platforms():
    """A budget hit on a mobile platform (Griffis-Duffy: curves of configurations) suggests the
    vector form of the legs when the squared form was used; on a rigid one (Dietmeier: 40 isolated
    assembly modes) it does not, nor where ``--legs auto`` (the default) already chose the vectors.
    All exit with status 4, the whole answer on stdout and one line on stderr."""
    for name, legs, hint in (("griffis-duffy", "squared", True), ("griffis-duffy", "auto", False), ("dietmeier", "auto", False)):
        p = kinbox_cli("solve", name, "--legs", legs, "--max-boxes", 300, "--json")
        assert p.returncode == 4, p.stderr
        d = json.loads(p.stdout)
        assert d["complete"] is False and ("legs='vector'" in d["message"]) == hint, (name, legs, d["message"])
        lines = p.stderr.splitlines()
        assert len(lines) == 1 and lines[0].startswith("kinbox: incomplete answer") and "exit status 4" in lines[0]


def test_solve_unassemblable_stewart(tmp_path):
    spec = json.loads((ROBOTS / "dietmeier.json").read_text())
    spec["leg_lengths"] = [10 * v for v in spec["leg_lengths"]]
    f = tmp_path / "too-long.json"
    f.write_text(json.dumps(spec))
    p = kinbox_cli("solve", f, "--json", "--time-limit", 120)
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["complete"] is True and d["solutions"] == [] and d["components"] == []


def test_list():
    p = kinbox_cli("list", timeout=120)
    assert p.returncode == 0, p.stderr
    words = set(p.stdout.split())
    for name in ("general-6r", "dietmeier", "griffis-duffy", "bricard", "four-bar", "3-rpr", "ur5", "panda"):
        assert name in words, name


# ----------------------------------------------------------------------------------------------
# errors: exit 2, one line
# ----------------------------------------------------------------------------------------------
POSE = ["--pose", "0.3", "0.2", "0.4", "0", "0", "0", "1"]


def test_error_unknown_robot():
    assert_usage_error(kinbox_cli("ik", "no_such_robot_xyz", "--frame", "tool0", *POSE), "no_such_robot_xyz")


def test_error_unknown_frame():
    assert_usage_error(kinbox_cli("ik", "ur5", "--frame", "no_such_frame", *POSE), "no_such_frame")


def test_error_unknown_base():
    assert_usage_error(kinbox_cli("ik", "ur5", "--frame", "tool0", "--base", "no_such_base", *POSE), "no_such_base")


BROKEN_URDFS = {
    "truncated": '<?xml version="1.0"?>\n<robot name="broken">\n  <link name="a"/>\n  <joint name="j" type="revolute">\n',
    "no_parent_link": """<?xml version="1.0"?>
<robot name="broken">
  <link name="a"/>
  <joint name="j" type="revolute">
    <parent link="missing"/><child link="a"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
</robot>
""",
    "not_xml": "this is not a robot\n",
}


@pytest.mark.parametrize("kind", sorted(BROKEN_URDFS))
def test_error_malformed_urdf(tmp_path, kind):
    f = tmp_path / f"{kind}.urdf"
    f.write_text(BROKEN_URDFS[kind])
    assert_usage_error(kinbox_cli("ik", f, "--frame", "a", *POSE), f.name)


@pytest.mark.parametrize("bad", ["nan", "inf"])
def test_error_non_finite_pose(bad):
    assert_usage_error(kinbox_cli("ik", "ur5", "--frame", "tool0", "--pose", "0.3", bad, "0.4", "0", "0", "0", "1"))


def test_error_non_number_pose():
    assert_usage_error(kinbox_cli("ik", "ur5", "--frame", "tool0", "--pose", "0.3", "abc", "0.4", "0", "0", "0", "1"))


def test_error_non_unit_quaternion():
    assert_usage_error(kinbox_cli("ik", "ur5", "--frame", "tool0", "--pose", "0.3", "0.2", "0.4", "0", "0", "0", "2"), "quaternion")


@pytest.mark.parametrize("values", ["0.1,0.2", "0.1,0.2,0.3,0.4,0.5,0.6,0.7", "0.1,nan,0.3,0.4,0.5,0.6", "a,b"])
def test_error_from_q(values):
    assert_usage_error(kinbox_cli("ik", "ur5", "--frame", "tool0", "--from-q", values))


def test_error_lock_unknown_joint():
    assert_usage_error(kinbox_cli("ik", "panda", "--frame", "panda_hand", "--lock", "panda_joint99=0.3", *POSE), "panda_joint99")


@pytest.mark.parametrize("lock", ["panda_joint7", "panda_joint7=abc", "=0.3"])
def test_error_malformed_lock(lock):
    assert_usage_error(kinbox_cli("ik", "panda", "--frame", "panda_hand", "--lock", lock, *POSE))


@pytest.mark.parametrize(
    "text",
    [
        "{not json",
        "[1, 2, 3]",
        '{"kind": "no-such-kind"}',
        '{"kind": "four-bar", "ground": 3, "crank": 1, "coupler": 3}',
        '{"kind": "four-bar", "ground": NaN, "crank": 1, "coupler": 3, "rocker": 2}',
    ],
)
def test_error_solve_file_that_does_not_parse(tmp_path, text):
    f = tmp_path / "bad.json"
    f.write_text(text)
    assert_usage_error(kinbox_cli("solve", f), "bad.json")


def test_error_solve_missing_file(tmp_path):
    assert_usage_error(kinbox_cli("solve", tmp_path / "nothing-here.json"))


def test_error_solve_without_loop_or_goal():
    assert_usage_error(kinbox_cli("solve", "ur5"), "no loop")


def test_error_solve_urdf_without_loop(tmp_path):
    f = tmp_path / "arm.urdf"
    f.write_text("""<?xml version="1.0"?>
<robot name="arm">
  <link name="base"/><link name="l1"/>
  <joint name="j1" type="revolute">
    <parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
</robot>
""")
    assert_usage_error(kinbox_cli("solve", f), "no loop")


def test_error_set_unknown_joint():
    assert_usage_error(kinbox_cli("solve", "four-bar", "--set", "no_such_joint=0.3"), "no_such_joint")


@pytest.mark.parametrize("setting", ["crank", "crank=abc", "crank=nan"])
def test_error_malformed_set(setting):
    assert_usage_error(kinbox_cli("solve", "four-bar", "--set", setting))


def test_error_bad_sigma():
    assert_usage_error(kinbox_cli("solve", "four-bar", "--set", "crank=0.7", "--sigma", "-1"), "sigma")


def test_ambiguous_frame_name_is_not_an_internal_error():
    """z1 has two frames named ``gripperStator`` (a FIXED_JOINT and a BODY frame on the same
    joint): kinbox must solve for it or refuse it as bad input (exit 2), not crash (exit 3)."""
    p = kinbox_cli("ik", "z1", "--frame", "gripperStator", "--pose", 10, 0, 0, 0, 0, 0, 1, "--json", "--time-limit", 60)
    if p.returncode == 0:
        d = json.loads(p.stdout)
        assert d["complete"] is True and d["solutions"] == []
    else:
        assert_usage_error(p, "gripperStator")


def test_curve_boxes_are_on_by_default_and_can_be_switched_off():
    """The four-bar's curves: with curve boxes (the default) fewer boxes than with
    --no-curve-boxes, where every box is split down to sigma; the same two curves."""
    runs = {}
    for flag in ([], ["--no-curve-boxes"]):
        p = kinbox_cli("solve", "four-bar", "--sigma", "0.1", "--json", *flag)
        assert p.returncode == 0, p.stderr
        d = json.loads(p.stdout)
        assert d["complete"] and [c["dimension"] for c in d["components"]] == [1, 1]
        runs[" ".join(flag)] = d["stats"]["boxes"]
    assert runs[""] < runs["--no-curve-boxes"]


def test_a_poses_line_is_written_whole_through_signals_on_a_full_pipe(monkeypatch):
    """A long line to a pipe whose reader is slow, with a signal handler (one that returns, as
    the first Ctrl-C's does) run many times while the write is blocked: every byte arrives, in
    order. Without a file descriptor (captured output) the line goes through print."""
    import signal
    import threading
    import time

    from kinbox.cli import _print_whole

    r, w = os.pipe()
    out = os.fdopen(w, "w")
    monkeypatch.setattr(sys, "stdout", out)
    got: list[bytes] = []

    def reader():
        time.sleep(0.2)  # the pipe fills and the write blocks
        with os.fdopen(r, "rb") as f:
            while chunk := f.read(4096):
                got.append(chunk)
                time.sleep(0.0005)

    t = threading.Thread(target=reader)
    t.start()
    hits = [0]
    old = signal.signal(signal.SIGALRM, lambda s, f: hits.__setitem__(0, hits[0] + 1))
    signal.setitimer(signal.ITIMER_REAL, 0.01, 0.003)
    text = "".join(f'{{"x": {i}}},' for i in range(40000))
    try:
        _print_whole(text)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0, 0)
        signal.signal(signal.SIGALRM, old)
        out.close()
    t.join()
    assert hits[0] > 10  # the handler ran during the write
    assert b"".join(got).decode() == text + "\n"
    captured = io.StringIO()
    monkeypatch.setattr(sys, "stdout", captured)
    _print_whole('{"line": 1}')
    assert captured.getvalue() == '{"line": 1}\n'


def test_cli_choices_are_the_library_s():
    """The command line offers exactly the names the library takes, drawn from it
    (kinbox.problems.choices, kinbox.search.options), and the library refuses any other."""
    import argparse

    import kinbox
    from kinbox.cli import _parser
    from kinbox.formulation.build import LEGS
    from kinbox.problems.choices import ARM_FORMULATIONS, CONSTRAINT_FORMULATIONS, MECHANISM_FORMULATIONS
    from kinbox.search.options import choices

    sub = next(a for a in _parser()._actions if isinstance(a, argparse._SubParsersAction))

    def offered(cmd: str, dest: str) -> set:
        return set(next(a for a in sub.choices[cmd]._actions if a.dest == dest).choices)

    assert offered("ik", "formulation") == set(ARM_FORMULATIONS)
    assert offered("solve", "legs") == set(LEGS)
    assert offered("solve", "formulation") == set(MECHANISM_FORMULATIONS) | set(CONSTRAINT_FORMULATIONS)
    assert offered("ik", "relaxation") == offered("solve", "relaxation") == set(choices("relaxation"))
    with pytest.raises(kinbox.InputError, match="auto, invariants, arm, general"):
        kinbox.IK("ur5", "tool0", formulation="invariant")
    with pytest.raises(kinbox.InputError, match="auto, planar, general"):
        kinbox.solve("four-bar", formulation="coordinates")


def test_cli_commands_are_the_library_s():
    """The command line's commands and their arguments are the library's declarations
    (kinbox.problems.commands.COMMANDS), each with a handler; a command that searches takes
    every search option."""
    import argparse

    from kinbox.cli import _HANDLERS, SEARCHES, _parser
    from kinbox.problems.commands import COMMANDS, SEARCH_ARGS

    sub = next(a for a in _parser()._actions if isinstance(a, argparse._SubParsersAction))
    assert list(sub.choices) == [c.name for c in COMMANDS]
    assert set(_HANDLERS) | set(SEARCHES) == set(sub.choices) and not set(_HANDLERS) & set(SEARCHES)
    for c in COMMANDS:
        offered = {s for a in sub.choices[c.name]._actions for s in (a.option_strings or [a.dest])}
        declared = {f for a in c.args for f in a.flags} | {"--no-" + f[2:] for a in c.args if a.negatable for f in a.flags}
        assert offered - {"-h", "--help"} == declared, c.name
    for name in SEARCHES:
        taken = {f for a in next(c for c in COMMANDS if c.name == name).args for f in a.flags}
        assert {f for a in SEARCH_ARGS for f in a.flags} <= taken
