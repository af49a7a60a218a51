#!/usr/bin/env python3
"""The closed form on arms whose link rotations are no signed permutations, against the branch
and prune they were sent to while the closed form proved no count for them.

The arms are ``tests/support/kr6_dh.py``'s ``TWISTED`` (a KR6-like spherical-wrist arm with
twists of 60 and 45 degrees, a UR-like arm with twists of no right angle), written as URDF.
Per arm, over random configurations' poses (after one warm-up pose, turn by turn in one run):
``IK.solve`` (the closed form, each root certified by Krawczyk in the joint angles) and
``IK.solve(..., closed_form=False)`` (the branch and prune); the CPU per pose
(``time.process_time``) of each, their ratio, and how many poses each method answered.

    python benchmarks/cf_twist.py [--poses 40]

Prints a table and the rows as JSON.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))
sys.path.insert(0, str(ROOT))

import kinbox  # noqa: E402
from tests.support import kr6_dh  # noqa: E402


def run(family: str, rows: list, n: int, folder: Path) -> dict:
    path = folder / f"{family}.urdf"
    path.write_text(kr6_dh.urdf(rows, name="twisted"))
    ik = kinbox.IK(str(path), "tool0")
    qs = np.random.default_rng(3).uniform(-2.5, 2.5, (n + 1, 6))
    poses = [ik.pose_at(q) for q in qs]
    ik.solve(poses[0])
    ik.solve(poses[0], closed_form=False)  # warm-up: loading, compiling
    cpu = {"closed form": 0.0, "branch and prune": 0.0}
    methods: dict[str, int] = {}
    same = 0
    for p in poses[1:]:
        t0 = time.process_time()
        a = ik.solve(p)
        t1 = time.process_time()
        b = ik.solve(p, closed_form=False)
        t2 = time.process_time()
        cpu["closed form"] += t1 - t0
        cpu["branch and prune"] += t2 - t1
        methods[a.stats["method"]] = methods.get(a.stats["method"], 0) + 1
        same += len(a.solutions) == len(b.solutions)
    cf_us, bp_us = (1e6 * cpu[k] / n for k in ("closed form", "branch and prune"))
    return {
        "arm": family,
        "poses": n,
        "answered by": methods,
        "same count": same,
        "closed form us/pose": round(cf_us, 1),
        "branch and prune us/pose": round(bp_us, 1),
        "ratio": round(bp_us / cf_us, 1),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses", type=int, default=40)
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as d:
        for family, dh in sorted(kr6_dh.TWISTED.items()):
            rows.append(run(family, dh, args.poses, Path(d)))
            print(f"{family}: done", file=sys.stderr, flush=True)
    print("| arm | poses | answered by | same count | closed form (us/pose) | branch and prune (us/pose) | ratio |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['arm']} | {r['poses']} | {r['answered by']} | {r['same count']} | {r['closed form us/pose']} "
            f"| {r['branch and prune us/pose']} | {r['ratio']}x |"
        )
    print(json.dumps(rows))


if __name__ == "__main__":
    main()
