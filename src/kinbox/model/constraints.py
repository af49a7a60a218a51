"""Geometric constraint systems: points, lines and planes under distances, angles, incidences.

A :class:`ConstraintSystem` is the model of ``{"kind": "constraints", ...}`` files
(``docs/constraints.md``): entities (points, lines, planes), free or fixed, optionally
grouped into rigid **bodies** (the parts of Ruiz 1994: features given in the body's own frame),
and constraints between two entities:

* ``distance``: point-point, point-line, point-plane, line-line (the common perpendicular),
  line-plane and plane-plane (the line or plane parallel, at that distance);
* ``angle`` (radians): line-line, line-plane, plane-plane;
* ``incident`` (``on``, ``coincident``): any pair (point on line, line in plane, equal points...);
* ``parallel``, ``perpendicular``: lines and planes.

Values are numbers or names of ``parameters`` (``--set name=value`` changes them); a distance
may be given squared (``"squared": 4.25``, as Porta et al. 2005 gives them). Every check here raises
:class:`~kinbox.errors.ModelError` with one line naming the entity or constraint at fault.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import MAX_ENTITIES, ModelError, NameNotFound, read_json

ENTITY_TYPES = ("point", "line", "plane")
#: constraint type -> canonical name
CONSTRAINT_TYPES = {
    "distance": "distance",
    "angle": "angle",
    "incident": "incident",
    "on": "incident",
    "coincident": "incident",
    "parallel": "parallel",
    "perpendicular": "perpendicular",
}
#: keys of a constraints file that are documentation only
_META_KEYS = {"kind", "name", "description", "source", "note", "notes", "reference", "expected", "frame"}
#: where the built-in constraint systems live (package data)
BUILTIN_DIR = Path(__file__).resolve().parents[1] / "robots" / "constraints"
#: how many independent conditions each constraint imposes in general (its codimension)
_CODIM = {
    ("distance", "point", "point"): 1,
    ("distance", "point", "line"): 1,
    ("distance", "point", "plane"): 1,
    ("distance", "line", "line"): 1,
    ("distance", "line", "plane"): 2,
    ("distance", "plane", "plane"): 3,
    ("angle", "line", "line"): 1,
    ("angle", "line", "plane"): 1,
    ("angle", "plane", "plane"): 1,
    ("incident", "point", "point"): 3,
    ("incident", "point", "line"): 2,
    ("incident", "point", "plane"): 1,
    ("incident", "line", "line"): 4,
    ("incident", "line", "plane"): 2,
    ("incident", "plane", "plane"): 3,
    ("parallel", "line", "line"): 2,
    ("parallel", "line", "plane"): 1,
    ("parallel", "plane", "plane"): 2,
    ("perpendicular", "line", "line"): 1,
    ("perpendicular", "line", "plane"): 2,
    ("perpendicular", "plane", "plane"): 1,
}
_ORDER = {"point": 0, "line": 1, "plane": 2}


@dataclass
class Entity:
    """A point, line or plane. ``point``/``direction`` are its data: for a fixed entity in the
    world frame, for a body's feature in the body's frame, ``None`` for a free entity. A line is
    ``point + t direction``, a plane ``{x : normal . (x - point) = 0}`` (``direction`` holds the
    unit normal)."""

    name: str
    type: str
    fixed: bool = False
    body: str | None = None
    # (None for a free entity, direction None for a point: typed Any for brevity)
    point: Any = None
    direction: Any = None
    #: the direction (or normal) as the file gives it, before normalizing (None: ``direction``
    #: itself): the exact unit vector is this divided by its exact length
    #: (:mod:`kinbox.formulation.enclose_constraints` encloses ``direction``'s distance to it)
    given_direction: Any = None

    @property
    def free(self) -> bool:
        return not self.fixed and self.body is None


@dataclass
class Body:
    """A rigid part: its features (entity names) keep their relative placement."""

    name: str
    entities: list[str]
    fixed: bool = False


@dataclass
class Constraint:
    index: int
    type: str
    entities: tuple[str, str]
    value: float | None = None
    #: the parameter that gives the value (``--set`` changes it), if any
    param: str | None = None
    squared: bool = False  # the value (or parameter) is the squared distance
    name: str | None = None

    @property
    def label(self) -> str:
        """How messages name the constraint: ``#3 (distance p1-L)`` or its own name."""
        base = f"#{self.index + 1} ({self.type} {self.entities[0]}-{self.entities[1]})"
        return f"{self.name} {base}" if self.name else base

    @property
    def key(self) -> str:
        """A short identifier for variable and row names."""
        return f"c{self.index + 1}"


