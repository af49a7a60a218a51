"""Entity-level answers of geometric constraint systems (``kinbox.assemble``).

Every solution is given by the placements of its entities (points ``[x, y, z]``, lines and
planes in canonical form: see :meth:`~kinbox.formulation.geometry.Placement.canonical`) and
the poses of its bodies, checked **independently of the equations**: every constraint is
measured on the placements (a distance, an angle, how far an incidence is off) and the largest
deviation is the solution's ``residual``. ``certified`` means a Krawczyk proof, in the
coordinate system, that a box around it holds exactly one solution; ``multiple`` flags a root
where the Jacobian is singular (tangent, double roots: no proof of uniqueness is possible
there). Positive-dimensional sets come as ``components`` with their dimension and sample
assemblies along them.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..formulation.distance import DistanceFormulation
from ..formulation.geometry import GeometryFormulation, Placement
from ..model.constraints import Constraint, ConstraintSystem
from ..search.certify import gauss_newton
from ..search.outcome import Outcome, Stats
from ..search.point import PointCertifier, point_certifier
from ..search.results import SolveResult
from ..search.status import BoxStatus, Status
from .components import Component, components
from .curve import Curve

#: an assembly is kept when every constraint holds this well on its placements
RESIDUAL = 1e-7
#: two assemblies are the same when their placements differ by less than this
SAME = 1e-7
#: assemblies per curve written as its ``samples`` in JSON
MAX_SAMPLES = 100
#: uncertified boxes polished per isolated component (the rest count as unresolved)
MAX_POLISHED = 200


@dataclass
class Assembly:
    entities: dict[str, Placement]
    bodies: dict[str, tuple[np.ndarray, np.ndarray]]
    #: what is known of it: certified (a Krawczyk proof) or uncertified (the one status of
    #: every solution box, :class:`~kinbox.search.status.BoxStatus`)
    status: BoxStatus
    residual: float
    multiple: bool = False
    width: float = 0.0
    #: index of this assembly's mirror image among the solutions (frames pinned by points)
    mirror: int | None = None
    x: np.ndarray | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        self.status = BoxStatus(self.status)

    @property
    def certified(self) -> bool:
        """Proven: exactly one assembly in a box of :attr:`width` around it (Krawczyk)."""
        return self.status is BoxStatus.CERTIFIED

    def to_dict(self) -> dict:
        d: dict[str, Any] = {"entities": {k: p.canonical() for k, p in self.entities.items()}}
        if self.bodies:
            d["bodies"] = {
                b: {"rotation": [[float(v) for v in row] for row in R], "translation": [float(v) for v in t]}
                for b, (R, t) in self.bodies.items()
            }
        d.update(certified=self.certified, status=self.status.value, residual=float(self.residual))
        d.update(multiple=bool(self.multiple), width=float(self.width))
        if self.mirror is not None:
            d["mirror"] = int(self.mirror)
        return d

    def distance(self, other: Assembly) -> float:
        dist = max((p.distance(other.entities[k]) for k, p in self.entities.items()), default=0.0)
        for b, (R, t) in self.bodies.items():
            R2, t2 = other.bodies[b]
            dist = max(dist, float(np.max(np.abs(R - R2))), float(np.max(np.abs(t - t2))))
        return dist


@dataclass(repr=False)
class AssemblyResult(Outcome):
    """Every assembly of a constraint system found (:func:`kinbox.assemble`), on the base of
    every kinbox result (:class:`~kinbox.search.outcome.Outcome`: ``status``, ``complete``,
    ``message``, ``stats``, ``to_json``, ``table``). ``curves``: component index -> the
    assemblies along that positive-dimensional component in order (the one curve view of every
    result, :class:`~kinbox.answer.curve.Curve`)."""

    problem: str
    formulation: str
    frame: str
    status: Status
    message: str
    solutions: list[Assembly]
    components: list[Component]
    curves: dict[int, Curve[Assembly]]
    stats: Stats
    diagnosis: dict = field(default_factory=dict)
    source: dict = field(default_factory=dict)
    raw: SolveResult | None = field(default=None, repr=False)
    #: what the certificates do not cover (an input taken as rounded)
    notes: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.status = Status(self.status)

    def __repr__(self) -> str:
        return f"AssemblyResult(problem={self.problem!r}, status={self.status.value!r}, solutions={len(self.solutions)})"

    @property
    def samples(self) -> dict[int, list[Assembly]]:
        """Component index -> up to about :data:`MAX_SAMPLES` assemblies spread along it (the
        ``samples`` of each component in JSON)."""
        return {i: cv.samples(MAX_SAMPLES) for i, cv in self.curves.items()}

    @property
    def shapes(self) -> int:
        """Isolated solutions counted up to a reflection (a solution and its mirror image are
        one shape): the count of distance-space solutions in Porta et al. 2005."""
        return len(self.solutions) - sum(1 for k, s in enumerate(self.solutions) if s.mirror is not None and s.mirror < k)

    def to_dict(self) -> dict:
        comps = []
        samples = self.samples
        for i, c in enumerate(self.components):
            if c.dimension == 0:
                continue
            comps.append(
                {
                    "dimension": c.dimension,
                    "boxes": len(c.boxes),
                    "bifurcation_boxes": len(c.bifurcations),
                    "samples": [s.to_dict()["entities"] for s in samples.get(i, [])],
                }
            )
        return {
            "kind": "constraints",
            "problem": self.problem,
            "source": self.source,
            "formulation": self.formulation,
            "frame": self.frame,
            "status": self.status.value,
            "complete": self.complete,
            "message": self.message,
            "solutions": [s.to_dict() for s in self.solutions],
            "shapes": self.shapes,
            "components": comps,
            "diagnosis": self.diagnosis,
            "stats": self.stats,
            **({"notes": list(self.notes)} if self.notes else {}),
        }

    def table(self) -> str:
        ncomp = sum(1 for c in self.components if c.dimension >= 1)
        lines = [
            f"{self.problem}: {len(self.solutions)} isolated assembl{'y' if len(self.solutions) == 1 else 'ies'}"
            f" ({self.shapes} up to reflection), {ncomp} positive-dimensional component(s); "
            f"{self.completeness()}",
            f"  formulation: {self.formulation}; frame: {self.frame}",
            "  residual: the largest deviation of a constraint on the placements (a length in the file's units, "
            "an angle in radians); below the rounding of the coordinates it prints as 0",
        ]
        for k, s in enumerate(self.solutions):
            flags = ("certified" if s.certified else "not certified") + (", multiple root" if s.multiple else "")
            mir = f", mirror of #{s.mirror + 1}" if s.mirror is not None and s.mirror < k else ""
            lines.append(f"  #{k + 1}: {flags}{mir}, residual {_residual_text(s)}")
            for name, p in s.entities.items():
                lines.append(f"      {name:>8}: {_fmt(p)}")
        for i, c in enumerate(self.components):
            if c.dimension >= 1:
                cv = self.curves.get(i)
                pts = sum(len(b) for b in cv.branches) if cv else 0
                lines.append(
                    f"  component of dimension {c.dimension}: {len(c.boxes)} boxes, {len(cv.branches) if cv else 0} branch(es), "
                    f"{pts} assemblies along them"
                )
        st = self.stats
        if st.get("unresolved_boxes"):
            lines.append(
                f"  {st['unresolved_boxes']} box(es) could not be ruled out but hold no solution found (a smaller sigma decides them)"
            )
        if st.get("not_embeddable"):
            lines.append(f"  {st['not_embeddable']} distance solution(s) do not embed in 3-D (dropped)")
        lines.extend(f"  note: {n}" for n in self.notes)
        lines.append(
            f"  {st.get('variables')} variables, {st.get('equations')} equations; {st.get('boxes')} boxes, "
            f"{st.get('lps')} LPs, {st.get('cpu_seconds', 0):.3f} CPU s"
        )
        return "\n".join(lines)


def _residual_text(s: Assembly) -> str:
    """A solution's residual for the table: 0 when it is below the rounding of its coordinates
    (a deviation of 1e-34 on coordinates of size 1 is a coincidence of the arithmetic, not a
    measure; test_assembly_residuals_print_in_units)."""
    size = max(
        (float(np.max(np.abs(np.atleast_1d(v)))) for p in s.entities.values() for v in (p.p, p.d, p.h) if v is not None), default=1.0
    )
    rounding = 4.0 * np.finfo(float).eps * max(1.0, size)
    return "0" if s.residual < rounding else f"{s.residual:.1e}"


def _fmt(p: Placement) -> str:
    c = p.canonical()
    if isinstance(c, list):
        return "(" + ", ".join(f"{v:.6f}" for v in c) + ")"
    key = "direction" if p.type == "line" else "normal"
    return f"{p.type} through (" + ", ".join(f"{v:.6f}" for v in c["point"]) + f"), {key} (" + ", ".join(f"{v:.6f}" for v in c[key]) + ")"


# ----------------------------------------------------------------------------------------------
# measuring constraints on placements
# ----------------------------------------------------------------------------------------------
def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _pt_line(p, L: Placement) -> float:
    d = _unit(L.d)
    w = p - L.p
    return float(np.linalg.norm(w - np.dot(w, d) * d))


def _pt_plane(p, P: Placement) -> float:
    n = float(np.linalg.norm(P.d))
    return abs(float(np.dot(P.d, p)) - float(P.h)) / n


def _sin(u, v) -> float:
    return float(np.linalg.norm(np.cross(_unit(u), _unit(v))))


def _cos(u, v) -> float:
    return abs(float(np.dot(_unit(u), _unit(v))))


def deviation(model: ConstraintSystem, c: Constraint, places: dict[str, Placement]) -> float:
    """How far constraint ``c`` is from holding at ``places`` (lengths, or sines/radians)."""
    a, b = c.entities
    A, B = places[a], places[b]
    order = {"point": 0, "line": 1, "plane": 2}
    if order[A.type] > order[B.type]:
        A, B = B, A
    pair = (A.type, B.type)
    v = model.value(c) if c.type in ("distance", "angle") else 0.0
    if c.type == "angle":
        v = min(v, math.pi - v)
        if pair == ("line", "plane"):
            ang = math.asin(min(1.0, _cos(A.d, B.d)))
        else:
            ang = math.acos(min(1.0, _cos(A.d, B.d)))
        return abs(ang - v)
    if c.type == "parallel":
        return _cos(A.d, B.d) if pair == ("line", "plane") else _sin(A.d, B.d)
    if c.type == "perpendicular":
        return _sin(A.d, B.d) if pair == ("line", "plane") else _cos(A.d, B.d)
    # distance and incidence: the distance between the sets, plus how far from parallel
    if pair == ("point", "point"):
        dist, extra = float(np.linalg.norm(A.p - B.p)), 0.0
    elif pair == ("point", "line"):
        dist, extra = _pt_line(A.p, B), 0.0
    elif pair == ("point", "plane"):
        dist, extra = _pt_plane(A.p, B), 0.0
    elif pair == ("line", "line"):
        s = _sin(A.d, B.d)
        if c.type == "incident":
            dist, extra = _pt_line(B.p, A), s
        elif s < 1e-9:
            dist, extra = _pt_line(B.p, A), 0.0
        else:
            m = np.cross(_unit(A.d), _unit(B.d))
            dist, extra = abs(float(np.dot(B.p - A.p, m))) / float(np.linalg.norm(m)), 0.0
    elif pair == ("line", "plane"):
        dist, extra = _pt_plane(A.p, B), _cos(A.d, B.d)
    else:
        pB = _unit(B.d) * float(B.h) / float(np.linalg.norm(B.d))
        dist, extra = _pt_plane(pB, A), _sin(A.d, B.d)
    return max(abs(dist - v), extra)


def max_deviation(model: ConstraintSystem, places: dict[str, Placement]) -> float:
    return max((deviation(model, c, places) for c in model.constraints), default=0.0)


# ----------------------------------------------------------------------------------------------
# building the answer
# ----------------------------------------------------------------------------------------------
def mirrored(p: Placement) -> Placement:
    """The placement reflected in the plane z = 0."""
    F = np.diag([1.0, 1.0, -1.0])
    return Placement(p.type, None if p.p is None else F @ p.p, None if p.d is None else F @ p.d, p.h)


#: Newton steps on the coordinate system before an uncertified assembly's proof is tried
PROOF_NEWTON = 40
#: an assembly not proven is a multiple root when the core Jacobian's condition number is this or more
SINGULAR_CONDITION = 1e10


class Prover:
    """Krawczyk proofs in a coordinate formulation, around given placements, through the search
    stage's one entry for a point (:func:`kinbox.search.point.point_certifier`)."""

    def __init__(self, geo: GeometryFormulation):
        self.geo = geo
        self._prove: PointCertifier = point_certifier(geo.system)

    def prove(self, x: np.ndarray) -> tuple[bool, float, np.ndarray]:
        """(certified, width of the proof's enclosure, the polished point) near ``x``."""
        box = self._prove(x, newton_iters=PROOF_NEWTON)
        if box is not None:
            return True, box.width, box.x
        return False, 0.0, x

    def singular(self, x: np.ndarray) -> bool:
        comp = self.geo.system.compile()
        if not (comp.n_core == comp.n and comp.n > 0):
            return True
        return not bool(np.linalg.cond(comp.jacobian(x, slice(0, comp.n_core))) < SINGULAR_CONDITION)


