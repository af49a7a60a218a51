#!/usr/bin/env python3
"""The benchmark page: ``docs/benchmarks.md``, written from the raw results in ``docs/benchmarks.json``.

Each benchmark script ends with ``report.record(KEY, rows, calibration=c)``: that stores its rows in
``docs/benchmarks.json`` under ``KEY`` (replacing the rows of its last run, with the machine
and its calibration) and writes the page again from every entry of ``TABLES``. The page holds
current numbers only: one table per benchmark, the latest run of each; history is in git and
``CHANGELOG.md``.

    python benchmarks/report.py            # write docs/benchmarks.md again from docs/benchmarks.json
    python benchmarks/report.py --calibrate  # print this machine and its calibration

Adding a benchmark to the page: one ``Table`` entry in ``TABLES`` below (its key, title, the
command that runs it, and one function that turns a row of its JSON into the cells of the
columns); in the script, ``c = report.calibrate()`` at the start and
``report.record(key, rows, calibration=c)`` at the end.

Calibration: the CPU seconds of a fixed pure-Python loop of 1e7 additions, measured by the
benchmark script at the start of its run. The machine is often shared; compare numbers as
ratios within one table (one run), and across runs only with their calibrations beside them.
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import platform
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "benchmarks.md"
RAW = ROOT / "docs" / "benchmarks.json"

Row = dict[str, Any]


def machine() -> dict[str, Any]:
    """The CPU model (from /proc/cpuinfo where there is one), the core count and the Python."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version()}


def calibrate(n: int = 10_000_000) -> float:
    """CPU seconds (``time.process_time``) of a pure-Python loop of ``n`` additions."""
    c0 = time.process_time()
    s = 0
    for i in range(n):
        s += i
    assert s == n * (n - 1) // 2
    return time.process_time() - c0


def _yes(v: object) -> str:
    return "yes" if v else "NO"


# ---- one entry per benchmark ---------------------------------------------------------------


@dataclass(frozen=True)
class Table:
    """A benchmark on the page: ``cells(row)`` gives the cells of ``columns`` for one JSON row."""

    key: str
    title: str
    command: str
    columns: Sequence[str]
    cells: Callable[[Row], Sequence[object]]
    about: str = ""
    notes: Callable[[list[Row]], list[str]] = field(default=lambda rows: [])


SUITE_COLUMNS = [
    "problem",
    "sigma",
    "solutions (found)",
    "expected",
    "certified",
    "max residual",
    "complete",
    "boxes",
    "LPs",
    "CPU s",
    "peak MB",
]


def _suite_cells(r: Row) -> list[object]:
    if "error" in r:
        return [r.get("name", "?"), r.get("sigma", ""), f"error: {r['error']}", "", "", "", "", "", "", "", ""]
    found = r["solutions"] if not r["curves"] else f"{r['solutions']} + {r['curves']} curves"
    return [
        r["problem"],
        f"{r['sigma']:g}",
        found,
        r["expected"],
        r["certified"],
        f"{r['max_residual']:.1e}",
        _yes(r["complete"]),
        r["boxes"],
        r["lps"],
        f"{r['cpu_seconds']:.3f}",
        f"{r['peak_mb']:.0f}",
    ]


def _suite_notes(rows: list[Row], picture: str = "runtime_vs_error.png") -> list[str]:
    out = []
    t = [r["kernel_load"] for r in rows if "kernel_load" in r]
    if t:
        out.append(f"Loading every compiled kernel of the search, once per process, is timed apart: {min(t):.2f}-{max(t):.2f} s CPU.")
    opts = list(dict.fromkeys(f"{r['problem']}: {r['options']}" for r in rows if r.get("options")))
    if opts:
        out.append("Options: " + "; ".join(opts) + ".")
    dls = [f"{r['problem']}: {r['dls']}" for r in rows if r.get("dls")]
    if dls:
        out.append(
            "Pinocchio damped least squares from random restarts, until it has found the set kinbox "
            "returned (`benchmarks/dls_baseline.py`; a pose is incomplete if the restart budget ran out): " + "; ".join(dls) + "."
        )
    if (PAGE.parent / picture).exists():
        out.append(f"![CPU time against final error]({picture})")
    return out


def _constraints_cells(r: Row) -> list[object]:
    if "error" in r:
        return [r["problem"], r["formulation"], "-", "-", "-", "-", "-", f"error: {r['error']}", "-", "-", "-"]
    return [
        f"{r['problem']} ({r['what']})",
        r["formulation"],
        f"{r['variables']} / {r['equations']}",
        r["boxes"],
        r["lps"],
        f"{r['cpu']:.2f}",
        f"{r.get('diagnosis', 0.0):.2f}",
        f"{r['solutions']} ({r['certified']})",
        r["shapes"],
        r["curves"],
        _yes(r["complete"]),
    ]


def _parallel_cells(r: Row) -> list[object]:
    return [
        r["problem"],
        r["run"],
        f"{r['wall']:.2f}",
        f"{r['speedup']:.2f}x",
        f"{r['cpu']:.2f}",
        f"{r['cores_used']:.2f}",
        r["boxes"],
        f"{'yes' if r['same_as_serial'] else 'NO'} / {'yes' if r['identical_boxes'] else 'no'}",
        f"{r['load_before']:.2f}",
    ]


