"""Replays of a result: every configuration on the robot, live in meshcat or as one HTML page.

``kinbox replay RESULT.json`` and :meth:`kinbox.result.Result.replay` /
:meth:`~kinbox.result.Result.to_html` land here. What is shown, in order:

* every isolated solution (IK solutions, assembly modes), then
* for each positive-dimensional component, its sample configurations in order along the
  component (a nearest-neighbour chain through the samples, measured on the joint and frame
  positions, so angle wrap-around does not matter).

The mechanism is rebuilt from the result's ``source`` (:func:`kinbox.mechanism.load`); the
goal, locks and set values need not be re-applied, the stored ``q`` vectors are complete.
Meshes are loaded **only here**: robots described by URDF (example-robot-data names, URDF
files) get their visual meshes through ``pin.buildGeomFromUrdf`` with ``package://`` URIs
resolved in example-robot-data; everything else (the mechanisms of ``robots/``, MJCF, models
given in code) gets simple shapes: a cylinder per link segment, a short cylinder along each
revolute axis, spheres at attachment points, plates (a closed polygon) for bodies with three or
more attachment points, and for every ``distance`` closure (a leg) and prismatic joint a
cylinder between its two end points, recomputed for each displayed configuration.

The HTML page is meshcat's static export (its scene plus its JavaScript inlined, the geometry
as ``data:`` URLs: it opens offline) with an animation that holds each configuration for
``delay`` seconds, plus a small label naming the configuration on screen. It is made without
starting a meshcat server: the commands are recorded in-process in the same scene tree the
meshcat server keeps and packed the same way ``Visualizer.static_html()`` does.
"""

from __future__ import annotations

import base64
import contextlib
import io
import json
import math
import os
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin

from ..answer import resultfile
from ..errors import InputError

#: colours (RGBA) of the simple shapes
BASE_COLOR = np.array([0.30, 0.30, 0.33, 1.0])
LINK_COLOR = np.array([0.93, 0.56, 0.15, 1.0])
JOINT_COLOR = np.array([0.25, 0.25, 0.28, 1.0])
LEG_COLOR = np.array([0.22, 0.74, 0.33, 1.0])
GOAL_COLOR = np.array([0.90, 0.15, 0.15, 1.0])

ROOT = "kinbox"  # meshcat node of the robot (under /meshcat)
FPS = 30


# ======================================================================================
# What to show
# ======================================================================================
@dataclass
class _Segment:
    """A cylinder between ``joint_a * point_a`` and ``joint_b * point_b``, placed per q."""

    gid: int
    joint_a: int
    point_a: np.ndarray
    joint_b: int
    point_b: np.ndarray


@dataclass
class Show:
    """A mechanism, its visual model and the configurations to show, with one label each."""

    title: str
    model: pin.Model
    visual: pin.GeometryModel
    qs: list[np.ndarray]
    labels: list[str]
    meshes: bool  # True: the robot's own meshes; False: simple shapes
    segments: list[_Segment] = field(default_factory=list)
    note: str = ""  # why simple shapes were used instead of meshes, if that was a fallback

    def __post_init__(self):
        self.data = self.model.createData()

    def place(self, q: np.ndarray) -> None:
        """Forward kinematics at ``q`` and the per-q geometry (legs, prismatic segments)."""
        pin.forwardKinematics(self.model, self.data, q)
        for s in self.segments:
            a = self.data.oMi[s.joint_a].act(s.point_a)
            b = self.data.oMi[s.joint_b].act(s.point_b)
            go = self.visual.geometryObjects[s.gid]
            go.placement = _cylinder_pose(a, b)
            go.meshScale = np.array([1.0, 1.0, max(float(np.linalg.norm(b - a)), 1e-6)])

    def points(self, q: np.ndarray) -> np.ndarray:
        """World positions of all joints and frames at ``q`` (for ordering and framing)."""
        pin.framesForwardKinematics(self.model, self.data, q)
        pts = [M.translation for M in self.data.oMi] + [M.translation for M in self.data.oMf]
        return np.array(pts)


def _cylinder_pose(a: np.ndarray, b: np.ndarray) -> pin.SE3:
    """Pose of a cylinder (axis z, centred) whose axis runs from ``a`` to ``b``."""
    d = b - a
    n = float(np.linalg.norm(d))
    R = np.eye(3)
    if n > 1e-12:
        R = pin.Quaternion.FromTwoVectors(np.array([0.0, 0.0, 1.0]), d / n).toRotationMatrix()
    return pin.SE3(R, 0.5 * (a + b))


