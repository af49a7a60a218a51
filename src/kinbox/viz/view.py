"""A :class:`~kinbox.viz.scene.Show` in a meshcat viewer, through Pinocchio's MeshcatVisualizer:
the robot loaded under ``/meshcat/kinbox``, the camera framed on the configurations, and the
configurations either displayed one at a time (live) or recorded as one meshcat animation (the
HTML page)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import pinocchio as pin

from .motion import FPS
from .scene import Show, points
from .server import meshcat_module

ROOT = "kinbox"  # meshcat node of the robot (under /meshcat)


def visualizer(show: Show, viewer: Any) -> Any:
    """Pinocchio's MeshcatVisualizer of ``show`` in ``viewer`` (a ``meshcat.Visualizer``), loaded."""
    meshcat_module()
    from pinocchio.visualize import MeshcatVisualizer

    viz = MeshcatVisualizer(show.model, None, show.visual)
    viz.initViewer(viewer=viewer)
    viz.loadViewerModel(rootNodeName=ROOT)
    return viz


def frame_camera(show: Show, viewer: Any) -> None:
    """Move the scene so the configurations are centred at the origin (where meshcat's camera
    looks) and put the camera at a distance that fits them."""
    data = show.model.createData()
    qs = show.qs[:400] or [pin.neutral(show.model)]
    P = np.vstack([points(show.model, data, q) for q in qs])
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


def _is_goal(go: Any) -> bool:
    return bool(go.name.startswith(("goal_", "kinbox_goal")))


def show_nothing(show: Show, viz: Any, viewer: Any) -> None:
    """No configuration to show: the robot hidden, an IK goal (if any) still drawn."""
    q0 = pin.neutral(show.model)
    show.place(q0)
    viz.display(q0)
    for go in viz.visual_model.geometryObjects:
        if not _is_goal(go):
            viewer[viz.getViewerNodeName(go, pin.GeometryType.VISUAL)].set_property("visible", False)


def display(show: Show, viz: Any, q: np.ndarray) -> None:
    """The robot at ``q`` (legs and sliders placed too)."""
    show.place(q)
    viz.display(q)


class _FrameViewer:
    """Looks like a meshcat ``Visualizer`` to ``MeshcatVisualizer.display``, but writes the
    transforms into an animation frame (position, quaternion and scale tracks)."""

    def __init__(self, frame: Any):
        self.frame = frame

    def __getitem__(self, path: str) -> _FrameViewer:
        return _FrameViewer(self.frame[path])

    def set_transform(self, T: np.ndarray | None = None) -> None:
        T = np.eye(4) if T is None else np.asarray(T, dtype=float)
        s = np.linalg.norm(T[:3, :3], axis=0)
        M = np.eye(4)
        M[:3, :3] = T[:3, :3] / np.where(s > 0, s, 1.0)
        M[:3, 3] = T[:3, 3]
        self.frame.set_transform(M)
        self.frame.set_property("scale", "vector3", [float(v) for v in s])


def keyframes(timing: Sequence[tuple[float, bool]]) -> list[tuple[int, int]]:
    """(first, last) animation frame of each configuration: a held configuration keeps its
    pose from its first to its last frame; the configurations of a motion have one key frame
    each, and the animation interpolates between them."""
    out: list[tuple[int, int]] = []
    t, last = 0.0, -1
    for seconds, held in timing:
        start = max(int(round(t * FPS)), last + 1)  # at least a frame per configuration
        t += seconds
        last = max(start + 1, int(round(t * FPS))) - 1 if held else start
        out.append((start, last))
    return out


def animate(show: Show, viz: Any, viewer: Any, timing: Sequence[tuple[float, bool]]) -> list[int]:
    """Record every configuration of ``show`` into one meshcat animation (looping) and send it;
    returns the first frame of each configuration."""
    Animation = meshcat_module().animation.Animation
    anim = Animation(default_framerate=FPS)
    keys = keyframes(timing)
    for q, (first, last) in zip(show.qs, keys):
        show.place(q)
        for frame in sorted({first, last}):
            with anim.at_frame(viewer, frame) as f:
                viz.viewer = _FrameViewer(f)
                try:
                    viz.display(q)
                finally:
                    viz.viewer = viewer
    viewer.set_animation(anim, play=True, repetitions=1_000_000)
    return [first for first, _ in keys]
