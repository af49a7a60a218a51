"""The boundary layer of a fixed-orientation arm paving: how thick, and why.

Thickness: the paving drawn on the grid of its smallest boxes; for every boundary cell, the
distance in cells (chessboard: a step to any of the 26 neighbours) to the nearest inside cell
and to the nearest outside cell. Through a layer between an inside and an outside cell the
layer's local thickness is ``d_in + d_out - 1`` boundary cells; a boundary cell with no cell of
one kind near it lies in a layer as thick as that distance. Reported: the distribution of the
thickness (median, the share of cells at most 2, the largest), and the runs of boundary cells
along the grid lines (as in workspace_free.py).

Why: each boundary box is probed at its 27 grid points (corners, edge and face middles, centre)
by the closed form's IK of the point (``ClosedForm.roots``, a root within the limits): *all
reached* (likely wholly inside: the inside test is the weaker), *none reached* (likely wholly
outside: the outside test), *mixed* (the workspace's border crosses the box: boundary at any
test).

    python benchmarks/workspace_layer.py --region -0.9 0.2 -0.9 0.9 0.26 0.9 --resolution 0.03
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))


def layer(pv) -> dict:
    """Thickness of the boundary layer, per boundary cell of the paving's finest grid."""
    from scipy.ndimage import distance_transform_cdt
    from workspace_free import _grid, thickness

    from kinbox.workspace import BOUNDARY, INSIDE, OUTSIDE

    _, g = _grid(pv)
    big = int(sum(g.shape))
    d_in = distance_transform_cdt(g != INSIDE, metric="chessboard") if np.any(g == INSIDE) else np.full(g.shape, big)
    d_out = distance_transform_cdt(g != OUTSIDE, metric="chessboard") if np.any(g == OUTSIDE) else np.full(g.shape, big)
    b = g == BOUNDARY
    th = (d_in[b] + d_out[b] - 1).astype(int)
    hist = np.bincount(np.minimum(th, 10)) if th.size else np.zeros(1, dtype=int)
    return {
        "boundary_cells": int(b.sum()),
        "median": float(np.median(th)) if th.size else 0.0,
        "share_at_most_2": float(np.mean(th <= 2)) if th.size else 1.0,
        "max": int(th.max()) if th.size else 0,
        "histogram_1_to_10plus": hist[1:].tolist(),
        "runs": thickness(pv),
    }


def probe(robot: str, frame: str, orientation, pv) -> dict:
    """Boundary boxes by how many of their 27 grid points the closed form reaches."""
    import pinocchio as pin

    from kinbox.pipeline import IK
    from kinbox.workspace import BOUNDARY

    ik = IK(robot, frame, formulation="arm")
    cf = ik.closed_form
    q = np.asarray(orientation, dtype=float)
    R = pin.Quaternion(q[3], *q[:3]).toRotationMatrix()
    kinds = {"all_reached": 0, "none_reached": 0, "mixed": 0}
    f = np.array(np.meshgrid([0.0, 0.5, 1.0], [0.0, 0.5, 1.0], [0.0, 0.5, 1.0], indexing="ij")).reshape(3, -1).T
    for lo, hi in zip(pv.lo[pv.verdict == BOUNDARY], pv.hi[pv.verdict == BOUNDARY]):
        got = []
        for t in lo + f * (hi - lo):
            n, _, ins = cf.roots(R, t)
            got.append(bool(n > 0 and np.any(ins[: max(n, 0)] == 1)))
        kinds["all_reached" if all(got) else "none_reached" if not any(got) else "mixed"] += 1
    return kinds


def main() -> None:
    from kinbox.workspace import reach

    ap = argparse.ArgumentParser()
    ap.add_argument("--robot", default="ur5")
    ap.add_argument("--frame", default="tool0")
    ap.add_argument("--orientation", nargs=4, type=float, default=[1.0, 0.0, 0.0, 0.0])
    ap.add_argument("--region", nargs=6, type=float, default=[-0.9, 0.2, -0.9, 0.9, 0.26, 0.9])
    ap.add_argument("--resolution", type=float, default=0.03)
    ap.add_argument("--no-probe", action="store_true")
    ap.add_argument("--out", help="write the paving here (npz)")
    ap.add_argument("--record", action="store_true", help="write the row to docs/benchmarks.json (workspace-layer)")
    a = ap.parse_args()
    cpu = time.process_time()
    pv = reach(a.robot, a.frame, tuple(a.orientation), region=a.region, resolution=a.resolution)
    cpu = time.process_time() - cpu
    if a.out:
        pv.save(a.out)
    print(pv.table(), file=sys.stderr)
    row = {
        "case": f"{a.robot} {a.frame}, orientation {' '.join(f'{v:g}' for v in a.orientation)}",
        "region": a.region,
        "resolution": a.resolution,
        "volumes": pv.volumes(),
        "counts": pv.counts(),
        "cpu_s": cpu,
        "layer": layer(pv),
    }
    if not a.no_probe:
        row["boundary_probe"] = probe(a.robot, a.frame, a.orientation, pv)
    print(json.dumps(row, indent=1))
    if a.record:
        import report
        from workspace_free import calibrate

        report.record("workspace-layer", [row], calibration=calibrate())


if __name__ == "__main__":
    main()
