"""The fixed cost of a kinbox process: where a small problem's CPU and memory go outside the
search, and what a first run without compiled kernels costs.

    python benchmarks/startup.py steps [--problem general-6r] [--repeat 3] [--time-limit 900] [--numba]
    python benchmarks/startup.py cold [--repeat 2] [--record]  # the demo's answers and load_all_kernels, empty cache

``steps``: a fresh process per run (bytecode cached, as an installed package has it) imports
numpy, scipy.sparse, Pinocchio, HiGHS and kinbox one after the other (the collector set as the
``kinbox`` program sets it, :func:`kinbox.cli.command`), then answers ``kinbox solve PROBLEM
--json`` through the command line's ``main``; each step's CPU (``time.process_time``) and the
resident memory after it (all of it, the process's own anonymous memory, the pages of mapped
files: the libraries' code), the kernel loading timed apart (:func:`kinbox.search.loading.load_clock`:
the ahead-of-time module, or numba's import and compiler lock), the search's own CPU from the
answer's stats, the process's peak memory (``ru_maxrss``), the CPU of the collector's passes,
the compiled kernels the process called (ahead of time or numba) and whether numba was
imported. ``--numba`` imports numba and makes its set-up that a first kernel loaded from its
cache makes (``target_context.refresh()``) as steps of their own (run with
``KINBOX_NO_AOT=1``: the process as it is without the ahead-of-time module). The minimum CPU
and the largest memory over the runs are printed (JSON with ``--json``).

``cold``: each command in a fresh process with numba's cache pointed at an empty folder
(``NUMBA_CACHE_DIR``), so every kernel it calls is compiled: CPU of the whole process (user +
system, ``os.wait4``) and its peak memory. ``load_all_kernels`` is what ``make setup`` runs.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import report

ROOT = Path(__file__).resolve().parents[1]

_STEPS = r"""
import json, resource, sys, time, io, contextlib, threading
def rss():
    d = {}
    with open("/proc/self/status") as f:
        for line in f:
            k = line.split(":")[0]
            if k in ("VmRSS", "RssAnon", "RssFile"):
                d[k] = int(line.split()[1]) / 1024
    return d
import gc
import kinbox.cli  # the program's collector settings (kinbox.cli.command), before any library loads
young, middle, _ = gc.get_threshold()
gc.set_threshold(young, middle, kinbox.cli.FULL_GC_EVERY)
collector = [0.0, 0.0]
def on_gc(phase, info):
    if phase == "start":
        collector[1] = time.process_time()
    else:
        collector[0] += time.process_time() - collector[1]
gc.callbacks.append(on_gc)
out = []
t = time.process_time()
def lap(name):
    global t
    n = time.process_time()
    out.append([name, n - t, rss()])
    t = n
import numpy; lap("numpy")
import scipy.sparse; lap("scipy.sparse")
import pinocchio; lap("pinocchio")
import highspy; lap("highspy")
if sys.argv[2] == "1":
    import numba; lap("numba")
import kinbox.cli, kinbox.pipeline; lap("kinbox's modules")
if sys.argv[2] == "1":
    from numba.core.registry import cpu_target
    cpu_target.target_context.refresh(); lap("numba's set-up before a first kernel")
from kinbox.search import jit
from kinbox.search.loading import load_clock
buf = io.StringIO()
with contextlib.redirect_stdout(buf), load_clock() as held:
    code = kinbox.cli.main(["solve", sys.argv[1], "--json", *sys.argv[3:]])
total = time.process_time() - t
res = json.loads(buf.getvalue())
search = float(res["stats"].get("cpu_seconds", 0.0)) - held.seconds  # the kernels load inside the search (wall seconds)
out.append(["kernel loading (wall)", held.seconds, rss()])
out.append(["search (without kernel loading)", max(search, 0.0), rss()])
out.append(["model, formulation, answer, JSON", total - held.seconds - max(search, 0.0), rss()])
ru = resource.getrusage(resource.RUSAGE_SELF)
print(json.dumps({"steps": out, "cpu": ru.ru_utime + ru.ru_stime, "peak_mb": ru.ru_maxrss / 1024, "exit": code,
                  "boxes": res["stats"].get("boxes"), "kernels": [f"{k} ({how})" for k, how in jit.loaded_kernels()],
                  "numba": "numba" in sys.modules, "gc_cpu": collector[0], "gc_full": gc.get_stats()[2]["collections"]}))
