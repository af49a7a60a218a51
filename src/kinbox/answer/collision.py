"""Collision verdicts: every solution of an answer checked against a scene, curves split into
their collision-free stretches.

The geometry is Pinocchio's and coal's (:mod:`kinbox.model.scene`): this module only decides
*which* coal queries a configuration needs, cheapest first, and what they prove.

At a configuration, each active pair of the scene has a lower bound on its signed distance
that is raised, cheapest first, only as far as the verdict needs:

1. **bounding volumes**: the largest of the gap between the balls holding the two geometries,
   the signed gap between their boxes' world AABBs and the boxes' gaps along their own axes
   (placed by Pinocchio's forward kinematics; :mod:`kinbox.answer.scene_bounds`, for all the
   solutions of an answer at once);
2. **convex hulls**: coal's distance between the hulls (meshes replaced by coal's convex hull,
   which holds the mesh), less coal's tolerance :data:`TOL`;
3. **meshes**: coal's distance on the meshes as loaded (``computeDistance``) for the
   clearance, coal's collision test on them (``computeCollision``, the test of
   ``pin.computeCollisions``) for contact.

``clearance`` is the smallest mesh distance over the active pairs, found best first: the pair of
smallest bound is raised one level until no bound is below the best mesh distance found, so a
pair whose bound shows it cannot hold the minimum never reaches the meshes, and the value is
the exact minimum, bit for bit coal's distance of that pair (:meth:`Checker._judge`). Then
``free`` needs no further query when every bound clears the margin; the pairs whose bound does
not go to coal's collision test, which says *contact* -- or, where the pair's distance on the
meshes is already known to be a penetration deeper than :data:`TOL`, coal's distance says it
(tests/answer/test_scene.py::test_penetration_is_contact). coal's queries carry no GJK guess
from one to the next (:func:`stateless`): a verdict depends on its configuration alone.

Along a curve (:func:`split_curve`), consecutive configurations ``q0``, ``q1`` are joined by
``pin.interpolate``; no point of a geometry moves further than ``sum_j L[j] |dv[j]|`` on the way
(``dv = pin.difference(q0, q1)``, ``L`` from :func:`kinbox.model.scene.motion_bounds`), so a
pair whose lower bounds ``d0``, ``d1`` at the ends satisfy ``(d0 + d1 - L_pair dv) / 2 > margin``
is clear along the whole segment. Segments where the bound does not prove it are split at
their middle (projected back on the curve by the answer's Newton step) down to
:data:`MAX_DEPTH` halvings; what is still not proven there is not reported free
(docs/soundness.md, "Collision-free stretches"; tests/answer/test_scene.py::test_curve_stretches_sound).
"""

from __future__ import annotations

import heapq
import math
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from ..model.scene import CollisionScene

#: coal's distances (GJK on the hulls, the meshes' BVH) are trusted to this many metres: a
#: distance minus TOL is the lower bound used; measured differences hull - mesh stay below 1e-7
TOL = 1e-6
#: a segment of a curve is halved at most this many times to prove it clear
MAX_DEPTH = 10
#: at most this many configurations are added to one curve by the halvings
MAX_INSERTED = 20000

SPHERE, HULL, MESH = 0, 1, 2


def stateless(gdata: pin.GeometryData) -> None:
    """No GJK guess carried from one coal query to the next: with coal's cached guess on (its
    default), a query's last bits depend on the queries made before it on the same pair;
    without it, on the configuration alone, so that a verdict and its clearance are the same
    whichever solutions were checked before (tests/answer/test_scene.py::test_verdicts_history_free)."""
    with warnings.catch_warnings():  # coal marks the flag deprecated, yet it is what carries the guess
        warnings.simplefilter("ignore", DeprecationWarning)
        for r in [*gdata.distanceRequests, *gdata.collisionRequests]:
            r.enable_cached_gjk_guess = False


