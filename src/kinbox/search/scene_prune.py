"""Pruning search boxes with a collision scene (``collision_free`` searches only, when asked).

A box of the search whose every configuration puts a point of the robot's collision geometry
strictly inside a solid obstacle holds no collision-free configuration: coal's collision test
finds that geometry in contact there (a vertex of a mesh inside a solid shape: the triangles
through it meet the shape). Such a box may be discarded when only free solutions are asked for.

The enclosure is interval forward kinematics over the box, built from Pinocchio's joint
placements (``model.jointPlacements``) and the search's own variables: a revolute joint about
a coordinate axis turns by the rotation whose cosine and sine are the system's ``c[joint]``,
``s[joint]`` intervals of the box; a joint without them (locked in the formulation, or off the
system) turns by the enclosure of cos and sin over its limits. Every product and sum is rounded
outward (:mod:`kinbox.interval`), and the anchor points (mesh vertices, in their joint's frame)
carry the rounding of their placement; a point counts as inside an obstacle only when its
whole enclosure is inside it by :data:`DEPTH` (box, sphere, cylinder, the cylinder of a capsule;
meshes and other shapes are never used: a surface has no inside).

Built by :func:`scene_pruner`; the search calls it on each box after the first propagation
(:meth:`kinbox.search.processor.BoxProcessor._rounds`). Tests:
tests/search/test_scene_prune.py (planted collision-free roots are never lost, and a box is
discarded only when coal finds every sampled configuration of it in contact).
"""

from __future__ import annotations

import numpy as np

from ..interval import INF, U, dot_bounds, down, mul, up
from ..interval import cos_range as _cos_range
from ..interval import sin_range as _sin_range

#: a point counts as inside an obstacle only this far (metres) from its boundary: beyond coal's
#: tolerances, so coal's collision test finds the contact
DEPTH = 1e-6
#: anchor points per mesh: its vertices extreme along these directions (joint frame)
_DIRECTIONS = np.array(
    [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1], [1, 1, 1], [-1, -1, -1], [1, -1, 1], [-1, 1, -1]],
    dtype=float,
)
_AXES = {"X": 0, "Y": 1, "Z": 2}


def _axis(shortname: str) -> int | None:
    """0, 1, 2 for a revolute joint about x, y, z (bounded or continuous), else None."""
    for prefix in ("JointModelRUB", "JointModelR"):
        if shortname.startswith(prefix) and shortname[len(prefix) :] in _AXES:
            return _AXES[shortname[len(prefix) :]]
    return None


def _imatmul(alo, ahi, blo, bhi):
    """Enclosure of the product of interval matrices (``[..., i, k] @ [..., k, j]``)."""
    plo, phi = mul(alo[..., :, :, None], ahi[..., :, :, None], blo[..., None, :, :], bhi[..., None, :, :])
    return dot_bounds(np.moveaxis(plo, -2, -1), np.moveaxis(phi, -2, -1))


def _imatvec(alo, ahi, vlo, vhi):
    """Enclosure of interval matrix times interval vectors: ``A (3, 3)``, ``v (k, 3)`` -> ``(k, 3)``."""
    plo, phi = mul(alo[None, :, :], ahi[None, :, :], vlo[:, None, :], vhi[:, None, :])
    return dot_bounds(plo, phi)


def _iadd(alo, ahi, blo, bhi):
    return down(alo + blo), up(ahi + bhi)


def _isq_upper(lo, hi):
    """An upper bound on ``x^2`` over ``[lo, hi]``."""
    m = np.maximum(np.abs(lo), np.abs(hi))
    return up(m * m)


