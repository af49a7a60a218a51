"""Collision scenes: a robot's own collision geometry plus obstacles, as Pinocchio and coal see them.

A scene file (``docs/scenes.md``) is JSON::

    {"kind": "scene",
     "obstacles": [{"name": "table", "shape": "box", "size": [1.2, 0.8, 0.04], "pose": [0.5, 0, -0.02, 0, 0, 0, 1]}, ...],
     "environment": [{"urdf": "cell.urdf", "pose": [0, 0, 0, 0, 0, 0, 1]}],
     "allow": [["base_link", "table"]],
     "margin": 0.0}

Shapes: ``box`` (``size``), ``sphere`` (``radius``), ``cylinder`` and ``capsule`` (``radius``,
``length`` along z), ``mesh`` (``file``, relative to the scene file, ``scale``). Poses are
``x y z qx qy qz qw`` in the world frame. :func:`read_scene` checks a file as all input is
checked (one line naming the problem, :class:`~kinbox.errors.InputError`);
:func:`build_scene` loads the robot's collision geometry (``pin.buildGeomFromUrdf``; the
SRDF's disabled pairs, or, without an SRDF, no pair of links joined by a joint), adds the
obstacles and classifies every pair of geometries:

* *active*: checked at every configuration;
* *disabled*: the SRDF says they never touch, they are joined by a joint, or the scene's
  ``allow`` lists them;
* *skipped*: both are fixed to the world (the same at every configuration), or the obstacle
  lies outside the moving geometry's reach (a ball about the chain's first joint whose radius
  bounds every point of the geometry over all joint values, :func:`reach`).

Loading geometry is Pinocchio's and coal's job: nothing here parses a URDF or collides shapes.
Meshes also get coal's convex hull (``buildConvexHull``): a hull holds its mesh, so a hull
found clear of a shape proves the mesh clear (:mod:`kinbox.answer.collision`).
"""

from __future__ import annotations

import difflib
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from ..errors import MAX_INPUT_BYTES, InputError, read_json
from .mechanism import Mechanism

#: the built-in scenes: package data beside the built-in mechanisms
_SCENE_DIR = Path(__file__).resolve().parents[1] / "robots" / "scenes"
#: a scene holds at most this many obstacles (each is checked against every moving link)
MAX_OBSTACLES = 1000
SHAPES = {
    "box": ("size",),
    "sphere": ("radius",),
    "cylinder": ("radius", "length"),
    "capsule": ("radius", "length"),
    "mesh": ("file",),
}
_OPTIONAL = {"mesh": ("scale",)}
_COMMON = ("name", "shape", "pose", "color")
_TOP = ("kind", "name", "description", "obstacles", "environment", "allow", "margin")


def builtin_scenes() -> dict[str, Path]:
    """name -> file of every built-in scene (``ur5-cell``, ``panda-shelf``)."""
    if not _SCENE_DIR.is_dir():
        return {}
    return {p.stem: p for p in sorted(_SCENE_DIR.glob("*.json"))}


@dataclass
class Obstacle:
    """One obstacle of a scene: a shape fixed in the world."""

    name: str
    shape: str
    params: dict[str, Any]  # size / radius / length / file (absolute) / scale
    pose: np.ndarray  # x y z qx qy qz qw (unit quaternion)
    color: list[float] | None = None

    def placement(self) -> pin.SE3:
        return pin.XYZQUATToSE3(self.pose)

    def to_dict(self) -> dict:
        d: dict[str, Any] = {"name": self.name, "shape": self.shape, **self.params, "pose": [float(v) for v in self.pose]}
        if self.color is not None:
            d["color"] = list(self.color)
        return d


@dataclass
class SceneSpec:
    """A checked scene file: obstacles, environment URDFs, allowed pairs, margin."""

    name: str
    obstacles: list[Obstacle] = field(default_factory=list)
    environment: list[dict] = field(default_factory=list)  # {"urdf": absolute path, "pose": 7 numbers}
    allow: list[tuple[str, str]] = field(default_factory=list)
    margin: float = 0.0
    source: str = ""  # the file or built-in name it came from

    def to_dict(self) -> dict:
        """The scene as a self-contained scene dict (file paths absolute): what a result file
        carries so that ``kinbox replay`` can draw the obstacles."""
        return {
            "kind": "scene",
            "name": self.name,
            "obstacles": [o.to_dict() for o in self.obstacles],
            "environment": [dict(e) for e in self.environment],
            "allow": [list(p) for p in self.allow],
            "margin": self.margin,
        }


