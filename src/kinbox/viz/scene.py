"""The scene of a replay: the mechanism, its visual model and the configurations to show.

The mechanism is rebuilt from the result's ``source`` (:func:`kinbox.model.loading.load`); the
goal, locks and set values need not be re-applied, the stored ``q`` vectors are complete.
Meshes are loaded **only here**: robots described by URDF (example-robot-data names, URDF
files) get their visual meshes from ``pin.buildGeomFromUrdf``, ``package://`` URIs resolved
in example-robot-data; everything else gets simple shapes (:mod:`kinbox.viz.shapes`).
"""

from __future__ import annotations

import copy
import os
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from ..errors import InputError
from .motion import Group, groups, result_dict
from .shapes import GOAL_COLOR, Segment, cylinder_pose, simple_model


@dataclass
class Show:
    """A mechanism, its visual model and the configurations to show, in groups."""

    title: str
    model: pin.Model
    visual: pin.GeometryModel
    groups: list[Group]
    meshes: bool  # True: the robot's own meshes; False: simple shapes
    segments: list[Segment] = field(default_factory=list)
    note: str = ""  # why simple shapes were used instead of meshes, if that was a fallback
    #: red copies of links in contact (kinbox.viz.obstacles.contact_ghosts): (geometry id,
    #: link, scale), and configuration key -> names in contact there
    ghosts: list[tuple[int, str, np.ndarray]] = field(default_factory=list)
    contact: dict[bytes, set[str]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.data = self.model.createData()

    @property
    def qs(self) -> list[np.ndarray]:
        """Every configuration shown, in order."""
        return [q for g in self.groups for q in g.qs]

    @property
    def labels(self) -> list[str]:
        """One label per configuration of :attr:`qs`."""
        return [label for g in self.groups for label in g.labels()]

    def place(self, q: np.ndarray) -> None:
        """Forward kinematics at ``q`` and the per-q geometry (legs, prismatic segments)."""
        pin.forwardKinematics(self.model, self.data, q)
        for s in self.segments:
            a = self.data.oMi[s.joint_a].act(s.point_a)
            b = self.data.oMi[s.joint_b].act(s.point_b)
            go = self.visual.geometryObjects[s.gid]
            go.placement = cylinder_pose(a, b)
            go.meshScale = np.array([1.0, 1.0, max(float(np.linalg.norm(b - a)), 1e-6)])
        if self.ghosts:
            from .obstacles import HIDDEN, key

            hit = self.contact.get(key(q), set())
            for gid, link, scale in self.ghosts:
                self.visual.geometryObjects[gid].meshScale = scale if link in hit else scale * HIDDEN


def points(model: pin.Model, data: pin.Data, q: np.ndarray) -> np.ndarray:
    """World positions of all joints and frames at ``q`` (to order and frame configurations:
    positions, unlike angles, do not wrap around)."""
    pin.framesForwardKinematics(model, data, q)
    return np.array([M.translation for M in data.oMi] + [M.translation for M in data.oMf])


def _resolve_file(name: str, base_dir: str | None) -> str:
    """A relative file name from a result's source: as given, else next to the result file."""
    if not name or os.path.isabs(name) or os.path.exists(name) or base_dir is None:
        return name
    cand = os.path.join(base_dir, name)
    return cand if os.path.exists(cand) else name


def _source(d: dict) -> dict:
    src = d.get("source")
    return src if isinstance(src, dict) else {}


def _source_name(d: dict) -> str | None:
    src = _source(d)
    kind = src.get("kind")
    key = "robot" if kind == "ik" else "mechanism" if kind == "solve" else None
    if key is None:
        raise InputError(f"result source kind {kind!r} unknown: expected 'ik' or 'solve'")
    name = src.get(key)
    return _resolve_file(name, d.get("_dir")) if isinstance(name, str) and name else None


# -- meshes ----------------------------------------------------------------------------------
def _urdf_of(name: str) -> tuple[str | None, list[str]] | None:
    """(URDF path, package dirs) of a robot described by URDF, (None, []) for an
    example-robot-data robot with a custom loader, None for anything else."""
    from ..model.loading import builtin_files, erd_files, erd_name, erd_package_dir, normalize_name

    builtins = builtin_files()
    for cand in (name, normalize_name(name)):
        if cand in builtins:  # as in load(): built-in names come first
            name = str(builtins[cand])
            break
    p = Path(os.path.expanduser(name))
    if p.is_file():
        head = p.read_text(encoding="utf-8", errors="replace")[:4096] if p.suffix.lower() == ".xml" else ""
        if p.suffix.lower() != ".urdf" and "<robot" not in head:
            return None
        dirs = [str(p.parent)] + [str(a) for a in list(p.parents)[1:4]]
        shared = erd_package_dir()  # a user's URDF may use the meshes of example-robot-data
        return str(p), dirs + ([str(shared)] if shared is not None else [])
    robot = erd_name(name)
    if robot is None:
        return None
    files = erd_files(robot)
    if files is None:
        return None, []
    return str(files.urdf), [str(files.package_dir)]


def mesh_model(model: pin.Model, name: str) -> tuple[pin.GeometryModel | None, str]:
    """The visual GeometryModel (meshes) of a URDF robot, or (None, reason)."""
    found = _urdf_of(name)
    if found is None:  # not a URDF robot: simple shapes, nothing to report
        return None, ""
    urdf, dirs = found
    from ..model.loading import CapturedStderr, erd_name

    cap = CapturedStderr()
    try:
        with cap:
            if urdf is None:  # custom example-robot-data loader: let it build the models
                import example_robot_data as erd

                geom = erd.load(erd_name(name)).visual_model
            else:
                geom = pin.buildGeomFromUrdf(model, urdf, pin.GeometryType.VISUAL, package_dirs=dirs)
    except Exception as e:  # noqa: BLE001 - missing mesh files, unknown links, ...
        return None, f"meshes of {name!r} could not be loaded ({e})"
    if geom.ngeoms == 0:
        return None, f"{name!r} has no visual geometry"
    # meshes only from the URDF's folder, its parent (a ROS package) or example-robot-data
    roots = [os.path.realpath(d) for d in dirs[:2] + dirs[4:]] if urdf is not None else []
    for go in geom.geometryObjects:  # tests/cli/test_hostile.py::test_mesh_outside_the_robot_folder
        path = go.meshPath
        if roots and path and not any(os.path.commonpath([os.path.realpath(path), r]) == r for r in roots):
            return None, f"mesh {path!r} of {name!r} lies outside the robot's folders, not shown"
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


def _goal_marker(geom: pin.GeometryModel, mech: Any, src: dict, size: float) -> None:
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


def _with_goal(mech: Any, src: dict) -> Any:
    """``mech`` with the IK goal of ``src`` as a closure (drawn as a red ball by the shapes)."""
    pose = src.get("pose")
    if not (isinstance(pose, list) and len(pose) == 7 and src.get("frame")):
        return mech
    try:
        m = copy.copy(mech)
        m.closures = list(mech.closures)
        return m.add_goal(src["frame"], pin.XYZQUATToSE3(np.asarray(pose, dtype=float)), src.get("base"))
    except Exception:  # noqa: BLE001 - a display nicety only
        return mech


def prepare(result: Any) -> Show:
    """A :class:`Show` from a :class:`~kinbox.answer.result.Result` or a result dict (JSON)."""
    from ..model.loading import load

    d = result_dict(result)
    src = _source(d)
    formulation = None if isinstance(result, dict) else getattr(result, "formulated", None)
    if formulation is None:
        name = _source_name(d)
        if name is None:
            raise InputError(
                "the result does not say how to rebuild its mechanism (it was solved for a model "
                "given in code); use kinbox.replay(result) / kinbox.to_html(result, path) from Python"
            )
        mech = load(name)
    else:  # a Result in memory: its own mechanism; the source only says where meshes are
        mech = formulation.mechanism
        name = _source_name(d) if src.get("kind") in ("ik", "solve") else None
    model = mech.model
    title = str(d.get("problem") or mech.name)
    if d.get("complete") is False:  # the page says what it is: not every configuration (test_an_incomplete_answer_s_page_says_so)
        title += f" \u2014 INCOMPLETE ({str(d.get('message') or 'a budget was hit')[:120]}): not every configuration"
    data = model.createData()
    shown = groups(d, model.nq, mech.name, lambda q: points(model, data, q))
    geom, note = mesh_model(model, name) if name is not None else (None, "")
    if geom is not None:
        if src.get("kind") == "ik":
            _goal_marker(geom, mech, src, 0.02)
        return _with_scene(Show(title, model, geom, shown, True), d)
    if note:
        print(f"kinbox: {note}; drawing simple shapes instead", file=sys.stderr)
    if src.get("kind") == "ik" and not any(c.name == "goal" for c in mech.closures):
        mech = _with_goal(mech, src)
    geom, segs = simple_model(mech, [q for g in shown for q in g.qs])
    return _with_scene(Show(title, model, geom, shown, False, segs, note), d)


def _with_scene(show: Show, d: dict) -> Show:
    """The result's collision scene drawn in ``show``: obstacles, links in contact in red."""
    scene = d.get("scene")
    if not isinstance(scene, dict):
        return show
    from .obstacles import add_obstacles, contact_ghosts

    add_obstacles(show.visual, scene)
    show.ghosts, show.contact = contact_ghosts(show.model, show.visual, d)
    return show
