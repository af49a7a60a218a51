"""Hostile input: what a careless or malicious user gives kinbox, generated here class by class
(huge and tiny numbers, huge models, special files, forged archives, recursive files, broken
numbers on the command line, unsafe save folders, oversized results).

Every refusal asserts the exit status, exactly one line ``kinbox: error: ...`` on stderr,
nothing on stdout, and bounds on time and memory: in this process (``kinbox.cli.main``) the
time is bounded by the suite's timeout; the cases that once crashed or exhausted memory run
in a child process under ``RLIMIT_AS`` and a subprocess timeout. The default suite runs a
small sample of each generator; ``@pytest.mark.slow`` runs them at the sizes that once broke
kinbox.
"""

from __future__ import annotations

import io
import json
import os
import resource
import subprocess
import sys
import textwrap
import time
import zipfile

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from kinbox.cli import EXIT_OUTPUT, main
from kinbox.errors import MAX_ENTITIES, MAX_LINKS, MAX_MODEL_DOF

POSE_FAR = ["--pose", "1e308", "1e308", "1e308", "0", "0", "0", "1"]
IK = ["ik", "ur5", "--frame", "tool0"]
POSE = ["--pose", "0.3", "0.2", "0.4", "0", "1", "0", "0"]


def run(capsys, args) -> tuple[int, str, str]:
    capsys.readouterr()
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def refused(capsys, args, *words: str, code: int = 2, seconds: float = 60.0) -> str:
    """Exit ``code``, one stderr line ``kinbox: error: ...`` naming ``words``, nothing on
    stdout. (``seconds``: documents the case's bound; time is bounded by the suite's timeout in
    this process, by a subprocess timeout in :func:`child`, not measured here.)"""
    got, out, err = run(capsys, args)
    lines = err.splitlines()
    assert got == code, (got, err)
    assert len(lines) == 1 and lines[0].startswith("kinbox: error:"), err
    for w in words:
        assert w.lower() in lines[0].lower(), (w, lines[0])
    assert out == ""
    return lines[0]


def child(args, timeout: float = 120, memory_gb: float = 1.5, stdout=subprocess.PIPE, cwd=None) -> subprocess.CompletedProcess:
    """``kinbox ARGS`` in a child process limited to ``memory_gb`` of address space."""

    def limit():
        n = int(memory_gb * 2**30)
        resource.setrlimit(resource.RLIMIT_AS, (n, n))

    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    code = "import sys; from kinbox.cli import command; sys.exit(command())"
    return subprocess.run(
        [sys.executable, "-c", code, *map(str, args)],
        stdout=stdout,
        stderr=subprocess.PIPE,
        text=True,
        timeout=timeout,
        preexec_fn=limit,
        env=env,
        cwd=cwd,
    )


def child_refused(args, *words: str, **kw) -> str:
    p = child(args, **kw)
    lines = p.stderr.splitlines()
    assert p.returncode == 2, (p.returncode, p.stderr[-2000:])
    assert len(lines) == 1 and lines[0].startswith("kinbox: error:"), p.stderr[-2000:]
    for w in words:
        assert w.lower() in lines[0].lower(), (w, lines[0])
    assert p.stdout == ""
    return lines[0]


def urdf_chain(n: int, joint: str = "fixed", origin: str = "0 0 0.1", extra: str = "") -> str:
    """A URDF chain of ``n`` links joined by ``joint`` joints."""
    s = ['<robot name="chain">', '<link name="l0"/>']
    for i in range(1, n):
        limit = '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/>' if joint != "fixed" else ""
        s.append(f'<link name="l{i}"/>')
        s.append(f'<joint name="j{i}" type="{joint}"><parent link="l{i - 1}"/><child link="l{i}"/><origin xyz="{origin}"/>{limit}</joint>')
    s.append(extra + "</robot>")
    return "\n".join(s)