# -- reading and checking ---------------------------------------------------------------------------
def _number(v, what: str, positive: bool = False, nonneg: bool = False) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise InputError(f"{what} must be a number, not {v!r:.60}")
    x = float(v)
    if not math.isfinite(x):
        raise InputError(f"{what} is not finite: {v!r}")
    if positive and not x > 0:
        raise InputError(f"{what} must be positive, got {x:g}")
    if nonneg and x < 0:
        raise InputError(f"{what} must not be negative, got {x:g}")
    return x


def _vector(v, n: int, what: str, positive: bool = False) -> list[float]:
    if not isinstance(v, list) or len(v) != n:
        raise InputError(f"{what} must be a list of {n} numbers, not {v!r:.60}")
    return [_number(x, f"{what}[{k}]", positive=positive) for k, x in enumerate(v)]


def check_pose(v, what: str) -> np.ndarray:
    """A pose ``x y z qx qy qz qw``: 7 finite numbers, a unit quaternion (normalised here)."""
    p = np.array(_vector(v, 7, what))
    nq = float(np.linalg.norm(p[3:]))
    if abs(nq - 1.0) > 1e-6:
        raise InputError(f"{what}: quaternion (qx qy qz qw) = {p[3:].tolist()} is not unit (norm {nq:.6g})")
    p[3:] /= nq
    return p


def _file(value, base: Path, what: str) -> str:
    if not isinstance(value, str) or not value.strip():
        raise InputError(f'{what}: "file" must be a path string')
    p = Path(os.path.expanduser(value))
    p = p if p.is_absolute() else base / p
    if not p.exists():
        raise InputError(f"{what}: no such file {value!r}")
    if not p.is_file():  # a device, FIFO or folder: tests/cli/test_hostile.py::test_special_files_refused
        raise InputError(f"{what}: {value!r} is not a regular file")
    size = p.stat().st_size
    if size > MAX_INPUT_BYTES:
        raise InputError(f"{what}: {p.name!r} is {size / 2**20:.1f} MB, more than the limit of {MAX_INPUT_BYTES / 2**20:.0f} MB")
    return str(p.resolve())


def _obstacle(o, k: int, base: Path) -> Obstacle:
    where = f"obstacles[{k}]"
    if not isinstance(o, dict):
        raise InputError(f"{where} must be an object with name, shape and pose")
    name = o.get("name")
    if not isinstance(name, str) or not name.strip():
        raise InputError(f'{where}: "name" must be a non-empty string')
    where = f"obstacle {name!r}"
    shape = o.get("shape")
    if shape not in SHAPES:
        raise InputError(f'{where}: "shape" must be one of {", ".join(SHAPES)}, not {shape!r:.40}')
    need = SHAPES[shape]
    allowed = set(_COMMON) | set(need) | set(_OPTIONAL.get(shape, ()))
    extra = sorted(set(o) - allowed)
    if extra:
        raise InputError(f"{where}: unknown key(s) {', '.join(extra)} for a {shape} (it takes {', '.join(need)})")
    missing = [k2 for k2 in (*need, "pose") if k2 not in o]
    if missing:
        raise InputError(f"{where}: a {shape} needs {', '.join(missing)}")
    params: dict[str, Any] = {}
    if shape == "box":
        params["size"] = _vector(o["size"], 3, f"{where}: size", positive=True)
    elif shape == "mesh":
        params["file"] = _file(o["file"], base, where)
        sc = o.get("scale", 1.0)
        params["scale"] = (
            _vector(sc, 3, f"{where}: scale", positive=True)
            if isinstance(sc, list)
            else [_number(sc, f"{where}: scale", positive=True)] * 3
        )
    else:
        params["radius"] = _number(o["radius"], f"{where}: radius", positive=True)
        if "length" in need:
            params["length"] = _number(o["length"], f"{where}: length", positive=True)
    color = None
    if "color" in o:
        color = _vector(o["color"], 4, f"{where}: color")
        if not all(0 <= c <= 1 for c in color):
            raise InputError(f"{where}: color must be 4 numbers in [0, 1] (r g b a)")
    return Obstacle(name, shape, params, check_pose(o["pose"], f"{where}: pose"), color)