def load_result(path) -> dict:
    """The JSON object of a result file (``kinbox ik/solve --json``), checked
    (:func:`kinbox.answer.resultfile.load_result`)."""
    return resultfile.load_result(path)


def _configurations(d: dict) -> list[tuple[str, list[np.ndarray]]]:
    """[(label prefix or "", configurations)]: the isolated solutions, then each component."""
    def vec(q, what: str) -> np.ndarray:
        try:
            v = np.asarray(q, dtype=float)
        except (TypeError, ValueError):
            v = None
        if v is None or v.ndim != 1:
            raise InputError(f"{what}: q is not a list of numbers")
        return v

    try:
        sols = d.get("solutions") or []
        groups = [("", [vec(s["q"], f"solution {k + 1}") for k, s in enumerate(sols)])]
        curves = [c for c in d.get("components") or [] if int(c.get("dimension", 0)) >= 1]
        for n, c in enumerate(curves):
            head = f"component {n + 1} of {len(curves)} (dimension {int(c['dimension'])})"
            groups.append((head, [vec(q, head) for q in c.get("samples") or []]))
    except (KeyError, TypeError, AttributeError, ValueError) as e:
        raise InputError(f"malformed result: solutions need 'q', components 'dimension' ({e!r})") from None
    return groups


def order_along_curve(points: list[np.ndarray]) -> list[int]:
    """Indices of ``points`` (one feature vector each) in order along the curve they sample.

    A nearest-neighbour chain started at one end (the point farthest from the first point,
    then from that one): good for the evenly spread samples of a curve; a closed curve is
    walked around once.
    """
    n = len(points)
    if n <= 2:
        return list(range(n))
    X = np.array([np.ravel(p) for p in points])
    start = int(np.argmax(np.linalg.norm(X - X[0], axis=1)))
    start = int(np.argmax(np.linalg.norm(X - X[start], axis=1)))
    D = np.linalg.norm(X[:, None, :] - X[None, :, :], axis=2) if n <= 3000 else None
    seen = np.zeros(n, dtype=bool)
    order = [start]
    seen[start] = True
    for _ in range(n - 1):
        cur = order[-1]
        dist = D[cur] if D is not None else np.linalg.norm(X - X[cur], axis=1)
        dist = np.where(seen, np.inf, dist)
        nxt = int(np.argmin(dist))
        order.append(nxt)
        seen[nxt] = True
    return order


def _resolve_file(name: str, base_dir: str | None) -> str:
    """A relative file name from a result's source: as given, else next to the result file."""
    if not name or os.path.isabs(name) or os.path.exists(name) or base_dir is None:
        return name
    cand = os.path.join(base_dir, name)
    return cand if os.path.exists(cand) else name


def _mechanism_from_source(d: dict):
    from ..model.loading import load

    src = d.get("source") if isinstance(d.get("source"), dict) else {}
    kind = src.get("kind")
    key = "robot" if kind == "ik" else "mechanism" if kind == "solve" else None
    if key is None:
        raise InputError(f"result source kind {kind!r} unknown: expected 'ik' or 'solve'")
    name = src.get(key)
    if not isinstance(name, str) or not name:
        raise InputError("the result does not say how to rebuild its mechanism (it was solved for a "
                         "model given in code); use kinbox.replay(result) / kinbox.to_html(result, path) from Python")
    name = _resolve_file(name, d.get("_dir"))
    return load(name), name


