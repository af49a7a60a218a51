"""Near-singular sweeps against a 40-digit oracle: the table of docs/soundness.md.

    python scripts/soundness_sweep.py                         # UR5, UR10, KR6; wrist and elbow
    python scripts/soundness_sweep.py --robots ur5 --sweeps wrist --out sweep.jsonl
    python scripts/soundness_sweep.py --summary sweep.jsonl   # the table of an earlier run

Per robot, the wrist sweep puts joint 5 at ``1e-1 .. 1e-12`` from its singularity and the elbow
sweep joint 3 at ``1e-3 .. 1e-12`` (the other joints at ``0.3, -1.2, 1.5 | 0.5, -0.8, 1.2,
0.4``), solves the pose the way a user does (the closed form where it decides, else the
search: ``IK.solve``) and with the search alone (``closed_form=False``), and checks the answer
against the 40-digit roots of the pose as given (``tests/support/oracles/mp_ik.py``,
``tests/support/curves.py``). One JSON line per case (``--out`` or stdout),
progress on stderr, the table at the end.

Needs the repository root on ``sys.path`` (it imports ``tests``); run from the root.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

ROBOTS = ("ur5", "ur10", "kr6")
WRIST = [10.0**-k for k in range(1, 13)]
ELBOW = [10.0**-k for k in range(3, 13)]


def configuration(robot: str, sweep: str, v: float) -> list[float]:
    q = [0.3, -1.2, 1.5 if robot != "kr6" else 0.5, -0.8, 1.2, 0.4]
    q[4 if sweep == "wrist" else 2] = v
    return q


def case(robot: str, sweep: str, v: float, search_only: bool) -> dict:
    import kinbox
    from tests.support import kr6_dh
    from tests.support.curves import judge
    from tests.support.oracles import mp_ik

    q = configuration(robot, sweep, v)
    chain = None
    if robot == "kr6":
        ik = kinbox.IK(str(Path(__file__).resolve().parents[1] / "tests" / "data" / "kr6_dh15.urdf"), "tool0")
        chain = mp_ik.Chain(ik.robot.model, "tool0", placements=kr6_dh.exact_placements())
    else:
        ik = kinbox.IK(robot, "tool0")
    goal = ik.pose_at(q)
    t0, c0 = time.perf_counter(), time.process_time()
    res = ik.solve(goal, closed_form=not search_only)
    cpu = time.perf_counter() - t0
    cpu_s = time.process_time() - c0
    rec = judge(ik, goal, res, q, chain=chain, ur=None if robot == "kr6" else robot)
    rec.pop("roots")
    path = "search" if search_only else "user"
    rec.update(robot=robot, sweep=sweep, value=v, path=path, method=res.stats.get("method"), seconds=cpu, cpu_seconds=cpu_s)
    # what each reported point claims: certified or not, its multiplicity and width
    rec["points"] = [[s.certified, s.multiplicity, float(s.width)] for s in res.solutions]
    return rec


#: (key, short heading, heading of docs/soundness.md, format) per column after the case's own
COLUMNS = [
    ("found", "found", "reported", "d"),
    ("certified", "cert", "certified", "d"),
    ("clusters", "clust", "clusters", "d"),
    ("curves", "curve", "curves", "d"),
    ("undecided", "undec", "undecided", "d"),
    ("duplicates", "dup", "duplicates", "d"),
    ("lost", "lost", "lost", "d"),
    ("merged", "mrg", "certified box reaching two roots", "d"),
    ("complex_in_clusters", "cin", "complex roots in clusters", "d"),
    ("cluster_over", "over", "cluster over its multiplicity", "d"),
    ("cluster_short", "short", "cluster narrower than its pair", "d"),
    ("phantom", "phant", "uncertified point reaching no root", "d"),
    ("cert_missing", "miss", "certified box without its root", "d"),
    ("max_cert_distance", "max dist", "largest distance to the 40-digit root", ".1e"),
    ("seconds", "s", "s", ".1f"),
]


def table(records: list[dict]) -> str:
    head = f"{'robot':<6}{'sweep':<7}{'value':>8} {'path':<7}{'method':<17}{'roots':>6}{'cplx':>5}"
    head += "".join(f"{h:>{max(len(h) + 1, 5) if f == 'd' else 9}}" for _, h, _, f in COLUMNS)
    lines = [head, "-" * len(head)]
    for r in records:
        line = f"{r['robot']:<6}{r['sweep']:<7}{r['value']:>8.0e} {r['path']:<7}{str(r['method']):<17}{r['real']:>6}{r['complex']:>5}"
        line += "".join(f"{r.get(k, 0):>{max(len(h) + 1, 5) if f == 'd' else 9}{f}}" for k, h, _, f in COLUMNS)
        lines.append(line)
    return "\n".join(lines)


def markdown(records: list[dict]) -> str:
    """The table of docs/soundness.md: one row per case."""
    head = ["robot", "sweep", "value", "path", "method", "roots (real/complex)"] + [h for _, _, h, _ in COLUMNS]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in records:
        cells = [r["robot"], r["sweep"], f"{r['value']:.0e}", r["path"], str(r["method"]), f"{r['real']}/{r['complex']}"]
        cells += [f"{r.get(k, 0):{f}}" for k, _, _, f in COLUMNS]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", default=",".join(ROBOTS))
    ap.add_argument("--sweeps", default="wrist,elbow")
    ap.add_argument("--values", default="", help="comma-separated values instead of the sweep's")
    ap.add_argument("--paths", default="user,search")
    ap.add_argument("--out", default="")
    ap.add_argument("--summary", default="", help="print the table of an earlier run's JSON lines (files joined by commas)")
    ap.add_argument("--markdown", action="store_true", help="with --summary: the table of docs/soundness.md")
    a = ap.parse_args(argv)
    if a.summary:
        recs = [json.loads(s) for f in a.summary.split(",") for s in Path(f).read_text().splitlines() if s.strip()]
        print(markdown(recs) if a.markdown else table(recs))
        return 0
    out = open(a.out, "w") if a.out else sys.stdout  # noqa: SIM115
    records = []
    for robot in a.robots.split(","):
        for sweep in a.sweeps.split(","):
            values = [float(s) for s in a.values.split(",")] if a.values else (WRIST if sweep == "wrist" else ELBOW)
            for v in values:
                for path in a.paths.split(","):
                    rec = case(robot, sweep, v, path == "search")
                    records.append(rec)
                    print(json.dumps(rec, default=float), file=out, flush=True)
                    print(table([rec]).splitlines()[-1], file=sys.stderr, flush=True)
    print(table(records), file=sys.stderr)
    return 0


if __name__ == "__main__":
    np.seterr(all="ignore")
    raise SystemExit(main())
