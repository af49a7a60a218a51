"""The cost of parameters as enclosures: the same poses solved with the arm template's rows
carrying the enclosures of the exact pose (``Compiled.merr``/``mgrad``, the default) and
without them (the rows as rounded taken as exact), interleaved pose by pose in one process so
that the ratio is measured on the same machine state.

    python benchmarks/enclosures.py --robot ur5 --count 100 --seed 1 [--json]

CPU seconds are ``time.process_time``; the first solve of each variant (kernels loaded) is
not counted. Prints the per-variant medians and means, their ratios, and the solution counts
(which must agree: enclosures may widen a certified box, never change what is found on
generic poses).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time

import numpy as np


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robot", default="ur5")
    ap.add_argument("--frame", default="tool0")
    ap.add_argument("--count", type=int, default=100)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args(argv)

    import kinbox

    ik = kinbox.IK(a.robot, a.frame)
    arm = ik.arm
    assert arm is not None and hasattr(arm, "params_enclosure"), "an arm with the arm template"
    enclosed = arm.bind

    def rounded(goal):  # the rows as rounded, taken as exact (no enclosure)
        return arm.template.bind(arm.params_binary64(goal), arm.param_magnitudes(goal))

    rng = np.random.default_rng(a.seed)
    goals = [ik.pose_at(q) for q in rng.uniform(-np.pi, np.pi, (a.count, len(ik.chain)))]
    variants = {"enclosed": enclosed, "rounded": rounded}
    cpu: dict[str, list[float]] = {k: [] for k in variants}
    sols: dict[str, list[int]] = {k: [] for k in variants}
    widths: dict[str, list[float]] = {k: [] for k in variants}
    for bind in variants.values():  # warm up: kernels loaded, template built
        arm.bind = bind
        ik.solve(goals[0], progress=False)
    for i, g in enumerate(goals):
        order = list(variants) if i % 2 == 0 else list(reversed(variants))
        for name in order:
            arm.bind = variants[name]
            c0 = time.process_time()
            r = ik.solve(g, progress=False)
            cpu[name].append(time.process_time() - c0)
            sols[name].append(len(r.solutions))
            widths[name] += [s.width for s in r.solutions if s.certified]
        if (i + 1) % 10 == 0:
            print(f"{i + 1}/{len(goals)} poses", file=sys.stderr)
    arm.bind = enclosed
    out: dict = {"robot": a.robot, "poses": len(goals), "seed": a.seed}
    for name in variants:
        c = np.array(cpu[name])
        out[name] = {
            "cpu_median_ms": 1e3 * float(np.median(c)),
            "cpu_mean_ms": 1e3 * float(c.mean()),
            "solutions_total": int(sum(sols[name])),
            "certified_width_median": float(statistics.median(widths[name])) if widths[name] else None,
        }
    out["ratio_median"] = out["enclosed"]["cpu_median_ms"] / out["rounded"]["cpu_median_ms"]
    out["ratio_mean"] = out["enclosed"]["cpu_mean_ms"] / out["rounded"]["cpu_mean_ms"]
    out["same_counts"] = sols["enclosed"] == sols["rounded"]
    if a.json:
        print(json.dumps(out))
    else:
        for name in variants:
            v = out[name]
            print(
                f"{name:9s} median {v['cpu_median_ms']:.2f} ms  mean {v['cpu_mean_ms']:.2f} ms  "
                f"solutions {v['solutions_total']}  certified width (median) {v['certified_width_median']:.2e}"
            )
        print(f"ratio enclosed/rounded: median {out['ratio_median']:.3f}, mean {out['ratio_mean']:.3f}; same counts: {out['same_counts']}")
    return out


if __name__ == "__main__":
    main()