def scene_from_dict(d, base: Path | None = None, where: str = "scene", name: str = "scene") -> SceneSpec:
    """A checked :class:`SceneSpec` from a scene dict (files relative to ``base``)."""
    base = base or Path.cwd()
    try:
        return _scene(d, base, name)
    except InputError as e:
        raise InputError(f"{where}: {e}") from None


def _scene(d, base: Path, name: str) -> SceneSpec:
    if not isinstance(d, dict):
        raise InputError(f"a scene is a JSON object, not {type(d).__name__}")
    if d.get("kind") != "scene":
        raise InputError(f'"kind" must be "scene", not {d.get("kind")!r:.40}')
    extra = sorted(set(d) - set(_TOP))
    if extra:
        close = difflib.get_close_matches(extra[0], _TOP, n=1)
        raise InputError(f"unknown key(s) {', '.join(extra)}" + (f"; did you mean {close[0]!r}?" if close else ""))
    obs = d.get("obstacles", [])
    if not isinstance(obs, list):
        raise InputError('"obstacles" must be a list')
    if len(obs) > MAX_OBSTACLES:
        raise InputError(f"{len(obs)} obstacles, more than the limit of {MAX_OBSTACLES}")
    obstacles = [_obstacle(o, k, base) for k, o in enumerate(obs)]
    seen: set[str] = set()
    for o in obstacles:
        if o.name in seen:
            raise InputError(f"two obstacles are named {o.name!r}")
        seen.add(o.name)
    env = d.get("environment", [])
    if isinstance(env, dict):
        env = [env]
    if not isinstance(env, list):
        raise InputError('"environment" must be a list of {"urdf": FILE, "pose": [...]}')
    environment = []
    for k, e in enumerate(env):
        if not isinstance(e, dict) or "urdf" not in e or set(e) - {"urdf", "pose"}:
            raise InputError(f'environment[{k}] must be {{"urdf": FILE, "pose": [x y z qx qy qz qw]}}')
        pose = check_pose(e.get("pose", [0, 0, 0, 0, 0, 0, 1]), f"environment[{k}]: pose")
        environment.append({"urdf": _file(e["urdf"], base, f"environment[{k}]"), "pose": [float(v) for v in pose]})
    allow = d.get("allow", [])
    if not isinstance(allow, list) or not all(
        isinstance(p, list) and len(p) == 2 and all(isinstance(s, str) and s for s in p) for p in allow
    ):
        raise InputError('"allow" must be a list of name pairs, e.g. [["base_link", "table"]]')
    margin = _number(d.get("margin", 0.0), '"margin"', nonneg=True)
    label = d.get("name", name)
    if not isinstance(label, str):
        raise InputError('"name" must be a string')
    return SceneSpec(label, obstacles, environment, [(a, b) for a, b in allow], margin)


def read_scene(source) -> SceneSpec:
    """A scene from a file path, a built-in scene name (:func:`builtin_scenes`), a dict or a
    :class:`SceneSpec`; bad input raises :class:`InputError` in one line."""
    if isinstance(source, SceneSpec):
        return source
    if isinstance(source, dict):
        return scene_from_dict(source)
    if isinstance(source, os.PathLike):
        source = os.fspath(source)
    if not isinstance(source, str) or not source.strip():
        raise InputError(f"a scene is a file, a built-in scene name or a dict, not {source!r:.60}")
    path = Path(os.path.expanduser(source))
    builtins = builtin_scenes()
    if not path.exists() and source in builtins:
        path = builtins[source]
    elif not path.exists():  # a device or FIFO is refused by the reader, naming it
        close = difflib.get_close_matches(source, list(builtins), n=3)
        hint = f"did you mean {', '.join(close)}?" if close else f"built-in scenes: {', '.join(builtins)}"
        raise InputError(f"no scene file {source!r} and no built-in scene of that name; {hint}")
    d = read_json(path, InputError, "scene file")
    spec = scene_from_dict(d, path.parent, where=f"scene {path.name!r}", name=path.stem)
    spec.source = source
    return spec