def _workspace_cells(r: Row) -> list[object]:
    c, v = r["counts"], r["volumes"]
    s = r.get("sampled")
    sampled = (
        f"{s['reached']} of {s['voxels']} voxel centres reached, {s['in_inside_box']} in inside boxes, {s['cpu_s']:.1f} s" if s else ""
    )
    chk = r.get("check_contradictions")
    return [
        r["case"],
        f"{r['resolution']:g}",
        "yes" if r["complete"] else "no",
        f"{c['inside']} / {c['outside']} / {c['boundary']}",
        f"{v['inside']:.4g} / {v['boundary']:.4g}",
        f"{r['cpu_s']:.2f}",
        "-" if chk is None else str(chk),
        sampled,
    ]


def _workspace_free_cells(r: Row) -> list[object]:
    if "speedup" in r:  # serial against Dask
        return [
            r["case"],
            f"{r['resolution']:g}",
            f"{r['boxes']} boxes",
            f"serial {r['serial_wall_s']:.1f} s wall, Dask {r['dask_wall_s']:.1f} s: {r['speedup']:.2f}x (load {r['load']:.1f})",
            "same paving" if r["same_paving"] else "DIFFERENT paving",
            "",
            "",
        ]
    v, th = r["volumes"], r["boundary_thickness"]
    return [
        r["case"],
        f"{r['resolution']:g}",
        f"{v['inside']:.4g} / {v['outside']:.4g} / {v['boundary']:.4g} m^3, {r['paving_cpu_s']:.0f} s CPU",
        f"{r['samples']:.0e} samples: {r['reached_volume']:.4g} m^3 reached ({r['reached_cells']} cells), {r['sampling_cpu_s']:.0f} s CPU",
        str(r["samples_in_outside_boxes"]),
        f"{r['reached_cells_in_inside_boxes']} of {r['reached_cells']}",
        f"max {th['max_run']}, {100 * th['share_at_most_2']:.0f} % of runs <= 2",
    ]


def _workspace_dask_cells(r: Row) -> list[object]:
    runs = r["runs"]

    def one(kind: str) -> str:
        xs = [x for x in runs if x["run"] == kind]
        if not xs:
            return "-"

        def cpu(x: Row) -> str:
            if kind == "serial":
                return f", {x['main_cpu_s']:.0f} s CPU"
            out = f", tasks {x['task_cpu_s']:.0f} s CPU, busiest process {x['max_process_cpu_s']:.0f} s"
            return out + (f", all processes {x['all_cpu_s']:.0f} s" if "all_cpu_s" in x else "")

        cells = "; ".join(f"{x['wall_s']:.0f} s wall{cpu(x)} (load {x['load_before']:.0f})" for x in xs)
        if kind == "serial" or f"{kind}_wall_ratio" not in r:
            return cells
        cells += f": {r[f'{kind}_wall_ratio']:.2f}x wall, {r[f'{kind}_ideal']:.2f}x ideal"
        if f"{kind}_two_core_bound" in r:
            cells += f", {r[f'{kind}_two_core_bound']:.2f}x with all its CPU on two cores"
        if f"{kind}_two_core_bound_own" in r:
            cells += f" ({r[f'{kind}_two_core_bound_own']:.2f}x against its own tasks' work)"
        return cells

    return [
        r["case"] + f" (runs in the order {', '.join(x['run'] for x in runs)})",
        f"{r['resolution']:g}",
        f"{r['boxes']} boxes",
        one("serial"),
        one("dask"),
        one("dask-lean"),
        one("workers"),
        "yes" if r["same_paving"] else "NO",
    ]


def _workspace_layer_cells(r: Row) -> list[object]:
    v, L = r["volumes"], r["layer"]
    probe = r.get("boundary_probe")
    return [
        r["case"] + (f" ({r['variant']})" if r.get("variant") else ""),
        f"{r['resolution']:g}",
        f"{v['inside']:.4g} / {v['outside']:.4g} / {v['boundary']:.4g} m^3, {r['cpu_s']:.0f} s CPU",
        f"median {L['median']:g}, {100 * L['share_at_most_2']:.1f} % <= 2, max {L['max']}"
        + (
            ""
            if "with_ring" not in L
            else f"; with the cells beyond the region's faces decided: {100 * L['with_ring']['share_at_most_2']:.2f} % <= 2, "
            f"max {L['with_ring']['max']}"
        ),
        f"median {L['runs']['median_run']:g}, {100 * L['runs']['share_at_most_2']:.0f} % <= 2, max {L['runs']['max_run']}",
        "" if not probe else f"{probe['all_reached']} / {probe['none_reached']} / {probe['mixed']}",
    ]


def _scenes_cells(r: Row) -> list[object]:
    p, ch, ag = r["pairs"], r["checks"], r.get("agreement")
    return [
        r["case"],
        r["poses"],
        f"{r['median_plain']:.4f}",
        f"{r['median_scene']:.4f}",
        f"{r['ratio']:.2f}",
        f"{r['scene_median_per_pose'] * 1e3:.2f}",
        p["active"],
        f"{p['world_fixed']}, {p['out_of_reach']}",
        f"{ch.get('sphere_skipped', 0)} / {ch.get('hull_proofs', 0)} / {ch.get('mesh_checked', 0)}",
        ch.get("configurations", "-"),
        "-" if ag is None else f"{ag['verdict']} / {ag['oracle']} ({ag['solutions']} solutions, {ag['free']} free)",
    ]