# ------------------------------------------------------------------------------------------------
# magnitudes: hangs once, now a proven empty answer or one line
# ------------------------------------------------------------------------------------------------
def test_far_pose_is_proven_empty(capsys, tmp_path):
    """A pose far beyond the arm's reach is a complete, empty answer, on the command line and
    in a poses file, computed without overflow."""
    code, out, err = run(capsys, [*IK, *POSE_FAR, "--json"])
    assert code == 0, err
    d = json.loads(out)
    assert d["complete"] and d["solutions"] == [] and d["source"]["pose"][:3] == [1e308] * 3
    f = tmp_path / "poses.txt"
    f.write_text("1e308 1e308 1e308 0 0 0 1\n-1e308 0 5e307 0 0 0 1\n")
    code, out, err = run(capsys, [*IK, "--poses", f, "--json"])
    assert code == 0, err
    assert [json.loads(line)["complete"] for line in out.splitlines()] == [True, True]


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.floats(min_value=10.0, max_value=1e308), st.integers(0, 2))
def test_far_pose_property(capsys, far, axis):
    """Any pose farther than the UR5's reach bound (under 2 m) has no solution, complete."""
    pose = ["0.1", "0.1", "0.1", "0", "0", "0", "1"]
    pose[axis] = repr(far)
    code, out, err = run(capsys, [*IK, "--pose", *pose, "--json"])
    assert code == 0, err
    d = json.loads(out)
    assert d["complete"] and not d["solutions"]


def test_huge_model_numbers(capsys, tmp_path):
    """A URDF origin of 1e308 (no robot is that long) is refused with one line."""
    f = tmp_path / "far.urdf"
    f.write_text(urdf_chain(4, "revolute", origin="0 0 1e308"))
    refused(capsys, ["info", f], "1e+308", "limit")
    stewart = {
        "kind": "stewart",
        "base_points": [[1e300, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0], [1, 1, 0], [-1, -1, 0]],
        "platform_points": [[1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0], [1, 1, 0], [-1, -1, 0]],
        "leg_lengths": [1, 1, 1, 1, 1, 1],
    }
    f = tmp_path / "st.json"
    f.write_text(json.dumps(stewart))
    refused(capsys, ["info", f], "base_points", "limit")


# ------------------------------------------------------------------------------------------------
# models beyond the limits: refused before Pinocchio
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("joint", ["fixed", "revolute"])
def test_robot_file_limits(capsys, tmp_path, joint):
    f = tmp_path / "big.urdf"
    f.write_text(urdf_chain(MAX_LINKS + 2 if joint == "fixed" else MAX_MODEL_DOF + 3, joint))
    refused(capsys, ["info", f], "limit")


@pytest.mark.slow
@pytest.mark.parametrize("joint", ["fixed", "revolute"])
def test_robot_file_limits_full_size(tmp_path, joint):
    """10,000 links once crashed Pinocchio (a segmentation fault): one line, in a child."""
    f = tmp_path / "big.urdf"
    f.write_text(urdf_chain(10_000, joint))
    child_refused(["info", f], "limit", timeout=120)


def test_mjcf_nesting_refused(capsys, tmp_path):
    n = 300
    body = "".join(f'<body name="b{i}"><joint name="j{i}" type="hinge"/><geom size="0.1"/>' for i in range(n)) + "</body>" * n
    f = tmp_path / "deep.xml"
    f.write_text(f"<mujoco><worldbody>{body}</worldbody></mujoco>")
    refused(capsys, ["info", f], "limit" if n <= 256 else "nested")


def _mimic() -> str:
    text = urdf_chain(3, "revolute")
    return text.replace("</joint>\n</robot>", '<mimic joint="nosuch"/></joint>\n</robot>')


def _nan_mass() -> str:
    inertial = '<inertial><mass value="nan"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>'
    return urdf_chain(3, "revolute").replace('<link name="l1"/>', f'<link name="l1">{inertial}</link>')


def _nan_inertia() -> str:
    inertial = '<inertial><mass value="1"/><inertia ixx="nan" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>'
    return urdf_chain(3, "revolute").replace('<link name="l1"/>', f'<link name="l1">{inertial}</link>')