# -- the robot's geometry -------------------------------------------------------------------------------
@dataclass
class RobotFiles:
    """Where a robot's collision geometry comes from."""

    kind: str  # "urdf" or "mjcf"
    path: Path
    package_dirs: list[str]
    srdf: Path | None


def robot_files(robot, mech: Mechanism) -> RobotFiles:
    """The geometry files of ``robot`` (what :func:`kinbox.model.loading.load` was given): an
    example-robot-data name (its URDF and SRDF), a URDF or MJCF file, a built-in mechanism or a
    mechanism file of kind ``urdf``/``mjcf``. A model given in code has no files: an error."""
    from .loading import builtin_files, erd_files, erd_name, erd_package_dir, normalize_name, read_mechanism_file

    what = f"{mech.name!r}"
    if isinstance(robot, os.PathLike):
        robot = os.fspath(robot)
    if not isinstance(robot, str):
        raise InputError(f"{what} was not loaded from a file or a name: a scene needs the robot's URDF (pass its path or name)")
    path = Path(os.path.expanduser(robot.strip()))
    if not path.is_file():
        builtins = builtin_files()
        key = robot if robot in builtins else normalize_name(robot)
        if key in builtins:
            path = builtins[key]
        else:
            name = erd_name(robot)
            files = erd_files(name) if name else None
            if files is None:
                raise InputError(f"{what}: no URDF to take collision geometry from")
            return RobotFiles("urdf", files.urdf, [str(files.package_dir)], files.srdf if files.srdf and files.srdf.is_file() else None)
    extra = [str(d) for d in [erd_package_dir()] if d is not None]
    if path.suffix.lower() == ".json":
        spec = read_mechanism_file(path)
        kind = str(spec.get("kind", ""))
        f = spec.get("file")
        if kind not in ("urdf", "mjcf") or not isinstance(f, str):
            raise InputError(f"{what} (kind {kind!r}) has no body geometry: a scene needs a URDF or MJCF mechanism with collision shapes")
        path = Path(f) if Path(f).is_absolute() else path.parent / f
    from .loading import _sniff_xml

    kind = "mjcf" if path.suffix.lower() == ".mjcf" else _sniff_xml(path)
    return RobotFiles(kind, path, [str(path.parent), *extra], None)


def _robot_geometry(mech: Mechanism, files: RobotFiles) -> pin.GeometryModel:
    from .loading import _call_loader

    if files.kind == "mjcf":
        return _call_loader(
            f"the collision geometry of {files.path.name!r}", pin.buildGeomFromMJCF, mech.model, str(files.path), pin.COLLISION
        )
    return _call_loader(
        f"the collision geometry of {files.path.name!r}",
        pin.buildGeomFromUrdf,
        mech.model,
        str(files.path),
        pin.COLLISION,
        None,
        files.package_dirs,
    )


def _shape(o: Obstacle):
    import coal

    p = o.params
    if o.shape == "box":
        return coal.Box(*p["size"])
    if o.shape == "sphere":
        return coal.Sphere(p["radius"])
    if o.shape == "cylinder":
        return coal.Cylinder(p["radius"], p["length"])
    if o.shape == "capsule":
        return coal.Capsule(p["radius"], p["length"])
    try:
        mesh = coal.MeshLoader().load(p["file"], np.array(p["scale"], dtype=float))
    except Exception as e:  # noqa: BLE001 - assimp raises RuntimeError, ValueError, ...
        raise InputError(f"obstacle {o.name!r}: cannot load mesh {Path(p['file']).name!r}: {_one_line(str(e))}") from None
    if mesh.num_vertices == 0:
        raise InputError(f"obstacle {o.name!r}: mesh {Path(p['file']).name!r} has no vertices")
    return mesh


