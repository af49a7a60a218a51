"""Bad input, everywhere it enters: command-line arguments of ``ik``, ``solve``,
``replay``, ``plot`` and ``info``, the files they read (generated malformed: truncated, wrong
types, NaN/inf, duplicate keys, huge, binary, deeply nested), and the Python API.

Every case asserts the exit status (2), exactly one line on stderr, ``kinbox: error: ...``,
that names the problem, and nothing on stdout (no answer, so no wrong one). The command line
runs in this process (``kinbox.cli.main``) to keep the suite fast.
"""

from __future__ import annotations

import json
import random

import numpy as np
import pinocchio as pin
import pytest

import kinbox
from kinbox.cli import main
from kinbox.errors import KinboxError
from kinbox.search.state import SearchState

POSE = ["--pose", "0.3", "0.2", "0.4", "0", "0", "0", "1"]
IK = ["ik", "ur5", "--frame", "tool0"]


def run(capsys, args) -> tuple[int, str, str]:
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def assert_rejected(capsys, args, *words, code: int = 2) -> str:
    """Exit ``code``, one stderr line ``kinbox: error: ...`` naming ``words``, nothing on stdout."""
    got, out, err = run(capsys, args)
    lines = err.splitlines()
    assert got == code, (got, err)
    assert "Traceback" not in err
    assert len(lines) == 1, f"expected one line on stderr, got {len(lines)}:\n{err}"
    assert lines[0].startswith("kinbox: error:"), lines[0]
    for w in words:
        assert w.lower() in lines[0].lower(), (w, lines[0])
    assert out == "", out[:500]
    return lines[0]


def sparse_file(path, size: int) -> None:
    """A file of ``size`` bytes that takes no disk space (a hole), to test size limits."""
    with open(path, "wb") as f:
        f.truncate(size)


