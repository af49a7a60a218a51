"""CuikSuite's example suite side by side with kinbox: CPU of the whole process, boxes, peak
memory, solutions, certified.

    python benchmarks/cuiksuite.py --cuik-bin DIR [--examples DIR] [--runs 2] [--only NAME ...]
                                   [--json out.json] [--markdown out.md]

``--cuik-bin`` (or the environment variable ``CUIKSUITE_BIN``) is the folder holding CuikSuite's
``cuikequations`` and ``cuik`` (built from the public CuikSuite sources); ``--examples`` (or
``CUIKSUITE_EXAMPLES``, default ``CUIK_BIN/../examples``) its ``examples`` folder. Each example
is copied to a temporary folder (CuikSuite writes its ``.cuik``, ``.sol`` and ``.state`` files
beside the world), given ``REPRESENTATION = LINKS`` where its ``.param`` sets none (the
default, JOINTS, stops with "SolveCuikSystem only operates on scalar systems"), then
``cuikequations NAME`` and ``cuik NAME`` run; kinbox runs as ``python -m kinbox.cli solve NAME
--json`` in a fresh process. Runs alternate (CuikSuite, kinbox, CuikSuite, kinbox, ...) so
both see the same load; the table gives the mean of the runs. CPU is user + system time of the
whole process (``os.wait4``: imports, kernel loading, model, answer included; for CuikSuite
both programs), peak memory is its ``ru_maxrss`` (on Linux at least the memory of this
script when it starts the process, about 10 MB: the script loads nothing heavy until every run is done).

The solution sets are compared where both describe the same links: for the planar examples,
the angle of every link of CuikSuite's ``.sol`` boxes (``atan2(u_z, u_x)``, the plane is its
x-z plane) against the same link's frame in kinbox's answer (Pinocchio forward kinematics): a
CuikSuite box that holds no kinbox solution is listed as ``cuik_only``, a kinbox solution in
no CuikSuite box as ``kinbox_only`` (CuikSuite seeds its generator from the clock: its boxes
vary run to run, and its shipped parameters can put two nearby solutions in one box).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path


@dataclass
class Example:
    name: str
    cuik: str  # path of the world file without extension, relative to examples/
    kinbox: list[str]  # arguments of `kinbox solve`
    planar: bool = False
    links: dict[str, str] = field(default_factory=dict)  # CuikSuite link -> kinbox link frame
    note: str = ""
    #: a mechanism file written for the run (its path replaces ``kinbox[0]``), for an example
    #: kinbox has no built-in file of
    spec: dict | str | None = None
    #: the kinbox command: ``solve`` (a mechanism's configurations) or ``ik`` (an arm's IK)
    command: str = "solve"


def _general_6r_rows() -> list:
    """The DH rows of kinbox's ``general-6r`` (the table of ``Serial6R.world``)."""
    path = Path(__file__).resolve().parents[1] / "src" / "kinbox" / "robots" / "general-6r.json"
    return json.loads(path.read_text())["dh"]


def rx60_urdf() -> str:
    """The RX60 of ``Serial6RRX60.world`` as a URDF, link frames as in the world file.

    A revolute joint of a world file names a point and a second point of the axis in the
    parent link and in the child link (here every parent axis is the parent's z through its
    origin; the child's runs from ``c`` along ``b``): the child's frame is the parent's turned
    by ``R0`` (``R0 b = z``) and by the joint angle about ``b``, shifted by ``-c``. A URDF joint
    turns about an axis through the child's origin, so the joint's child is a frame at ``c``
    and the link hangs from it by a fixed joint."""
    a2, d3, d4 = 0.29, 0.049, 0.31  # the world file's constants (metres)
    rpy = {"-y": (-math.pi / 2, 0.0, 0.0), "+y": (math.pi / 2, 0.0, 0.0), "+z": (0.0, 0.0, 0.0)}
    axis = {"-y": "0 -1 0", "+y": "0 1 0", "+z": "0 0 1"}
    joints = [  # child, its point c on the axis, its axis direction b
        ("link1", (0, 0, 0), "-y"),
        ("link2", (-a2, 0, 0), "+z"),
        ("link3", (0, d3, 0), "+y"),
        ("link4", (0, d4, 0), "-y"),
        ("link5", (0, 0, 0), "-y"),
        ("EndEfector", (0, 0, 0), "+z"),
    ]
    out = ['<robot name="rx60">', '<link name="base"/>']
    parent = "base"
    for k, (child, c, b) in enumerate(joints, 1):
        r = " ".join(repr(v) for v in rpy[b])
        out += [
            f'<link name="{child}_axis"/>',
            f'<link name="{child}"/>',
            f'<joint name="joint{k}" type="revolute"><parent link="{parent}"/><child link="{child}_axis"/>'
            f'<origin xyz="0 0 0" rpy="{r}"/><axis xyz="{axis[b]}"/>'
            f'<limit lower="{-math.pi!r}" upper="{math.pi!r}" effort="1" velocity="1"/></joint>',
            f'<joint name="{child}_offset" type="fixed"><parent link="{child}_axis"/><child link="{child}"/>'
            f'<origin xyz="{-c[0]!r} {-c[1]!r} {-c[2]!r}" rpy="0 0 0"/></joint>',
        ]
        parent = child
    return "\n".join([*out, "</robot>"]) + "\n"