@dataclass
class Sample:
    """A configuration with a lower bound per active pair and how it was obtained."""

    q: np.ndarray
    lb: np.ndarray  # lower bound on each pair's distance
    level: np.ndarray  # SPHERE, HULL or MESH per pair
    exact: np.ndarray  # mesh distance where level == MESH, else nan
    contact: np.ndarray  # bool per pair: coal's collision test on the meshes says contact
    decided: bool = False  # the contact of every pair is known
    nearest: int = -1  # the pair of the clearance, once measured
    verdict: Verdict | None = None  # once measured (:meth:`Checker.verdict_of`)


@dataclass
class Verdict:
    free: bool
    clearance: float | None
    pairs: list[list[str]]
    nearest: list[str] | None = None  # the pair whose distance is the clearance

    def to_dict(self) -> dict:
        return {"free": self.free, "clearance": self.clearance, "pairs": self.pairs, "nearest": self.nearest}


@dataclass
class Checker:
    """The queries of one scene, with their counts (``stats``)."""

    scene: CollisionScene
    stats: dict = field(default_factory=dict)

    def __post_init__(self):
        sc = self.scene
        self.model = sc.model
        self.data = self.model.createData()
        self._fk = self.model.createData()  # the bounds' forward kinematics (:meth:`bounds`)
        self._oMi = list(self._fk.oMi)  # its joint placements (live: each entry views ``_fk``)
        self.gdata = pin.GeometryData(sc.geom)
        self.hdata = pin.GeometryData(sc.hull)
        n = len(sc.labels)
        if sc.margin > 0:
            self.gdata.setSecurityMargins(sc.geom, np.full((n, n), sc.margin), True, True)
        # the hulls' collision test (:meth:`_judge` with ``quick``) says contact within the
        # margin and TOL: "no contact" proves the hulls -- and the meshes in them -- further
        # apart than the margin, as their distance less TOL does
        self.hdata.setSecurityMargins(sc.hull, np.full((n, n), sc.margin + TOL), True, True)
        stateless(self.gdata)
        stateless(self.hdata)
        objs = sc.geom.geometryObjects
        self.a = np.array([p[0] for p in sc.pairs], dtype=int)
        self.b = np.array([p[1] for p in sc.pairs], dtype=int)
        self.parent = np.array([o.parentJoint for o in objs], dtype=int)
        self.centre = np.array([c for c, _ in sc.spheres]).reshape(-1, 3)
        self.radius = np.array([r for _, r in sc.spheres])
        self.rab = self.radius[self.a] + self.radius[self.b]
        self._names = [sc.pair_names(k) for k in range(len(sc.pairs))]
        # each geometry's box in its joint's frame: coal's local AABB (which holds the mesh, its
        # hull or the shape), its centre placed -- the ball's centre --, its axes turned by the
        # geometry's placement, its half-widths h along them
        half = []
        for o in objs:
            o.geometry.computeLocalAABB()
            box = o.geometry.aabb_local
            half.append(0.5 * (np.asarray(box.max_, dtype=float) - np.asarray(box.min_, dtype=float)))
        self.half = np.array(half).reshape(-1, 3)
        self.rot = np.array([np.asarray(o.placement.rotation, dtype=float) for o in objs]).reshape(-1, 3, 3)
        # world-fixed geometries (joint 0, whose placement is the identity) are placed once;
        # the others by the placement of their joint, read once per joint and configuration
        self._joints = sorted({int(j) for j in self.parent if j != 0})
        self._slot = np.array([self._joints.index(int(j)) if j != 0 else -1 for j in self.parent], dtype=np.int64)
        self._joint_oMi = [self._oMi[j] for j in self._joints]
        from .scene_bounds import pair_bounds, sorted_pair_bounds

        self._pair_bounds, self._sorted_bounds = pair_bounds, sorted_pair_bounds
        self.a, self.b = self.a.astype(np.int64), self.b.astype(np.int64)
        self.pair_motion = sc.motion[self.a] + sc.motion[self.b] if len(sc.pairs) else np.zeros((0, self.model.nv))
        # the mesh distances of :meth:`_judge` below a known clearance: coal's own distance
        # functor per pair (Pinocchio's cannot be called from Python), with its pair's request
        # and a result whose ``min_distance`` starts at that clearance (:meth:`_below`)
        import coal

        self._dfun = [coal.ComputeDistance(objs[a].geometry, objs[b].geometry) for a, b in sc.pairs]
        self._dreq = list(self.gdata.distanceRequests)
        self._dres = [coal.DistanceResult() for _ in sc.pairs]
        self._pa = [int(a) for a, _ in sc.pairs]
        self._pb = [int(b) for _, b in sc.pairs]
        # coal's distance between two meshes is never negative (the smallest distance between
        # their triangles, a square root; no penetration depth): such a pair cannot hold a
        # clearance of zero or less (tests/answer/test_scene.py::test_mesh_pairs_never_negative)
        bvh = [isinstance(o.geometry, coal.BVHModelBase) for o in objs]
        self._floor = [0.0 if bvh[a] and bvh[b] else -math.inf for a, b in sc.pairs]
        self._placed: np.ndarray | None = None
        self._described: tuple[dict, dict] | None = None
        for k in ("configurations", "sphere_skipped", "hull_checked", "hull_proofs", "mesh_checked", "mesh_distances"):
            self.stats.setdefault(k, 0)

    # -- one configuration ---------------------------------------------------------------------
    def _place(self, q: np.ndarray) -> None:
        if self._placed is not None and self._placed is q:
            return
        sc = self.scene
        pin.forwardKinematics(self.model, self.data, q)
        pin.updateGeometryPlacements(self.model, self.data, sc.hull, self.hdata)
        pin.updateGeometryPlacements(self.model, self.data, sc.geom, self.gdata)
        self._placed = q

    def bounds(self, qs: list[np.ndarray]) -> np.ndarray:
        """Per configuration (rows) and pair, a lower bound on the pair's signed distance from
        their bounding volumes (:func:`kinbox.answer.scene_bounds.pair_bounds`: balls and
        boxes, with the boxes' separating axes, less :data:`TOL`), for all configurations at once. Placements are Pinocchio's
        (``data.oMi`` after ``forwardKinematics``)."""
        m, n = len(qs), len(self.a)
        if n == 0 or m == 0:
            return np.zeros((m, n))
        return self._pair_bounds(self._placements(qs), self._slot, self.centre, self.rot, self.half, self.radius, self.a, self.b, TOL)

    def _placements(self, qs: list[np.ndarray]) -> np.ndarray:
        """The placements (Pinocchio's ``data.oMi`` after ``forwardKinematics``) of the joints
        carrying geometry, per configuration: an array (configurations, joints, 4, 4)."""
        model, data, placements = self.model, self._fk, self._joint_oMi
        fk = pin.forwardKinematics
        placed: list[np.ndarray] = []
        for q in qs:
            fk(model, data, q)
            # copied now (``homogeneous`` is a new array): ``oMi`` views ``data``, which the
            # next configuration overwrites (tests/answer/test_scene.py::test_verdicts_history_free)
            placed += [o.homogeneous for o in placements]
        return np.concatenate(placed).reshape(len(qs), len(placements), 4, 4)

    def sample(self, q: np.ndarray) -> Sample:
        """Place the geometry at ``q``; each pair's lower bound from its bounding volumes."""
        return self.samples([q])[0]

    def samples(self, qs: list[np.ndarray]) -> list[Sample]:
        """:meth:`sample` of each of ``qs``, their bounds computed at once."""
        qs = [np.asarray(q, dtype=float) for q in qs]
        self.stats["configurations"] += len(qs)
        n = len(self.a)
        return [Sample(q, lb, np.zeros(n, dtype=int), np.full(n, np.nan), np.zeros(n, dtype=bool)) for q, lb in zip(qs, self.bounds(qs))]

    def tighten(self, s: Sample, k) -> None:
        """Raise pair ``k``'s bound at ``s`` one level: bounding volumes -> hulls -> meshes."""
        self._place(s.q)
        k = int(k)
        if s.level[k] == SPHERE:
            d = float(pin.computeDistance(self.scene.hull, self.hdata, k).min_distance) - TOL
            self.stats["hull_checked"] += 1
            s.lb[k] = max(s.lb[k], d)
            s.level[k] = HULL
        elif s.level[k] == HULL:
            d = float(pin.computeDistance(self.scene.geom, self.gdata, k).min_distance)
            self.stats["mesh_distances"] += 1
            s.exact[k] = d
            s.lb[k] = max(s.lb[k], d - TOL)
            s.level[k] = MESH

    def _judge(
        self,
        lb: list[float],
        order: list[int],
        level: list[int],
        exact: list[float],
        contact: list[int],
        measure: bool = True,
        decide: bool = True,
    ) -> tuple[float, int]:
        """The verdict at the placed configuration from the pairs' bounds (``lb``, ``level``,
        ``exact`` raised in place; ``order``: the pairs by increasing ``lb``): returns
        (clearance, its pair) and fills ``contact``.

        The clearance first, best first: the pair of smallest bound is raised one level
        (volumes -> hull -> mesh distance) until the smallest bound is no smaller than the
        best mesh distance found. A pair whose bound reaches that distance cannot hold the
        minimum, nor can a pair of two meshes once that distance is zero or less (coal's
        distance between meshes is never negative), so only pairs that could are measured on
        the meshes, and the clearance is the exact minimum. Once the best is zero or less (and
        for the first pair measured if its bound is, unless it is two meshes), a pair still at
        its bounding volumes goes to its mesh distance without its hull's (a penetrating
        hull's depth seldom shows the pair cannot hold the minimum). Then every bound is at least the
        clearance less :data:`TOL` (when the clearance is above zero); pairs whose bound still
        does not clear the margin get coal's collision test on the meshes
        (after the hull, if not yet measured): contact is decided by that test alone, a clear
        verdict by a lower bound above the margin (tests/answer/test_scene.py::test_verdict_matches_reference).
        ``measure=False``: no clearance (every pair within the margin tested); ``decide=False``:
        no contact test. The verdicts of an answer's solutions take :meth:`_quick`, the same
        steps on fresh bounds."""
        hull, hdata, geom, gdata = self.scene.hull, self.hdata, self.scene.geom, self.gdata
        margin, floor = self.scene.margin, self._floor
        hulls = meshes = distances = 0
        best, nearest = math.inf, -1
        if measure:
            raised: list[tuple[float, int]] = []  # pairs at the hull's level, by bound
            i, n = 0, len(order)
            while True:
                b0 = lb[order[i]] if i < n else math.inf
                if raised and raised[0][0] < b0:
                    b, k = raised[0]
                    if b >= best:
                        break
                    heapq.heappop(raised)
                    if floor[k] >= best:  # two meshes, a clearance of zero or less found
                        continue
                    distances += 1
                    e = pin.computeDistance(geom, gdata, k).min_distance
                    exact[k] = e
                    if e - TOL > b:
                        lb[k] = e - TOL
                    level[k] = MESH
                    if e < best:
                        best, nearest = e, k
                    continue
                if b0 >= best:
                    break
                k = order[i]
                i += 1
                if floor[k] >= best:
                    continue
                lv = level[k]
                if lv == SPHERE and (best <= 0.0 or (b0 <= 0.0 and best == math.inf and floor[k] < 0.0)):
                    # a penetration found, or likely (the first pair measured, its boxes
                    # overlapping, not two meshes): this pair's mesh distance at once, the
                    # hulls' depth seldom showing that a pair cannot hold a deeper one
                    heapq.heappush(raised, (b0, k))
                    continue
                if lv == SPHERE:
                    d = pin.computeDistance(hull, hdata, k).min_distance - TOL
                    hulls += 1
                    if d > b0:
                        lb[k] = b0 = d
                    level[k] = HULL
                    if b0 < best:
                        heapq.heappush(raised, (b0, k))
                elif lv == HULL:  # raised before (a curve's sample)
                    heapq.heappush(raised, (b0, k))
                elif exact[k] < best:
                    best, nearest = exact[k], k
        if decide and best - TOL <= margin:  # some bound may not clear the margin
            for k in range(len(lb)):
                b = lb[k]
                if b > margin:
                    continue
                if level[k] == SPHERE:
                    hulls += 1
                    level[k] = HULL
                    d = pin.computeDistance(hull, hdata, k).min_distance - TOL
                    if d > b:
                        lb[k] = b = d
                    if b > margin:
                        continue
                if exact[k] < -TOL:  # coal's distance on the meshes is a penetration: contact
                    contact.append(k)
                    continue
                if pin.computeCollision(geom, gdata, k):
                    contact.append(k)
                meshes += 1
        stats = self.stats
        stats["hull_checked"] += hulls
        stats["mesh_checked"] += meshes
        stats["mesh_distances"] += distances
        return best, nearest

    def _below(self, k: int, best: float) -> float:
        """coal's mesh distance of pair ``k`` at the placed configuration if it is below
        ``best`` (> 0), else ``best`` or more: coal's traversal starts from ``best`` as the
        distance found so far, so it skips every part of the meshes whose bounding volumes are
        that far apart. Below ``best`` the value is the one ``pin.computeDistance`` returns, bit
        for bit: the same triangle pairs' distances, fewer of the far ones
        (tests/answer/test_scene.py::test_bounded_distance_is_coal)."""
        res = self._dres[k]
        res.clear()
        res.min_distance = best
        oMg = self.gdata.oMg
        return float(self._dfun[k](oMg[self._pa[k]], oMg[self._pb[k]], self._dreq[k], res))

    def _settled(self, level: list[int]) -> None:
        """Count the pairs settled by their bounding volumes and by their hulls alone."""
        self.stats["sphere_skipped"] += level.count(SPHERE)
        self.stats["hull_proofs"] += level.count(HULL)

    def described(self) -> tuple[dict, dict]:
        """The scene as a result carries it (``spec.to_dict()``) and its summary, made once per
        checker: shared by the answers it annotates, read, never changed."""
        if self._described is None:
            self._described = (self.scene.spec.to_dict(), self.scene.summary())
        return self._described

    def verdict(self, q: np.ndarray) -> Verdict:
        """:meth:`verdicts` of one configuration."""
        return self.verdicts([q])[0]

    def verdicts(self, qs: list[np.ndarray]) -> list[Verdict]:
        """The collision verdict at each of ``qs``, their bounds computed at once, on plain Python
        numbers (no :class:`Sample` kept): the steps of :meth:`_judge` (``measure`` and
        ``decide``) on fresh bounds -- every pair at its bounding volumes, each reached once in
        its configuration's order --, with the queries' cheaper forms where they give the same
        verdict: once a clearance above the margin is found, a mesh distance is only measured
        below it (:meth:`_below`): a pair at least that far gets the clearance less :data:`TOL`
        as its bound and no exact distance, so it still clears the margin; and a pair that needs
        its hull to clear the margin gets the hulls' collision test (within the margin and
        :data:`TOL`) rather than their distance. The same coal queries' outcomes, verdicts and
        counts as :meth:`verdict_of` of :meth:`sample`
        (tests/answer/test_scene.py::test_verdict_same_as_sample_path). It runs for the solutions of
        every answer (benchmarks/scenes.py measures it), so it is written for speed: one loop,
        the per-pair constants bound once."""
        qs = [np.asarray(q, dtype=float) for q in qs]
        stats = self.stats
        stats["configurations"] += len(qs)
        npairs = len(self.a)
        if not npairs:
            return [Verdict(True, None, [], None) for _ in qs]
        if not qs:
            return []
        margin = self.scene.margin
        # in one compiled call (each NumPy call costs microseconds here): the bounds of
        # :meth:`bounds`, each row's pairs by increasing bound, and how many of them, first in
        # that order, do not clear the margin
        lbs, orders = self._sorted_bounds(
            self._placements(qs), self._slot, self.centre, self.rot, self.half, self.radius, self.a, self.b, TOL, margin
        )
        orders = orders.tolist()
        model, data, place = self.model, self.data, pin.updateGeometryPlacements
        hull, hdata, geom, gdata = self.scene.hull, self.hdata, self.scene.geom, self.gdata
        distance, collide, push, pop = pin.computeDistance, pin.computeCollision, heapq.heappush, heapq.heappop
        names, floor, below, inf = self._names, self._floor, self._below, math.inf
        skipped = proofs = hulls = meshes = distances = 0
        out = []
        for q, lb, order in zip(qs, lbs.tolist(), orders):
            low = order.pop()
            place(model, data, geom, gdata, q)  # :meth:`_place` (its forward kinematics too)
            place(model, data, hull, hdata)
            self._placed = q
            level: dict[int, int] = {}  # the pairs raised past their bounding volumes: HULL or MESH
            exact: dict[int, float] = {}  # their mesh distances, where measured
            best, nearest = inf, -1
            raised: list[tuple[float, int]] = []  # pairs waiting for their mesh distance, by bound
            i, n = 0, len(order)
            while True:  # the clearance, best first (:meth:`_judge`)
                b0 = lb[order[i]] if i < n else inf
                if raised and raised[0][0] < b0:
                    b, k = raised[0]
                    if b >= best:
                        break
                    pop(raised)
                    if floor[k] >= best:  # two meshes, a clearance of zero or less found
                        continue
                    distances += 1
                    level[k] = MESH
                    if best - TOL > margin and best < inf:
                        e = below(k, best)
                        if e >= best:  # no closer than the clearance found: not its pair
                            lb[k] = max(b, e - TOL)
                            continue
                    else:
                        e = distance(geom, gdata, k).min_distance
                    exact[k] = e
                    if e - TOL > b:
                        lb[k] = e - TOL
                    if e < best:
                        best, nearest = e, k
                    continue
                if b0 >= best:
                    break
                k = order[i]
                i += 1
                if floor[k] >= best:
                    continue
                if best <= 0.0 or (b0 <= 0.0 and best == inf and floor[k] < 0.0):
                    push(raised, (b0, k))  # its mesh distance at once (:meth:`_judge`)
                    continue
                d = distance(hull, hdata, k).min_distance - TOL
                hulls += 1
                if d > b0:
                    lb[k] = b0 = d
                level[k] = HULL
                if b0 < best:
                    push(raised, (b0, k))
            contact: list[int] = []
            if best - TOL <= margin:  # some bound may not clear the margin
                for k in order[:low]:  # bounds only rise: the others clear it
                    if lb[k] > margin:
                        continue
                    if k not in level:
                        hulls += 1
                        level[k] = HULL
                        if not collide(hull, hdata, k):  # the hulls are clear
                            continue
                    if exact.get(k, inf) < -TOL:  # coal's distance on the meshes is a penetration: contact
                        contact.append(k)
                        continue
                    if collide(geom, gdata, k):
                        contact.append(k)
                    meshes += 1
            skipped += npairs - len(level)
            if level:
                proofs += list(level.values()).count(HULL)
            pairs = [list(p) for p in sorted({names[k] for k in contact})] if contact else []
            out.append(Verdict(not contact, best, pairs, list(names[nearest]) if nearest >= 0 else None))
        stats["sphere_skipped"] += skipped
        stats["hull_proofs"] += proofs
        stats["hull_checked"] += hulls
        stats["mesh_checked"] += meshes
        stats["mesh_distances"] += distances
        return out

    def _verdict(self, contact: list[int], best: float, nearest: int) -> Verdict:
        names = self._names
        pairs = sorted({names[k] for k in contact})
        return Verdict(not contact, best, [list(p) for p in pairs], list(names[nearest]) if nearest >= 0 else None)

    def decide(self, s: Sample) -> None:
        """Contact of every pair at ``s``: pairs whose bound exceeds the margin are clear, the
        others go to coal's collision test on the meshes (after the hull)."""
        if s.decided:
            return
        self._judge_sample(s, measure=False, decide=True)

    def clearance(self, s: Sample) -> float | None:
        """The smallest mesh distance over the active pairs at ``s`` (None: no active pair)."""
        return self.verdict_of(s).clearance

    def verdict_of(self, s: Sample) -> Verdict:
        """The verdict at a sample (:meth:`_judge`), its bounds raised in place."""
        if s.verdict is None:
            if len(s.lb) == 0:
                s.decided, s.verdict = True, Verdict(True, None, [], None)
            else:
                best, nearest = self._judge_sample(s, measure=True, decide=not s.decided)
                s.nearest = nearest
                s.verdict = self._verdict(np.flatnonzero(s.contact).tolist(), best, nearest)
        return s.verdict

    def _judge_sample(self, s: Sample, measure: bool, decide: bool) -> tuple[float, int]:
        self._place(s.q)
        lb, level, exact = s.lb.tolist(), s.level.tolist(), s.exact.tolist()
        order = np.argsort(s.lb, kind="stable").tolist() if measure else []
        contact: list[int] = []
        best, nearest = self._judge(lb, order, level, exact, contact, measure, decide)
        if measure:
            self._settled(level)
        s.lb[:], s.level[:], s.exact[:] = lb, level, exact
        if decide:
            s.contact[contact] = True
            s.decided = True
        return best, nearest

    # -- along a curve -----------------------------------------------------------------------------
    def segment_bound(self, s0: Sample, s1: Sample) -> np.ndarray:
        """Per pair, a lower bound on its distance all along the segment ``s0`` -> ``s1``."""
        dv = np.abs(pin.difference(self.model, s0.q, s1.q))
        m = np.where(dv > 0, self.pair_motion, 0.0)  # an unbounded joint that does not move adds nothing
        L = m @ dv if len(m) else np.zeros(0)
        return 0.5 * (s0.lb + s1.lb - L)

    def prove(self, s0: Sample, s1: Sample, polish, inserted: list, depth: int = 0) -> tuple[bool, float, list[Sample]]:
        """(the segment is clear, a lower bound on the clearance along it, the configurations
        added inside it in order)."""
        margin = self.scene.margin
        bound = self.segment_bound(s0, s1)
        for k in np.flatnonzero(bound <= margin):
            while bound[k] <= margin and (s0.level[k] < MESH or s1.level[k] < MESH):
                self.tighten(s0 if s0.level[k] <= s1.level[k] else s1, k)
                bound[k] = self.segment_bound_pair(s0, s1, k)
        low = float(np.min(bound)) if len(bound) else math.inf
        if low > margin:
            return True, low, []
        self.decide(s0)
        self.decide(s1)
        if np.any(s0.contact) or np.any(s1.contact) or depth >= MAX_DEPTH or len(inserted) >= MAX_INSERTED:
            return False, low, []
        qm = pin.interpolate(self.model, s0.q, s1.q, 0.5)
        if polish is not None:
            qp = polish(qm)
            dv = np.abs(pin.difference(self.model, s0.q, s1.q))
            if np.all(np.isfinite(qp)) and np.max(np.abs(pin.difference(self.model, qm, qp)), initial=0.0) <= 0.5 * float(
                np.max(dv, initial=0.0)
            ):
                qm = qp
        sm = self.sample(qm)
        inserted.append(sm)
        ok0, low0, in0 = self.prove(s0, sm, polish, inserted, depth + 1)
        ok1, low1, in1 = self.prove(sm, s1, polish, inserted, depth + 1)
        return ok0 and ok1, min(low0, low1), [*in0, sm, *in1]

    def segment_bound_pair(self, s0: Sample, s1: Sample, k) -> float:
        dv = np.abs(pin.difference(self.model, s0.q, s1.q))
        m = np.where(dv > 0, self.pair_motion[k], 0.0)
        return 0.5 * (float(s0.lb[k]) + float(s1.lb[k]) - float(m @ dv))


