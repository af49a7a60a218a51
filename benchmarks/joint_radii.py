#!/usr/bin/env python3
"""The cost of the model's radii in the closed forms' joint-angle certificate, measured in one run.

The default certificate of ``IK.solve_array`` (Krawczyk in the six joint angles,
:mod:`kinbox.search.cf_certify`) takes the arm's links as midpoint and radius and the goal's
constant frames as intervals (the enclosures of :mod:`kinbox.formulation.constants`), so that it
covers the model as given. This script solves the same random poses with that certifier and
with one whose radii are zero (the template's binary64 constants taken as exact), interleaved
chunk by chunk (the order alternating) in one process, and reports per arm the median CPU
microseconds per pose (batch: over chunks; single pose: the median of 21 one-pose calls), their
ratios, the poses each sends to the branch and prune, whether both give the same
configurations, and the median width of the proof boxes.

    python benchmarks/joint_radii.py [--batch 6000] [--chunk 250] [--print]

Records its rows on docs/benchmarks.md (``report.record``, key ``joint-certificate-radii``)
unless ``--print``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))
sys.path.insert(0, str(ROOT / "benchmarks"))

import report  # noqa: E402

from kinbox.pipeline import IK  # noqa: E402
from kinbox.search.cf_certify import JointCertifier  # noqa: E402

ARMS = {
    "UR5": ("ur5", "tool0", {}),
    "IRB 120-like (DH)": (str(ROOT / "tests" / "data" / "arms" / "irb120_dh.json"), "tool", {}),
    "Panda, joint 7 locked": ("panda", "panda_hand", {"panda_joint7": 0.5}),
}


def log(*a) -> None:
    print(*a, file=sys.stderr, flush=True)


def random_poses(ik: IK, n: int, seed: int) -> np.ndarray:
    """XYZQUAT of ``n`` poses of random configurations within the limits (locked joints at
    their values)."""
    import pinocchio as pin

    model = ik.robot.model
    rng = np.random.default_rng(seed)
    lo, hi = model.lowerPositionLimit, model.upperPositionLimit
    out = []
    for _ in range(n):
        q = np.clip(rng.uniform(np.maximum(lo, -np.pi), np.minimum(hi, np.pi)), lo, hi)
        for name, v in ik.robot.locked.items():
            jm = model.joints[model.getJointId(name)]
            q[jm.idx_q] = float(np.ravel(v)[0])
        out.append(pin.SE3ToXYZQUAT(ik.pose_at(q)))
    return np.array(out)


def bench_arm(name: str, n: int, chunk: int) -> dict:
    robot, frame, lock = ARMS[name]
    ik = IK(robot, frame, lock=lock)
    ik.prepare()
    cf = ik.closed_form
    arm = ik.arm
    with_radii = cf.joint_certifier
    without = JointCertifier(arm.geometry, cf.joints, cf.gamma, None)
    variants = {"radii": with_radii, "zero": without}
    P = random_poses(ik, n, seed=1)
    for jc in variants.values():  # kernels loaded
        cf.joint_certifier = jc
        ik.solve_array(P[:2])
    batch: dict[str, list[float]] = {k: [] for k in variants}
    for i, s in enumerate(range(0, n, chunk)):
        part = P[s : s + chunk]
        for key in list(variants) if i % 2 == 0 else list(reversed(variants)):
            cf.joint_certifier = variants[key]
            t = time.process_time()
            ik.solve_array(part)
            batch[key].append((time.process_time() - t) / len(part))
    single: dict[str, list[float]] = {k: [] for k in variants}
    for k in range(2, 23):
        for key in list(variants) if k % 2 == 0 else list(reversed(variants)):
            cf.joint_certifier = variants[key]
            t = time.process_time()
            ik.solve_array(P[k : k + 1])
            single[key].append(time.process_time() - t)
    answers = {}
    for key, jc in variants.items():
        cf.joint_certifier = jc
        answers[key] = ik.solve_array(P)
    cf.joint_certifier = with_radii
    a, b = answers["radii"], answers["zero"]
    same = all(len(a.solutions(k)) == len(b.solutions(k)) for k in range(n))
    R = np.array([report_rotation(p) for p in P[:2000]])
    t = P[:2000, :3]
    widths = {}
    for key, jc in variants.items():
        cf.joint_certifier = jc
        from kinbox.search.cf_batch import run_batch

        bt = run_batch(cf, cf.certifier, R, t, V=P[:2000], certificate="joint")
        widths[key] = float(np.median(np.max(bt.jhi - bt.jlo, axis=1))) if len(bt.jhi) else None
    cf.joint_certifier = with_radii
    row = {
        "arm": name,
        "poses": n,
        "batch_radii_us": statistics.median(batch["radii"]) * 1e6,
        "batch_zero_us": statistics.median(batch["zero"]) * 1e6,
        "batch_ratio": statistics.median(batch["radii"]) / statistics.median(batch["zero"]),
        "batch_ratio_chunks_median": statistics.median(x / y for x, y in zip(batch["radii"], batch["zero"])),
        "single_radii_us": statistics.median(single["radii"]) * 1e6,
        "single_zero_us": statistics.median(single["zero"]) * 1e6,
        "single_ratio": statistics.median(single["radii"]) / statistics.median(single["zero"]),
        "fallback_radii": int(np.sum(np.asarray(a.method) != "closed-form")),
        "fallback_zero": int(np.sum(np.asarray(b.method) != "closed-form")),
        "same_counts": bool(same),
        "box_width_radii": widths["radii"],
        "box_width_zero": widths["zero"],
    }
    log(f"{name}: batch {row['batch_radii_us']:.1f} / {row['batch_zero_us']:.1f} us, ratio {row['batch_ratio']:.3f}")
    return row


def report_rotation(v: np.ndarray) -> np.ndarray:
    import pinocchio as pin

    return pin.XYZQUATToSE3(v).rotation


def _fmt(v, f="{:.1f}") -> str:
    return "-" if v is None else f.format(v)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--batch", type=int, default=6000, help="poses per arm (default 6000)")
    ap.add_argument("--chunk", type=int, default=250, help="poses per timed chunk")
    ap.add_argument("--print", action="store_true", help="print instead of recording")
    a = ap.parse_args()
    calibration = report.calibrate()
    log(f"joint_radii: machine {json.dumps(report.machine())}; calibration {calibration:.3f} s CPU")
    rows = [bench_arm(name, a.batch, a.chunk) for name in ARMS]
    if a.print:
        print(json.dumps(rows, indent=1))
        return 0
    report.record("joint-certificate-radii", rows, calibration=calibration, mode=f"{a.batch} poses per arm, chunks of {a.chunk}")
    log(f"recorded on {report.PAGE}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
