"""Position workspaces (the tool's orientation free) against forward-kinematics sampling, the
boundary layer's thickness, and a paving on a Dask LocalCluster against serial.

Sampling: ``N`` random configurations within the joint limits (a fixed seed), the frame's
position of each by Pinocchio's forward kinematics; a voxel of the grid at the paving's
resolution is *sampled-reached* when a sample falls in it. Soundness: no sample may lie in a box
kinbox proves outside (the count must be 0). The sampled map's reached volume is compared with
kinbox's inside volume (proven: every point reached) and inside + boundary volume.

Boundary thickness: the paving drawn on the grid of its smallest boxes; along every grid line
in x, y and z, the runs of consecutive boundary cells between a non-boundary cell and the next:
their largest length, and the share of runs of at most two cells.

Dask: the same map serially and on a LocalCluster of 2 worker processes (1 thread each); the
pavings must be equal box for box; wall times and their ratio (a shared machine gives no
reliable ratio: the load average is recorded beside it).

    python benchmarks/workspace_free.py --samples 100000 1000000 --record
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np


def sample_positions(robot: str, frame: str, n: int, seed: int = 0, batch: int = 100_000) -> np.ndarray:
    """Positions of ``frame`` at ``n`` random configurations within the limits (Pinocchio FK)."""
    import pinocchio as pin

    from kinbox.pipeline import IK
    from kinbox.workspace.free import Chain6

    ik = IK(robot, frame, formulation="arm")
    fk = Chain6(ik)
    model = ik.robot.model
    data = model.createData()
    fid = model.getFrameId(frame)
    rng = np.random.default_rng(seed)
    out = np.empty((n, 3))
    q = np.array(fk.chain.q_ref, dtype=float)
    k = 0
    while k < n:
        m = min(batch, n - k)
        D = rng.uniform(fk.lo, fk.hi, (m, 6))
        for i in range(m):
            q[fk.idx_q] = fk.chain.q_ref[fk.idx_q] + D[i]
            pin.framesForwardKinematics(model, data, q)
            out[k + i] = data.oMf[fid].translation
        k += m
    return out


def _grid(pv):
    """The paving on the grid of its smallest boxes: (cell size, verdict per cell)."""
    side = (pv.hi - pv.lo).min(axis=0)
    n = np.round((pv.region[1] - pv.region[0]) / side).astype(int)
    g = np.full(tuple(n), -1, dtype=np.int8)
    a = np.round((pv.lo - pv.region[0]) / side).astype(int)
    b = np.round((pv.hi - pv.region[0]) / side).astype(int)
    for lo, hi, v in zip(a, b, pv.verdict):
        g[lo[0] : hi[0], lo[1] : hi[1], lo[2] : hi[2]] = v
    return side, g


def thickness(pv) -> dict:
    from kinbox.workspace import BOUNDARY

    _, g = _grid(pv)
    runs: list[int] = []
    for ax in range(3):
        lines = np.moveaxis(g, ax, -1).reshape(-1, g.shape[ax]) == BOUNDARY
        for line in lines:
            k = 0
            for b in line:
                if b:
                    k += 1
                elif k:
                    runs.append(k)
                    k = 0
            if k:
                runs.append(k)
    r = np.array(runs) if runs else np.zeros(1, dtype=int)
    return {"runs": int(len(runs)), "max_run": int(r.max()), "share_at_most_2": float(np.mean(r <= 2)), "median_run": float(np.median(r))}


def compare(pv, P: np.ndarray) -> dict:
    """Samples in outside boxes (must be 0), and the sampled map's reached volume."""
    from kinbox.workspace import INSIDE, OUTSIDE

    side, g = _grid(pv)
    idx = np.floor((P - pv.region[0]) / side).astype(int)
    ok = np.all((idx >= 0) & (idx < np.array(g.shape)), axis=1)
    idx = idx[ok]
    cells = np.unique(idx, axis=0)
    v = g[cells[:, 0], cells[:, 1], cells[:, 2]]
    # a sample in an outside box: checked against the boxes themselves, not the grid
    bad = 0
    Pin = P[ok]
    for lo, hi in zip(pv.lo[pv.verdict == OUTSIDE], pv.hi[pv.verdict == OUTSIDE]):
        bad += int(np.all((Pin >= lo) & (Pin <= hi), axis=1).sum())
    cell = float(np.prod(side))
    return {
        "samples_in_region": int(ok.sum()),
        "reached_cells": int(len(cells)),
        "reached_volume": len(cells) * cell,
        "reached_cells_in_inside_boxes": int(np.sum(v == INSIDE)),
        "samples_in_outside_boxes": bad,
    }