def _scenes_notes(rows: list[Row]) -> list[str]:
    out = []
    for r in rows:
        s = r.get("selfmotion")
        if not s:
            continue
        low = s["lowest_stretch_clearance"]
        out.append(
            f"Panda self-motion in panda-shelf (the hand between the shelf's lower boards, `PANDA_IN_SHELF`): "
            f"{s['curves']} curve(s), {s['samples']} configurations ({s['colliding_samples']} in contact), "
            f"{s['stretches']} collision-free stretch(es) of {s['stretch_points']} configurations ({s['inserted']} added by halving); "
            f"every stretch sampled 10x finer with coal: {s['finer_contacts']} contacts in {s['finer_checked']} configurations; "
            f"lowest clearance bound along a stretch {'-' if low is None else f'{low:.3g}'}; "
            f"complete: {_yes(s['complete'])}; search and scene {s['seconds']:.1f} s CPU, of it the scene {s['scene_seconds']:.1f} s."
        )
    out += [scenes_pruning_line(p) for r in rows for p in r.get("pruning", [])]
    return out


def scenes_pruning_line(r: dict) -> str:
    """One sentence of the pruning measurement of one scene."""
    off, on = r["off"], r["on"]
    pr = on["pruning"] or {}
    return (
        f"Pruning inside the search, Panda self-motion in {r['scene']} (collision-free): without {off['boxes']} boxes, "
        f"{off['cpu_seconds']:.1f} s CPU; with {on['boxes']} boxes ({pr.get('discarded', 0)} of {pr.get('tested', 0)} tested discarded), "
        f"{on['cpu_seconds']:.1f} s CPU: boxes x{r['boxes_ratio']:.2f}, CPU x{r['cpu_ratio']:.2f}; free stretches "
        f"{off['stretches']} ({off['stretch_points']} points) without, {on['stretches']} ({on['stretch_points']} points) with."
    )


def _num(v: object, fmt: str = "{:.1f}") -> str:
    return "-" if v is None else fmt.format(v)


def _closed_form_cells(r: Row) -> list[object]:
    g = r.get
    return [
        r["arm"],
        r["family"] or "-",
        f"{_num(r['roots_per_pose'], '{:.2f}')} / {_num(g('eaik_roots_per_pose'), '{:.2f}')} / {_num(g('ikgeo_roots_per_pose'), '{:.2f}')}",
        f"{r['kinbox_batch_us']:.1f} / {_num(g('kinbox_batch_system_us'))} / {r['kinbox_batch_interval_us']:.1f}",
        _num(g("eaik_repeated_us")),
        _num(g("ikgeo_repeated_us")),
        f"{_num(g('batch_ratio_eaik'), '{:.1f}x')} / {_num(g('batch_system_ratio_eaik'), '{:.1f}x')} / "
        f"{_num(g('batch_interval_ratio_eaik'), '{:.1f}x')}",
        f"{r['kinbox_single_array_us']:.0f} / {r['kinbox_single_interval_us']:.0f} / {r['kinbox_single_result_us']:.0f}",
        _num(g("eaik_first_us")),
        f"{_num(g('single_ratio_eaik'), '{:.1f}x')} / {_num(g('single_interval_ratio_eaik'), '{:.1f}x')} / "
        f"{_num(g('single_result_ratio_eaik'), '{:.0f}x')}",
        f"{r['closed_form_share']:.3f}",
    ]


def _closed_form_notes(rows: list[Row]) -> list[str]:
    errs = [f"{r['arm']}: {r['eaik_error']}" for r in rows if r.get("eaik_error")]
    return ["EAIK could not model: " + "; ".join(errs) + "."] if errs else []


def _joint_radii_cells(r: Row) -> list[object]:
    return [
        r["arm"],
        f"{r['batch_radii_us']:.1f} / {r['batch_zero_us']:.1f}",
        f"{r['batch_ratio']:.3f}",
        f"{r['single_radii_us']:.0f} / {r['single_zero_us']:.0f}",
        f"{r['single_ratio']:.3f}",
        f"{r['fallback_radii']} / {r['fallback_zero']}",
        "yes" if r["same_counts"] else "no",
        f"{_num(r.get('box_width_radii'), '{:.1e}')} / {_num(r.get('box_width_zero'), '{:.1e}')}",
    ]


def _selfmotion_cells(r: Row) -> list[object]:
    return [
        r["case"],
        r["method"],
        f"{r['sweep_cpu']:.2f}",
        f"{r['bp_cpu']:.1f}",
        f"{r['bp_cpu'] / r['sweep_cpu']:.0f}x",
        f"{r['curves']} / {r['bp_curves']}",
        f"{_yes(r['complete'])} / {_yes(r['bp_complete'])}",
        f"{r['gap_to_bp']:.3f} / {r['gap_from_bp']:.3f}",
        f"{r['certified_points']} of {r['points']}",
        f"{r['residual']:.1e}",
    ]


