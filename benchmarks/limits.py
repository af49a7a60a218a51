"""Resources of `kinbox` at its input limits: exit status, wall and CPU seconds and
peak resident memory of whole command-line runs, each in its own process.

    python benchmarks/limits.py            # prints a Markdown table

Cases: a mechanism file of 200k DH rows (refused at once), the largest loop allowed (128
joints) under `--time-limit 5` (the limit covers loading and formulation), and a UR5 pose for
scale.
"""

from __future__ import annotations

import json
import os
import platform
import random
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def dh_loop(path: Path, rows: int) -> Path:
    rng = random.Random(1)
    spec = {
        "kind": "dh-loop",
        "dh": [{"a": round(rng.random(), 6), "d": round(rng.random(), 6), "alpha": round(rng.random(), 6)} for _ in range(rows)],
    }
    path.write_text(json.dumps(spec))
    return path


def run(args: list[str]) -> dict:
    """Exit status, wall seconds, CPU seconds (user + system) and peak RSS (MB) of one process."""
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    t = time.perf_counter()
    p = subprocess.Popen([sys.executable, "-m", "kinbox.cli", *args], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env, text=True)
    err = p.stderr.read()
    _, status, ru = os.wait4(p.pid, 0)
    return {
        "status": os.waitstatus_to_exitcode(status),
        "wall": time.perf_counter() - t,
        "cpu": ru.ru_utime + ru.ru_stime,
        "peak_mb": ru.ru_maxrss / 1024,
        "stderr": err.strip().splitlines()[-1:] or [""],
    }


def main() -> None:
    with tempfile.TemporaryDirectory() as d:
        big = dh_loop(Path(d) / "rows200k.json", 200_000)
        loop128 = dh_loop(Path(d) / "loop128.json", 128)
        cases = [
            (f"200k DH rows ({big.stat().st_size / 2**20:.1f} MB file)", ["solve", str(big)]),
            ("128-joint DH loop, --time-limit 5", ["solve", str(loop128), "--time-limit", "5", "--quiet"]),
            ("UR5 pose", ["ik", "ur5", "--frame", "tool0", "--pose", "0.3", "0.2", "0.4", "0", "1", "0", "0", "--quiet"]),
        ]
        print(
            f"Machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
            f"Python {platform.python_version()}; {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}\n"
        )
        print("| case | exit | wall s | CPU s | peak MB | last line on stderr |")
        print("|---|---|---|---|---|---|")
        for label, args in cases:
            r = run(args)
            print(
                f"| {label} | {r['status']} | {r['wall']:.2f} | {r['cpu']:.2f} | {r['peak_mb']:.0f} | {r['stderr'][0][:110]} |", flush=True
            )


if __name__ == "__main__":
    main()
