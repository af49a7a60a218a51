#!/usr/bin/env python3
"""Constraint systems: the coordinate and the distance formulation side by side.

Runs the published problems of Porta et al. 2005/2003 (docs/references.md) and Dietmeier's
platform (as a constraint system, and as a mechanism for reference) one after the other, each in
its own process, and prints the rows (``--write`` records them as the "constraints" table of
docs/benchmarks.md, through ``report.record``). CPU seconds are
``time.process_time`` of the search alone (``stats["cpu_seconds"]``); compare ratios within
one run, the machine is shared.

    python benchmarks/constraints.py [--quick] [--problems A,B] [--write] [--time-limit S]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import report

ROOT = Path(__file__).resolve().parents[1]

CHILD = r"""
import json, sys, time
import kinbox
from kinbox.search import certify, propagate, relaxation
for load in (propagate.load_kernel, certify.load_kernel, relaxation.load_kernel):
    load()
spec = json.loads(sys.argv[1])
c0 = time.process_time()
if spec["formulation"] == "mechanism":
    r = kinbox.solve(spec["problem"], progress=False, time_limit=spec["time_limit"])
    out = dict(variables=r.stats["variables"], equations=r.stats["equations"], boxes=r.stats["boxes"],
               lps=r.stats["lps"], cpu=r.stats["cpu_seconds"], total=time.process_time() - c0,
               complete=r.complete, solutions=len(r.solutions), certified=sum(s.certified for s in r.solutions),
               shapes=len(r.solutions), curves=sum(1 for c in r.components if c.dimension >= 1))
else:
    a = kinbox.Assemble(spec["problem"], formulation=spec["formulation"])
    c1 = time.process_time()
    r = a.solve(progress=False, time_limit=spec["time_limit"])
    out = dict(variables=r.stats["variables"], equations=r.stats["equations"], boxes=r.stats["boxes"],
               lps=r.stats["lps"], cpu=r.stats["cpu_seconds"], diagnosis=c1 - c0, total=time.process_time() - c0,
               complete=r.complete, solutions=len(r.solutions), certified=sum(s.certified for s in r.solutions),
               shapes=r.shapes, curves=sum(1 for c in r.components if c.dimension >= 1),
               not_embeddable=r.stats.get("not_embeddable", 0))
print(json.dumps(out))
"""

PROBLEMS = [
    ("octahedral-a", "Porta et al. 2005 Sec. V-A, config. a: 2 shapes"),
    ("octahedral-b", "Porta et al. 2005 Sec. V-A, config. b: 6 points in (r14, r36), 2 tangent = 8 shapes"),
    ("cyclohexane", "Porta et al. 2005 Sec. V-A: chair (isolated) + boat (curve)"),
    ("tangent-lines", "Porta et al. 2005 Sec. V-B: 12 lines"),
    ("dietmeier-constraints", "Dietmeier 6-6 platform: 40 assemblies"),
]
QUICK = ["octahedral-a", "octahedral-b", "tangent-lines"]


def run(problem: str, formulation: str, time_limit: float) -> dict:
    spec = json.dumps({"problem": problem, "formulation": formulation, "time_limit": time_limit})
    p = subprocess.run(
        [sys.executable, "-c", CHILD, spec],
        capture_output=True,
        text=True,
        env={**__import__("os").environ, "PYTHONPATH": str(ROOT / "src")},
    )
    if p.returncode != 0:
        return {"error": p.stderr.strip().splitlines()[-1] if p.stderr.strip() else f"exit {p.returncode}"}
    return json.loads(p.stdout.strip().splitlines()[-1])


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="the small problems only")
    ap.add_argument("--problems", metavar="A,B", help="only these problems (names of PROBLEMS)")
    ap.add_argument("--write", action="store_true", help="record the rows on docs/benchmarks.md (benchmarks/report.py)")
    ap.add_argument("--time-limit", type=float, default=1800.0, help="seconds per search (wall)")
    a = ap.parse_args()
    calibration = report.calibrate()
    print(f"machine {json.dumps(report.machine())}; calibration: 1e7 additions in {calibration:.3f} s CPU", file=sys.stderr)
    rows = []
    probs = [p for p in PROBLEMS if not a.quick or p[0] in QUICK]
    if a.problems:
        probs = [p for p in probs if p[0] in a.problems.split(",")]
    for name, what in probs:
        for form in ("coordinates", "distances"):
            print(f"{name} {form} ...", file=sys.stderr, flush=True)
            rows.append((name, what, form, run(name, form, a.time_limit)))
        if name == "dietmeier-constraints":
            print("dietmeier mechanism ...", file=sys.stderr, flush=True)
            rows.append(
                (
                    "dietmeier",
                    "the same platform as a mechanism (`kinbox solve dietmeier`)",
                    "mechanism",
                    run("dietmeier", "mechanism", a.time_limit),
                )
            )
    records = [{"problem": name, "what": what, "formulation": form, **r} for name, what, form, r in rows]
    table = next(t for t in report.TABLES if t.key == "constraints")
    for r in records:
        print(" | ".join(str(c) for c in table.cells(r)))
    if a.write:
        report.record("constraints", records, calibration=calibration, mode="quick" if a.quick else "full")
    return 0


if __name__ == "__main__":
    sys.exit(main())