# ------------------------------------------------------------------------------------------------
# kinbox ik: arguments
# ------------------------------------------------------------------------------------------------
IK_ARGS = {
    "unknown robot": (["ik", "no_such_robot_xyz", "--frame", "tool0", *POSE], ["no_such_robot_xyz"]),
    "unknown frame": ([*IK[:3], "no_such_frame", *POSE], ["no_such_frame"]),
    "empty frame": ([*IK[:3], "", *POSE], ["frame", "empty"]),
    "frame world": ([*IK[:3], "world", *POSE], ["world", "no joint"]),
    "frame base_link": ([*IK[:3], "base_link", *POSE], ["base_link", "no joint"]),
    "frame is base": ([*IK, "--base", "tool0", *POSE], ["no joint"]),
    "frame fixed to base": ([*IK, "--base", "ee_link", *POSE], ["no joint"]),
    "unknown base": ([*IK, "--base", "no_such_base", *POSE], ["no_such_base"]),
    "empty base": ([*IK, "--base", "", *POSE], ["base", "empty"]),
    "pose nan": ([*IK, "--pose", "0.3", "nan", "0.4", "0", "0", "0", "1"], ["non-finite"]),
    "pose inf": ([*IK, "--pose", "inf", "0.2", "0.4", "0", "0", "0", "1"], ["non-finite"]),
    "pose -inf": ([*IK, "--pose", "0.3", "0.2", "-inf", "0", "0", "0", "1"], ["non-finite"]),
    "pose overflow": ([*IK, "--pose", "1e999", "0.2", "0.4", "0", "0", "0", "1"], ["non-finite"]),
    "pose letters": ([*IK, "--pose", "0.3", "abc", "0.4", "0", "0", "0", "1"], ["--pose", "abc"]),
    "pose six numbers": ([*IK, "--pose", "0.3", "0.2", "0.4", "0", "0", "1"], ["--pose", "7"]),
    "pose zero quaternion": ([*IK, "--pose", "0.3", "0.2", "0.4", "0", "0", "0", "0"], ["quaternion", "norm 0"]),
    "pose non-unit quaternion": ([*IK, "--pose", "0.3", "0.2", "0.4", "0", "0", "0", "2"], ["quaternion"]),
    "from-q too few": ([*IK, "--from-q", "0.1,0.2"], ["joint values", "got 2"]),
    "from-q too many": ([*IK, "--from-q", "0.1,0.2,0.3,0.4,0.5,0.6,0.7"], ["joint values", "got 7"]),
    "from-q nan": ([*IK, "--from-q", "0.1,nan,0.3,0.4,0.5,0.6"], ["not finite"]),
    "from-q letters": ([*IK, "--from-q", "a,b"], ["--from-q"]),
    "from-q empty": ([*IK, "--from-q", ""], ["got 0"]),
    "lock without value": ([*IK, "--lock", "elbow_joint", *POSE], ["--lock", "JOINT=VALUE"]),
    "lock not a number": ([*IK, "--lock", "elbow_joint=abc", *POSE], ["--lock", "not a number"]),
    "lock without joint": ([*IK, "--lock", "=0.3", *POSE], ["--lock"]),
    "lock unknown joint": ([*IK, "--lock", "no_such_joint=0.3", *POSE], ["no_such_joint"]),
    "lock nan": ([*IK, "--lock", "elbow_joint=nan", *POSE], ["elbow_joint", "not finite"]),
    "lock inf": ([*IK, "--lock", "elbow_joint=inf", *POSE], ["elbow_joint", "not finite"]),
    "lock every joint": (
        [
            *IK,
            *sum(
                (
                    ["--lock", f"{j}=0.1"]
                    for j in ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")
                ),
                [],
            ),
            *POSE,
        ],
        ["locked"],
    ),
    "time limit negative": ([*IK, *POSE, "--time-limit", "-1"], ["--time-limit", "-1"]),
    "time limit zero": ([*IK, *POSE, "--time-limit", "0"], ["--time-limit"]),
    "time limit nan": ([*IK, *POSE, "--time-limit", "nan"], ["--time-limit", "nan"]),
    "time limit inf": ([*IK, *POSE, "--time-limit", "inf"], ["--time-limit", "inf"]),
    "time limit text": ([*IK, *POSE, "--time-limit", "soon"], ["--time-limit", "soon"]),
    "max boxes zero": ([*IK, *POSE, "--max-boxes", "0"], ["--max-boxes", "0"]),
    "max boxes negative": ([*IK, *POSE, "--max-boxes", "-5"], ["--max-boxes", "-5"]),
    "max boxes fraction": ([*IK, *POSE, "--max-boxes", "1.5"], ["--max-boxes", "1.5"]),
    "sigma zero": ([*IK, *POSE, "--sigma", "0"], ["--sigma"]),
    "sigma negative": ([*IK, *POSE, "--sigma", "-1"], ["--sigma"]),
    "sigma nan": ([*IK, *POSE, "--sigma", "nan"], ["--sigma"]),
    "sigma too large": ([*IK, *POSE, "--sigma", "3"], ["sigma", "too large"]),
    "workers negative": ([*IK, *POSE, "--workers", "-1"], ["--workers"]),
    "workers far too many": ([*IK, *POSE, "--workers", "99999"], ["99999", "too many"]),
    "workers and dask": ([*IK, *POSE, "--workers", "2", "--dask", "tcp://127.0.0.1:1"], ["--dask"]),
    "no frame": (["ik", "ur5", *POSE], ["--frame"]),
    "no goal": ([*IK], ["--pose", "--from-q", "--poses"]),
    "two goals": ([*IK, *POSE, "--from-q", "0,0,0,0,0,0"], ["not allowed"]),
    "unknown option": ([*IK, *POSE, "--frobnicate"], ["--frobnicate"]),
    "unknown command": (["frobnicate"], ["frobnicate"]),
    "info unknown robot": (["info", "no_such_robot_xyz"], ["no_such_robot_xyz"]),
}


@pytest.mark.parametrize("case", sorted(IK_ARGS))
def test_ik_arguments(capsys, case):
    args, words = IK_ARGS[case]
    assert_rejected(capsys, args, *words)


# ------------------------------------------------------------------------------------------------
# robot files (URDF)
# ------------------------------------------------------------------------------------------------
def _urdf(joints: str, links: str = '<link name="base"/><link name="l1"/><link name="l2"/>') -> str:
    return f'<?xml version="1.0"?>\n<robot name="r">{links}{joints}</robot>\n'


_J = (
    '<joint name="{n}" type="revolute"><parent link="{p}"/><child link="{c}"/><axis xyz="{a}"/>'
    '<origin xyz="{o}"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
)
GOOD_JOINTS = _J.format(n="j1", p="base", c="l1", a="0 0 1", o="0 0 0.1") + _J.format(n="j2", p="l1", c="l2", a="0 1 0", o="0 0 0.5")


def _chain(n: int) -> str:
    links = "".join(f'<link name="l{k}"/>' for k in range(n + 1))
    joints = "".join(_J.format(n=f"j{k}", p=f"l{k - 1}", c=f"l{k}", a="0 0 1", o="0 0 0.1") for k in range(1, n + 1))
    return f'<?xml version="1.0"?>\n<robot name="long">{links}{joints}</robot>\n'