BAD_ROBOTS = {
    "mimic of a missing joint": ("r.urdf", _mimic, ["mimic", "nosuch"]),
    "NaN mass": ("r.urdf", _nan_mass, ["mass", "finite"]),
    "NaN inertia": ("r.urdf", _nan_inertia, ["ixx", "finite"]),
    "tiny axis": ("r.urdf", lambda: urdf_chain(3, "revolute").replace('xyz="0 0 1"', 'xyz="0 0 1e-300"', 1), ["1e-300", "too small"]),
    "MJCF include": (
        "m.xml",
        lambda: '<mujoco><include file="/etc/passwd"/><worldbody><body><joint type="hinge"/><geom size="1"/></body></worldbody></mujoco>',
        ["include"],
    ),
    "MJCF NaN position": (
        "m.xml",
        lambda: '<mujoco><worldbody><body pos="nan 0 0"><joint type="hinge"/><geom size="1"/></body></worldbody></mujoco>',
        ["pos", "finite"],
    ),
    "a raw terminal escape": ("r.urdf", lambda: urdf_chain(3, "revolute").replace('"l2"', '"l\x1b[31m"'), ["not well-formed"]),
    "latin-1 with a declaration": (
        "r.urdf",
        lambda: '<?xml version="1.0" encoding="latin-1"?>\n' + urdf_chain(3, "revolute").replace('"l2"', '"l\xe92"'),
        ["UTF-8"],
    ),
}


@pytest.mark.parametrize("case", BAD_ROBOTS)
@pytest.mark.parametrize("cmd", ["info", "ik"])
def test_bad_robot_files(capsys, tmp_path, case, cmd):
    name, make, words = BAD_ROBOTS[case]
    f = tmp_path / name
    f.write_bytes(make().encode("latin-1"))
    args = ["info", f] if cmd == "info" else ["ik", f, "--frame", "l2", *POSE]
    refused(capsys, args, *words)


def test_urdf_root_element_decides(capsys, tmp_path):
    """A URDF whose comment mentions <mujoco> is read as URDF: its root element says so."""
    f = tmp_path / "arm.xml"
    f.write_text('<?xml version="1.0"?>\n<!-- converted from a <mujoco> model -->\n' + urdf_chain(3, "revolute"))
    code, out, err = run(capsys, ["info", f, "--json"])
    assert code == 0, err
    assert "j2" in out


def test_control_characters_escaped(capsys, tmp_path):
    """Names with terminal escapes and newlines are printed escaped by `info`."""
    f = tmp_path / "ansi.urdf"
    f.write_text(urdf_chain(3, "revolute").replace('"l2"', '"l&#x9b;31mred&#10;x&#x202e;"'))
    code, out, err = run(capsys, ["info", f])
    assert code == 0, err
    assert "\x9b" not in out and "red\nx" not in out and "\u202e" not in out
    assert "l\\x9b31mred\\nx\\u202e" in out
    line = refused(capsys, ["ik", f, "--frame", "no\nsuch\x1b[2J", *POSE], "no\\nsuch\\x1b[2J")
    assert "\x1b" not in line and "\x9b" not in line


# ------------------------------------------------------------------------------------------------
# special files and budgets
# ------------------------------------------------------------------------------------------------
@pytest.fixture
def fifo(tmp_path):
    p = tmp_path / "fifo"
    os.mkfifo(p)
    return p


@pytest.mark.parametrize("special", ["/dev/zero", "/dev/urandom", "fifo"])
def test_special_files_refused(capsys, tmp_path, fifo, special):
    """Devices and FIFOs are refused as robot, mechanism, poses, result and state files, at
    once (a FIFO without a writer does not block)."""
    path = str(fifo) if special == "fifo" else special
    why = "FIFO" if special == "fifo" else "device"
    refused(capsys, ["info", path], why, seconds=30)
    refused(capsys, [*IK, "--poses", path], why, seconds=30)
    refused(capsys, ["plot", path, "--vars", "a,b", "-o", tmp_path / "x.png"], why, seconds=30)
    refused(capsys, ["replay", path, "--html", tmp_path / "x.html"], why, seconds=30)
    refused(capsys, ["solve", "four-bar", "--resume", path], why, seconds=30)
    refused(capsys, ["check", path], why, seconds=30)
    refused(capsys, [*IK, *POSE, "--scene", path], why, seconds=30)


