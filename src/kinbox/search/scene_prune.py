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
(``System.exclude``, :meth:`kinbox.search.processor.BoxProcessor._rounds`). Tests:
tests/search/test_scene_prune.py (planted collision-free roots are never lost, and a box is
discarded only when coal finds every sampled configuration of it in contact).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..interval import TINY, U
from ..interval import cos_range as _cos_range
from ..interval import sin_range as _sin_range
from .propagate import _dn, _up

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


_KIND = {"sphere": 0, "box": 1, "cylinder": 2}


class ScenePrune:
    """The pruning test of one problem's search (picklable: workers of a parallel search get a
    copy). ``calls`` and ``pruned`` count the boxes tested and discarded in this process.

    Per joint of the chains (root first): the slot of its parent (-1: the root), its placement
    ``MR``, ``Mt`` in the parent's frame, the axis it turns about, the indices of its cosine and
    sine in the box (-1: none, ``cs_range`` holds their enclosure); per anchor point: its
    joint's slot, the point in the joint's frame and the radius of that placement's rounding;
    per solid obstacle: its kind (sphere, box, cylinder), ``R^T``, centre and sizes (radius;
    half-sides; radius and length)."""

    def __init__(self, joints: list[tuple], anchors: list[tuple], obstacles: list[tuple]):
        self.parent = np.array([j[0] for j in joints], dtype=np.int64)
        self.MR = np.array([j[1] for j in joints], dtype=float).reshape(-1, 3, 3)
        self.Mt = np.array([j[2] for j in joints], dtype=float).reshape(-1, 3)
        self.axis = np.array([j[3] for j in joints], dtype=np.int64)
        self.cs = np.array([[j[4], j[5]] for j in joints], dtype=np.int64).reshape(-1, 2)
        self.cs_range = np.array([[*j[6], *j[7]] for j in joints], dtype=float).reshape(-1, 4)
        self.a_slot = np.array([a[0] for a in anchors], dtype=np.int64)
        self.a_pts = np.array([a[1] for a in anchors], dtype=float).reshape(-1, 3)
        self.a_rad = np.array([a[2] for a in anchors], dtype=float)
        self.o_kind = np.array([_KIND[o[0]] for o in obstacles], dtype=np.int64)
        self.o_RT = np.array([o[1] for o in obstacles], dtype=float).reshape(-1, 3, 3)
        self.o_t = np.array([o[2] for o in obstacles], dtype=float).reshape(-1, 3)
        self.o_par = np.array([[*o[3], *([0.0] * (3 - len(o[3])))] for o in obstacles], dtype=float).reshape(-1, 3)
        self.calls = 0
        self.pruned = 0

    def __call__(self, lo: np.ndarray, hi: np.ndarray) -> bool:
        """True when every configuration of the box ``[lo, hi]`` (system variables) is in
        contact by the rule of the module docstring."""
        self.calls += 1
        out = bool(
            prune_kernel(
                np.asarray(lo, dtype=float),
                np.asarray(hi, dtype=float),
                self.parent,
                self.MR,
                self.Mt,
                self.axis,
                self.cs,
                self.cs_range,
                self.a_slot,
                self.a_pts,
                self.a_rad,
                self.o_kind,
                self.o_RT,
                self.o_t,
                self.o_par,
                DEPTH,
            )
        )
        self.pruned += out
        return out


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
        for p in np.vstack(found):
            # the rounding of placing a vertex in its joint's frame, a few ulps of its size
            anchors.append((slot[jid], p, 8 * U * (float(np.abs(p).sum()) + 1.0)))
    return ScenePrune(joints, anchors, obstacles) if anchors else None


__all__ = ["DEPTH", "ScenePrune", "prune_kernel", "scene_pruner"]


# -- the test, compiled: the rules of :mod:`kinbox.interval` applied to scalars ----------------------
_G3 = 3 * U / (1 - 3 * U)  # Higham's gamma_3: a sum of three terms
_G4 = 4 * U / (1 - 4 * U)


@nb.njit(cache=True, inline="always")
def _imul(alo, ahi, blo, bhi):
    p1, p2, p3, p4 = alo * blo, alo * bhi, ahi * blo, ahi * bhi
    return _dn(min(min(p1, p2), min(p3, p4))) - TINY, _up(max(max(p1, p2), max(p3, p4))) + TINY


@nb.njit(cache=True, inline="always")
def _isum(slo, shi, alo, ahi, g, n):
    """Enclose a sum of ``n`` terms: ``slo``/``shi`` the sums of their bounds, ``alo``/``ahi`` of
    their magnitudes (interval.dot_bounds)."""
    return _dn(slo - (g * alo + n * TINY)), _up(shi + (g * ahi + n * TINY))


@nb.njit(cache=True)
def _compose(Rlo, Rhi, Blo, Bhi, Olo, Ohi):
    """``O = R B`` for interval 3x3 matrices (rows of ``R`` times columns of ``B``)."""
    for i in range(3):
        for j in range(3):
            slo = shi = alo = ahi = 0.0
            for k in range(3):
                plo, phi = _imul(Rlo[i, k], Rhi[i, k], Blo[k, j], Bhi[k, j])
                slo += plo
                shi += phi
                alo += abs(plo)
                ahi += abs(phi)
            Olo[i, j], Ohi[i, j] = _isum(slo, shi, alo, ahi, _G3, 3)