def main() -> None:
    from kinbox.workspace import reach

    ap = argparse.ArgumentParser()
    ap.add_argument("--robot", default="ur5")
    ap.add_argument("--frame", default="tool0")
    ap.add_argument("--region", nargs=6, type=float, default=[0.0, -0.1, -0.3, 1.0, 0.1, 0.7])
    ap.add_argument("--resolution", type=float, default=0.05)
    ap.add_argument("--samples", nargs="+", type=float, default=[1e5, 1e6])
    ap.add_argument("--dask-region", nargs=6, type=float, default=[-0.4, -0.4, -0.2, 0.4, 0.4, 0.6])
    ap.add_argument("--dask-resolution", type=float, default=0.05)
    ap.add_argument("--no-dask", action="store_true")
    ap.add_argument("--record", action="store_true")
    ap.add_argument("--dask-only", action="store_true", help="measure Dask again; keep the recorded sampling rows")
    a = ap.parse_args()
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import report

    cal = report.calibrate()
    if a.dask_only:
        import sys
        from pathlib import Path

        sys.path.insert(0, str(Path(__file__).resolve().parent))
        import report

        old = [r for r in report.load_raw(report.RAW).get("workspace-free", {}).get("rows", []) if "speedup" not in r]
        row = dask_row(a.robot, a.frame, a.dask_region, a.dask_resolution)
        print(json.dumps(row), flush=True)
        if a.record:
            report.record("workspace-free", [*old, row], calibration=cal)
        return
    rows = []
    cpu = time.process_time()
    pv = reach(a.robot, a.frame, "any", region=a.region, resolution=a.resolution)
    paving_cpu = time.process_time() - cpu
    print(pv.table(), flush=True)
    th = thickness(pv)
    for n in a.samples:
        cpu = time.process_time()
        P = sample_positions(a.robot, a.frame, int(n))
        s_cpu = time.process_time() - cpu
        row = {
            "case": f"{a.robot} {a.frame}, any orientation",
            "region": a.region,
            "resolution": a.resolution,
            "complete": pv.complete,
            "volumes": pv.volumes(),
            "counts": pv.counts(),
            "paving_cpu_s": paving_cpu,
            "samples": int(n),
            "sampling_cpu_s": s_cpu,
            **compare(pv, P),
            "boundary_thickness": th,
        }
        print(json.dumps(row), flush=True)
        rows.append(row)
    if not a.no_dask:
        rows.append(dask_row(a.robot, a.frame, a.dask_region, a.dask_resolution))
        print(json.dumps(rows[-1]), flush=True)
    if a.record:
        import sys
        from pathlib import Path

        sys.path.insert(0, str(Path(__file__).resolve().parent))
        import report

        report.record("workspace-free", rows, calibration=cal)


def dask_row(robot: str, frame: str, region, resolution: float) -> dict:
    """The tool-down map serially and on a LocalCluster(2 processes): wall times, same paving."""
    from distributed import Client, LocalCluster

    from kinbox.workspace import reach

    load = os.getloadavg()[0]
    w = time.perf_counter()
    serial = reach(robot, frame, (1.0, 0.0, 0.0, 0.0), region=region, resolution=resolution)
    t_serial = time.perf_counter() - w
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=40)
    client = Client(cluster)
    try:
        reach(robot, frame, (1.0, 0.0, 0.0, 0.0), region=region, resolution=4 * resolution, executor=client)  # workers warm
        w = time.perf_counter()
        dask = reach(robot, frame, (1.0, 0.0, 0.0, 0.0), region=region, resolution=resolution, executor=client)
        t_dask = time.perf_counter() - w
    finally:
        client.close()
        cluster.close()
    same = bool(np.array_equal(serial.lo, dask.lo) and np.array_equal(serial.hi, dask.hi) and np.array_equal(serial.verdict, dask.verdict))
    return {
        "case": f"{robot} {frame}, orientation 1 0 0 0: serial vs Dask LocalCluster(2)",
        "region": list(region),
        "resolution": resolution,
        "boxes": int(len(serial.verdict)),
        "serial_wall_s": t_serial,
        "dask_wall_s": t_dask,
        "speedup": t_serial / t_dask,
        "same_paving": same,
        "load": load,
    }


if __name__ == "__main__":
    main()