@pytest.mark.slow
def test_dev_zero_bounded_memory():
    for args in (["ik", "ur5", "--frame", "tool0", "--poses", "/dev/zero"], ["replay", "/dev/zero", "--html", "/dev/null"]):
        child_refused(args, "device", memory_gb=1.0)


def test_mechanism_file_faults(capsys, tmp_path):
    (tmp_path / "self.json").write_text(json.dumps({"kind": "urdf", "file": "self.json"}))
    refused(capsys, ["info", tmp_path / "self.json"], "mechanism file")
    (tmp_path / "a.json").write_text(json.dumps({"kind": "urdf", "file": "b.json"}))
    (tmp_path / "b.json").write_text(json.dumps({"kind": "mjcf", "file": "a.json"}))
    refused(capsys, ["info", tmp_path / "a.json"], "mechanism file")
    (tmp_path / "int.json").write_text('{"kind": "four-bar", "ground": ' + "9" * 5000 + ', "crank": 1, "coupler": 3, "rocker": 2}')
    refused(capsys, ["info", tmp_path / "int.json"], "5000 digits")
    (tmp_path / "str.json").write_text('{"kind": "four-bar", "ground": 3, "crank": 1, "coupler": "3", "rocker": 2}')
    refused(capsys, ["info", tmp_path / "str.json"], "coupler", "string")


def chain(n: int) -> dict:
    return {
        "kind": "constraints",
        "name": f"chain{n}",
        "entities": {f"p{i}": {"type": "point"} for i in range(n)},
        "constraints": [{"type": "distance", "entities": [f"p{i}", f"p{i + 1}"], "value": 1.0} for i in range(n - 1)],
    }


@pytest.mark.parametrize("n", [MAX_ENTITIES + 1, 1000])
@pytest.mark.parametrize("cmd", ["solve", "check"])
def test_constraint_chain_refused(capsys, tmp_path, n, cmd):
    f = tmp_path / "chain.json"
    f.write_text(json.dumps(chain(n)))
    refused(capsys, [cmd, f], f"{n} entities", "limit", seconds=30)


@pytest.mark.slow
@pytest.mark.parametrize("n", [3000, 20_000])
def test_constraint_chain_refused_full_size(tmp_path, n):
    f = tmp_path / "chain.json"
    f.write_text(json.dumps(chain(n)))
    for cmd in ("solve", "check"):
        child_refused([cmd, f], "entities", memory_gb=1.0, timeout=60)


def test_inconsistent_triangle_named(capsys, tmp_path):
    """Three distances that break the triangle inequality: the documented message."""
    d = {
        "kind": "constraints",
        "name": "tri",
        "entities": {f"p{i}": {"type": "point"} for i in range(3)},
        "constraints": [
            {"type": "distance", "entities": ["p0", "p1"], "value": 1.0, "name": "C1"},
            {"type": "distance", "entities": ["p1", "p2"], "value": 1.0, "name": "C2"},
            {"type": "distance", "entities": ["p0", "p2"], "value": 3.0, "name": "C3"},
        ],
    }
    f = tmp_path / "tri.json"
    f.write_text(json.dumps(d))
    refused(capsys, ["solve", f], "C1", "C2", "C3", "inconsistent")