# -- meshes ----------------------------------------------------------------------------------
def _urdf_of(name: str):
    """(URDF path, package dirs, loader class or None) for an example-robot-data name or URDF file."""
    from ..model.loading import builtin_files, normalize_name

    builtins = builtin_files()
    for cand in (name, normalize_name(name)):
        if cand in builtins:  # as in mechanism.load: built-in names come first
            name = str(builtins[cand])
            break
    p = Path(os.path.expanduser(name))
    if p.is_file():
        if p.suffix.lower() == ".urdf" or (p.suffix.lower() == ".xml" and "<robot" in p.read_text(
                encoding="utf-8", errors="replace")[:4096]):
            dirs = [str(p.parent)] + [str(a) for a in list(p.parents)[1:4]]
            with contextlib.suppress(Exception):
                from example_robot_data.utils import getModelPath

                dirs.append(os.path.join(getModelPath("ur_description"), "..", ".."))
            return str(p), dirs, None
        return None
    try:
        import example_robot_data as erd
        from example_robot_data.utils import getModelPath
    except ImportError:  # pragma: no cover - a declared dependency
        return None
    table = {n.lower(): n for n in erd.ROBOTS}
    key = table.get(name.lower()) or table.get(name.lower().replace("-", "_"))
    if key is None:
        return None
    cls = erd.ROBOTS[key]
    if key == "ur3" and getattr(cls, "urdf_filename", "") != "ur3_robot.urdf":  # as mechanism._erd_model
        cls = getattr(erd.robots_loader, "UR3Loader", cls)
    if not getattr(cls, "urdf_filename", "") or getattr(cls, "sdf_filename", ""):
        return None, None, cls
    sub = os.path.join(cls.path, cls.urdf_subpath, cls.urdf_filename)
    root = cls.model_path or getModelPath(sub)
    return os.path.join(root, sub), [os.path.join(root, "..", "..")], cls


def mesh_model(model: pin.Model, name: str) -> tuple[pin.GeometryModel | None, str]:
    """The visual GeometryModel (meshes) of a URDF robot, or (None, reason)."""
    found = _urdf_of(name)
    if found is None:  # not a URDF robot: simple shapes, nothing to report
        return None, ""
    urdf, dirs, cls = found
    from ..model.loading import CapturedStderr

    cap = CapturedStderr()
    try:
        with cap:
            if urdf is None:  # custom example-robot-data loader: let it build the models
                import example_robot_data as erd

                geom = erd.load(name).visual_model
            else:
                geom = pin.buildGeomFromUrdf(model, urdf, pin.GeometryType.VISUAL, package_dirs=dirs)
    except Exception as e:  # noqa: BLE001 - missing mesh files, unknown links, ...
        return None, f"meshes of {name!r} could not be loaded ({e})"
    if geom.ngeoms == 0:
        return None, f"{name!r} has no visual geometry"
    import coal

    for go in geom.geometryObjects:
        if go.parentJoint >= model.njoints:
            return None, f"the meshes of {name!r} do not match its model"
        if go.meshPath.lower().endswith(".dae") and isinstance(go.geometry, coal.BVHModelBase):
            # meshcat's Collada loader drops parts of the example-robot-data meshes (UR arms):
            # draw the triangles the URDF loader read instead (already scaled)
            go.meshPath = ""
            go.meshScale = np.ones(3)
    return geom, ""


# -- simple shapes ---------------------------------------------------------------------------
def _revolute_axis(j) -> np.ndarray | None:
    s = j.shortname()
    for k, ax in enumerate("XYZ"):
        if s in (f"JointModelR{ax}", f"JointModelRUB{ax}"):
            return np.eye(3)[k]
    if "RevoluteUnaligned" in s or "RevoluteUnboundedUnaligned" in s:
        with contextlib.suppress(AttributeError):
            return np.asarray(j.extract().axis, dtype=float)
    return None


def _is_prismatic(j) -> bool:
    s = j.shortname()
    return s in ("JointModelPX", "JointModelPY", "JointModelPZ") or "PrismaticUnaligned" in s


def _one_dof(j) -> bool:
    return j.nv == 1


def _dedup(points: list[np.ndarray], tol: float) -> list[np.ndarray]:
    out: list[np.ndarray] = []
    for p in points:
        if all(np.linalg.norm(p - o) > tol for o in out):
            out.append(p)
    return out


def _outline(points: list[np.ndarray]) -> list[tuple[int, int]]:
    """Edges to draw between the attachment points of one body.

    Two points: a segment; collinear points: consecutive segments along the line; otherwise
    the closed convex outline in the best-fit plane (a plate).
    """
    n = len(points)
    if n < 2:
        return []
    P = np.array(points)
    c = P.mean(axis=0)
    _, s, Vt = np.linalg.svd(P - c)
    if n == 2 or s[1] <= 1e-6 * max(s[0], 1e-12):
        t = (P - c) @ Vt[0]
        o = np.argsort(t)
        return [(int(o[i]), int(o[i + 1])) for i in range(n - 1)]
    uv = (P - c) @ Vt[:2].T
    hull = _convex_hull(uv)
    return [(hull[i], hull[(i + 1) % len(hull)]) for i in range(len(hull))] if len(hull) > 2 else [
        (hull[0], hull[-1])]