def _one_line(text: str) -> str:
    """coal's loader errors span lines (file, function, line, message, hint): the message."""
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    keep = [ln for ln in lines if not ln.startswith(("From file:", "in function:", "at line:", "Hint:", "message: Could not load"))]
    return "; ".join(ln.removeprefix("message:").strip() for ln in keep) or (lines[0] if lines else "unreadable")


def _environment(entry: dict) -> list[tuple[str, pin.SE3, Any]]:
    """(link name, world placement, geometry) of every collision shape of an environment URDF,
    at its neutral configuration, placed at the entry's pose."""
    from .loading import _call_loader, erd_package_dir

    path = Path(entry["urdf"])
    model = _call_loader(f"environment URDF {path.name!r}", pin.buildModelFromUrdf, str(path))
    dirs = [str(path.parent)] + [str(d) for d in [erd_package_dir()] if d is not None]
    geom = _call_loader(
        f"the geometry of environment URDF {path.name!r}", pin.buildGeomFromUrdf, model, str(path), pin.COLLISION, None, dirs
    )
    data, gdata = model.createData(), pin.GeometryData(geom)
    pin.updateGeometryPlacements(model, data, geom, gdata, pin.neutral(model))
    at = pin.XYZQUATToSE3(np.asarray(entry["pose"], dtype=float))
    return [(model.frames[o.parentFrame].name, at * gdata.oMg[i], o.geometry) for i, o in enumerate(geom.geometryObjects)]


# -- bounds: how far a geometry reaches, how fast it moves ---------------------------------------------
_REVOLUTE = ("JointModelR", "JointModelRevolute", "JointModelRUB")
_PRISMATIC = ("JointModelP", "JointModelPrismatic")


def _joint_kind(j) -> str:
    s = j.shortname()
    if s.startswith(_PRISMATIC):
        return "prismatic"
    if s.startswith(_REVOLUTE):
        return "revolute"
    if s == "JointModelSpherical" or s == "JointModelSphericalZYX":
        return "spherical"
    return "other"


def local_sphere(geometry, placement: pin.SE3) -> tuple[np.ndarray, float]:
    """(centre in the parent joint's frame, radius) of a ball holding ``geometry`` placed at
    ``placement``: coal's local AABB centre and the radius of its corners."""
    geometry.computeLocalAABB()
    return placement.act(np.asarray(geometry.aabb_center, dtype=float)), float(geometry.aabb_radius)


def motion_bounds(model: pin.Model, parent: int, centre: np.ndarray, radius: float) -> np.ndarray:
    """``L`` (one entry per velocity index of ``model``) such that no point of a body on joint
    ``parent`` that lies in the ball (``centre`` in the joint's frame, ``radius``) moves further
    than ``sum_j L[j] |dv[j]|`` when the configuration moves by ``dv`` along
    ``pin.interpolate`` -- over all joint values within the model's limits.

    A revolute joint turns a point at distance r from its axis by at most r per radian, and r
    is at most the distance to the joint's origin: the sum of the joint offsets down the chain
    (``jointPlacements``), of the prismatic ranges on it, and of the ball's reach. A prismatic
    joint moves every point by its own motion (1 per metre); a spherical joint by r per radian
    of each component. Other joints (free flyer, planar, ...) get an infinite bound."""
    L = np.zeros(model.nv)
    chain = list(model.supports[parent])[1:]  # joints from the root down to ``parent``
    reach = float(np.linalg.norm(centre)) + radius
    # walk up: ``reach`` bounds the distance from the origin of the joint above to any point
    for jid in reversed(chain):
        j = model.joints[jid]
        kind = _joint_kind(j)
        sl = slice(j.idx_v, j.idx_v + j.nv)
        if kind == "revolute":
            L[sl] = reach
        elif kind == "spherical":
            L[sl] = reach
        elif kind == "prismatic":
            L[sl] = 1.0
            lo, hi = model.lowerPositionLimit[j.idx_q], model.upperPositionLimit[j.idx_q]
            reach += max(abs(lo), abs(hi))  # the joint's own travel, from its origin
        else:
            L[sl] = math.inf
            reach = math.inf
        reach += float(np.linalg.norm(model.jointPlacements[jid].translation))
    return L


