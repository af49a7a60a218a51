#!/usr/bin/env python3
"""The LP contractors side by side: the linear relaxation (Porta, Ros and Thomas 2009), the
Bernstein polytope (Fünfzig et al. 2010), and none.

For each problem and each ``relaxation`` ("linear", "bernstein", "none") one solve in a fresh
subprocess (kernels loaded before the clock starts), in the order problem by problem, the
relaxations of one problem one after the other, so the three of a problem see about the same
load: boxes, LPs, solver CPU seconds (``time.process_time``), solutions, certified, curves,
unresolved boxes, and whether the certified solution sets agree between the relaxations.

    python benchmarks/relaxations.py                     # all problems, markdown table on stdout
    python benchmarks/relaxations.py --only general-6r,ur5 --json out.json --plot relaxations.png
    python benchmarks/relaxations.py --variant bernstein-squares   # a variant of a contractor

Variants (experiments, not options of kinbox): ``bernstein-squares`` turns on the
square-root reduction of Fünfzig et al. 2010, Sec. 6, in the Bernstein contractor; ``linear-squares`` the same
idea in the linear relaxation (LPs on ``m = x^2``, then ``x`` from the square root).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

# (name, kind, target, options of kinbox.solve / IK.solve)
PROBLEMS = [
    ("general-6r", "solve", "general-6r", {}),
    ("ur5", "ik", "ur5", {}),
    ("dietmeier", "solve", "dietmeier", {}),
    ("four-bar", "solve", "four-bar", {}),
    ("griffis-duffy", "solve", "griffis-duffy", {"legs": "vector", "sigma": 0.25}),
]
RELAXATIONS = ["linear", "bernstein", "none"]

_CASE = r"""
import json, sys, time
import numpy as np
spec = json.loads(sys.argv[1])
sys.path.insert(0, spec["here"])
import kinbox
from kinbox.search import bernstein, certify, propagate, relaxation, solver
for load in (propagate.load_kernel, certify.load_kernel, relaxation.load_kernel, bernstein.load_kernel):
    load()
variant = spec.get("variant")
rel = spec["relaxation"]
if variant == "bernstein-squares":
    bernstein.SQUARES = True
elif variant == "linear-squares":
    from relaxation_variants import LinearWithSquares
    from kinbox.search import ctc_linear
    ctc_linear.LinearRelaxation = LinearWithSquares
elif variant:
    raise SystemExit(f"unknown variant {variant}")
opts = dict(spec["options"], relaxation=rel, progress=False, time_limit=spec["time_limit"],
            max_boxes=spec["max_boxes"])
runs = []
if spec["kind"] == "solve":
    c0 = time.process_time()
    r = kinbox.solve(spec["target"], **opts)
    runs.append((r, time.process_time() - c0))
else:
    import pinocchio as pin
    prob = kinbox.IK(spec["target"], "tool0")
    pin.seed(0)
    qs = [pin.randomConfiguration(prob.robot.model) for _ in range(spec["poses"])]
    for q in qs:
        pose = prob.pose_at(q)
        c0 = time.process_time()
        r = prob.solve(pose, **opts)
        runs.append((r, time.process_time() - c0))
out = []
for r, cpu in runs:
    out.append(dict(boxes=r.stats["boxes"], lps=r.stats["lps"], cpu=cpu, complete=r.complete,
                    solutions=len(r.solutions), certified=sum(s.certified for s in r.solutions),
                    curves=sum(1 for c in r.components if c.dimension >= 1),
                    unresolved=r.stats.get("unresolved_boxes", 0),
                    q=[s.q.tolist() for s in r.solutions if s.certified]))