def _convex_hull(xy: np.ndarray) -> list[int]:
    """Indices of the 2-D convex hull, counter-clockwise (Andrew's monotone chain)."""
    idx = sorted(range(len(xy)), key=lambda i: (xy[i, 0], xy[i, 1]))

    def cross(o, a, b):
        return (xy[a, 0] - xy[o, 0]) * (xy[b, 1] - xy[o, 1]) - (xy[a, 1] - xy[o, 1]) * (xy[b, 0] - xy[o, 0])

    lower: list[int] = []
    for i in idx:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], i) <= 0:
            lower.pop()
        lower.append(i)
    upper: list[int] = []
    for i in reversed(idx):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], i) <= 0:
            upper.pop()
        upper.append(i)
    return lower[:-1] + upper[:-1]


def simple_model(mech, qs: list[np.ndarray]) -> tuple[pin.GeometryModel, list[_Segment]]:
    """Cylinders and spheres for a mechanism without meshes (see the module docstring).

    Sizes follow the mechanism's extent over the configurations ``qs`` (neutral if empty).
    """
    import coal

    model = mech.model
    data = model.createData()
    pts = []
    for q in (qs or [pin.neutral(model)])[:200]:
        pin.framesForwardKinematics(model, data, q)
        pts += [M.translation for M in data.oMi] + [M.translation for M in data.oMf]
    pts = np.array(pts)
    extent = float(np.max(np.ptp(pts, axis=0))) if len(pts) else 1.0
    extent = max(extent, 1e-3)
    r = 0.014 * extent
    tol = 1e-6 * extent

    geom = pin.GeometryModel()
    segments: list[_Segment] = []
    count = [0]

    def add(parent: int, placement: pin.SE3, shape, color, what: str) -> int:
        count[0] += 1
        go = pin.GeometryObject(f"{what}_{count[0]}", parent, placement, shape)
        go.meshColor = np.array(color, dtype=float)
        return geom.addGeometryObject(go)

    # attachment points of every body, in the body's joint frame
    attach: dict[int, list[np.ndarray]] = {j: [] for j in range(model.njoints)}
    for j in range(1, model.njoints):
        if _one_dof(model.joints[j]):
            attach[j].append(np.zeros(3))
            attach[model.parents[j]].append(np.array(model.jointPlacements[j].translation))
    for f in model.frames:
        if f.type in (pin.FrameType.OP_FRAME, pin.FrameType.FIXED_JOINT) and f.name != "universe":
            if f.parentJoint == 0 and f.type == pin.FrameType.FIXED_JOINT:
                continue  # URDF base links: nothing to draw
            attach[int(f.parentJoint)].append(np.array(f.placement.translation))
    for c in mech.closures:
        if c.name == "goal":
            continue
        attach[c.joint_a].append(np.array(c.placement_a.translation))
        attach[c.joint_b].append(np.array(c.placement_b.translation))

    for j in range(model.njoints):
        P = _dedup(attach[j], tol)
        color = BASE_COLOR if j == 0 else LINK_COLOR
        for a, b in _outline(P):
            L = float(np.linalg.norm(P[b] - P[a]))
            if L > tol:
                add(j, _cylinder_pose(P[a], P[b]), coal.Cylinder(r, L), color, "link")
        for p in P:
            add(j, pin.SE3(np.eye(3), p), coal.Sphere(1.3 * r), color, "point")
        if j > 0:
            axis = _revolute_axis(model.joints[j])
            if axis is not None:  # a hinge: short cylinder along the axis
                add(j, _cylinder_pose(-2.5 * r * axis, 2.5 * r * axis), coal.Cylinder(1.9 * r, 5 * r),
                    JOINT_COLOR, "hinge")
            elif _is_prismatic(model.joints[j]):
                gid = add(0, pin.SE3.Identity(), coal.Cylinder(0.8 * r, 1.0), LEG_COLOR, "slider")
                segments.append(_Segment(gid, model.parents[j], np.array(model.jointPlacements[j].translation),
                                         j, np.zeros(3)))
    for c in mech.closures:
        if c.kind == "distance":
            gid = add(0, pin.SE3.Identity(), coal.Cylinder(0.7 * r, 1.0), LEG_COLOR, c.name or "leg")
            segments.append(_Segment(gid, c.joint_a, np.array(c.placement_a.translation),
                                     c.joint_b, np.array(c.placement_b.translation)))
        elif c.name == "goal":  # an IK goal: a red ball at the target
            add(c.joint_b, pin.SE3(np.eye(3), np.array(c.placement_b.translation)), coal.Sphere(2 * r),
                GOAL_COLOR, "goal")
    return geom, segments