def _near_singular_cells(r: Row) -> list[object]:
    whole = r.get("whole_domain_ms")
    return [
        r["pose"],
        f"{r['method']} in {r['enclosures']} closed-form boxes" if r.get("enclosures") else r["method"],
        _yes(r["complete"]),
        f"{r['roots']} ({r['certified']}, {r['flagged_singular']})",
        r["curves"],
        f"{r['kinbox_ms']:.1f}",
        f"{r['ratio_generic']:.0f}x",
        r.get("search_boxes", "—"),
        "—" if whole is None else f"{whole:.1f}, {r['whole_domain_ratio_generic']:.0f}x",
        r["eaik_roots"],
    ]


def _shaving_cells(r: Row) -> list[object]:
    if "error" in r:
        return [r["case"], f"error: {r['error']}", "", "", "", "", ""]
    return [
        r["case"],
        f"{r['boxes']} / {r['boxes_shave']}",
        f"{r['lps']} / {r['lps_shave']}",
        f"{r['search_cpu']:.2f} / {r['search_cpu_shave']:.2f}",
        f"{r['boxes_ratio']:.2f}x / {r['cpu_ratio']:.2f}x",
        _yes(r["same_answer"]),
        r["answer"] if r.get("answer_shave", r["answer"]) == r["answer"] else f"{r['answer']} / {r['answer_shave']}",
    ]


def _cuiksuite_cells(r: Row) -> list[object]:
    sols = f"{r['kinbox_solutions']} ({r['kinbox_certified']})"
    if r.get("kinbox_curves"):
        sols += f" + {r['kinbox_curves']} curve(s)"
    if not r.get("kinbox_complete"):
        sols += ", incomplete"
    ratio = "-" if r.get("ratio_cpu") is None else f"{r['ratio_cpu']:.2f}x"
    return [
        r["example"],
        r["runs"],
        f"{r['cuik_cpu']:.2f}",
        f"{r['cuik_boxes']:.0f}",
        f"{r['cuik_mb']:.0f}",
        f"{r['kinbox_cpu']:.2f} ({r['kinbox_search_cpu']:.2f})",
        f"{r['kinbox_boxes']:.0f}",
        sols,
        f"{r['kinbox_mb']:.0f}",
        ratio,
    ]


def _eigen6r_cells(r: Row) -> list[object]:
    em = r.get("median_eigen_ms")
    return [
        r["arm"],
        r["poses"],
        f"{r['eigen_share']}/{r['poses']}",
        f"{r['roots_mean']:.2f}",
        f"{r['median_ms']:.1f}",
        f"{em:.1f}" if em is not None else "-",
        f"{r['median_core_ms']:.1f}" if r.get("median_core_ms") is not None else "-",
        f"{r['median_search_ms']:.1f}",
        f"{r['ratio']:.1f}x",
        f"{r['first_call_ms']:.0f}",
        f"{r['all_certified_complete']}/{r['poses']}",
        f"{r['same_sets']}/{r['poses']}",
    ]