@dataclass
class ConstraintSystem:
    name: str
    entities: dict[str, Entity]
    bodies: dict[str, Body]
    constraints: list[Constraint]
    parameters: dict[str, float] = field(default_factory=dict)
    #: half-width of the world box, if the file gives one
    bounds: float | None = None
    meta: dict[str, Any] = field(default_factory=dict)

    # -- values ----------------------------------------------------------------------------
    def value(self, c: Constraint) -> float:
        """The constraint's value (a distance, or an angle in radians); squared distances are
        returned as distances."""
        v = self.parameters[c.param] if c.param is not None else c.value
        if v is None:
            raise ModelError(f"constraint {c.label} has no value")
        return math.sqrt(v) if c.squared else float(v)

    def types(self, c: Constraint) -> tuple[str, str]:
        return self.entities[c.entities[0]].type, self.entities[c.entities[1]].type

    def codim(self, c: Constraint) -> int:
        """How many independent conditions ``c`` imposes on entities in general position (a
        distance 0 is an incidence, except between lines: they meet; an angle 0 or pi/2 is
        parallelism or perpendicularity)."""
        a, b = sorted(self.types(c), key=_ORDER.__getitem__)
        t = c.type
        if t == "distance" and self.value(c) == 0.0 and not a == b == "line":
            t = "incident"
        elif t == "angle":
            v = min(self.value(c), math.pi - self.value(c))
            t = "parallel" if v == 0.0 else "perpendicular" if v == math.pi / 2 else t
        return _CODIM[(t, a, b)]

    @property
    def has_fixed(self) -> bool:
        return any(e.fixed for e in self.entities.values()) or any(b.fixed for b in self.bodies.values())

    # -- variants ----------------------------------------------------------------------------
    def with_parameters(self, values: Mapping[str, float] | None) -> ConstraintSystem:
        """A copy with parameters set (``--set``); an unknown name raises NameNotFound."""
        out = copy.deepcopy(self)
        for k, v in (values or {}).items():
            if k not in out.parameters:
                known = ", ".join(sorted(out.parameters)) or "none"
                raise NameNotFound(f"{self.name}: no parameter named {k!r} (parameters: {known})")
            out.parameters[k] = _number(v, f"parameter {k!r}")
        for c in out.constraints:
            _check_value(out, c)
        return out

    def subset(self, indices: Iterable[int]) -> ConstraintSystem:
        """The same entities with only the constraints at ``indices`` (their labels keep the
        original numbers)."""
        keep = sorted(set(indices))
        out = copy.copy(self)
        out.constraints = [self.constraints[i] for i in keep]
        return out

    def constraint(self, label: str) -> Constraint:
        for c in self.constraints:
            if label in (c.name, c.key, f"#{c.index + 1}"):
                return c
        raise NameNotFound(f"{self.name}: no constraint {label!r}")


# ----------------------------------------------------------------------------------------------
# loading
# ----------------------------------------------------------------------------------------------
def builtin_constraint_files() -> dict[str, Path]:
    """name -> file of the built-in constraint systems (``robots/constraints/*.json``)."""
    if not BUILTIN_DIR.is_dir():
        return {}
    return {p.stem: p for p in sorted(BUILTIN_DIR.glob("*.json"))}


def is_constraints_source(source) -> bool:
    """Is ``source`` a constraint system: a dict, a file with ``"kind": "constraints"``, or the
    name of a built-in one?"""
    if isinstance(source, ConstraintSystem):
        return True
    if isinstance(source, Mapping):
        return source.get("kind") == "constraints"
    if not isinstance(source, (str, Path)):
        return False
    p = Path(source)
    if p.suffix.lower() == ".json" and p.is_file():
        from ..errors import KinboxError

        try:  # within the input limits; a refused file is left to the loader, which names why
            d = read_json(p, ModelError, "constraint system")
        except KinboxError:
            return False
        return isinstance(d, dict) and d.get("kind") == "constraints"
    return str(source) in builtin_constraint_files()