def split_branch(checker: Checker, qs: list[np.ndarray], closed: bool, polish: Callable | None = None) -> dict:
    """A branch of a curve (ordered configurations) against the scene: its collision-free
    stretches (polylines whose every segment is proven clear, refined where needed), the
    clearance at each configuration (mesh distances) and the lower bound along each stretch."""
    samples = checker.samples(qs)
    verdicts = [checker.verdict_of(s) for s in samples]
    n = len(samples)
    seg_count = n if closed and n > 2 else max(n - 1, 0)
    inserted: list[Sample] = []
    stretches: list[dict] = []
    cur: list[Sample] = []
    cur_low = math.inf
    unproven = 0

    def close_stretch():
        nonlocal cur, cur_low
        if cur:
            stretches.append({"polyline": [[float(v) for v in s.q] for s in cur], "clearance": _num(cur_low)})
        cur, cur_low = [], math.inf

    oks = []
    for i in range(seg_count):
        s0, s1 = samples[i], samples[(i + 1) % n]
        ok, low, inner = checker.prove(s0, s1, polish, inserted)
        oks.append(ok)
        if ok:
            if not cur:
                cur = [s0]
                cur_low = min(cur_low, low)
            cur.extend([*inner, s1])
            cur_low = min(cur_low, low)
        else:
            unproven += 1
            close_stretch()
    close_stretch()
    if n == 1 and verdicts[0].free:
        stretches.append({"polyline": [[float(v) for v in samples[0].q]], "clearance": verdicts[0].clearance})
    if closed and len(stretches) > 1 and oks[0] and oks[-1]:
        # a closed branch: the stretch through its last segment goes on into the first one
        last, first = stretches.pop(), stretches.pop(0)
        lows = [x for x in (last["clearance"], first["clearance"]) if x is not None]
        stretches.insert(0, {"polyline": last["polyline"] + first["polyline"][1:], "clearance": min(lows) if lows else None})
    clear = [v.clearance for v in verdicts if v.clearance is not None]
    pairs = sorted({tuple(p) for v in verdicts for p in v.pairs})
    return {
        "free": unproven == 0 and all(v.free for v in verdicts),
        "clearance": _num(min(clear)) if clear else None,
        "stretches": stretches,
        "samples": n,
        "colliding_samples": sum(not v.free for v in verdicts),
        "unproven_segments": unproven,
        "inserted": len(inserted),
        "sample_clearance": [_num(v.clearance) if v.clearance is not None else None for v in verdicts],
        "contacts": [[i, v.pairs] for i, v in enumerate(verdicts) if not v.free],
        "pairs": [list(p) for p in pairs],
    }