def _goal_marker(geom: pin.GeometryModel, mech, src: dict, size: float) -> None:
    """A red ball at an IK result's goal position (meshes case)."""
    import coal

    pose = src.get("pose")
    if not (isinstance(pose, list) and len(pose) == 7):
        return
    try:
        jb, pb = mech.frame_anchor(src.get("base") or "universe")
        M = pb * pin.XYZQUATToSE3(np.asarray(pose, dtype=float))
    except Exception:  # noqa: BLE001 - a display nicety only
        return
    go = pin.GeometryObject("kinbox_goal", jb, pin.SE3(np.eye(3), M.translation), coal.Sphere(size))
    go.meshColor = GOAL_COLOR.copy()
    geom.addGeometryObject(go)


def prepare(result) -> Show:
    """A :class:`Show` from a :class:`~kinbox.result.Result` or a result dict (JSON)."""
    mech = None
    if isinstance(result, dict):
        d = result
    else:  # a Result: what to_dict() would give, without the boxes
        d = {"problem": result.problem, "source": result.source,
             "solutions": [{"q": s.q} for s in result.solutions],
             "components": [{"dimension": c.dimension, "samples": result.samples.get(i, [])}
                            for i, c in enumerate(result.components)]}
        mech = result.formulation.mechanism if result.formulation is not None else None
    src = d.get("source") if isinstance(d.get("source"), dict) else {}
    name = None
    if mech is None:
        mech, name = _mechanism_from_source(d)
    else:
        key = "robot" if src.get("kind") == "ik" else "mechanism"
        name = src.get(key) if isinstance(src.get(key), str) else None
    model = mech.model
    title = str(d.get("problem") or mech.name)
    probe = Show(title, model, pin.GeometryModel(), [], [], False)
    qs, labels = [], []
    for head, group in _configurations(d):
        for k, q in enumerate(group):
            if q.shape != (model.nq,) or not np.all(np.isfinite(q)):
                raise InputError(f"{head or 'solution'} {k + 1}: q must be {model.nq} finite numbers "
                                 f"for {mech.name!r}, got {q.size}")
        if not head:
            qs += group
            labels += [f"solution {k + 1} of {len(group)}" for k in range(len(group))]
            continue
        order = order_along_curve([probe.points(q) for q in group])  # in order along the curve
        qs += [group[i] for i in order]
        labels += [f"{head}, point {k + 1} of {len(group)}" for k in range(len(group))]

    geom, note = (None, "")
    if name is not None:
        file_name = _resolve_file(name, d.get("_dir"))
        geom, note = mesh_model(model, file_name)
    if geom is not None:
        show = Show(title, model, geom, qs, labels, True)
        if src.get("kind") == "ik":
            _goal_marker(geom, mech, src, 0.02)
        return show
    if note:
        print(f"kinbox: {note}; drawing simple shapes instead", file=sys.stderr)
    if src.get("kind") == "ik" and not any(c.name == "goal" for c in mech.closures):
        mech = _with_goal(mech, src)
    geom, segs = simple_model(mech, qs)
    return Show(title, model, geom, qs, labels, False, segs, note)


def _with_goal(mech, src: dict):
    import copy

    pose = src.get("pose")
    if not (isinstance(pose, list) and len(pose) == 7 and src.get("frame")):
        return mech
    try:
        m = copy.copy(mech)
        m.closures = list(mech.closures)
        return m.add_goal(src["frame"], pin.XYZQUATToSE3(np.asarray(pose, dtype=float)), src.get("base"))
    except Exception:  # noqa: BLE001 - a display nicety only
        return mech


# ======================================================================================
# Meshcat
# ======================================================================================
def _meshcat():
    """``import meshcat`` without its pyzmq deprecation warning (``zmq.eventloop.ioloop``)."""
    import warnings

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", category=DeprecationWarning, module=r"meshcat\..*")
        warnings.filterwarnings("ignore", message=r".*zmq\.eventloop\.ioloop is deprecated.*")
        import meshcat
        import meshcat.animation  # noqa: F401
        import meshcat.servers.tree  # noqa: F401
    return meshcat


