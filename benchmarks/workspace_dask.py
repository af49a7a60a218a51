"""A workspace paving serially, over two local processes and on a Dask LocalCluster of two
workers, alternating, with wall and CPU of each run.

The UR5's tool pointing down (``kinbox reach ur5 --frame tool0 --orientation 1 0 0 0
--resolution R``, the default region: a cube bounding the reach), serially in this process,
with ``workers=2`` (``--workers 2``) and with ``executor=`` a LocalCluster of two worker
processes with one thread each (``--dask``): ``dask`` with Dask's default configuration,
``dask-lean`` with the housekeeping of a CPU-bound cluster turned down (:data:`LEAN`: no
statistical profiler in the workers, event-loop health checks and system monitors once a second
or less). Every paving must equal the serial one box for box (bounds, verdicts and witnesses).

Each Dask run has a cluster of its own, started and warmed (a small paving on it: the workers
import kinbox and load the kernels; that CPU is reported as ``warmup_cpu_s``) before it is
measured and closed after, so no idle cluster runs beside another run; the serial run is warmed
in this process the same way. Besides the wall ratio, the *ideal* ratio of a parallel run: the
CPU of all its subtree tasks over the CPU of its busiest process -- what two free cores would
give to the tasks; and every CPU second of the run (for Dask: this process, where a
LocalCluster's scheduler and the client run, and the workers' and their nannies' processes
whole) against the serial run's CPU: the speed-up two free cores would give if all of it were
spread evenly over them (``*_two_core_bound``), and against the run's own work, its tasks'
threads' CPU (``*_two_core_bound_own``: CPU seconds of one computation drift by tens of percent
between runs on a loaded machine). On a machine shared with other work the wall ratio measures the share of
the cores the runs got as much as the method (with the kernel's autogroup scheduling, a
session's processes share one slice however many there are). The rounds alternate the order of
the runs; the load average is recorded before each run.

    python benchmarks/workspace_dask.py --resolution 0.055 --rounds 2 --record
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

#: Dask configuration of a cluster for long CPU-bound tasks: the workers' statistical profiler
#: (a stack sample every 10 ms) off, the event loops' health check (every 20 ms in each process)
#: and the system and memory monitors (every 0.5 s and 0.1 s) once a second or less
LEAN = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
    "distributed.worker.memory.monitor-interval": "1s",
}
#: the warm-up paving: a small region, coarse
WARM = {"region": (0.3, -0.2, 0.0, 0.6, 0.1, 0.3), "resolution": 0.1}


def _same(a, b) -> bool:
    return bool(
        a.complete
        and b.complete
        and np.array_equal(a.lo, b.lo)
        and np.array_equal(a.hi, b.hi)
        and np.array_equal(a.verdict, b.verdict)
        and np.array_equal(a.witness, b.witness, equal_nan=True)
    )


def _cluster_cpu(client) -> tuple[dict, dict]:
    return client.run(time.process_time), client.run(time.process_time, nanny=True)


def run(kind: str, a) -> tuple[dict, object]:
    import dask
    from distributed import Client, LocalCluster

    from kinbox.workspace import reach

    kw: dict = {"resolution": a.resolution}
    if a.region:
        kw["region"] = a.region
    row: dict = {"run": kind}
    client = cluster = None
    if kind.startswith("dask"):
        with dask.config.set(LEAN if kind == "dask-lean" else {}):
            cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=40)
            client = Client(cluster)
            w0, n0 = _cluster_cpu(client)
            c = time.process_time()
            reach(a.robot, a.frame, tuple(a.orientation), executor=client, **WARM)  # type: ignore[arg-type]
            w1, n1 = _cluster_cpu(client)
            row["warmup_cpu_s"] = time.process_time() - c + sum(w1[k] - w0[k] for k in w1) + sum(n1[k] - n0[k] for k in n1)
        kw["executor"] = client
    else:
        reach(a.robot, a.frame, tuple(a.orientation), **WARM)  # type: ignore[arg-type]
    if kind == "workers":
        kw["workers"] = 2
    try:
        load = os.getloadavg()[0]
        before = _cluster_cpu(client) if client is not None else ({}, {})
        w, c, t = time.perf_counter(), time.process_time(), time.thread_time()
        pv = reach(a.robot, a.frame, tuple(a.orientation), **kw)
        wall, cpu, thread = time.perf_counter() - w, time.process_time() - c, time.thread_time() - t
        after = _cluster_cpu(client) if client is not None else ({}, {})
    finally:
        if client is not None:
            client.close()
            cluster.close()  # type: ignore[union-attr]
    st = pv.stats
    row |= {
        "wall_s": wall,
        "main_cpu_s": cpu,
        "main_thread_cpu_s": thread,
        "task_cpu_s": st.get("task_cpu_seconds", 0.0),
        "task_thread_cpu_s": st.get("task_thread_cpu_seconds", 0.0),
        "max_process_cpu_s": st.get("max_process_cpu_seconds", 0.0),
        "subtrees": st.get("subtrees", 0),
        "boxes": int(len(pv.verdict)),
        "load_before": load,
    }
    if kind != "serial" and row["max_process_cpu_s"] > 0:
        row["ideal_speedup"] = row["task_cpu_s"] / row["max_process_cpu_s"]
    if client is not None:
        # every CPU second the run cost: the workers' processes whole (tasks, unpickling, their
        # Dask machinery), their nannies, and this one (the scheduler of a LocalCluster and the
        # client run here)
        row["worker_process_cpu_s"] = [after[0][k] - before[0][k] for k in sorted(after[0])]
        row["nanny_process_cpu_s"] = [after[1][k] - before[1][k] for k in sorted(after[1])]
        row["all_cpu_s"] = sum(row["worker_process_cpu_s"]) + sum(row["nanny_process_cpu_s"]) + cpu
        # the same against the work of this run itself (its tasks' own threads), free of the
        # drift of CPU seconds between runs on a loaded machine
        row["two_core_bound_own"] = 2.0 * row["task_thread_cpu_s"] / row["all_cpu_s"]
        # cores the run's Dask machinery and waiting kept busy beside its tasks' own threads, on
        # average over its wall time (most of it grows with the wall time: periodic callbacks)
        row["overhead_cores"] = (row["all_cpu_s"] - row["task_thread_cpu_s"]) / wall
    return row, pv


def summary(runs: list[dict], a) -> dict:
    """The row of a benchmark run: its runs, and per parallel kind the medians' ratios."""
    serial = [r for r in runs if r["run"] == "serial"]
    out: dict = {
        "case": f"{a.robot} {a.frame}, orientation {' '.join(f'{v:g}' for v in a.orientation)}",
        "region": a.region or "default",
        "resolution": a.resolution,
        "boxes": runs[0]["boxes"],
        "runs": runs,
    }
    for kind in ("dask", "dask-lean", "workers"):
        par = [r for r in runs if r["run"] == kind]
        if serial and par:
            out[f"{kind}_wall_ratio"] = float(np.median([r["wall_s"] for r in serial]) / np.median([r["wall_s"] for r in par]))
            out[f"{kind}_ideal"] = float(np.median([r["ideal_speedup"] for r in par]))
            if all("all_cpu_s" in r for r in par):
                # the speed-up two free cores would give if the run's CPU, all of it, were spread
                # evenly: against the serial run's CPU, and against the run's own tasks' work
                all_cpu = float(np.median([r["all_cpu_s"] for r in par]))
                out[f"{kind}_two_core_bound"] = float(np.median([r["main_cpu_s"] for r in serial])) / (all_cpu / 2.0)
                out[f"{kind}_two_core_bound_own"] = float(np.median([r["two_core_bound_own"] for r in par]))
    out["same_paving"] = all(r["same_as_first"] for r in runs)
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--robot", default="ur5")
    ap.add_argument("--frame", default="tool0")
    ap.add_argument("--orientation", nargs=4, type=float, default=[1.0, 0.0, 0.0, 0.0])
    ap.add_argument("--region", nargs=6, type=float, help="default: the cube bounding the reach")
    ap.add_argument("--resolution", type=float, default=0.04)
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--kinds", nargs="+", default=["serial", "dask", "dask-lean", "workers"])
    ap.add_argument("--record", action="store_true")
    a = ap.parse_args()
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import report

    cal = report.calibrate()
    runs: list[dict] = []
    ref = None
    for r in range(a.rounds):
        for kind in a.kinds if r % 2 == 0 else a.kinds[::-1]:  # alternate the order: load drifts
            row, pv = run(kind, a)
            if ref is None:
                ref = pv
            row["same_as_first"] = _same(ref, pv)
            runs.append(row)
            print(json.dumps(row), file=sys.stderr, flush=True)
    out = summary(runs, a)
    print(json.dumps(out, indent=1))
    if a.record:
        from pathlib import Path

        sys.path.insert(0, str(Path(__file__).resolve().parent))
        import report

        report.record("workspace-dask", [out], calibration=cal)


if __name__ == "__main__":
    main()