URDF_FILES = {
    "truncated": (_urdf(GOOD_JOINTS)[:150], ["robot.urdf"]),
    "not xml": ("this is not a robot\n", ["robot.urdf"]),
    "empty": ("", ["robot.urdf"]),
    "binary": (bytes(random.Random(1).randrange(256) for _ in range(4000)), ["robot.urdf"]),
    "zero joint axis": (
        _urdf(_J.format(n="j1", p="base", c="l1", a="0 0 0", o="0 0 0.1") + _J.format(n="j2", p="l1", c="l2", a="0 1 0", o="0 0 0.5")),
        ["j1", "zero axis"],
    ),
    "nan origin": (
        _urdf(_J.format(n="j1", p="base", c="l1", a="0 0 1", o="0 nan 0.1") + _J.format(n="j2", p="l1", c="l2", a="0 1 0", o="0 0 0.5")),
        ["robot.urdf"],
    ),
    "missing parent link": (_urdf(_J.format(n="j1", p="nowhere", c="l1", a="0 0 1", o="0 0 0.1")), ["robot.urdf"]),
    "duplicate joint": (
        _urdf(_J.format(n="j1", p="base", c="l1", a="0 0 1", o="0 0 0.1") + _J.format(n="j1", p="l1", c="l2", a="0 1 0", o="0 0 0.5")),
        ["robot.urdf"],
    ),
    "too many joints": (_chain(200), ["200 degrees of freedom", "128"]),
}


@pytest.mark.parametrize("case", sorted(URDF_FILES))
def test_urdf_files(capsys, tmp_path, case):
    text, words = URDF_FILES[case]
    f = tmp_path / "robot.urdf"
    if isinstance(text, bytes):
        f.write_bytes(text)
    else:
        f.write_text(text)
    frame = "l2" if case != "too many joints" else "l200"
    assert_rejected(capsys, ["ik", f, "--frame", frame, *POSE], *words)
    assert_rejected(capsys, ["info", f], *words)


def test_urdf_file_too_large(capsys, tmp_path):
    f = tmp_path / "huge.urdf"
    sparse_file(f, 17 * 2**20)
    assert_rejected(capsys, ["ik", f, "--frame", "l2", *POSE], "huge.urdf", "limit")


def test_xml_that_is_no_robot(capsys, tmp_path):
    f = tmp_path / "thing.xml"
    f.write_text("<?xml version='1.0'?><thing/>")
    assert_rejected(capsys, ["ik", f, "--frame", "a", *POSE], "thing.xml", "neither")


def test_robot_path_is_a_directory(capsys, tmp_path):
    assert_rejected(capsys, ["ik", f"{tmp_path}/", "--frame", "a", *POSE], "directory")


# ------------------------------------------------------------------------------------------------
# kinbox solve: mechanism files
# ------------------------------------------------------------------------------------------------
FOUR_BAR = '{"kind": "four-bar", "ground": 3, "crank": 1, "coupler": 3, "rocker": 2}'


def _nested(depth: int) -> str:
    return '{"kind": "four-bar", "ground": 3, "crank": 1, "coupler": 3, "rocker": 2, "note": ' + "[" * depth + "]" * depth + "}"


def _dh_rows(n: int) -> str:
    rng = random.Random(2)
    return json.dumps({"kind": "dh-loop", "dh": [{"a": rng.random(), "d": rng.random(), "alpha": rng.random()} for _ in range(n)]})