def reach_ball(model: pin.Model, parent: int, centre: np.ndarray, radius: float) -> tuple[np.ndarray, float]:
    """(world centre, radius) of a ball holding every point of the body ball (``centre`` in
    joint ``parent``'s frame, ``radius``) over all joint values within the model's limits:
    about the origin of the chain's first joint, which no joint moves (see
    :func:`motion_bounds` for the radius)."""
    chain = list(model.supports[parent])[1:]
    if not chain:
        return centre.copy(), radius
    reach = float(np.linalg.norm(centre)) + radius
    for jid in reversed(chain):
        j = model.joints[jid]
        kind = _joint_kind(j)
        if kind == "prismatic":
            lo, hi = model.lowerPositionLimit[j.idx_q], model.upperPositionLimit[j.idx_q]
            reach += max(abs(lo), abs(hi))
        elif kind == "other":
            return np.zeros(3), math.inf
        if jid != chain[0]:
            reach += float(np.linalg.norm(model.jointPlacements[jid].translation))
    return np.array(model.jointPlacements[chain[0]].translation, dtype=float), reach


# -- the scene --------------------------------------------------------------------------------------------------
@dataclass
class CollisionScene:
    """A robot's collision geometry with a scene's obstacles, pairs classified (module doc).

    ``geom``: the geometry as loaded (meshes), holding the *active* pairs as its collision
    pairs (so that ``pin.computeCollisions`` checks exactly them); ``hull``: the same objects
    with every mesh replaced by coal's convex hull, same pairs. ``labels``: the link or
    obstacle name of each geometry; ``sphere``: (centre in the parent joint's frame, radius)
    of each; ``motion``: :func:`motion_bounds` of each (rows)."""

    model: pin.Model
    spec: SceneSpec
    geom: pin.GeometryModel
    hull: pin.GeometryModel
    labels: list[str]
    obstacle: list[bool]
    spheres: list[tuple[np.ndarray, float]]
    motion: np.ndarray
    pairs: list[tuple[int, int]]
    counts: dict[str, int]
    margin: float = 0.0
    srdf: str | None = None
    meshes: list[bool] = field(default_factory=list)

    def pair_names(self, k: int) -> tuple[str, str]:
        a, b = self.pairs[k]
        return self.labels[a], self.labels[b]

    def summary(self) -> dict:
        return {
            "name": self.spec.name,
            "geometries": len(self.labels),
            "obstacles": sum(self.obstacle),
            "srdf": self.srdf,
            "margin": self.margin,
            "pairs": dict(self.counts),
        }


