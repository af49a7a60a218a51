#!/usr/bin/env python
"""Speed-up of the parallel search: serial vs 1 and 2 (or more) worker processes, optionally Dask.

    python benchmarks/bench_parallel.py                       # four-bar (LPs) + Viviani curve (no LPs)
    python benchmarks/bench_parallel.py --problem four-bar --workers 1 2 4 --repeat 3
    python benchmarks/bench_parallel.py --dask                # also a 2-worker Dask LocalCluster
    python benchmarks/bench_parallel.py --dask tcp://host:8786  # also an existing Dask cluster
    python benchmarks/bench_parallel.py --json out.json
    python benchmarks/bench_parallel.py --repeat 2 --record  # the "parallel" table of docs/benchmarks.md

Problems (the default two take >= 5 s serially on a 2-core laptop-class machine):

* ``four-bar``: the configuration curve of the built-in four-bar (positive-dimensional),
  LPs on, sigma 0.05 (the ``kinbox solve`` default), ~15 s;
* ``viviani``: Viviani's curve (sphere x cylinder) in 3 variables, no LPs, sigma 0.02, ~9 s:
  the parallel answer must be the serial one box for box;
* ``general-6r`` / ``general-6r-nolp``: the 16 assembly modes of the general 6R loop with /
  without LPs (a second or two serially: overhead-dominated, little parallelism near the root).

For each run the script checks that the answer is the serial one — the same certified solutions,
the same completeness, coverings of positive-dimensional sets within sigma of each other — and
whether it is the same box for box (expected without LPs; with LPs the solver adapts from box to
box, so the boxes depend on the processing order), and prints wall time, speed-up over serial,
CPU seconds (master + workers), the cores the run actually got (CPU seconds / wall seconds)
and the machine's load average before the run: on a shared machine other processes take cores
too, and the speed-up is only meaningful when the runs got the cores they asked for (about 1 for
serial and 1 worker, about 2 for 2 workers). Exit status 1 if an answer differs.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np
import report

PROBLEMS = {
    "four-bar": ("four-bar", dict(lp=True, sigma=0.05)),
    "viviani": ("viviani", dict(lp=False, sigma=0.02)),
    "general-6r": ("general-6r", dict(lp=True)),
    "general-6r-nolp": ("general-6r", dict(lp=False)),
}
DEFAULT = ["four-bar", "viviani"]


def viviani():
    """Viviani's curve: a sphere cut by a cylinder through its centre (positive-dimensional)."""
    from kinbox.formulation.system import System

    s = System()
    x, y, z = s.add_var("x", -3, 3), s.add_var("y", -3, 3), s.add_var("z", -3, 3)
    s.add_eq(x * x + y * y + z * z - 4)
    s.add_eq((x - 1) * (x - 1) + y * y - 1)
    return s


def system_of(mechanism: str):
    if mechanism == "viviani":
        return viviani()
    from kinbox.formulation.build import formulate
    from kinbox.model.loading import load

    return formulate(load(mechanism)).system


def identical(r, ref) -> bool:
    """Box for box the same answer (expected without LPs)."""
    key = lambda res: [(tuple(b.lo), tuple(b.hi), b.certified) for b in res.boxes]  # noqa: E731
    return r.complete == ref.complete and key(r) == key(ref) and r.stats["boxes"] == ref.stats["boxes"]


def _near(A, B, tol) -> bool:
    """Every box of A is within ``tol`` (max-norm gap) of some box of B."""
    if not len(A):
        return True
    if not len(B):
        return False
    (alo, ahi), (blo, bhi) = (
        (np.array([a[0] for a in A]), np.array([a[1] for a in A])),
        (np.array([b[0] for b in B]), np.array([b[1] for b in B])),
    )
    gap = np.maximum(blo[None] - ahi[:, None], alo[:, None] - bhi[None]).max(axis=2)
    return bool(np.all(gap.min(axis=1) <= tol))


