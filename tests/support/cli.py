"""Running ``kinbox`` in a test: in this process or as a subprocess, one-line errors, UR5 forward kinematics."""

from __future__ import annotations

import contextlib
import io
import os
import subprocess
import sys

import numpy as np
import pinocchio as pin

from kinbox.cli import main
from tests.support.oracles.ur_ik import load_model


def kinbox_process(*args, timeout: float = 600, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "kinbox.cli", *map(str, args)], capture_output=True, text=True, timeout=timeout, cwd=cwd)


def kinbox_cli(*args, timeout: float = 600, cwd=None) -> subprocess.CompletedProcess:
    """``kinbox ARGS`` run by ``kinbox.cli.main`` in this process: status, stdout and stderr as
    a subprocess would give them (``timeout`` is the subprocess's; here the tests' own)."""
    argv = [str(a) for a in args]
    out, err = io.StringIO(), io.StringIO()
    old = os.getcwd()
    try:
        if cwd is not None:
            os.chdir(cwd)
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = main(argv)
            except SystemExit as e:  # argparse and the signal paths exit
                code = e.code if isinstance(e.code, int) else (0 if e.code is None else 2)
    finally:
        os.chdir(old)
    return subprocess.CompletedProcess(["kinbox", *argv], code, out.getvalue(), err.getvalue())


def assert_usage_error(p: subprocess.CompletedProcess, *words: str) -> str:
    """Exit 2, one stderr line ``kinbox: error: ...`` (mentioning ``words``), no traceback."""
    lines = p.stderr.splitlines()
    assert p.returncode == 2, (p.returncode, p.stderr)
    assert "Traceback" not in p.stderr and "Traceback" not in p.stdout
    assert len(lines) == 1, f"expected one line on stderr, got {len(lines)}:\n{p.stderr}"
    assert lines[0].startswith("kinbox: error:"), lines[0]
    for w in words:
        assert w.lower() in lines[0].lower(), (w, lines[0])
    assert p.stdout == ""
    return lines[0]


_UR5 = None


def ur5_model():
    global _UR5
    if _UR5 is None:
        _UR5 = load_model("ur5")
    return _UR5


def tool0(q) -> pin.SE3:
    m = ur5_model()
    d = m.createData()
    pin.forwardKinematics(m, d, np.asarray(q, float))
    return pin.SE3(pin.updateFramePlacement(m, d, m.getFrameId("tool0")))


def pose_error(M: pin.SE3, goal: pin.SE3) -> float:
    return max(float(np.linalg.norm(M.translation - goal.translation)), float(np.linalg.norm(pin.log3(goal.rotation.T @ M.rotation))))