MECHANISM_FILES = {
    "truncated": (FOUR_BAR[:30], ["not valid JSON"]),
    "empty": ("", ["not valid JSON"]),
    "binary": (bytes(random.Random(3).randrange(128, 256) for _ in range(3000)), ["UTF-8"]),
    "latin-1 text": ('{"kind": "four-bar", "note": "caf\xe9"}'.encode("latin-1"), ["UTF-8"]),
    "utf-8 bom": ("\ufeff" + FOUR_BAR, ["not valid JSON"]),
    "json array": ("[1, 2, 3]", ["JSON object"]),
    "json string": ('"four-bar"', ["JSON object"]),
    "json null": ("null", ["JSON object"]),
    "missing kind": ('{"ground": 3}', ["kind"]),
    "unknown kind": ('{"kind": "no-such-kind"}', ["no-such-kind"]),
    "kind a number": ('{"kind": 4}', ["kind"]),
    "missing parameter": ('{"kind": "four-bar", "ground": 3, "crank": 1, "coupler": 3}', ["rocker"]),
    "parameter a string": ('{"kind": "four-bar", "ground": "three", "crank": 1, "coupler": 3, "rocker": 2}', ["ground", "number"]),
    "parameter a list": ('{"kind": "four-bar", "ground": [3], "crank": 1, "coupler": 3, "rocker": 2}', ["ground"]),
    "parameter a bool": ('{"kind": "four-bar", "ground": true, "crank": 1, "coupler": 3, "rocker": 2}', ["ground"]),
    "parameter null": ('{"kind": "four-bar", "ground": null, "crank": 1, "coupler": 3, "rocker": 2}', ["ground"]),
    "NaN": ('{"kind": "four-bar", "ground": NaN, "crank": 1, "coupler": 3, "rocker": 2}', ["NaN"]),
    "Infinity": ('{"kind": "four-bar", "ground": Infinity, "crank": 1, "coupler": 3, "rocker": 2}', ["Infinity"]),
    "-Infinity": ('{"kind": "four-bar", "ground": 3, "crank": -Infinity, "coupler": 3, "rocker": 2}', ["Infinity"]),
    "huge number": ('{"kind": "four-bar", "ground": 1e999, "crank": 1, "coupler": 3, "rocker": 2}', ["ground"]),
    "negative length": ('{"kind": "four-bar", "ground": -3, "crank": 1, "coupler": 3, "rocker": 2}', ["ground"]),
    "unknown parameter": ('{"kind": "four-bar", "ground": 3, "crank": 1, "coupler": 3, "rocker": 2, "colour": 1}', ["colour"]),
    "duplicate key": ('{"kind": "four-bar", "ground": 3, "ground": 4, "crank": 1, "coupler": 3, "rocker": 2}', ["ground", "twice"]),
    "nested too deep": (_nested(100000), ["nested deeper"]),
    "nested deeper than the limit": (_nested(40), ["nested deeper than 32"]),
    "too many dh rows": (_dh_rows(129), ["129 rows", "128"]),
    "dh row of two numbers": ('{"kind": "dh-loop", "dh": [[1, 2]]}', ["DH row 1"]),
    "dh row missing a key": ('{"kind": "dh-loop", "dh": [{"a": 1, "d": 0}]}', ["DH row 1", "alpha"]),
    "dh row unknown key": ('{"kind": "dh-loop", "dh": [{"a": 1, "d": 0, "alpha": 0, "beta": 1}]}', ["beta"]),
    "dh rows not a list": ('{"kind": "dh-loop", "dh": 6}', ["dh"]),
    "dh duplicate joint names": (
        '{"kind": "dh-loop", "dh": [{"a": 1, "d": 0, "alpha": 0, "name": "j"}, {"a": 1, "d": 0, "alpha": 0, "name": "j"}]}',
        ["unique"],
    ),
    "stewart points of two coordinates and four": (
        '{"kind": "stewart", "base_points": [[0, 0, 0, 0]], "platform_points": [[0, 0, 0]]}',
        ["base_points"],
    ),
    "stewart too many legs": (
        json.dumps(
            {"kind": "stewart", "base_points": [[k, 0, 0] for k in range(1001)], "platform_points": [[k, 1, 0] for k in range(1001)]}
        ),
        ["1001 legs"],
    ),
    "set unknown joint": (
        '{"kind": "four-bar", "ground": 3, "crank": 1, "coupler": 3, "rocker": 2, "set": {"no_such_joint": 0.3}}',
        ["no_such_joint"],
    ),
    "set not an object": ('{"kind": "four-bar", "ground": 3, "crank": 1, "coupler": 3, "rocker": 2, "set": [0.3]}', ["set"]),
    "urdf kind without file": ('{"kind": "urdf", "file": "no_such_file.urdf"}', ["no_such_file.urdf"]),
}


@pytest.mark.parametrize("case", sorted(MECHANISM_FILES))
def test_mechanism_files(capsys, tmp_path, case):
    text, words = MECHANISM_FILES[case]
    f = tmp_path / "mech.json"
    if isinstance(text, bytes):
        f.write_bytes(text)
    else:
        f.write_text(text, encoding="utf-8")
    assert_rejected(capsys, ["solve", f], *words)


@pytest.mark.parametrize("case", ["binary", "latin-1 text", "nested too deep", "duplicate key"])
@pytest.mark.parametrize("command", ["solve", "check"])
def test_files_refused_before_telling_constraints_from_mechanisms(capsys, tmp_path, case, command):
    """A .json may be a constraint system: the file is read within the limits to tell, and a
    refused one is named in one line, not a traceback of the reading."""
    text, words = MECHANISM_FILES[case]
    f = tmp_path / "mech.json"
    if isinstance(text, bytes):
        f.write_bytes(text)
    else:
        f.write_text(text.replace('"kind": "four-bar"', '"kind": "constraints"'), encoding="utf-8")
    assert_rejected(capsys, [command, f], *words)


