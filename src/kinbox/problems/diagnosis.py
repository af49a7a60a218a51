"""Diagnosis of a geometric constraint system before solving it (Ruiz 1994, Sec. 3.2.2).

Ruiz adds constraints one at a time and asks of each: does it make the system inconsistent,
is it redundant, or how many degrees of freedom does it remove? He answers with Gröbner
bases; kinbox answers numerically, with the Jacobian of the coordinate formulation (every
constraint with its own rows: ``substitute=False``, frame not pinned):

* **at the given values**: a real solution is sought by Levenberg-Marquardt from
  deterministic random starts. At the solution, constraint ``k`` (in file order) removes
  ``D(k-1) - D(k)`` degrees of freedom, with ``D(k) = #variables - rank J`` over the rows and
  variables of the entities and constraints ``1..k``: ``independent`` if it removes as many as it
  imposes in general, ``redundant`` if none, ``partially redundant`` otherwise. The degrees of
  freedom of the system are ``D`` minus the rigid motions (when nothing is fixed), and the
  entities that still move along the solution set are **under-constrained**.
* **generically** (for generic geometry: Ruiz's *topological* view): the same count at a
  *witness*, a random configuration that satisfies the constraints without values
  (incidences, parallelism, perpendicularity), with every value, fixed placement and body
  feature measured there.
* **inconsistency**: when no solution is found, the shortest inconsistent prefix of the
  constraints and a deletion filter give a minimal set that no solution satisfies. The search
  only *suggests* it; ``solve`` refuses the system only after a complete interval search on
  that set proves that it has no solution in the world box (:func:`refuse_if_inconsistent`).

Mechanisms get the same count from their own system (:func:`diagnose_mechanism`).

The diagnosis runs before solving (:class:`kinbox.problems.constraints.Assemble`, :func:`kinbox.check`),
so it lives with the problem kinds, above the answer stage whose checks it reuses.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import InconsistentError
from ..formulation.geometry import GeometryFormulation, Placement, formulate
from ..formulation.system import Compiled
from ..model.constraints import ConstraintSystem
from ..model.planar import plane_normal
from ..search import solver

#: random starts of the solution search (deterministic: a fixed seed)
STARTS = 10
SEED = 20_021_994
#: boxes allowed to the interval search that proves a set of constraints inconsistent
PROOF_BOXES = 20_000


@dataclass
class Status:
    """What constraint ``label`` does when added after those before it."""

    label: str
    imposes: int  # independent conditions in general (its codimension)
    removes: int  # degrees of freedom it removes here
    left: int | None = None  # degrees of freedom left after it (rigid motions taken out)

    @property
    def status(self) -> str:
        if self.removes <= 0:
            return "redundant"
        if self.removes < self.imposes:
            return "partially redundant"
        return "independent"

    def to_dict(self) -> dict:
        return {"constraint": self.label, "imposes": self.imposes, "removes": self.removes, "status": self.status, "dof_left": self.left}


@dataclass
class Diagnosis:
    consistent: bool | None  # None: no solution found, inconsistency not proven
    dof: int | None  # at the solution found
    generic_dof: int | None
    rigid_motions: int  # rigid motions taken out of the counts (6 when nothing is fixed)
    at_solution: list[Status] = field(default_factory=list)
    generic: list[Status] = field(default_factory=list)
    underconstrained: dict[str, int] = field(default_factory=dict)
    inconsistent: list[str] = field(default_factory=list)
    #: indices into the model's constraints of :attr:`inconsistent`
    inconsistent_indices: list[int] = field(default_factory=list)
    proven: bool = False
    pin: list[str] | None = None
    notes: list[str] = field(default_factory=list)
    #: the solution found: (placements, body poses), in no particular frame
    solution: tuple | None = field(default=None, repr=False)

    @property
    def redundant(self) -> list[str]:
        return [s.label for s in self.at_solution if s.status != "independent"]

    @property
    def generic_redundant(self) -> list[str]:
        return [s.label for s in self.generic if s.status != "independent"]

    @property
    def message(self) -> str:
        if self.inconsistent:
            what = "are inconsistent" if self.proven else "look inconsistent (no solution found)"
            return f"constraints {', '.join(self.inconsistent)} {what}" + (
                ": no assembly satisfies them (proven by a complete search)" if self.proven else ""
            )
        return ""

    def to_dict(self) -> dict:
        return {
            "consistent": self.consistent,
            "dof": self.dof,
            "generic_dof": self.generic_dof,
            "rigid_motions": self.rigid_motions,
            "redundant": self.redundant,
            "generically_redundant": self.generic_redundant,
            "underconstrained": self.underconstrained,
            "inconsistent": self.inconsistent,
            "inconsistency_proven": self.proven,
            "constraints": [s.to_dict() for s in self.at_solution],
            "generic_constraints": [s.to_dict() for s in self.generic],
            "notes": self.notes,
        }

    def report(self, name: str) -> str:
        lines = [f"{name}:"]
        if self.consistent is False or self.inconsistent:
            lines.append(f"  INCONSISTENT: {self.message}")
        elif self.consistent is None:
            lines.append("  no solution found by the local search (the system may still be consistent)")
        if self.generic_dof is not None:
            lines.append(
                f"  generic degrees of freedom: {self.generic_dof}"
                + (f" (after {self.rigid_motions} rigid motions)" if self.rigid_motions else "")
            )
        if self.dof is not None:
            lines.append(f"  degrees of freedom at a solution: {self.dof}")
        for title, sts in (("generically", self.generic), ("at the solution", self.at_solution)):
            bad = [s for s in sts if s.status != "independent"]
            if bad:
                lines.append(
                    f"  redundant {title}: " + "; ".join(f"{s.label} ({s.status}: removes {s.removes} of {s.imposes})" for s in bad)
                )
            elif sts:
                lines.append(f"  redundant {title}: none")
        if self.underconstrained:
            lines.append("  under-constrained: " + ", ".join(f"{k} ({v} dof)" for k, v in self.underconstrained.items()))
        elif self.dof == 0:
            lines.append("  under-constrained: none (isolated assemblies)")
        if self.pin:
            lines.append(f"  frame pinned by points {', '.join(self.pin)}")
        lines += [f"  note: {n}" for n in self.notes]
        return "\n".join(lines)


# ----------------------------------------------------------------------------------------------
# numerics
# ----------------------------------------------------------------------------------------------
def scale(model: ConstraintSystem) -> float:
    """A length typical of the system: the largest value, fixed or feature coordinate, or 1."""
    s = 1.0
    for c in model.constraints:
        if c.type == "distance":
            s = max(s, model.value(c))
    for e in model.entities.values():
        if e.point is not None:
            s = max(s, float(np.max(np.abs(e.point))))
    return s


def _rotation(rng) -> np.ndarray:
    Q, R = np.linalg.qr(rng.normal(size=(3, 3)))
    Q = Q * np.sign(np.diag(R))
    if np.linalg.det(Q) < 0:
        Q[:, 0] = -Q[:, 0]
    return Q


def _random_unit(rng) -> np.ndarray:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def random_placements(model: ConstraintSystem, rng, L: float):
    places: dict[str, Placement] = {}
    poses = {b: (_rotation(rng), rng.uniform(-L, L, 3)) for b, body in model.bodies.items() if not body.fixed}
    for n, e in model.entities.items():
        if e.body is not None:
            R, t = poses[e.body]
            p = t + R @ e.point
            if e.type == "point":
                places[n] = Placement("point", p)
            else:
                d = R @ e.direction
                places[n] = Placement(e.type, p, d, None if e.type != "plane" else float(np.dot(d, p)))
        elif e.fixed:
            d = e.direction
            places[n] = Placement(e.type, e.point, d, None if e.type != "plane" else float(np.dot(d, e.point)))
        elif e.type == "point":
            places[n] = Placement("point", rng.uniform(-L, L, 3))
        elif e.type == "line":
            places[n] = Placement("line", rng.uniform(-L, L, 3), _random_unit(rng))
        else:
            places[n] = Placement("plane", None, _random_unit(rng), float(rng.uniform(-L, L)))
    return places, poses


def levenberg_marquardt(comp: Compiled, x0: np.ndarray, tol: float, iters: int = 150) -> tuple[np.ndarray, float]:
    """A zero of all equations of ``comp`` near ``x0`` (minimum-norm steps: the system may be
    under- or over-determined), and the largest residual reached."""
    x = np.array(x0, dtype=float)
    F = comp.eval_eqs(x)
    cost = float(F @ F)
    lam = 1e-6
    n = comp.n
    for _ in range(iters):
        if not np.all(np.isfinite(F)) or np.max(np.abs(F), initial=0.0) <= tol:
            break
        J = comp.jacobian(x)
        A = np.vstack([J, math.sqrt(lam) * np.eye(n)])
        b = np.concatenate([-F, np.zeros(n)])
        dx = np.linalg.lstsq(A, b, rcond=None)[0]
        xn = x + dx
        Fn = comp.eval_eqs(xn)
        cn = float(Fn @ Fn)
        if np.isfinite(cn) and cn < cost:
            x, F, cost = xn, Fn, cn
            lam = max(lam / 4.0, 1e-15)
        else:
            lam *= 8.0
            if lam > 1e12:
                break
    return x, float(np.max(np.abs(F), initial=0.0)) if np.all(np.isfinite(F)) else math.inf


def _tol(L: float) -> float:
    return 1e-10 * max(1.0, L * L)


def explicit(model: ConstraintSystem, L: float) -> GeometryFormulation:
    """The coordinate formulation with a row set per constraint and no pinned frame."""
    return formulate(model, substitute=False, frame=False, fallback_radius=1e3 * L)


def find_solution(model: ConstraintSystem, rng, L: float, starts: int = STARTS):
    """(formulation, a real solution or None)."""
    geo = explicit(model, L)
    comp = geo.system.compile()
    for _ in range(starts):
        places, poses = random_placements(model, rng, L)
        x0 = geo.encode(places, poses)
        x, res = levenberg_marquardt(comp, x0, _tol(L))
        if res <= _tol(L):
            return geo, x
    return geo, None


def _rank(J: np.ndarray) -> int:
    if J.size == 0:
        return 0
    s = np.linalg.svd(J, compute_uv=False)
    return int(np.sum(s > 1e-8 * max(1.0, float(s[0]))))


def sequential(geo: GeometryFormulation, x: np.ndarray) -> tuple[int, list[Status]]:
    """``D(0)`` (entities alone) and what each constraint removes, in file order."""
    comp = geo.system.compile()
    J = comp.jacobian(x)
    owners = [name.split("|", 1)[0] for name in comp.row_names[: comp.n_eq]]
    var_owner = [geo.var_owner.get(i, "") for i in range(comp.n)]
    model = geo.model

    def dof(keys: set[str]) -> int:
        rows = [r for r, o in enumerate(owners) if o in keys or o.startswith(("e:", "b:"))]
        cols = [i for i, o in enumerate(var_owner) if o in keys or o.startswith(("e:", "b:"))]
        return len(cols) - _rank(J[np.ix_(rows, cols)]) if rows else len(cols)

    keys: set[str] = set()
    d0 = prev = dof(keys)
    out = []
    for c in model.constraints:
        keys.add(c.key)
        d = dof(keys)
        out.append(Status(c.label, model.codim(c), prev - d))
        prev = d
    return d0, out


def moved(p: Placement, R: np.ndarray, t: np.ndarray) -> Placement:
    if p.type == "point":
        return Placement("point", R @ p.p + t)
    if p.type == "line":
        return Placement("line", R @ p.p + t, R @ p.d)
    n = R @ p.d
    return Placement("plane", None, n, float(p.h) + float(np.dot(n, t)))


def _hat(w):
    return np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])


def rigid_velocities(geo: GeometryFormulation, x: np.ndarray, eps: float = 1e-6) -> np.ndarray:
    """Columns: the system velocities of the six infinitesimal rigid motions at ``x``."""
    places, poses = geo.placements(x), geo.body_poses(x)
    cols = []
    for k in range(6):
        xs = []
        for sgn in (1.0, -1.0):
            w = np.zeros(3)
            v = np.zeros(3)
            (w if k < 3 else v)[k % 3] = sgn * eps
            th = float(np.linalg.norm(w))
            K = _hat(w / th) if th > 0 else np.zeros((3, 3))
            R = np.eye(3) + math.sin(th) * K + (1 - math.cos(th)) * K @ K
            pl = {n: moved(p, R, v) for n, p in places.items()}
            po = {b: (R @ Rb, R @ tb + v) for b, (Rb, tb) in poses.items()}
            xs.append(geo.encode(pl, po))
        cols.append((xs[0] - xs[1]) / (2 * eps))
    return np.array(cols).T


def _signature(geo: GeometryFormulation, x: np.ndarray, name: str) -> np.ndarray:
    if name in geo.model.bodies:
        R, t = geo.body_poses(x)[name]
        return np.concatenate([R.ravel(), t])
    p = geo.placements(x)[name]
    if p.type == "point":
        return p.p
    d = p.d / np.linalg.norm(p.d)
    if p.type == "line":
        return np.concatenate([p.p - np.dot(p.p, d) * d, d])
    return np.concatenate([d, [float(p.h) / float(np.linalg.norm(p.d))]])


def underconstrained(geo: GeometryFormulation, x: np.ndarray, gauge: list[int] | None = None) -> dict[str, int]:
    """Free entities and bodies that move along the solution set, with the number of
    independent motions each has. When nothing is fixed, the motions are those that keep the
    variables ``gauge`` in place (the frame: three pinned points, or a held body)."""
    comp = geo.system.compile()
    J = comp.jacobian(x)
    if gauge:
        G = np.zeros((len(gauge), comp.n))
        G[np.arange(len(gauge)), gauge] = 1.0
        J = np.vstack([J, G]) if J.size else G
    if J.size:
        _, s, Vt = np.linalg.svd(J)
        r = int(np.sum(s > 1e-8 * max(1.0, float(s[0]))))
        N = Vt[r:].T
    else:
        N = np.eye(comp.n)
    if N.size == 0:
        return {}
    out = {}
    names = [n for n, e in geo.model.entities.items() if e.free] + [b for b, body in geo.model.bodies.items() if not body.fixed]
    eps = 1e-6
    for name in names:
        cols = [
            (_signature(geo, x + eps * N[:, j], name) - _signature(geo, x - eps * N[:, j], name)) / (2 * eps) for j in range(N.shape[1])
        ]
        k = _rank(np.array(cols).T) if cols else 0
        if k:
            out[name] = k
    return out


def _gauge(geo: GeometryFormulation, pin: list[str] | None) -> list[int]:
    """Variables that hold the frame of a formulation without one: the first body's pose, or
    the coordinates of pinned points (all of the first, y and z of the second, z of the third)."""
    model = geo.model
    free_bodies = [b for b, body in model.bodies.items() if not body.fixed]
    if free_bodies:
        return list(geo.entity_vars.get(free_bodies[0], []))
    if not pin:
        return []
    a, b, c = (geo.entity_vars[p] for p in pin)
    return list(a) + [b[1], b[2], c[2]]


# ----------------------------------------------------------------------------------------------
# the generic witness
# ----------------------------------------------------------------------------------------------
def _valueless(c, model: ConstraintSystem) -> bool:
    if c.type in ("incident", "parallel", "perpendicular"):
        return True
    v = model.value(c)
    if c.type == "distance":
        return v == 0.0
    v = min(v, math.pi - v)
    return v == 0.0 or v == math.pi / 2


def witness(model: ConstraintSystem, rng, L: float):
    """A model with generic data that the same constraint topology fits exactly, and a solution
    of it: ``(model', formulation, x)``, or None if the constraints without values cannot
    all hold."""
    free = copy.deepcopy(model)
    free.bodies = {}
    for e in free.entities.values():
        e.fixed, e.body, e.point, e.direction = False, None, None, None
    free.constraints = [c for c in model.constraints if _valueless(c, model)]
    geo, x = find_solution(free, rng, L)
    if x is None:
        return None
    world = geo.placements(x)
    m2 = copy.deepcopy(model)
    poses = {b: (_rotation(rng), rng.uniform(-L, L, 3)) for b, body in m2.bodies.items() if not body.fixed}
    for n, e in m2.entities.items():
        p = world[n]
        d = None if p.type == "point" else p.d / np.linalg.norm(p.d)
        pt = p.d / np.linalg.norm(p.d) * float(p.h) / float(np.linalg.norm(p.d)) if p.type == "plane" else p.p
        if e.body is not None:
            R, t = poses[e.body]
            e.point = R.T @ (pt - t)
            e.direction = None if d is None else R.T @ d
        else:
            e.point, e.direction = pt, d
            if not e.fixed:
                e.point, e.direction = None, None
    for c in m2.constraints:
        if c.type in ("distance", "angle") and not _valueless(c, model):
            c.value = _measure(c, world)
            c.param, c.squared = None, False
    places = {n: world[n] for n in m2.entities}
    geo2 = explicit(m2, L)
    x2 = geo2.encode(places, poses)
    comp = geo2.system.compile()
    x2, res = levenberg_marquardt(comp, x2, _tol(L), iters=20)
    if res > 1e-6 * max(1.0, L * L):
        return None
    return m2, geo2, x2


def _measure(c, world: dict[str, Placement]) -> float:
    from ..answer.assembly import deviation

    probe = copy.copy(c)
    probe.value, probe.param, probe.squared = 0.0, None, False
    tmp = ConstraintSystem("probe", {}, {}, [probe])
    # the deviation from a zero value is the measured value
    return deviation(tmp, probe, world)


# ----------------------------------------------------------------------------------------------
# inconsistency
# ----------------------------------------------------------------------------------------------
def _consistent(model: ConstraintSystem, idx: list[int], rng, L: float, starts: int) -> bool:
    return find_solution(model.subset(idx), rng, L, starts)[1] is not None


def minimal_inconsistent(model: ConstraintSystem, rng, L: float, starts: int = 6) -> list[int]:
    """Indices of a minimal set of constraints with no solution found: the shortest
    inconsistent prefix, then a deletion filter over it."""
    n = len(model.constraints)
    lo, hi = 0, n  # prefix lo consistent, prefix hi not
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if _consistent(model, list(range(mid)), rng, L, starts):
            lo = mid
        else:
            hi = mid
    S = list(range(hi))
    for i in list(S[:-1]):
        T = [j for j in S if j != i]
        if not _consistent(model, T, rng, L, starts):
            S = T
    return S


def prove_inconsistent(model: ConstraintSystem, idx: list[int], pin, radius) -> bool:
    """A complete search proves that no solution of the constraints ``idx`` lies in the
    world box of the whole system (where all its solutions lie), for the input as given (the
    core rows' enclosures, :mod:`kinbox.formulation.enclose_constraints`)."""
    from ..formulation.enclose_constraints import enclose
    from ..formulation.geometry import formulate as geo_formulate

    sub = model.subset(idx)
    try:
        geo = geo_formulate(sub, pin=pin, radius=radius)
    except Exception:  # noqa: BLE001 - a subset may not be formulable (then nothing is proven)
        return False
    enclose(geo.system, lambda num: geo_formulate(sub, pin=pin, radius=radius, numbers=num).system)
    raw = solver.solve_system(geo.system, solver.SolverOptions(sigma=0.05, max_boxes=PROOF_BOXES, progress=False))
    return raw.complete and not raw.boxes


# ----------------------------------------------------------------------------------------------
def _pin(model: ConstraintSystem, geo: GeometryFormulation, x: np.ndarray | None, L: float) -> list[str] | None:
    """Three free points that pin the frame at the solution ``x``: the first point, the first
    point apart from it, the first point off their line (file order)."""
    if model.has_fixed or any(not b.fixed for b in model.bodies.values()):
        return None
    pts = [n for n, e in model.entities.items() if e.type == "point" and e.free]
    if x is None:
        return pts[:3] if len(pts) >= 3 else None
    pl = geo.placements(x)
    tol = 1e-6 * L
    if not pts:
        return None
    a = pts[0]
    b = next((q for q in pts[1:] if np.linalg.norm(pl[q].p - pl[a].p) > tol), None)
    if b is None:
        return None
    u = (pl[b].p - pl[a].p) / np.linalg.norm(pl[b].p - pl[a].p)
    for q in pts[1:]:
        if q == b:
            continue
        w = pl[q].p - pl[a].p
        if np.linalg.norm(w - np.dot(w, u) * u) > tol:
            return [a, b, q]
    return None


def diagnose(model: ConstraintSystem, seed: int = SEED) -> Diagnosis:
    """Degrees of freedom, redundant and inconsistent constraints, under-constrained entities."""
    rng = np.random.default_rng(seed)
    L = scale(model)
    rigid = 0 if model.has_fixed else 6
    geo, x = find_solution(model, rng, L)
    diag = Diagnosis(consistent=x is not None, dof=None, generic_dof=None, rigid_motions=rigid)
    w = witness(model, rng, L)
    if w is not None:
        _, gw, xw = w
        Vw = rigid_velocities(gw, xw) if rigid else None
        kw = _rank(Vw) if Vw is not None else 0
        d0, diag.generic = sequential(gw, xw)
        _fill_left(diag.generic, d0 - kw)
        diag.generic_dof = (d0 - sum(s.removes for s in diag.generic)) - kw
        diag.rigid_motions = kw if rigid else 0
    else:
        diag.notes.append("the constraints without values (incidences, parallelism, perpendicularity) cannot all hold for generic data")
    if x is not None:
        diag.solution = (geo.placements(x), geo.body_poses(x))
        V = rigid_velocities(geo, x) if rigid else None
        k = _rank(V) if V is not None else 0
        d0, diag.at_solution = sequential(geo, x)
        _fill_left(diag.at_solution, d0 - k)
        diag.dof = (d0 - sum(s.removes for s in diag.at_solution)) - k
        pin = _pin(model, geo, x, L)
        diag.underconstrained = underconstrained(geo, x, _gauge(geo, pin) if rigid else None)
        if rigid and k < 6:
            diag.notes.append(f"the solution found is invariant under {6 - k} rigid motion(s) (e.g. all on one line)")
    else:
        diag.consistent = None
        S = minimal_inconsistent(model, rng, L)
        diag.inconsistent = [model.constraints[i].label for i in S]
        diag.inconsistent_indices = list(S)
    diag.pin = _pin(model, geo, x, L)
    return diag


def in_frame(model: ConstraintSystem, geo: GeometryFormulation, places: dict, poses: dict):
    """Placements and poses moved into the frame of ``geo`` (a formulation with a frame): the
    pinned points onto the origin, the +x axis and the xy plane, or the held body onto its
    given placement; unchanged when entities are fixed."""
    if model.has_fixed:
        return places, poses
    if geo.pinned:
        a, b, c = (places[p].p for p in geo.pinned)
        e1 = (b - a) / np.linalg.norm(b - a)
        w = (c - a) - np.dot(c - a, e1) * e1
        e2 = w / np.linalg.norm(w)
        R = np.array([e1, e2, np.cross(e1, e2)])
        t = -R @ a
    else:
        held = next(b for b, body in model.bodies.items() if not body.fixed)
        Rb, tb = poses[held]
        R, t = Rb.T, -Rb.T @ tb
    return ({n: moved(p, R, t) for n, p in places.items()}, {b: (R @ Rb, R @ tb + t) for b, (Rb, tb) in poses.items()})


def _fill_left(sts: list[Status], start: int) -> None:
    left = start
    for st in sts:
        left -= st.removes
        st.left = left


def refuse_if_inconsistent(model: ConstraintSystem, diag: Diagnosis) -> None:
    """Raise :class:`InconsistentError` if the diagnosis's minimal inconsistent set is proven
    to have no solution (a complete interval search); record the outcome in ``diag``."""
    S = diag.inconsistent_indices
    if not S:
        return
    from ..formulation.geometry import reach

    pin = diag.pin
    if pin is None and not model.has_fixed and not any(not b.fixed for b in model.bodies.values()):
        pin = [n for n, e in model.entities.items() if e.type == "point" and e.free][:3]
    try:
        radius = reach(model, (pin or [])[:1])
        if prove_inconsistent(model, S, pin, radius):
            diag.proven = True
            diag.consistent = False
    except Exception:  # noqa: BLE001 - an unbounded system: nothing proven, the search decides
        return
    if diag.proven:
        raise InconsistentError(diag.message)


# ----------------------------------------------------------------------------------------------
# mechanisms
# ----------------------------------------------------------------------------------------------
_CLOSURE_ROWS = {"weld": 6, "point": 3, "distance": 1}
#: conditions of a closure between bodies that move in parallel planes
_PLANAR_CLOSURE_ROWS = {"weld": 3, "point": 2, "distance": 1}
#: two configurations found closer than this (Pinocchio's difference, free joints) are one
SAME_CONFIGURATION = 1e-6


@dataclass
class MechanismDiagnosis:
    """Mobility of a mechanism: by counting (Chebychev-Grübler-Kutzbach: the joints' degrees
    of freedom minus the loop closures' conditions, for generic geometry) and at solutions (the
    joints' degrees of freedom minus the rank of the closures' Jacobian there)."""

    joints_dof: int
    closure_conditions: int
    #: local mobility -> how many of the configurations found have it
    at_solutions: dict[int, int]
    #: closure equations that are dependent at the configurations found (count -> configurations)
    redundant_conditions: dict[int, int]
    starts: int
    #: counted in the plane (every body moves in parallel planes: 3 dof per rigid closure)
    planar: bool = False
    #: distinct configurations among those found (starts that met the same one counted once)
    distinct: int | None = None

    @property
    def counted_mobility(self) -> int:
        return self.joints_dof - self.closure_conditions

    def to_dict(self) -> dict:
        return {
            "joints_dof": self.joints_dof,
            "closure_conditions": self.closure_conditions,
            "counted_mobility": self.counted_mobility,
            "mobility_at_solutions": {str(k): v for k, v in sorted(self.at_solutions.items())},
            "redundant_conditions_at_solutions": {str(k): v for k, v in sorted(self.redundant_conditions.items())},
            "starts": self.starts,
            "planar": self.planar,
            "distinct_configurations": self.distinct,
        }

    def report(self, name: str) -> str:
        lines = [
            f"{name}:",
            f"  mobility by counting (generic geometry{', in the plane' if self.planar else ''}): {self.joints_dof} joint dof - "
            f"{self.closure_conditions} closure conditions = {self.counted_mobility}",
        ]
        if self.at_solutions:
            found = ", ".join(f"{v} configuration(s) with mobility {k}" for k, v in sorted(self.at_solutions.items()))
            lines.append(
                f"  at the distinct configurations found from {self.starts} random starts (a sample; "
                f"`kinbox solve` finds them all): {found}"
            )
            red = ", ".join(f"{k} dependent condition(s) at {v}" for k, v in sorted(self.redundant_conditions.items()))
            lines.append(f"  redundant closure conditions: {red}")
            if max(self.at_solutions) > max(self.counted_mobility, 0):
                lines.append("  the geometry is special: the mechanism moves more than counting predicts")
        else:
            lines.append(f"  no configuration closing every loop found from {self.starts} random starts")
        return "\n".join(lines)


def diagnose_mechanism(mech, seed: int = SEED, starts: int = STARTS) -> MechanismDiagnosis:
    """Mobility by counting and by the rank of Pinocchio's closure Jacobians at configurations
    that close the loops (Gauss-Newton from random configurations)."""
    import pinocchio as pin

    from ..answer.refine import closure_errors

    model = mech.model
    data = model.createData()
    locked = {model.getJointId(n): np.asarray(v, dtype=float) for n, v in mech.locked.items()}
    free_v: list[int] = []
    for jid in range(1, model.njoints):
        if jid not in locked:
            j = model.joints[jid]
            free_v.extend(range(j.idx_v, j.idx_v + j.nv))
    fv = np.array(free_v, dtype=int)
    q0 = pin.neutral(model)
    for jid, v in locked.items():
        q0[model.joints[jid].idx_q : model.joints[jid].idx_q + model.joints[jid].nq] = v
    planar = plane_normal(mech, q0) is not None
    m = sum((_PLANAR_CLOSURE_ROWS if planar else _CLOSURE_ROWS)[c.kind] for c in mech.closures)
    found: list[np.ndarray] = []
    # revolute joints of one q entry: angles that differ by turns are one configuration
    turns = np.zeros(model.nv, dtype=bool)
    for jid in range(1, model.njoints):
        j = model.joints[jid]
        if j.nq == 1 and j.shortname().startswith(("JointModelR", "JointModelRevolute")) and "Unbounded" not in j.shortname():
            turns[j.idx_v] = True

    def apart(qa: np.ndarray, qb: np.ndarray) -> float:
        d = pin.difference(model, qa, qb)
        d[turns] = np.remainder(d[turns] + math.pi, 2 * math.pi) - math.pi
        return float(np.linalg.norm(d[fv]))

    rng = np.random.default_rng(seed)
    # pin.randomConfiguration draws from Pinocchio's own generator: seeded too, so that every
    # call gives the same starts (tests/cli/test_cli_constraints.py::test_check_is_public_and_the_command_prints_it)
    pin.seed(seed)
    lo = np.where(np.isfinite(model.lowerPositionLimit), model.lowerPositionLimit, -math.pi)
    hi = np.where(np.isfinite(model.upperPositionLimit), model.upperPositionLimit, math.pi)
    lo, hi = np.maximum(lo, -10.0), np.minimum(hi, 10.0)

    def errors(q):
        e, J = closure_errors(mech, data, q)
        assert J is not None
        return e, J[:, fv]

    dofs: dict[int, int] = {}
    reds: dict[int, int] = {}
    if not mech.closures:
        return MechanismDiagnosis(len(fv), 0, {len(fv): 1}, {0: 1}, 0)
    for _ in range(starts):
        q = pin.randomConfiguration(model, lo, hi) if model.nq == model.nv else pin.neutral(model)
        if model.nq != model.nv:
            q = pin.integrate(model, q, rng.uniform(-math.pi, math.pi, model.nv))
        for jid, v in locked.items():
            j = model.joints[jid]
            q[j.idx_q : j.idx_q + j.nq] = v
        lam = 1e-6
        e, J = errors(q)
        for _it in range(200):
            if np.max(np.abs(e)) < 1e-11:
                break
            A = np.vstack([J, math.sqrt(lam) * np.eye(len(fv))])
            dv = np.zeros(model.nv)
            dv[fv] = np.linalg.lstsq(A, np.concatenate([-e, np.zeros(len(fv))]), rcond=None)[0]
            qn = pin.integrate(model, q, dv)
            en, Jn = errors(qn)
            if float(en @ en) < float(e @ e):
                q, e, J, lam = qn, en, Jn, max(lam / 4, 1e-15)
            else:
                lam *= 8
                if lam > 1e12:
                    break
        if np.max(np.abs(e)) < 1e-10:
            if any(apart(q, o) < SAME_CONFIGURATION for o in found):
                continue  # a configuration met from another start already
            found.append(q)
            r = _rank(J)
            dofs[len(fv) - r] = dofs.get(len(fv) - r, 0) + 1
            reds[m - r] = reds.get(m - r, 0) + 1
    return MechanismDiagnosis(len(fv), m, dofs, reds, starts, planar=planar, distinct=len(found))
