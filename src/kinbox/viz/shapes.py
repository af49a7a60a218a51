"""Simple shapes for mechanisms without meshes (the mechanisms of ``robots/``, MJCF, models given
in code): a cylinder per link segment, a short cylinder along each revolute axis, spheres at
attachment points, a closed outline (a plate) for bodies with three or more attachment points,
and for every ``distance`` closure (a leg) and prismatic joint a :class:`Segment`: a cylinder
between two points of two bodies, placed again for each configuration shown.

What a joint shows follows from its pairs (:func:`~kinbox.formulation.pairs.joint_parts`) and
their families, not from a list of joint types: a hinge for the last part of a joint when its
family is a rotation about the part's axis and nothing else (in the joint's frame) and for the first part of a joint of
several (in the parent's frame, where its axis stays), a slider for a joint that is one
translation along an axis."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..errors import FormulationError
from ..formulation.pairs import family, joint_parts

#: colours (RGBA) of the simple shapes
BASE_COLOR = np.array([0.30, 0.30, 0.33, 1.0])
LINK_COLOR = np.array([0.93, 0.56, 0.15, 1.0])
JOINT_COLOR = np.array([0.25, 0.25, 0.28, 1.0])
LEG_COLOR = np.array([0.22, 0.74, 0.33, 1.0])
GOAL_COLOR = np.array([0.90, 0.15, 0.15, 1.0])


@dataclass
class Segment:
    """A cylinder (geometry ``gid``) between ``joint_a * point_a`` and ``joint_b * point_b``."""

    gid: int
    joint_a: int
    point_a: np.ndarray
    joint_b: int
    point_b: np.ndarray


def cylinder_pose(a: np.ndarray, b: np.ndarray) -> pin.SE3:
    """Pose of a cylinder (axis z, centred) whose axis runs from ``a`` to ``b``."""
    d = b - a
    n = float(np.linalg.norm(d))
    R = np.eye(3)
    if n > 1e-12:
        R = pin.Quaternion.FromTwoVectors(np.array([0.0, 0.0, 1.0]), d / n).toRotationMatrix()
    return pin.SE3(R, 0.5 * (a + b))


def _parts(j, placement: pin.SE3) -> list:
    """The pairs of a joint, in sequence (none for types kinbox does not formulate)."""
    try:
        return joint_parts(j, "", placement)
    except FormulationError:
        return []


def _dedup(points: list[np.ndarray], tol: float) -> list[np.ndarray]:
    out: list[np.ndarray] = []
    for p in points:
        if all(np.linalg.norm(p - o) > tol for o in out):
            out.append(p)
    return out


def outline(points: Sequence[np.ndarray]) -> list[tuple[int, int]]:
    """Edges to draw between the attachment points of one body.

    Two points: a segment; collinear points: consecutive segments along the line; otherwise
    the closed convex outline in the best-fit plane (a plate; ``scipy.spatial.ConvexHull``).
    """
    from scipy.spatial import ConvexHull, QhullError

    n = len(points)
    if n < 2:
        return []
    P = np.array(points)
    c = P.mean(axis=0)
    _, s, Vt = np.linalg.svd(P - c)
    if n == 2 or s[1] <= 1e-6 * max(s[0], 1e-12):
        t = (P - c) @ Vt[0]
        o = np.argsort(t)
        return [(int(o[i]), int(o[i + 1])) for i in range(n - 1)]
    try:
        hull = [int(i) for i in ConvexHull((P - c) @ Vt[:2].T).vertices]  # counter-clockwise in 2-D
    except QhullError:  # pragma: no cover - not collinear by the test above
        return []
    return [(hull[i], hull[(i + 1) % len(hull)]) for i in range(len(hull))]


def simple_model(mech, qs: Sequence[np.ndarray]) -> tuple[pin.GeometryModel, list[Segment]]:
    """Cylinders and spheres for a mechanism without meshes (see the module docstring).

    Sizes follow the mechanism's extent over the configurations ``qs`` (neutral if empty).
    """
    import coal

    model = mech.model
    data = model.createData()
    pts = []
    for q in (list(qs) or [pin.neutral(model)])[:200]:
        pin.framesForwardKinematics(model, data, q)
        pts += [M.translation for M in data.oMi] + [M.translation for M in data.oMf]
    extent = max(float(np.max(np.ptp(np.array(pts), axis=0))), 1e-3)
    r = 0.014 * extent
    tol = 1e-6 * extent

    geom = pin.GeometryModel()
    segments: list[Segment] = []

    def add(parent: int, placement: pin.SE3, shape, color: np.ndarray, what: str) -> int:
        go = pin.GeometryObject(f"{what}_{geom.ngeoms + 1}", parent, placement, shape)
        go.meshColor = np.array(color, dtype=float)
        return geom.addGeometryObject(go)

    # attachment points of every body, in the body's joint frame
    attach: dict[int, list[np.ndarray]] = {j: [] for j in range(model.njoints)}
    for j in range(1, model.njoints):
        if model.joints[j].nv == 1:
            attach[j].append(np.zeros(3))
            attach[model.parents[j]].append(np.array(model.jointPlacements[j].translation))
    for f in model.frames:
        if f.type in (pin.FrameType.OP_FRAME, pin.FrameType.FIXED_JOINT) and f.name != "universe":
            if f.parentJoint == 0 and f.type == pin.FrameType.FIXED_JOINT:
                continue  # URDF base links: nothing to draw
            attach[int(f.parentJoint)].append(np.array(f.placement.translation))
    for c in mech.closures:
        if c.name == "goal":
            continue
        attach[c.joint_a].append(np.array(c.placement_a.translation))
        attach[c.joint_b].append(np.array(c.placement_b.translation))

    for j in range(model.njoints):
        P = _dedup(attach[j], tol)
        color = BASE_COLOR if j == 0 else LINK_COLOR
        for a, b in outline(P):
            L = float(np.linalg.norm(P[b] - P[a]))
            if L > tol:
                add(j, cylinder_pose(P[a], P[b]), coal.Cylinder(r, L), color, "link")
        for p in P:
            add(j, pin.SE3(np.eye(3), p), coal.Sphere(1.3 * r), color, "point")
        if j > 0:
            parts = _parts(model.joints[j], model.jointPlacements[j])
            for k, part in enumerate(parts):
                fam = family(part.kind)
                if fam.rotation == "rev" and fam.translation == "none" and part.axis is not None and k in (0, len(parts) - 1):
                    # a hinge: a short cylinder along the axis, where the axis stays put
                    if k == len(parts) - 1:
                        at, c, axis = j, np.zeros(3), part.axis
                    else:
                        at, c, axis = model.parents[j], np.array(part.placement.translation), part.placement.rotation @ part.axis
                    add(at, cylinder_pose(c - 2.5 * r * axis, c + 2.5 * r * axis), coal.Cylinder(1.9 * r, 5 * r), JOINT_COLOR, "hinge")
                elif len(parts) == 1 and fam.rotation == "const" and fam.translation == "local" and part.axis is not None:
                    gid = add(0, pin.SE3.Identity(), coal.Cylinder(0.8 * r, 1.0), LEG_COLOR, "slider")
                    segments.append(Segment(gid, model.parents[j], np.array(model.jointPlacements[j].translation), j, np.zeros(3)))
    for c in mech.closures:
        if c.kind == "distance":
            gid = add(0, pin.SE3.Identity(), coal.Cylinder(0.7 * r, 1.0), LEG_COLOR, c.name or "leg")
            segments.append(Segment(gid, c.joint_a, np.array(c.placement_a.translation), c.joint_b, np.array(c.placement_b.translation)))
        elif c.name == "goal":  # an IK goal: a red ball at the target
            add(c.joint_b, pin.SE3(np.eye(3), np.array(c.placement_b.translation)), coal.Sphere(2 * r), GOAL_COLOR, "goal")
    return geom, segments