def test_mechanism_file_too_large(capsys, tmp_path):
    f = tmp_path / "huge.json"
    sparse_file(f, 17 * 2**20)
    assert_rejected(capsys, ["solve", f], "huge.json", "limit")


SOLVE_ARGS = {
    "unknown mechanism": (["solve", "no_such_mechanism"], ["no_such_mechanism"]),
    "missing file": (["solve", "missing/mech.json"], ["missing/mech.json"]),
    "nothing to solve": (["solve", "ur5"], ["nothing to solve"]),
    "set without value": (["solve", "four-bar", "--set", "crank"], ["--set"]),
    "set not a number": (["solve", "four-bar", "--set", "crank=abc"], ["--set", "abc"]),
    "set nan": (["solve", "four-bar", "--set", "crank=nan"], ["crank", "not finite"]),
    "set unknown joint": (["solve", "four-bar", "--set", "no_such_joint=0.3"], ["no_such_joint"]),
    "legs bogus": (["solve", "four-bar", "--legs", "bogus"], ["--legs", "bogus"]),
    "resume missing state": (["solve", "general-6r", "--resume", "no_such_state.npz"], ["no_such_state.npz"]),
    "save into a missing folder": (["solve", "general-6r", "--save", "no/such/folder/s.npz"], ["--save", "cannot write"]),
}


@pytest.mark.parametrize("case", sorted(SOLVE_ARGS))
def test_solve_arguments(capsys, case):
    args, words = SOLVE_ARGS[case]
    assert_rejected(capsys, args, *words)


# ------------------------------------------------------------------------------------------------
# --save / --resume
# ------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def six_r_state(tmp_path_factory):
    """A saved search of the general 6R loop, stopped after 20 boxes."""
    path = tmp_path_factory.mktemp("state") / "six_r.npz"
    res = kinbox.solve("general-6r", max_boxes=20, progress=False)
    assert not res.complete
    res.raw.state.save(path)
    return path


def test_resume_garbage(capsys, tmp_path):
    f = tmp_path / "state.npz"
    f.write_text("not a saved search")
    assert_rejected(capsys, ["solve", "general-6r", "--resume", f], "state.npz", "not a kinbox search state")


def test_resume_truncated(capsys, tmp_path, six_r_state):
    f = tmp_path / "state.npz"
    f.write_bytes(six_r_state.read_bytes()[:2000])
    assert_rejected(capsys, ["solve", "general-6r", "--resume", f], "state.npz")


def test_resume_other_problem(capsys, six_r_state):
    assert_rejected(capsys, ["solve", "bricard", "--resume", six_r_state], "another problem")


def test_resume_other_options(capsys, six_r_state):
    assert_rejected(capsys, ["solve", "general-6r", "--sigma", "0.01", "--resume", six_r_state], "sigma")


def test_resume_with_poses(capsys, tmp_path, six_r_state):
    f = tmp_path / "poses.txt"
    f.write_text("0.3 0.2 0.4 0 0 0 1\n")
    assert_rejected(capsys, [*IK, "--poses", f, "--resume", six_r_state], "--poses")


def test_resume_damaged_arrays(capsys, tmp_path, six_r_state):
    with np.load(six_r_state) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["rest_lo"] = arrays["rest_lo"][:, :3]
    f = tmp_path / "damaged.npz"
    np.savez(f, **arrays)
    assert_rejected(capsys, ["solve", "general-6r", "--resume", f], "damaged.npz", "wrong shape")


# ------------------------------------------------------------------------------------------------
# kinbox replay / plot: result files
# ------------------------------------------------------------------------------------------------
def _result(**change) -> dict:
    """A small valid result (two joints, one solution, one box), changed by ``change``."""
    d = {
        "problem": "ik r",
        "source": {"kind": "ik", "robot": "ur5", "frame": "tool0"},
        "joint_names": ["a", "b"],
        "complete": True,
        "message": "",
        "solutions": [{"q": [0.1, 0.2], "residual": 0.0, "certified": True, "width": 0.0}],
        "components": [{"dimension": 0, "boxes": 1, "certified": True}],
        "stats": {},
        "boxes": {"variables": ["x", "y"], "count": 1, "lo": [[0.0, 0.0]], "hi": [[1.0, 1.0]], "component": [0]},
    }
    d.update(change)
    return d


def _boxes(**change) -> dict:
    b = {"variables": ["x", "y"], "count": 1, "lo": [[0.0, 0.0]], "hi": [[1.0, 1.0]], "component": [0]}
    b.update(change)
    return b