def load_constraints(source) -> ConstraintSystem:
    """A :class:`ConstraintSystem` from a dict, a JSON file or a built-in name."""
    if isinstance(source, ConstraintSystem):
        return source
    if isinstance(source, Mapping):
        return parse(dict(source), name=str(source.get("name", "constraints")))
    p = Path(source)
    if not p.is_file():
        files = builtin_constraint_files()
        if str(source) in files:
            p = files[str(source)]
        else:
            raise NameNotFound(f"no constraint system {str(source)!r} (not a file; built-in: {', '.join(files)})")
    d = read_json(p, ModelError, "constraint system")
    if not isinstance(d, dict):
        raise ModelError(f"{p}: a constraint system is a JSON object")
    return parse(d, name=str(d.get("name", p.stem)))


def parse(d: dict, name: str = "constraints") -> ConstraintSystem:
    """Validate a constraint-system dict (the JSON file's content)."""
    if d.get("kind") != "constraints":
        raise ModelError(f'{name}: "kind" must be "constraints" (got {d.get("kind")!r})')
    known = _META_KEYS | {"entities", "bodies", "constraints", "parameters", "bounds"}
    for k in d:
        if k not in known:
            raise ModelError(f"{name}: unknown key {k!r} (known: {', '.join(sorted(known))})")
    params: dict[str, float] = {}
    raw_params = d.get("parameters", {})
    if not isinstance(raw_params, dict):
        raise ModelError(f'{name}: "parameters" must be an object name -> number')
    for k, v in raw_params.items():
        params[str(k)] = _number(v, f"parameter {k!r}")
    entities: dict[str, Entity] = {}
    raw_ents = d.get("entities", {})
    if not isinstance(raw_ents, dict):
        raise ModelError(f'{name}: "entities" must be an object name -> entity')
    _refuse_too_many(d, name)
    for en, spec in raw_ents.items():
        entities[str(en)] = _entity(str(en), spec, body=None)
    bodies: dict[str, Body] = {}
    raw_bodies = d.get("bodies", {})
    if not isinstance(raw_bodies, dict):
        raise ModelError(f'{name}: "bodies" must be an object name -> body')
    for bn, spec in raw_bodies.items():
        bn = str(bn)
        if not isinstance(spec, dict) or not isinstance(spec.get("entities"), dict) or not spec["entities"]:
            raise ModelError(f'body {bn!r}: needs "entities", an object name -> feature')
        for k in spec:
            if k not in ("entities", "fixed", "description", "note"):
                raise ModelError(f"body {bn!r}: unknown key {k!r}")
        fixed = spec.get("fixed", False)
        if not isinstance(fixed, bool):
            raise ModelError(f'body {bn!r}: "fixed" must be true or false')
        names = []
        for en, fs in spec["entities"].items():
            en = str(en)
            if en in entities:
                raise ModelError(f"entity {en!r} is defined twice (in body {bn!r} and elsewhere)")
            e = _entity(en, fs, body=bn)
            if fixed:
                e.fixed, e.body = True, None  # a fixed body's features are fixed entities
            entities[en] = e
            names.append(en)
        bodies[bn] = Body(bn, names, fixed)
        if not fixed:
            _check_body_pose(bodies[bn], entities)
    if not entities:
        raise ModelError(f"{name}: no entities")
    cons: list[Constraint] = []
    raw_cons = d.get("constraints", [])
    if not isinstance(raw_cons, list):
        raise ModelError(f'{name}: "constraints" must be a list')
    sysm = ConstraintSystem(name, entities, bodies, cons, params, None, {k: d[k] for k in _META_KEYS if k in d})
    for i, spec in enumerate(raw_cons):
        cons.append(_constraint(sysm, i, spec))
    if "bounds" in d:
        b = _number(d["bounds"], '"bounds"')
        if not b > 0:
            raise ModelError(f'{name}: "bounds" must be a positive number (half-width of the world box)')
        sysm.bounds = b
    return sysm


