"""Points, lines and planes of constraint-system answers in meshcat (live and static HTML).

:func:`draw` puts the entities of one assembly (the ``"entities"`` of a solution in the JSON of
``kinbox solve SYSTEM --json``) into any meshcat ``Visualizer`` under a path: points as spheres,
lines as long thin cylinders, planes as thin square slabs, one colour per entity.
:func:`place` moves them to another assembly (in a live viewer or in an animation frame), so a
replay draws once and then only sets transforms. :func:`to_html` and :func:`serve` step through
every assembly of a result (isolated ones, then samples of each component), like
``kinbox replay`` does for mechanisms; the page is meshcat's own static export
with the label bar of :mod:`kinbox.viz.page`, the live viewer a server of :mod:`kinbox.viz.server`
(loopback unless another host is asked for).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

from ..errors import InputError

FPS = 30
ROOT = "kinbox/entities"
_COLOURS = [
    0xE6194B,
    0x3CB44B,
    0x4363D8,
    0xF58231,
    0x911EB4,
    0x46F0F0,
    0xF032E6,
    0xBCF60C,
    0x008080,
    0x9A6324,
    0x800000,
    0x808000,
    0x000075,
    0x808080,
]


def is_constraints_result(path) -> bool:
    """Is ``path`` the JSON of a constraint-system answer (``"kind": "constraints"``)?"""
    from ..errors import MAX_RESULT_BYTES, KinboxError, read_json

    try:  # within the input limits; a refused file is left to the reader, which names why
        d = read_json(path, InputError, "result file", max_bytes=MAX_RESULT_BYTES)
    except KinboxError:
        return False
    return isinstance(d, dict) and d.get("kind") == "constraints"


def load_result(path) -> dict:
    """A constraint-system answer read back and checked against the result file's JSON Schema
    (:mod:`kinbox.answer.resultfile`)."""
    from ..answer.resultfile import load_result as load

    d = load(path)
    if d.get("kind") != "constraints":
        raise InputError(f"{str(path)!r} is not the answer of a constraint system (kinbox solve SYSTEM --json)")
    return d


def assemblies(result: dict) -> list[tuple[str, dict]]:
    """(label, entities) of every assembly to show: isolated solutions, then component samples."""
    out = []
    for k, s in enumerate(result.get("solutions", [])):
        cert = "certified" if s.get("certified") else "not certified"
        out.append((f"assembly {k + 1} of {len(result['solutions'])} ({cert})", s["entities"]))
    for ci, c in enumerate(result.get("components", [])):
        sm = c.get("samples", [])
        for k, e in enumerate(sm):
            out.append((f"component {ci + 1} (dimension {c.get('dimension')}): sample {k + 1} of {len(sm)}", e))
    return out


def extent(all_entities: list[dict]) -> tuple[np.ndarray, float]:
    """Centre and size of the scene (points, and the points given for lines and planes)."""
    pts = []
    for ents in all_entities:
        for v in ents.values():
            pts.append(np.asarray(v if isinstance(v, list) else v["point"], dtype=float))
    if not pts:
        return np.zeros(3), 1.0
    P = np.array(pts)
    lo, hi = P.min(axis=0), P.max(axis=0)
    return 0.5 * (lo + hi), max(float(np.max(hi - lo)), 1.0)


def _frame(z: np.ndarray, axis: int) -> np.ndarray:
    """A rotation whose column ``axis`` is the unit vector ``z``."""
    z = z / np.linalg.norm(z)
    a = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(z, a)
    u /= np.linalg.norm(u)
    w = np.cross(z, u)
    cols = [u, w]
    cols.insert(axis, z)
    R = np.array(cols).T
    if np.linalg.det(R) < 0:
        R[:, (axis + 1) % 3] *= -1
    return R


def transform(value) -> np.ndarray:
    """The pose of an entity's shape: a sphere at the point, a cylinder (meshcat's axis is y)
    along the line through its point, a slab (normal z) on the plane at its point."""
    T = np.eye(4)
    if isinstance(value, list):
        T[:3, 3] = value
        return T
    if "direction" in value:
        T[:3, :3] = _frame(np.asarray(value["direction"], dtype=float), 1)
    else:
        T[:3, :3] = _frame(np.asarray(value["normal"], dtype=float), 2)
    T[:3, 3] = value["point"]
    return T


def draw(viewer, entities: dict, size: float = 1.0, path: str = ROOT) -> None:
    """Add the shapes of ``entities`` (name -> JSON placement) to a meshcat ``viewer`` under
    ``path`` and place them; ``size`` is the scene's size (lines are three times as long,
    planes that wide)."""
    import meshcat.geometry as g

    for k, (name, value) in enumerate(sorted(entities.items())):
        colour = _COLOURS[k % len(_COLOURS)]
        if isinstance(value, list):
            shape, mat = g.Sphere(0.03 * size), g.MeshLambertMaterial(color=colour)
        elif "direction" in value:
            shape, mat = g.Cylinder(3.0 * size, 0.008 * size), g.MeshLambertMaterial(color=colour)
        else:
            shape = g.Box([1.5 * size, 1.5 * size, 0.004 * size])
            mat = g.MeshLambertMaterial(color=colour, opacity=0.35, transparent=True)
        viewer[f"{path}/{name}"].set_object(shape, mat)
    place(viewer, entities, path)


def place(viewer, entities: dict, path: str = ROOT) -> None:
    """Move the shapes drawn by :func:`draw` to ``entities`` (a viewer or an animation frame)."""
    for name, value in entities.items():
        viewer[f"{path}/{name}"].set_transform(transform(value))


def _scene(result: dict, viewer, delay: float) -> tuple[list[str], list[float]]:
    """Draw a result into ``viewer`` with an animation through its assemblies; their labels
    and the time (s) at which each starts in the animation."""
    from .server import meshcat_module

    meshcat = meshcat_module()
    shows = assemblies(result)
    if not shows:
        return ["no assembly found"], [0.0]
    centre, size = extent([e for _, e in shows])
    T = np.eye(4)
    T[:3, 3] = -centre
    viewer["kinbox"].set_transform(T)
    viewer["/Axes"].set_transform(T)
    viewer["/Grid"].set_property("visible", False)  # it hides planes seen edge-on
    draw(viewer, shows[0][1], size)
    F = max(2, int(round(delay * FPS)))
    if len(shows) > 1:
        anim = meshcat.animation.Animation(default_framerate=FPS)
        for k, (_, ents) in enumerate(shows):
            for frame in (k * F, k * F + F - 1):
                with anim.at_frame(viewer, frame) as f:
                    place(f, ents)
        viewer.set_animation(anim, play=True, repetitions=1_000_000)
    dist = 1.2 * size / math.sin(math.radians(37.5))
    d = np.array([1.0, 0.75, 0.55]) / np.linalg.norm([1.0, 0.75, 0.55]) * dist
    viewer["/Cameras/default/rotated/<object>"].set_property("position", [float(d[0]), float(d[2]), float(-d[1])])
    return [label for label, _ in shows], [k * F / FPS for k in range(len(shows))]


def _delay(delay: float) -> None:
    if not (isinstance(delay, (int, float)) and math.isfinite(delay) and delay > 0):
        raise InputError(f"delay must be a positive number of seconds, got {delay!r}")


def html(result: dict, delay: float = 1.0) -> str:
    """A self-contained HTML page stepping through every assembly of ``result``: meshcat's own
    static export, with the label bar and slider of :mod:`kinbox.viz.page`."""
    from .page import with_overlay
    from .server import connect, start

    _delay(delay)
    server = start()
    try:
        viewer = connect(server)
        labels, starts = _scene(result, viewer, delay)
        page = viewer.static_html()
    finally:
        server.stop()
    title = str(result.get("problem", "constraints"))
    if result.get("complete") is False:  # test_an_incomplete_answer_s_page_says_so
        title += f" \u2014 INCOMPLETE ({str(result.get('message') or 'a budget was hit')[:120]}): not every assembly"
    return with_overlay(str(page), title, labels, starts)


def to_html(result: dict, path, delay: float = 1.0) -> Path:
    page = html(result, delay)
    p = Path(path)
    try:
        p.write_text(page, encoding="utf-8")
    except OSError as e:
        raise InputError(f"cannot write {str(path)!r}: {e.strerror or e}") from None
    return p


def serve(result: dict, delay: float = 1.0, cycles: int = 0, host: str = "127.0.0.1") -> None:  # pragma: no cover
    """Show a result in a live meshcat viewer served on ``host`` (its URL printed) until Ctrl-C
    or ``cycles`` passes."""
    import time

    from .live import start_viewer, stop_viewer

    _delay(delay)
    viewer = start_viewer(host)
    try:
        print(f"kinbox: meshcat viewer at {viewer.url()} (Ctrl-C to stop)", flush=True)
        shows = assemblies(result)
        _scene(result, viewer, delay)
        n = 0
        while cycles == 0 or n < cycles:
            for label, ents in shows:
                place(viewer, ents)
                print(f"kinbox: {label}", file=sys.stderr, flush=True)
                time.sleep(delay)
            n += 1
    finally:
        stop_viewer(viewer)