SUITE = [
    Example("general 6R (Serial6R)", "Serial6R/Serial6R", ["general-6r"]),
    Example(
        "general 6R as arm IK (Serial6R)",
        "Serial6R/Serial6R",
        # the loop prod Rx(alpha) Tx(a) Rz(theta) Tz(d) = I is the IK of the arm of the same
        # rows with its tool at the base frame: kinbox answers it by its eigenvalue path
        ["general-6r-arm.json", "--frame", "tool", "--pose", "0", "0", "0", "0", "0", "0", "1"],
        spec={"kind": "dh-arm", "dh": _general_6r_rows()},
        command="ik",
    ),
    Example(
        "RX60 IK (Serial6RRX60)",
        "Serial6R/Serial6RRX60",
        # the world's closure: the end effector fixed at Txyz(0.25, 0.15, 0.5) of the base
        ["rx60.urdf", "--frame", "EndEfector", "--pose", "0.25", "0.15", "0.5", "0", "0", "0", "1"],
        spec=rx60_urdf(),
        command="ik",
        links={f"link{k}": f"link{k}" for k in range(1, 6)} | {"EndEfector": "EndEfector"},
    ),
    Example("Dietmeier 6-6 platform", "ParallelPlatform/Dietmeier", ["dietmeier"]),
    Example(
        "Bricard (Serial6RBricard, curve)",
        "Serial6R/Serial6RBricard",
        ["serial6r-bricard.json"],
        # its DH table: a = 1, d = 0, twists alternately pi/2 and -pi/2 (kinbox's dh-loop reads
        # the same convention as the Serial6R world, whose table is kinbox's general-6r)
        spec={"kind": "dh-loop", "dh": [[1.0, 0.0, (-1) ** k * math.pi / 2] for k in range(6)]},
    ),
    Example(
        "FourBars rhombus (curve)",
        "FourBars/FourBars",
        ["rhombus"],
        planar=True,
        note="a curve: CuikSuite and kinbox both cover it with boxes of size SIGMA = 0.05",
        links={n: n for n in ("link2", "link3", "link4")},
    ),
    Example(
        "Double Butterfly, rigid",
        "DoubleButterfly/DoubleButterfly_fix",
        ["double-butterfly"],
        planar=True,
        links={n: n for n in ("t2", "t3", "t4", "b1", "b2", "b3", "b4")},
    ),
    Example(
        "Watt-Baranov truss",
        "Watt-Baranov/Watt-Baranov",
        ["watt-baranov"],
        planar=True,
        links={f"link{k}": f"link{k}" for k in range(1, 7)},
    ),
]

#: a solution box of a .sol file: ``N (err:E tm:T): <S> { n var[lo,hi] ... }`` (the type tag
#: ``<S>`` is left out on some boxes)
_SOL = re.compile(r"^\s*\d+\s+\(err:([^\s)]*)[^)]*\):\s*(?:<(\w)>)?\s*\{\s*\d+\s*(.*)\}\s*$")
_VAR = re.compile(r"(\w+)\[([-+0-9.eE]+),([-+0-9.eE]+)\]")


