"""UR-like throughput and start-up: a poses file from random configurations, ``kinbox ik --poses``
over 1 and 2 workers, the per-pose CPU time in process, and the start-up of a whole
``kinbox ik ... --from-q`` process.

    python benchmarks/ur_poses.py make-poses --robot ur5 --count 1000 --seed 0 -o poses.txt
    python benchmarks/ur_poses.py per-pose --robot ur5 --count 100 --seed 1
    python benchmarks/ur_poses.py throughput --robot ur5 --count 1000 --workers 0 1 2
    python benchmarks/ur_poses.py startup --repeat 5

CPU seconds are ``time.process_time`` (this process) or the children's user+system time from
``os.wait4`` (a whole command), wall seconds ``time.perf_counter``: the machine is shared, so
CPU is what to compare; wall is printed too. Goal poses come from Pinocchio forward kinematics
(:meth:`kinbox.IK.pose_at`) at configurations drawn uniformly in [-pi, pi].
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

STARTUP_Q = "0.3,-1.2,1.5,-0.8,1.2,0.4"


def poses(robot: str, frame: str, count: int, seed: int) -> list[list[float]]:
    import pinocchio as pin

    import kinbox

    ik = kinbox.IK(robot, frame)
    rng = np.random.default_rng(seed)
    return [pin.SE3ToXYZQUAT(ik.pose_at(q)).tolist() for q in rng.uniform(-np.pi, np.pi, (count, len(ik.chain)))]


def write_poses(path: str, robot: str, frame: str, count: int, seed: int) -> None:
    with open(path, "w") as f:
        f.write(f"# {count} poses of {robot} {frame}, random q (seed {seed})\n")
        for p in poses(robot, frame, count, seed):
            f.write(" ".join(f"{v:.17g}" for v in p) + "\n")


def run_child(cmd: list[str], stdout=subprocess.DEVNULL, env: dict | None = None) -> tuple[int, float, float]:
    """(exit status, wall s, CPU s of the command and its children)."""
    t0 = time.perf_counter()
    p = subprocess.Popen(cmd, stdout=stdout, stderr=subprocess.DEVNULL, env=env)
    # os.wait4 gives the rusage of the process itself; its children (workers) are added by the
    # kernel to it once it has waited for them (ProcessPoolExecutor joins its workers)
    _, status, ru = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t0
    p.returncode = os.waitstatus_to_exitcode(status)
    return p.returncode, wall, ru.ru_utime + ru.ru_stime


def kinbox_cmd() -> list[str]:
    return [sys.executable, "-m", "kinbox.cli"]


def cmd_per_pose(a) -> dict:
    import kinbox

    ik = kinbox.IK(a.robot, a.frame)
    ps = poses(a.robot, a.frame, a.count, a.seed)
    ik.solve(ps[0], progress=False)  # kernels loaded, template built
    cpu, boxes, lps, sols = [], [], [], []
    for p in ps:
        c0 = time.process_time()
        r = ik.solve(p, progress=False)
        cpu.append(time.process_time() - c0)
        boxes.append(r.stats["boxes"])
        lps.append(r.stats["lps"])
        sols.append(len(r.solutions))
        assert r.complete
    cpu_a = np.array(cpu)
    out = {
        "robot": a.robot,
        "poses": len(ps),
        "seed": a.seed,
        "cpu_median_ms": 1e3 * float(np.median(cpu_a)),
        "cpu_worst_ms": 1e3 * float(cpu_a.max()),
        "cpu_p90_ms": 1e3 * float(np.quantile(cpu_a, 0.9)),
        "cpu_mean_ms": 1e3 * float(cpu_a.mean()),
        "boxes_median": statistics.median(boxes),
        "boxes_max": max(boxes),
        "lps_median": statistics.median(lps),
        "solutions_total": sum(sols),
    }
    return out


def cmd_throughput(a) -> list[dict]:
    out = []
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "poses.txt")
        write_poses(path, a.robot, a.frame, a.count, a.seed)
        for w in a.workers:
            extra = [] if w == 0 else ["--workers", str(w)]
            with open(os.path.join(d, f"out{w}.jsonl"), "w") as f:
                code, wall, cpu = run_child(
                    [
                        *kinbox_cmd(),
                        "ik",
                        a.robot,
                        "--frame",
                        a.frame,
                        "--poses",
                        path,
                        "--json",
                        "--quiet",
                        "--time-limit",
                        str(a.time_limit),
                        *extra,
                    ],
                    stdout=f,
                )
            with open(os.path.join(d, f"out{w}.jsonl")) as f:
                recs = [json.loads(line) for line in f]
            out.append(
                {
                    "robot": a.robot,
                    "poses": a.count,
                    "workers": w or 1,
                    "exit": code,
                    "answers": len(recs),
                    "wall_s": wall,
                    "cpu_s": cpu,
                    "poses_per_s_wall": a.count / wall,
                    "solutions": sum(len(r.get("solutions", [])) for r in recs),
                    "incomplete_lines": [r["line"] for r in recs if not r.get("complete", False)],
                }
            )
            print(json.dumps(out[-1]), file=sys.stderr)
    return out


def cmd_startup(a) -> dict:
    cmd = [*kinbox_cmd(), "ik", "ur5", "--frame", "tool0", "--from-q", STARTUP_Q, "--quiet"]
    # caches warm: numba's kernels, and Python's bytecode of kinbox's modules, which any install
    # has (pip compiles it, or the first import writes it) but an editable install run with
    # PYTHONDONTWRITEBYTECODE set never writes: then every start compiled kinbox's modules
    # from source
    run_child(cmd, env={k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"})
    runs = [run_child(cmd) for _ in range(a.repeat)]
    imp = [run_child([sys.executable, "-c", "import kinbox"]) for _ in range(a.repeat)]
    bare = [run_child([sys.executable, "-c", "pass"]) for _ in range(a.repeat)]
    return {
        "command": "kinbox ik ur5 --frame tool0 --from-q " + STARTUP_Q,
        "cpu_s_median": statistics.median(r[2] for r in runs),
        "wall_s_median": statistics.median(r[1] for r in runs),
        "cpu_s_min": min(r[2] for r in runs),
        "import_kinbox_cpu_s_median": statistics.median(r[2] for r in imp),
        "import_kinbox_wall_s_median": statistics.median(r[1] for r in imp),
        "bare_python_cpu_s_median": statistics.median(r[2] for r in bare),
    }


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    mk = sub.add_parser("make-poses")
    pp = sub.add_parser("per-pose")
    tp = sub.add_parser("throughput")
    su = sub.add_parser("startup")
    for q in (mk, pp, tp):
        q.add_argument("--robot", default="ur5")
        q.add_argument("--frame", default="tool0")
        q.add_argument("--count", type=int, default=100)
        q.add_argument("--seed", type=int, default=0)
    mk.add_argument("-o", "--output", required=True)
    tp.add_argument("--workers", type=int, nargs="+", default=[0, 2], help="0: no --workers flag (serial)")
    tp.add_argument("--time-limit", type=float, default=10.0, help="per pose (seconds of wall time)")
    su.add_argument("--repeat", type=int, default=5)
    a = p.parse_args()
    if a.cmd == "make-poses":
        write_poses(a.output, a.robot, a.frame, a.count, a.seed)
        return
    res = {"per-pose": cmd_per_pose, "throughput": cmd_throughput, "startup": cmd_startup}[a.cmd](a)
    print(
        json.dumps(
            {
                "machine": f"{platform.node()} {platform.processor() or platform.machine()}, {len(os.sched_getaffinity(0))} cores",
                "date": time.strftime("%Y-%m-%d"),
                "result": res,
            },
            indent=1,
        )
    )


if __name__ == "__main__":
    main()