class _RecordingWindow:
    """Stands in for meshcat's ``ViewerWindow``: keeps the scene tree in-process, exactly as
    the meshcat server does (``meshcat.servers.zmqserver``), and exports it the same way."""

    def __init__(self):
        self.tree = _meshcat().servers.tree.SceneTree()
        self.web_url = None
        self.server_proc = None

    def send(self, command) -> None:
        import umsgpack
        from meshcat.servers.tree import SceneTree, find_node

        data = command.lower()
        cmd, packed = data["type"], umsgpack.packb(data)
        path = [p for p in data.get("path", "").split("/") if p]
        if cmd == "set_transform":
            find_node(self.tree, path).transform = packed
        elif cmd == "set_object":
            find_node(self.tree, path).object = packed
            find_node(self.tree, path).properties = []
        elif cmd == "set_property":
            find_node(self.tree, path).properties.append(packed)
        elif cmd == "set_animation":
            find_node(self.tree, path).animation = packed
        elif cmd == "delete":
            if path:
                parent = find_node(self.tree, path[:-1])
                if path[-1] in parent:
                    del parent[path[-1]]
            else:
                self.tree = SceneTree()

    def get_scene(self) -> str:
        """The static page, as ``meshcat.servers.zmqserver`` builds it for ``get_scene``."""
        meshcat = _meshcat()
        walk = meshcat.servers.tree.walk
        viewer_root = Path(meshcat.__file__).parent / "viewer" / "dist"  # zmqserver.VIEWER_ROOT

        def create_command(data: bytes) -> str:
            return ('\nfetch("data:application/octet-binary;base64,{}")\n'
                    "    .then(res => res.arrayBuffer())\n"
                    "    .then(buffer => viewer.handle_command_bytearray(new Uint8Array(buffer)));\n"
                    ).format(base64.b64encode(data).decode("utf-8"))

        commands = []
        for node in walk(self.tree):
            if node.object is not None:
                commands.append(create_command(node.object))
            for p in node.properties:
                commands.append(create_command(p))
            if node.transform is not None:
                commands.append(create_command(node.transform))
            if node.animation is not None:
                commands.append(create_command(node.animation))
        js = (viewer_root / "main.min.js").read_text(encoding="utf-8")
        return _PAGE.format(mainminjs=js, commands="".join(commands))

    def close(self) -> None:
        pass


_PAGE = """
<!DOCTYPE html>
<html>
    <head> <meta charset=utf-8> <title>MeshCat</title> </head>
    <body>
        <div id="meshcat-pane">
        </div>
        <script>
            {mainminjs}
        </script>
        <script>
            var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
            {commands}
        </script>
         <style>
            body {{margin: 0; }}
            #meshcat-pane {{
                width: 100vw;
                height: 100vh;
                overflow: hidden;
            }}
        </style>
        <script id="embedded-json"></script>
    </body>
</html>
"""


class _FrameViewer:
    """Looks like a meshcat ``Visualizer`` to ``MeshcatVisualizer.display``, but writes the
    transforms into an animation frame (position, quaternion and scale tracks)."""

    def __init__(self, frame):
        self.frame = frame

    def __getitem__(self, path):
        return _FrameViewer(self.frame[path])

    def set_transform(self, T=None):
        T = np.eye(4) if T is None else np.asarray(T, dtype=float)
        s = np.linalg.norm(T[:3, :3], axis=0)
        M = np.eye(4)
        M[:3, :3] = T[:3, :3] / np.where(s > 0, s, 1.0)
        M[:3, 3] = T[:3, 3]
        self.frame.set_transform(M)
        self.frame.set_property("scale", "vector3", [float(v) for v in s])


def _visualizer(show: Show, viewer):
    _meshcat()
    from pinocchio.visualize import MeshcatVisualizer

    viz = MeshcatVisualizer(show.model, None, show.visual)
    viz.initViewer(viewer=viewer)
    viz.loadViewerModel(rootNodeName=ROOT)
    return viz