def distance_assemblies(dist: DistanceFormulation, x: np.ndarray) -> list[Assembly]:
    """The assemblies (in the coordinate formulation) of a point ``x`` of a
    distance formulation: every embedding of its distances
    in 3-D (none if they do not embed), placed and encoded as coordinates."""
    out = []
    for Y in dist.embed(x):
        places, poses = dist.placements(Y)
        out.append(assembly_of(dist.geometry, dist.geometry.encode(places, poses), False))
    return out


def assembly_of(geo: GeometryFormulation, x: np.ndarray, certified: bool, width: float = 0.0) -> Assembly:
    places = geo.placements(x)
    status = BoxStatus.CERTIFIED if certified else BoxStatus.UNCERTIFIED
    return Assembly(places, geo.body_poses(x), status, max_deviation(geo.model, places), width=width, x=x)


def collect(geo: GeometryFormulation, cands: list[tuple[Assembly, bool]], prover: Prover, stats: Stats) -> list[Assembly]:
    """Merge candidate assemblies (``(assembly, certified by the search)``): polish and prove
    the uncertified ones, drop what does not satisfy the constraints, merge duplicates, pair
    mirror images."""
    sols: list[Assembly] = []
    for a, proven in cands:
        if a.residual > RESIDUAL and a.x is not None:
            # a point near a singular root: Gauss-Newton on the system gets closer
            y = gauss_newton(geo.system.compile(), a.x, iters=50)
            b = assembly_of(geo, y, False)
            if b.residual < a.residual:
                a = b
        if a.residual > RESIDUAL:
            stats["spurious"] = stats.get("spurious", 0) + 1
            continue
        if not proven and a.x is not None:
            ok, w, y = prover.prove(a.x)
            if ok:
                b = assembly_of(geo, y, True, w)
                if b.residual <= RESIDUAL:
                    a = b
            if not a.certified and a.x is not None:
                a.multiple = prover.singular(a.x)
        dup = next((o for o in sols if o.distance(a) < SAME), None)
        if dup is not None:
            if a.certified and not dup.certified:
                sols[sols.index(dup)] = a
            continue
        sols.append(a)
    if geo.pinned:
        for i, s in enumerate(sols):
            m = Assembly({k: mirrored(p) for k, p in s.entities.items()}, {}, BoxStatus.UNCERTIFIED, 0.0)
            for j, o in enumerate(sols):
                if j != i and m.distance(o) < 1e-6:
                    s.mirror = j
    return sols