def _refuse_too_many(d: dict, name: str) -> None:
    """At most :data:`~kinbox.errors.MAX_ENTITIES` entities (body features included) and
    eight constraints per entity, counted before anything is built
    (tests/cli/test_hostile.py::test_constraint_chain_refused)."""

    def size(x) -> int:
        return len(x) if isinstance(x, (dict, list)) else 0

    bodies = d.get("bodies", {})
    n = size(d.get("entities")) + sum(
        size(b.get("entities")) for b in (bodies.values() if isinstance(bodies, dict) else []) if isinstance(b, dict)
    )
    if n > MAX_ENTITIES:
        raise ModelError(f"{name}: {n} entities, more than the limit of {MAX_ENTITIES} (its diagnosis would take too long)")
    cons = d.get("constraints", [])
    if isinstance(cons, list) and len(cons) > 8 * MAX_ENTITIES:
        raise ModelError(f"{name}: {len(cons)} constraints, more than the limit of {8 * MAX_ENTITIES}")


def _number(v, what: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ModelError(f"{what} must be a number, got {v!r}")
    x = float(v)
    if not math.isfinite(x):
        raise ModelError(f"{what} is not finite")
    return x


def _vec(v, what: str) -> np.ndarray:
    if not isinstance(v, (list, tuple)) or len(v) != 3:
        raise ModelError(f"{what} must be a list of 3 numbers, got {v!r}")
    return np.array([_number(x, what) for x in v], dtype=float)


def _unit(v, what: str) -> np.ndarray:
    x = _vec(v, what)
    n = float(np.linalg.norm(x))
    if n < 1e-12:
        raise ModelError(f"{what} is the zero vector")
    return x / n


def _entity(name: str, spec, body: str | None) -> Entity:
    where = f"entity {name!r}" + (f" (body {body!r})" if body else "")
    if not isinstance(spec, dict):
        raise ModelError(f'{where}: must be an object with a "type"')
    t = spec.get("type")
    if t not in ENTITY_TYPES:
        raise ModelError(f"{where}: type must be one of {', '.join(ENTITY_TYPES)}, got {t!r}")
    allowed = {"type", "fixed", "description", "note"} | ({"at", "point", "direction", "normal"} if body else set())
    for k in spec:
        if k not in allowed:
            raise ModelError(f"{where}: unknown key {k!r}")
    e = Entity(name, t, body=body)
    if body is not None:
        data: Any = spec
        if t == "point":
            data = spec.get("at", spec.get("point"))
        if data is None:
            need = '"at": [x, y, z]' if t == "point" else '"point" and "' + ("direction" if t == "line" else "normal") + '"'
            raise ModelError(f"{where}: a body's feature needs its placement in the body frame ({need})")
        _place(e, data, where)
        return e
    fx = spec.get("fixed")
    if fx is None or fx is False:
        return e
    e.fixed = True
    _place(e, fx, where)
    return e


def _place(e: Entity, data, where: str) -> None:
    if e.type == "point":
        e.point = _vec(data, f"{where}: position")
        return
    if not isinstance(data, dict):
        key = "direction" if e.type == "line" else "normal"
        raise ModelError(f"{where}: a {e.type} is placed by {{'point': [...], '{key}': [...]}}")
    key = "direction" if e.type == "line" else "normal"
    if "point" not in data or key not in data:
        raise ModelError(f'{where}: a {e.type} needs "point" and "{key}"')
    e.point = _vec(data["point"], f"{where}: point")
    e.direction = _unit(data[key], f"{where}: {key}")
    e.given_direction = _vec(data[key], f"{where}: {key}")


def _check_body_pose(b: Body, entities: dict[str, Entity]) -> None:
    """A free body's features must fix its pose: no rigid motion may leave them all in place
    (else the body's rotation would be a spurious continuum of solutions)."""
    rows = []
    for k in range(6):
        w = np.zeros(3)
        v = np.zeros(3)
        (w if k < 3 else v)[k % 3] = 1.0
        vel = []
        for en in b.entities:
            e = entities[en]
            if e.type == "point":
                vel += list(np.cross(w, e.point) + v)
            else:
                d = e.direction
                vel += list(np.cross(w, d))  # the direction (or normal) turns
                pv = np.cross(w, e.point) + v
                if e.type == "line":
                    vel += list(pv - np.dot(pv, d) * d)  # the line moves across itself
                else:
                    vel.append(float(np.dot(pv, d)))  # the plane moves along its normal
        rows.append(vel)
    s = np.linalg.svd(np.array(rows), compute_uv=False)
    rank = int(np.sum(s > 1e-9 * max(1.0, s[0])))
    if rank < 6:
        raise ModelError(
            f"body {b.name!r}: its features do not fix its pose ({6 - rank} rigid motion(s) leave "
            f"them in place): add a feature off their line, or use free entities"
        )


def _constraint(s: ConstraintSystem, i: int, spec) -> Constraint:
    where = f"constraint #{i + 1}"
    if not isinstance(spec, dict):
        raise ModelError(f'{where}: must be an object with "type" and "entities"')
    if isinstance(spec.get("name"), str):
        where = f"constraint {spec['name']} #{i + 1}"
    for k in spec:
        if k not in ("type", "entities", "value", "squared", "name", "description", "note"):
            raise ModelError(f"{where}: unknown key {k!r}")
    t = CONSTRAINT_TYPES.get(spec.get("type"))  # type: ignore[arg-type]
    if t is None:
        raise ModelError(f"{where}: type must be one of {', '.join(sorted(CONSTRAINT_TYPES))}, got {spec.get('type')!r}")
    ents = spec.get("entities")
    if not isinstance(ents, list) or len(ents) != 2 or not all(isinstance(x, str) for x in ents):
        raise ModelError(f'{where} ({t}): "entities" must be a list of two entity names')
    for en in ents:
        if en not in s.entities:
            raise ModelError(f"{where} ({t}): unknown entity {en!r}")
    if ents[0] == ents[1]:
        raise ModelError(f"{where} ({t}): relates {ents[0]!r} to itself")
    c = Constraint(i, t, (ents[0], ents[1]), name=spec.get("name") if isinstance(spec.get("name"), str) else None)
    ta, tb = s.types(c)
    pair = tuple(sorted((ta, tb), key=_ORDER.__getitem__))
    if (t, *pair) not in _CODIM:
        raise ModelError(f"constraint {c.label}: {t} is not defined between a {ta} and a {tb}")
    has_value = "value" in spec or "squared" in spec
    if t in ("distance", "angle"):
        if "value" in spec and "squared" in spec:
            raise ModelError(f'constraint {c.label}: give "value" or "squared", not both')
        if not has_value:
            raise ModelError(f'constraint {c.label}: needs a "value" (a number or a parameter name)')
        if "squared" in spec and t != "distance":
            raise ModelError(f'constraint {c.label}: only distances can be given "squared"')
        raw = spec.get("value", spec.get("squared"))
        c.squared = "squared" in spec
        if isinstance(raw, str):
            if raw not in s.parameters:
                raise ModelError(f"constraint {c.label}: unknown parameter {raw!r}")
            c.param = raw
        else:
            c.value = _number(raw, f"constraint {c.label}: value")
        _check_value(s, c)
    elif has_value:
        raise ModelError(f"constraint {c.label}: an {t} constraint takes no value")
    a, b = (s.entities[x] for x in c.entities)
    if a.body is not None and a.body == b.body:
        raise ModelError(f"constraint {c.label}: both entities belong to body {a.body!r} (their relation is fixed)")
    return c


def _check_value(s: ConstraintSystem, c: Constraint) -> None:
    if c.type not in ("distance", "angle"):
        return
    raw = s.parameters[c.param] if c.param is not None else c.value
    assert raw is not None
    if c.type == "distance" and raw < 0:
        raise ModelError(f"constraint {c.label}: a distance cannot be negative ({raw:g})")
    if c.type == "angle" and not (0.0 <= raw <= math.pi):
        raise ModelError(f"constraint {c.label}: an angle is in radians, between 0 and pi (got {raw:g})")
