"""The coordinate formulation of a geometric constraint system: a quadratic :class:`System`.

Unknowns (``docs/constraints.md`` has the full table):

* a free **point**: its coordinates ``p``;
* a free **line**: a unit direction ``d`` and its point closest to the origin ``c`` (``c . d = 0``):
  one representation per line up to the sign of ``d``;
* a free **plane**: a unit normal ``n`` and its offset ``h`` (the plane ``n . x = h``), one
  representation up to the sign of ``(n, h)``;
* a free **body**: a rotation ``R = [u v w]`` (the free rotation of ``docs/formulation.md``:
  core ``|u| = |v| = 1, u . v = 0, w = u x v``) and a translation ``t``; its features are
  ``t + R a`` (points), ``R d`` (directions): linear in the unknowns.

Directions are shared: lines and planes that must be parallel (``parallel``, ``incident``
lines or planes, a line ``perpendicular`` to a plane, parallel distances) use one unit vector,
so ``parallel`` costs nothing. A class of free directions takes its first coordinate in
``[0, 1]``: the sign of a line's direction and of a plane's ``(n, h)`` is not geometry, and
every equation below is invariant under flipping it, so each line and plane is searched once
(a direction with first coordinate 0 may appear twice; the answer merges them). Two parallel
directions that are not free (bodies, fixed entities) get ``u = sigma v`` with a sign variable.

Frame: fixed entities pin it. With none, the first free body is held at its given placement;
with no body either, the points ``a, b, c`` chosen by :func:`formulate` (``pin``) are placed
at ``a = 0``, ``b = (x, 0, 0)`` with ``x >= 0`` and ``c = (x, y, 0)`` with ``y >= 0``: one
representative per proper rigid motion (mirror images stay distinct solutions).

Every row is named ``owner|what``: ``owner`` is a constraint's key (``c3``), ``e:NAME`` for an
entity's own equations or ``b:NAME`` for a body's, so the diagnosis can tell which constraint
a row comes from.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import FormulationError
from ..model.constraints import Constraint, ConstraintSystem, Entity
from .pairs.algebra import kabsch
from .pairs.algebra import vcross as cross
from .pairs.algebra import vdot as dot
from .system import Expr, Scalar, System, as_expr

#: relative padding of auxiliary-variable domains computed by interval evaluation
_PAD = 1e-9


class Numbers:
    """The input's numbers as the builders (this module's and
    :mod:`kinbox.formulation.distance`'s) write them into rows, in binary64. The shadow build of
    :mod:`kinbox.formulation.enclose_constraints` passes the same numbers as
    :class:`~kinbox.formulation.errfloat.EF` (the same values, each with its distance to the
    exact number of the input), so that every row's coefficients carry their rounding."""

    def value(self, m: ConstraintSystem, c: Constraint) -> Any:
        """A distance constraint's value (a squared one's square root)."""
        return m.value(c)

    def trig(self, m: ConstraintSystem, c: Constraint, v: float, sine: bool) -> Any:
        """``sin v`` or ``cos v`` of an angle constraint's value reduced to ``[0, pi/2]``."""
        return math.sin(v) if sine else math.cos(v)

    def snapped(self, m: ConstraintSystem, c: Constraint, row: bool) -> Any:
        """An angle constraint written as parallelism or perpendicularity: the constant added
        to its one row ``u . v = 0`` (``row``: lines or planes perpendicular, a line parallel
        to a plane), 0 here; with ``row`` False the two directions are made one."""
        return 0.0

    def point(self, e: Entity) -> list:
        """A fixed point's (or a body feature's) coordinates, a line's or plane's point."""
        return [float(v) for v in e.point]

    def direction(self, e: Entity) -> list:
        """A fixed line's direction or plane's normal (a body feature's: in the body frame), unit."""
        return [float(v) for v in e.direction]

    def offset(self, e: Entity) -> Any:
        """A plane's offset ``normal . point``."""
        return float(np.dot(e.direction, e.point))

    def sqdist(self, p: np.ndarray, q: np.ndarray) -> Any:
        """The squared distance of two points of the input (fixed, or of one body)."""
        return float(np.sum((np.asarray(p, dtype=float) - np.asarray(q, dtype=float)) ** 2))

    def trilateration(self, P0: np.ndarray) -> tuple[Any, list]:
        """For four anchors with coordinates ``P0``: ``(2 (P0[1:] - P0[0]))^-1`` and the
        constants ``|P0[k]|^2 - |P0[0]|^2`` (k = 1..3)."""
        Minv = np.linalg.inv(2.0 * (P0[1:] - P0[0]))
        return Minv, [float(np.sum(P0[k] ** 2) - np.sum(P0[0] ** 2)) for k in range(1, 4)]


FLOATS = Numbers()


@dataclass
class Geo:
    """World expressions of one entity: a point ``p``; a line's point ``p`` and direction
    ``d``; a plane's normal ``d``, offset ``h`` and (on demand) a point ``p`` of it."""

    type: str
    # (None where the entity's type has no such part: typed Any for brevity)
    p: Any = None
    d: Any = None
    h: Any = None
    #: the direction class (shared unit vector) of a line or plane, if any
    dclass: int | None = None


