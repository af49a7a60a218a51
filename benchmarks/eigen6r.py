#!/usr/bin/env python3
"""CPU milliseconds per pose of general 6R arms from URDF: the eigenvalue path against the branch and prune.

Arms: the general 6R loop of the CuikSuite example (kinbox's ``general-6r``, written as a URDF
arm whose tool must reach a pose; its identity pose has the 16 real roots) and random general
6R arms of the fuzz harness (``tests/support/fuzz_arms.py``, class ``general_6r``), each loaded
from its URDF text. Poses: the arm's generating pose and Pinocchio forward kinematics of seeded
random configurations. Each pose is solved twice in this process, after one call that loads
the kernels: ``IK.solve(goal)`` (the eigenvalue path where its proof holds, else the branch
and prune) and ``IK.solve(goal, closed_form=False)`` (the branch and prune alone, the path every
general 6R pose took before), and their solution sets are compared.

    python benchmarks/eigen6r.py [--poses 10] [--arms 3]

Writes ``benchmarks/results/eigen6r.json`` and its table on ``docs/benchmarks.md``
(``report.record``, key ``eigen-6r``).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pinocchio as pin

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

import report  # noqa: E402

import kinbox  # noqa: E402
from tests.support import fuzz_arms as fa  # noqa: E402


def serial6r(directory: str) -> tuple[str, str, pin.Model]:
    dh = json.loads((ROOT / "src" / "kinbox" / "robots" / "general-6r.json").read_text())["dh"]
    rows = [(r["alpha"], r["a"], r["d"], 0.0, "R") for r in dh]
    arm = fa.arm_from_dh("general_6r", np.random.default_rng(0), rows, gauge="random")
    for j in arm.joints:
        j.kind, j.lower, j.upper = "continuous", -math.pi, math.pi
    path = Path(directory) / "serial6r.urdf"
    text = arm.urdf("serial6r")
    path.write_text(text)
    return str(path), "tool", pin.buildModelFromXML(text)


def same_sets(model, a, b) -> bool:
    va = [fa.joint_values(model, s.q) for s in a.solutions]
    vb = [fa.joint_values(model, s.q) for s in b.solutions]
    if len(va) != len(vb):
        return False
    return all(min(fa.value_distance(model, x, y) for y in vb) < 1e-6 for x in va)


def run_arm(name: str, robot: str, frame: str, model: pin.Model, goals: list, progress) -> dict:
    ik = kinbox.IK(robot, frame)
    c0 = time.process_time()
    ik.solve(goals[0])  # the first call loads the kernels and builds the arm's elimination
    first = time.process_time() - c0
    from kinbox.search.eigen6r import certify

    fast, slow, core, methods, roots, agree, certified = [], [], [], [], [], 0, 0
    for k, g in enumerate(goals):
        c0 = time.process_time()
        r = ik.solve(g)
        fast.append(time.process_time() - c0)
        c0 = time.process_time()
        done = ik.eigen6r is not None and certify(ik.eigen6r, g.rotation, g.translation) is not None
        if done:  # the certified roots alone, without the checked Result
            core.append(time.process_time() - c0)
        c0 = time.process_time()
        b = ik.solve(g, closed_form=False)
        slow.append(time.process_time() - c0)
        methods.append(r.stats["method"])
        roots.append(len(r.solutions))
        certified += all(s.certified for s in r.solutions) and r.complete
        agree += same_sets(model, r, b) and r.complete and b.complete
        ms = f"{fast[-1] * 1e3:.1f} ms / {slow[-1] * 1e3:.1f} ms"
        progress(f"{name} pose {k + 1}/{len(goals)}: {r.stats['method']}, {len(r.solutions)} roots, {ms}")
    fast_a, slow_a = np.array(fast), np.array(slow)
    eig = np.array([m == "eigen-6r" for m in methods])
    return {
        "arm": name,
        "poses": len(goals),
        "eigen_share": int(eig.sum()),
        "roots_mean": float(np.mean(roots)),
        "median_ms": float(np.median(fast_a) * 1e3),
        "median_eigen_ms": float(np.median(fast_a[eig]) * 1e3) if eig.any() else None,
        "median_core_ms": float(np.median(core) * 1e3) if core else None,
        "median_search_ms": float(np.median(slow_a) * 1e3),
        "ratio": float(np.median(slow_a) / np.median(fast_a)),
        "first_call_ms": first * 1e3,
        "all_certified_complete": int(certified),
        "same_sets": int(agree),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--poses", type=int, default=10, help="random poses per arm (besides its generating pose)")
    ap.add_argument("--arms", type=int, default=3, help="random general 6R arms of the fuzz harness")
    ap.add_argument("--no-record", action="store_true", help="print only; do not write the JSON or the page")
    args = ap.parse_args(argv)
    calibration = report.calibrate()

    def progress(msg: str) -> None:
        print(msg, file=sys.stderr, flush=True)

    rows = []
    with tempfile.TemporaryDirectory() as d:
        robot, frame, model = serial6r(d)
        ik = kinbox.IK(robot, frame)
        rng = np.random.default_rng(6)
        goals = [pin.SE3.Identity()] + [ik.pose_at(rng.uniform(-math.pi, math.pi, 6)) for _ in range(args.poses)]
        rows.append(run_arm("Serial6R (CuikSuite general-6r)", robot, frame, model, goals, progress))
        for seed in range(1, args.arms + 1):
            case = fa.make_case("general_6r", seed, d)
            ik = kinbox.IK(case.robot, case.frame)
            rng = np.random.default_rng(seed)
            goals = [case.goal] + [ik.pose_at(fa.config_from_values(case.model, rng.uniform(-3, 3, 6))) for _ in range(args.poses)]
            rows.append(run_arm(f"fuzz general_6r seed {seed}", case.robot, case.frame, case.model, goals, progress))
    for r in rows:
        print(json.dumps(r))
    if not args.no_record:
        out = ROOT / "benchmarks" / "results" / "eigen6r.json"
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps({"calibration_seconds": calibration, "rows": rows}, indent=1) + "\n")
        report.record("eigen-6r", rows, calibration=calibration, mode=f"{args.poses + 1} poses per arm")
    return 0


if __name__ == "__main__":
    sys.exit(main())
