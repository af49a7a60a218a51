"""What a collision scene costs and whether its verdicts hold (docs/scenes.md).

1. **UR5 in ur5-cell**: ``--poses`` random poses (a random configuration within the limits,
   its pose by forward kinematics), each solved with ``kinbox.IK("ur5", "tool0")`` and with
   ``kinbox.IK(..., scene="ur5-cell")`` in this process, interleaved: the median CPU seconds
   per pose of each and their ratio (target: at most 1.5). Every verdict is checked against
   coal's ``computeCollisions`` on the full meshes, and the free solutions against the
   closed-form UR5 solutions (tests/support/oracles/ur_ik.py) that coal finds free.
2. **Panda in panda-shelf**: the same with the Panda's hand (joint 7 locked at a random value
   per pose, a six-joint chain): per-pose cost of the scene.
3. **Panda self-motion in the shelf**: the 7-joint self-motion through a configuration with
   the hand inside the shelf, split into collision-free stretches; every stretch sampled 10x
   finer (coal on the meshes) must show no contact.

    PYTHONPATH=src python benchmarks/scenes.py [--poses 100] [--panda-poses 20] [--no-selfmotion] [--json FILE]

prints a Markdown section and records its rows on docs/benchmarks.md (``report.record``, key
``scenes``; ``--no-record`` leaves the page alone).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
import pinocchio as pin

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))  # report, also when imported as benchmarks.scenes (a test)

import report  # noqa: E402

import kinbox  # noqa: E402
from tests.support.oracles.ur_ik import ur_ik  # noqa: E402

#: a Panda configuration with the hand between the shelf's lower boards, clear of everything
#: (found by sampling configurations within the limits, kept fixed here)
PANDA_IN_SHELF = [2.07, -1.394, -1.698, -1.973, -0.89, 3.048, -2.446]


def coal_contact(scene, q) -> set:
    model = scene.model
    data, gdata = model.createData(), pin.GeometryData(scene.geom)
    pin.computeCollisions(model, data, scene.geom, gdata, q, False)
    return {
        (scene.labels[p.first], scene.labels[p.second])
        for k, p in enumerate(scene.geom.collisionPairs)
        if gdata.collisionResults[k].isCollision()
    }


def same_mod_2pi(a, b, tol=1e-6) -> bool:
    return bool(np.max(np.abs(np.angle(np.exp(1j * (np.asarray(a) - np.asarray(b)))))) < tol)


def timed(fn, *args, **kw):
    t = time.process_time()
    out = fn(*args, **kw)
    return out, time.process_time() - t


scene_cache: dict = {}  # robot -> its CollisionScene, built once (IK objects per lock share it)


def per_pose(robot, frame, scene, poses, lock=None, check=None):
    plain = kinbox.IK(robot, frame, lock=lock)
    withs = kinbox.IK(robot, frame, lock=lock, scene=scene)
    plain.solve(poses[0][0])  # kernels loaded, geometry built: not counted
    withs.solve(poses[0][0])
    t0, t1, own, records = [], [], [], []
    counts: dict = {}
    for goal, lk in poses:
        if lk is not None:
            plain = kinbox.IK(robot, frame, lock=lk)
            withs = kinbox.IK(robot, frame, lock=lk, scene=scene)
            withs.scene._built = scene_cache.setdefault(robot, withs.scene.collision)
        r0, s0 = timed(plain.solve, goal)
        r1, s1 = timed(withs.solve, goal)
        t0.append(s0)
        t1.append(s1)
        c = r1.stats["collision"]
        own.append(c["cpu_seconds"])
        for k, v in c["checks"].items():
            counts[k] = counts.get(k, 0) + v
        records.append((goal, r0, r1))
        if check is not None:
            check(withs.scene.collision, goal, r1)
    counts["scene_seconds"] = own
    return np.array(t0), np.array(t1), counts, withs.scene.collision, records


def ur5_section(n: int) -> dict:
    rng = np.random.default_rng(40)
    ik = kinbox.IK("ur5", "tool0")
    model = ik.robot.model
    poses = []
    for _ in range(n):
        q = rng.uniform(np.maximum(model.lowerPositionLimit, -math.pi), np.minimum(model.upperPositionLimit, math.pi))
        poses.append((ik.pose_at(q), None))
    bad = {"verdict": 0, "clearance": 0, "oracle": 0, "solutions": 0, "free": 0, "contact": 0}

    def check(scene, goal, res):
        for s in res.solutions:
            contact = coal_contact(scene, s.q)
            bad["solutions"] += 1
            bad["free" if not contact else "contact"] += 1
            if s.collision["free"] != (not contact) or {tuple(p) for p in s.collision["pairs"]} != contact:
                bad["verdict"] += 1
        free_oracle = [q for q in ur_ik("ur5", goal.homogeneous) if not coal_contact(scene, np.asarray(q))]
        free_kinbox = [s.q for s in res.solutions if s.collision["free"]]
        if len(free_oracle) != len(free_kinbox) or not all(any(same_mod_2pi(q, p) for p in free_kinbox) for q in free_oracle):
            bad["oracle"] += 1

    t0, t1, counts, scene, _ = per_pose("ur5", "tool0", "ur5-cell", poses, check=check)
    own = counts.pop("scene_seconds")
    return {
        "scene_median_per_pose": float(np.median(own)),
        "poses": n,
        "median_plain": float(np.median(t0)),
        "median_scene": float(np.median(t1)),
        "ratio": float(np.median(t1) / np.median(t0)),
        "ratio_of_sums": float(np.sum(t1) / np.sum(t0)),
        "pairs": scene.counts,
        "checks": counts,
        "agreement": bad,
    }


def panda_section(n: int) -> dict:
    rng = np.random.default_rng(41)
    ik = kinbox.IK("panda", "panda_hand")
    model = ik.robot.model
    poses = []
    for _ in range(n):
        q = rng.uniform(model.lowerPositionLimit, model.upperPositionLimit)
        lk = {"panda_joint7": float(q[6])}
        poses.append((ik.pose_at(q), lk))
    t0, t1, counts, scene, recs = per_pose("panda", "panda_hand", "panda-shelf", poses, lock=poses[0][1])
    sols = sum(len(r1.solutions) for _, _, r1 in recs)
    own = counts.pop("scene_seconds")
    return {
        "poses": n,
        "solutions": sols,
        "median_plain": float(np.median(t0)),
        "median_scene": float(np.median(t1)),
        "ratio": float(np.median(t1) / np.median(t0)),
        "scene_seconds_per_solution": float(np.sum(own) / max(sols, 1)),
        "scene_median_per_pose": float(np.median(own)),
        "pairs": scene.counts,
        "checks": counts,
    }


def selfmotion_section() -> dict:
    ik = kinbox.IK("panda", "panda_hand", scene="panda-shelf")
    goal = ik.pose_at(PANDA_IN_SHELF)
    res, secs = timed(ik.solve, goal, progress=False)
    scene = ik.scene.collision
    model = scene.model
    stretches = pieces = checked = contacts = samples = colliding = inserted = 0
    low = math.inf
    for cv in res.curves.values():
        for b in cv.collision or []:
            samples += b["samples"]
            colliding += b["colliding_samples"]
            inserted += b["inserted"]
            for st in b["stretches"]:
                stretches += 1
                pl = [np.array(q) for q in st["polyline"]]
                pieces += len(pl)
                if st["clearance"] is not None:
                    low = min(low, st["clearance"])
                for a, c in zip(pl, pl[1:]):
                    for t in np.linspace(0, 1, 11)[1:-1]:
                        checked += 1
                        contacts += bool(coal_contact(scene, pin.interpolate(model, a, c, t)))
    return {
        "complete": res.complete,
        "seconds": secs,
        "curves": len(res.curves),
        "samples": samples,
        "colliding_samples": colliding,
        "inserted": inserted,
        "stretches": stretches,
        "stretch_points": pieces,
        "finer_checked": checked,
        "finer_contacts": contacts,
        "lowest_stretch_clearance": low if math.isfinite(low) else None,
        "scene_checks": res.stats["collision"]["checks"],
        "scene_seconds": res.stats["collision"]["cpu_seconds"],
    }


def pruning_section() -> list[dict]:
    """The Panda's self-motion through ``PANDA_IN_SHELF`` with ``collision_free``, searched without
    and with pruning inside the search (``prune_scene``), in panda-shelf and in panda-clutter:
    boxes, CPU seconds, and the free stretches found (the same with and without)."""
    out = []
    for name in ("panda-shelf", "panda-clutter"):
        row: dict = {"scene": name}
        for prune in (False, True):
            ik = kinbox.IK("panda", "panda_hand", scene=name)
            res, secs = timed(ik.solve, ik.pose_at(PANDA_IN_SHELF), collision_free=True, prune_scene=prune, progress=False)
            stretches = [st for cv in res.curves.values() for b in (cv.collision or []) for st in b["stretches"]]
            key = "on" if prune else "off"
            row[key] = {
                "boxes": res.stats["boxes"],
                "cpu_seconds": secs,
                "complete": res.complete,
                "curves": len(res.curves),
                "stretches": len(stretches),
                "stretch_points": sum(len(st["polyline"]) for st in stretches),
                "pruning": res.stats["collision"].get("pruning"),
            }
            print(f"scenes: pruning {name} {key}: {row[key]}", file=sys.stderr)
        row["boxes_ratio"] = row["on"]["boxes"] / max(row["off"]["boxes"], 1)
        row["cpu_ratio"] = row["on"]["cpu_seconds"] / row["off"]["cpu_seconds"]
        out.append(row)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses", type=int, default=100)
    ap.add_argument("--panda-poses", type=int, default=20)
    ap.add_argument("--no-selfmotion", action="store_true")
    ap.add_argument("--pruning", action="store_true", help="also measure pruning inside the search (minutes of CPU)")
    ap.add_argument("--json", metavar="FILE")
    ap.add_argument("--no-record", action="store_true", help="do not record the rows on docs/benchmarks.md")
    a = ap.parse_args()
    calibration = report.calibrate()
    print(f"scenes: machine {json.dumps(report.machine())}; calibration: 1e7 additions in {calibration:.3f} s CPU", file=sys.stderr)
    out = {"ur5": ur5_section(a.poses), "panda": panda_section(a.panda_poses)}
    if not a.no_selfmotion:
        out["selfmotion"] = selfmotion_section()
    if a.pruning:
        out["pruning"] = pruning_section()
    u, p = out["ur5"], out["panda"]
    lines = [
        "## Collision scenes (benchmarks/scenes.py)",
        "",
        "| case | poses | median s/pose without scene | with scene | ratio | active pairs | skipped (world-fixed, out of reach) |",
        "|---|---|---|---|---|---|---|",
        f"| UR5, ur5-cell | {u['poses']} | {u['median_plain']:.4f} | {u['median_scene']:.4f} | {u['ratio']:.2f} | "
        f"{u['pairs']['active']} | {u['pairs']['world_fixed']}, {u['pairs']['out_of_reach']} |",
        f"| Panda (joint 7 locked), panda-shelf | {p['poses']} | {p['median_plain']:.4f} | {p['median_scene']:.4f} | {p['ratio']:.2f} | "
        f"{p['pairs']['active']} | {p['pairs']['world_fixed']}, {p['pairs']['out_of_reach']} |",
        "",
        f"Per configuration (UR5): {u['checks']['sphere_skipped']} pair checks settled by bounding volumes, {u['checks']['hull_proofs']} "
        f"by convex hulls, {u['checks']['mesh_checked']} collision tests on meshes, {u['checks']['mesh_distances']} mesh distances "
        f"for the clearance, over {u['checks']['configurations']} solutions; the scene's own median CPU time per pose "
        f"{u['scene_median_per_pose'] * 1e3:.2f} ms. Panda: {p['scene_seconds_per_solution'] * 1e3:.2f} ms of scene per solution "
        f"({p['solutions']} solutions; {p['checks']['sphere_skipped']} pair checks settled by bounding volumes, "
        f"{p['checks']['hull_proofs']} by hulls, {p['checks']['mesh_checked']} collision tests on meshes).",
        "",
        f"Agreement (UR5, {u['poses']} poses, {u['agreement']['solutions']} solutions, {u['agreement']['free']} free): "
        f"{u['agreement']['verdict']} verdicts differ from coal's computeCollisions on the meshes; "
        f"{u['agreement']['oracle']} poses whose free set differs from the closed-form solutions filtered by coal.",
    ]
    if "selfmotion" in out:
        s = out["selfmotion"]
        lines += [
            "",
            f"Panda self-motion in panda-shelf: {s['curves']} curve(s), {s['samples']} configurations "
            f"({s['colliding_samples']} in contact), "
            f"{s['stretches']} collision-free stretch(es) of {s['stretch_points']} configurations ({s['inserted']} added by halving); "
            f"sampled 10x finer: {s['finer_contacts']} contacts in {s['finer_checked']} configurations; "
            f"lowest clearance bound along a stretch {s['lowest_stretch_clearance']}; search and scene {s['seconds']:.1f} s CPU, "
            f"of it the scene {s['scene_seconds']:.1f} s.",
        ]
    for r in out.get("pruning", []):
        lines += ["", report.scenes_pruning_line(r)]
    print("\n".join(lines))
    if a.json:
        Path(a.json).write_text(json.dumps(out, indent=1))
    if not a.no_record:
        report.record("scenes", page_rows(out), calibration=calibration, mode=f"{a.poses} UR5 poses, {a.panda_poses} Panda poses")
        print(f"scenes: wrote {report.PAGE.relative_to(ROOT)} and {report.RAW.relative_to(ROOT)}", file=sys.stderr)


def page_rows(out: dict) -> list[dict]:
    """One row per case for the benchmark page (benchmarks/report.py, key ``scenes``); the
    self-motion check rides on the Panda row."""
    rows = []
    for case, key in (("UR5, ur5-cell", "ur5"), ("Panda (joint 7 locked), panda-shelf", "panda")):
        r = out[key]
        row = {
            "case": case,
            "poses": r["poses"],
            "median_plain": r["median_plain"],
            "median_scene": r["median_scene"],
            "ratio": r["ratio"],
            "scene_median_per_pose": r["scene_median_per_pose"],
            "pairs": r["pairs"],
            "checks": r["checks"],
        }
        if "agreement" in r:
            row["agreement"] = r["agreement"]
        if key == "panda" and "selfmotion" in out:
            row["selfmotion"] = out["selfmotion"]
        if key == "panda" and "pruning" in out:
            row["pruning"] = out["pruning"]
        rows.append(row)
    return rows


if __name__ == "__main__":
    main()
