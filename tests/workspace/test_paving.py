"""The paving loop (kinbox.workspace.paving.pave): the top of the tree wave by wave, then one
task per subtree. Whatever the cut between the two, the leaves are the same boxes with the same
verdicts; in one cut, serial and local processes give the same paving box for box and in the
same order; a budget stopping a subtree task leaves pending boxes whose paving completes it."""

from __future__ import annotations

import numpy as np
import pytest

from kinbox.workspace import Paving, paving, reach_platform

KW = {"legs": (10.0, 22.0), "region": (-15, -15, 35, 35), "resolution": 1.0}


def _sorted(pv: Paving) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    key = np.lexsort(np.hstack([pv.lo, pv.hi]).T)
    return pv.lo[key], pv.hi[key], pv.verdict[key]


def _equal(a: Paving, b: Paving) -> bool:
    return bool(
        np.array_equal(a.lo, b.lo)
        and np.array_equal(a.hi, b.hi)
        and np.array_equal(a.verdict, b.verdict)
        and np.array_equal(a.witness, b.witness, equal_nan=True)
    )


@pytest.mark.parametrize("tasks", [1, 8, 10**9])
def test_the_leaves_do_not_depend_on_where_subtrees_start(monkeypatch, tasks):
    monkeypatch.setattr(paving, "SUBTREE_TASKS", 64)
    ref = reach_platform("3-rpr", 0.4, **KW)
    monkeypatch.setattr(paving, "SUBTREE_TASKS", tasks)
    pv = reach_platform("3-rpr", 0.4, **KW)
    assert ref.complete and pv.complete
    assert ref.stats["subtrees"] >= 64 and (pv.stats.get("subtrees", 0) >= tasks) == (tasks < 10**6)
    assert all(np.array_equal(x, y) for x, y in zip(_sorted(ref), _sorted(pv)))
    assert len(set(ref.verdict.tolist())) == 3  # inside, outside and boundary boxes all met


def test_a_budget_stopping_inside_a_subtree_resumes_to_the_same_leaves(monkeypatch):
    monkeypatch.setattr(paving, "SUBTREE_TASKS", 2)
    whole = reach_platform("3-rpr", 0.4, **KW)
    part = reach_platform("3-rpr", 0.4, max_boxes=300, **KW)
    assert not part.complete and len(part.pending) > 1  # a subtree task stopped part way, and the next one
    assert part.stats["decided"] <= 300
    done = reach_platform("3-rpr", 0.4, resume=part, **KW)
    assert done.complete
    assert all(np.array_equal(x, y) for x, y in zip(_sorted(whole), _sorted(done)))


@pytest.mark.slow
def test_subtrees_over_two_processes_pave_as_serial(monkeypatch):
    monkeypatch.setattr(paving, "SUBTREE_TASKS", 16)
    serial = reach_platform("3-rpr", 0.4, **KW)
    two = reach_platform("3-rpr", 0.4, workers=2, **KW)
    assert serial.stats["subtrees"] >= 16 and _equal(serial, two)