RESULT_FILES = {
    "empty": ("", ["not valid JSON"]),
    "truncated": (json.dumps(_result())[:100], ["not valid JSON"]),
    "binary": (bytes(random.Random(4).randrange(128, 256) for _ in range(3000)), ["UTF-8"]),
    "json array": ("[]", ["not a kinbox result"]),
    "no solutions": (json.dumps({"source": {}}), ["missing 'solutions'"]),
    "no source": (json.dumps({"solutions": []}), ["missing 'source'"]),
    "source a string": (json.dumps(_result(source="ur5")), ["source"]),
    "solutions an object": (json.dumps(_result(solutions={"q": [1, 2]})), ["solutions", "list"]),
    "solution without q": (json.dumps(_result(solutions=[{"residual": 0}])), ["solutions[0]", "missing 'q'"]),
    "q NaN": (json.dumps(_result()).replace("[0.1, 0.2]", "[0.1, NaN]"), ["solutions[0].q[1]", "nan", "not a finite number"]),
    "q Infinity": (json.dumps(_result()).replace("[0.1, 0.2]", "[Infinity, 0.2]"), ["q[0]", "inf"]),
    "q strings": (json.dumps(_result(solutions=[{"q": ["0.1", "0.2"]}])), ["solutions[0].q[", "not a number"]),
    "q of the wrong length": (json.dumps(_result(solutions=[{"q": [0.1, 0.2, 0.3]}])), ["solutions[0].q", "3 entries", "expected 2"]),
    "q nested": (json.dumps(_result(solutions=[{"q": [[0.1], [0.2]]}])), ["solutions[0].q[", "not a number"]),
    "joint names duplicated": (json.dumps(_result(joint_names=["a", "a"])), ["joint_names", "twice"]),
    "joint names not strings": (json.dumps(_result(joint_names=[1, 2])), ["joint_names"]),
    "dimension negative": (json.dumps(_result(components=[{"dimension": -1}])), ["components[0].dimension", "below 0"]),
    "dimension a string": (json.dumps(_result(components=[{"dimension": "one"}])), ["dimension"]),
    "sample NaN": (
        json.dumps(_result(components=[{"dimension": 1, "samples": [[0.1, 0.2], [0.3, 1e999]]}])),
        ["components[0].samples[1][1]", "infinity", "not a finite number"],
    ),
    "duplicate key": (json.dumps(_result())[:-1] + ', "solutions": []}', ["solutions", "twice"]),
    "nested too deep": (json.dumps(_result())[:-1] + ', "extra": ' + "[" * 50000 + "]" * 50000 + "}", ["nested deeper"]),
    "boxes lo and hi of different lengths": (json.dumps(_result(boxes=_boxes(hi=[]))), ["boxes.lo", "not the same length"]),
    "box with lo above hi": (json.dumps(_result(boxes=_boxes(lo=[[0.0, 2.0]]))), ["boxes[0]", "lo > hi"]),
    "box NaN": (json.dumps(_result(boxes=_boxes(hi=[[1.0, float("nan")]]))), ["boxes.hi[0][1]", "not a finite number"]),
    "box of the wrong width": (json.dumps(_result(boxes=_boxes(lo=[[0.0]]))), ["boxes.lo[0]", "expected 2"]),
    "box strings": (json.dumps(_result(boxes=_boxes(lo=[["a", "b"]]))), ["boxes.lo"]),
    "box component out of range": (json.dumps(_result(boxes=_boxes(component=[7]))), ["boxes.component[0]", "component 7"]),
}


@pytest.mark.parametrize("command", ["replay", "plot"])
@pytest.mark.parametrize("case", sorted(RESULT_FILES))
def test_result_files(capsys, tmp_path, case, command):
    text, words = RESULT_FILES[case]
    f = tmp_path / "result.json"
    if isinstance(text, bytes):
        f.write_bytes(text)
    else:
        f.write_text(text, encoding="utf-8")
    args = (
        [command, f, "--html", tmp_path / "out.html"] if command == "replay" else [command, f, "--vars", "x,y", "-o", tmp_path / "out.png"]
    )
    assert_rejected(capsys, args, *words)
    assert not (tmp_path / "out.html").exists() and not (tmp_path / "out.png").exists()


def test_result_file_too_large(capsys, tmp_path):
    f = tmp_path / "huge.json"
    sparse_file(f, 65 * 2**20)
    assert_rejected(capsys, ["plot", f, "--vars", "x,y", "-o", tmp_path / "out.png"], "huge.json", "limit")


@pytest.fixture()
def good_result(tmp_path):
    f = tmp_path / "good.json"
    f.write_text(json.dumps(_result()))
    return f


