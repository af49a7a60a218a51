"""The shaving contractor (``extra_steps="shave"``, kinbox.search.ctc_shave): boxes and CPU with and without it.

    python benchmarks/shaving.py [--cases general-6r,four-bar,...] [--record]

Each case runs in a fresh process: every kernel loaded first, then the solve without shaving and
the solve with it, one after the other in that process (the same machine load for both). Boxes
and LPs are counters (the same on every run); CPU is the search's own ``time.process_time``
(``stats["cpu_seconds"]``) and the whole solve's. The answers are compared (solutions, certified,
curves, completeness) and both shown where they differ. ``--record`` stores the rows as the "shaving" table of docs/benchmarks.md.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import report

ROOT = Path(__file__).resolve().parents[1]

# name -> (kind, target, options): the quick suite's searched problems and the mechanisms
CASES = {
    "general-6r": ("solve", "general-6r", {"sigma": 1e-4}),
    "four-bar": ("solve", "four-bar", {"sigma": 0.1}),
    "ur5 search 10 poses": ("ik", "ur5", {"sigma": 1e-4, "closed_form": False}),
    "bricard": ("solve", "bricard", {}),
    "griffis-duffy 1/4 vector": ("solve", "griffis-duffy", {"sigma": 0.25, "legs": "vector"}),
    "dietmeier": ("solve", "dietmeier", {"sigma": 1e-4}),
}

CODE = r"""
import json, sys, time
import numpy as np
import kinbox, kinbox.pipeline
kinbox.pipeline.load_kernels()
kind, target, kw = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
out = {}
if kind == "ik":
    import pinocchio as pin
    ik = kinbox.IK(target, "tool0")
    pin.seed(0)
    poses = [ik.pose_at(pin.randomConfiguration(ik.robot.model)) for _ in range(10)]
for extra in ("", "shave"):
    c0 = time.process_time()
    rs = [ik.solve(p, progress=False, extra_steps=extra, **kw) for p in poses] if kind == "ik" else [
        kinbox.solve(target, progress=False, extra_steps=extra, **kw)]
    cpu = time.process_time() - c0
    out[extra or "none"] = dict(
        cpu=cpu, search_cpu=sum(r.stats["cpu_seconds"] for r in rs), boxes=sum(r.stats["boxes"] for r in rs),
        lps=sum(r.stats["lps"] for r in rs), complete=all(r.complete for r in rs),
        solutions=sum(len(r.solutions) for r in rs), certified=sum(sum(s.certified for s in r.solutions) for r in rs),
        curves=sum(sum(1 for c in r.components if c.dimension >= 1) for r in rs),
        unresolved=sum(r.stats.get("unresolved_boxes", 0) for r in rs))
print(json.dumps(out))
"""


def run(kind: str, target: str, kw: dict) -> dict:
    p = subprocess.run([sys.executable, "-c", CODE, kind, target, json.dumps(kw)], capture_output=True, text=True)
    if p.returncode != 0:
        return {"error": (p.stderr.strip().splitlines() or ["?"])[-1]}
    return json.loads(p.stdout.strip().splitlines()[-1])


def row(name: str, r: dict) -> dict:
    if "error" in r:
        return {"case": name, "error": r["error"]}
    a, b = r["none"], r["shave"]
    same = all(a[k] == b[k] for k in ("solutions", "certified", "curves", "complete"))
    return {
        "case": name,
        "boxes": a["boxes"],
        "boxes_shave": b["boxes"],
        "lps": a["lps"],
        "lps_shave": b["lps"],
        "search_cpu": a["search_cpu"],
        "search_cpu_shave": b["search_cpu"],
        "cpu": a["cpu"],
        "cpu_shave": b["cpu"],
        "boxes_ratio": b["boxes"] / max(a["boxes"], 1),
        "cpu_ratio": b["search_cpu"] / max(a["search_cpu"], 1e-9),
        "same_answer": same,
        "answer": _answer(a),
        "answer_shave": _answer(b),
    }


def _answer(r: dict) -> str:
    out = f"{r['solutions']} solutions ({r['certified']} certified), {r['curves']} curves"
    return out + (f", {r['unresolved']} unresolved boxes" if r.get("unresolved") else "")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--record", action="store_true", help="store the rows on docs/benchmarks.md")
    a = ap.parse_args()
    c = report.calibrate()
    rows = []
    print("| case | boxes | LPs | search CPU s | ratio (boxes, CPU) | same answer |")
    print("|---|---|---|---|---|---|")
    for name in [s.strip() for s in a.cases.split(",") if s.strip()]:
        kind, target, kw = CASES[name]
        r = row(name, run(kind, target, kw))
        rows.append(r)
        if "error" in r:
            print(f"| {name} | error: {r['error']} |", flush=True)
            continue
        print(
            f"| {name} | {r['boxes']} -> {r['boxes_shave']} | {r['lps']} -> {r['lps_shave']} | "
            f"{r['search_cpu']:.2f} -> {r['search_cpu_shave']:.2f} | {r['boxes_ratio']:.2f}x, {r['cpu_ratio']:.2f}x | "
            f"{'yes' if r['same_answer'] else 'NO'} |",
            flush=True,
        )
    if a.record:
        report.record("shaving", rows, calibration=c)


if __name__ == "__main__":
    main()
