"""Large fuzz sweep: random arms of every structural class, every answer checked.

    python scripts/fuzz_sweep.py                                # 600 poses x 9 classes (5400)
    python scripts/fuzz_sweep.py --classes ur_like,ur5 --poses-per-class 50 --out sweep.jsonl
    python scripts/fuzz_sweep.py --classes ur_like --seed 17 --poses-per-class 1 -v   # replay one
    python scripts/fuzz_sweep.py --summary sweep.jsonl          # the table of an earlier run

Case ``(class, seed)`` is reproducible from those two values alone (and ``--gauge`` if it was
given): the arm, its URDF, the configuration and the pose all come from that seed
(``tests/support/fuzz_arms.py``). Seeds run from ``--seed`` to ``--seed + poses-per-class - 1``; classes
are interleaved so a partial run covers all of them. One JSON line per pose goes to ``--out``
(or stdout), progress to stderr, the summary table at the end (stderr, and ``--table``). A pose
fails if kinbox loses a root (the generating configuration, a Newton root or a closed-form
solution), returns a wrong or duplicate solution, is incomplete, or takes more than
``--slow`` CPU seconds. ``--save-failures DIR`` writes each failing case's URDF and a JSON
with its pose, configuration, locks and record.

Needs the repository root on ``sys.path`` (it imports ``tests.support.fuzz_arms``); run from the root.
"""

from __future__ import annotations

import argparse
import faulthandler
import json
import math
import os
import signal
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tests.support import fuzz_arms as fa


class _Hang(Exception):
    pass


def _alarm(signum, frame):  # pragma: no cover - only on a hang
    raise _Hang()


def summary(records: list[dict]) -> str:
    by = defaultdict(list)
    for r in records:
        by[r["class"]].append(r)
    head = (
        f"{'class':<18}{'poses':>6}{'ok':>6}{'lost':>6}{'roots':>6}{'bad':>5}{'incompl':>8}"
        f"{'slow':>6}{'error':>6}{'median s':>10}{'worst s':>9}  worst seed"
    )
    lines = [head, "-" * len(head)]
    tot = defaultdict(int)
    for cls in [c for c in fa.CLASSES if c in by] + sorted(set(by) - set(fa.CLASSES)):
        rs = by[cls]
        cpu = sorted(r.get("cpu_s", math.nan) for r in rs)
        worst = max(rs, key=lambda r: r.get("cpu_s", -1))
        row = dict(
            poses=len(rs),
            ok=sum(r["status"] == "ok" for r in rs),
            lost=sum(r.get("lost", 0) > 0 or r["status"].startswith("lost") for r in rs),
            roots=sum(r.get("lost", 0) for r in rs),
            bad=sum(any(p.startswith("bad_solution") for p in r.get("problems", [])) for r in rs),
            incompl=sum(r.get("complete") is False for r in rs),
            slow=sum(any(p.startswith("slow") for p in r.get("problems", [])) for r in rs),
            error=sum(r["status"] == "error" for r in rs),
        )
        for k, v in row.items():
            tot[k] += v
        lines.append(
            f"{cls:<18}{row['poses']:>6}{row['ok']:>6}{row['lost']:>6}{row['roots']:>6}{row['bad']:>5}"
            f"{row['incompl']:>8}{row['slow']:>6}{row['error']:>6}{cpu[len(cpu) // 2]:>10.3f}"
            f"{worst.get('cpu_s', math.nan):>9.2f}  {worst['seed']}"
        )
    lines.append("-" * len(head))
    lines.append(
        f"{'all':<18}{tot['poses']:>6}{tot['ok']:>6}{tot['lost']:>6}{tot['roots']:>6}{tot['bad']:>5}"
        f"{tot['incompl']:>8}{tot['slow']:>6}{tot['error']:>6}"
    )
    lines.append(
        "lost: poses with a lost root; roots: roots lost in all; bad: wrong/duplicate solutions; CPU s of the solve (kinbox.IK(...).solve)"
    )
    return "\n".join(lines)


