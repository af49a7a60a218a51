"""A result's collision scene in a replay: the obstacles drawn, the links in contact coloured.

A result checked against a scene (``kinbox ik ... --scene``) carries the scene (``"scene"``:
its obstacles, mesh files as absolute paths) and a verdict per configuration (docs/scenes.md).
:func:`add_obstacles` adds the obstacles to the visual model (fixed to the world, grey and
translucent unless the scene gives a ``color``); :func:`contact_ghosts` adds a red copy of
every link that is in contact in some configuration, shown only at those configurations
(:class:`~kinbox.viz.scene.Show` scales it to nothing elsewhere); :func:`verdict_notes` says for
each configuration shown whether it is free, in contact, or (on a curve) in a collision-free
stretch.
"""

from __future__ import annotations

import sys
from typing import Any

import numpy as np
import pinocchio as pin

OBSTACLE_COLOR = np.array([0.55, 0.55, 0.6, 0.45])
CONTACT_COLOR = np.array([0.95, 0.1, 0.1, 0.9])
#: a ghost not in contact is drawn at this scale (meshcat has no per-frame visibility track)
HIDDEN = 1e-6


def _shape(o: dict) -> Any:
    import coal

    shape = o.get("shape")
    if shape == "box":
        return coal.Box(*[float(v) for v in o["size"]])
    if shape == "sphere":
        return coal.Sphere(float(o["radius"]))
    if shape == "cylinder":
        return coal.Cylinder(float(o["radius"]), float(o["length"]))
    if shape == "capsule":
        return coal.Capsule(float(o["radius"]), float(o["length"]))
    if shape == "mesh":
        return coal.MeshLoader().load(str(o["file"]), np.asarray(o.get("scale", [1.0, 1.0, 1.0]), dtype=float))
    raise ValueError(f"unknown shape {shape!r}")


def add_obstacles(geom: pin.GeometryModel, scene: dict) -> int:
    """Add the obstacles of a result's ``scene`` to ``geom`` (a visual model); returns how many.
    An obstacle that cannot be drawn (a mesh file gone since) is left out with a note."""
    n = 0
    for o in scene.get("obstacles") or []:
        try:
            g = _shape(o)
            M = pin.XYZQUATToSE3(np.asarray(o["pose"], dtype=float))
        except Exception as e:  # noqa: BLE001 - a picture without one obstacle beats no picture
            print(f"kinbox: obstacle {o.get('name')!r} not drawn ({e})", file=sys.stderr)
            continue
        go = pin.GeometryObject(f"kinbox_obstacle/{o.get('name')}", 0, 0, M, g)
        if o.get("shape") == "mesh":
            go.meshPath = str(o["file"])
            go.meshScale = np.asarray(o.get("scale", [1.0, 1.0, 1.0]), dtype=float)
        go.meshColor = np.asarray(o.get("color", OBSTACLE_COLOR), dtype=float)
        geom.addGeometryObject(go)
        n += 1
    return n


def contacts(d: dict) -> list[tuple[np.ndarray, set[str]]]:
    """(configuration, names of the links and obstacles in contact there) of every
    configuration of a result dict that is in contact."""
    out = []
    for s in d.get("solutions") or []:
        c = s.get("collision") or {}
        if c.get("pairs"):
            out.append((np.asarray(s["q"], dtype=float), {n for p in c["pairs"] for n in p}))
    for comp in d.get("components") or []:
        branches = comp.get("branches") or ([{"polyline": comp["polyline"]}] if comp.get("polyline") else [])
        for b, col in zip(branches, comp.get("collision") or []):
            pl = b.get("polyline") or []
            for i, pairs in col.get("contacts") or []:
                if 0 <= int(i) < len(pl):
                    out.append((np.asarray(pl[int(i)], dtype=float), {n for p in pairs for n in p}))
    return out


def key(q: np.ndarray) -> bytes:
    return np.round(np.asarray(q, dtype=float), 9).tobytes()


def contact_ghosts(model: pin.Model, geom: pin.GeometryModel, d: dict) -> tuple[list[tuple[int, str, np.ndarray]], dict[bytes, set[str]]]:
    """Red copies of the visual geometry of every link in contact somewhere in ``d``:
    ([(geometry id, link, scale)], configuration key -> names in contact)."""
    table = {key(q): names for q, names in contacts(d)}
    links = set().union(*table.values()) if table else set()
    ghosts = []
    for go in list(geom.geometryObjects):
        if go.parentFrame >= len(model.frames) or go.name.startswith("kinbox_"):
            continue
        link = model.frames[go.parentFrame].name
        if link not in links:
            continue
        copy = pin.GeometryObject(go)
        copy.name = f"kinbox_contact/{go.name}"
        copy.meshColor = CONTACT_COLOR.copy()
        copy.overrideMaterial = True
        scale = np.asarray(go.meshScale, dtype=float) * 1.01
        copy.meshScale = scale * HIDDEN
        ghosts.append((geom.addGeometryObject(copy), link, scale))
    return ghosts, table


def verdict_notes(d: dict) -> tuple[list[str], dict[int, list[str]]]:
    """Notes for the label bar: one per isolated solution (free with its clearance, or the
    pairs in contact), and per curve component (index among the components of dimension >= 1)
    one per point of its polyline (in which collision-free stretch it lies, or not free)."""
    sols = []
    for s in d.get("solutions") or []:
        c = s.get("collision")
        if c is None:
            sols.append("")
        elif c.get("free"):
            cl = c.get("clearance")
            sols.append("collision-free" + (f", clearance {cl:.3f} m" if isinstance(cl, (int, float)) else ""))
        else:
            sols.append("IN CONTACT: " + ", ".join(f"{a}-{b}" for a, b in c.get("pairs") or []))
    curves: dict[int, list[str]] = {}
    for n, comp in enumerate(c for c in d.get("components") or [] if int(c.get("dimension", 0)) >= 1):
        col = comp.get("collision")
        pl = comp.get("polyline")
        if not col or not pl:
            continue
        stretches = col[0].get("stretches") or []
        where: dict[bytes, int] = {}
        for k, st in enumerate(stretches):
            for q in st.get("polyline") or []:
                where.setdefault(key(q), k)
        notes = []
        for q in pl:
            at = where.get(key(q))
            notes.append(f"collision-free stretch {at + 1} of {len(stretches)}" if at is not None else "NOT collision-free")
        curves[n] = notes
    return sols, curves
