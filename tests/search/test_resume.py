"""Stopping a search and going on with it: a budget, Ctrl-C or SIGTERM stops the search
between two boxes; ``--save`` writes where it stood, ``--resume`` goes on from there, and the
resumed search ends exactly as one that never stopped (same boxes, same counts, same answer).
Serial and parallel searches share the state, so either can go on with the other's."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import kinbox
from kinbox.cli import main
from kinbox.formulation.build import formulate
from kinbox.model.loading import load
from kinbox.pipeline import solve_system
from kinbox.search import interrupt
from kinbox.search.state import SearchState
from kinbox.search.status import BoxStatus, Status
from tests.support import paths as PATHS

REFERENCE = PATHS.DATA / "reference"
COUNTS = ("boxes", "empty", "split", "solutions", "certified", "lps", "krawczyk", "waves", "max_pending")


@pytest.fixture(scope="module")
def six_r():
    return formulate(load("general-6r")).system


@pytest.fixture(scope="module")
def six_r_once(six_r):
    r = solve_system(six_r, progress=False)
    assert r.complete and len(r.certified) == 16 and r.state is None and r.pending == []
    return r


def tree(r):
    """The solution boxes in the order found (the search's own order, the same on every run)."""
    return [(tuple(b.lo), tuple(b.hi), b.certified, tuple(b.x)) for b in r.boxes]


def assert_same_search(r, once):
    assert r.complete and r.message == once.message
    assert tree(r) == tree(once)
    for k in COUNTS:
        assert r.stats[k] == once.stats[k], k


@pytest.mark.parametrize("cut", [1, 2, 37, 150])
def test_stopped_and_resumed_is_one_search(tmp_path, six_r, six_r_once, cut):
    """Stopped after ``cut`` boxes (in the middle of a wave, or at its start), saved to a file,
    loaded and resumed: the same search as one that never stopped."""
    first = solve_system(six_r, progress=False, max_boxes=cut)
    assert not first.complete and "box budget" in first.message and first.stats["boxes"] == cut
    assert len(first.pending) == len(first.state.pending) > 0
    path = first.state.save(tmp_path / "state.npz")
    r = solve_system(six_r, progress=False, resume=SearchState.load(path))
    assert_same_search(r, six_r_once)


def test_stopped_twice(six_r, six_r_once):
    a = solve_system(six_r, progress=False, max_boxes=40)
    b = solve_system(six_r, progress=False, max_boxes=60, resume=a.state)
    assert not b.complete and b.stats["boxes"] == 100  # the budget counts this run's boxes
    assert_same_search(solve_system(six_r, progress=False, resume=b.state), six_r_once)


def test_parallel_and_serial_resume_each_other(six_r, six_r_once):
    a = solve_system(six_r, progress=False, max_boxes=70, workers=2)
    assert not a.complete and a.stats["boxes"] == 70
    assert_same_search(solve_system(six_r, progress=False, resume=a.state), six_r_once)
    b = solve_system(six_r, progress=False, max_boxes=90)
    assert_same_search(solve_system(six_r, progress=False, resume=b.state, workers=2), six_r_once)


def test_stop_request_stops_between_boxes(six_r, six_r_once):
    """:func:`interrupt.request` (what Ctrl-C does in the command line) stops the search at its
    next box with what it found; the state goes on to the same end."""
    stopped = []

    def later(stats):  # from the parallel master's callback: as a signal handler would
        if stats["boxes"] >= 50 and not stopped:
            interrupt.request("interrupted by test")
            stopped.append(stats["boxes"])

    from kinbox.search.parallel import solve_parallel
    from kinbox.search.solver import make_options

    try:
        a = solve_parallel(six_r, make_options(progress=False), workers=2, callback=later)
    finally:
        interrupt.clear()
    assert stopped and not a.complete and a.message == "interrupted by test" and a.status == Status.INTERRUPTED
    assert all(np.all(lo <= hi) for lo, hi in a.pending)
    assert_same_search(solve_system(six_r, progress=False, resume=a.state), six_r_once)


def test_time_limit_counts_from_started(six_r):
    """``started`` puts the origin of the time limit before the search (the command line: at
    its start, so that loading and formulating count): a limit already spent stops the search
    before its first box, with the whole domain pending."""
    r = solve_system(six_r, progress=False, time_limit=1.0, started=time.perf_counter() - 5.0)
    assert not r.complete and "time limit" in r.message and r.stats["boxes"] == 0 and r.status is Status.TIME_LIMIT
    lo0, hi0 = six_r.search_domain()
    assert len(r.pending) == 1 and np.array_equal(r.pending[0][0], lo0) and np.array_equal(r.pending[0][1], hi0)


def test_memory_budget(six_r):
    r = solve_system(six_r, progress=False, max_memory=20_000.0)
    assert not r.complete and "memory budget" in r.message and r.pending and r.status is Status.MEMORY_BUDGET


# ------------------------------------------------------------------------------------------------
# the command line: --save, --resume, Ctrl-C, SIGTERM
# ------------------------------------------------------------------------------------------------
def test_cli_save_and_resume(capsys, tmp_path):
    state = tmp_path / "s.npz"
    assert main(["solve", "general-6r", "--json", "--max-boxes", "60", "--save", str(state)]) == 4
    out, err = capsys.readouterr()
    d = json.loads(out)
    assert d["complete"] is False and "box budget of 60" in d["message"]
    assert SearchState.load(state).stats["boxes"] == 60
    assert len(err.splitlines()) == 1 and "--resume" in err and "exit status 4" in err and state.is_file()
    assert main(["solve", "general-6r", "--json", "--resume", str(state)]) == 0
    resumed = json.loads(capsys.readouterr().out)
    assert main(["solve", "general-6r", "--json"]) == 0
    once = json.loads(capsys.readouterr().out)
    assert resumed["complete"] and len(resumed["solutions"]) == 16
    assert [s["q"] for s in resumed["solutions"]] == [s["q"] for s in once["solutions"]]
    for k in ("boxes", "lps", "krawczyk", "empty", "split"):
        assert resumed["stats"][k] == once["stats"][k], k


def kinbox_process(*args, **kw) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "kinbox.cli", *map(str, args)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        **kw,
    )