# ------------------------------------------------------------------------------------------------
# numbers and flags on the command line
# ------------------------------------------------------------------------------------------------
CLI_FAULTS = {
    "digit separator in --pose": ([*IK, "--pose", "0_4", "0.1", "0.2", "0", "0", "0", "1"], ["0_4"]),
    "empty field in --from-q": ([*IK, "--from-q", "0.1,,0.2,0,0,0"], ["--from-q"]),
    "joint locked twice": ([*IK, "--lock", "wrist_1_joint=1", "--lock", "wrist_1_joint=2", *POSE], ["twice"]),
    "lock beyond range": ([*IK, "--lock", "wrist_1_joint=1e308", *POSE], ["wrist_1_joint", "limit"]),
    "lock outside limits": (["ik", "panda", "--frame", "panda_hand", "--lock", "panda_joint7=5", *POSE], ["panda_joint7", "range"]),
    "set beyond range": (["solve", "four-bar", "--set", "crank=1e308"], ["crank", "limit"]),
    "dask garbage": (["solve", "four-bar", "--dask", "garbage"], ["--dask"]),
    "dask colons": (["solve", "four-bar", "--dask", "::::"], ["--dask"]),
    "dask http": (["solve", "four-bar", "--dask", "http://localhost:8786"], ["--dask", "http"]),
}


@pytest.mark.parametrize("case", CLI_FAULTS)
def test_cli_numbers(capsys, case):
    args, words = CLI_FAULTS[case]
    refused(capsys, args, *words)


def test_poses_digit_separator(capsys, tmp_path):
    f = tmp_path / "poses.txt"
    f.write_text("0_4 0.1 0.2 0 0 0 1\n")
    code, out, err = run(capsys, [*IK, "--poses", f, "--json"])
    assert code == 5
    assert "error" in json.loads(out)


@pytest.fixture(scope="module")
def ur5_result(tmp_path_factory):
    d = tmp_path_factory.mktemp("res")
    p = d / "ur5.json"
    buf = io.StringIO()
    import contextlib

    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(io.StringIO()):
        assert main([*IK, "--from-q", "0.3,-1.2,1.5,-0.8,1.2,0.4", "--json", "--quiet"]) == 0
    p.write_text(buf.getvalue())
    return p


@pytest.mark.parametrize("delay", ["1e300", "1e308"])
def test_replay_delay_bounded(capsys, tmp_path, ur5_result, delay):
    refused(capsys, ["replay", ur5_result, "--html", tmp_path / "x.html", "--delay", delay], "--delay")


# ------------------------------------------------------------------------------------------------
# search states (--resume)
# ------------------------------------------------------------------------------------------------
def _npz(members: dict[str, bytes], compress: int = zipfile.ZIP_STORED) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=compress) as z:
        for name, data in members.items():
            z.writestr(name, data)
    return buf.getvalue()


def _npy(a: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.save(buf, a)
    return buf.getvalue()


def _header_state(header) -> bytes:
    return _npz({"header.npy": _npy(np.array(json.dumps(header)))})


GOOD_HEADER = {
    "format": "kinbox-search-state",
    "version": 1,
    "fingerprint": "x",
    "options": {},
    "names": [],
    "policy": {},
    "events": {},
    "stats": {},
}


def _claims(n: int) -> bytes:
    """An npy member whose header claims ``n`` floats, followed by a few bytes."""
    head = _npy(np.zeros(1))
    fake = head.replace(b"(1,)", f"({n},)".encode())
    return fake


STATES = {
    "a number as header": lambda: _header_state(3),
    "a string policy field": lambda: _header_state({**GOOD_HEADER, "policy": {"lp_rate": "fast"}}),
    "options a list": lambda: _header_state({**GOOD_HEADER, "options": [1, 2]}),
    "nested header": lambda: _npz({"header.npy": _npy(np.array("[" * 100_000 + "]" * 100_000))}),
    "an .npy file": lambda: _npy(np.zeros(3)),
    "3e12 floats claimed": lambda: _npz({"header.npy": _npy(np.array("{}")), "rest_lo.npy": _claims(3 * 10**12)}),
    "a zip bomb": lambda: _npz({"rest_lo.npy": _npy(np.zeros(2**21))}, zipfile.ZIP_DEFLATED),
}


@pytest.mark.parametrize("case", STATES)
def test_resume_faults(capsys, tmp_path, case):
    f = tmp_path / "state.npz"
    f.write_bytes(STATES[case]())
    refused(capsys, ["solve", "four-bar", "--resume", f], "search state")


# ------------------------------------------------------------------------------------------------
# files written
# ------------------------------------------------------------------------------------------------
def test_save_is_safe(capsys, tmp_path, monkeypatch):
    """A link planted at the old temporary name is not followed; stale temporary files of dead
    savers are removed; a save that fails keeps the answer's exit status 4 and says so."""
    victim = tmp_path / "victim"
    victim.write_text("precious")
    save = tmp_path / "s.npz"
    (tmp_path / "s.npz.part").symlink_to(victim)
    stale = tmp_path / ".s.npz.999999999.abc.part"
    stale.write_text("left by a saver that died")
    code, out, err = run(capsys, ["solve", "four-bar", "--max-boxes", "5", "--save", save, "--quiet"])
    assert code == 4 and "saved to" in err
    assert victim.read_text() == "precious" and save.is_file() and not stale.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".s.npz.")]
    from kinbox.search import statefile

    def full(*a):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(statefile.os, "replace", full)
    code, out, err = run(capsys, ["solve", "four-bar", "--max-boxes", "5", "--save", save, "--quiet", "--json"])
    assert code == 4 and json.loads(out)["complete"] is False
    assert len(err.splitlines()) == 1 and "NOT saved" in err and "exit status 4" in err
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".s.npz.")]