TABLES: list[Table] = [
    Table(
        key="suite",
        title="The benchmark suite",
        command="make bench  # python benchmarks/run.py --quick; without --quick: every problem, two sigmas",
        about=(
            "Each problem in a fresh process (peak memory is its own). Solver CPU seconds "
            "(`time.process_time`; for IK the median over the poses, the counts of each pose joined by /). "
            "Expected answers: the published problems (`tests/data/reference`, the built-in mechanisms) and, "
            "for the UR5, an independent closed-form solver (`tests/support/oracles`)."
        ),
        columns=SUITE_COLUMNS,
        cells=_suite_cells,
        notes=_suite_notes,
    ),
    Table(
        key="suite-full",
        title="The benchmark suite, every problem",
        command="python benchmarks/run.py  # every problem at two sigmas, 5 poses per arm",
        about="As the table above, for every problem of `benchmarks/bench.py` (`CASES`) at each of its sigmas.",
        columns=SUITE_COLUMNS,
        cells=_suite_cells,
        notes=functools.partial(_suite_notes, picture="runtime_vs_error_full.png"),
    ),
    Table(
        key="constraints",
        title="Constraint systems: coordinates against distances",
        command="python benchmarks/constraints.py [--quick]",
        about=(
            "Each row in its own process, one after the other; CPU seconds of the search, the diagnosis "
            "before it apart. Every answer is checked on its placements and proven in coordinates."
        ),
        columns=[
            "problem",
            "formulation",
            "variables / equations",
            "boxes",
            "LPs",
            "search CPU s",
            "diagnosis CPU s",
            "assemblies (certified)",
            "up to reflection",
            "curves",
            "complete",
        ],
        cells=_constraints_cells,
    ),
    Table(
        key="parallel",
        title="Parallel search: serial against worker processes",
        command="python benchmarks/bench_parallel.py --repeat 2 --record [--dask]",
        about=(
            "Each problem serially, then with 1 and 2 worker processes (docs/scaling.md); the best wall "
            'time of the repeats. "cores" is CPU seconds over wall seconds: a speed-up means something '
            "only where a run got the cores it asked for (about 2 for 2 workers), which a shared machine "
            'does not give ("load": the load average before the run). Without LPs the answer must be '
            "the serial one box for box; with LPs the boxes depend on the processing order."
        ),
        columns=["problem", "run", "wall s", "speed-up", "CPU s", "cores", "boxes", "same answer / box for box", "load"],
        cells=_parallel_cells,
    ),
    Table(
        key="startup-cold",
        title="The first answer without compiled kernels",
        command="python benchmarks/startup.py cold --repeat 2 --record",
        about=(
            "Each command in a fresh process with numba's kernel cache pointed at an empty folder, so "
            "that every kernel it calls is compiled (an install without `make setup`), then once more on "
            "the cache it filled: CPU seconds of the whole process (user + system), the least of the "
            "rounds (a loaded machine only adds), and its peak memory. Target: a first answer under 30 s. "
            "`load_all_kernels` is what `make setup` runs."
        ),
        columns=["command", "first run: CPU s (min-max)", "peak MB", "second run: CPU s", "peak MB", "rounds"],
        cells=lambda r: [
            r["command"],
            f"{r['cold_cpu']:.1f}-{r.get('cold_cpu_max', r['cold_cpu']):.1f}",
            f"{r['cold_peak_mb']:.0f}",
            f"{r['warm_cpu']:.2f}",
            f"{r['warm_peak_mb']:.0f}",
            r.get("runs", 1),
        ],
    ),
    Table(
        key="scenes",
        title="Collision scenes: the cost of a scene per pose",
        command="python benchmarks/scenes.py --poses 100 --panda-poses 20 --pruning  # docs/scenes.md",
        about=(
            "Random poses (a random configuration within the limits, its pose by forward kinematics), each "
            "solved without and with the scene in one process, interleaved: the median CPU seconds per pose "
            "and their ratio (target: at most 1.5), and the scene's own median CPU per pose. Pairs: the "
            "collision pairs left active, and those skipped before any search (fixed to the world, out of "
            "reach). Pair checks over all solutions: settled by bounding volumes (balls and boxes) / by "
            "convex hulls / collision tests on the meshes. Check (UR5): verdicts that differ from coal's "
            "`computeCollisions` on the meshes / poses whose free set differs from the closed-form "
            "solutions (`tests/support/oracles/ur_ik.py`) filtered by coal."
        ),
        columns=[
            "case",
            "poses",
            "median CPU s/pose without scene",
            "with scene",
            "ratio",
            "scene ms/pose",
            "active pairs",
            "skipped pairs (world-fixed, out of reach)",
            "pair checks: bounding volumes / hulls / mesh tests",
            "solutions checked",
            "check: verdicts / free sets differing",
        ],
        cells=_scenes_cells,
        notes=_scenes_notes,
    ),
    Table(
        key="workspace",
        title="Workspace pavings",
        command="python benchmarks/workspace.py --resolution 0.05 --record  # docs/workspace.md",
        about=(
            "Each paving in one process, CPU seconds of the paving alone. Arm: a fixed tool orientation over "
            "a small region, beside a map from IK at every voxel centre of a grid at the resolution "
            '("check": reached voxel centres lying in an outside box, which must be 0). Platforms: the '
            "constant-orientation workspace (resolution in the mechanism's length unit); "
            '"check": random positions, two per box, whose legs\' lengths by Pinocchio FK contradict the '
            "box's verdict (must be 0; not run for the 3-RPR, whose own test checks it)."
        ),
        columns=[
            "case",
            "resolution",
            "complete",
            "inside / outside / boundary boxes",
            "inside / boundary volume",
            "CPU s",
            "check",
            "sampled map",
        ],
        cells=_workspace_cells,
    ),
    Table(
        key="workspace-free",
        title="Position workspace against forward-kinematics sampling; Dask against serial",
        command=(
            "python benchmarks/workspace_free.py --samples 100000 1000000 10000000 --record; "
            "... --dask-only --dask-resolution 0.025 --record  # docs/workspace.md"
        ),
        about=(
            "kinbox's paving with the tool's orientation free (inside / outside / boundary volume, CPU of the "
            "paving in one process) beside N random configurations within the limits, each frame position by "
            "Pinocchio FK, over the same region and grid: the volume of the grid cells a sample falls in, the "
            "samples lying in a box kinbox proves outside (must be 0), the sampled cells within inside boxes, "
            "and the boundary layer's thickness (runs of boundary cells along the grid lines). Dask: the tool-down "
            "map serially and on a LocalCluster of 2 worker processes, wall times; the pavings must be equal."
        ),
        columns=["case", "resolution", "kinbox paving", "sampled map", "check", "sampled cells in inside boxes", "boundary runs"],
        cells=_workspace_free_cells,
    ),
    Table(
        key="workspace-dask",
        title="Workspace paving: serial, two local processes, Dask LocalCluster of two workers",
        command="python benchmarks/workspace_dask.py --resolution 0.055 --rounds 2 --record  # docs/workspace.md",
        about=(
            "The UR5 tool-down map over the default region (a cube bounding the reach), serially, with "
            "`workers=2` and on a LocalCluster of two worker processes (one thread each; Dask's default "
            "configuration, and a lean one: no statistical profiler in the workers, event-loop checks and "
            "monitors once a second or less), each Dask run on a cluster of its own, warmed by a small paving "
            "first. Each run's wall time and CPU (tasks: the subtree tasks' CPU summed; busiest process: the "
            "most any one process spent on them; all processes: every CPU second of the run, this process "
            "with the LocalCluster's scheduler and the client, the workers and their nannies, or the local "
            "processes). Wall ratio: serial wall over parallel wall; ideal: tasks' CPU over the busiest "
            "process's; with all its CPU on two cores: serial CPU over half the run's CPU, the speed-up two "
            "free cores would give. Equal pavings: bounds, verdicts and witnesses, box for box. The machine is "
            "shared: the load average before each run is shown; its scheduler gives each session one share "
            "however many processes it runs, so under load the wall ratio follows the CPU ratio."
        ),
        columns=[
            "case",
            "resolution",
            "paving",
            "serial",
            "Dask LocalCluster(2)",
            "Dask, lean configuration",
            "--workers 2",
            "same paving",
        ],
        cells=_workspace_dask_cells,
    ),
    Table(
        key="workspace-layer",
        title="Workspace paving: the boundary layer's thickness",
        command=(
            "python benchmarks/workspace_layer.py --region -0.9 -0.9 -0.9 0.9 0.9 0.9 --resolution 0.05 --no-probe  # docs/workspace.md"
        ),
        about=(
            "A fixed-orientation paving on the grid of its smallest boxes: for every boundary cell the "
            "distances in cells (chessboard) to the nearest inside and outside cells, the layer's local "
            "thickness d_in + d_out - 1 (and again with the cells within two of the boundary cells beyond the "
            "region's faces decided, where the border runs along a face); the runs of boundary cells along the grid lines; "
            "where probed, the "
            "boundary boxes whose 27 grid points the closed form all reaches / none reaches / some reaches."
        ),
        columns=[
            "case",
            "resolution",
            "inside / outside / boundary",
            "layer thickness (cells)",
            "runs along grid lines",
            "probe all / none / mixed",
        ],
        cells=_workspace_layer_cells,
    ),
    Table(
        key="closed-form",
        title="Closed-form IK against EAIK and ik-geo",
        command="python benchmarks/closed_form.py [--batch 10000]  # docs/closed-form.md",
        about=(
            "CPU microseconds per pose, measured in one run (EAIK and ik-geo installed for the benchmark only). "
            "Batch: the median over chunks of `IK.solve_array` on random poses, each root certified by Krawczyk "
            'in the joint angles (the default) / by Krawczyk on the kinbox system (`certify="system"`, the first '
            "2,000 poses) / with the interval closed form as the only proof, against EAIK's `IK` and "
            "ik-geo's `get_ik` called once per pose. Single pose, after loading (the median over 21 poses): "
            "`solve_array` of one pose (Krawczyk / interval) and the full checked `IK.solve` Result, against "
            "EAIK's first call. Roots per "
            "pose: kinbox within the joint limits, EAIK and ik-geo without limits. Closed-form share: the poses "
            "the closed form answered (the rest went to the branch and prune)."
        ),
        columns=[
            "arm",
            "family",
            "roots per pose: kinbox / EAIK / ik-geo",
            "kinbox batch µs: Krawczyk joints / system / interval",
            "EAIK repeated µs",
            "ik-geo repeated µs",
            "batch ratio to EAIK: joints / system / interval",
            "kinbox single µs: Krawczyk / interval / Result",
            "EAIK first call µs",
            "single ratio to EAIK: Krawczyk / interval / Result",
            "closed-form share",
        ],
        cells=_closed_form_cells,
        notes=_closed_form_notes,
    ),
    Table(
        key="closed-form-singular",
        title="Closed-form IK: near-singular UR5 poses",
        command="python benchmarks/closed_form.py  # the same run as the table above (--near: these poses alone)",
        about=(
            "One `IK.solve` per pose (after a first call), the path that answered it (the branch and prune "
            "inside the closed form's relaxed enclosures where it does not decide: `kinbox.search.cf_fallback`), "
            "the roots found (certified, flagged singular) and the curves, its CPU milliseconds against the generic "
            "pose's, the boxes searched, the branch and prune of the whole domain on the same pose (`closed_form=False`), "
            "and the real (not least-squares) roots EAIK returns for the same pose."
        ),
        columns=[
            "UR5 pose",
            "kinbox path",
            "complete",
            "roots (certified, flagged singular)",
            "curves",
            "kinbox ms",
            "x generic",
            "search boxes",
            "whole domain searched: ms, x generic",
            "EAIK roots",
        ],
        cells=_near_singular_cells,
    ),
    Table(
        key="joint-certificate-radii",
        title="Closed-form IK: the joint-angle certificate with the model's radii",
        command="python benchmarks/joint_radii.py [--batch 6000]",
        about=(
            "The default certificate of `IK.solve_array` (Krawczyk in the joint angles) with the links and "
            "constant frames as enclosures of the model as given, against the same certifier with zero radii "
            "(the binary64 constants taken as exact), chunks interleaved in one run. CPU microseconds per pose "
            "(batch: median over chunks; single: median of 21 one-pose calls), the poses sent to the branch "
            "and prune, and the median width of the proof boxes."
        ),
        columns=[
            "arm",
            "batch µs: radii / zero",
            "batch ratio",
            "single µs: radii / zero",
            "single ratio",
            "to the search: radii / zero",
            "same counts",
            "median proof box: radii / zero",
        ],
        cells=_joint_radii_cells,
    ),
    Table(
        key="shaving",
        title="The shaving contractor (3BCID): without / with",
        command="python benchmarks/shaving.py --record",
        about=(
            'The optional step `extra_steps="shave"` (`kinbox.search.ctc_shave`): each problem in its own '
            "process, solved without and then with it. Boxes and LPs are counters; CPU is the search's own. "
            "It stays an option unless it pays on the problems measured."
        ),
        columns=["problem", "boxes", "LPs", "search CPU s", "with / without (boxes, CPU)", "same answer", "answer (without / with)"],
        cells=_shaving_cells,
    ),
    Table(
        key="cuiksuite",
        title="CuikSuite's examples: the whole process against CuikSuite's",
        command="python benchmarks/cuiksuite.py --cuik-bin DIR --runs 3 --only general butterfly  # docs/cuiksuite.md",
        about=(
            "CPU seconds of the whole process (user + system, `os.wait4`: for CuikSuite `cuikequations` plus `cuik`, "
            "for kinbox `python -m kinbox.cli solve NAME --json` from start to exit, its search's own count in "
            "brackets, loading the compiled kernels it calls included), mean of the alternated runs in one "
            "session; peak resident memory (`ru_maxrss`, MB) of each "
            "process, the largest over the runs."
        ),
        columns=[
            "example",
            "runs",
            "CuikSuite CPU s",
            "CuikSuite boxes",
            "CuikSuite peak MB",
            "kinbox CPU s (search)",
            "kinbox boxes",
            "solutions (certified)",
            "kinbox peak MB",
            "kinbox / CuikSuite CPU",
        ],
        cells=_cuiksuite_cells,
    ),
    Table(
        key="selfmotion",
        title="Seven-joint self-motions: the sweep against the branch and prune",
        command="python benchmarks/selfmotion.py --sweep --record",
        about=(
            "Each pose answered twice in one run: by the sweep of an end joint through the closed form "
            "of the other six (kinbox's default for seven joints) and by the branch and prune "
            "(`closed_form=False`). CPU seconds of each, the curves each found, how far the points of "
            "either answer are from the other's (largest distance from a point to the nearest point of the "
            "other answer, radians), and the sweep's points certified by Krawczyk."
        ),
        columns=[
            "pose",
            "sweep path",
            "sweep CPU s",
            "branch and prune CPU s",
            "speed-up",
            "curves (sweep / B&P)",
            "complete (sweep / B&P)",
            "largest gap sweep->B&P / B&P->sweep",
            "points certified",
            "max FK residual",
        ],
        cells=_selfmotion_cells,
    ),
    Table(
        key="eigen-6r",
        title="General 6R arms from URDF: eigenvalue path against the branch and prune",
        command="python benchmarks/eigen6r.py [--poses 10] [--arms 3]  # kinbox/search/eigen6r.py",
        about=(
            "CPU milliseconds per pose, both paths on the same poses in one run (after a first call per arm). "
            "`IK.solve`: the elimination of Raghavan and Roth / Manocha and Canny with 16 eigenvalues proven in "
            "disjoint discs and each real root certified by Krawczyk, where that proof holds, else the branch "
            "and prune; against `IK.solve(closed_form=False)`, the branch and prune alone. Certified roots "
            "alone: `kinbox.search.eigen6r.certify` (elimination, proof, Krawczyk), without the checked "
            "`Result`. Same sets: poses whose two answers agree (both complete)."
        ),
        columns=[
            "arm",
            "poses",
            "eigen path share",
            "roots per pose",
            "median ms: IK.solve",
            "median ms: eigen-path poses",
            "median ms: certified roots alone",
            "median ms: branch and prune",
            "ratio",
            "first call ms",
            "certified and complete",
            "same sets",
        ],
        cells=_eigen6r_cells,
    ),
]