class ScenePrune:
    """The pruning test of one problem's search (picklable: workers of a parallel search get a
    copy). ``calls`` and ``pruned`` count the boxes tested and discarded in this process."""

    def __init__(self, joints, anchors, obstacles):
        #: per joint of the chains, root first: (parent slot or -1, placement R, placement t,
        #: axis, index of c or -1, index of s or -1, cos range, sin range)
        self.joints = joints
        #: (joint slot, points (k, 3) in the joint's frame, their radius)
        self.anchors = anchors
        #: (kind, R^T, t, parameters) of the solid obstacles
        self.obstacles = obstacles
        self.calls = 0
        self.pruned = 0

    def __call__(self, lo: np.ndarray, hi: np.ndarray) -> bool:
        """True when every configuration of the box ``[lo, hi]`` (system variables) is in
        contact by the rule of the module docstring."""
        self.calls += 1
        frames: list[tuple] = []
        for parent, MR, Mt, axis, ic, is_, crange, srange in self.joints:
            c = (max(lo[ic], -1.0), min(hi[ic], 1.0)) if ic >= 0 else crange
            s = (max(lo[is_], -1.0), min(hi[is_], 1.0)) if is_ >= 0 else srange
            if c[0] > c[1] or s[0] > s[1]:
                return False  # an empty box: the search proves it so itself
            # the joint's rotation about its axis, as an interval matrix
            Xlo, Xhi = np.zeros((3, 3)), np.zeros((3, 3))
            i, j = (axis + 1) % 3, (axis + 2) % 3
            Xlo[axis, axis] = Xhi[axis, axis] = 1.0
            Xlo[i, i], Xhi[i, i] = c
            Xlo[j, j], Xhi[j, j] = c
            Xlo[j, i], Xhi[j, i] = s
            Xlo[i, j], Xhi[i, j] = -s[1], -s[0]
            if parent < 0:
                Rlo, Rhi, tlo, thi = MR, MR, Mt, Mt
            else:
                PRlo, PRhi, Ptlo, Pthi = frames[parent]
                Rlo, Rhi = _imatmul(PRlo, PRhi, MR, MR)
                mlo, mhi = _imatvec(PRlo, PRhi, Mt[None, :], Mt[None, :])
                tlo, thi = _iadd(mlo[0], mhi[0], Ptlo, Pthi)
            Rlo, Rhi = _imatmul(Rlo, Rhi, Xlo, Xhi)
            frames.append((Rlo, Rhi, tlo, thi))
        for slot, pts, rad in self.anchors:
            Rlo, Rhi, tlo, thi = frames[slot]
            plo, phi = _imatvec(Rlo, Rhi, down(pts - rad), up(pts + rad))
            plo, phi = _iadd(plo, phi, tlo[None, :], thi[None, :])
            for kind, RT, t, par in self.obstacles:
                if _inside(kind, RT, t, par, plo, phi):
                    self.pruned += 1
                    return True
        return False


def _inside(kind: str, RT: np.ndarray, t: np.ndarray, par: tuple, plo: np.ndarray, phi: np.ndarray) -> bool:
    """Is any of the point enclosures ``[plo, phi]`` (rows) inside the obstacle by DEPTH?"""
    if kind == "sphere":
        (r,) = par
        sq = _isq_upper(down(plo - t), up(phi - t))
        d2 = dot_bounds(sq, sq)[1]
        return bool(np.any(d2 < (r - DEPTH) ** 2 * (1 - 4 * U)))
    dlo, dhi = down(plo - t), up(phi - t)
    llo, lhi = _imatvec(RT, RT, dlo, dhi)  # the points in the obstacle's frame
    if kind == "box":
        h = np.asarray(par) - DEPTH
        return bool(np.any(np.all((llo > -h) & (lhi < h), axis=1)))
    # cylinder (and a capsule's cylinder): axis z, radius r, length L
    r, L = par
    z_ok = (llo[:, 2] > -(L / 2 - DEPTH)) & (lhi[:, 2] < L / 2 - DEPTH)
    q = up(_isq_upper(llo[:, 0], lhi[:, 0]) + _isq_upper(llo[:, 1], lhi[:, 1]))
    return bool(np.any(z_ok & (q < (r - DEPTH) ** 2 * (1 - 4 * U))))


def _solid(geometry) -> tuple[str, tuple] | None:
    import coal

    if isinstance(geometry, coal.Box):
        return "box", tuple(float(v) for v in geometry.halfSide)
    if isinstance(geometry, coal.Sphere):
        return "sphere", (float(geometry.radius),)
    if isinstance(geometry, (coal.Cylinder, coal.Capsule)):
        return "cylinder", (float(geometry.radius), 2.0 * float(geometry.halfLength))
    return None


