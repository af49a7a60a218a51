"""Workspace paving (kinbox.workspace) against a sampled map of the same region.

The sampled map solves the ordinary IK at the centre of every voxel of a grid at the paving's
resolution (a reachability map from IK at grid poses): a voxel is "reached" when its centre is.
The paving is sound when no voxel centre the sampled map reaches lies in an outside box; it
says more where its inside boxes are proven for every point, not one.

    python benchmarks/workspace.py --resolution 0.05 --json out.json
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np


def calibrate() -> float:
    """CPU seconds of a fixed pure-Python loop of 1e7 additions (the machine's speed)."""
    t = time.process_time()
    s = 0
    for i in range(10_000_000):
        s += i
    return time.process_time() - t


def main() -> None:
    from kinbox.pipeline import IK
    from kinbox.workspace import INSIDE, OUTSIDE, reach

    ap = argparse.ArgumentParser()
    ap.add_argument("--robot", default="ur5")
    ap.add_argument("--frame", default="tool0")
    ap.add_argument("--orientation", nargs=4, type=float, default=[1.0, 0.0, 0.0, 0.0])
    ap.add_argument("--region", nargs=6, type=float, default=[0.2, -0.2, 0.0, 0.6, 0.2, 0.4])
    ap.add_argument("--resolution", type=float, default=0.05)
    ap.add_argument("--workers", type=int)
    ap.add_argument("--json")
    a = ap.parse_args()
    cal = calibrate()
    print(f"calibration: {cal:.3f} s CPU for 1e7 Python additions")
    cpu = time.process_time()
    pv = reach(a.robot, a.frame, a.orientation, region=a.region, resolution=a.resolution, workers=a.workers)
    paving_cpu = time.process_time() - cpu
    print(pv.table())
    reg = np.array(a.region).reshape(2, 3)
    n = np.maximum(np.round((reg[1] - reg[0]) / a.resolution).astype(int), 1)
    axes = [reg[0][k] + (np.arange(n[k]) + 0.5) * (reg[1][k] - reg[0][k]) / n[k] for k in range(3)]
    ik = IK(a.robot, a.frame, formulation="arm")
    cpu = time.process_time()
    reached, unsound, in_inside = 0, 0, 0
    for x in axes[0]:
        for y in axes[1]:
            for z in axes[2]:
                t = np.array([x, y, z])
                res = ik.solve(np.concatenate([t, a.orientation]))
                if not res.solutions:
                    continue
                reached += 1
                where = np.all((pv.lo <= t) & (t <= pv.hi), axis=1)
                if np.any(pv.verdict[where] == OUTSIDE):
                    unsound += 1
                if np.any(pv.verdict[where] == INSIDE):
                    in_inside += 1
    sampled_cpu = time.process_time() - cpu
    voxel = float(np.prod((reg[1] - reg[0]) / n))
    row = {
        "robot": a.robot,
        "resolution": a.resolution,
        "region": a.region,
        "calibration_s": cal,
        "paving_cpu_s": paving_cpu,
        "paving_volumes": pv.volumes(),
        "paving_counts": pv.counts(),
        "sampled_voxels": int(np.prod(n)),
        "sampled_reached": reached,
        "sampled_reached_volume": reached * voxel,
        "sampled_cpu_s": sampled_cpu,
        "reached_in_outside_box": unsound,
        "reached_in_inside_box": in_inside,
    }
    print(json.dumps(row, indent=1))
    if a.json:
        with open(a.json, "w") as f:
            json.dump(row, f, indent=1)


if __name__ == "__main__":
    main()
