"""A workspace paving serially, over two local processes and on a Dask LocalCluster of two
workers, alternating, with wall and CPU of each run.

The UR5's tool pointing down (``kinbox reach ur5 --frame tool0 --orientation 1 0 0 0
--resolution R``, the default region: a cube bounding the reach), serially in this process,
with ``workers=2`` (``--workers 2``) and with ``executor=`` a LocalCluster of two worker
processes with one thread each (``--dask``). Every paving must equal the serial one box for box
(bounds, verdicts and witnesses). Besides the wall ratio, the *ideal* ratio of a parallel run:
the CPU of all its subtree tasks over the CPU of its busiest process -- what two free cores
would give to the tasks; and for Dask, every CPU second of the run (the workers' processes whole,
and this process, where a LocalCluster's scheduler runs) against the serial run's CPU: the
speed-up two free cores would give if all of it were spread evenly over them. On a machine
shared with other work the wall ratio measures the share of the cores the runs got as much as
the method. The load average is recorded before each run.

    python benchmarks/workspace_dask.py --resolution 0.04 --rounds 2 --record
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np


def calibrate() -> float:
    """CPU seconds of a fixed pure-Python loop of 1e7 additions (the machine's speed)."""
    t = time.process_time()
    s = 0
    for i in range(10_000_000):
        s += i
    return time.process_time() - t


def _same(a, b) -> bool:
    return bool(
        a.complete
        and b.complete
        and np.array_equal(a.lo, b.lo)
        and np.array_equal(a.hi, b.hi)
        and np.array_equal(a.verdict, b.verdict)
        and np.array_equal(a.witness, b.witness, equal_nan=True)
    )


def run(kind: str, a, client=None) -> tuple[dict, object]:
    from kinbox.workspace import reach

    kw: dict = {"resolution": a.resolution}
    if a.region:
        kw["region"] = a.region
    if kind == "workers":
        kw["workers"] = 2
    elif kind == "dask":
        kw["executor"] = client
    load = os.getloadavg()[0]
    before = client.run(time.process_time) if kind == "dask" else {}
    w, c = time.perf_counter(), time.process_time()
    pv = reach(a.robot, a.frame, tuple(a.orientation), **kw)
    wall, cpu = time.perf_counter() - w, time.process_time() - c
    after = client.run(time.process_time) if kind == "dask" else {}
    st = pv.stats
    row = {
        "run": kind,
        "wall_s": wall,
        "main_cpu_s": cpu,
        "task_cpu_s": st.get("task_cpu_seconds", 0.0),
        "max_process_cpu_s": st.get("max_process_cpu_seconds", 0.0),
        "subtrees": st.get("subtrees", 0),
        "boxes": int(len(pv.verdict)),
        "load_before": load,
    }
    if kind != "serial" and row["max_process_cpu_s"] > 0:
        row["ideal_speedup"] = row["task_cpu_s"] / row["max_process_cpu_s"]
    if before:
        # every CPU second the run cost: the workers' processes whole (tasks, unpickling, their
        # Dask machinery) and this one (the scheduler of a LocalCluster runs here)
        row["worker_process_cpu_s"] = [after[k] - before[k] for k in sorted(after)]
        row["all_cpu_s"] = sum(row["worker_process_cpu_s"]) + cpu
    print(json.dumps(row), file=sys.stderr, flush=True)
    return row, pv


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--robot", default="ur5")
    ap.add_argument("--frame", default="tool0")
    ap.add_argument("--orientation", nargs=4, type=float, default=[1.0, 0.0, 0.0, 0.0])
    ap.add_argument("--region", nargs=6, type=float, help="default: the cube bounding the reach")
    ap.add_argument("--resolution", type=float, default=0.04)
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--kinds", nargs="+", default=["serial", "dask", "workers"])
    ap.add_argument("--record", action="store_true")
    a = ap.parse_args()
    from distributed import Client, LocalCluster

    cal = calibrate()
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=40)
    client = Client(cluster)
    runs: list[dict] = []
    ref = None
    try:
        for _ in range(a.rounds):
            for kind in a.kinds:
                row, pv = run(kind, a, client)
                if ref is None:
                    ref = pv
                row["same_as_first"] = _same(ref, pv)
                runs.append(row)
    finally:
        client.close()
        cluster.close()
    serial = [r["wall_s"] for r in runs if r["run"] == "serial"]
    out = {
        "case": f"{a.robot} {a.frame}, orientation {' '.join(f'{v:g}' for v in a.orientation)}",
        "region": a.region or "default",
        "resolution": a.resolution,
        "boxes": runs[0]["boxes"],
        "runs": runs,
    }
    for kind in ("dask", "workers"):
        par = [r for r in runs if r["run"] == kind]
        if serial and par:
            out[f"{kind}_wall_ratio"] = float(np.median(serial) / np.median([r["wall_s"] for r in par]))
            out[f"{kind}_ideal"] = float(np.median([r["ideal_speedup"] for r in par]))
    out["same_paving"] = all(r["same_as_first"] for r in runs)
    serial_cpu = [r["main_cpu_s"] for r in runs if r["run"] == "serial"]
    dask_all = [r["all_cpu_s"] for r in runs if "all_cpu_s" in r]
    if serial_cpu and dask_all:
        # the speed-up two free cores would give if the run's CPU, all of it, were spread evenly
        out["dask_two_core_bound"] = float(np.median(serial_cpu) / (np.median(dask_all) / 2.0))
    print(json.dumps(out, indent=1))
    if a.record:
        from pathlib import Path

        sys.path.insert(0, str(Path(__file__).resolve().parent))
        import report

        report.record("workspace-dask", [out], calibration=cal)


if __name__ == "__main__":
    main()