#: equations' residual up to which a point counts as a sample of a component
SAMPLE_RESIDUAL = 1e-9


def build_assembly_result(
    problem: str,
    raw: SolveResult,
    geo: GeometryFormulation,
    sigma: float,
    decode: Callable[[np.ndarray], list[Assembly]] | None = None,
    formulation: str = "coordinates",
    source: dict | None = None,
    diagnosis: dict | None = None,
    max_samples: int = 100,
    prover: Prover | None = None,
) -> AssemblyResult:
    """Solver boxes to assemblies. ``decode(x)`` maps a point of the solved system to its
    assemblies (default: ``geo`` is the solved system); ``geo`` is the coordinate formulation
    where assemblies are proven."""
    prover = prover or Prover(geo)
    stats = raw.stats.copy()
    if decode is None:

        def decode(x: np.ndarray) -> list[Assembly]:
            return [assembly_of(geo, x, False)]

    comps = components(raw.system, raw.boxes, sigma)
    cands: list[tuple[Assembly, bool]] = []
    unresolved = 0
    for c in comps:
        if c.dimension != 0:
            continue
        boxes = [raw.boxes[i] for i in c.boxes]
        cert = [b for b in boxes if b.certified]
        unc = sorted((b for b in boxes if not b.certified), key=lambda b: b.residual)
        unresolved += max(0, len(unc) - MAX_POLISHED)
        for b in cert + unc[:MAX_POLISHED]:
            got = decode(b.x)
            if not got:  # a distance solution with no embedding in 3-D
                stats["not_embeddable"] = stats.get("not_embeddable", 0) + 1
            for a in got:
                if formulation == "coordinates":  # the search's proof is a proof of this assembly
                    a.status = BoxStatus.CERTIFIED if b.certified else BoxStatus.UNCERTIFIED
                    a.width = b.width if b.certified else 0.0
                cands.append((a, a.certified))
    sols = collect(geo, cands, prover, stats)
    stats["unresolved_boxes"] = unresolved
    curves = {ci: _curve(c, raw, decode, max_samples) for ci, c in enumerate(comps) if c.dimension >= 1}
    stats["solutions"] = len(sols)
    stats["certified"] = sum(s.certified for s in sols)
    notes = [
        f"constraint {label}: an angle of binary64 pi or pi/2 taken as exact parallelism; the assemblies of the angle as given "
        "lie on a circle about 1e-16 from each reported one, which the certificates do not cover"
        for label in geo.rounded_angles
    ]
    return AssemblyResult(
        problem, formulation, geo.frame, raw.status, raw.message, sols, comps, curves, stats, diagnosis or {}, source or {}, raw, notes
    )