@dataclass
class Placement:
    """Numbers of one entity in the world: point ``p``, line ``(p, d)``, plane ``(d, h)``."""

    type: str
    # (None where the entity's type has no such part: typed Any for brevity)
    p: Any = None
    d: Any = None
    h: Any = None

    def canonical(self) -> dict | list[float]:
        """JSON form: a point ``[x, y, z]``; a line ``{"point", "direction"}`` with its point
        closest to the origin and a direction whose first non-zero coordinate is positive; a
        plane ``{"point", "normal"}`` likewise (the point is the foot of the origin)."""
        if self.type == "point":
            assert self.p is not None
            return [float(v) for v in self.p]
        d = _sign_canonical(self.d)
        if self.type == "line":
            c = self.p - np.dot(self.p, d) * d
            return {"point": [float(v) for v in c], "direction": [float(v) for v in d]}
        h = float(self.h) * (1.0 if np.dot(d, self.d) > 0 else -1.0)
        return {"point": [float(v) for v in h * d], "normal": [float(v) for v in d]}

    def distance(self, other: Placement) -> float:
        """How far two placements of the same entity are apart (0 for the same set)."""
        if self.type == "point":
            return float(np.max(np.abs(self.p - other.p)))
        a, b = _sign_canonical(self.d), _sign_canonical(other.d)
        if np.dot(a, b) < 0:
            b = -b
        dd = float(np.max(np.abs(a - b)))
        if self.type == "line":
            ca = self.p - np.dot(self.p, a) * a
            cb = other.p - np.dot(other.p, b) * b
            return max(dd, float(np.max(np.abs(ca - cb))))
        ha = float(self.h) * (1.0 if np.dot(a, self.d) > 0 else -1.0)
        hb = float(other.h) * (1.0 if np.dot(b, other.d) > 0 else -1.0)
        return max(dd, abs(ha - hb))


def _sign_canonical(d: np.ndarray) -> np.ndarray:
    d = np.asarray(d, dtype=float)
    d = d / np.linalg.norm(d)
    for v in d:
        if abs(v) > 1e-12:
            return d if v > 0 else -d
    return d


