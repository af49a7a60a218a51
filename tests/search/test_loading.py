"""The search reports the time it spent loading compiled kernels apart (kinbox.search.loading)."""

import json
import subprocess
import sys
import threading

import numba
import pytest

from kinbox.search.loading import load_clock

README_Q = "0.3,-1.2,1.5,-0.8,1.2,0.4"


def fresh_kernel():
    """A kernel numba has not compiled yet (no cache): its first call holds the compiler lock."""

    @numba.njit
    def add_one(x):
        return x + 1.0

    return add_one


def test_the_clock_counts_a_compilation_in_its_thread_only():
    f, g = fresh_kernel(), fresh_kernel()
    with load_clock() as clock:
        assert f(1.0) == 2.0
    assert clock.seconds > 0.0  # compiling even this takes milliseconds
    with load_clock() as clock:
        assert f(2.0) == 3.0  # compiled already: no lock taken
        other = threading.Thread(target=g, args=(1.0,))
        other.start()
        other.join()
    assert clock.seconds == 0.0


def test_a_search_after_loading_reports_no_loading():
    import kinbox
    from kinbox.pipeline import load_kernels

    load_kernels()
    res = kinbox.solve("general-6r")
    assert res.stats["load_seconds"] == 0.0
    assert "loading compiled kernels" not in res.table()


@pytest.mark.parametrize("fmt", ["json", "table"])
def test_a_fresh_process_says_what_loading_took(fmt):
    """A one-pose ``kinbox ik`` (no time limit: kernels load at their first call, inside the
    search) reports the loading as part of its seconds, and says so."""
    args = [sys.executable, "-m", "kinbox.cli", "ik", "ur5", "--frame", "tool0", "--from-q", README_Q, "--quiet"]
    p = subprocess.run([*args, *(["--json"] if fmt == "json" else [])], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    if fmt == "json":
        st = json.loads(p.stdout)["stats"]
        assert 0.0 < st["load_seconds"] <= st["seconds"]
    else:
        assert "s of it loading compiled kernels, once per process)" in p.stdout.splitlines()[-1]


KERNEL_MODULE = """
import numba


@numba.njit(cache=True)
def twice(x):
    return 2.0 * x
"""


def test_kernels_cached_sees_every_kernel(tmp_path, monkeypatch):
    """A module's numba function that was never compiled makes ``kernels_cached`` False (a time
    limit's clock then waits for the compilation); compiled and cached, True. The search's own
    modules are all cached once ``load_kernels`` has run: no kernel of theirs is left out of it."""
    import importlib

    from kinbox.search import solver
    from kinbox.search.loading import kernels_cached

    (tmp_path / "kinbox_probe_kernels.py").write_text(KERNEL_MODULE)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    mod = importlib.import_module("kinbox_probe_kernels")
    assert kernels_cached((mod,)) is False
    assert mod.twice(2.0) == 4.0
    assert kernels_cached((mod,)) is True
    solver.load_kernels()
    assert kernels_cached() is True


def test_a_time_limit_with_a_warm_cache_loads_no_kernel_ahead():
    """With the kernels cached, ``compile_kernels`` (what runs before a time limit's clock)
    loads none of them: each loads when the problem first calls it."""
    from kinbox.search import solver

    solver.load_kernels()  # the cache is warm (compiled here if it was not)
    code = (
        "import kinbox.pipeline as p; from kinbox.search import certify, propagate, transverse; p.compile_kernels(); "
        "print(sum(len(k.overloads) for k in (propagate._contract, certify._newton_kernel, transverse._slice_kernel)))"
    )
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    assert p.stdout.split() == ["0"]