def _frame_camera(show: Show, viewer) -> None:
    """Move the scene so the configurations are centred at the origin (where meshcat's camera
    looks) and put the camera at a distance that fits them."""
    pts = [show.points(q) for q in show.qs[:400]] or [show.points(pin.neutral(show.model))]
    P = np.vstack(pts)
    lo, hi = P.min(axis=0), P.max(axis=0)
    centre = 0.5 * (lo + hi)
    radius = max(0.5 * float(np.linalg.norm(hi - lo)), 0.05)
    if show.meshes:
        radius += 0.1  # the meshes reach beyond the joint origins
    T = np.eye(4)
    T[:3, 3] = -centre
    viewer[ROOT].set_transform(T)
    viewer["/Axes"].set_transform(T)
    viewer["/Grid"].set_property("visible", False)  # meshcat's grid renders oddly from oblique views
    ext = hi - lo
    flat = ext[2] < 0.05 * max(ext[0], ext[1], 1e-9)
    direction = np.array([0.35, -0.75, 1.0]) if flat else np.array([1.0, 0.75, 0.55])
    direction /= np.linalg.norm(direction)
    dist = 0.9 * radius / math.sin(math.radians(37.5))
    a, b, c = dist * direction
    # the camera node is rotated by Rx(pi/2): world (a, b, c) is (a, c, -b) there
    viewer["/Cameras/default/rotated/<object>"].set_property("position", [float(a), float(c), float(-b)])


def _is_goal(go) -> bool:
    return go.name.startswith(("goal_", "kinbox_goal"))


def _hide_robot(viz, viewer) -> None:
    for go in viz.visual_model.geometryObjects:
        if not _is_goal(go):
            viewer[viz.getViewerNodeName(go, pin.GeometryType.VISUAL)].set_property("visible", False)


def _steps(delay: float) -> int:
    if not (isinstance(delay, (int, float)) and math.isfinite(delay) and delay > 0):
        raise InputError(f"delay must be a positive number of seconds, got {delay!r}")
    return max(2, int(round(delay * FPS)))


def html(result, delay: float = 1.0) -> str:
    """The self-contained HTML page of a result (see the module docstring)."""
    meshcat = _meshcat()
    Animation = meshcat.animation.Animation

    show = prepare(result) if not isinstance(result, Show) else result
    F = _steps(delay)
    window = _RecordingWindow()
    viewer = meshcat.Visualizer(window=window)
    viz = _visualizer(show, viewer)
    _frame_camera(show, viewer)
    if not show.qs:  # nothing to show but an IK goal, if any
        q0 = pin.neutral(show.model)
        show.place(q0)
        viz.display(q0)
        _hide_robot(viz, viewer)
    else:
        show.place(show.qs[0])
        viz.display(show.qs[0])
        if len(show.qs) > 1:
            anim = Animation(default_framerate=FPS)
            for k, q in enumerate(show.qs):
                show.place(q)
                for frame in (k * F, k * F + F - 1):
                    with anim.at_frame(viewer, frame) as f:
                        viz.viewer = _FrameViewer(f)
                        try:
                            viz.display(q)
                        finally:
                            viz.viewer = viewer
            viewer.set_animation(anim, play=True, repetitions=1_000_000)
    page = window.get_scene()
    labels = show.labels or ["no configuration found"]
    overlay = _OVERLAY.format(title=_js(show.title), labels=_js(labels), step=F / FPS)
    return page.replace("</body>", overlay + "</body>", 1)


def _js(v) -> str:
    return json.dumps(v).replace("</", "<\\/")


_OVERLAY = """<div id="kinbox-label" style="position:absolute;left:8px;top:8px;font:14px sans-serif;
color:#fff;background:rgba(0,0,0,0.45);padding:4px 8px;border-radius:4px;pointer-events:none"></div>
<script>
(function () {{
  var title = {title}, labels = {labels}, step = {step};
  var el = document.getElementById("kinbox-label");
  function update() {{
    var t = 0;
    try {{ viewer.animator.actions.forEach(function (a) {{ t = Math.max(t, a.time); }}); }} catch (e) {{}}
    var k = Math.min(labels.length - 1, Math.floor(t / step + 1e-6));
    el.textContent = "kinbox: " + title + " \\u2014 " + labels[k];
  }}
  function loop() {{ update(); requestAnimationFrame(loop); }}
  loop();
}})();
</script>
"""


def to_html(result, path, delay: float = 1.0) -> Path:
    """Write :func:`html` to ``path``; returns the path."""
    page = html(result, delay)
    p = Path(path)
    try:
        p.write_text(page, encoding="utf-8")
    except OSError as e:
        raise InputError(f"cannot write {str(path)!r}: {e.strerror or e}") from None
    return p


