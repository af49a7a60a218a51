"""Mobile mechanisms: CPU seconds and box counts, before/after in one run.

    python benchmarks/mobile.py [--src DIR ...] [--cases four-bar,bricard,...] [--time-limit S]

Each case runs in a fresh subprocess with ``PYTHONPATH`` set to each ``--src`` directory in turn
(e.g. main's ``src`` and a branch's), interleaved case by case so both see the same machine load;
CPU time is ``time.process_time`` of the solve alone (every kernel of the search loaded and modules
imported before): formulation, search and the answer's components; the search's own CPU in brackets.
Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

# name -> (mechanism, options of kinbox.solve)
CASES = {
    "four-bar": ("four-bar", {}),
    "bricard": ("bricard", {}),
    "griffis-duffy 1/4": ("griffis-duffy", {"sigma": 0.25}),
    "griffis-duffy 1/8": ("griffis-duffy", {"sigma": 0.125}),
    "griffis-duffy 1/16": ("griffis-duffy", {"sigma": 0.0625}),
    "griffis-duffy 1/4 vector": ("griffis-duffy", {"sigma": 0.25, "legs": "vector"}),
    "general-6r": ("general-6r", {}),
    "dietmeier": ("dietmeier", {}),
}

CODE = r"""
import json, sys, time
from collections import Counter
import kinbox
import kinbox.pipeline  # imported before the clock starts (kinbox.solve imports it lazily)
from kinbox.search import certify, propagate, relaxation, solver
if hasattr(solver, "load_kernels"):  # every kernel of the search (Bernstein's and the transverse
    solver.load_kernels()            # test's too), where the tree has the list
else:
    for load in (propagate.load_kernel, certify.load_kernel, relaxation.load_kernel):
        load()
try:  # the answer's curve tracer, where the tree has it compiled
    from kinbox.answer import trace
    trace.load_kernel()
except (ImportError, AttributeError):
    pass
mech, kw = sys.argv[1], json.loads(sys.argv[2])
c0 = time.process_time()
r = kinbox.solve(mech, progress=False, **kw)
cpu = time.process_time() - c0
comps = Counter(c.dimension for c in r.components)
print(json.dumps({"cpu": cpu, "search_cpu": r.stats["cpu_seconds"], "boxes": r.stats["boxes"],
                  "lps": r.stats["lps"], "complete": r.complete,
                  "certified": sum(s.certified for s in r.solutions),
                  "bifurcations": sum(len(c.bifurcations) for c in r.components if c.dimension >= 1),
                  "components": {str(k): v for k, v in sorted(comps.items())}}))
"""


def run(src: str, mech: str, kw: dict) -> dict:
    env = dict(os.environ, PYTHONPATH=str(Path(src).resolve()))
    p = subprocess.run([sys.executable, "-c", CODE, mech, json.dumps(kw)], env=env, capture_output=True, text=True)
    if p.returncode != 0:
        return {"error": (p.stderr.strip().splitlines() or ["?"])[-1]}
    return json.loads(p.stdout.strip().splitlines()[-1])


def cell(r: dict) -> str:
    if "error" in r:
        return f"error: {r['error']}"
    comps = ", ".join(f"{v} of dim {k}" for k, v in r["components"].items()) or "none"
    done = "" if r["complete"] else " **incomplete**"
    bif = f", {r['bifurcations']} bifurcation points" if r.get("bifurcations") else ""
    return (
        f"{r['cpu']:.2f} s (search {r.get('search_cpu', float('nan')):.2f} s), {r['boxes']} boxes, "
        f"{r['lps']} LPs, {comps}{bif}, {r['certified']} certified{done}"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--src", action="append", help="source trees to compare (default: this one)")
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--time-limit", type=float, default=600.0, help="per solve, wall seconds")
    a = ap.parse_args()
    srcs = a.src or [str(ROOT / "src")]
    names = [c.strip() for c in a.cases.split(",") if c.strip()]
    print(f"{platform.node()} {platform.processor() or platform.machine()}, {os.cpu_count()} cores", file=sys.stderr)
    head = "| case | " + " | ".join(f"tree {i + 1}" for i in range(len(srcs))) + (" | ratio |" if len(srcs) == 2 else "")
    print(head)
    print("|" + "---|" * (head.count("|") - 1))
    for name in names:
        mech, kw = CASES[name]
        kw = dict(kw, time_limit=a.time_limit)
        res = [run(s, mech, kw) for s in srcs]
        row = f"| {name} | " + " | ".join(cell(r) for r in res)
        if len(res) == 2 and all("cpu" in r for r in res):
            row += f" | {res[1]['cpu'] / max(res[0]['cpu'], 1e-9):.2f}x"
        print(row + " |", flush=True)


if __name__ == "__main__":
    main()