@pytest.mark.slow
def test_concurrent_savers(tmp_path):
    """Four processes saving to one file: each exits 4 with its state saved, the file whole."""
    save = tmp_path / "s.npz"
    args = ["solve", "four-bar", "--max-boxes", "5", "--save", save, "--quiet"]
    code = "import sys; from kinbox.cli import command; sys.exit(command())"
    procs = [
        subprocess.Popen([sys.executable, "-c", code, *map(str, args)], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        for _ in range(4)
    ]
    for p in procs:
        _, err = p.communicate(timeout=300)
        assert p.returncode == 4, err
        assert "saved to" in err
    from kinbox.search.state import SearchState

    SearchState.load(save)


def test_output_errors(capsys, tmp_path, ur5_result):
    """A full disk is an output error with its own status, and `plot -o /dev/full` fails."""
    p = child(["info", "four-bar"], stdout=open("/dev/full", "w"))
    assert p.returncode == EXIT_OUTPUT, p.stderr
    assert p.stderr.splitlines() == ["kinbox: error: cannot write the output: No space left on device"]
    refused(capsys, ["plot", ur5_result, "--vars", "shoulder_pan_joint,elbow_joint", "-o", "/dev/full"], "/dev/full")


# ------------------------------------------------------------------------------------------------
# big results: bounded time
# ------------------------------------------------------------------------------------------------
def test_big_results_bounded(capsys, tmp_path, ur5_result):
    d = json.loads(ur5_result.read_text())
    many = dict(d, solutions=[d["solutions"][k % len(d["solutions"])] for k in range(1001)])
    f = tmp_path / "many.json"
    f.write_text(json.dumps(many))
    refused(capsys, ["replay", f, "--html", tmp_path / "x.html"], "1001 solutions", "limit")
    boxes = {"variables": ["a", "b"], "count": 20001, "lo": [[0.0, 0.0]] * 20001, "hi": [[1.0, 1.0]] * 20001}
    f.write_text(json.dumps(dict(d, boxes=boxes)))
    refused(capsys, ["plot", f, "--vars", "a,b", "-o", tmp_path / "x.png"], "20001 boxes")


@pytest.mark.slow
def test_big_curve_replays_in_bounded_time(tmp_path):
    """100,000 curve samples are thinned: the page is written in bounded time and memory."""
    fb = child(["solve", "four-bar", "--json", "--quiet"], timeout=300)
    d = json.loads(fb.stdout)
    c = d["components"][0]
    c["samples"] = [c["samples"][k % len(c["samples"])] for k in range(100_000)]
    f = tmp_path / "big.json"
    f.write_text(json.dumps(d))
    p = child(["replay", f, "--html", tmp_path / "x.html"], timeout=120)
    assert p.returncode == 0, p.stderr


# ------------------------------------------------------------------------------------------------
# generated JSON faults (property-based)
# ------------------------------------------------------------------------------------------------
_json_leaf = st.one_of(st.none(), st.booleans(), st.integers(), st.floats(allow_nan=False), st.text(max_size=5))
_json = st.recursive(
    _json_leaf, lambda kids: st.one_of(st.lists(kids, max_size=4), st.dictionaries(st.text(max_size=4), kids, max_size=4)), max_leaves=20
)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(_json)
def test_generated_mechanism_files(capsys, tmp_path_factory, value):
    """Any JSON as a mechanism file: an answer or one line, never an internal error."""
    f = tmp_path_factory.mktemp("gen") / "m.json"
    f.write_text(json.dumps(value))
    code, out, err = run(capsys, ["info", f])
    assert code in (0, 2), err
    if code == 2:
        assert len(err.splitlines()) == 1 and out == ""


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.dictionaries(st.sampled_from(list(GOOD_HEADER) + ["x"]), _json, max_size=8))
def test_generated_state_headers(capsys, tmp_path_factory, header):
    f = tmp_path_factory.mktemp("gen") / "s.npz"
    f.write_bytes(_header_state({**GOOD_HEADER, **header}))
    refused(capsys, ["solve", "four-bar", "--resume", f])