def build_scene(mech: Mechanism, robot, spec: SceneSpec, srdf: str | os.PathLike | None = None) -> CollisionScene:
    """The :class:`CollisionScene` of ``mech`` (loaded from ``robot``: a name or file, see
    :func:`robot_files`) in ``spec``; ``srdf``: a file whose ``disable_collisions`` replace the
    robot's own SRDF."""
    import coal

    files = robot_files(robot, mech)
    geom = _robot_geometry(mech, files)
    model = mech.model
    srdf_path = Path(srdf) if srdf is not None else files.srdf
    if srdf is not None and not Path(srdf).is_file():
        raise InputError(f"--srdf: no such file {str(srdf)!r}")
    labels = [model.frames[o.parentFrame].name if o.parentFrame < len(model.frames) else o.name for o in geom.geometryObjects]
    n_robot = len(labels)
    if n_robot == 0:
        raise InputError(f"{mech.name!r} has no collision geometry in {files.path.name!r}: a scene cannot check it")
    # which robot pairs the SRDF (or, without one, the joints) disables
    robot_pairs = {(a, b) for a in range(n_robot) for b in range(a + 1, n_robot)}
    if srdf_path is not None:
        from .loading import _call_loader

        probe = geom.copy()
        probe.addAllCollisionPairs()
        before = {(p.first, p.second) for p in probe.collisionPairs}
        _call_loader(f"SRDF {srdf_path.name!r}", pin.removeCollisionPairs, model, probe, str(srdf_path), False)
        enabled = {(p.first, p.second) for p in probe.collisionPairs}
        disabled = (before - enabled) | {p for p in robot_pairs if p not in before}
    else:
        objs = geom.geometryObjects
        disabled = set()
        for a, b in robot_pairs:
            ja, jb = objs[a].parentJoint, objs[b].parentJoint
            if ja == jb or model.parents[ja] == jb or model.parents[jb] == ja:
                disabled.add((a, b))
    # obstacles: world-fixed geometry objects
    obstacle = [False] * n_robot
    for o in spec.obstacles:
        go = pin.GeometryObject(f"scene/{o.name}", 0, 0, o.placement(), _shape(o))
        geom.addGeometryObject(go)
        labels.append(o.name)
        obstacle.append(True)
    names_robot = set(labels[:n_robot])
    for e in spec.environment:
        for link, M, g in _environment(e):
            geom.addGeometryObject(pin.GeometryObject(f"env/{link}", 0, 0, M, g))
            labels.append(link)
            obstacle.append(True)
    clash = sorted(names_robot & {labels[i] for i in range(n_robot, len(labels))})
    if clash:
        raise InputError(f"scene {spec.name!r}: obstacle {clash[0]!r} has the name of a link of {mech.name!r}: rename it")
    known = set(labels)
    for pair in spec.allow:
        for s in pair:
            if s not in known:
                close = difflib.get_close_matches(s, sorted(known), n=3)
                hint = f"; did you mean {', '.join(close)}?" if close else ""
                raise InputError(f"scene {spec.name!r}: allow names {s!r}, neither a link of {mech.name!r} nor an obstacle{hint}")
    allowed = {frozenset((a, b)) for a, b in spec.allow}
    objs = geom.geometryObjects
    spheres = [local_sphere(o.geometry, o.placement) for o in objs]
    motion = np.array([motion_bounds(model, o.parentJoint, *spheres[i]) for i, o in enumerate(objs)]).reshape(len(objs), model.nv)
    reach = [reach_ball(model, o.parentJoint, *spheres[i]) for i, o in enumerate(objs)]
    counts = {"active": 0, "disabled": 0, "allowed": 0, "world_fixed": 0, "out_of_reach": 0}
    pairs: list[tuple[int, int]] = []
    for a in range(len(objs)):
        for b in range(a + 1, len(objs)):
            if (a, b) in disabled:
                counts["disabled"] += 1
            elif frozenset((labels[a], labels[b])) in allowed:
                counts["allowed"] += 1
            elif objs[a].parentJoint == 0 and objs[b].parentJoint == 0:
                counts["world_fixed"] += 1
            elif _apart(reach[a], reach[b], spec.margin):
                counts["out_of_reach"] += 1
            else:
                pairs.append((a, b))
    counts["active"] = len(pairs)
    for a, b in pairs:
        geom.addCollisionPair(pin.CollisionPair(a, b))
    meshes = [isinstance(o.geometry, coal.BVHModelBase) for o in objs]
    hull = pin.GeometryModel()
    for o, is_mesh in zip(objs, meshes):
        g = o.geometry
        if is_mesh:
            g.buildConvexHull(True, "Qt")
            g = g.convex
        hull.addGeometryObject(pin.GeometryObject(o.name, o.parentJoint, o.parentFrame, o.placement, g))
    for a, b in pairs:
        hull.addCollisionPair(pin.CollisionPair(a, b))
    return CollisionScene(
        model=model,
        spec=spec,
        geom=geom,
        hull=hull,
        labels=labels,
        obstacle=obstacle,
        spheres=spheres,
        motion=motion,
        pairs=pairs,
        counts=counts,
        margin=spec.margin,
        srdf=srdf_path.name if srdf_path is not None else None,
        meshes=meshes,
    )


def _apart(a: tuple[np.ndarray, float], b: tuple[np.ndarray, float], margin: float) -> bool:
    """Two balls (centre, radius) that stay more than ``margin`` apart (with room for rounding)."""
    if not (math.isfinite(a[1]) and math.isfinite(b[1])):
        return False
    gap = float(np.linalg.norm(a[0] - b[0])) - a[1] - b[1]
    return gap > margin + 1e-9 * (1.0 + a[1] + b[1])