print(json.dumps(out))
"""


def run(
    name: str,
    kind: str,
    target: str,
    options: dict,
    relaxation: str,
    time_limit: float,
    poses: int,
    variant: str | None,
    max_boxes: int = 300_000,
) -> dict:
    spec = dict(
        kind=kind,
        target=target,
        options=options,
        relaxation=relaxation,
        time_limit=time_limit,
        max_boxes=max_boxes,
        poses=poses,
        variant=variant,
        here=str(Path(__file__).resolve().parent),
    )
    t0 = time.perf_counter()
    p = subprocess.run(
        [sys.executable, "-c", _CASE, json.dumps(spec)], capture_output=True, text=True, timeout=time_limit * max(poses, 1) + 600
    )
    if p.returncode != 0:
        return dict(problem=name, relaxation=relaxation, error=(p.stderr.strip().splitlines() or ["failed"])[-1])
    runs = json.loads(p.stdout.strip().splitlines()[-1])
    return dict(
        problem=name,
        relaxation=relaxation,
        variant=variant,
        wall=time.perf_counter() - t0,
        boxes=sum(r["boxes"] for r in runs),
        lps=sum(r["lps"] for r in runs),
        cpu=sum(r["cpu"] for r in runs),
        complete=all(r["complete"] for r in runs),
        solutions="/".join(str(r["solutions"]) for r in runs),
        certified="/".join(str(r["certified"]) for r in runs),
        curves="/".join(str(r["curves"]) for r in runs),
        unresolved=sum(r["unresolved"] for r in runs),
        q=[r["q"] for r in runs],
    )


def same_points(a: list, b: list, tol: float = 1e-6) -> bool:
    """The two lists of certified solutions (joint vectors) are the same set, within ``tol``."""
    if len(a) != len(b):
        return False
    used = set()
    for x in a:
        hit = next((j for j, y in enumerate(b) if j not in used and np.max(np.abs(np.subtract(x, y))) <= tol), None)
        if hit is None:
            return False
        used.add(hit)
    return True


def agree(rows: list[dict]) -> None:
    """Mark each row with ``same``: its certified solutions (per pose) are those of the first
    complete row of its problem."""
    by: dict[str, dict] = {}
    for r in rows:
        if "error" in r or not r["complete"]:
            continue
        ref = by.setdefault(r["problem"], r)
        r["same"] = all(same_points(a, b) for a, b in zip(ref["q"], r["q"])) and r["curves"] == ref["curves"]


def markdown(rows: list[dict]) -> str:
    out = [
        "| problem | relaxation | boxes | LPs | CPU s | solutions | certified | curves | unresolved | complete | same set |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        label = r["relaxation"] + (f" ({r['variant']})" if r.get("variant") else "")
        if "error" in r:
            out.append(f"| {r['problem']} | {label} | error: {r['error']} | | | | | | | | |")
            continue
        same = {True: "yes", False: "**NO**"}.get(r.get("same"), "-")
        out.append(
            f"| {r['problem']} | {label} | {r['boxes']} | {r['lps']} | {r['cpu']:.2f} | {r['solutions']} | "
            f"{r['certified']} | {r['curves']} | {r['unresolved']} | {'yes' if r['complete'] else 'NO'} | {same} |"
        )
    return "\n".join(out)


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    probs = list(dict.fromkeys(r["problem"] for r in rows))
    labels = list(dict.fromkeys(r["relaxation"] + (f"+{r['variant']}" if r.get("variant") else "") for r in rows))
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    width = 0.8 / max(len(labels), 1)
    for k, lab in enumerate(labels):
        for ax, key in zip(axes, ("cpu", "boxes")):
            xs, ys, hatch = [], [], []
            for i, p in enumerate(probs):
                r = next(
                    (r for r in rows if r["problem"] == p and r["relaxation"] + (f"+{r['variant']}" if r.get("variant") else "") == lab),
                    None,
                )
                if r is None or "error" in r:
                    continue
                xs.append(i + (k - (len(labels) - 1) / 2) * width)
                ys.append(max(r[key], 1e-3))
                hatch.append(not r["complete"])
            bars = ax.bar(xs, ys, width, label=lab)
            for b, h in zip(bars, hatch):
                if h:
                    b.set_hatch("//")
    for ax, title in zip(axes, ("solver CPU seconds (hatched: time limit hit)", "boxes")):
        ax.set_yscale("log")
        ax.set_xticks(range(len(probs)))
        ax.set_xticklabels(probs, rotation=20)
        ax.set_title(title)
    axes[0].legend()
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="benchmarks/relaxations.py", description=__doc__.splitlines()[0])
    ap.add_argument("--only", help="comma-separated problem names")
    ap.add_argument("--relaxations", default=",".join(RELAXATIONS))
    ap.add_argument("--variant", help="bernstein-squares or linear-squares (an experiment)")
    ap.add_argument("--poses", type=int, default=5, help="UR5 poses (summed)")
    ap.add_argument(
        "--time-limit",
        type=float,
        default=3600.0,
        help="per solve, wall seconds (a safety net on a loaded machine: the budget that counts is --max-boxes)",
    )
    ap.add_argument("--max-boxes", type=int, default=300_000, help="per solve: a deterministic budget")
    ap.add_argument("--json", help="write the rows here")
    ap.add_argument("--plot", help="write the bar chart here")
    a = ap.parse_args(argv)
    only = set(a.only.split(",")) if a.only else None
    rows = []
    for name, kind, target, options in PROBLEMS:
        if only and name not in only:
            continue
        for rel in a.relaxations.split(","):
            print(f"relaxations: {name} {rel} ...", file=sys.stderr, flush=True)
            row = run(name, kind, target, options, rel, a.time_limit, a.poses, a.variant, a.max_boxes)
            rows.append(row)
            print(f"relaxations:   {json.dumps({k: v for k, v in row.items() if k != 'q'})}", file=sys.stderr, flush=True)
    agree(rows)
    print(markdown(rows))
    if a.json:
        Path(a.json).write_text(json.dumps(rows, indent=1))
    if a.plot:
        plot(rows, Path(a.plot))
    return 0 if all("error" not in r and r.get("same", True) for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