def same_answer(r, ref, sigma) -> bool:
    """The same certified solutions, the same completeness, and coverings of any
    positive-dimensional set that lie within sigma of each other (with LPs the solver adapts
    from box to box, so the covering boxes depend on the order boxes were processed in)."""
    pts = lambda res: np.array(sorted(tuple(b.x) for b in res.certified))  # noqa: E731
    p, q = pts(r), pts(ref)
    if r.complete != ref.complete or p.shape != q.shape or (p.size and not np.allclose(p, q, atol=1e-8)):
        return False
    A = [(b.lo, b.hi) for b in r.boxes if not b.certified]
    B = [(b.lo, b.hi) for b in ref.boxes if not b.certified]
    return _near(A, B, sigma) and _near(B, A, sigma)


def run(system, opts, **kw):
    from kinbox.pipeline import solve_system

    load = os.getloadavg()[0]
    t = time.perf_counter()
    r = solve_system(system, progress=False, **opts, **kw)
    return r, time.perf_counter() - t, load


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--problem", action="append", choices=sorted(PROBLEMS), help="problem(s) to run (default: four-bar and viviani)")
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2], help="worker counts (default: 1 2)")
    ap.add_argument("--repeat", type=int, default=1, help="runs per configuration; the best wall time is kept")
    ap.add_argument(
        "--dask",
        nargs="?",
        const="local",
        metavar="ADDRESS",
        help="also run on Dask: a 2-worker LocalCluster on loopback, or the scheduler at ADDRESS",
    )
    ap.add_argument("--json", metavar="FILE", help="write the measurements as JSON")
    ap.add_argument("--record", action="store_true", help="record the rows on docs/benchmarks.md (benchmarks/report.py)")
    a = ap.parse_args(argv)
    calibration = report.calibrate()

    client = cluster = None
    if a.dask:
        from distributed import Client, LocalCluster

        if a.dask == "local":
            cluster = LocalCluster(
                n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None, silence_logs=40
            )
            client = Client(cluster)
        else:
            client = Client(a.dask)
        client.wait_for_workers(1)

    print(f"kinbox parallel benchmark: {json.dumps(report.machine())}; calibration: 1e7 additions in {calibration:.3f} s CPU")
    rows = []
    for name in a.problem or DEFAULT:
        mech, opts = PROBLEMS[name]
        system = system_of(mech)
        configs = [("serial", {})] + [(f"{w} worker{'s' * (w > 1)}", {"workers": w}) for w in a.workers]
        if client is not None:
            n = sum(client.nthreads().values())
            configs.append((f"dask ({n} threads)", {"executor": client}))
        ref = None
        base = None
        sigma = opts.get("sigma", 1e-3)
        print(f"\n{name} ({mech}, {opts})")
        print(
            f"  {'run':<18} {'wall s':>8} {'speed-up':>9} {'cpu s':>8} {'cores':>5} {'boxes':>7} {'sols':>5} "
            f"{'load':>5}  same answer / box for box"
        )
        for label, kw in configs:
            best = None
            for _ in range(a.repeat):
                r, wall, load = run(system, opts, **kw)
                if best is None or wall < best[1]:
                    best = (r, wall, load)
            r, wall, load = best
            if ref is None:
                ref, base = r, wall
            same, ident = same_answer(r, ref, sigma), identical(r, ref)
            row = dict(
                problem=name,
                run=label,
                wall=wall,
                speedup=base / wall,
                cpu=r.stats["cpu_seconds"],
                cores_used=r.stats["cpu_seconds"] / wall,
                boxes=r.stats["boxes"],
                solutions=len(r.boxes),
                certified=len(r.certified),
                complete=r.complete,
                same_as_serial=same,
                identical_boxes=ident,
                load_before=load,
                batches=r.stats.get("batches"),
                restarts=r.stats.get("worker_restarts"),
            )
            rows.append(row)
            print(
                f"  {label:<18} {wall:8.2f} {base / wall:8.2f}x {row['cpu']:8.2f} {row['cpu'] / wall:5.2f} "
                f"{row['boxes']:7d} "
                f"{row['solutions']:5d} {load:5.2f}  {'yes' if same else 'NO'} / {'yes' if ident else 'no'}",
                flush=True,
            )
    if client is not None:
        client.close()
    if cluster is not None:
        cluster.close()
    if a.json:
        with open(a.json, "w") as f:
            json.dump(dict(cores=os.cpu_count(), rows=rows), f, indent=1)
    if a.record:
        report.record("parallel", rows, calibration=calibration, mode=f"--repeat {a.repeat}" + (" --dask" if a.dask else ""))
    return 0 if all(r["same_as_serial"] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