# ---- the raw results and the page ----------------------------------------------------------


def load_raw(path: Path = RAW) -> dict[str, Any]:
    if path.exists():
        data = json.loads(path.read_text(encoding="utf-8"))
        if isinstance(data, dict):
            return data
    return {}


def record(
    key: str,
    rows: list[Row],
    *,
    calibration: float,
    mode: str = "",
    raw: Path = RAW,
    page: Path = PAGE,
) -> None:
    """Store the rows of one run of benchmark ``key`` and write the page again."""
    if key not in {t.key for t in TABLES}:
        raise KeyError(f"no Table entry for benchmark {key!r} in benchmarks/report.py")
    data = load_raw(raw)
    data[key] = {"machine": machine(), "calibration_seconds": round(calibration, 3), "mode": mode, "rows": rows}
    raw.write_text(json.dumps(data, indent=1, default=float) + "\n", encoding="utf-8")
    write_page(data, page)


def _cell(v: object) -> str:
    return str(v).replace("|", "\\|").replace("\n", " ")


def _machine_line(entry: dict[str, Any]) -> str:
    m = entry.get("machine", {})
    cal = entry.get("calibration_seconds")
    cal_s = f"{cal:.2f} s CPU" if isinstance(cal, (int, float)) else "not measured"
    return (
        f"Machine: {m.get('cpu', '?')}, {m.get('cores', '?')} cores, Python {m.get('python', '?')}; "
        f"calibration (1e7 pure-Python additions): {cal_s}."
    )