def run_measured(cmd: list[str], cwd: str | None = None, env: dict | None = None, timeout: float = 3600.0) -> tuple[dict, str]:
    """Run ``cmd``; (``{"cpu": user + system seconds, "maxrss_mb": peak memory, "wall", "rc"}``,
    stdout). CPU and memory are the process's own (``os.wait4``)."""
    t0 = time.perf_counter()
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        p = subprocess.Popen(cmd, cwd=cwd, env=env, stdout=out, stderr=err)
        deadline = t0 + timeout
        while True:
            pid, status, ru = os.wait4(p.pid, os.WNOHANG)
            if pid:
                break
            if time.perf_counter() > deadline:
                p.kill()
                pid, status, ru = os.wait4(p.pid, 0)
                break
            time.sleep(0.01)
        p.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        text = out.read().decode("utf-8", "replace")
        errtext = err.read().decode("utf-8", "replace")
    m = {
        "cpu": ru.ru_utime + ru.ru_stime,
        "maxrss_mb": ru.ru_maxrss / 1024.0,
        "wall": time.perf_counter() - t0,
        "rc": p.returncode,
    }
    if p.returncode not in (0, 4):
        m["stderr"] = errtext[-500:]
    return m, text


def parse_sol(path: Path) -> dict:
    """Solution boxes (type letter, {variable: (lo, hi)}) and statistics of a CuikSuite .sol file."""
    boxes = []
    errs: list[float] = []  # CuikSuite's error at each box's centre ("err:")
    stats: dict = {}
    for line in path.read_text(errors="replace").splitlines():
        m = _SOL.match(line)
        if m:
            box = {v: (float(a), float(b)) for v, a, b in _VAR.findall(m.group(3))}
            boxes.append((m.group(2) or "-", box))
            errs.append(float(m.group(1)) if re.fullmatch(r"[-+0-9.eE]+", m.group(1)) else math.nan)
            continue
        for key, pat in (
            ("boxes", r"N processed boxes\s*:\s*(\d+)"),
            ("solution_boxes", r"N solution boxes\s*:\s*(\d+)"),
            ("empty_boxes", r"N empty boxes\s*:\s*(\d+)"),
            ("user_time", r"User time in process:\s*([0-9.]+)"),
        ):
            mm = re.search(pat, line)
            if mm:
                stats[key] = float(mm.group(1))
    stats["types"] = {t: sum(1 for b in boxes if b[0] == t) for t in sorted({b[0] for b in boxes})}
    return {"boxes": boxes, "errs": errs, "stats": stats}


def run_cuik(ex: Example, bin_dir: Path, examples: Path, work: Path) -> tuple[dict, dict]:
    src = examples / ex.cuik
    dst = work / Path(ex.cuik).parent.name
    if dst.exists():
        shutil.rmtree(dst)
    shutil.copytree(src.parent, dst)
    base = dst / src.name
    param = base.with_suffix(".param")
    text = param.read_text(errors="replace") if param.exists() else ""
    if not re.search(r"^\s*REPRESENTATION", text, re.M):
        param.write_text(text + "\nREPRESENTATION = LINKS\n")
    for f in (base.with_suffix(".sol"), base.with_suffix(".state"), base.with_suffix(".cuik")):
        f.unlink(missing_ok=True)
    m1, _ = run_measured([str(bin_dir / "cuikequations"), str(base)], cwd=str(dst))
    m2, _ = run_measured([str(bin_dir / "cuik"), str(base)], cwd=str(dst))
    sol = parse_sol(base.with_suffix(".sol")) if base.with_suffix(".sol").exists() else {"boxes": [], "stats": {}}
    m = {"cpu": m1["cpu"] + m2["cpu"], "maxrss_mb": max(m1["maxrss_mb"], m2["maxrss_mb"]), "wall": m1["wall"] + m2["wall"], "rc": m2["rc"]}
    return m, sol


def run_kinbox(ex: Example, env: dict, work: Path, time_limit: float) -> tuple[dict, dict]:
    args = list(ex.kinbox)
    if ex.spec is not None:
        path = work / args[0]
        path.write_text(ex.spec if isinstance(ex.spec, str) else json.dumps(ex.spec))
        args[0] = str(path)
    m, out = run_measured([sys.executable, "-m", "kinbox.cli", ex.command, *args, "--json", "--time-limit", str(time_limit)], env=env)
    try:
        res = json.loads(out)
    except json.JSONDecodeError:
        res = {}
    return m, res