def stop_after_progress(p: subprocess.Popen, sig: int, lines: int = 2, solutions: int = 0) -> tuple[str, str]:
    """Send ``sig`` once the search has reported progress ``lines`` times, the last time with at
    least ``solutions`` solutions (counted, not timed: how far a search gets in a second depends
    on the machine's load); its output."""
    seen = 0
    while True:
        line = p.stderr.readline()
        assert line, f"the search ended before it could be stopped (exit {p.wait()})"
        if line.startswith("kinbox:") and "boxes" in line:
            seen += 1
            found = re.search(r"(\d+) solutions", line)
            if seen >= lines and (found is not None and int(found.group(1)) >= solutions):
                break
    os.kill(p.pid, sig)
    out, err = p.communicate(timeout=120)
    return out, err


@pytest.mark.parametrize("sig, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
@pytest.mark.slow
def test_cli_signal_prints_the_answer_so_far(tmp_path, sig, code):
    """Ctrl-C or SIGTERM during a search: the answer so far, in full and marked incomplete, on
    stdout; exit 130 or 143; with --save the state, which goes on (here for a few boxes)."""
    state = tmp_path / "s.npz"
    p = kinbox_process("solve", "dietmeier", "--json", "--progress", "--save", state)
    out, err = stop_after_progress(p, sig)
    assert p.returncode == code, err
    d = json.loads(out)
    name = signal.Signals(sig).name
    assert d["complete"] is False and d["message"] == f"interrupted by {name}"
    assert d["stats"]["boxes"] > 0 and all(s["certified"] for s in d["solutions"])
    assert f"exit status {code}" in err.splitlines()[-1] and state.is_file()
    before = SearchState.load(state)
    assert before.stats["boxes"] == d["stats"]["boxes"] and before.pending
    q = subprocess.run(
        [sys.executable, "-m", "kinbox.cli", "solve", "dietmeier", "--json", "--quiet", "--resume", str(state), "--max-boxes", "50"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert q.returncode == 4, q.stderr
    assert json.loads(q.stdout)["stats"]["boxes"] == d["stats"]["boxes"] + 50


def test_cli_signal_outside_a_search(capsys, monkeypatch):
    """A signal while loading (no search yet) stops at once: exit 130, one line."""
    import kinbox.problems.ik

    def load_slowly(*a, **k):
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(5)
        raise AssertionError("not stopped")

    monkeypatch.setattr(kinbox.problems.ik, "load", load_slowly)
    assert main(["ik", "ur5", "--frame", "tool0", "--pose", "0.3", "0.2", "0.4", "0", "0", "0", "1"]) == 130
    out, err = capsys.readouterr()
    assert out == "" and err.strip() == "kinbox: interrupted by SIGINT"


def test_cli_internal_error_is_status_3(capsys, monkeypatch):
    import kinbox.problems.mechanism

    def bug(*a, **k):
        raise ZeroDivisionError("a planted bug")

    monkeypatch.setattr(kinbox.problems.mechanism, "load", bug)
    assert main(["solve", "four-bar"]) == 3
    out, err = capsys.readouterr()
    assert out == "" and len(err.splitlines()) == 1 and "internal error: ZeroDivisionError: a planted bug" in err
    with pytest.raises(ZeroDivisionError):
        main(["--debug", "solve", "four-bar"])


# ------------------------------------------------------------------------------------------------
# the published problem: Dietmeier's 40 assembly modes, interrupted and resumed
# ------------------------------------------------------------------------------------------------
@pytest.mark.slow  # two searches of Dietmeier's platform, about a minute of CPU
def test_dietmeier_interrupted_and_resumed_gives_the_40_of_one_run(tmp_path):
    once = kinbox.solve("dietmeier", progress=False)
    expected = json.loads((REFERENCE / "dietmeier_66.json").read_text())["expected"]["real_solutions"]
    assert once.complete and len(once.solutions) == expected == 40 and all(s.certified for s in once.solutions)
    state = tmp_path / "dietmeier.npz"
    p = kinbox_process("solve", "dietmeier", "--json", "--progress", "--save", state)
    out, err = stop_after_progress(p, signal.SIGINT, lines=5, solutions=1)
    assert p.returncode == 130, err
    partial = json.loads(out)
    assert partial["complete"] is False and 0 < len(partial["solutions"]) < 40
    q = subprocess.run(
        [sys.executable, "-m", "kinbox.cli", "solve", "dietmeier", "--json", "--quiet", "--resume", str(state)],
        capture_output=True,
        text=True,
        timeout=1800,
    )
    assert q.returncode == 0, q.stderr
    resumed = json.loads(q.stdout)
    assert resumed["complete"] and len(resumed["solutions"]) == 40
    assert all(s["certified"] for s in resumed["solutions"])
    assert np.allclose(np.array([s["q"] for s in resumed["solutions"]]), np.array([s.q for s in once.solutions]), atol=1e-10)
    for k in ("boxes", "lps", "krawczyk", "empty", "split"):
        assert resumed["stats"][k] == once.stats[k], k


def test_a_box_within_a_roots_resolution_keeps_its_root_through_save_and_load(tmp_path, six_r):
    """``SolutionBox.within_resolution_of`` (the root the answer files the box with) survives a
    saved search; boxes without one load without one."""
    first = solve_system(six_r, progress=False, max_boxes=150)
    boxes = first.state.boxes
    assert len(boxes) >= 2
    root = np.arange(six_r.n, dtype=float) / 7.0
    boxes[0].within_resolution_of = root
    loaded = SearchState.load(first.state.save(tmp_path / "state.npz")).boxes
    assert np.array_equal(loaded[0].within_resolution_of, root)
    assert all(b.within_resolution_of is None for b in loaded[1:])


def test_curve_boxes_keep_their_flag_through_save_and_load(tmp_path, six_r):
    """A curve box's status (``SolutionBox.curve``: the answer searches a curve box again if it finds no curve there)
    survives a saved search; a state written before the flag existed takes its uncertified
    boxes wider than sigma for its curve boxes, as the answer did then."""
    first = solve_system(six_r, progress=False, max_boxes=150)
    boxes = first.state.boxes
    assert len(boxes) >= 3
    boxes[0].status = BoxStatus.CURVE
    path = first.state.save(tmp_path / "state.npz")
    loaded = SearchState.load(path).boxes
    assert [b.curve for b in loaded] == [True] + [False] * (len(boxes) - 1)

    sigma = float(first.state.options["sigma"])
    boxes[1].status, boxes[1].hi = BoxStatus.UNCERTIFIED, boxes[1].lo + 2.0 * sigma  # wide, uncertified
    boxes[2].status, boxes[2].hi = BoxStatus.UNCERTIFIED, boxes[2].lo + 0.5 * sigma  # narrow, uncertified
    first.state.save(path)
    with np.load(path) as z:
        old = {k: z[k] for k in z.files if k != "sol_curve"}
    np.savez(path, **old)
    loaded = SearchState.load(path).boxes
    assert [b.curve for b in loaded] == [False, True] + [False] * (len(boxes) - 2)


def test_a_state_whose_policy_has_a_rule_since_removed_still_loads(tmp_path, six_r):
    """Policy fields a later kinbox dropped (``lp_yields_to_krawczyk``, ``k_settled``) are left
    out when an older state is loaded; the fields it still has keep their saved values."""
    first = solve_system(six_r, progress=False, max_boxes=150)
    path = first.state.save(tmp_path / "state.npz")
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    header = json.loads(str(arrays["header"]))
    header["policy"].update(lp_yields_to_krawczyk=True, k_settled=0.7)
    arrays["header"] = np.array(json.dumps(header))
    np.savez(path, **arrays)
    loaded = SearchState.load(path)
    assert loaded.policy == first.state.policy


# ------------------------------------------------------------------------------------------------
# a saved search goes on only under the options that shaped its tree
# ------------------------------------------------------------------------------------------------
def _other_value(name: str, value):
    """A value of option ``name`` other than ``value``, in its range."""
    import dataclasses

    from kinbox.search.options import SolverOptions

    field = next(f for f in dataclasses.fields(SolverOptions) if f.name == name)
    if field.metadata.get("choices"):
        return next(c for c in field.metadata["choices"] if c != value)
    if isinstance(value, bool):
        return not value
    if isinstance(value, int):
        return value + 1
    if isinstance(value, str):  # a list of names: the steps of the sequence
        from kinbox.search.steps import SEQUENCE

        return ",".join(n for n in SEQUENCE if n not in value.split(","))
    return value / 2


def test_only_budgets_and_display_are_left_out_of_the_tree_options():
    """Every option shapes the tree unless it is a budget, a clock or the progress display: a
    field added to SolverOptions without the mark (``options.tree``) fails here until it is
    marked or named below."""
    import dataclasses

    from kinbox.search.options import TREE_OPTIONS, SolverOptions
    from kinbox.search.state import TREE_OPTIONS as CHECKED

    assert CHECKED == TREE_OPTIONS
    names = {f.name for f in dataclasses.fields(SolverOptions)}
    assert names - set(TREE_OPTIONS) == {"max_boxes", "time_limit", "max_memory", "started", "progress"}
    assert "relaxation" in TREE_OPTIONS


@pytest.fixture(scope="module")
def linear_state(six_r):
    first = solve_system(six_r, progress=False, max_boxes=40, relaxation="linear")
    assert not first.complete and first.state is not None
    return first.state


def test_every_tree_option_is_checked_on_resume(six_r, linear_state):
    """Resuming under another value of any option that shapes the tree is refused with one line
    naming the option and both values; the same options resume."""
    from kinbox.errors import InputError
    from kinbox.search.options import TREE_OPTIONS

    saved = dict(linear_state.options)
    assert saved["relaxation"] == "linear"
    for name in TREE_OPTIONS:
        other = _other_value(name, saved[name])
        with pytest.raises(InputError) as e:
            solve_system(six_r, progress=False, resume=linear_state, **{**saved, name: other})
        msg = str(e.value)
        assert "\n" not in msg and f"{name} {saved[name]!r} (now {other!r})" in msg, msg
    r = solve_system(six_r, progress=False, resume=linear_state, max_boxes=5, **saved)
    assert r.stats["boxes"] == 45


def test_a_state_that_does_not_record_a_tree_option_is_not_resumed(tmp_path, six_r, linear_state):
    """A state whose header lacks a tree option (written before the option was recorded) cannot
    promise the same tree: refused, naming the option."""
    from kinbox.errors import InputError

    path = linear_state.save(tmp_path / "state.npz")
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    header = json.loads(str(arrays["header"]))
    del header["options"]["relaxation"]
    arrays["header"] = np.array(json.dumps(header))
    np.savez(path, **arrays)
    with pytest.raises(InputError, match=r"relaxation not recorded \(now 'linear'\)"):
        solve_system(six_r, progress=False, resume=SearchState.load(path), relaxation="linear")


def test_cli_refuses_a_resume_under_another_relaxation(capsys, tmp_path):
    state = tmp_path / "s.npz"
    args = ["solve", "general-6r", "--json", "--quiet", "--max-boxes", "30", "--save", str(state)]
    assert main([*args, "--relaxation", "linear"]) == 4 and state.is_file()
    capsys.readouterr()
    code = main(["solve", "general-6r", "--json", "--quiet", "--resume", str(state), "--relaxation", "bernstein"])
    out, err = capsys.readouterr()
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("kinbox: error: ") and "relaxation 'linear' (now 'bernstein')" in err, err
    assert main(["solve", "general-6r", "--json", "--quiet", "--resume", str(state), "--relaxation", "linear"]) == 0