def render(data: dict[str, Any]) -> str:
    lines = [
        "# Benchmarks",
        "",
        "<!-- Written by benchmarks/report.py from docs/benchmarks.json: do not edit by hand. -->",
        "",
        "Current numbers, one table per benchmark, each from the latest run of its script (the raw",
        "rows are in [benchmarks.json](benchmarks.json)). `python benchmarks/report.py` writes this page",
        "again from that file. Each run names its machine and its **calibration**: the CPU seconds of",
        "a fixed pure-Python loop of 1e7 additions, measured at the start of the run. The machines",
        "are shared, so compare numbers as ratios within one table, and across tables only with",
        "their calibrations beside them. What changed over time is in git and in",
        "[CHANGELOG.md](../CHANGELOG.md).",
        "",
        "To add a benchmark here: one `Table` entry in `TABLES` of `benchmarks/report.py` (key,",
        "title, command, columns, and a function from one JSON row to its cells), and in its script",
        "`c = report.calibrate()` at the start and `report.record(key, rows, calibration=c)` at the end.",
        "",
    ]
    for t in TABLES:
        entry = data.get(t.key)
        if not entry:
            continue
        rows = entry.get("rows", [])
        lines += [f"## {t.title}", "", f"`{t.command}`" + (f" ({entry['mode']} run)" if entry.get("mode") else ""), ""]
        if t.about:
            lines += [t.about, ""]
        lines += [_machine_line(entry), ""]
        lines.append("| " + " | ".join(t.columns) + " |")
        lines.append("|" + "---|" * len(t.columns))
        for r in rows:
            lines.append("| " + " | ".join(_cell(c) for c in t.cells(r)) + " |")
        notes = t.notes(rows)
        if notes:
            lines.append("")
            for n in notes:
                lines += [n, ""]
            lines.pop()
        lines.append("")
    return "\n".join(lines)