def test_child_limits_hold():
    """The helper itself: a child over its memory limit fails (the bound is real)."""
    code = textwrap.dedent("bytearray(3 * 2**30)")
    p = subprocess.run(
        [sys.executable, "-c", code],
        preexec_fn=lambda: resource.setrlimit(resource.RLIMIT_AS, (2**30, 2**30)),
        capture_output=True,
        timeout=60,
    )
    assert p.returncode != 0 and b"MemoryError" in p.stderr


# ------------------------------------------------------------------------------------------------
# the viewer
# ------------------------------------------------------------------------------------------------
def test_viewer_checks_host():
    """The page answers loopback Host headers only; the command socket is a Unix socket in a
    folder only this user can enter."""
    import http.client
    import stat
    from urllib.parse import urlparse

    from kinbox.viz import server

    srv = server.start()
    try:
        u = urlparse(srv.web_url)
        for host, status in (
            ("evil.example", 403),
            (f"127.0.0.1:{u.port}", 200),
            (f"localhost:{u.port}", 200),
            ("127.0.0.1.evil.example", 403),
        ):
            c = http.client.HTTPConnection(u.hostname, u.port, timeout=30)
            c.putrequest("GET", "/static/", skip_host=True)
            c.putheader("Host", host)
            c.endheaders()
            assert c.getresponse().status == status, host
            c.close()
        assert srv.zmq_url.startswith("ipc://")
        folder = os.path.dirname(srv.zmq_url[len("ipc://") :])
        assert stat.S_IMODE(os.stat(folder).st_mode) == 0o700
    finally:
        srv.stop()
    assert not os.path.exists(folder)


def test_page_title_escaped():
    """No title can end or disable the page's script: it holds no ``<`` at all."""
    from kinbox.viz.page import with_overlay

    nasty = "<!--<script></script><b>&"
    page = with_overlay("<html><body></body></html>", nasty, [nasty, "b"], [0.0, 1.0])
    script = page[page.index("<script>") + len("<script>") : page.rindex("</script>")]
    line = script[script.index("var title = ") : script.index(";", script.index("var title = "))]
    assert "<" not in line and ">" not in line and "&" not in line and "<!--" not in script
    assert json.loads(script[script.index("var title = ") + 12 : script.index(", labels")]) == nasty


STL = "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n"


