"""Workspace pavings (kinbox.workspace): an arm against a sampled map of the same region, and
parallel platforms' constant-orientation workspaces.

Arm: the sampled map solves the ordinary IK at the centre of every voxel of a grid at the
paving's resolution (a reachability map from IK at grid poses): a voxel is "reached" when its
centre is. The paving is sound when no voxel centre the sampled map reaches lies in an outside
box; it says more where its inside boxes are proven for every point, not one.

Platforms: Dietmeier's 6-6 Gough-Stewart platform held at the orientation of one of its
assembly modes (the home pose), legs within +-20 % of the lengths it sets; the 3-RPR of
3-rpr.json at one angle, legs within [10, 22]. Each verdict is checked at random positions of
its box by the legs' lengths computed with Pinocchio's forward kinematics.

    python benchmarks/workspace.py --resolution 0.05 --record    # arm and platforms, page rows
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np


def _platform_check(mech, pv, R, lo_len, hi_len, samples: int = 2) -> int:
    """Positions (random, ``samples`` per box) whose legs' lengths, by Pinocchio FK of the
    free-flyer platform, contradict their box's verdict."""
    import pinocchio as pin

    from kinbox.workspace import INSIDE, OUTSIDE

    model = mech.model
    data = model.createData()
    rng = np.random.default_rng(0)
    bad = 0
    for lo, hi, v in zip(pv.lo, pv.hi, pv.verdict):
        for t in lo + rng.uniform(0.02, 0.98, (samples, 3)) * (hi - lo):
            q = pin.neutral(model)
            q[:7] = pin.SE3ToXYZQUAT(pin.SE3(R, t))
            pin.forwardKinematics(model, data, q)
            L = np.array(
                [
                    np.linalg.norm((data.oMi[c.joint_a] * c.placement_a).translation - (data.oMi[c.joint_b] * c.placement_b).translation)
                    for c in mech.closures
                    if c.kind == "distance"
                ]
            )
            ok = bool(np.all((lo_len <= L) & (L <= hi_len)))
            bad += int((v == INSIDE and not ok) or (v == OUTSIDE and ok))
    return bad


def platform_rows(resolution: float) -> list[dict]:
    import pinocchio as pin

    import kinbox
    from kinbox.model.loading import load
    from kinbox.workspace import reach_platform

    rows = []
    mech = load("dietmeier")
    home = kinbox.solve("dietmeier")
    pose = next(s.platform["pose"] for s in home.solutions if s.certified and s.platform)
    quat = pose[3:]
    R = pin.Quaternion(quat[3], *quat[:3]).toRotationMatrix()
    cpu = time.process_time()
    pv = reach_platform(mech, quat, legs_scale=(0.8, 1.2), resolution=resolution)
    cpu = time.process_time() - cpu
    lengths = np.array([c.length for c in mech.closures if c.kind == "distance"])
    rows.append(_row("Dietmeier 6-6, legs +-20 %, home orientation", pv, cpu, _platform_check(mech, pv, R, 0.8 * lengths, 1.2 * lengths)))
    cpu = time.process_time()
    pv = reach_platform("3-rpr", 0.4, legs=(10.0, 22.0), resolution=resolution * 10.0)
    cpu = time.process_time() - cpu
    rows.append(_row("3-RPR (3-rpr.json), legs [10, 22], angle 0.4", pv, cpu, None))
    return rows


def _row(case: str, pv, cpu: float, bad: int | None) -> dict:
    return {
        "case": case,
        "region": [pv.region[0].tolist(), pv.region[1].tolist()],
        "resolution": pv.resolution,
        "complete": pv.complete,
        "counts": pv.counts(),
        "volumes": pv.volumes(),
        "cpu_s": cpu,
        "check_contradictions": bad,
    }


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
    ap.add_argument("--record", action="store_true", help="write the rows to docs/benchmarks.json and the page")
    ap.add_argument("--platforms-only", action="store_true")
    ap.add_argument("--cube", type=float, default=1.8, help="the side of the cube about the base paved at --cube-resolution (0: skip)")
    ap.add_argument("--cube-resolution", type=float, default=0.02)
    a = ap.parse_args()
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import report

    cal = report.calibrate()
    print(f"calibration: {cal:.3f} s CPU for 1e7 Python additions")
    rows = platform_rows(a.resolution / 2.5)
    if a.cube > 0 and not a.platforms_only:
        h = a.cube / 2.0
        cpu = time.process_time()
        big = reach(a.robot, a.frame, a.orientation, region=(-h, -h, -h, h, h, h), resolution=a.cube_resolution, workers=a.workers)
        name = f"{a.robot} {a.frame}, orientation {' '.join(f'{v:g}' for v in a.orientation)}, {a.cube:g} m cube"
        row = _row(name, big, time.process_time() - cpu, None)
        print(json.dumps(row))
        rows.insert(0, row)
    for r in rows:
        print(json.dumps(r))
    if a.platforms_only:
        if a.record:
            _record(rows, cal)
        return
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
    arm = _row(f"{a.robot} {a.frame}, orientation {' '.join(f'{v:g}' for v in a.orientation)}", pv, paving_cpu, unsound)
    arm["sampled"] = {"voxels": row["sampled_voxels"], "reached": reached, "in_inside_box": in_inside, "cpu_s": sampled_cpu}
    if a.record:
        _record([arm, *rows], cal)


def _record(rows: list[dict], cal: float) -> None:
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import report

    report.record("workspace", rows, calibration=cal)


if __name__ == "__main__":
    main()