def _anchor_points(geometry, placement) -> np.ndarray | None:
    """Vertices of a mesh (or the centre of a solid shape), in the joint's frame."""
    import coal

    if isinstance(geometry, coal.BVHModelBase):
        v = np.asarray(geometry.vertices(), dtype=float).reshape(-1, 3)
        if not len(v):
            return None
        picks = sorted({int(np.argmax(v @ d)) for d in _DIRECTIONS})
        v = v[picks]
    elif _solid(geometry) is not None:
        v = np.zeros((1, 3))
    else:
        return None
    R, t = np.asarray(placement.rotation), np.asarray(placement.translation)
    return v @ R.T + t


def scene_pruner(model, system, scene, locked: dict | None = None) -> ScenePrune | None:
    """The pruning test of a search of ``system`` (a formulation's system of ``model``) in
    ``scene`` (:class:`~kinbox.model.scene.CollisionScene`), or None when it can prune nothing
    (no solid obstacle, or no geometry on a chain of revolute joints about coordinate axes).
    ``locked``: joint id -> locked value of joints the formulation fixed."""
    locked = locked or {}
    objs = scene.geom.geometryObjects
    obstacles = []
    for g, o in enumerate(objs):
        if not scene.obstacle[g] or o.parentJoint != 0:
            continue
        solid = _solid(o.geometry)
        if solid is not None:
            M = o.placement
            obstacles.append((solid[0], np.asarray(M.rotation, dtype=float).T.copy(), np.asarray(M.translation, dtype=float), solid[1]))
    if not obstacles:
        return None
    names = {n: i for i, n in enumerate(system.names)}
    anchors_by_joint: dict[int, list[np.ndarray]] = {}
    for g, o in enumerate(objs):
        if scene.obstacle[g] or o.parentJoint == 0:
            continue
        pts = _anchor_points(o.geometry, o.placement)
        if pts is not None:
            anchors_by_joint.setdefault(int(o.parentJoint), []).append(pts)

    # only geometry whose chain from the root turns about coordinate axes (a hand's fingers on
    # prismatic joints are left out; their palm is anchored)
    def turns(jid: int) -> bool:
        return all(_axis(model.joints[j].shortname()) is not None for j in list(model.supports[jid])[1:])

    anchors_by_joint = {jid: pts for jid, pts in anchors_by_joint.items() if turns(jid)}
    needed = sorted({int(j) for jid in anchors_by_joint for j in model.supports[jid] if j != 0})
    slot: dict[int, int] = {}
    joints: list[tuple] = []
    for jid in needed:
        jm = model.joints[jid]
        axis = _axis(jm.shortname())
        assert axis is not None
        name = model.names[jid]
        lo, hi = float(model.lowerPositionLimit[jm.idx_q]), float(model.upperPositionLimit[jm.idx_q])
        if jid in locked:
            v = float(np.atleast_1d(locked[jid])[0])
            lo = hi = v
        if jm.nq != 1 or not (np.isfinite(lo) and np.isfinite(hi)):
            crange = srange = (-1.0, 1.0)
        else:
            crange, srange = _cos_range(lo, hi), _sin_range(lo, hi)
        ic = names.get(f"c[{name}]", -1) if jid not in locked else -1
        is_ = names.get(f"s[{name}]", -1) if jid not in locked else -1
        parent = int(model.parents[jid])
        M = model.jointPlacements[jid]
        slot[jid] = len(joints)
        joints.append(
            (
                slot.get(parent, -1),
                np.asarray(M.rotation, dtype=float),
                np.asarray(M.translation, dtype=float),
                axis,
                ic,
                is_,
                crange,
                srange,
            )
        )
    anchors = []
    for jid, found in anchors_by_joint.items():
        p = np.vstack(found)
        # the rounding of placing a vertex in its joint's frame, a few ulps of its size
        rad = 8 * U * (np.abs(p).sum(axis=1, keepdims=True) + 1.0) + 1e-300
        anchors.append((slot[jid], p, np.broadcast_to(rad, p.shape).copy()))
    return ScenePrune(joints, anchors, obstacles) if anchors else None


__all__ = ["DEPTH", "INF", "ScenePrune", "scene_pruner"]
