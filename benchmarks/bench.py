"""Benchmarks: ``make bench`` / ``benchmarks/run.py``.

Runs the benchmark suite, each case in a fresh subprocess (so peak memory is its own), prints
the machine's calibration (``report.calibrate``), and records the rows with ``report.record``:
the "suite" table (``--quick``) or the "suite-full" table of ``docs/benchmarks.md`` (raw rows
in ``docs/benchmarks.json``), with a runtime-versus-error plot beside it. A run with ``--only``
prints its rows and writes nothing. Expected answers come from the
published reference problems (``tests/data/reference``, the built-in mechanisms) and, for UR arms, from an
independent closed-form solver when the test oracles are importable; nothing here feeds an
expected answer to the solver.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import report

ROOT = Path(__file__).resolve().parents[1]

# (name, kind, target, sigma values (full), sigma (quick), expected)
CASES = [
    ("general-6r", "solve", "general-6r", [1e-2, 1e-4], 1e-4, {"solutions": 16}),
    ("ur5", "ik", "ur5", [1e-4], 1e-4, {"oracle": "ur5"}),
    ("panda-locked", "ik", "panda", [1e-4], 1e-4, {}),
    ("four-bar", "solve", "four-bar", [0.1, 0.05], 0.1, {"curves": 2}),
    ("dietmeier", "solve", "dietmeier", [1e-3, 1e-4], 1e-4, {"solutions": 40}),
    ("griffis-duffy", "solve", "griffis-duffy", [0.25, 0.0625], 0.25, {"curves": 2}),
]
# options of kinbox.solve per problem: the mobile platform uses the leg-vector formulation
OPTIONS = {"griffis-duffy": {"legs": "vector"}}
QUICK = {"general-6r", "ur5", "four-bar", "panda-locked"}


def _case_code() -> str:
    return r"""
import json, resource, sys, time
import numpy as np
import kinbox
spec = json.loads(sys.argv[1])
out = []
# the compiled kernels are loaded once per process (the first solve of a user's session pays
# it): every kernel of the search, timed apart from the solves
import kinbox.pipeline
c0 = time.process_time()
kinbox.pipeline.load_kernels()
kernel_load = time.process_time() - c0
if spec["kind"] == "solve":
    c0 = time.process_time()
    r = kinbox.solve(spec["target"], sigma=spec["sigma"], time_limit=spec["time_limit"], progress=False,
                     **spec.get("options", {}))
    cpu = time.process_time() - c0
    runs = [(r, cpu, None)]
else:
    import pinocchio as pin
    lock = spec.get("lock") or {}
    prob = kinbox.IK(spec["target"], spec["frame"], lock=lock)
    pin.seed(spec["seed"])  # fixed poses: the same benchmark every run
    m = prob.robot.model
    runs = []
    for k in range(spec["poses"]):
        q = pin.randomConfiguration(m)
        for name, v in lock.items():
            j = m.joints[m.getJointId(name)]
            q[j.idx_q] = v
        pose = prob.pose_at(q)
        c0 = time.process_time()
        r = prob.solve(pose, sigma=spec["sigma"], time_limit=spec["time_limit"], progress=False)
        runs.append((r, time.process_time() - c0, pose.homogeneous.tolist()))
dls = {}
if spec["kind"] == "ik" and spec.get("dls") and not spec.get("lock"):  # the baseline cannot lock joints
    # the competitor: Pinocchio damped least squares from random restarts, until it has found
    # the set kinbox returned (benchmarks/dls_baseline.py)
    sys.path.insert(0, spec["root"] + "/benchmarks")
    import pinocchio as pin
    from dls_baseline import restarts_until_complete
    for i, (r, cpu, pose) in enumerate(runs):
        if not r.solutions:
            continue
        ref = [s.q for s in r.solutions]
        d = restarts_until_complete(prob.robot.model, spec["frame"], pin.SE3(np.array(pose)), ref,
                                    max_restarts=spec["dls"], seed=i)
        dls[i] = dict(restarts=d["restarts"], seconds=d["seconds"], missing=len(d["missing"]))
for i, (r, cpu, pose) in enumerate(runs):
    out.append(dict(dls=dls.get(i),solutions=len(r.solutions), certified=sum(s.certified for s in r.solutions),
                    max_residual=max([s.residual for s in r.solutions], default=0.0),
                    curves=sum(1 for c in r.components if c.dimension >= 1),
                    unresolved=r.stats.get("unresolved_boxes", 0), complete=r.complete,
                    boxes=r.stats["boxes"], lps=r.stats["lps"], cpu=cpu, pose=pose,
                    q=[s.q.tolist() for s in r.solutions]))
print(json.dumps(dict(runs=out, kernel_load=kernel_load,
                      peak_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)))