def _curve(c: Component, raw: SolveResult, decode: Callable[[np.ndarray], list[Assembly]], max_samples: int) -> Curve[Assembly]:
    """The assemblies along a curve component: its traced branches in order (a point of the
    solved system may give several assemblies, the embeddings of a distance solution: each
    branch is followed through the nearest one); a component with no traced branch gets the
    points of up to ``max_samples`` of its boxes, one branch not in order. Only points of the
    solution set are kept (equations within :data:`SAMPLE_RESIDUAL`)."""
    comp = raw.system.compile()

    def on_set(x: np.ndarray) -> bool:
        return bool(np.max(np.abs(comp.eval_eqs(x)), initial=0.0) <= SAMPLE_RESIDUAL)

    branches: list[list[Assembly]] = []
    closed: list[bool] = []
    for pl, cl in zip(c.polylines, c.closed):
        for b in _follow([decode(np.asarray(x, dtype=float)) for x in pl if on_set(np.asarray(x, dtype=float))]):
            branches.append(b)
            closed.append(bool(cl))
    if not branches:
        idx = c.boxes[:: max(1, len(c.boxes) // max_samples)]
        points = [gauss_newton(comp, raw.boxes[i].x, iters=20) for i in idx]
        # a sample is a point of the solution set: one Gauss-Newton left off it is not shown
        got = [a for x in points if on_set(x) for a in decode(x)]
        branches, closed = ([got], [False]) if got else ([], [])
    branches.sort(key=lambda b: -len(b))
    bif = [a for x in c.bifurcations for a in decode(np.asarray(x, dtype=float))[:1]]
    residual = max((a.residual for b in branches for a in b), default=0.0)
    return Curve(branches, closed, residual, bif)


def _follow(points: list[list[Assembly]]) -> list[list[Assembly]]:
    """Branches through a sequence of points, each given as its assemblies: one branch from
    each assembly of the first point, continued through the nearest assembly of each next."""
    points = [p for p in points if p]
    if not points:
        return []
    branches = [[a] for a in points[0]]
    for p in points[1:]:
        for b in branches:
            b.append(min(p, key=lambda a: b[-1].distance(a)))
    return branches
