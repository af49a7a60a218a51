"""CPU seconds per IK pose by arm class: the arm formulation against the general one.

For each class, ``--poses`` random poses (a random configuration inside the limits, its pose by
forward kinematics): example-robot-data's UR5 and Panda (a joint locked at a random value per
pose), and random arms of tests/support/fuzz_arms.py written as URDF (one arm per pose: UR-like,
industrial, spherical wrist, general 6R). Each pose is solved twice in this process, with
``kinbox.IK(..., formulation="auto")`` (the arm template when the chain is six joints) and with
``formulation="general"`` (the formulation every pose had before), so the ratios come from one
run. CPU time is ``time.process_time`` around ``IK.solve`` only; building the arm template (once
per arm and frame) is reported on its own. Every answer is checked: each solution reaches the
pose (independent FK) and the generating configuration is among the solutions.

    PYTHONPATH=src python benchmarks/arm_classes.py --poses 20 [--classes ur5,ur_like] [--before-limit 20]

``--baseline arm`` compares with the arm formulation instead (``formulation="arm"``: for a
general 6R arm, the formulation it had before Raghavan and Roth's invariants).

Prints a Markdown table (and the records as JSON with ``--json FILE``); it is not on
docs/benchmarks.md yet: a ``Table`` entry in benchmarks/report.py would put it there.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pinocchio as pin

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import kinbox  # noqa: E402
from tests.support import fuzz_arms as fa  # noqa: E402

CLASSES = ("ur5", "ur_like", "industrial", "spherical_wrist", "general_6r", "panda_locked")
#: targets per class: (median, worst) CPU seconds per pose
TARGETS = {
    "ur5": (0.010, 0.050),
    "ur_like": (0.010, 0.050),
    "industrial": (0.050, 0.3),
    "spherical_wrist": (0.050, 0.3),
    "general_6r": (0.3, 3.0),
    "panda_locked": (0.050, 0.5),
}


def cases(cls: str, n: int, directory: str):
    """(robot, frame, lock, goal, q_gen) of ``n`` poses of class ``cls``; deterministic."""
    if cls in ("ur5", "panda_locked"):
        name, frame = ("ur5", "tool0") if cls == "ur5" else ("panda", "panda_hand")
        rng = np.random.default_rng(18)
        model = kinbox.IK(name, frame).robot.model
        for _ in range(n):
            q = rng.uniform(model.lowerPositionLimit, model.upperPositionLimit)
            lock = {}
            if cls == "panda_locked":  # the fingers are off the path to the hand: neutral
                q[7:] = pin.neutral(model)[7:]
                lock = {"panda_joint7": float(q[6])}
            yield name, frame, lock, fa.frame_pose(model, frame, q), q
        return
    for seed in range(n):
        case = fa.make_case(cls, seed, directory)
        yield case.robot, case.frame, dict(case.lock), case.goal, fa.config_from_values(case.model, case.values)


def check(ik: kinbox.IK, frame: str, goal, q_gen, res) -> str:
    model = ik.robot.model
    if not res.complete:
        return "incomplete"
    for s in res.solutions:
        if fa.pose_error(model, frame, s.q, goal) > fa.FK_TOL:
            return "bad solution"
    if not any(fa.value_distance(model, fa.joint_values(model, s.q), fa.joint_values(model, q_gen)) < 1e-6 for s in res.solutions):
        return "q_gen missing"
    return "ok"


def run_class(
    cls: str, n: int, before_limit: float, directory: str, arm_limit: float | None = None, general: bool = True, baseline: str = "general"
) -> list[dict]:
    out = []
    for k, (robot, frame, lock, goal, q_gen) in enumerate(cases(cls, n, directory)):
        rec: dict = {"class": cls, "pose": k, "baseline": baseline}
        for mode in ("auto", baseline) if general else ("auto",):
            key = "general" if mode == baseline else mode  # the baseline's record, whichever it is
            ik = kinbox.IK(robot, frame, lock=lock or None, formulation=mode)
            t0 = time.process_time()
            arm = ik.arm  # built once per arm and frame (None: the general formulation)
            t1 = time.process_time()
            limit = arm_limit if mode == "auto" else before_limit
            res = ik.solve(goal, time_limit=limit)
            t2 = time.process_time()
            rec[key] = {
                "cpu": t2 - t1,
                "build": t1 - t0,
                "arm": arm is not None,
                "boxes": res.stats["boxes"],
                "lps": res.stats["lps"],
                "solutions": len(res.solutions),
                "variables": res.stats["variables"],
                "equations": res.stats["equations"],
                "complete": res.complete,
                "check": check(ik, frame, goal, q_gen, res),
            }
        a, g = rec["auto"], rec.get("general")
        rec["same"] = g is None or a["solutions"] == g["solutions"] or not g["complete"]
        other = "" if g is None else (f", {baseline} {g['cpu']:.3f} s ({g['boxes']} boxes, {g['solutions']} sol, {g['check']})")
        print(
            f"{cls} {k}: auto {a['cpu']:.3f} s ({a['boxes']} boxes, {a['solutions']} sol, {a['check']}){other}", file=sys.stderr, flush=True
        )
        out.append(rec)
    return out


def summary(records: list[dict], before_limit: float) -> str:
    base = records[0].get("baseline", "general") if records else "general"
    lines = [
        "| class | poses | auto median (s) | auto worst (s) | target median / worst | boxes (median) | LPs (median) "
        f"| vars x eqs | {base} median (s) | {base} worst (s) | ratio of medians | checks |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for cls in CLASSES:
        rs = [r for r in records if r["class"] == cls]
        if not rs:
            continue
        a = np.array([r["auto"]["cpu"] for r in rs])
        has_g = all("general" in r for r in rs)
        g = np.array([r["general"]["cpu"] for r in rs]) if has_g else np.full(len(rs), np.nan)
        cut = sum(not r["general"]["complete"] for r in rs) if has_g else 0
        tm, tw = TARGETS[cls]
        held = ("held" if np.median(a) <= tm else "missed") + " / " + ("held" if a.max() <= tw else "missed")
        bad = [f"{r['pose']}: {r['auto']['check']}" for r in rs if r["auto"]["check"] != "ok"]
        diff = sum(not r["same"] for r in rs)
        checks = "all ok" if not bad and not diff else "; ".join(bad + ([f"{diff} differ"] if diff else []))
        a_cut = sum(not r["auto"]["complete"] for r in rs)
        general_worst = (f"{g.max():.3f}" + (f" ({cut} cut)" if cut else "")) if has_g else "-"
        ar = rs[0]["auto"]
        lines.append(
            f"| {cls} | {len(rs)} | {np.median(a):.4f} | {a.max():.3f}{f' ({a_cut} cut)' if a_cut else ''} "
            f"| {tm:g} / {tw:g}: {held} "
            f"| {np.median([r['auto']['boxes'] for r in rs]):.0f} | {np.median([r['auto']['lps'] for r in rs]):.0f} "
            f"| {ar['variables']} x {ar['equations']}{'' if ar['arm'] else ' (general)'} "
            + (
                f"| {np.median(g):.3f} | {general_worst} | {np.median(g) / np.median(a):.1f} | {checks} |"
                if has_g
                else f"| - | - | - | {checks} |"
            )
        )
    return "\n".join(lines)


def plot(records: list[dict], path: str) -> None:
    """CPU seconds of each pose by class (log scale), the median and worst targets as ticks."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    classes = [c for c in CLASSES if any(r["class"] == c for r in records)]
    fig, ax = plt.subplots(figsize=(7.5, 3.8))
    rng = np.random.default_rng(0)
    for k, cls in enumerate(classes):
        cpu = np.array([r["auto"]["cpu"] for r in records if r["class"] == cls])
        ax.scatter(
            k + 0.12 * rng.uniform(-1, 1, len(cpu)), cpu, s=12, alpha=0.7, color="tab:blue", label="CPU per pose" if k == 0 else None
        )
        ax.hlines(np.median(cpu), k - 0.3, k + 0.3, color="tab:blue", lw=2, label="median" if k == 0 else None)
        tm, tw = TARGETS[cls]
        ax.hlines(tm, k - 0.3, k + 0.3, color="tab:green", ls="--", label="target median" if k == 0 else None)
        ax.hlines(tw, k - 0.3, k + 0.3, color="tab:red", ls=":", label="target worst" if k == 0 else None)
    ax.set_xticks(range(len(classes)), [c.replace("_", " ") for c in classes])
    ax.set_yscale("log")
    ax.set_ylabel("CPU s per pose")
    ax.set_title("kinbox IK, arm formulation: CPU per pose by arm class")
    ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--poses", type=int, default=20)
    ap.add_argument("--classes", default=",".join(CLASSES))
    ap.add_argument(
        "--before-limit",
        type=float,
        default=30.0,
        help="time limit of the general formulation per pose (seconds); a cut pose counts at its time",
    )
    ap.add_argument("--arm-limit", type=float, help="time limit of the arm formulation per pose (default none)")
    ap.add_argument("--json", metavar="FILE", help="the records, written after each class")
    ap.add_argument("--no-general", action="store_true", help="solve with the arm formulation only (to compare two versions of kinbox)")
    ap.add_argument("--baseline", default="general", choices=("general", "arm"), help="the formulation each pose is compared with")
    ap.add_argument("--plot", metavar="PNG", help="CPU per pose by class, with the targets (matplotlib)")
    ap.add_argument("--from-json", metavar="FILE", help="plot or summarise the records of an earlier run")
    a = ap.parse_args(argv)
    if a.from_json:
        records = json.loads(Path(a.from_json).read_text())
        print(summary(records, a.before_limit))
        if a.plot:
            plot(records, a.plot)
        return 0
    classes = [c for c in a.classes.split(",") if c]
    unknown = set(classes) - set(CLASSES)
    if unknown:
        ap.error(f"unknown classes {sorted(unknown)}; known: {', '.join(CLASSES)}")
    ik = kinbox.IK("ur5", "tool0")  # compiled kernels loaded before anything is timed
    ik.solve(ik.pose_at([0.1, -1.0, 1.0, 0.2, 0.5, 0.3]))
    if not a.no_general:
        kinbox.IK("ur5", "tool0", formulation=a.baseline).solve(ik.pose_at([0.1, -1.0, 1.0, 0.2, 0.5, 0.3]))
    records: list[dict] = []
    with tempfile.TemporaryDirectory() as d:
        for cls in classes:
            records += run_class(cls, a.poses, a.before_limit, d, a.arm_limit, general=not a.no_general, baseline=a.baseline)
            if a.json:
                Path(a.json).write_text(json.dumps(records, indent=1))
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    builds = [r["auto"]["build"] for r in records if r["auto"]["arm"]]
    print(
        f"Run of {stamp} on {platform.node() or 'this machine'} ({platform.processor() or platform.machine()}, "
        f"{os.cpu_count()} cores), kinbox {kinbox.__version__}, {a.poses} poses per class, "
        f"CPU seconds per pose (time.process_time), one process; time limits (wall clock) per pose: {a.baseline} "
        f"formulation {a.before_limit:g} s, auto {a.arm_limit if a.arm_limit else 'none'}.\n"
    )
    print(summary(records, a.before_limit))
    if a.plot:
        plot(records, a.plot)
    if builds:
        print(
            f"\nArm template built once per arm and frame: median {np.median(builds):.3f} s, "
            f"worst {max(builds):.3f} s CPU (not in the per-pose times)."
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