def start_viewer():
    """A meshcat viewer with its own server on localhost (its URL printed by the caller)."""
    meshcat = _meshcat()
    with contextlib.redirect_stdout(io.StringIO()):  # meshcat prints its URL; the caller does
        return meshcat.Visualizer()


def stop_viewer(viewer) -> None:
    """Shut down the server of a viewer made by :func:`start_viewer`."""
    proc = getattr(getattr(viewer, "window", None), "server_proc", None)
    if proc is not None and proc.poll() is None:
        proc.kill()
        proc.wait()


def replay(result, viewer=None, delay: float = 1.0, cycles: int = 1, log=None):
    """Show every configuration of ``result`` in meshcat, ``delay`` seconds each.

    ``viewer``: a ``meshcat.Visualizer`` (default: a new one with its own server on localhost,
    whose URL is printed). ``cycles``: passes through the configurations (0: until Ctrl-C).
    ``log``: where to print each configuration's label (default: stderr; ``False``: nowhere).
    Returns the ``pinocchio.visualize.MeshcatVisualizer`` (its ``viewer`` is the meshcat one).
    """
    _steps(delay)
    show = prepare(result) if not isinstance(result, Show) else result
    out = sys.stderr if log is None else log
    if viewer is None:
        viewer = start_viewer()
        if out:
            print(f"kinbox: meshcat viewer at {viewer.url()}", file=out, flush=True)
    viz = _visualizer(show, viewer)
    _frame_camera(show, viewer)
    if not show.qs:
        if out:
            print(f"kinbox: {show.title}: no configuration to show", file=out, flush=True)
        q0 = pin.neutral(show.model)
        show.place(q0)
        viz.display(q0)
        _hide_robot(viz, viewer)
        return viz
    n = 0
    while cycles <= 0 or n < cycles:
        for q, label in zip(show.qs, show.labels):
            show.place(q)
            viz.display(q)
            if out:
                print(f"kinbox: {label}", file=out, flush=True)
            time.sleep(delay)
        n += 1
    return viz


# ======================================================================================
# Screenshots (headless Chromium): for tests and the README pictures
# ======================================================================================
def find_chromium() -> str | None:
    """A Chromium / Chrome executable on PATH, or None."""
    import shutil

    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        exe = shutil.which(name)
        if exe:
            return exe
    return None


def screenshot(html_path, png_path, size: tuple[int, int] = (800, 600), budget_ms: int = 1000,
               timeout: float = 30.0, browser: str | None = None) -> Path:
    """Render a page with headless Chromium (software WebGL, no network) into a PNG.

    ``budget_ms`` is Chromium's virtual time budget: the page runs that long (animation
    included) before the picture is taken. Chromium occasionally hangs at start-up in
    containers: a run that exceeds ``timeout`` seconds is killed and tried once more.
    """
    import signal
    import subprocess
    import tempfile

    exe = browser or find_chromium()
    if exe is None:
        raise InputError("no Chromium found on PATH (Debian: apt-get install chromium)")
    png = Path(png_path).resolve()
    if png.exists():
        png.unlink()
    url = Path(html_path).resolve().as_uri()
    last = ""
    for _ in range(2):
        with tempfile.TemporaryDirectory(prefix="kinbox-chromium-") as profile, \
                tempfile.TemporaryFile() as err:
            args = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader",
                    "--disable-quic", "--no-first-run", "--disable-background-networking",
                    "--disable-component-update", "--disable-sync", "--hide-scrollbars",
                    f"--user-data-dir={profile}", f"--window-size={int(size[0])},{int(size[1])}",
                    f"--virtual-time-budget={int(budget_ms)}", f"--screenshot={png}", url]
            proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=err, start_new_session=True)
            timed_out = False
            try:
                proc.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                timed_out = True
                last = f"timed out after {timeout} s"
            finally:
                with contextlib.suppress(ProcessLookupError, PermissionError):
                    os.killpg(proc.pid, signal.SIGKILL)  # the browser we started, and its children
                proc.wait()
            if timed_out:
                continue
            err.seek(0)
            last = err.read().decode("utf-8", "replace").strip().splitlines()[-1:] or [""]
            last = last[0]
            if png.is_file() and png.stat().st_size > 0:
                return png
    raise RuntimeError(f"Chromium did not write {png.name}: {last}")