def _num(x: float) -> float | None:
    return float(x) if x is not None and math.isfinite(x) else None


def annotate(
    res,
    scene: CollisionScene,
    collision_free: bool = False,
    polish: Callable | None = None,
    curves: bool = True,
    checker: Checker | None = None,
):
    """Give every solution of ``res`` (a :class:`~kinbox.answer.result.Result`) its verdict,
    every curve its free stretches; with ``collision_free``, drop the solutions in contact
    (``stats["collision"]["dropped"]`` counts them); ``checker``: a :class:`Checker` of
    ``scene`` to reuse (its Pinocchio and coal data). Returns ``res``."""
    started, cpu = time.perf_counter(), time.process_time()
    if checker is None or checker.scene is not scene:
        checker = Checker(scene)
    for k in checker.stats:  # the counts of this answer alone
        checker.stats[k] = 0
    for s, v in zip(res.solutions, checker.verdicts([s.q for s in res.solutions])):
        s.collision = v.to_dict()
    if curves:
        for cv in res.curves.values():
            cv.collision = [split_branch(checker, list(b), bool(cl), polish) for b, cl in zip(cv.branches, cv.closed)]
    dropped = 0
    if collision_free:
        keep = [s for s in res.solutions if s.collision is not None and s.collision["free"]]
        dropped = len(res.solutions) - len(keep)
        res.solutions = keep
        res.stats["solutions"] = len(keep)
    res.scene, summary = checker.described()
    res.stats["collision"] = {
        **summary,
        "free": sum(1 for s in res.solutions if s.collision and s.collision["free"]),
        "in_contact": sum(1 for s in res.solutions if s.collision and not s.collision["free"]),
        "dropped": dropped,
        "checks": dict(checker.stats),
        "seconds": time.perf_counter() - started,
        "cpu_seconds": time.process_time() - cpu,
    }
    if dropped:
        res.message += f"; {dropped} solution(s) in collision dropped (--collision-free)"
    return res