PICTURE_ARGS = {
    "plot one variable": (["plot", "{f}", "--vars", "x", "-o", "{d}/o.png"], ["--vars", "two or three"]),
    "plot four variables": (["plot", "{f}", "--vars", "x,y,a,b", "-o", "{d}/o.png"], ["--vars", "got 4"]),
    "plot the same variable twice": (["plot", "{f}", "--vars", "x,x", "-o", "{d}/o.png"], ["must differ"]),
    "plot unknown variable": (["plot", "{f}", "--vars", "x,nope", "-o", "{d}/o.png"], ["nope"]),
    "plot into a missing folder": (["plot", "{f}", "--vars", "x,y", "-o", "{d}/no/such/dir/o.png"], ["cannot write"]),
    "plot missing file": (["plot", "{d}/none.json", "--vars", "x,y", "-o", "{d}/o.png"], ["none.json"]),
    "replay delay nan": (["replay", "{f}", "--html", "{d}/o.html", "--delay", "nan"], ["--delay"]),
    "replay delay negative": (["replay", "{f}", "--html", "{d}/o.html", "--delay", "-1"], ["--delay"]),
    "replay delay zero": (["replay", "{f}", "--html", "{d}/o.html", "--delay", "0"], ["--delay"]),
    "replay cycles negative": (["replay", "{f}", "--cycles", "-1"], ["--cycles"]),
    "replay missing file": (["replay", "{d}/none.json", "--html", "{d}/o.html"], ["none.json"]),
}


@pytest.mark.parametrize("case", sorted(PICTURE_ARGS))
def test_picture_arguments(capsys, tmp_path, good_result, case):
    args, words = PICTURE_ARGS[case]
    assert_rejected(capsys, [a.format(f=good_result, d=tmp_path) for a in args], *words)


def test_replay_of_an_unknown_robot(capsys, tmp_path):
    f = tmp_path / "r.json"
    f.write_text(json.dumps(_result(source={"kind": "ik", "robot": "no_such_robot_xyz"})))
    assert_rejected(capsys, ["replay", f, "--html", tmp_path / "o.html"], "no_such_robot_xyz")


# ------------------------------------------------------------------------------------------------
# --poses: a bad line costs its own answer only (exit 5, an error record, the others answered)
# ------------------------------------------------------------------------------------------------
BAD_LINES = {
    "six numbers": ("0.3 0.2 0.4 0 0 1", "7 numbers"),
    "eight numbers": ("0.3 0.2 0.4 0 0 0 1 5", "7 numbers"),
    "a word": ("0.3 0.2 0.4 zero 0 0 1", "not a list of numbers"),
    "nan": ("0.3 nan 0.4 0 0 0 1", "non-finite"),
    "non-unit quaternion": ("0.3 0.2 0.4 0 0 0 3", "quaternion"),
}


@pytest.mark.parametrize("case", sorted(BAD_LINES))
def test_poses_bad_line(capsys, tmp_path, case):
    line, words = BAD_LINES[case]
    good = pin.SE3ToXYZQUAT(pin.XYZQUATToSE3(np.array([0.3, 0.2, 0.4, 0, 1, 0, 0.0])))
    f = tmp_path / "poses.txt"
    f.write_text(f"# two poses\n{line}\n{' '.join(map(str, good))}\n")
    code, out, err = run(capsys, [*IK, "--poses", f, "--json", "--quiet", "--time-limit", "120"])
    assert code == 5, err
    bad, ok = [json.loads(x) for x in out.splitlines()]
    assert bad == {"line": 2, "error": bad["error"]} and words in bad["error"]
    assert ok["line"] == 3 and ok["complete"] and ok["solutions"]
    model = kinbox.load("ur5").model
    data = model.createData()
    for s in ok["solutions"]:  # no wrong answer: each solution puts tool0 at the pose
        pin.framesForwardKinematics(model, data, np.array(s["q"]))
        M = data.oMf[model.getFrameId("tool0")]
        assert np.allclose(pin.SE3ToXYZQUAT(M)[:3], good[:3], atol=1e-9)
    lines = err.splitlines()
    assert len(lines) == 1 and "line 2" in lines[0] and words in lines[0] and "exit status 5" in lines[0]


def test_poses_file_binary(capsys, tmp_path):
    f = tmp_path / "poses.txt"
    f.write_bytes(bytes(random.Random(5).randrange(128, 256) for _ in range(500)))
    assert_rejected(capsys, [*IK, "--poses", f], "poses.txt", "UTF-8")