def save_failure(directory: Path, case: fa.Case, rec: dict) -> Path:
    directory.mkdir(parents=True, exist_ok=True)
    stem = f"{case.cls}_{case.seed}" + (f"_{case.notes['gauge_arg']}" if case.notes.get("gauge_arg") else "")
    if case.urdf is not None:
        (directory / f"{stem}.urdf").write_text(case.urdf)
    info = dict(
        case.describe(),
        urdf=f"{stem}.urdf" if case.urdf is not None else None,
        robot=None if case.urdf is not None else case.robot,
        record=rec,
        replay=fa.replay_command(case.cls, case.seed, case.notes.get("gauge_arg")),
    )
    (directory / f"{stem}.json").write_text(json.dumps(info, indent=1) + "\n")
    return directory / f"{stem}.json"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--classes", default=",".join(fa.CLASSES), help=f"comma-separated, from {','.join(fa.CLASSES)} (default: all)")
    ap.add_argument("--poses-per-class", type=int, default=600)
    ap.add_argument("--seed", type=int, default=0, help="first seed of each class")
    ap.add_argument("--time-limit", type=float, default=10.0, help="solver time limit per pose (s)")
    ap.add_argument("--slow", type=float, default=5.0, help="CPU s above which a pose counts as a failure")
    ap.add_argument("--newton-starts", type=int, default=100)
    ap.add_argument(
        "--gauge", choices=["dh", "permutation", "random"], default=None, help="force how joint axes are written (default: drawn per arm)"
    )
    ap.add_argument("--out", default=None, help="JSON Lines file (default: stdout)")
    ap.add_argument("--table", default=None, help="also write the summary table here")
    ap.add_argument("--save-failures", default=None, help="directory for failing cases (URDF + JSON)")
    ap.add_argument("--summary", default=None, help="only print the table of an existing JSON Lines file")
    ap.add_argument("-v", "--verbose", action="store_true", help="print every problem of every pose")
    args = ap.parse_args(argv)
    faulthandler.enable()  # a native crash (one run died of "malloc(): invalid size") prints where

    if args.summary:
        recs = [json.loads(line) for line in Path(args.summary).read_text().splitlines() if line.strip()]
        print(summary(recs))
        return 0
    classes = [c.strip() for c in args.classes.split(",") if c.strip()]
    unknown = [c for c in classes if c not in fa.CLASSES]
    if unknown:
        ap.error(f"unknown classes {unknown}; choose from {list(fa.CLASSES)}")
    out = open(args.out, "a") if args.out else sys.stdout
    hang_s = int(max(60, 10 * args.time_limit))
    # compiled once after an install (tens of seconds): not inside the first pose's time and
    # hang alarm, which once stopped the compiler half-way and broke the kernels for the run
    import kinbox.pipeline

    kinbox.pipeline.load_kernels()
    signal.signal(signal.SIGALRM, _alarm)
    records, failures = [], 0
    t_start = time.process_time()
    n_total = len(classes) * args.poses_per_class
    with tempfile.TemporaryDirectory(prefix="kinbox-fuzz-") as tmp:
        for i in range(args.poses_per_class):
            seed = args.seed + i
            for cls in classes:
                signal.alarm(hang_s)
                try:
                    case = fa.make_case(cls, seed, tmp, gauge=args.gauge)
                    rec = fa.run_case(case, time_limit=args.time_limit, newton_starts=args.newton_starts, slow_s=args.slow)
                except _Hang:
                    case, rec = (
                        None,
                        {"class": cls, "seed": seed, "status": "error", "lost": 0, "problems": [f"error: no answer after {hang_s} s"]},
                    )
                finally:
                    signal.alarm(0)
                if args.gauge:
                    rec["gauge_arg"] = args.gauge
                rec["replay"] = fa.replay_command(cls, seed, args.gauge)
                records.append(rec)
                out.write(json.dumps(rec) + "\n")
                out.flush()
                bad = rec["status"] != "ok"
                failures += bad
                if case is not None and case.urdf is not None:
                    os.unlink(case.robot)
                if bad and args.save_failures and case is not None:
                    save_failure(Path(args.save_failures), case, rec)
                if bad or args.verbose:
                    print(
                        f"[{len(records)}/{n_total}] {cls} seed {seed}: {rec['status']}, "
                        f"{rec.get('solutions')} solutions, newton {rec.get('newton')}, "
                        f"{rec.get('cpu_s', math.nan):.2f} s  -- {rec['replay']}",
                        file=sys.stderr,
                    )
                    for p in rec.get("problems", [])[: (50 if args.verbose else 3)]:
                        print(f"    {p}", file=sys.stderr)
                elif len(records) % 25 == 0:
                    print(
                        f"[{len(records)}/{n_total}] {failures} failing so far, {time.process_time() - t_start:.0f} s CPU", file=sys.stderr
                    )
    table = summary(records)
    print(table, file=sys.stderr)
    if args.table:
        Path(args.table).write_text(table + "\n")
    if args.out:
        out.close()
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