def write_page(data: dict[str, Any] | None = None, page: Path = PAGE) -> None:
    page.write_text(render(load_raw() if data is None else data), encoding="utf-8")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="benchmarks/report.py", description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--calibrate", action="store_true", help="print the machine and its calibration, write nothing")
    a = ap.parse_args(argv)
    if a.calibrate:
        print(json.dumps({"machine": machine(), "calibration_seconds": round(calibrate(), 3)}))
        return 0
    write_page()
    print(f"report: wrote {PAGE.relative_to(ROOT)}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())


def interleaved(label: str, run, variant_on, repeat: int) -> dict:
    """One problem's row of an enclosures benchmark: ``run()`` (a kinbox answer) timed in CPU
    seconds with the enclosures on and off (``variant_on(bool)``), after a warm-up of each,
    ``repeat`` times each in alternating order; the medians, their ratio, and the boxes,
    solutions and certified solutions of each variant."""
    import statistics
    import time

    cpu: dict[str, list[float]] = {"enclosed": [], "rounded": []}
    out: dict[str, tuple[int, int, int]] = {}
    for variant in ("enclosed", "rounded"):  # warm-up
        variant_on(variant == "enclosed")
        run()
    for i in range(repeat):
        for variant in ("enclosed", "rounded") if i % 2 == 0 else ("rounded", "enclosed"):
            variant_on(variant == "enclosed")
            c0 = time.process_time()
            r = run()
            cpu[variant].append(time.process_time() - c0)
            sols = r.solutions
            out[variant] = (int(r.stats["boxes"]), len(sols), sum(1 for s in sols if s.certified))
    variant_on(True)
    me, mr = statistics.median(cpu["enclosed"]), statistics.median(cpu["rounded"])
    return {
        "problem": label,
        "cpu_enclosed_s": round(me, 4),
        "cpu_rounded_s": round(mr, 4),
        "ratio": round(me / mr, 3),
        "boxes_enclosed": out["enclosed"][0],
        "boxes_rounded": out["rounded"][0],
        "solutions": f"{out['enclosed'][1]}/{out['rounded'][1]}",
        "certified": f"{out['enclosed'][2]}/{out['rounded'][2]}",
    }


def interleaved_summary(rows: list[dict], as_json: bool, width: int) -> dict:
    """The rows of an enclosures benchmark (:func:`interleaved`) with their median and mean
    ratio, printed as JSON (``as_json``) or as a table whose problem column is ``width`` wide."""
    import statistics

    ratios = [r["ratio"] for r in rows]
    summary = {"rows": rows, "median_ratio": statistics.median(ratios), "mean_ratio": round(statistics.fmean(ratios), 3)}
    if as_json:
        print(json.dumps(summary, indent=1))
        return summary
    for r in rows:
        print(
            f"{r['problem']:<{width}} {r['cpu_enclosed_s']:8.3f} {r['cpu_rounded_s']:8.3f} {r['ratio']:6.3f} "
            f"boxes {r['boxes_enclosed']}/{r['boxes_rounded']} sols {r['solutions']} cert {r['certified']}"
        )
    print(f"median ratio {summary['median_ratio']:.3f}, mean {summary['mean_ratio']:.3f}")
    return summary