def compare_planar(ex: Example, sol: dict, res: dict) -> dict:
    """CuikSuite boxes against kinbox solutions, by link angles (see the module docstring)."""
    if not ex.links or not res.get("solutions"):
        return {}
    import numpy as np
    import pinocchio as pin

    import kinbox

    mech = kinbox.load(ex.kinbox[0])
    model = mech.model
    data = model.createData()
    ours = []
    for s in res["solutions"]:
        pin.framesForwardKinematics(model, data, np.asarray(s["q"], float))
        ours.append({c: _angle(data.oMf[model.getFrameId(k, pin.FrameType.OP_FRAME)].rotation) for c, k in ex.links.items()})
    theirs, theirs_err = [], []
    errs = sol.get("errs") or [math.nan] * len(sol["boxes"])
    for (_, box), err in zip(sol["boxes"], errs):
        ang = {}
        for c in ex.links:
            ux, uz = box.get(f"{c}_u_x"), box.get(f"{c}_u_z")
            if ux is None or uz is None:
                break
            ang[c] = (math.atan2(0.5 * (uz[0] + uz[1]), 0.5 * (ux[0] + ux[1])), max(ux[1] - ux[0], uz[1] - uz[0]))
        else:
            theirs.append(ang)
            theirs_err.append(err)
    tol = 1e-3

    def match(o, t):
        return all(abs(math.remainder(o[c] - t[c][0], 2 * math.pi)) <= 2 * t[c][1] + tol for c in ex.links)

    def gap(o, t):
        return max(abs(math.remainder(o[c] - t[c][0], 2 * math.pi)) for c in ex.links)

    lonely = [k for k, t in enumerate(theirs) if not any(match(o, t) for o in ours)]
    cuik_only = len(lonely)
    alone = [o for o in ours if not any(match(o, t) for t in theirs)]
    per_box = [sum(1 for o in ours if match(o, t)) for t in theirs]
    return {
        "cuik_boxes_compared": len(theirs),
        "cuik_only": cuik_only,
        "kinbox_only": len(alone),
        # how far (largest link-angle difference, radians) each kinbox-only solution is from the
        # nearest CuikSuite box, and how many CuikSuite boxes hold the same kinbox solution
        "kinbox_only_gaps": [min((gap(o, t) for t in theirs), default=math.inf) for o in alone],
        "boxes_sharing_a_solution": sum(1 for o in ours if sum(1 for t in theirs if match(o, t)) > 1),
        "boxes_per_solution_max": max(per_box, default=0),
        # each CuikSuite box without a kinbox solution: its width, CuikSuite's error at its
        # centre, and how far the nearest kinbox solution is (largest link-angle difference)
        "cuik_only_boxes": [
            {
                "width": max(a[1] for a in theirs[k].values()),
                "err": theirs_err[k],
                "gap": min((gap(o, theirs[k]) for o in ours), default=math.inf),
            }
            for k in lonely
        ],
    }