@nb.njit(cache=True)
def _place(Rlo, Rhi, tlo, thi, vlo, vhi, out_lo, out_hi):
    """``R v + t`` for interval ``R``, ``v`` and ``t``."""
    for i in range(3):
        slo, shi = tlo[i], thi[i]
        alo, ahi = abs(tlo[i]), abs(thi[i])
        for k in range(3):
            plo, phi = _imul(Rlo[i, k], Rhi[i, k], vlo[k], vhi[k])
            slo += plo
            shi += phi
            alo += abs(plo)
            ahi += abs(phi)
        out_lo[i], out_hi[i] = _isum(slo, shi, alo, ahi, _G4, 4)


@nb.njit(cache=True)
def _sq_up(lo, hi):
    m = max(abs(lo), abs(hi))
    return _up(m * m)


@nb.njit(cache=True)
def prune_kernel(lo, hi, parent, MR, Mt, axis, cs, cs_range, a_slot, a_pts, a_rad, o_kind, o_RT, o_t, o_par, depth):
    """True when some anchor's enclosure lies inside some obstacle by ``depth`` (see
    :class:`ScenePrune` for the arguments)."""
    nj = parent.shape[0]
    Rlo = np.empty((nj, 3, 3))
    Rhi = np.empty((nj, 3, 3))
    tlo = np.empty((nj, 3))
    thi = np.empty((nj, 3))
    Xlo = np.zeros((3, 3))
    Xhi = np.zeros((3, 3))
    Alo = np.empty((3, 3))
    Ahi = np.empty((3, 3))
    for n in range(nj):
        if cs[n, 0] >= 0:
            clo, chi = max(lo[cs[n, 0]], -1.0), min(hi[cs[n, 0]], 1.0)
            slo, shi = max(lo[cs[n, 1]], -1.0), min(hi[cs[n, 1]], 1.0)
        else:
            clo, chi, slo, shi = cs_range[n, 0], cs_range[n, 1], cs_range[n, 2], cs_range[n, 3]
        if clo > chi or slo > shi:
            return False  # an empty box: the search proves it so itself
        ax = axis[n]
        i, j = (ax + 1) % 3, (ax + 2) % 3
        for r in range(3):
            for c in range(3):
                Xlo[r, c] = 0.0
                Xhi[r, c] = 0.0
        Xlo[ax, ax] = Xhi[ax, ax] = 1.0
        Xlo[i, i], Xhi[i, i] = clo, chi
        Xlo[j, j], Xhi[j, j] = clo, chi
        Xlo[j, i], Xhi[j, i] = slo, shi
        Xlo[i, j], Xhi[i, j] = -shi, -slo
        p = parent[n]
        if p < 0:
            for r in range(3):
                tlo[n, r] = thi[n, r] = Mt[n, r]
                for c in range(3):
                    Alo[r, c] = Ahi[r, c] = MR[n, r, c]
        else:
            _compose(Rlo[p], Rhi[p], MR[n], MR[n], Alo, Ahi)
            _place(Rlo[p], Rhi[p], tlo[p], thi[p], Mt[n], Mt[n], tlo[n], thi[n])
        _compose(Alo, Ahi, Xlo, Xhi, Rlo[n], Rhi[n])
    plo = np.empty(3)
    phi = np.empty(3)
    vlo = np.empty(3)
    vhi = np.empty(3)
    llo = np.empty(3)
    lhi = np.empty(3)
    zero = np.zeros(3)
    for a in range(a_slot.shape[0]):
        n = a_slot[a]
        for r in range(3):
            vlo[r] = _dn(a_pts[a, r] - a_rad[a])
            vhi[r] = _up(a_pts[a, r] + a_rad[a])
        _place(Rlo[n], Rhi[n], tlo[n], thi[n], vlo, vhi, plo, phi)
        for o in range(o_kind.shape[0]):
            for r in range(3):  # the point relative to the obstacle's centre
                vlo[r] = _dn(plo[r] - o_t[o, r])
                vhi[r] = _up(phi[r] - o_t[o, r])
            kind = o_kind[o]
            if kind == 0:  # sphere
                d2 = 0.0
                for r in range(3):
                    d2 = _up(d2 + _sq_up(vlo[r], vhi[r]))
                rr = o_par[o, 0] - depth
                if rr > 0 and d2 < rr * rr * (1 - 4 * U):
                    return True
                continue
            _place(o_RT[o], o_RT[o], zero, zero, vlo, vhi, llo, lhi)  # in the obstacle's frame
            if kind == 1:  # box
                inside = True
                for r in range(3):
                    h = o_par[o, r] - depth
                    if not (llo[r] > -h and lhi[r] < h):
                        inside = False
                if inside:
                    return True
            else:  # cylinder along z (and a capsule's cylinder)
                rr, half = o_par[o, 0] - depth, 0.5 * o_par[o, 1] - depth
                if llo[2] > -half and lhi[2] < half and rr > 0:
                    q = _up(_sq_up(llo[0], lhi[0]) + _sq_up(llo[1], lhi[1]))
                    if q < rr * rr * (1 - 4 * U):
                        return True
    return False