"""


def run_case(name, kind, target, sigma, time_limit, poses=5, seed=0, dls: int = 0) -> dict:
    spec = dict(kind=kind, target=target, sigma=sigma, time_limit=time_limit, poses=poses, seed=seed, dls=dls, root=str(ROOT))
    spec["options"] = OPTIONS.get(name, {})
    if kind == "ik":
        spec["frame"] = {"ur5": "tool0", "panda": "panda_hand"}.get(target, "tool")
        if target == "panda":
            spec["lock"] = {"panda_joint7": 0.3}
    t0 = time.perf_counter()
    p = subprocess.run(
        [sys.executable, "-c", _case_code(), json.dumps(spec)], capture_output=True, text=True, timeout=time_limit * max(poses, 1) + 600
    )
    if p.returncode != 0:
        return dict(name=name, sigma=sigma, error=p.stderr.strip().splitlines()[-1:] or ["failed"])
    res = json.loads(p.stdout.strip().splitlines()[-1])
    res.update(name=name, sigma=sigma, wall=time.perf_counter() - t0)
    return res


def _ur_expected(run) -> int | None:
    try:
        sys.path.insert(0, str(ROOT))
        from tests.support.oracles.ur_ik import ur_ik
    except Exception:
        return None
    try:
        return len(ur_ik("ur5", np.array(run["pose"])))
    except Exception:
        return None


def summarize(res: dict, expected: dict) -> dict:
    runs = res["runs"]
    row = dict(problem=res["name"], sigma=res["sigma"], peak_mb=res["peak_mb"], runs=len(runs), kernel_load=res.get("kernel_load", 0.0))
    row["cpu_seconds"] = float(np.median([r["cpu"] for r in runs]))
    row["cpu_max"] = float(np.max([r["cpu"] for r in runs]))
    row["solutions"] = "/".join(str(r["solutions"]) for r in runs) if len(runs) > 1 else runs[0]["solutions"]
    row["certified"] = "/".join(str(r["certified"]) for r in runs) if len(runs) > 1 else runs[0]["certified"]
    row["max_residual"] = float(max(r["max_residual"] for r in runs))
    row["boxes"] = int(np.median([r["boxes"] for r in runs]))
    row["lps"] = int(np.median([r["lps"] for r in runs]))
    row["complete"] = all(r["complete"] for r in runs)
    row["curves"] = runs[0]["curves"]
    row["unresolved"] = sum(r["unresolved"] for r in runs)
    exp = "-"
    if "solutions" in expected:
        exp = str(expected["solutions"])
        row["ok"] = all(r["solutions"] == expected["solutions"] and r["certified"] == expected["solutions"] for r in runs)
    elif "curves" in expected:
        exp = f"{expected['curves']} curves"
        row["ok"] = all(r["curves"] == expected["curves"] for r in runs)
    elif expected.get("oracle"):
        counts = [_ur_expected(r) for r in runs]
        exp = "/".join("?" if c is None else str(c) for c in counts)
        row["ok"] = all(c is not None and r["solutions"] == c == r["certified"] for c, r in zip(counts, runs))
    row["expected"] = exp
    d = [r.get("dls") for r in runs if r.get("dls")]
    if d:
        done = [x for x in d if x["restarts"] is not None]
        row["dls"] = (
            f"{len(done)}/{len(d)} poses complete; median {np.median([x['restarts'] for x in done]):.0f} "
            f"restarts, {1e3 * np.median([x['seconds'] for x in done]):.0f} ms"
            if done
            else f"0/{len(d)} poses complete"
        ) + (f"; missed {sum(x['missing'] for x in d)} solutions" if any(x["missing"] for x in d) else "")
    return row


def _plot(rows: list[dict], path: Path) -> None:
    try:
        from kinbox.viz.plot import plot_runtime_vs_error

        plot_runtime_vs_error(
            [
                dict(problem=r["problem"], sigma=r["sigma"], cpu_seconds=r["cpu_seconds"], max_residual=max(r["max_residual"], 1e-17))
                for r in rows
                if "error" not in r
            ],
            path,
        )
    except Exception as e:  # the table matters more than the picture
        print(f"bench: no plot ({e})", file=sys.stderr)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="benchmarks/run.py", description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a few minutes: the fast problems, one sigma")
    ap.add_argument("--only", help="comma-separated problem names")
    ap.add_argument("--poses", type=int, default=None, help="IK poses per robot (default 5, quick 3)")
    ap.add_argument("--time-limit", type=float, default=None, help="per solve (default 900 s, quick 120 s)")
    ap.add_argument(
        "--dls", type=int, default=2000, help="IK: compare with Pinocchio DLS random restarts, at most this many per pose (0: off)"
    )
    ap.add_argument("--json", help="also write the raw rows here")
    a = ap.parse_args(argv)
    calibration = report.calibrate()
    cal = f"calibration: 1e7 additions in {calibration:.3f} s CPU"
    print(f"bench: machine {json.dumps(report.machine())}; {cal}", file=sys.stderr, flush=True)
    only = set(a.only.split(",")) if a.only else None
    tl = a.time_limit or (120.0 if a.quick else 900.0)
    poses = a.poses or (3 if a.quick else 5)
    rows = []
    for name, kind, target, sigmas, qsigma, expected in CASES:
        if only and name not in only:
            continue
        if a.quick and not only and name not in QUICK:
            continue
        for sigma in [qsigma] if a.quick else sigmas:
            print(f"bench: {name} sigma={sigma} ...", file=sys.stderr, flush=True)
            res = run_case(name, kind, target, sigma, tl, poses=poses, dls=a.dls if kind == "ik" else 0)
            row = res if "error" in res else summarize(res, expected)
            if name in OPTIONS:
                row["options"] = ", ".join(f"{k}={v!r}" for k, v in OPTIONS[name].items())
            rows.append(row)
            print(f"bench:   {json.dumps({k: v for k, v in row.items() if k != 'runs'})}", file=sys.stderr, flush=True)
    if a.json:
        Path(a.json).write_text(json.dumps(rows, indent=1))
    if only:
        print("bench: --only: the page is not written (it holds whole runs)", file=sys.stderr)
    else:
        _plot(rows, report.PAGE.with_name("runtime_vs_error.png" if a.quick else "runtime_vs_error_full.png"))
        report.record("suite" if a.quick else "suite-full", rows, calibration=calibration, mode="quick" if a.quick else "full")
        print(f"bench: wrote {report.PAGE.relative_to(ROOT)} and {report.RAW.relative_to(ROOT)}", file=sys.stderr)
    return 0 if all(r.get("ok", True) and "error" not in r for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