def compare_curve(ex: Example, sol: dict, res: dict) -> dict:
    """CuikSuite's boxes covering a curve against kinbox's curve components, by link angles as
    in :func:`compare_planar`: the points of every branch's polyline (kinbox's trace of the
    curve, joint values) are put through Pinocchio forward kinematics. A CuikSuite box is
    ``cuik_far`` when no polyline point lies within twice its width plus half the polyline's
    largest step (the points are that far apart along the curve); a polyline point is
    ``kinbox_far`` when it lies in no CuikSuite box widened the same way."""
    comps = [c for c in res.get("components", []) if c.get("dimension", 0) == 1]
    if not ex.links or not comps:
        return {}
    import numpy as np
    import pinocchio as pin

    import kinbox

    model = kinbox.load(ex.kinbox[0]).model
    data = model.createData()
    ids = {c: model.getFrameId(k, pin.FrameType.OP_FRAME) for c, k in ex.links.items()}
    pts, step = [], 0.0
    for comp in comps:
        for branch in comp.get("branches", []):
            prev = None
            for q in branch.get("polyline", []):
                pin.framesForwardKinematics(model, data, np.asarray(q, float))
                a = np.array([_angle(data.oMf[ids[c]].rotation) for c in ex.links])
                if prev is not None:
                    step = max(step, float(np.max(np.abs(np.remainder(a - prev + math.pi, 2 * math.pi) - math.pi))))
                prev = a
                pts.append(a)
    theirs = []
    for _, box in sol["boxes"]:
        if all(f"{c}_u_x" in box and f"{c}_u_z" in box for c in ex.links):
            ux = [box[f"{c}_u_x"] for c in ex.links]
            uz = [box[f"{c}_u_z"] for c in ex.links]
            mid = [math.atan2(0.5 * (z[0] + z[1]), 0.5 * (x[0] + x[1])) for x, z in zip(ux, uz)]
            width = max(max(x[1] - x[0], z[1] - z[0]) for x, z in zip(ux, uz))
            theirs.append((np.array(mid), width))
    if not pts or not theirs:
        return {}
    P = np.array(pts)
    C = np.array([t[0] for t in theirs])
    W = np.array([t[1] for t in theirs])
    # largest link-angle difference between every polyline point and every box centre
    D = np.max(np.abs(np.remainder(P[:, None, :] - C[None, :, :] + math.pi, 2 * math.pi) - math.pi), axis=2)
    tol = 2 * W[None, :] + 0.5 * step + 1e-3
    near = D <= tol
    return {
        "cuik_boxes_compared": len(theirs),
        "curve_points": len(pts),
        "curve_step": step,
        "cuik_far": int(np.sum(~near.any(axis=0))),
        "kinbox_far": int(np.sum(~near.any(axis=1))),
    }


def compare_frames(ex: Example, sol: dict, res: dict) -> dict:
    """CuikSuite boxes against kinbox solutions of a spatial example, by the x and y axes of
    each link's frame (``u`` and ``v`` in the ``.sol``; the link's body frame by Pinocchio
    forward kinematics in kinbox's answer): a box holds a solution when every entry lies in
    the box widened by 1e-6."""
    if not ex.links or not res.get("solutions") or not isinstance(ex.spec, str):
        return {}
    import numpy as np
    import pinocchio as pin

    import kinbox

    model = kinbox.load(ex.spec).model
    data = model.createData()
    ours = []
    for s in res["solutions"]:
        pin.framesForwardKinematics(model, data, np.asarray(s["q"], float))
        R = {c: data.oMf[model.getFrameId(k, pin.FrameType.BODY)].rotation for c, k in ex.links.items()}
        ours.append({f"{c}_{a}_{x}": float(R[c][i, col]) for c in R for a, col in (("u", 0), ("v", 1)) for i, x in enumerate("xyz")})
    theirs = [box for _, box in sol["boxes"] if all(k in box for k in ours[0])]

    def match(o, t):
        return all(t[k][0] - 1e-6 <= v <= t[k][1] + 1e-6 for k, v in o.items())

    return {
        "cuik_boxes_compared": len(theirs),
        "cuik_only": sum(1 for t in theirs if not any(match(o, t) for o in ours)),
        "kinbox_only": sum(1 for o in ours if not any(match(o, t) for t in theirs)),
    }


def compare_joint_sets(a: dict, b: dict, name: str) -> dict:
    """kinbox's solutions of one example answered two ways (the loop, the arm's IK): joint
    values compared modulo 2 pi (largest difference 1e-6)."""
    qa = [[float(v) for v in s["q"]] for s in a.get("solutions", [])]
    qb = [[float(v) for v in s["q"]] for s in b.get("solutions", [])]

    def same(p, q):
        return len(p) == len(q) and all(abs(math.remainder(x - y, 2 * math.pi)) <= 1e-6 for x, y in zip(p, q))

    return {"same_as": name, "solutions": len(qb), "other": len(qa), "matched": sum(1 for q in qb if any(same(p, q) for p in qa))}


def _angle(R) -> float:
    return math.atan2(float(R[1, 0]), float(R[0, 0]))