@dataclass
class GeometryFormulation:
    """A constraint system as a quadratic :class:`System`, with the maps between system points
    and entity placements."""

    model: ConstraintSystem
    system: System
    geo: dict[str, Geo]
    #: body name -> (R as 3x3 expressions, t as 3 expressions)
    poses: dict[str, tuple[list[list[Scalar]], list[Scalar]]]
    #: how the frame is pinned, in words
    frame: str
    pinned: dict[str, str] = field(default_factory=dict)
    #: for each variable not read directly from placements: how to compute it from earlier ones
    getters: dict[int, Callable[..., float]] = field(default_factory=dict)
    #: variable index -> how to read it from placements (see :meth:`encode`)
    readers: dict[int, Callable[..., float]] = field(default_factory=dict)
    #: row owner -> constraint index (rows of entities and bodies are not listed)
    owners: dict[str, int] = field(default_factory=dict)
    #: free entity / body name -> its variable indices
    entity_vars: dict[str, list[int]] = field(default_factory=dict)
    radius: dict[str, float] = field(default_factory=dict)
    #: variable index -> its owner: ``e:NAME``, ``b:NAME`` or a constraint key
    var_owner: dict[int, str] = field(default_factory=dict)
    #: labels of angle constraints of binary64 pi (same kinds) or pi/2 (a line and a plane)
    #: written as one shared direction: rows of the rounded angle (the answer's notes)
    rounded_angles: list[str] = field(default_factory=list)

    # ------------------------------------------------------------------------------------------
    def placements(self, x: np.ndarray) -> dict[str, Placement]:
        """World placements of every entity at the system point ``x``."""
        out = {}
        for name, g in self.geo.items():
            p = None if g.p is None else np.array([_val(v, x) for v in g.p])
            d = None if g.d is None else np.array([_val(v, x) for v in g.d])
            h = None if g.h is None else _val(g.h, x)
            out[name] = Placement(g.type, p, d, h)
        return out

    def body_poses(self, x: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        return {
            b: (np.array([[_val(v, x) for v in row] for row in R]), np.array([_val(v, x) for v in t])) for b, (R, t) in self.poses.items()
        }

    def encode(self, places: dict[str, Placement], poses: dict[str, tuple[np.ndarray, np.ndarray]] | None = None) -> np.ndarray:
        """The system point of world placements (and body poses ``name -> (R, t)``; derived from
        the placements of the body's features when missing). Exact up to rounding when the
        placements satisfy the pinning of the frame."""
        poses = dict(poses or {})
        for b in self.poses:
            if b not in poses:
                poses[b] = body_pose(self.model, b, places)
        s = self.system
        x = np.zeros(s.n)
        for i in range(s.n):
            if i in self.readers:
                x[i] = self.readers[i](places, poses)
            elif i in self.getters:
                x[i] = self.getters[i](x)
            else:  # pragma: no cover - a formulation bug
                raise FormulationError(f"internal: no way to encode {s.names[i]!r}")
        return x

    def row_owner(self, row_name: str) -> str:
        return row_name.split("|", 1)[0]


def _val(v: Scalar, x: np.ndarray) -> float:
    return v.value(x) if isinstance(v, Expr) else float(v)


def body_pose(model: ConstraintSystem, body: str, places: dict[str, Placement]) -> tuple[np.ndarray, np.ndarray]:
    """The pose ``(R, t)`` of a body whose features are at ``places``: a least-squares fit
    (Kabsch) of its points, and of the directions of its lines and planes when the points do
    not span a plane (their signs are not geometry: every choice is tried)."""
    b = model.bodies[body]
    la = [model.entities[en].point for en in b.entities if model.entities[en].type == "point"]
    wa = [places[en].p for en in b.entities if model.entities[en].type == "point"]
    dirs = [(model.entities[en].direction, places[en].d) for en in b.entities if model.entities[en].type != "point"]
    best = None
    centred = np.array(la) - np.mean(la, axis=0) if la else np.zeros((0, 3))
    spans = len(la) >= 3 and np.linalg.matrix_rank(centred, tol=1e-9) >= 2
    combos = [()] if spans or not dirs else [tuple(s) for s in np.ndindex(*([2] * len(dirs)))]
    for signs in combos:
        A, B = [], []
        if la:
            ca, cw = np.mean(la, axis=0), np.mean(wa, axis=0)
            A += [a - ca for a in la]
            B += [w - cw for w in wa]
        for (dl, dw), sg in zip(dirs, signs):
            A.append(dl)
            B.append(dw if sg == 0 else -dw)
        R = kabsch(np.array(A), np.array(B))
        err = float(sum(np.sum((R @ a - w) ** 2) for a, w in zip(A, B)))
        if best is None or err < best[0]:
            best = (err, R)
    assert best is not None
    R = best[1]
    pts = [(model.entities[en].point, places[en].p) for en in b.entities if model.entities[en].type == "point"]
    if pts:
        t = np.mean([w - R @ a for a, w in pts], axis=0)
    else:  # lines and planes only: least squares on their offsets
        rows, rhs = [], []
        for en in b.entities:
            e, pl = model.entities[en], places[en]
            n = R @ e.direction
            if e.type == "plane":
                rows.append(n)
                rhs.append(float(np.dot(pl.d, n)) * float(pl.h) - float(np.dot(n, R @ e.point)))
            else:
                P = np.eye(3) - np.outer(n, n)
                rows += list(P)
                rhs += list(P @ (pl.p - R @ e.point))
        t = np.linalg.lstsq(np.array(rows), np.array(rhs), rcond=None)[0]
    return R, t


# ----------------------------------------------------------------------------------------------
# bounds
# ----------------------------------------------------------------------------------------------
def reach(model: ConstraintSystem, pinned: Sequence[str] = ()) -> dict[str, float]:
    """How far from the origin each entity can be (points: ``|p|``; lines and planes: their
    distance to the origin), from fixed entities, pinned points and the constraints; bodies
    (``body:NAME``) bound their origin. ``inf`` where nothing bounds it."""
    inf = math.inf
    r: dict[str, float] = {}
    for n, e in model.entities.items():
        if e.fixed:
            if e.type == "point":
                r[n] = float(np.linalg.norm(e.point))
            elif e.type == "line":
                r[n] = float(np.linalg.norm(e.point - np.dot(e.point, e.direction) * e.direction))
            else:
                r[n] = abs(float(np.dot(e.point, e.direction)))
        else:
            r[n] = inf
    if pinned:
        r[pinned[0]] = 0.0
    for b in model.bodies:
        r["body:" + b] = inf

    def lower(k: str, v: float) -> bool:
        if v < r[k] - 1e-12 * max(1.0, v):
            r[k] = v
            return True
        return False

    for _ in range(2 * len(r) + 2):
        changed = False
        for c in model.constraints:
            a, b = c.entities
            ta, tb = model.types(c)
            v = model.value(c) if c.type == "distance" else 0.0
            if c.type in ("distance", "incident"):
                if ta == "point" and tb == "point":
                    changed |= lower(b, r[a] + v) | lower(a, r[b] + v)
                elif ta == "point":
                    changed |= lower(b, r[a] + v)
                elif tb == "point":
                    changed |= lower(a, r[b] + v)
                elif ta == tb == "plane" or (ta == tb == "line" and c.type == "incident"):
                    changed |= lower(b, r[a] + v) | lower(a, r[b] + v)
                elif ta == "line" and tb == "plane":
                    changed |= lower(b, r[a] + v)
                elif ta == "plane" and tb == "line":
                    changed |= lower(a, r[b] + v)
        for bn, body in model.bodies.items():
            if body.fixed:
                continue
            k = "body:" + bn
            for en in body.entities:
                e = model.entities[en]
                if e.type == "point":
                    changed |= lower(k, r[en] + float(np.linalg.norm(e.point)))
            for en in body.entities:
                e = model.entities[en]
                changed |= lower(en, r[k] + float(np.linalg.norm(e.point)))
        if not changed:
            break
    return r


# ----------------------------------------------------------------------------------------------
# building
# ----------------------------------------------------------------------------------------------
class _Builder:
    def __init__(
        self,
        model: ConstraintSystem,
        pin: Sequence[str] | None,
        substitute: bool,
        frame: bool = True,
        radius: dict[str, float] | None = None,
        fallback_radius: float | None = None,
        numbers: Numbers = FLOATS,
    ):
        self.m = model
        self.num = numbers
        self.s = System()
        self.substitute = substitute
        self.frame = frame
        self.fallback_radius = fallback_radius
        self.var_owner: dict[int, str] = {}
        self.geo: dict[str, Geo] = {}
        self.poses: dict[str, tuple[list[list[Scalar]], list[Scalar]]] = {}
        self.getters: dict[int, Callable[..., float]] = {}
        self.readers: dict[int, Callable[..., float]] = {}
        self.owners: dict[str, int] = {}
        self.entity_vars: dict[str, list[int]] = {}
        self.rounded_angles: list[str] = []
        self.pin = list(pin or [])
        self.anchor_body: str | None = None
        self.radius = dict(radius) if radius is not None else reach(model, self.pin[:1])
        finite = [v for v in self.radius.values() if math.isfinite(v)]
        vals = [model.value(c) for c in model.constraints if c.type == "distance"]
        #: half-width of the box where the feet of common perpendiculars are sought
        self.world = model.bounds if model.bounds is not None else (max(finite, default=1.0) + max(vals, default=1.0))

    # -- variables ---------------------------------------------------------------------------
    def var(self, name: str, lo: float, hi: float, tag: str, owner: str | None = None) -> Expr:
        v = self.s.add_var(name, lo, hi, tag)
        if owner is not None:
            self.entity_vars.setdefault(owner, []).append(self.s.n - 1)
            self.var_owner[self.s.n - 1] = ("b:" if owner in self.m.bodies else "e:") + owner
        return v

    def aux(self, name: str, lo: float, hi: float, owner: str) -> Expr:
        v = self.s.add_var(name, lo, hi, "aux")
        self.var_owner[self.s.n - 1] = owner
        return v

    def bound(self, e: Scalar) -> tuple[float, float]:
        """An interval holding ``e`` over the current domains (padded for rounding)."""
        if not isinstance(e, Expr):
            return float(e), float(e)
        lo = hi = 0.0
        s = self.s
        for k, a in e.terms.items():
            if len(k) == 0:
                tl = th = a
            elif len(k) == 1:
                tl, th = sorted((a * s.lo[k[0]], a * s.hi[k[0]]))
            else:
                i, j = k
                if i == j:
                    ll, hh = s.lo[i], s.hi[i]
                    sq = [ll * ll, hh * hh]
                    pl, ph = (0.0 if ll <= 0 <= hh else min(sq)), max(sq)
                else:
                    prods = [s.lo[i] * s.lo[j], s.lo[i] * s.hi[j], s.hi[i] * s.lo[j], s.hi[i] * s.hi[j]]
                    pl, ph = min(prods), max(prods)
                tl, th = sorted((a * pl, a * ph))
            lo += tl
            hi += th
        pad = _PAD * max(1.0, abs(lo), abs(hi))
        return lo - pad, hi + pad

    def mat(self, e: Scalar, name: str, owner: str) -> Scalar:
        """``e`` itself if it is linear, else a new auxiliary variable defined by it."""
        if not isinstance(e, Expr) or e.degree <= 1:
            return e
        lo, hi = self.bound(e)
        v = self.aux(name, lo, hi, owner)
        idx = self.s.n - 1
        ee = e.copy()
        self.getters[idx] = lambda x, ee=ee: ee.value(x)
        self.eq(v - e, owner, f"def:{name}")
        return v

    def eq(self, e: Scalar, owner: str, what: str, redundant: bool = False) -> None:
        self.s.add_eq(as_expr(e), f"{owner}|{what}", redundant=redundant)

    # -- entities ----------------------------------------------------------------------------
    def build_entities(self) -> None:
        m = self.m
        if not m.has_fixed and self.frame:
            free_bodies = [b for b in m.bodies.values() if not b.fixed]
            if free_bodies:
                self.anchor_body = free_bodies[0].name
            elif len(self.pin) < 3:
                raise FormulationError(
                    f"{m.name}: nothing is fixed and there are not three points to pin the frame (fix an entity or a body)"
                )
        dclass = self._direction_classes()
        self.class_vec: dict[int, list[Scalar]] = {}
        # bodies first: their directions may represent classes
        for bn, b in m.bodies.items():
            if b.fixed:
                continue
            if bn == self.anchor_body:
                R: list[list[Scalar]] = [[1.0 if r == k else 0.0 for k in range(3)] for r in range(3)]
                t: list[Scalar] = [0.0, 0.0, 0.0]
            else:
                R, t = self._free_body(bn)
            self.poses[bn] = (R, t)
            for en in b.entities:
                e = m.entities[en]
                p = [t[k] + dot(R[k], self.num.point(e)) for k in range(3)]
                if e.type == "point":
                    self.geo[en] = Geo("point", p=p)
                else:
                    d = [dot(R[k], self.num.direction(e)) for k in range(3)]
                    g = Geo(e.type, p=p, d=d)
                    if e.type == "plane":
                        # h = n . (t + R p0) = (R n0) . t + n0 . p0, using R^T R = I
                        g.h = dot(d, t) + self.num.offset(e)
                    self.geo[en] = g
        for en, e in m.entities.items():
            if e.body is not None:
                continue
            if e.fixed:
                p = self.num.point(e)
                if e.type == "point":
                    self.geo[en] = Geo("point", p=p)
                else:
                    d = self.num.direction(e)
                    self.geo[en] = Geo(e.type, p=p, d=d, h=self.num.offset(e) if e.type == "plane" else None)
                continue
            self.geo[en] = self._free_entity(e)
        # direction classes: a shared vector per class
        for slot, k in dclass.items():
            self.geo[slot].dclass = k
        self._resolve_classes(dclass)

    def _rad(self, name: str, what: str) -> float:
        r = self.radius.get(name, math.inf)
        if self.m.bounds is not None:
            r = min(r, self.m.bounds * math.sqrt(3.0))
        if not math.isfinite(r) and self.fallback_radius is not None:
            r = self.fallback_radius
        if not math.isfinite(r):
            raise FormulationError(
                f"{what} {name.removeprefix('body:')!r}: nothing bounds where it can be (no distance or incidence "
                'ties it to a fixed or pinned entity): give "bounds" (half-width of the world box) in the file'
            )
        return r

    def _free_body(self, bn: str):
        rb = self._rad("body:" + bn, "body")
        # column by column (u, v, w), as the free rotations of mechanisms (docs/formulation.md)
        cols = [[self.var(f"{bn}.R[{r},{k}]", -1.0, 1.0, "rot", bn) for r in range(3)] for k in range(3)]
        Rv = [[cols[k][r] for k in range(3)] for r in range(3)]
        for k in range(3):
            for r in range(3):
                idx = self.s.n - 9 + 3 * k + r
                self.readers[idx] = lambda pl, po, bn=bn, r=r, k=k: float(po[bn][0][r, k])
        t = [self.var(f"{bn}.t[{k}]", -rb, rb, "pos", bn) for k in range(3)]
        for k in range(3):
            self.readers[self.s.n - 3 + k] = lambda pl, po, bn=bn, k=k: float(po[bn][1][k])
        u = [Rv[r][0] for r in range(3)]
        v = [Rv[r][1] for r in range(3)]
        w = [Rv[r][2] for r in range(3)]
        own = "b:" + bn
        self.eq(dot(u, u) - 1.0, own, "|u|")
        self.eq(dot(v, v) - 1.0, own, "|v|")
        self.eq(dot(u, v), own, "u.v")
        uxv = cross(u, v)
        for k in range(3):
            self.eq(w[k] - uxv[k], own, f"w{k}")
        self.eq(dot(w, w) - 1.0, own, "|w|", redundant=True)
        self.eq(dot(u, w), own, "u.w", redundant=True)
        self.eq(dot(v, w), own, "v.w", redundant=True)
        return [list(row) for row in Rv], t

    def _free_entity(self, e: Entity) -> Geo:
        n = e.name
        if e.type == "point":
            r = self._rad(n, "point")
            if n in self.pin[:1]:
                return Geo("point", p=[0.0, 0.0, 0.0])
            if len(self.pin) >= 2 and n == self.pin[1]:
                x = self.var(f"{n}.x", 0.0, r, "pos", n)
                self.readers[self.s.n - 1] = lambda pl, po, n=n: float(pl[n].p[0])
                return Geo("point", p=[x, 0.0, 0.0])
            if len(self.pin) >= 3 and n == self.pin[2]:
                x = self.var(f"{n}.x", -r, r, "pos", n)
                self.readers[self.s.n - 1] = lambda pl, po, n=n: float(pl[n].p[0])
                y = self.var(f"{n}.y", 0.0, r, "pos", n)
                self.readers[self.s.n - 1] = lambda pl, po, n=n: float(pl[n].p[1])
                return Geo("point", p=[x, y, 0.0])
            p = []
            for k, c in enumerate("xyz"):
                p.append(self.var(f"{n}.{c}", -r, r, "pos", n))
                self.readers[self.s.n - 1] = lambda pl, po, n=n, k=k: float(pl[n].p[k])
            return Geo("point", p=p)
        r = self._rad(n, e.type)
        if e.type == "line":
            cpt: list[Scalar] = []
            for k, ch in enumerate("xyz"):
                cpt.append(self.var(f"{n}.c{ch}", -r, r, "pos", n))

                def read(pl, po, n=n, k=k):
                    q = pl[n]
                    d = q.d / np.linalg.norm(q.d)
                    return float((q.p - np.dot(q.p, d) * d)[k])

                self.readers[self.s.n - 1] = read
            return Geo("line", p=cpt)
        h = self.var(f"{n}.h", -r, r, "pos", n)
        self.readers[self.s.n - 1] = lambda pl, po, n=n: self._plane_h(n, pl, po)
        return Geo("plane", h=h)

    def _plane_h(self, n: str, pl: dict, po: dict) -> float:
        """A free plane's offset, with the sign of its class vector."""
        q = pl[n]
        d = q.d / np.linalg.norm(q.d)
        ref = self._class_direction(self.geo[n].dclass, pl, po)
        return float(q.h) * (1.0 if np.dot(d, ref) >= 0 else -1.0) / float(np.linalg.norm(q.d))

    def _class_direction(self, k: int | None, pl: dict, po: dict) -> np.ndarray:
        """The value of class ``k``'s vector for placements ``pl`` and body poses ``po``: the
        direction of its body or fixed member if it has one, else of its first free member with
        its first coordinate made non-negative."""
        assert k is not None
        given = self.class_given.get(k)
        if given is not None:
            e = self.m.entities[given]
            return e.direction if e.body is None else po[e.body][0] @ e.direction
        first = self.class_first[k]
        d = pl[first].d / np.linalg.norm(pl[first].d)
        return d if d[0] >= 0 or not self.substitute else -d

    def _direction_classes(self) -> dict[str, int]:
        """Union-find of the direction slots of lines and planes tied by parallelism."""
        parent: dict[str, str] = {}
        m = self.m
        slots = [n for n, e in m.entities.items() if e.type in ("line", "plane")]
        for n in slots:
            parent[n] = n

        def find(a):
            while parent[a] != a:
                parent[a] = parent[parent[a]]
                a = parent[a]
            return a

        self.merged_by: dict[tuple[str, str], Constraint] = {}
        if self.substitute:
            for c in m.constraints:
                if self._parallel_kind(c):
                    a, b = c.entities
                    ra, rb = find(a), find(b)
                    if ra != rb:
                        parent[rb] = ra
                        self.merged_by[(a, b)] = c
        roots: dict[str, int] = {}
        out = {}
        for n in slots:
            out[n] = roots.setdefault(find(n), len(roots))
        return out

    def _parallel_kind(self, c: Constraint) -> bool:
        """Does ``c`` make the two direction slots equal (up to sign)?"""
        ta, tb = self.m.types(c)
        if "point" in (ta, tb):
            return False
        if c.type == "parallel":
            return ta == tb
        if c.type == "perpendicular":
            return ta != tb
        if c.type == "incident":
            return ta == tb
        if c.type == "distance":
            return ta == tb == "plane"
        if c.type == "angle":
            v = self.m.value(c)
            a = min(v, math.pi - v)
            return (ta == tb and a == 0.0) or (ta != tb and a == math.pi / 2)
        return False

    def _resolve_classes(self, dclass: dict[str, int]) -> None:
        members: dict[int, list[str]] = {}
        for n, k in dclass.items():
            members.setdefault(k, []).append(n)
        self.class_first: dict[int, str] = {}
        self.class_given: dict[int, str] = {}
        for k, names in members.items():
            given = [n for n in names if self.geo[n].d is not None]  # body or fixed
            free = [n for n in names if self.geo[n].d is None]
            if given:
                self.class_given[k] = given[0]
                rep = self.geo[given[0]].d
                for other in given[1:]:
                    c = self._merging_constraint(other, names)
                    self._sigma(rep, self.geo[other].d, c.key if c else "e:" + other, f"{given[0]}~{other}")
            if free:
                self.class_first[k] = free[0]
            if not free:
                continue
            if given:
                vec = rep
            else:
                stem = free[0]
                vec = []
                for i, ch in enumerate("xyz"):
                    lo = 0.0 if i == 0 and self.substitute else -1.0  # the sign quotient (module docstring)
                    vec.append(self.var(f"{stem}.d{ch}", lo, 1.0, "unit", stem))
                    self.readers[self.s.n - 1] = lambda pl, po, k=k, i=i: float(self._class_direction(k, pl, po)[i])
                self.eq(dot(vec, vec) - 1.0, "e:" + stem, "|d|")
            for n in free:
                g = self.geo[n]
                g.d = vec
                if g.type == "line":
                    self.eq(dot(g.p, vec), "e:" + n, "c.d")

    def _merging_constraint(self, a: str, names: list[str]) -> Constraint | None:
        for (x, y), c in self.merged_by.items():
            if a in (x, y):
                return c
        return None

    def _sigma(self, u: Sequence[Scalar], v: Sequence[Scalar], owner: str, stem: str) -> None:
        """``v = sigma u`` for unit vectors given by expressions (parallel, either sense)."""
        sg = self.aux(f"{owner}.sigma[{stem}]", -1.0, 1.0, owner)
        idx = self.s.n - 1
        uu, vv = [as_expr(a) for a in u], [as_expr(b) for b in v]
        self.getters[idx] = lambda x, uu=uu, vv=vv: 1.0 if sum(a.value(x) * b.value(x) for a, b in zip(uu, vv)) >= 0 else -1.0
        for k in range(3):
            self.eq(v[k] - sg * u[k], owner, f"sigma{k}")
        self.eq(sg * sg - 1.0, owner, "sigma^2", redundant=True)

    # -- helpers for constraints -----------------------------------------------------------
    def plane_point(self, n: str, owner: str) -> list[Scalar]:
        """A point of plane ``n`` (linear expressions; a free plane's ``h n`` materialized)."""
        g = self.geo[n]
        if g.p is None:
            g.p = [self.mat(g.h * g.d[k], f"{n}.a{'xyz'[k]}", "e:" + n) for k in range(3)]
        return g.p

    def parallel(self, a: str, b: str, c: Constraint) -> None:
        ga, gb = self.geo[a], self.geo[b]
        if ga.dclass is not None and ga.dclass == gb.dclass and self.substitute:
            return  # the same vector (or a sign equation made when the class was built)
        self._sigma(ga.d, gb.d, c.key, f"{a}~{b}")

    def same_direction(self, a: str, b: str) -> bool:
        ga, gb = self.geo[a], self.geo[b]
        return self.substitute and ga.dclass is not None and ga.dclass == gb.dclass

    def build_constraint(self, c: Constraint) -> None:
        m = self.m
        a, b = c.entities
        ta, tb = m.types(c)
        order = {"point": 0, "line": 1, "plane": 2}
        if order[ta] > order[tb]:
            a, b, ta, tb = b, a, tb, ta
        own = c.key
        self.owners[own] = c.index
        A, B = self.geo[a], self.geo[b]
        v = self.num.value(m, c) if c.type == "distance" else m.value(c) if c.type == "angle" else 0.0
        typ = c.type
        snap: Any = 0.0  # an angle's row as one of u . v = 0: what the exact angle adds (Numbers.snapped)
        if typ == "angle":
            v = min(v, math.pi - v)
            if v == 0.0:
                typ = "parallel"
            elif v == math.pi / 2:
                typ = "perpendicular"
            if typ != "angle":
                row = (typ == "perpendicular") == (ta == tb)
                snap = self.num.snapped(m, c, row)
                if not row and m.value(c) != 0.0:
                    self.rounded_angles.append(c.label)
        if typ == "distance" and v == 0.0 and not (ta == tb == "line"):
            typ = "incident"
        pair = (ta, tb)
        if typ == "distance":
            if pair == ("point", "point"):
                w = [A.p[k] - B.p[k] for k in range(3)]
                if not (self.m.entities[a].body or self.m.entities[b].body):
                    # (between body points, t + R q - p, the search was ten times slower with them:
                    # Dietmeier's platform, benchmarks/constraints.py)
                    w = self.edge(own, w, v)
                self.eq(dot(w, w) - v * v, own, "dist")
            elif pair == ("point", "line"):
                w = [A.p[k] - B.p[k] for k in range(3)]
                # a free line's point is its foot from the origin (c . d = 0 is core): the
                # projection (p - c) . d is p . d, linear when p is fixed
                proj = dot(A.p, B.d) if self.m.entities[b].free else dot(w, B.d)
                s = self.mat(proj, f"{own}.s", own)
                self.eq(dot(w, w) - s * s - v * v, own, "dist")
            elif pair == ("point", "plane"):
                s = self.mat(dot(B.d, A.p) - B.h, f"{own}.s", own)
                self.eq(s * s - v * v, own, "dist")
            elif pair == ("line", "line"):
                self._line_line_distance(c, a, b, v)
            elif pair == ("line", "plane"):
                self.eq(dot(A.d, B.d), own, "par")
                s = self.mat(dot(B.d, A.p) - B.h, f"{own}.s", own)
                self.eq(s * s - v * v, own, "dist")
            else:
                self.parallel(a, b, c)
                off = B.h - A.h if self.same_direction(a, b) else dot(A.d, self.plane_point(b, own)) - A.h
                s = self.mat(off, f"{own}.s", own)
                self.eq(s * s - v * v, own, "dist")
        elif typ == "angle":
            val = self.num.trig(m, c, v, pair == ("line", "plane"))
            s = self.mat(dot(A.d, B.d), f"{own}.s", own)
            self.eq(s * s - val * val, own, "angle")
        elif typ == "incident":
            if pair == ("point", "point"):
                for k in range(3):
                    self.eq(A.p[k] - B.p[k], own, f"on{k}")
            elif pair == ("point", "line"):
                self._on_line(own, A.p, b, "")
            elif pair == ("point", "plane"):
                self.eq(dot(B.d, A.p) - B.h, own, "on")
            elif pair == ("line", "line"):
                self.parallel(a, b, c)
                self._on_line(own, A.p, b, "")
            elif pair == ("line", "plane"):
                self.eq(dot(A.d, B.d), own, "par")
                self.eq(dot(B.d, A.p) - B.h, own, "on")
            else:
                self.parallel(a, b, c)
                off = B.h - A.h if self.same_direction(a, b) else dot(A.d, self.plane_point(b, own)) - A.h
                self.eq(off, own, "on")
        elif typ == "parallel":
            if ta == tb:
                self.parallel(a, b, c)
            else:
                self.eq(dot(A.d, B.d) + snap, own, "par")
        elif typ == "perpendicular":
            if ta == tb:
                self.eq(dot(A.d, B.d) + snap, own, "perp")
            else:
                self.parallel(a, b, c)
        else:  # pragma: no cover - the model validated the type
            raise FormulationError(f"constraint {c.label}: unknown type")

    def edge(self, own: str, w: list[Scalar], v: float) -> list[Scalar]:
        """The vector ``w`` between two points at distance ``v`` as variables in ``[-v, v]`` (linear
        definitions): the distance equation then has only squares of single variables, whose
        relaxations are tight, and the definitions carry the bounds back to the points."""
        out: list[Scalar] = []
        for k in range(3):
            e = as_expr(w[k])
            if e.degree == 0:
                out.append(e.constant)
                continue
            lo, hi = self.bound(e)
            pad = _PAD * max(1.0, v)
            var = self.aux(f"{own}.w{'xyz'[k]}", max(lo, -v - pad), min(hi, v + pad), own)
            idx = self.s.n - 1
            ee = e.copy()
            self.getters[idx] = lambda x, ee=ee: ee.value(x)
            self.eq(var - e, own, f"def:w{'xyz'[k]}")
            out.append(var)
        return out

    def _on_line(self, own: str, p: Sequence[Scalar], line: str, tag: str) -> None:
        """``p = c + t d``: the point ``p`` on ``line`` (3 equations, one variable ``t``)."""
        L = self.geo[line]
        w = [as_expr(p[k]) - L.p[k] for k in range(3)]
        lo, hi = self.bound(dot(w, L.d))
        t = self.aux(f"{own}.t{tag}", lo, hi, own)
        idx = self.s.n - 1
        ew, ed = [e.copy() for e in w], [as_expr(e) for e in L.d]
        self.getters[idx] = lambda x, ew=ew, ed=ed: sum(a.value(x) * b.value(x) for a, b in zip(ew, ed))
        for k in range(3):
            self.eq(w[k] - t * L.d[k], own, f"on{k}{tag}")

    def _line_line_distance(self, c: Constraint, a: str, b: str, v: float) -> None:
        own = c.key
        A, B = self.geo[a], self.geo[b]
        if self.same_direction(a, b) or self._explicitly_parallel(a, b):
            w = [B.p[k] - A.p[k] for k in range(3)]
            if self.same_direction(a, b) and self.m.entities[a].free and self.m.entities[b].free:
                self.eq(dot(w, w) - v * v, own, "dist")  # both feet from the origin: w . d = 0
                return
            s = self.mat(dot(w, A.d), f"{own}.s", own)
            self.eq(dot(w, w) - s * s - v * v, own, "dist")
            return
        # feet of the common perpendicular, sought in the world box
        W = self.world * math.sqrt(3.0)
        feet = []
        for tag, G, other in (("1", A, B), ("2", B, A)):
            lo, hi = self.bound(G.p[0])
            rc = max(abs(lo), abs(hi)) * math.sqrt(3.0)
            t = self.aux(f"{own}.t{tag}", -(W + rc), W + rc, own)
            idx = self.s.n - 1
            Gp, Gd = [as_expr(e) for e in G.p], [as_expr(e) for e in G.d]
            Op, Od = [as_expr(e) for e in other.p], [as_expr(e) for e in other.d]

            def foot(x, Gp=Gp, Gd=Gd, Op=Op, Od=Od):
                p1, d1 = np.array([e.value(x) for e in Gp]), np.array([e.value(x) for e in Gd])
                p2, d2 = np.array([e.value(x) for e in Op]), np.array([e.value(x) for e in Od])
                k = float(np.dot(d1, d2))
                den = 1.0 - k * k
                return 0.0 if den < 1e-14 else float(np.dot(p2 - p1, d1 - k * d2) / den)

            self.getters[idx] = foot
            f = [self.mat(G.p[k] + t * G.d[k], f"{own}.f{tag}{'xyz'[k]}", own) for k in range(3)]
            feet.append(f)
        w = [feet[1][k] - feet[0][k] for k in range(3)]
        self.eq(dot(w, A.d), own, "perp1")
        self.eq(dot(w, B.d), own, "perp2")
        self.eq(dot(w, w) - v * v, own, "dist")

    def _explicitly_parallel(self, a: str, b: str) -> bool:
        for c in self.m.constraints:
            if set(c.entities) == {a, b} and self._parallel_kind(c):
                return True
        return False


def formulate(
    model: ConstraintSystem,
    pin: Sequence[str] | None = None,
    substitute: bool = True,
    frame: bool = True,
    radius: dict[str, float] | None = None,
    fallback_radius: float | None = None,
    numbers: Numbers = FLOATS,
) -> GeometryFormulation:
    """The coordinate formulation of ``model``.

    ``pin``: the points that pin the frame when nothing is fixed and there is no body (``a, b,
    c``: see the module docstring); default: the first three free points. ``substitute=False``
    writes every parallelism as equations of its own constraint (the diagnosis needs each
    constraint's rows); the default shares direction vectors. ``numbers``: the input's numbers
    as the rows take them (:class:`Numbers`; the shadow build's enclosures).
    """
    if not frame:
        pin = []
    elif pin is None and not model.has_fixed and not any(not b.fixed for b in model.bodies.values()):
        pin = [n for n, e in model.entities.items() if e.type == "point" and e.free][:3]
    b = _Builder(model, pin if pin else None, substitute, frame, radius, fallback_radius, numbers)
    b.build_entities()
    for c in model.constraints:
        b.build_constraint(c)
    pinned: dict[str, str] = {}
    if not b.frame:
        desc = "none (every rigid motion of a solution is a solution)"
    elif b.anchor_body:
        desc = f"body {b.anchor_body!r} is held at its given placement (nothing is fixed)"
    elif b.pin and not model.has_fixed:
        p = b.pin
        desc = (
            f"{p[0]!r} at the origin, {p[1]!r} on the +x axis, {p[2]!r} in the xy plane with y >= 0 "
            "(nothing is fixed: one representative per rigid motion; mirror images are distinct)"
        )
        pinned = {p[0]: "origin", p[1]: "+x axis", p[2]: "xy plane, y >= 0"}
    else:
        desc = "fixed entities"
    return GeometryFormulation(
        model, b.s, b.geo, b.poses, desc, pinned, b.getters, b.readers, b.owners, b.entity_vars, b.radius, b.var_owner, b.rounded_angles
    )


def square_core(system: System, x: np.ndarray) -> int:
    """Make the core square when constraints are redundant: keep, in order, the core rows that
    raise the rank of the Jacobian at the solution ``x`` (entity and body rows come first, then
    constraints in file order) and turn the others into redundant equations, which still prune
    but are left out of Krawczyk's square system. Returns how many rows were moved. (A root of
    the smaller core that misses a moved row is no solution: the answer checks every
    constraint on the placements.)"""
    comp = system.compile()
    if comp.n_core <= system.n:
        return 0
    J = comp.jacobian(x, slice(0, comp.n_core))
    names = comp.row_names[: comp.n_core]
    order = sorted(range(comp.n_core), key=lambda r: (0 if names[r].startswith(("e:", "b:")) else 1, r))
    keep: list[int] = []
    basis = np.zeros((0, system.n))
    scale = max(1.0, float(np.max(np.abs(J), initial=0.0)))
    for r in order:
        row = J[r]
        if basis.shape[0]:
            resid = row - basis.T @ (basis @ row)
        else:
            resid = row
        nr = float(np.linalg.norm(resid))
        if nr > 1e-8 * scale * max(1.0, float(np.linalg.norm(row))):
            keep.append(r)
            basis = np.vstack([basis, resid / nr])
        if len(keep) == system.n:
            break
    drop = {names[r] for r in range(comp.n_core) if r not in keep}
    moved = 0
    for c in system.constraints:
        if c.kind == "core" and c.name in drop:
            c.kind = "redundant"
            moved += 1
    system.invalidate()
    return moved
