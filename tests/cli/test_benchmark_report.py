"""benchmarks/report.py: the benchmark page holds the latest run of each benchmark, once, with
its machine and calibration, and is written again (never prepended to) on every run."""

from __future__ import annotations

import functools
import importlib.util
import json
import re
import sys

import pytest

from tests.support import paths as PATHS

ROOT = PATHS.ROOT


@functools.cache
def _report():
    """benchmarks/report.py (outside the package) as a module."""
    spec = importlib.util.spec_from_file_location("kinbox_bench_report", ROOT / "benchmarks" / "report.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # its dataclasses look their module up
    spec.loader.exec_module(mod)
    return mod


SUITE_ROW = dict(
    problem="general-6r", sigma=1e-4, solutions=16, expected="16", certified=16, max_residual=5e-16, complete=True,
    boxes=187, lps=20, cpu_seconds=0.1, peak_mb=300.0, curves=0, kernel_load=0.4,
)  # fmt: skip


def test_a_run_replaces_its_table_and_keeps_the_others(tmp_path):
    report = _report()
    raw, page = tmp_path / "b.json", tmp_path / "b.md"
    report.record("suite", [SUITE_ROW], calibration=0.5, mode="quick", raw=raw, page=page)
    row = dict(
        problem="viviani", run="serial", wall=9.3, speedup=1.0, cpu=9.9, cores_used=1.06, boxes=5179,
        same_as_serial=True, identical_boxes=True, load_before=0.8,
    )  # fmt: skip
    report.record("parallel", [row], calibration=0.6, raw=raw, page=page)
    report.record("suite", [{**SUITE_ROW, "boxes": 190}], calibration=0.7, mode="quick", raw=raw, page=page)
    text = page.read_text()
    assert text.count("## The benchmark suite") == 1 and text.count("## Parallel search") == 1
    assert "| 190 |" in text and "| 187 |" not in text  # the latest run only
    assert "calibration (1e7 pure-Python additions): 0.70 s CPU" in text and "0.60 s CPU" in text
    assert not re.search(r"20\d\d-\d\d-\d\d", text)  # no dated section
    data = json.loads(raw.read_text())
    assert set(data) == {"suite", "parallel"} and data["suite"]["rows"][0]["boxes"] == 190
    assert data["suite"]["machine"]["cores"] >= 1


def test_an_unknown_benchmark_is_refused(tmp_path):
    with pytest.raises(KeyError, match="no Table entry"):
        _report().record("nope", [], calibration=0.1, raw=tmp_path / "b.json", page=tmp_path / "b.md")
    assert not (tmp_path / "b.json").exists()


def test_the_page_in_the_repository_is_the_one_its_json_gives():
    report = _report()
    assert (ROOT / "docs" / "benchmarks.md").read_text() == report.render(report.load_raw(ROOT / "docs" / "benchmarks.json"))


def test_calibration_is_cpu_seconds_of_the_fixed_loop():
    assert _report().calibrate(100_000) > 0.0