def summarize(rows: list[dict]) -> list[dict]:
    out = []
    for name in dict.fromkeys(r["example"] for r in rows):
        rs = [r for r in rows if r["example"] == name]
        c = [r["cuik"] for r in rs]
        k = [r["kinbox"] for r in rs]
        last = rs[-1]
        kc = statistics.mean(x["cpu"] for x in k)
        cc = statistics.mean(x["cpu"] for x in c)
        out.append(
            {
                "example": name,
                "runs": len(rs),
                "cuik_cpu": cc,
                "cuik_boxes": statistics.mean(x.get("boxes", 0) for x in c),
                "cuik_solution_boxes": statistics.mean(x.get("solution_boxes", 0) for x in c),
                "cuik_mb": max(x["maxrss_mb"] for x in c),
                "kinbox_cpu": kc,
                "kinbox_search_cpu": statistics.mean(x.get("search_cpu", 0.0) for x in k),
                "kinbox_boxes": statistics.mean(x.get("boxes", 0) for x in k),
                "kinbox_mb": max(x["maxrss_mb"] for x in k),
                "kinbox_solutions": last["kinbox"].get("solutions"),
                "kinbox_certified": last["kinbox"].get("certified"),
                "kinbox_curves": last["kinbox"].get("curves"),
                "kinbox_complete": last["kinbox"].get("complete"),
                "ratio_cpu": kc / cc if cc > 0 else None,
                "compare": last.get("compare", {}),
            }
        )
    return out


