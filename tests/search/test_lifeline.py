"""Worker processes die with their master, whatever kills it: a search in a child
process is killed with SIGKILL (no clean-up runs) while its workers have batches, and every
process it had started (workers, fork server, resource tracker) must be gone moments later.
The processes are listed from /proc before the kill and looked for after it."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

from tests.support import paths as PATHS
from tests.support.proctree import command, descendants, wait_gone

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc; the kernel's parent-death signal is Linux's")
ROOT = PATHS.ROOT

MASTER = textwrap.dedent("""
    import sys
    import kinbox.search.parallel as par
    from kinbox.formulation.system import System
    from kinbox.search.solver import make_options

    method, spin = sys.argv[1], sys.argv[2] == "spin"
    s = System()
    x, y, z = s.add_var("x", -3, 3), s.add_var("y", -3, 3), s.add_var("z", -3, 3)
    s.add_eq(x * x + y * y + z * z - 4)
    s.add_eq((x - 1) * (x - 1) + y * y - 1)  # a curve: at sigma 1e-6, a search of minutes
    if spin:
        def explore(*a, **k):  # a worker stuck in C code that holds the GIL: no thread of it runs
            print("SPINNING", flush=True)
            sum(range(10**15))
        par.explore = explore
    said = []

    def ready(stats):
        if not said and stats["boxes"] >= 100:
            said.append(1)
            print("READY", flush=True)

    par.solve_parallel(s, make_options(lp=False, progress=False, sigma=1e-6), workers=2, start_method=method,
                       callback=ready)
""")


def kill_master_and_look(args, ready: str, kids_at_least: int = 2) -> tuple[list[int], list[int]]:
    """Start ``args`` (its own session), wait for the line ``ready`` on its stdout and for
    ``kids_at_least`` processes under it, list them, SIGKILL it; (processes it had started,
    those still alive 10 s later)."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT / "src"), str(ROOT)]))
    p = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=env, start_new_session=True)
    try:
        while True:
            line = p.stdout.readline()
            assert line, f"the master ended before it was ready (exit {p.wait()})"
            if line.strip() == ready or line.startswith(ready):
                break
        end = time.monotonic() + 30
        kids = descendants(p.pid)
        while len(kids) < kids_at_least and time.monotonic() < end:
            time.sleep(0.05)
            kids = descendants(p.pid)
        os.kill(p.pid, signal.SIGKILL)
        p.wait(timeout=30)
        left = wait_gone(kids, 10.0)
    finally:
        if p.poll() is None:
            p.kill()
    for pid in left:  # leave nothing behind, even when the test fails
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    return kids, left


@pytest.mark.parametrize("method", ["fork", "forkserver", "spawn"])
@pytest.mark.slow
def test_workers_die_with_a_killed_master(method):
    kids, left = kill_master_and_look([sys.executable, "-c", MASTER, method, "busy"], "READY")
    assert len(kids) >= 2, [command(k) for k in kids]  # the workers (and a fork server, a tracker)
    assert not left, [command(k) for k in left]


def test_a_worker_that_holds_the_gil_dies_with_the_master():
    """No Python code of that worker runs (its watch thread cannot): only the kernel's
    parent-death signal ends it. (Start method fork: the patched task reaches the worker.)"""
    kids, left = kill_master_and_look([sys.executable, "-c", MASTER, "fork", "spin"], "SPINNING")
    assert len(kids) >= 2
    assert not left, [command(k) for k in left]


@pytest.mark.slow
def test_cli_poses_batch_killed(tmp_path):
    """The case of the issue: ``kinbox ik ur5 --frame tool0 --poses FILE --workers 0`` killed
    with SIGKILL in the middle of its batch."""
    poses = tmp_path / "poses.txt"
    poses.write_text("".join("0.3 0.2 0.4 0 1 0 0\n0.35 0.1 0.3 0 1 0 0\n" for _ in range(100)))
    kids, left = kill_master_and_look(
        [sys.executable, "-m", "kinbox.cli", "ik", "ur5", "--frame", "tool0", "--poses", str(poses), "--workers", "0", "--json"],
        '{"line": 2',
    )
    assert len(kids) >= 2
    assert not left, [command(k) for k in left]


def test_cli_poses_over_workers_interrupted(tmp_path):
    """Ctrl-C (SIGINT) to ``kinbox ik --poses FILE --workers 2``: the lines answered so far are
    printed, in order, exit status 130, and the worker processes are gone."""
    import json

    poses = tmp_path / "poses.txt"
    poses.write_text("".join("0.3 0.2 0.4 0 1 0 0\n0.35 0.1 0.3 0 1 0 0\n" for _ in range(500)))
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT / "src"), str(ROOT)]))
    p = subprocess.Popen(
        [sys.executable, "-m", "kinbox.cli", "ik", "ur5", "--frame", "tool0", "--poses", str(poses), "--workers", "2", "--json", "--quiet"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        start_new_session=True,
    )
    try:
        first = p.stdout.readline()
        assert first.startswith('{"line": 1'), p.stderr.read()
        kids = descendants(p.pid)
        os.kill(p.pid, signal.SIGINT)
        rest = p.stdout.read()  # not communicate(): it would skip what readline has buffered
        err = p.stderr.read()
        p.wait(timeout=60)
    finally:
        if p.poll() is None:
            p.kill()
    assert p.returncode == 130, err
    lines = [json.loads(s)["line"] for s in [first, *rest.splitlines()]]
    assert lines == list(range(1, len(lines) + 1)) and len(lines) < 1000
    assert "interrupted by SIGINT" in err and "exit status 130" in err
    assert not wait_gone(kids, 10.0), [command(k) for k in kids]
