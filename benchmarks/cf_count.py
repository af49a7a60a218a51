#!/usr/bin/env python3
"""The closed form's count proof with the links' radii: how often a pose goes on, what it costs.

For the closed-form benchmark's arms and poses (``benchmarks/closed_form.py``: UR5, the IRB
120-like DH arm, the Panda with ``panda_joint7`` locked; random configurations in the limits),
the compiled batch (:func:`kinbox.search.cf_batch.run_batch`, Krawczyk in the joint angles,
the default) is run on this source tree and, with ``--other SRC``, on another one (e.g. the
main branch's ``src``), each in its own process, turn by turn (``--rounds``), in one run:

* poses the batch sends to the branch and prune (``status`` not closed form), per tree;
* the batch's CPU per pose (``time.process_time`` over the whole batch, the median over the
  rounds) and its ratio to the other tree's.

Prints a table and writes ``benchmarks/results/cf_count.json``.

    python benchmarks/cf_count.py --poses 3000 --rounds 5 --other ../main/src [--no-aot]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
ARMS = {
    "UR5": ("ur5", "tool0", {}),
    "IRB 120-like (DH)": (str(ROOT / "tests" / "data" / "arms" / "irb120_dh.json"), "tool", {}),
    "Panda, joint 7 locked": ("panda", "panda_hand", {"panda_joint7": 0.5}),
}


def worker(arm: str, n: int, seed: int, repeats: int) -> dict:
    """In this process (kinbox from ``sys.path``): the batch over ``n`` poses, ``repeats``
    times after one warm-up call; CPU per pose of each and the poses sent on."""
    import numpy as np
    import pinocchio as pin

    import kinbox
    from kinbox.search.cf_batch import run_batch

    sys.path.insert(0, str(ROOT / "benchmarks"))
    from closed_form import poses_of, random_qs

    robot, frame, lock = ARMS[arm]
    ik = kinbox.IK(robot, frame, lock=lock)
    cf = ik.closed_form
    V = poses_of(ik, random_qs(ik, n, seed))
    M = [pin.XYZQUATToSE3(v) for v in V]
    R = np.array([m.rotation for m in M])
    t = np.array([m.translation for m in M])
    b = run_batch(cf, cf.certifier, R[:10], t[:10], V=V[:10], certificate="joint")
    cpu = []
    for _ in range(repeats):
        c0 = time.process_time()
        b = run_batch(cf, cf.certifier, R, t, V=V, certificate="joint")
        cpu.append((time.process_time() - c0) / n)
    return {
        "source": str(Path(kinbox.__file__).resolve().parents[1]),
        "cpu_per_pose": cpu,
        "sent_on": int(np.sum(b.status != 0)),
        "roots": int(np.sum(b.count)),
    }


def run_worker(src: Path, arm: str, n: int, seed: int, repeats: int, no_aot: bool = False) -> dict:
    env = dict(os.environ, PYTHONPATH=str(src))
    if no_aot:  # both trees on numba's compiled kernels (a changed kernel's source has no module)
        env["KINBOX_NO_AOT"] = "1"
    out = subprocess.run(
        [sys.executable, __file__, "--worker", arm, "--poses", str(n), "--seed", str(seed), "--repeats", str(repeats)],
        env=env,
        check=True,
        capture_output=True,
        text=True,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses", type=int, default=3000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--other", type=Path, default=None, help="another kinbox source tree to compare with")
    ap.add_argument("--no-aot", action="store_true", help="numba's kernels in both trees, not the ahead-of-time module")
    ap.add_argument("--worker", default=None, help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.worker is not None:
        print(json.dumps(worker(a.worker, a.poses, a.seed, a.repeats)))
        return 0
    trees = {"this": ROOT / "src"}
    if a.other is not None:
        trees["other"] = a.other.resolve()
    rows = []
    for arm in ARMS:
        runs: dict[str, list[dict]] = {k: [] for k in trees}
        for r in range(a.rounds):
            for name, src in trees.items():
                res = run_worker(src, arm, a.poses, a.seed, a.repeats, a.no_aot)
                runs[name].append(res)
                print(f"{arm} round {r} {name}: {min(res['cpu_per_pose']) * 1e6:.1f} us/pose, sent on {res['sent_on']}", file=sys.stderr)
        row: dict = {"arm": arm, "poses": a.poses}
        for name in trees:
            row[f"{name}_us_per_pose"] = statistics.median(min(x["cpu_per_pose"]) for x in runs[name]) * 1e6
            row[f"{name}_sent_on"] = runs[name][0]["sent_on"]
            row[f"{name}_roots"] = runs[name][0]["roots"]
        if "other" in trees:
            ratios = [min(x["cpu_per_pose"]) / min(y["cpu_per_pose"]) for x, y in zip(runs["this"], runs["other"])]
            row["ratio"] = statistics.median(ratios)
            row["ratios"] = ratios
        rows.append(row)
    out = ROOT / "benchmarks" / "results" / "cf_count.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(rows, indent=1) + "\n", encoding="utf-8")
    print("| arm | poses | sent on (this) | sent on (other) | us/pose (this) | us/pose (other) | ratio |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['arm']} | {r['poses']} | {r['this_sent_on']} | {r.get('other_sent_on', '-')} | {r['this_us_per_pose']:.1f} | "
            f"{r.get('other_us_per_pose', float('nan')):.1f} | {r.get('ratio', float('nan')):.3f} |"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