def markdown(summary: list[dict], meta: dict) -> str:
    lines = [
        f"CuikSuite ({meta['cuik']}) and kinbox ({meta['kinbox']}) on one machine ({meta['machine']}), "
        f"mean of {meta['runs']} alternated run(s); CPU is user + system time of the whole process "
        "(kinbox's search in brackets, loading the compiled kernels it calls included).",
        "",
        "| example | CuikSuite CPU | boxes | solution boxes | MB | kinbox CPU (search) | boxes | solutions (certified) | MB "
        "| kinbox / CuikSuite CPU |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for s in summary:
        sols = f"{s['kinbox_solutions']} ({s['kinbox_certified']})"
        if s["kinbox_curves"]:
            sols += f" + {s['kinbox_curves']} curve(s)"
        if not s["kinbox_complete"]:
            sols += ", incomplete"
        cmp = s["compare"]
        if cmp.get("same_as"):
            sols += f"; {cmp['matched']} of {cmp['solutions']} equal to the {cmp['other']} of {cmp['same_as']}"
        elif "cuik_far" in cmp:
            sols += f"; vs .sol: {cmp['cuik_far']} of {cmp['cuik_boxes_compared']} CuikSuite boxes off kinbox's curve, "
            sols += f"{cmp['kinbox_far']} of {cmp['curve_points']} curve points in no box"
        elif cmp:
            sols += f"; vs .sol: {cmp['cuik_only']} CuikSuite box(es) without a kinbox solution, "
            sols += f"{cmp['kinbox_only']} kinbox solution(s) in no box"
        ratio = f"{s['ratio_cpu']:.2f}x" if s["ratio_cpu"] is not None else "-"
        cuik = f"{s['cuik_cpu']:.2f} s | {s['cuik_boxes']:.0f} | {s['cuik_solution_boxes']:.0f} | {s['cuik_mb']:.0f}"
        kb = f"{s['kinbox_cpu']:.2f} s ({s['kinbox_search_cpu']:.2f} s) | {s['kinbox_boxes']:.0f} | {sols} | {s['kinbox_mb']:.0f}"
        lines.append(f"| {s['example']} | {cuik} | {kb} | {ratio} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cuik-bin", default=os.environ.get("CUIKSUITE_BIN"), help="folder of cuik and cuikequations (env CUIKSUITE_BIN)")
    ap.add_argument("--examples", default=os.environ.get("CUIKSUITE_EXAMPLES"), help="CuikSuite's examples folder (env CUIKSUITE_EXAMPLES)")
    ap.add_argument("--runs", type=int, default=2)
    ap.add_argument("--kinbox-time-limit", type=float, default=900.0, help="kinbox's --time-limit per example (seconds)")
    ap.add_argument("--only", nargs="*", help="examples whose name contains one of these words")
    ap.add_argument("--json", help="write the rows and the summary here")
    ap.add_argument("--markdown", help="write the table here")
    ap.add_argument("--no-record", action="store_true", help="leave docs/benchmarks.md alone (report.record, key cuiksuite)")
    a = ap.parse_args(argv)
    if not a.cuik_bin:
        ap.error("give --cuik-bin or set CUIKSUITE_BIN")
    bin_dir = Path(a.cuik_bin)
    examples = Path(a.examples) if a.examples else bin_dir.parent / "examples"
    for exe in ("cuik", "cuikequations"):
        if not (bin_dir / exe).is_file():
            ap.error(f"no {exe} in {bin_dir}")
    suite = [e for e in SUITE if not a.only or any(w.lower() in e.name.lower() for w in a.only)]
    env = dict(os.environ)
    src = Path(__file__).resolve().parents[1] / "src"
    env["PYTHONPATH"] = os.pathsep.join([str(src), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    # kinbox runs as installed, its modules' bytecode cached: with PYTHONDONTWRITEBYTECODE set
    # every run would compile kinbox's sources again (some 0.2 s CPU a process)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    rows = []
    last: dict[str, tuple] = {}  # compared after every run: kinbox loaded here would count in the children's peak memory
    with tempfile.TemporaryDirectory(prefix="cuik-") as tmp:
        for r in range(a.runs):
            for ex in suite:
                cm, sol = run_cuik(ex, bin_dir, examples, Path(tmp))
                cm.update({k: v for k, v in sol["stats"].items() if k != "types"}, types=sol["stats"].get("types", {}))
                km, res = run_kinbox(ex, env, Path(tmp), a.kinbox_time_limit)
                st = res.get("stats", {})
                comps = res.get("components", [])
                km.update(
                    boxes=st.get("boxes"),
                    # the kernels load at their first call, inside the search: its CPU includes
                    # their loading (load_seconds: its wall seconds, apart)
                    search_cpu=st.get("cpu_seconds", 0.0),
                    load_seconds=st.get("load_seconds", 0.0),
                    solutions=len(res.get("solutions", [])),
                    certified=sum(1 for s in res.get("solutions", []) if s.get("certified")),
                    curves=sum(1 for c in comps if c.get("dimension", 0) >= 1),
                    complete=res.get("complete"),
                )
                row = {"example": ex.name, "run": r, "cuik": cm, "kinbox": km}
                if r == a.runs - 1:
                    last[ex.name] = (ex, sol, res)
                rows.append(row)
                print(
                    f"[{r + 1}/{a.runs}] {ex.name}: CuikSuite {cm['cpu']:.2f} s {cm.get('boxes', 0):.0f} boxes; "
                    f"kinbox {km['cpu']:.2f} s {km['boxes']} boxes {km['solutions']} solutions",
                    file=sys.stderr,
                    flush=True,
                )
    for row in rows:
        if row["example"] in last and row["run"] == a.runs - 1:
            ex = last[row["example"]][0]
            if ex.planar:
                row["compare"] = compare_planar(*last[row["example"]]) or compare_curve(*last[row["example"]])
            elif isinstance(ex.spec, str):
                row["compare"] = compare_frames(*last[row["example"]])
            same = next((o for o in SUITE if o is not ex and o.cuik == ex.cuik and o.name in last), None)
            if ex.command == "ik" and same is not None:  # the same example answered as a loop
                row["compare"] = compare_joint_sets(last[same.name][2], last[ex.name][2], same.name)
    summary = summarize(rows)
    import platform

    meta = {
        "cuik": "3.1, built from the public sources",
        "kinbox": _kinbox_version(),
        "machine": f"{platform.machine()}, {os.cpu_count()} cores",
        "runs": a.runs,
    }
    table = markdown(summary, meta)
    print(table)
    if a.json:
        Path(a.json).write_text(json.dumps({"meta": meta, "summary": summary, "rows": rows}, indent=1) + "\n")
    if a.markdown:
        Path(a.markdown).write_text(table)
    if not a.no_record:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        import report

        page_rows = [{k: v for k, v in s.items() if k != "compare"} for s in summary]
        report.record("cuiksuite", page_rows, calibration=report.calibrate(), mode=f"{a.runs}-alternation")
        print(f"cuiksuite: wrote {report.PAGE.name} and {report.RAW.name}", file=sys.stderr)
    return 0


def _kinbox_version() -> str:
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, cwd=Path(__file__).parent)
        return rev.stdout.strip() or "unknown"
    except OSError:
        return "unknown"


if __name__ == "__main__":
    sys.exit(main())