@pytest.mark.parametrize("where", ["inside", "outside"])
def test_mesh_outside_the_robot_folder(tmp_path, where):
    """A mesh path that leaves the robot's folder (and its package) is not shown."""
    from kinbox.model.loading import load
    from kinbox.viz.scene import mesh_model

    pkg = tmp_path / "deep" / "pkg"
    (pkg / "urdf").mkdir(parents=True)
    (pkg / "meshes").mkdir()
    (pkg / "meshes" / "m.stl").write_text(STL)
    (tmp_path / "secret.stl").write_text(STL)
    ref = "../meshes/m.stl" if where == "inside" else "../../../secret.stl"
    visual = f'<visual><geometry><mesh filename="{ref}"/></geometry></visual>'
    text = urdf_chain(3, "revolute").replace('<link name="l1"/>', f'<link name="l1">{visual}</link>')
    f = pkg / "urdf" / "r.urdf"
    f.write_text(text)
    geom, note = mesh_model(load(str(f)).model, str(f))
    if where == "inside":
        assert geom is not None, note
    else:
        assert geom is None and "outside" in note and "\n" not in note


def test_numba_cache_choice(tmp_path, monkeypatch):
    """An unwritable NUMBA_CACHE_DIR is passed over; with nothing writable but the temporary
    folder, a private folder there is used; with nothing writable at all, caching is off."""
    import numba

    from kinbox import jitcache

    monkeypatch.setattr(numba.config, "CACHE_DIR", numba.config.CACHE_DIR)  # restored after the test
    monkeypatch.setenv("NUMBA_CACHE_DIR", "/proc/kinbox-no-such-dir")
    assert jitcache.choose() in ("numba",) or os.path.isdir(jitcache.choose())
    writable = {str(tmp_path)}
    monkeypatch.setattr(jitcache, "_usable", lambda d: bool(d) and str(d).startswith(tuple(writable)))
    monkeypatch.setattr("tempfile.gettempdir", lambda: str(tmp_path))
    got = jitcache.choose()
    assert got.startswith(str(tmp_path)) and os.environ["NUMBA_CACHE_DIR"] == got
    assert os.stat(got).st_mode & 0o777 == 0o700
    writable.clear()
    import numba.core.dispatcher

    monkeypatch.setattr(numba.core.dispatcher.Dispatcher, "enable_caching", numba.core.dispatcher.Dispatcher.enable_caching)
    assert jitcache.choose() == ""

    @numba.njit(cache=True)
    def twice(x):
        return 2 * x

    assert twice(3) == 6 and type(twice._cache).__name__ == "NullCache"


@pytest.mark.slow
@pytest.mark.parametrize("trial", range(5))
def test_lost_worker_does_not_hang(trial):
    """A worker of `solve --workers 2` killed mid-search: the master finishes (the batch runs
    again on a new pool) and exits, never waiting on the old pool's surviving worker."""
    import signal

    psutil = pytest.importorskip("psutil")
    code = "import sys; from kinbox.cli import command; sys.exit(command())"
    proc = subprocess.Popen(
        [sys.executable, "-c", code, "solve", "bricard", "--workers", "2", "--json", "--quiet"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline = time.monotonic() + 120
        workers: list = []
        while time.monotonic() < deadline and len(workers) < 2 and proc.poll() is None:
            workers = psutil.Process(proc.pid).children()
            time.sleep(0.2)
        time.sleep(1.0 + trial)
        if workers and proc.poll() is None:
            workers[trial % len(workers)].send_signal(signal.SIGKILL)
        out, err = proc.communicate(timeout=600)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode in (0, 4), err
    assert json.loads(out)["solutions"] is not None


def test_poses_on_stdin_bounded(capsys, monkeypatch):
    """Binary or oversized poses on stdin: one line, read with the budget."""
    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(bytes(range(128, 256)) * 4)))
    refused(capsys, [*IK, "--poses", "-"], "UTF-8")
    from kinbox.errors import MAX_INPUT_BYTES

    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(b"\0" * (MAX_INPUT_BYTES + 2))))
    refused(capsys, [*IK, "--poses", "-"], "more than")
