"""What a mechanism is made of, for ``kinbox info``: its joints (type, limits), frames (the
names ``--frame`` and ``--base`` take) and loop closures."""

from __future__ import annotations

import math
import re

import numpy as np

from .mechanism import Mechanism

_AXES = {"X": "x", "Y": "y", "Z": "z"}


def joint_kind(jmodel) -> str:
    """A readable joint type: ``revolute z``, ``continuous x``, ``prismatic y``, ``free-flyer``, ..."""
    short = jmodel.shortname().removeprefix("JointModel")
    if short.startswith("RUB") and short[3:] in _AXES:
        return f"continuous {_AXES[short[3:]]}"
    if short.startswith("R") and short[1:] in _AXES:
        return f"revolute {_AXES[short[1:]]}"
    if short.startswith("P") and short[1:] in _AXES:
        return f"prismatic {_AXES[short[1:]]}"
    named = {
        "RevoluteUnaligned": "revolute",
        "RevoluteUnboundedUnaligned": "continuous",
        "PrismaticUnaligned": "prismatic",
        "FreeFlyer": "free-flyer",
        "Planar": "planar",
        "Spherical": "spherical",
        "SphericalZYX": "spherical",
        "Translation": "translation",
        "Composite": "composite",
        "Mimic": "mimic",
    }
    # any other type (one a pair module added, or one kinbox does not formulate) by Pinocchio's
    # name in words: Universal -> "universal", HelicalUnaligned -> "helical unaligned"
    return named.get(short, re.sub(r"(?<=[a-z])(?=[A-Z])", " ", short).lower())


def _plain(v: float) -> float | None:
    """A limit for JSON: None for an infinite one."""
    return float(v) if math.isfinite(v) else None


def describe(mech: Mechanism) -> dict:
    """Joints, frames and closures of ``mech`` as a JSON-ready dict."""
    model = mech.model
    joints = []
    for jid in range(1, model.njoints):
        j = model.joints[jid]
        lo = np.asarray(model.lowerPositionLimit[j.idx_q : j.idx_q + j.nq], dtype=float)
        hi = np.asarray(model.upperPositionLimit[j.idx_q : j.idx_q + j.nq], dtype=float)
        kind = joint_kind(j)
        limits = None
        if j.nq == 1 and j.nv == 1:
            limits = [_plain(lo[0]), _plain(hi[0])]
        name = model.names[jid]
        joints.append(
            {
                "name": name,
                "type": kind,
                "nq": int(j.nq),
                "nv": int(j.nv),
                "limits": limits,
                "parent": model.names[model.parents[jid]],
                "locked": [float(v) for v in mech.locked[name]] if name in mech.locked else None,
            }
        )
    frames = []
    depth = {0: 0}
    for jid in range(1, model.njoints):
        depth[jid] = depth[int(model.parents[jid])] + 1
    for f in model.frames:
        if f.name == "universe":
            continue
        jid = int(f.parentJoint)
        frames.append(
            {"name": f.name, "type": str(f.type).rsplit(".", 1)[-1].lower(), "joint": model.names[jid], "joints_from_world": depth[jid]}
        )
    closures = [
        {
            "name": c.name or f"{c.kind}{k}",
            "kind": c.kind,
            "joint_a": model.names[c.joint_a],
            "joint_b": model.names[c.joint_b],
            **({"length": c.length} if c.kind == "distance" else {}),
        }
        for k, c in enumerate(mech.closures)
    ]
    return {"name": mech.name, "nq": int(model.nq), "nv": int(model.nv), "joints": joints, "frames": frames, "closures": closures}


def printable(text: str) -> str:
    """``text`` with control and format characters (terminal escapes, newlines, bidi overrides)
    written as Python escapes, so that a name cannot move the cursor or recolour a terminal
    (tests/cli/test_hostile.py::test_control_characters_escaped)."""
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def _printable(v):
    if isinstance(v, str):
        return printable(v)
    if isinstance(v, dict):
        return {k: _printable(x) for k, x in v.items()}
    if isinstance(v, list):
        return [_printable(x) for x in v]
    return v


def info_table(d: dict) -> str:
    """:func:`describe`'s dict as text (names made printable)."""
    d = _printable(d)
    lines = [
        f"{d['name']}: {len(d['joints'])} joints ({d['nv']} degrees of freedom, nq = {d['nq']}), "
        f"{len(d['frames'])} frames, {len(d['closures'])} loop closures"
    ]
    w = max([len(j["name"]) for j in d["joints"]] + [5])
    lines.append("joints (--lock / --set JOINT=VALUE; joints of --from-q in this order):")
    for j in d["joints"]:
        lim = "-"
        if j["limits"] is not None:
            lo, hi = j["limits"]
            lim = f"[{'-inf' if lo is None else f'{lo:.4g}'}, {'inf' if hi is None else f'{hi:.4g}'}]"
        elif j["type"].startswith("continuous"):
            lim = "unlimited"
        extra = f"  locked at {j['locked']}" if j["locked"] is not None else ""
        lines.append(f"  {j['name']:<{w}}  {j['type']:<13} {lim:<20} parent {j['parent']}{extra}")
    wf = max([len(f["name"]) for f in d["frames"]] + [5])
    lines.append("frames (--frame / --base; a frame with no joint between it and the world cannot be placed):")
    for f in d["frames"]:
        k = f["joints_from_world"]
        lines.append(f"  {f['name']:<{wf}}  {f['type']:<11} on {f['joint']} ({k} joint{'' if k == 1 else 's'} from the world)")
    if d["closures"]:
        lines.append("loop closures:")
        for c in d["closures"]:
            extra = f", length {c['length']:.6g}" if "length" in c else ""
            lines.append(f"  {c['name']}: {c['kind']} between {c['joint_a']} and {c['joint_b']}{extra}")
    return "\n".join(lines)
