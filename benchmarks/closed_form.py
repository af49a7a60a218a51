#!/usr/bin/env python3
"""Closed-form IK against EAIK and ik-geo, measured in one run (CPU time per pose).

Needs ``eaik`` and ``ik-geo`` in the environment (references only, not kinbox dependencies):
``pip install eaik ik-geo``. Writes ``benchmarks/results/closed_form.json`` and the table of
``docs/closed-form.md`` (between its ``<!-- table -->`` markers) and records its rows on
``docs/benchmarks.md`` (``report.record``, keys ``closed-form`` and ``closed-form-singular``), or
prints them with ``--print``.

Rows, per arm (UR5, an IRB 120-like DH arm, a Panda with ``panda_joint7`` locked):

* batch: median CPU per pose over ``--batch`` poses (in chunks, the median over chunks) of
  ``IK.solve_array`` (compiled closed form, each root certified by Krawczyk in the joint
  angles, the default, timed chunk by chunk in turn with EAIK's repeated call; by Krawczyk
  on the kinbox system, on the first 2,000 poses; and with the interval closed form as the
  only proof), of EAIK's ``IK`` called once per pose and of ik-geo's ``get_ik`` called once
  per pose;
* single: one pose after loading (the median over 21 poses), kinbox's ``solve_array`` of one
  pose and the full ``IK.solve`` (a checked :class:`~kinbox.answer.result.Result`) against
  EAIK's first call (on a robot built afresh: the median over 7 robots);
* near-singular UR5 poses: how many real roots each tool returns, and kinbox's time against a
  generic pose's.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import pinocchio as pin

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

import kinbox  # noqa: E402
from kinbox.pipeline import IK  # noqa: E402

sys.path.insert(0, str(ROOT / "benchmarks"))
import report  # noqa: E402

ARMS = {
    "UR5": ("ur5", "tool0", {}),
    "IRB 120-like (DH)": (str(ROOT / "tests" / "data" / "arms" / "irb120_dh.json"), "tool", {}),
    "Panda, joint 7 locked": ("panda", "panda_hand", {"panda_joint7": 0.5}),
}


def cpu() -> float:
    return time.process_time()


def log(*a) -> None:
    print(*a, file=sys.stderr, flush=True)


def random_qs(ik: IK, n: int, seed: int) -> np.ndarray:
    model = ik.robot.model
    rng = np.random.default_rng(seed)
    lo, hi = [], []
    for j in ik.chain:
        i = model.joints[j].idx_q
        v = ik.robot.locked.get(model.names[j])
        if v is not None:
            lo.append(float(np.ravel(v)[0]))
            hi.append(float(np.ravel(v)[0]))
        else:
            lo.append(max(model.lowerPositionLimit[i], -math.pi))
            hi.append(min(model.upperPositionLimit[i], math.pi))
    return rng.uniform(lo, hi, (n, len(lo)))


def poses_of(ik: IK, qs: np.ndarray) -> np.ndarray:
    return np.array([pin.SE3ToXYZQUAT(ik.pose_at(q)) for q in qs])


def homogeneous(p: np.ndarray) -> np.ndarray:
    return pin.XYZQUATToSE3(p).homogeneous


def zero_geometry(ik: IK):
    """Axes ``h`` (6, 3), offsets ``p`` (7, 3) and the frame's rotation at the zero
    configuration (locked joints at their values), as Pinocchio computes them: IK-Geo's
    product-of-exponentials description of the chain."""
    model = ik.robot.model
    data = model.createData()
    q = pin.neutral(model)
    for name, v in ik.robot.locked.items():
        jm = model.joints[model.getJointId(name)]
        q[jm.idx_q : jm.idx_q + jm.nq] = v
    pin.framesForwardKinematics(model, data, q)
    moving = [j for j in ik.chain if model.names[j] not in ik.robot.locked]
    h, o = [], []
    for j in moving:
        M = data.oMi[j]
        h.append(
            M.rotation @ np.array([0.0, 0.0, 1.0]) if model.joints[j].shortname() == "JointModelRZ" else M.rotation @ _axis(model.joints[j])
        )
        o.append(M.translation)
    tool = data.oMf[model.getFrameId(ik.frame)]
    p = [o[0]] + [o[i + 1] - o[i] for i in range(5)] + [tool.translation - o[5]]
    return np.array(h), np.array(p), tool.rotation


def _axis(jm) -> np.ndarray:
    name = jm.shortname()
    if name.endswith("X"):
        return np.array([1.0, 0.0, 0.0])
    if name.endswith("Y"):
        return np.array([0.0, 1.0, 0.0])
    if name.endswith("Z"):
        return np.array([0.0, 0.0, 1.0])
    return np.asarray(jm.axis, dtype=float)


def urdf_of(ik: IK, path: Path) -> Path:
    """A URDF of a DH arm's model (the joints' placements as Pinocchio holds them), for EAIK."""
    model = ik.robot.model
    links = ['<link name="base"/>']
    joints = []
    parent = "base"
    for j in ik.chain:
        M = model.jointPlacements[j]
        rpy = pin.rpy.matrixToRpy(M.rotation)
        name = model.names[j]
        links.append(f'<link name="{name}_link"/>')
        lo, hi = float(model.lowerPositionLimit[model.joints[j].idx_q]), float(model.upperPositionLimit[model.joints[j].idx_q])
        joints.append(
            f'<joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{name}_link"/>'
            f'<origin xyz="{" ".join(repr(float(v)) for v in M.translation)}" rpy="{" ".join(repr(float(v)) for v in rpy)}"/>'
            f'<axis xyz="0 0 1"/><limit lower="{lo!r}" upper="{hi!r}" effort="1" velocity="1"/></joint>'
        )
        parent = f"{name}_link"
    F = model.frames[model.getFrameId(ik.frame)].placement
    rpy = pin.rpy.matrixToRpy(F.rotation)
    links.append('<link name="tool_link"/>')
    joints.append(
        f'<joint name="tool_joint" type="fixed"><parent link="{parent}"/><child link="tool_link"/>'
        f'<origin xyz="{" ".join(repr(float(v)) for v in F.translation)}" rpy="{" ".join(repr(float(v)) for v in rpy)}"/></joint>'
    )
    path.write_text('<robot name="dh_arm">' + "".join(links) + "".join(joints) + "</robot>\n")
    return path


def eaik_robot(name: str, ik: IK, tmp: Path):
    from eaik.IK_URDF import UrdfRobot

    if name == "UR5":
        return UrdfRobot(_urdf("ur_description/urdf/ur5_robot.urdf"))
    if name.startswith("Panda"):  # the arm's seven joints (EAIK counts the fingers too), joint 7 fixed
        return UrdfRobot(str(urdf_of(ik, tmp / "panda_arm.urdf")), fixed_axes=[(6, 0.5)])
    return UrdfRobot(str(urdf_of(ik, tmp / "dh_arm.urdf")))


def _urdf(rel: str) -> str:
    import example_robot_data as erd

    return str(Path(erd.getModelPath(rel)) / rel)


def ikgeo_robot(name: str, ik: IK):
    """ik-geo's solver of the arm's structure with its axes and offsets, and the frame's
    rotation at zero (ik-geo's end frame is the base's orientation there), or None."""
    import ik_geo

    h, p, R0 = zero_geometry(ik)
    if name == "UR5":
        return ik_geo.Robot.three_parallel_two_intersecting(h.tolist(), p.tolist()), R0
    if name.startswith("IRB"):
        return ik_geo.Robot.spherical_two_intersecting(h.tolist(), p.tolist()), R0
    return None, R0


def _same_set(a: np.ndarray, b: np.ndarray, tol: float = 1e-6) -> bool:
    """Do two arrays of configurations hold the same ones (angles modulo 2 pi), each once?"""
    if len(a) != len(b):
        return False
    left = list(range(len(b)))
    for x in a:
        hit = [k for k in left if np.max(np.abs(np.angle(np.exp(1j * (x - b[k]))))) < tol]
        if len(hit) != 1:
            return False
        left.remove(hit[0])
    return True


def per_pose_median(fn, items, chunk: int) -> float:
    """Median over chunks of the CPU time per item."""
    times = []
    for s in range(0, len(items), chunk):
        part = items[s : s + chunk]
        t = cpu()
        fn(part)
        times.append((cpu() - t) / len(part))
    return statistics.median(times)


def bench_arm(name: str, n: int, chunk: int, tmp: Path) -> dict:
    robot, frame, lock = ARMS[name]
    ik = IK(robot, frame, lock=lock)
    ik.prepare()
    cf = ik.closed_form
    out: dict = {"arm": name, "family": cf.family.name if cf else None, "poses": n}
    qs = random_qs(ik, n, seed=1)
    P = poses_of(ik, qs)
    ik.solve_array(P[:2])  # kernels loaded
    # single poses, after loading: one call per pose (the median of 21 such calls)
    for key, cert in (("kinbox_single_array_us", True), ("kinbox_single_interval_us", False)):
        ts = []
        for k in range(2, 23):
            t = cpu()
            ik.solve_array(P[k : k + 1], certify=cert)
            ts.append(cpu() - t)
        out[key] = statistics.median(ts) * 1e6
    ts = []
    for k in range(2, 23):
        t = cpu()
        res = ik.solve(P[k])
        ts.append(cpu() - t)
    out["kinbox_single_result_us"] = statistics.median(ts) * 1e6
    out["single_method"] = res.stats.get("method")
    ans = ik.solve_array(P)
    out["closed_form_share"] = float(np.mean([m == "closed-form" for m in ans.method]))
    out["roots_per_pose"] = float(np.mean(ans.count))
    try:
        rob = eaik_robot(name, ik, tmp)
    except Exception as e:  # noqa: BLE001 - a reference that cannot model this arm
        rob = None
        out["eaik_error"] = f"{type(e).__name__}: {e}"
    Ts = [homogeneous(p) for p in P]

    def run_eaik(part):
        for T in part:
            rob.IK(T)

    # kinbox's certified batch and EAIK's repeated call chunk by chunk, in turn, so that a
    # change of the machine's load reaches both (the ratio is the target)
    kin_t, eaik_t = [], []
    for s in range(0, n, chunk):
        t = cpu()
        ik.solve_array(P[s : s + chunk])
        kin_t.append((cpu() - t) / len(P[s : s + chunk]))
        if rob is not None:
            t = cpu()
            run_eaik(Ts[s : s + chunk])
            eaik_t.append((cpu() - t) / len(P[s : s + chunk]))
    out["kinbox_batch_us"] = statistics.median(kin_t) * 1e6
    out["kinbox_batch_interval_us"] = per_pose_median(lambda part: ik.solve_array(part, certify=False), P, chunk) * 1e6
    out["kinbox_batch_system_us"] = per_pose_median(lambda part: ik.solve_array(part, certify="system"), P[:2000], chunk) * 1e6
    # the same configurations (as sets, modulo 2 pi) with either certificate; where one of them
    # gives up on a root next to a singularity the branch and prune answers that pose
    sys_ans = ik.solve_array(P[:2000], certify="system")
    m = min(2000, n)
    out["same_sets_as_system"] = bool(all(_same_set(sys_ans.solutions(k), ans.solutions(k)) for k in range(m)))
    out["poses_compared_with_system"] = m
    out["poses_path_differs_from_system"] = sum(sys_ans.method[k] != ans.method[k] for k in range(m))
    log(f"{name}: kinbox batch {out['kinbox_batch_us']:.1f} us/pose")
    if rob is not None:
        # EAIK's first call: on a robot built afresh, the median over 7 such robots (one call
        # is too short to time once on a shared machine)
        firsts = []
        for k in range(7):
            fresh = eaik_robot(name, ik, tmp)
            t = cpu()
            fresh.IK(Ts[k])
            firsts.append(cpu() - t)
        out["eaik_first_us"] = statistics.median(firsts) * 1e6
        out["eaik_repeated_us"] = statistics.median(eaik_t) * 1e6
        out["eaik_roots_per_pose"] = float(np.mean([int(np.sum(~np.asarray(rob.IK(T).is_LS, dtype=bool))) for T in Ts[:200]]))
    geo, R0 = ikgeo_robot(name, ik)
    if geo is not None:
        Rt = [(pin.XYZQUATToSE3(p).rotation @ R0.T, pin.XYZQUATToSE3(p).translation) for p in P]
        t = cpu()
        geo.get_ik(*Rt[0])
        out["ikgeo_first_us"] = (cpu() - t) * 1e6
        out["ikgeo_roots_per_pose"] = float(np.mean([sum(not ls for _, ls in geo.get_ik(R, tt)) for R, tt in Rt[:200]]))

        def run_geo(part):
            for R, tt in part:
                geo.get_ik(R, tt)

        out["ikgeo_repeated_us"] = per_pose_median(run_geo, Rt, chunk) * 1e6
    if "eaik_repeated_us" in out:
        out["batch_ratio_eaik"] = out["kinbox_batch_us"] / out["eaik_repeated_us"]
        out["batch_interval_ratio_eaik"] = out["kinbox_batch_interval_us"] / out["eaik_repeated_us"]
        out["batch_system_ratio_eaik"] = out["kinbox_batch_system_us"] / out["eaik_repeated_us"]
        out["single_ratio_eaik"] = out["kinbox_single_array_us"] / out["eaik_first_us"]
        out["single_interval_ratio_eaik"] = out["kinbox_single_interval_us"] / out["eaik_first_us"]
        out["single_result_ratio_eaik"] = out["kinbox_single_result_us"] / out["eaik_first_us"]
    return out


NEAR = {
    "generic": [0.3, -1.2, 1.5, -0.8, 1.2, 0.4],
    "wrist 1e-7": [0.3, -1.2, 1.5, -0.8, 1e-7, 0.4],
    "wrist 1e-9": [0.3, -1.2, 1.5, -0.8, 1e-9, 0.4],
    "elbow 1e-6": [0.3, -1.2, 1e-6, -0.8, 1.2, 0.4],
    "elbow 1e-7": [0.3, -1.2, 1e-7, -0.8, 1.2, 0.4],
    "all zero": [0.0] * 6,
}


def bench_near() -> list[dict]:
    ik = IK("ur5", "tool0")
    ik.prepare()
    rob = eaik_robot("UR5", ik, Path("."))
    rows = []
    for label, q in NEAR.items():
        pose = ik.pose_at(q)
        ik.solve(pose)
        ts: list[float] = []
        while len(ts) < 7 and sum(ts) < 0.5:  # the median of a few calls where they are short
            t = cpu()
            res = ik.solve(pose)
            ts.append(cpu() - t)
        dt = statistics.median(ts)
        whole = None
        if res.stats.get("method") != "closed-form":  # the branch and prune of the whole domain, for comparison
            t = cpu()
            ik.solve(pose, closed_form=False)
            whole = cpu() - t
        e = rob.IK(pose.homogeneous)
        rows.append(
            {
                "pose": label,
                "method": res.stats.get("method"),
                "complete": res.complete,
                "roots": len(res.solutions),
                "certified": sum(s.certified for s in res.solutions),
                "flagged_singular": sum(s.singular for s in res.solutions),
                "curves": len(res.curves),
                "kinbox_ms": dt * 1e3,
                "search_boxes": int(res.stats.get("boxes", 0)),
                "enclosures": int(sum(res.stats.get("searched", {}).values())),
                "whole_domain_ms": None if whole is None else whole * 1e3,
                "eaik_roots": int(np.sum(~np.asarray(e.is_LS, dtype=bool))),  # not least-squares approximations
            }
        )
        log(f"near {label}: {rows[-1]}")
    g = rows[0]["kinbox_ms"]
    for r in rows:
        r["ratio_generic"] = r["kinbox_ms"] / g
        r["whole_domain_ratio_generic"] = None if r["whole_domain_ms"] is None else r["whole_domain_ms"] / g
    return rows


def near_path(r: dict) -> str:
    """The path of a near-singular row: the branch and prune searches the closed form's
    enclosures (``kinbox.search.cf_fallback``) where it can."""
    return f"{r['method']} in {r['enclosures']} closed-form boxes" if r.get("enclosures") else str(r["method"])


def table(arms: list[dict], near: list[dict]) -> str:
    def f(v, fmt="{:.1f}"):
        return "—" if v is None else fmt.format(v)

    lines = [
        "| arm | family | roots per pose: kinbox (within limits) / EAIK (no limits) | kinbox batch, Krawczyk in the joints (µs/pose) "
        "| kinbox batch, Krawczyk on the system | kinbox batch, interval proof | EAIK repeated | ik-geo repeated "
        "| batch ratio to EAIK (joints / system / interval) "
        "| kinbox single pose: Krawczyk / interval / Result | EAIK first call | single ratio to EAIK (Krawczyk / interval / Result) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for a in arms:
        lines.append(
            f"| {a['arm']} | {a['family']} | {f(a['roots_per_pose'], '{:.2f}')} / {f(a.get('eaik_roots_per_pose'), '{:.2f}')} "
            f"| {f(a['kinbox_batch_us'])} | {f(a['kinbox_batch_system_us'])} | {f(a['kinbox_batch_interval_us'])} | "
            f"{f(a.get('eaik_repeated_us'))} | {f(a.get('ikgeo_repeated_us'))} | "
            f"{f(a.get('batch_ratio_eaik'), '{:.1f}x')} / {f(a.get('batch_system_ratio_eaik'), '{:.1f}x')} / "
            f"{f(a.get('batch_interval_ratio_eaik'), '{:.1f}x')} | "
            f"{f(a['kinbox_single_array_us'], '{:.0f}')} / {f(a['kinbox_single_interval_us'], '{:.0f}')} / "
            f"{f(a['kinbox_single_result_us'], '{:.0f}')} | {f(a.get('eaik_first_us'))} | "
            f"{f(a.get('single_ratio_eaik'), '{:.1f}x')} / {f(a.get('single_interval_ratio_eaik'), '{:.1f}x')} / "
            f"{f(a.get('single_result_ratio_eaik'), '{:.0f}x')} |"
        )
    lines += [
        "",
        "| UR5 pose | kinbox path | complete | roots (certified, flagged singular) | curves | kinbox ms | x generic "
        "| search boxes | whole domain searched: ms, x generic | EAIK roots |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in near:
        whole = "—" if r["whole_domain_ms"] is None else f"{r['whole_domain_ms']:.1f}, {r['whole_domain_ratio_generic']:.0f}x"
        lines.append(
            f"| {r['pose']} | {near_path(r)} | {r['complete']} | {r['roots']} ({r['certified']}, {r['flagged_singular']}) "
            f"| {r['curves']} | "
            f"{r['kinbox_ms']:.1f} | {r['ratio_generic']:.0f}x | {r['search_boxes']} | {whole} | {r['eaik_roots']} |"
        )
    return "\n".join(lines)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--batch", type=int, default=10_000, help="poses per arm (default 10000)")
    ap.add_argument("--chunk", type=int, default=500, help="poses per timed chunk")
    ap.add_argument("--print", action="store_true", help="print instead of writing the files")
    ap.add_argument("--near", action="store_true", help="the near-singular poses alone (the arms' rows kept from the last run)")
    a = ap.parse_args()
    calibration = report.calibrate()
    log(f"closed_form: machine {json.dumps(report.machine())}; calibration: 1e7 additions in {calibration:.3f} s CPU")
    kinbox.pipeline.load_kernels()
    import tempfile

    last = ROOT / "benchmarks" / "results" / "closed_form.json"
    if a.near:
        arms = json.loads(last.read_text())["arms"]
    else:
        with tempfile.TemporaryDirectory() as tmp:
            arms = [bench_arm(name, a.batch, a.chunk, Path(tmp)) for name in ARMS]
    near = bench_near()
    versions = {}
    for mod in ("eaik", "ik_geo"):
        try:
            from importlib.metadata import version

            versions[mod] = version(mod.replace("_", "-"))
        except Exception:  # noqa: BLE001
            versions[mod] = None
    out = {"arms": arms, "near_singular": near, "versions": versions}
    md = table(arms, near)
    if a.print:
        print(json.dumps(out, indent=1))
        print(md)
        return 0
    res = ROOT / "benchmarks" / "results"
    res.mkdir(exist_ok=True)
    (res / "closed_form.json").write_text(json.dumps(out, indent=1) + "\n")
    doc = ROOT / "docs" / "closed-form.md"
    text = doc.read_text()
    a0, a1 = text.index("<!-- table -->"), text.index("<!-- /table -->")
    doc.write_text(text[: a0 + len("<!-- table -->")] + "\n" + md + "\n" + text[a1:])
    mode = f"{a.batch} poses per arm"
    if not a.near:
        report.record("closed-form", arms, calibration=calibration, mode=mode)
    report.record("closed-form-singular", near, calibration=calibration, mode="one IK.solve per pose" if a.near else mode)
    log(f"wrote {res / 'closed_form.json'}, {doc}, {report.PAGE} and {report.RAW}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
