"""The boundary layer of a fixed-orientation arm paving: how thick, and why.

Thickness: the paving drawn on the grid of its smallest boxes; for every boundary cell, the
distance in cells (chessboard: a step to any of the 26 neighbours) to the nearest inside cell
and to the nearest outside cell. Through a layer between an inside and an outside cell the
layer's local thickness is ``d_in + d_out - 1`` boundary cells; a boundary cell with no cell of
one kind near it lies in a layer as thick as that distance. Reported: the distribution of the
thickness (median, the share of cells at most 2, the largest), and the runs of boundary cells
along the grid lines (as in workspace_free.py). Where the border runs along a face of the
region, the cells it crosses there have their other side beyond the region: the cells beyond
the faces within two cells of a boundary cell are decided too (``--no-ring`` skips it) and the
thickness is reported again with them (``with_ring``).

Check (``--check N``): at 4 random positions in each of N inside and N outside boxes, the
closed form of the position must agree (a root within the limits, whose configuration puts the
frame there by Pinocchio's forward kinematics, for an inside box; none for an outside box).

Why: each boundary box is probed at its 27 grid points (corners, edge and face middles, centre)
by the closed form's IK of the point (``ClosedForm.roots``, a root within the limits): *all
reached* (likely wholly inside: the inside test is the weaker), *none reached* (likely wholly
outside: the outside test), *mixed* (the workspace's border crosses the box: boundary at any
test).

    python benchmarks/workspace_layer.py --region -0.9 0.2 -0.9 0.9 0.26 0.9 --resolution 0.03
    python benchmarks/workspace_layer.py --region -0.9 -0.9 -0.9 0.9 0.9 0.9 --resolution 0.05 --no-probe
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))


def layer(pv, decider=None, ring: int = 2) -> dict:
    """Thickness of the boundary layer, per boundary cell of the paving's finest grid.

    Where the border runs along a face of the region, the cells it crosses there have their
    other side beyond the region: with ``decider`` (a :class:`kinbox.workspace.Reach`), the
    cells beyond the faces within ``ring`` cells of a boundary cell are decided too (as boxes at
    the resolution), and the layer is measured again with them (``with_ring``)."""
    from scipy.ndimage import binary_dilation
    from workspace_free import _grid, thickness

    from kinbox.workspace import BOUNDARY

    side, g = _grid(pv)
    out = {**_thickness(g), "runs": thickness(pv)}
    if decider is not None:
        G = np.full(tuple(n + 2 * ring for n in g.shape), -1, dtype=np.int8)
        core = tuple(slice(ring, ring + n) for n in g.shape)
        G[core] = g
        b = np.zeros(G.shape, dtype=bool)
        b[core] = g == BOUNDARY
        todo = binary_dilation(b, structure=np.ones((3,) * g.ndim, dtype=bool), iterations=ring) & (G == -1)
        res = float(side.max()) * (1.0 + 1e-9)
        for idx in np.argwhere(todo):
            lo = pv.region[0] + (idx - ring) * side
            G[tuple(idx)] = decider.decide(lo, lo + side, res)[0]
        th = _thickness(G, core)
        out["with_ring"] = {"cells_decided": int(todo.sum()), **th}
    return out


def _thickness(g, core=None) -> dict:
    """``d_in + d_out - 1`` per boundary cell of ``g`` (those within ``core`` only)."""
    from scipy.ndimage import distance_transform_cdt

    from kinbox.workspace import BOUNDARY, INSIDE, OUTSIDE

    big = int(sum(g.shape))
    d_in = distance_transform_cdt(g != INSIDE, metric="chessboard") if np.any(g == INSIDE) else np.full(g.shape, big)
    d_out = distance_transform_cdt(g != OUTSIDE, metric="chessboard") if np.any(g == OUTSIDE) else np.full(g.shape, big)
    b = g == BOUNDARY
    if core is not None:
        keep = np.zeros(g.shape, dtype=bool)
        keep[core] = True
        b &= keep
    th = (d_in[b] + d_out[b] - 1).astype(int)
    hist = np.bincount(np.minimum(th, 10)) if th.size else np.zeros(1, dtype=int)
    return {
        "boundary_cells": int(b.sum()),
        "median": float(np.median(th)) if th.size else 0.0,
        "share_at_most_2": float(np.mean(th <= 2)) if th.size else 1.0,
        "max": int(th.max()) if th.size else 0,
        "histogram_1_to_10plus": hist[1:].tolist(),
    }


def check(robot: str, frame: str, orientation, pv, boxes: int, points: int, seed: int = 0) -> dict:
    """The verdicts against the closed form at random positions: in ``boxes`` boxes of each
    verdict, ``points`` positions each; an inside box's position has a root within the limits
    whose configuration puts the frame there by Pinocchio's forward kinematics, an outside
    box's position none (contradictions counted)."""
    import pinocchio as pin

    from kinbox.pipeline import IK
    from kinbox.workspace import INSIDE, OUTSIDE

    ik = IK(robot, frame, formulation="arm")
    cf = ik.closed_form
    q = np.asarray(orientation, dtype=float)
    R = pin.Quaternion(q[3], *q[:3]).toRotationMatrix()
    rng = np.random.default_rng(seed)
    out = {"inside_positions": 0, "outside_positions": 0, "contradictions": 0, "max_fk_error": 0.0}
    for verdict, key in ((INSIDE, "inside_positions"), (OUTSIDE, "outside_positions")):
        sel = np.flatnonzero(pv.verdict == verdict)
        for k in rng.choice(sel, size=min(boxes, sel.size), replace=False):
            for t in rng.uniform(pv.lo[k], pv.hi[k], (points, 3)):
                n, enc, ins = cf.roots(R, t)
                good = [j for j in range(max(n, 0)) if ins[j] == 1]
                out[key] += 1
                if n < 0:
                    continue  # the point's closed form undecided: no evidence either way
                if (verdict == INSIDE) != bool(good):
                    out["contradictions"] += 1
                for j in good[:1]:
                    pose = ik.pose_at(cf.configuration(enc[j]))
                    err = max(float(np.abs(pose.translation - t).max()), float(np.abs(pose.rotation - R).max()))
                    out["max_fk_error"] = max(out["max_fk_error"], err)
    return out


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


