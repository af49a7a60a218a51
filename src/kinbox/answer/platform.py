"""The platform's pose in the answer of a parallel mechanism: what forward kinematics asks for.

A mechanism with a frame named ``platform`` (the Gough-Stewart, 3-RPR and delta builders
make one) gets, for each isolated solution, that frame's pose from Pinocchio forward
kinematics at the solution's ``q``: ``[x, y, z, qx, qy, qz, qw]`` in the world, and for a
planar mechanism moving in the world's xy plane also ``[x, y, phi]`` (phi the rotation about
z) (test_platforms_answer_with_the_platform_pose).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

#: the frame whose pose a parallel mechanism's answer carries
PLATFORM_FRAME = "platform"


def platform_frame(mech) -> int | None:
    """Pinocchio id of the mechanism's platform frame (one of that name, moved by a joint), or None."""
    ids = [i for i, f in enumerate(mech.model.frames) if f.name == PLATFORM_FRAME and f.parentJoint != 0]
    return ids[0] if len(ids) == 1 else None


def platform_poses(mech, qs: list[np.ndarray]) -> list[dict] | None:
    """``{"frame", "pose", ["planar"]}`` of the platform frame at each configuration, or None
    for a mechanism without one."""
    fid = platform_frame(mech)
    if fid is None:
        return None
    from ..model.planar import plane_normal

    model = mech.model
    data = model.createData()
    n = plane_normal(mech, qs[0]) if qs else None
    in_xy = n is not None and abs(abs(float(n[2])) - 1.0) < 1e-12
    out = []
    for q in qs:
        pin.framesForwardKinematics(model, data, q)
        M = data.oMf[fid]
        d: dict = {"frame": PLATFORM_FRAME, "pose": [float(v) for v in pin.SE3ToXYZQUAT(M)]}
        if in_xy:
            R = M.rotation
            d["planar"] = [float(M.translation[0]), float(M.translation[1]), math.atan2(float(R[1, 0]), float(R[0, 0]))]
        out.append(d)
    return out


def add_platform_poses(res) -> None:
    """Fill each solution's ``platform`` of a result (:class:`kinbox.answer.result.Result`)."""
    mech = res.formulated.mechanism if res.formulated is not None else None
    if mech is None or not res.solutions:
        return
    poses = platform_poses(mech, [s.q for s in res.solutions])
    if poses is None:
        return
    for s, p in zip(res.solutions, poses):
        s.platform = p


def platform_table(res) -> list[str]:
    """Lines of the table: the platform pose of each solution."""
    rows = [(k, s.platform) for k, s in enumerate(res.solutions) if getattr(s, "platform", None)]
    if not rows:
        return []
    planar = all("planar" in p for _, p in rows)
    head = "x y phi" if planar else "x y z qx qy qz qw"
    lines = [f"  platform pose (frame {PLATFORM_FRAME!r}, Pinocchio FK; {head}):"]
    for k, p in rows:
        vals = p["planar"] if planar else p["pose"]
        lines.append(f"{k + 1:3d}  " + " ".join(f"{v:10.6f}" for v in vals))
    return lines
