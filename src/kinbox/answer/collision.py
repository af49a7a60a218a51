"""Collision verdicts: every solution of an answer checked against a scene, curves split into
their collision-free stretches.

The geometry is Pinocchio's and coal's (:mod:`kinbox.model.scene`): this module only decides
*which* coal queries a configuration needs, cheapest first, and what they prove.

At a configuration, for every active pair of the scene:

1. **bounding balls**: the distance between the balls holding the two geometries (placed by
   Pinocchio's forward kinematics) is a lower bound on their distance; above the margin the
   pair is clear without a coal call (counted as *skipped*);
2. **convex hulls**: coal's distance between the hulls (meshes replaced by coal's convex hull,
   which holds the mesh) is a lower bound too; above the margin (less coal's tolerance
   :data:`TOL`) the pair is clear;
3. **meshes**: otherwise coal's collision test on the meshes as loaded decides (``contact``),
   the same test as ``pin.computeCollisions``.

The verdict of a configuration is ``free`` when no active pair is in contact; ``clearance`` is
the smallest distance over the active pairs measured on the meshes (coal's
``computeDistance``; negative or zero: in contact); the pairs needed for that minimum are
found in the order of their lower bounds, so most pairs never reach a mesh distance.

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

import math
import time
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


@dataclass
class Sample:
    """A configuration with a lower bound per active pair and how it was obtained."""

    q: np.ndarray
    lb: np.ndarray  # lower bound on each pair's distance
    level: np.ndarray  # SPHERE, HULL or MESH per pair
    exact: np.ndarray  # mesh distance where level == MESH, else nan
    contact: np.ndarray  # bool per pair: coal's collision test on the meshes says contact
    decided: bool = False  # the verdict (contact of every pair) is known
    nearest: int = -1  # the pair of the clearance, once measured


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
        self.gdata = pin.GeometryData(sc.geom)
        self.hdata = pin.GeometryData(sc.hull)
        if sc.margin > 0:
            n = len(sc.labels)
            self.gdata.setSecurityMargins(sc.geom, np.full((n, n), sc.margin), True, True)
        self.a = np.array([p[0] for p in sc.pairs], dtype=int)
        self.b = np.array([p[1] for p in sc.pairs], dtype=int)
        self.parent = np.array([o.parentJoint for o in sc.geom.geometryObjects], dtype=int)
        self.centre = np.array([c for c, _ in sc.spheres]).reshape(-1, 3)
        self.radius = np.array([r for _, r in sc.spheres])
        self.ra, self.rb = self.radius[self.a], self.radius[self.b]
        # the balls' centres in the world: those of world-fixed geometries (joint 0, whose
        # placement is the identity) once here, the others per configuration in sample()
        self._world = self.centre.copy()
        self._moving = [(g, int(j), self.centre[g]) for g, j in enumerate(self.parent) if j != 0]
        self.pair_motion = sc.motion[self.a] + sc.motion[self.b] if len(sc.pairs) else np.zeros((0, self.model.nv))
        self._placed: np.ndarray | None = None
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

    def sample(self, q: np.ndarray) -> Sample:
        """Place the geometry at ``q``; each pair's lower bound from its bounding balls."""
        q = np.asarray(q, dtype=float)
        self._place(q)
        self.stats["configurations"] += 1
        n = len(self.a)
        if n:
            oMi, world = self.data.oMi, self._world
            for g, j, c in self._moving:
                world[g] = oMi[j].act(c)
            gap = np.linalg.norm(world[self.a] - world[self.b], axis=1) - self.ra - self.rb - TOL
        else:
            gap = np.zeros(0)
        return Sample(q, gap, np.zeros(n, dtype=int), np.full(n, np.nan), np.zeros(n, dtype=bool))

    def tighten(self, s: Sample, k) -> None:
        """Raise pair ``k``'s bound at ``s`` one level: bounding balls -> hulls -> meshes."""
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

    def decide(self, s: Sample) -> None:
        """Contact of every pair at ``s``: pairs whose bound exceeds the margin are clear, the
        others go to coal's collision test on the meshes."""
        if s.decided:
            return
        margin = self.scene.margin
        lb, level, contact = s.lb, s.level, s.contact
        near = lb <= margin
        close = np.nonzero(near)[0].tolist()
        stats = self.stats
        stats["sphere_skipped"] += int(np.count_nonzero(level[~near] == SPHERE))
        if close:
            self._place(s.q)
        # the per-pair steps of :meth:`tighten` inlined (one coal call each): this loop runs
        # for every configuration of every curve; :meth:`verdict` does the same for a solution
        hull, hdata, geom, gdata = self.scene.hull, self.hdata, self.scene.geom, self.gdata
        hulls = proofs = meshes = 0
        for k in close:
            bound = float(lb[k])
            if level[k] == SPHERE:
                d = pin.computeDistance(hull, hdata, k).min_distance - TOL
                hulls += 1
                if d > bound:
                    lb[k] = bound = d
                level[k] = HULL
            if bound > margin:
                proofs += 1
                continue
            contact[k] = pin.computeCollision(geom, gdata, k)
            meshes += 1
        stats["hull_checked"] += hulls
        stats["hull_proofs"] += proofs
        stats["mesh_checked"] += meshes
        s.decided = True

    def clearance(self, s: Sample) -> float | None:
        """The smallest mesh distance over the active pairs at ``s`` (None: no active pair):
        pairs in the order of their lower bounds until the next bound is no smaller."""
        if len(s.lb) == 0:
            return None
        best = math.inf
        lb, level, exact = s.lb, s.level, s.exact
        for k in np.argsort(lb, kind="stable").tolist():
            if lb[k] >= best:
                break
            while level[k] < MESH:
                self.tighten(s, k)
                if lb[k] >= best:
                    break
            if level[k] == MESH and exact[k] < best:
                best, s.nearest = float(exact[k]), k
        return best

    def verdict(self, q: np.ndarray) -> Verdict:
        """:meth:`verdict_of` of :meth:`sample` at ``q``, computed on plain Python numbers (no
        :class:`Sample` kept): the same coal queries in the same order, the same verdict and
        counts (tests/answer/test_scene.py::test_verdict_same_as_sample_path). It runs for every
        solution of every answer (benchmarks/scenes.py measures it)."""
        q = np.asarray(q, dtype=float)
        self._place(q)
        stats = self.stats
        stats["configurations"] += 1
        sc = self.scene
        n = len(self.a)
        if not n:
            return Verdict(True, None, [], None)
        oMi, world = self.data.oMi, self._world
        for g, j, c in self._moving:
            world[g] = oMi[j].act(c)
        x = world[self.a] - world[self.b]
        gap = np.sqrt(np.add.reduce(x * x, axis=1)) - self.ra - self.rb - TOL  # np.linalg.norm(x, axis=1)'s sum
        lb: list[float] = gap.tolist()
        level = [SPHERE] * n
        exact = [math.nan] * n
        margin = sc.margin
        hull, hdata, geom, gdata = sc.hull, self.hdata, sc.geom, self.gdata
        # decide: the pairs within the margin by their balls, in index order
        contact: list[int] = []
        hulls = proofs = meshes = skipped = 0
        for k in range(n):
            b = lb[k]
            if not b <= margin:
                skipped += b > margin
                continue
            d = pin.computeDistance(hull, hdata, k).min_distance - TOL
            hulls += 1
            if d > b:
                lb[k] = b = d
            level[k] = HULL
            if b > margin:
                proofs += 1
                continue
            if pin.computeCollision(geom, gdata, k):
                contact.append(k)
            meshes += 1
        # clearance: pairs in the order of their bounds until the next bound is no smaller
        best, nearest, distances = math.inf, -1, 0
        for k in np.argsort(np.array(lb), kind="stable").tolist():
            if lb[k] >= best:
                break
            while level[k] < MESH:
                if level[k] == SPHERE:
                    d = pin.computeDistance(hull, hdata, k).min_distance - TOL
                    hulls += 1
                    if d > lb[k]:
                        lb[k] = d
                    level[k] = HULL
                else:
                    e = pin.computeDistance(geom, gdata, k).min_distance
                    distances += 1
                    exact[k] = e
                    if e - TOL > lb[k]:
                        lb[k] = e - TOL
                    level[k] = MESH
                if lb[k] >= best:
                    break
            if level[k] == MESH and exact[k] < best:
                best, nearest = exact[k], k
        stats["sphere_skipped"] += skipped
        stats["hull_checked"] += hulls
        stats["hull_proofs"] += proofs
        stats["mesh_checked"] += meshes
        stats["mesh_distances"] += distances
        names = sorted({tuple(sc.pair_names(k)) for k in contact})
        return Verdict(not contact, best, [list(p) for p in names], list(sc.pair_names(nearest)) if nearest >= 0 else None)

    def verdict_of(self, s: Sample) -> Verdict:
        self.decide(s)
        names = sorted({tuple(self.scene.pair_names(int(k))) for k in np.flatnonzero(s.contact)})
        clearance = self.clearance(s)
        nearest = list(self.scene.pair_names(s.nearest)) if s.nearest >= 0 else None
        return Verdict(not bool(np.any(s.contact)), clearance, [list(p) for p in names], nearest)

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
    samples = [checker.sample(q) for q in qs]
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
    for s in res.solutions:
        s.collision = checker.verdict(s.q).to_dict()
    if curves:
        for cv in res.curves.values():
            cv.collision = [split_branch(checker, list(b), bool(cl), polish) for b, cl in zip(cv.branches, cv.closed)]
    dropped = 0
    if collision_free:
        keep = [s for s in res.solutions if s.collision is not None and s.collision["free"]]
        dropped = len(res.solutions) - len(keep)
        res.solutions = keep
        res.stats["solutions"] = len(keep)
    res.scene = scene.spec.to_dict()
    res.stats["collision"] = {
        **scene.summary(),
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