def _decider(robot: str, frame: str, orientation):
    from kinbox.pipeline import IK
    from kinbox.workspace import Reach

    return Reach(IK(robot, frame, formulation="arm"), tuple(orientation))


def main() -> None:
    from kinbox.workspace import reach

    ap = argparse.ArgumentParser()
    ap.add_argument("--robot", default="ur5")
    ap.add_argument("--frame", default="tool0")
    ap.add_argument("--orientation", nargs=4, type=float, default=[1.0, 0.0, 0.0, 0.0])
    ap.add_argument("--region", nargs=6, type=float, default=[-0.9, 0.2, -0.9, 0.9, 0.26, 0.9])
    ap.add_argument("--resolution", type=float, default=0.03)
    ap.add_argument("--no-probe", action="store_true")
    ap.add_argument("--no-ring", dest="ring", action="store_false", help="do not decide the cells beyond the region's faces")
    ap.add_argument("--check", type=int, default=300, help="boxes of each verdict checked at random positions (0: none)")
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
        "layer": layer(pv, _decider(a.robot, a.frame, a.orientation) if a.ring else None),
    }
    if a.check:
        row["check"] = check(a.robot, a.frame, a.orientation, pv, a.check, 4)
    if not a.no_probe:
        row["boundary_probe"] = probe(a.robot, a.frame, a.orientation, pv)
    print(json.dumps(row, indent=1))
    if a.record:
        import report
        from workspace_free import calibrate

        report.record("workspace-layer", [row], calibration=calibrate())


if __name__ == "__main__":
    main()