"""


def _env(**extra: str) -> dict[str, str]:
    env = dict(os.environ, **extra)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "src"), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # as installed: kinbox's bytecode cached
    return env


def steps(problem: str, repeat: int, numba: bool = False, extra: tuple[str, ...] = ()) -> dict:
    runs = []
    for i in range(repeat):
        args = [sys.executable, "-c", _STEPS, problem, "1" if numba else "0", *extra]
        out = subprocess.run(args, capture_output=True, text=True, env=_env(), check=True)
        runs.append(json.loads(out.stdout.strip().splitlines()[-1]))
        print(f"[{i + 1}/{repeat}] {problem}: {runs[-1]['cpu']:.2f} s CPU, peak {runs[-1]['peak_mb']:.0f} MB", file=sys.stderr)
    names = [s[0] for s in runs[0]["steps"]]
    rows = [
        {"step": n, "cpu_min": min(r["steps"][k][1] for r in runs), "cpu_max": max(r["steps"][k][1] for r in runs),
         "rss_mb": max(r["steps"][k][2]["VmRSS"] for r in runs), "anon_mb": max(r["steps"][k][2]["RssAnon"] for r in runs),
         "file_mb": max(r["steps"][k][2]["RssFile"] for r in runs)}
        for k, n in enumerate(names)
    ]  # fmt: skip
    return {
        "problem": problem,
        "runs": len(runs),
        "rows": rows,
        "cpu_min": min(r["cpu"] for r in runs),
        "cpu_max": max(r["cpu"] for r in runs),
        "peak_mb": max(r["peak_mb"] for r in runs),
        "kernels": runs[0]["kernels"],
        "numba": any(r["numba"] for r in runs),
        "gc_cpu_min": min(r["gc_cpu"] for r in runs),
        "gc_full": max(r["gc_full"] for r in runs),
        "args": list(extra),
    }


def _measured(cmd: list[str], env: dict[str, str]) -> dict:
    p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    _, status, ru = os.wait4(p.pid, 0)
    return {"cpu": ru.ru_utime + ru.ru_stime, "peak_mb": ru.ru_maxrss / 1024, "exit": os.waitstatus_to_exitcode(status)}


COLD = {
    "kinbox solve general-6r": ["-m", "kinbox.cli", "solve", "general-6r"],
    "kinbox ik ur5 --frame tool0 --from-q ...": [
        "-m",
        "kinbox.cli",
        "ik",
        "ur5",
        "--frame",
        "tool0",
        "--from-q",
        "0.3,-1.2,1.5,-0.8,1.2,0.4",
    ],
    "load_all_kernels (make setup)": ["-c", "import kinbox.pipeline as p; p.load_all_kernels()"],
}


def cold(repeat: int = 1) -> list[dict]:
    """Each command ``repeat`` times (rounds over the commands), each time in a fresh empty
    kernel cache, then once more on the cache it filled: the least CPU of the rounds (a loaded
    machine only adds), the largest memory."""
    runs: dict[str, list] = {name: [] for name in COLD}
    for i in range(repeat):
        for name, args in COLD.items():
            with tempfile.TemporaryDirectory(prefix="kinbox-cold-") as cache:
                m = _measured([sys.executable, *args], _env(NUMBA_CACHE_DIR=cache))
                m2 = _measured([sys.executable, *args], _env(NUMBA_CACHE_DIR=cache))
            runs[name].append((m, m2))
            cold_s = f"cold {m['cpu']:.1f} s CPU ({m['peak_mb']:.0f} MB)"
            print(f"[{i + 1}/{repeat}] {name}: {cold_s}, then {m2['cpu']:.2f} s ({m2['peak_mb']:.0f} MB)", file=sys.stderr)
    return [
        {
            "command": name,
            "runs": len(rs),
            "cold_cpu": min(m["cpu"] for m, _ in rs),
            "cold_cpu_max": max(m["cpu"] for m, _ in rs),
            "cold_peak_mb": max(m["peak_mb"] for m, _ in rs),
            "warm_cpu": min(m2["cpu"] for _, m2 in rs),
            "warm_peak_mb": max(m2["peak_mb"] for _, m2 in rs),
        }
        for name, rs in runs.items()
    ]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("mode", choices=["steps", "cold"])
    ap.add_argument("--problem", default="general-6r")
    ap.add_argument("--repeat", type=int, help="fresh processes per measurement (steps: 3, cold: 1)")
    ap.add_argument("--numba", action="store_true", help="numba's import and set-up as steps of their own")
    ap.add_argument("--time-limit", help="passed to kinbox solve (as the CuikSuite benchmark does)")
    ap.add_argument("--json", help="write the results here")
    ap.add_argument("--record", action="store_true", help="cold: record the rows on docs/benchmarks.md (benchmarks/report.py)")
    a = ap.parse_args(argv)
    calibration = report.calibrate() if a.record else 0.0
    if a.mode == "steps":
        extra = ("--time-limit", a.time_limit) if a.time_limit else ()
        res: dict | list = steps(a.problem, a.repeat or 3, a.numba, extra)
        assert isinstance(res, dict)
        cmd = " ".join(["kinbox solve", res["problem"], "--json", *extra])
        print(f"{cmd}, {res['runs']} fresh processes: CPU min-max over the runs, memory after the step\n")
        print("| step | CPU s | resident MB after | of it anonymous | of it mapped files |\n|---|---|---|---|---|")
        for r in res["rows"]:
            print(f"| {r['step']} | {r['cpu_min']:.2f}-{r['cpu_max']:.2f} | {r['rss_mb']:.0f} | {r['anon_mb']:.0f} | {r['file_mb']:.0f} |")
        print(f"| whole process | {res['cpu_min']:.2f}-{res['cpu_max']:.2f} | peak {res['peak_mb']:.0f} | | |")
        print(f"\nthe collector: {res['gc_cpu_min']:.2f} s CPU of it, {res['gc_full']} full passes")
        print(f"{len(res['kernels'])} compiled kernels called: {', '.join(k.removeprefix('kinbox.') for k in res['kernels'])}")
        print(f"numba imported: {res['numba']}")
    else:
        res = cold(a.repeat or 1)
        if a.record:
            report.record("startup-cold", res, calibration=calibration, mode=f"--repeat {a.repeat or 1}")
        print("| command | first run, empty kernel cache: CPU s | peak MB | second run: CPU s | peak MB |\n|---|---|---|---|---|")
        for r in res:
            print(f"| {r['command']} | {r['cold_cpu']:.1f} | {r['cold_peak_mb']:.0f} | {r['warm_cpu']:.2f} | {r['warm_peak_mb']:.0f} |")
    if a.json:
        Path(a.json).write_text(json.dumps(res, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
