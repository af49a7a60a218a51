"""The distance formulation of Porta et al. 2005 and Porta et al. 2003: unknown squared distances
under Cayley-Menger conditions, embedded back to coordinates.

Scope: systems of **points** (free, fixed, or features of bodies made of points) and **free
lines** under **distances** point-point and point-line. Every entity becomes points with
squared distances ``r_ij`` between them, known (constraints, fixed points, bodies) or not:

* a line ``L`` becomes two points ``L.a``, ``L.b`` a unit apart; ``L.a`` is the foot of the
  perpendicular from the first point ``q`` with a distance ``v`` to ``L`` (``r(q,a) = v^2``,
  ``r(q,b) = v^2 + 1``: the right triangle of Porta et al. 2005, Sec. V-B); every other point at distance
  ``v'`` from ``L`` gives Eq. (5), ``Xi(q', a, b) + 4 v'^2 = 0``;
* four **anchor** points, chosen to share as many known distances as possible (fixed points
  first), span the frame; the unknowns are the distances among anchors and from every other
  point to the anchors that are not known;
* core equations: ``Xi(anchors + v) = 0`` for every other point ``v`` (five points,
  condition R3), ``Xi(three anchors + v + w) = 0`` for every known distance between two
  non-anchors (when the anchors are fixed points, the equivalent ``|y_v - y_w|^2 = r_vw`` of
  their trilateration: quadratic, where the determinant has degree four), Eq. (5) for lines.
  (The six-point conditions ``Xi(anchors + v + w) = 0`` of Porta et al. 2005 vanish to second order on
  every configuration of 3-D: their Jacobian is singular at every solution, so they only
  prune, as redundant equations.) They are as many as the unknowns for a well-constrained
  system (``3N - 6`` known distances); when there are more (redundant constraints, rigid
  bodies) a square subset of full rank at a solution (or a random realization) is the core and
  the rest are redundant equations, as are further Cayley-Menger conditions of five points
  (they prune, as Porta et al. 2005, Table I, shows) and ``Xi`` of the anchor triangles and tetrahedron give
  the inequalities R1, R2 -- those of them that need no monomial variable of their own.

Determinants are expanded exactly into polynomials of the unknowns; monomials of degree above
two become auxiliary variables (products of two lower ones), so the system is the quadratic
:class:`~kinbox.formulation.system.System` the solver handles.

**Embedding**: the anchors are placed by coordinates (fixed ones where they are; else the first
at the origin, the second on the x axis, the third in the xy plane, the fourth above or below
it: both mirror images), every other point by trilateration from the anchors (a linear solve),
then the whole is moved onto the fixed points (or the held body, or the pinned frame of the
coordinate formulation). A distance solution whose embedding fails (a negative squared height:
Cayley-Menger conditions R1-R2 violated, or distances not met in 3-D) is counted in
``not_embeddable`` and dropped.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..errors import FormulationError
from ..model.constraints import ConstraintSystem
from .errfloat import EF, err, keep
from .geometry import FLOATS, GeometryFormulation, Numbers, Placement
from .pairs.algebra import kabsch
from .system import Expr, System

Poly = dict[tuple[int, ...], float]
#: at most this many extra five-point conditions are added as redundant equations
MAX_REDUNDANT = 40
#: an embedding is kept when every known distance holds to this (relative) accuracy
EMBED_TOL = 1e-6


def supports(model: ConstraintSystem) -> str | None:
    """None if the distance formulation applies to ``model``, else why not (one line)."""
    for n, e in model.entities.items():
        if e.type == "plane":
            return f"entity {n!r} is a plane (the distance formulation takes points and lines)"
        if e.type == "line" and not e.free:
            return f"line {n!r} is fixed or a body's feature (the distance formulation takes free lines)"
    lines_with_anchor = set()
    for c in model.constraints:
        ta, tb = model.types(c)
        if c.type != "distance":
            return f"constraint {c.label} is not a distance"
        if ta == tb == "line":
            return f"constraint {c.label} is a distance between lines"
        if model.value(c) == 0.0:
            return f"constraint {c.label} has distance 0 (an incidence)"
        for n in c.entities:
            if model.entities[n].type == "line":
                lines_with_anchor.add(n)
    for n, e in model.entities.items():
        if e.type == "line" and n not in lines_with_anchor:
            return f"line {n!r} has no distance to a point"
    ref = _reference_points(model)
    if ref is not None and len(ref) > 0:
        P = np.array([p for _, p in ref])
        if len(ref) < 3 or np.linalg.matrix_rank(P[1:] - P[0], tol=1e-9) < 2:
            return "the fixed points do not pin the frame (fewer than three, or on one line)"
    return None


def _reference_points(model: ConstraintSystem) -> list[tuple[str, np.ndarray]] | None:
    """Points with known world coordinates: fixed points, or the points of the body the
    coordinate formulation holds when nothing is fixed; None when the frame is pinned by
    three free points."""
    if model.has_fixed:
        out = [(n, e.point) for n, e in model.entities.items() if e.fixed and e.type == "point"]
        return out
    free_bodies = [b for b in model.bodies.values() if not b.fixed]
    if free_bodies:
        b = free_bodies[0]
        return [(n, model.entities[n].point) for n in b.entities if model.entities[n].type == "point"]
    return None


# ----------------------------------------------------------------------------------------------
# polynomials
# ----------------------------------------------------------------------------------------------
def _pmul(a: Poly, b: Poly) -> Poly:
    out: Poly = {}
    for ka, va in a.items():
        for kb, vb in b.items():
            k = tuple(sorted(ka + kb))
            out[k] = out.get(k, 0.0) + va * vb
    return {k: v for k, v in out.items() if keep(v)}


def _padd(a: Poly, b: Poly, s: float = 1.0) -> Poly:
    out = dict(a)
    for k, v in b.items():
        out[k] = out.get(k, 0.0) + s * v
    return {k: v for k, v in out.items() if keep(v)}


def determinant(M: list[list[Poly]]) -> Poly:
    """The determinant of a matrix of polynomials (Laplace expansion along the first row,
    skipping zero entries; fine for the 6x6 and 7x7 bordered Cayley-Menger matrices)."""
    n = len(M)
    memo: dict[tuple[int, frozenset], Poly] = {}

    def rec(row: int, cols: frozenset) -> Poly:
        if row == n:
            return {(): 1.0}
        key = (row, cols)
        if key in memo:
            return memo[key]
        acc: Poly = {}
        order = sorted(cols)
        for pos, c in enumerate(order):
            e = M[row][c]
            if not e:
                continue
            sub = rec(row + 1, cols - {c})
            if not sub:
                continue
            acc = _padd(acc, _pmul(e, sub), -1.0 if pos % 2 else 1.0)
        memo[key] = acc
        return acc

    return rec(0, frozenset(range(n)))


# ----------------------------------------------------------------------------------------------
@dataclass
class DistanceFormulation:
    model: ConstraintSystem
    system: System
    geometry: GeometryFormulation
    #: point names (entities' points, then line points ``L.a``, ``L.b``)
    points: list[str]
    anchors: list[int]
    #: known squared distances by point-index pair (i < j)
    known: dict[tuple[int, int], float]
    #: unknown squared distances: pair -> system variable index
    unknown: dict[tuple[int, int], int]
    fixed_coords: dict[int, np.ndarray] = field(default_factory=dict)

    def r(self, x: np.ndarray, i: int, j: int) -> float:
        if i == j:
            return 0.0
        k = (min(i, j), max(i, j))
        if k in self.known:
            return self.known[k]
        return float(x[self.unknown[k]])

    # -- embedding ------------------------------------------------------------------------------
    def embed(self, x: np.ndarray) -> list[np.ndarray]:
        """Coordinates of every point (rows, in :attr:`points` order) for the distances at
        ``x``, in the frame of the coordinate formulation: one array per embedding (two for
        mirror images), none if the distances do not embed in 3-D."""
        A = self.anchors
        n = len(self.points)
        tol = EMBED_TOL * max(1.0, max((abs(v) for v in self.known.values()), default=1.0))
        if all(a in self.fixed_coords for a in A):
            bases = [np.array([self.fixed_coords[a] for a in A])]
        else:
            bases = _anchor_frames([[self.r(x, a, b) for b in A] for a in A], tol)
        out = []
        for base in bases:
            Y = np.zeros((n, 3))
            ok = True
            for k, a in enumerate(A):
                Y[a] = base[k]
            M = 2.0 * (base[1:] - base[0])
            try:
                Minv = np.linalg.inv(M)
            except np.linalg.LinAlgError:
                continue
            for v in range(n):
                if v in A:
                    continue
                rv = np.array([self.r(x, v, a) for a in A])
                rhs = (np.sum(base[1:] ** 2, axis=1) - np.sum(base[0] ** 2)) - (rv[1:] - rv[0])
                Y[v] = Minv @ rhs
            # every distance the system knows or found must hold in 3-D
            for (i, j), rr in list(self.known.items()) + [(k, float(x[ix])) for k, ix in self.unknown.items()]:
                if abs(float(np.sum((Y[i] - Y[j]) ** 2)) - rr) > EMBED_TOL * max(1.0, abs(rr)):
                    ok = False
                    break
            if ok:
                out.extend(self._align(Y))
        uniq: list[np.ndarray] = []
        for Y in out:
            if not any(np.max(np.abs(Y - U)) < 1e-9 * max(1.0, float(np.max(np.abs(Y)))) for U in uniq):
                uniq.append(Y)
        return uniq

    def _align(self, Y: np.ndarray) -> list[np.ndarray]:
        """Move an embedding onto the frame of the coordinate formulation (both the embedding and
        its mirror image are tried where the reference allows)."""
        geo = self.geometry
        ref = _reference_points(self.model)
        idx = {p: i for i, p in enumerate(self.points)}
        cands = [Y, Y * np.array([1.0, 1.0, -1.0])]
        res = []
        if ref is None:  # the pinned frame: a at 0, b on +x, c in the xy plane with y >= 0
            a, b, c = (idx[p] for p in list(geo.pinned))
            for Z in cands:
                Z = Z - Z[a]
                e1 = Z[b] / np.linalg.norm(Z[b])
                w = Z[c] - np.dot(Z[c], e1) * e1
                e2 = w / np.linalg.norm(w)
                e3 = np.cross(e1, e2)
                R = np.array([e1, e2, e3])
                res.append(Z @ R.T)
            return res
        P = np.array([p for _, p in ref])
        I = [idx[n] for n, _ in ref]
        for Z in cands:
            Q = Z[I]
            cp, cq = P.mean(axis=0), Q.mean(axis=0)
            R = kabsch(Q - cq, P - cp)
            Z2 = (Z - cq) @ R.T + cp
            if np.max(np.abs(Z2[I] - P)) <= 1e-6 * max(1.0, float(np.max(np.abs(P)))):
                res.append(Z2)
        return res

    def placements(self, Y: np.ndarray) -> tuple[dict[str, Placement], dict]:
        idx = {p: i for i, p in enumerate(self.points)}
        places: dict[str, Placement] = {}
        for n, e in self.model.entities.items():
            if e.type == "point":
                places[n] = Placement("point", Y[idx[n]].copy())
            else:
                a, b = Y[idx[n + ".a"]], Y[idx[n + ".b"]]
                places[n] = Placement("line", a.copy(), (b - a) / np.linalg.norm(b - a))
        from .geometry import body_pose

        poses = {b: body_pose(self.model, b, places) for b, body in self.model.bodies.items() if not body.fixed}
        return places, poses


def _anchor_frames(r: list[list[float]], tol: float) -> list[np.ndarray]:
    """Coordinates of four points from their squared distances: the first at 0, the second on
    +x, the third in the xy plane (y >= 0), the fourth with z >= 0 and z <= 0."""
    d01 = r[0][1]
    if d01 < -tol:
        return []
    a1 = math.sqrt(max(d01, 0.0))
    if a1 <= 0:
        return []
    x2 = (r[0][2] + d01 - r[1][2]) / (2 * a1)
    y2s = r[0][2] - x2 * x2
    if y2s < -tol:
        return []
    y2 = math.sqrt(max(y2s, 0.0))
    if y2 <= 0:
        return []
    x3 = (r[0][3] + d01 - r[1][3]) / (2 * a1)
    y3 = (r[0][3] + x2 * x2 + y2 * y2 - r[2][3] - 2 * x2 * x3) / (2 * y2)
    z3s = r[0][3] - x3 * x3 - y3 * y3
    if z3s < -tol:
        return []
    z3 = math.sqrt(max(z3s, 0.0))
    base = np.array([[0, 0, 0], [a1, 0, 0], [x2, y2, 0], [x3, y3, z3]], dtype=float)
    if z3 == 0.0:
        return [base]
    mir = base.copy()
    mir[3, 2] = -z3
    return [base, mir]


# ----------------------------------------------------------------------------------------------
class _Builder:
    def __init__(self, model: ConstraintSystem, geo: GeometryFormulation, numbers: Numbers = FLOATS):
        self.m = model
        self.num = numbers
        self.geo = geo
        self.s = System()
        self.points: list[str] = []
        self.coords: dict[int, np.ndarray] = {}  # known coordinates (fixed points)
        self.body_of: dict[int, str] = {}
        self.known: dict[tuple[int, int], float] = {}
        self.line_eqs: list[tuple[int, int, int, float, str]] = []  # (q, a, b, v, label)
        self.mono: dict[tuple[int, ...], Expr] = {}

    def pid(self, name: str) -> int:
        if name not in self.points:
            self.points.append(name)
        return self.points.index(name)

    def know(self, i: int, j: int, r: float) -> None:
        k = (min(i, j), max(i, j))
        if k in self.known and abs(self.known[k] - r) > 1e-9 * max(1.0, r):
            raise FormulationError(f"points {self.points[i]!r} and {self.points[j]!r} are given two distances")
        self.known[k] = r

    def gather(self) -> None:
        m = self.m
        for n, e in m.entities.items():
            if e.type == "point":
                i = self.pid(n)
                if e.fixed:
                    self.coords[i] = np.asarray(e.point, dtype=float)
                elif e.body is not None:
                    self.body_of[i] = e.body
        for n, e in m.entities.items():
            if e.type == "line":
                a, b = self.pid(n + ".a"), self.pid(n + ".b")
                self.know(a, b, 1.0)
        ids = list(range(len(self.points)))
        for i, j in itertools.combinations(ids, 2):
            if i in self.coords and j in self.coords:
                self.know(i, j, self.num.sqdist(self.coords[i], self.coords[j]))
            elif i in self.body_of and self.body_of.get(j) == self.body_of[i]:
                pi, pj = m.entities[self.points[i]].point, m.entities[self.points[j]].point
                self.know(i, j, self.num.sqdist(pi, pj))
        anchored: set[str] = set()
        for c in m.constraints:
            ea, eb = c.entities
            val = self.num.value(m, c)
            ta, tb = m.types(c)
            if ta == tb == "point":
                self.know(self.pid(ea), self.pid(eb), val * val)
                continue
            q, L = (ea, eb) if ta == "point" else (eb, ea)
            qa, la, lb = self.pid(q), self.pid(L + ".a"), self.pid(L + ".b")
            if L not in anchored:
                anchored.add(L)
                self.know(qa, la, val * val)
                self.know(qa, lb, val * val + 1.0)
            else:
                self.line_eqs.append((qa, la, lb, val, c.key))

    def choose_anchors(self) -> list[int]:
        n = len(self.points)
        if n < 5:
            raise FormulationError(f"{self.m.name}: the distance formulation needs at least five points")
        fixed = [i for i in range(n) if i in self.coords]
        if len(fixed) >= 4:
            best = None
            for S in itertools.combinations(fixed, 4):
                P = np.array([self.coords[i] for i in S])
                vol = abs(float(np.linalg.det(P[1:] - P[0])))
                if best is None or vol > best[0] * (1 + 1e-9):
                    best = (vol, list(S))
            assert best is not None
            if best[0] > 1e-9:
                return best[1]
        known = {k for k in self.known}

        def score(S):
            inside = sum(1 for a, b in itertools.combinations(S, 2) if (min(a, b), max(a, b)) in known)
            out = sum(1 for a in S for v in range(n) if v not in S and (min(a, v), max(a, v)) in known)
            nfix = sum(1 for a in S if a in self.coords)
            # a body's points are known among themselves, but four coplanar ones cannot anchor
            bodies = {self.body_of.get(a) for a in S}
            flat = 0
            if len(bodies) == 1 and None not in bodies:
                P = np.array([self.m.entities[self.points[a]].point for a in S])
                flat = int(abs(float(np.linalg.det(P[1:] - P[0]))) < 1e-9)
            if nfix == 4:
                P = np.array([self.coords[a] for a in S])
                flat = int(abs(float(np.linalg.det(P[1:] - P[0]))) < 1e-9)
            return (-flat, nfix >= 3, inside, out, nfix)

        best_s = max(itertools.combinations(range(n), 4), key=score)
        return list(best_s)

    # -- variables and polynomials ----------------------------------------------------------
    def bounds(self) -> dict[tuple[int, int], tuple[float, float]]:
        """Bounds on every distance (not squared): shortest paths over known distances, and the
        reach of each point from the origin (coordinate formulation)."""
        n = len(self.points)
        inf = math.inf
        D = np.full((n, n), inf)
        np.fill_diagonal(D, 0.0)
        for (i, j), r in self.known.items():
            D[i, j] = D[j, i] = math.sqrt(r)
        for k in range(n):
            D = np.minimum(D, D[:, [k]] + D[[k], :])
        rad = self.geo.radius
        # (a line's points are bounded through the distances to the point that anchors them)
        rp = [inf if p.endswith((".a", ".b")) and p[:-2] in self.m.entities else rad.get(p, inf) for p in self.points]
        for i in range(n):
            for j in range(n):
                D[i, j] = min(D[i, j], rp[i] + rp[j])
        out = {}
        for i, j in itertools.combinations(range(n), 2):
            hi = D[i, j]
            lo = 0.0
            for k in range(n):
                lo = max(
                    lo,
                    abs(D[i, k] - D[j, k])
                    if (math.isfinite(D[i, k]) and (min(j, k), max(j, k)) in self.known and (min(i, k), max(i, k)) in self.known)
                    else 0.0,
                )
            out[(i, j)] = (lo, hi)
        return out

    def entry(self, i: int, j: int, unknown: dict[tuple[int, int], int]) -> Poly:
        if i == j:
            return {}
        k = (min(i, j), max(i, j))
        if k in self.known:
            v = self.known[k]
            return {(): v} if v != 0.0 else {}
        return {(unknown[k],): 1.0}

    def cm(self, pts: Sequence[int], unknown) -> Poly:
        """The Cayley-Menger determinant of the points ``pts`` as a polynomial."""
        n = len(pts)
        one: Poly = {(): 1.0}
        M: list[list[Poly]] = []
        for a in range(n):
            M.append([self.entry(pts[a], pts[b], unknown) for b in range(n)] + [one])
        M.append([one] * n + [{}])
        return determinant(M)

    def monomial(self, k: tuple[int, ...]) -> Expr:
        """An expression of degree <= 1 (a variable) equal to the monomial ``k``."""
        if len(k) == 1:
            return Expr.var(k[0])
        if k in self.mono:
            return self.mono[k]
        h = len(k) // 2
        A, B = self.monomial(k[:h]), self.monomial(k[h:])
        lo, hi = _prod_bounds(self.s, k)
        name = "m[" + "*".join(self.s.names[i] for i in k) + "]"
        v = self.s.add_var(name, lo, hi, "aux")
        self.s.add_eq(v - A * B, f"def:{name}")
        self.mono[k] = v
        return v

    def quadratic(self, P: Poly, create: bool = True) -> Expr | None:
        """``P`` as an expression of degree <= 2 over the unknowns and monomial variables;
        with ``create=False``, None if that needs a monomial variable not made yet."""
        if not create:
            for k in P:
                if len(k) > 2:
                    h = len(k) // 2
                    if any(len(m) > 1 and m not in self.mono for m in (k[:h], k[h:])):
                        return None
        e = Expr()
        for k, c in P.items():
            if len(k) > 2 and c == 0.0:
                # a coefficient that rounded to zero (the shadow build: its error kept) needs no
                # monomial variable: its term is within its error times the monomial's bound
                e = e + EF(0.0, err(c) * _monomial_bound(self.s, k))
                continue
            if len(k) <= 2:
                t = Expr({k: c}) if k else Expr.const(c)
            else:
                h = len(k) // 2
                t = self.monomial(k[:h]) * self.monomial(k[h:]) * c
            e = e + t
        return e

    def trilateration(self, A: list[int], v: int, unknown) -> list[Poly]:
        """The coordinates of point ``v`` as affine polynomials of its squared distances to
        four fixed anchors: subtracting the sphere equations, 2 (a_k - a_0) . y = |a_k|^2 -
        |a_0|^2 - r_vk + r_v0 (k = 1..3)."""
        P0 = np.array([self.coords[a] for a in A])
        Minv, cs = self.num.trilateration(P0)
        r = [self.entry(v, a, unknown) for a in A]
        rhs = []
        for k in range(1, 4):
            rhs.append(_padd(_padd({(): cs[k - 1]}, r[k], -1.0), r[0]))
        out = []
        for row in Minv:
            acc: Poly = {}
            for k in range(3):
                acc = _padd(acc, {m: row[k] * val for m, val in rhs[k].items()})
            out.append(acc)
        return out


def _monomial_bound(s: System, k: tuple[int, ...]) -> float:
    """An upper bound of ``|prod x_i|`` (``i`` in ``k``) over the search domain, rounded up."""
    lo, hi = s.search_domain()
    out = 1.0
    for i in k:
        out *= max(abs(float(lo[i])), abs(float(hi[i])))
    return out * (1.0 + 1e-12)


def _prod_bounds(s: System, k: tuple[int, ...]) -> tuple[float, float]:
    lo, hi = 1.0, 1.0
    counts: dict[int, int] = {}
    for i in k:
        counts[i] = counts.get(i, 0) + 1
    for i, p in counts.items():
        a, b = s.lo[i] ** p, s.hi[i] ** p
        if p % 2 == 0 and s.lo[i] <= 0 <= s.hi[i]:
            cand = [0.0, max(a, b)]
        else:
            cand = [min(a, b), max(a, b)]
        prods = [lo * cand[0], lo * cand[1], hi * cand[0], hi * cand[1]]
        lo, hi = min(prods), max(prods)
    pad = 1e-9 * max(1.0, abs(lo), abs(hi))
    return lo - pad, hi + pad


def _scaled(P: Poly) -> Poly:
    """``P`` divided by its largest coefficient (determinants grow like the fourth power of the
    lengths; the solver's tolerances are relative, but Newton's are not)."""
    m = max((abs(v) for v in P.values()), default=1.0)
    return {k: v / m for k, v in P.items()} if m > 0 else P


def formulate(
    model: ConstraintSystem,
    geometry: GeometryFormulation,
    seed: int = 7,
    at: dict[str, Placement] | None = None,
    numbers: Numbers = FLOATS,
) -> DistanceFormulation:
    """The distance formulation of ``model``; ``geometry`` is its coordinate formulation (for
    bounds, the frame, and the assemblies that come out). ``at``: placements of a solution
    (from the diagnosis), where the core is chosen when constraints are redundant; else a
    random configuration. ``numbers``: the input's numbers as the rows take them
    (:class:`~kinbox.formulation.geometry.Numbers`; the shadow build's enclosures)."""
    why = supports(model)
    if why is not None:
        raise FormulationError(f"the distance formulation does not apply: {why} (use --formulation coordinates)")
    b = _Builder(model, geometry, numbers)
    b.gather()
    A = b.choose_anchors()
    n = len(b.points)
    bnd = b.bounds()
    unknown: dict[tuple[int, int], int] = {}

    def need(i: int, j: int) -> None:
        k = (min(i, j), max(i, j))
        if k in b.known or k in unknown:
            return
        lo, hi = bnd[k]
        if not math.isfinite(hi):
            raise FormulationError(f"nothing bounds the distance between {b.points[i]!r} and {b.points[j]!r}")
        unknown[k] = b.s.n
        b.s.add_var(f"r[{b.points[k[0]]},{b.points[k[1]]}]", lo * lo, hi * hi, "dist")

    for i, j in itertools.combinations(A, 2):
        need(i, j)
    others = [v for v in range(n) if v not in A]
    for v in others:
        for a in A:
            need(v, a)
    # non-anchor pairs that equations need: known ones between non-anchors, and those of Eq. (5)
    pairs = [(i, j) for (i, j) in b.known if i not in A and j not in A and not (i in b.coords and j in b.coords)]
    for q, la, lb, _, _ in b.line_eqs:
        for p in (la, lb):
            k = (min(q, p), max(q, p))
            if k not in b.known and k not in unknown:  # neither is an anchor
                need(q, p)
                pairs.append(k)
    cands: list[tuple[str, Poly]] = []
    for v in others:
        P = b.cm(A + [v], unknown)
        if P and any(len(k) for k in P):
            cands.append((f"cm5[{b.points[v]}]", _scaled(P)))
    # a known distance between two non-anchors: five points (three anchors and the two) lie in
    # 3-D. (The six-point determinant of the anchors and the two vanishes to second order on
    # every realization in 3-D: its Jacobian is singular at every solution, so it only prunes.)
    # One triple of anchors per pair goes to the candidates for the core (the conditions of the
    # four triples are equivalent at a solution: one is enough, the others prune).
    six: list[tuple[str, Poly]] = []
    closures: list[tuple[str, Poly]] = []
    fixed_anchors = all(a in b.coords for a in A)
    for i, j in pairs:
        first = True
        if fixed_anchors:
            # anchors with known coordinates: each point's coordinates are affine in its squared
            # distances to them, and |y_i - y_j|^2 = r_ij is quadratic (the trilateration of Porta et al. 2005)
            yi, yj = b.trilateration(A, i, unknown), b.trilateration(A, j, unknown)
            P = _padd({}, b.entry(i, j, unknown), -1.0)
            for axis in range(3):
                d = _padd(yi[axis], yj[axis], -1.0)
                P = _padd(P, _pmul(d, d))
            if any(len(k) for k in P):
                closures.append((f"gram[{b.points[i]},{b.points[j]}]", _scaled(P)))
            first = False
        for T in itertools.combinations(A, 3):
            P = b.cm(list(T) + [i, j], unknown)
            if P and any(len(k) for k in P):
                eq = (f"cm5[{','.join(b.points[t] for t in T)},{b.points[i]},{b.points[j]}]", _scaled(P))
                (closures if first else six).append(eq)
                first = False
        P = b.cm(A + [i, j], unknown)
        if P and any(len(k) for k in P):
            six.append((f"cm6[{b.points[i]},{b.points[j]}]", _scaled(P)))
    for q, la, lb, dq, key in b.line_eqs:
        P = b.cm([q, la, lb], unknown)
        P = _padd(P, {(): 4.0 * b.known[(min(la, lb), max(la, lb))] * dq * dq})
        cands.append((f"{key}:line[{b.points[q]},{b.points[la][:-2]}]", _scaled(P)))
    cands += closures
    core, red = _square_core(b, cands, unknown, A, seed, at)
    red += six
    for name, P in core:
        e = b.quadratic(P)
        assert e is not None
        b.s.add_eq(e, name)
    # redundant equations only where they need no monomial variable of their own: each new
    # monomial is a variable and a core equation, which costs more than the pruning gains
    for name, P in red:
        e = b.quadratic(P, create=False)
        if e is not None:
            b.s.add_eq(e, name, redundant=True)
    # more five-point conditions over points whose distances are all known or unknowns
    pool = A + others
    extra = 0
    have = {tuple(sorted(A + [v])) for v in others}
    for S in itertools.combinations(pool, 5):
        if extra >= MAX_REDUNDANT:
            break
        if tuple(sorted(S)) in have:
            continue
        if all((min(i, j), max(i, j)) in b.known or (min(i, j), max(i, j)) in unknown for i, j in itertools.combinations(S, 2)):
            P = b.cm(list(S), unknown)
            if P and any(len(k) for k in P):
                e = b.quadratic(_scaled(P), create=False)
                if e is not None:
                    b.s.add_eq(e, f"cm5[{','.join(b.points[i] for i in S)}]", redundant=True)
                    extra += 1
    # R1, R2 on the anchors: triangles have Xi <= 0, the tetrahedron Xi >= 0
    for T in itertools.combinations(A, 3):
        P = b.cm(list(T), unknown)
        e = b.quadratic(_scaled(P), create=False) if any(len(k) for k in P) else None
        if e is not None:
            b.s.add_ineq(e, f"R1[{','.join(b.points[i] for i in T)}]")
    P = b.cm(A, unknown)
    e = b.quadratic({k: -v for k, v in _scaled(P).items()}, create=False) if any(len(k) for k in P) else None
    if e is not None:
        b.s.add_ineq(e, "R2[anchors]")
    return DistanceFormulation(model, b.s, geometry, b.points, A, b.known, unknown, dict(b.coords))


def _square_core(b: _Builder, cands: list[tuple[str, Poly]], unknown, A, seed: int, at=None):
    """Split the candidate equations into a core as large as the unknowns allow, of full rank
    at a solution (placements ``at``) or else at a random realization, and redundant ones."""
    nv = len(unknown)
    if len(cands) <= nv:
        return cands, []
    rng = np.random.default_rng(seed)
    n = len(b.points)
    Y = rng.normal(size=(n, 3))
    if at is not None:
        for i, name in enumerate(b.points):
            if name in at:
                Y[i] = at[name].p
        for name, pl in at.items():
            if pl.type == "line":
                i, j = b.points.index(name + ".a"), b.points.index(name + ".b")
                q = next(b.points[k] for (k, m) in b.known if m == i and b.points[k] in at)
                d = pl.d / np.linalg.norm(pl.d)
                w = at[q].p - pl.p
                Y[i] = pl.p + np.dot(w, d) * d
                Y[j] = Y[i] + d
    else:
        for i, p in b.coords.items():
            Y[i] = p
        bodies: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        for i, bn in b.body_of.items():
            if bn not in bodies:
                Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
                bodies[bn] = (Q, rng.normal(size=3))
            R, t = bodies[bn]
            Y[i] = t + R @ b.m.entities[b.points[i]].point
    vals = np.zeros(nv)
    for (i, j), ix in unknown.items():
        vals[ix] = float(np.sum((Y[i] - Y[j]) ** 2))

    def grad(P: Poly) -> np.ndarray:
        g = np.zeros(nv)
        for k, c in P.items():
            for pos, v in enumerate(k):
                rest = k[:pos] + k[pos + 1 :]
                g[v] += c * float(np.prod([vals[u] for u in rest])) if rest else c
        return g

    G = np.array([grad(P) for _, P in cands])
    core: list[int] = []
    rank = 0
    for r in range(len(cands)):
        trial = core + [r]
        rk = np.linalg.matrix_rank(G[trial], tol=1e-9 * max(1.0, float(np.max(np.abs(G[trial])))))
        if rk > rank:
            core, rank = trial, rk
        if rank == nv:
            break
    red = [cands[r] for r in range(len(cands)) if r not in core]
    return [cands[r] for r in core], red