def test_poses_file_too_large(capsys, tmp_path):
    f = tmp_path / "poses.txt"
    sparse_file(f, 17 * 2**20)
    assert_rejected(capsys, [*IK, "--poses", f], "poses.txt", "limit")


# ------------------------------------------------------------------------------------------------
# the Python API
# ------------------------------------------------------------------------------------------------
GOOD = [0.3, 0.2, 0.4, 0, 1, 0, 0]
API = {
    "ik pose a string": (lambda: kinbox.ik("ur5", "tool0", "0.3 0.2 0.4 0 1 0 0"), ["pose"]),
    "ik pose a dict": (lambda: kinbox.ik("ur5", "tool0", {"x": 0.3}), ["pose"]),
    "ik pose of six numbers": (lambda: kinbox.ik("ur5", "tool0", GOOD[:6]), ["7 numbers"]),
    "ik pose nan": (lambda: kinbox.ik("ur5", "tool0", [0.3, float("nan"), 0.4, 0, 1, 0, 0]), ["non-finite"]),
    "ik frame None": (lambda: kinbox.ik("ur5", None, GOOD), ["frame"]),
    "ik frame a number": (lambda: kinbox.ik("ur5", 3, GOOD), ["frame"]),
    "ik frame world": (lambda: kinbox.ik("ur5", "world", GOOD), ["no joint"]),
    "ik robot None": (lambda: kinbox.ik(None, "tool0", GOOD), ["load()"]),
    "ik robot a float": (lambda: kinbox.ik(3.5, "tool0", GOOD), ["load()"]),
    "ik lock a string": (lambda: kinbox.ik("ur5", "tool0", GOOD, lock={"elbow_joint": "x"}), ["elbow_joint"]),
    "ik time limit negative": (lambda: kinbox.ik("ur5", "tool0", GOOD, time_limit=-1), ["time_limit"]),
    "ik max boxes zero": (lambda: kinbox.ik("ur5", "tool0", GOOD, max_boxes=0), ["max_boxes"]),
    "ik max boxes a bool": (lambda: kinbox.ik("ur5", "tool0", GOOD, max_boxes=True), ["max_boxes"]),
    "ik max boxes a float": (lambda: kinbox.ik("ur5", "tool0", GOOD, max_boxes=10.5), ["max_boxes"]),
    "ik time limit a string": (lambda: kinbox.ik("ur5", "tool0", GOOD, time_limit="5"), ["time_limit"]),
    "ik sigma nan": (lambda: kinbox.ik("ur5", "tool0", GOOD, sigma=float("nan")), ["sigma"]),
    "ik memory budget zero": (lambda: kinbox.ik("ur5", "tool0", GOOD, max_memory=0), ["max_memory"]),
    "ik workers a string": (lambda: kinbox.ik("ur5", "tool0", GOOD, workers="2"), ["workers"]),
    "pose_at of two values": (lambda: kinbox.IK("ur5", "tool0").pose_at([0.1, 0.2]), ["got 2"]),
    "pose_at of words": (lambda: kinbox.IK("ur5", "tool0").pose_at(["a", "b"]), ["numbers"]),
    "solve unknown name": (lambda: kinbox.solve("no_such_mechanism"), ["no_such_mechanism"]),
    "solve set nan": (lambda: kinbox.solve("four-bar", set={"crank": float("nan")}), ["crank"]),
    "solve legs bogus": (lambda: kinbox.solve("four-bar", legs="bogus"), ["legs"]),
    "solve_system rho above 1": (lambda: kinbox.solve_system(_small_system(), rho=2.0), ["rho"]),
    "solve_system lp_rounds zero": (lambda: kinbox.solve_system(_small_system(), lp_rounds=0), ["lp_rounds"]),
    "load an empty string": (lambda: kinbox.load(""), ["empty"]),
    "load a list": (lambda: kinbox.load([1, 2]), ["load()"]),
    "load a dict without kind": (lambda: kinbox.load({"ground": 3}), ["kind"]),
    "state of a text file": (lambda: SearchState.load(__file__), ["not a kinbox search state"]),
}


def _small_system():
    from kinbox.formulation.system import System

    s = System()
    x = s.add_var("x", -2, 2)
    s.add_eq(x * x - 1)
    return s


@pytest.mark.parametrize("case", sorted(API))
def test_python_api(case):
    call, words = API[case]
    with pytest.raises(KinboxError) as e:
        call()
    msg = str(e.value)
    assert "\n" not in msg
    for w in words:
        assert w.lower() in msg.lower(), (w, msg)


def test_python_api_unknown_option_is_a_type_error():
    with pytest.raises(TypeError, match="frobnicate"):
        kinbox.ik("ur5", "tool0", GOOD, frobnicate=1)
