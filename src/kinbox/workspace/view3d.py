"""A workspace paving in 3-D (meshcat's static HTML export) with the robot.

The paving (:class:`~kinbox.workspace.Paving`) is drawn on the grid of its smallest boxes: the
inside boxes as one merged mesh (only the faces between an inside cell and a cell that is not),
green; the boundary layer the same way, orange and translucent; outside boxes are not drawn. The
robot is shown at witness configurations of inside boxes (up to :data:`WITNESSES`, spread over
the paving, in a looping animation), or at its reference configuration when there is none.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError

#: the most witness configurations the page cycles through
WITNESSES = 8
INSIDE_COLOUR, BOUNDARY_COLOUR = 0x2CA02C, 0xFF7F0E


def grid(pv) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(origin, cell, verdicts)``: the paving on the grid of its smallest boxes (-1 where no box
    was decided)."""
    side = (pv.hi - pv.lo).min(axis=0)
    n = np.maximum(np.round((pv.region[1] - pv.region[0]) / side).astype(int), 1)
    g = np.full(tuple(n), -1, dtype=np.int8)
    a = np.round((pv.lo - pv.region[0]) / side).astype(int)
    b = np.round((pv.hi - pv.region[0]) / side).astype(int)
    for lo, hi, v in zip(a, b, pv.verdict):
        g[lo[0] : hi[0], lo[1] : hi[1], lo[2] : hi[2]] = v
    return np.asarray(pv.region[0], dtype=float), side, g


def merged_mesh(origin: np.ndarray, cell: np.ndarray, g: np.ndarray, verdict: int) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (n x 3) and triangles (m x 3) of the outer faces of the cells of ``verdict``: each
    face between such a cell and one that is not (or the grid's edge), two triangles."""
    mine = np.pad(g == verdict, 1)
    verts: list[np.ndarray] = []
    for ax in range(3):
        for step in (1, -1):
            nb = np.roll(mine, -step, axis=ax)
            face = mine & ~nb
            idx = np.argwhere(face[1:-1, 1:-1, 1:-1])
            if not len(idx):
                continue
            u, v = [k for k in range(3) if k != ax]
            base = idx.astype(float)
            base[:, ax] += 1.0 if step == 1 else 0.0
            corners = []
            for du, dv in ((0, 0), (1, 0), (1, 1), (0, 1)):
                c = base.copy()
                c[:, u] += du
                c[:, v] += dv
                corners.append(origin + c * cell)
            quad = np.stack(corners, axis=1)  # k x 4 x 3
            verts.append(quad)
    if not verts:
        return np.zeros((0, 3), np.float32), np.zeros((0, 3), np.uint32)
    Q = np.concatenate(verts)
    V = Q.reshape(-1, 3).astype(np.float32)
    k = np.arange(len(Q), dtype=np.uint32) * 4
    # both windings: the faces are seen from either side
    F = np.concatenate(
        [np.stack([k, k + 1, k + 2], 1), np.stack([k, k + 2, k + 3], 1), np.stack([k, k + 2, k + 1], 1), np.stack([k, k + 3, k + 2], 1)]
    )
    return V, F


def _witnesses(pv, nq: int) -> list[np.ndarray]:
    from .paving import INSIDE

    if pv.witness.shape[1] != nq:
        return []
    idx = np.where((pv.verdict == INSIDE) & np.all(np.isfinite(pv.witness), axis=1))[0]
    if not len(idx):
        return []
    pick = idx[np.linspace(0, len(idx) - 1, min(WITNESSES, len(idx))).round().astype(int)]
    return [np.array(pv.witness[i], dtype=float) for i in dict.fromkeys(pick)]


def html(pv, delay: float = 1.5) -> str:
    """The page of a paving (see the module's text)."""
    import pinocchio as pin

    from ..model.loading import load
    from ..viz.motion import FPS, Group, timeline
    from ..viz.page import with_overlay
    from ..viz.scene import Show, mesh_model
    from ..viz.server import connect, meshcat_module, start
    from ..viz.shapes import simple_model
    from ..viz.view import ROOT, animate, display, frame_camera, visualizer

    robot = pv.meta.get("robot")
    if not isinstance(robot, str):
        raise InputError("the paving does not name its robot: no 3-D view of it")
    mech = load(robot)
    model = mech.model
    qs = _witnesses(pv, model.nq) or [pin.neutral(model)]
    geom, _ = mesh_model(model, robot)
    meshes = geom is not None
    if geom is None:
        geom, segs = simple_model(mech, qs)
    else:
        segs = []
    v = pv.volumes()
    title = f"workspace of {robot} {pv.meta.get('frame', 'platform')}: inside {v['inside']:.4g}, boundary {v['boundary']:.4g}"
    show = Show(title, model, geom, [Group("", qs, False)], meshes, segs)
    server = start()
    try:
        viewer = connect(server)
        viz = visualizer(show, viewer)
        frame_camera(show, viewer)
        g = meshcat_module().geometry
        origin, cell, grid_ = grid(pv)
        if pv.dims == 3:
            for verdict, colour, opacity in ((1, INSIDE_COLOUR, 0.55), (2, BOUNDARY_COLOUR, 0.2)):
                V, F = merged_mesh(origin, cell, grid_, verdict)
                if len(F):
                    mat = g.MeshLambertMaterial(color=colour, opacity=opacity, transparent=True)
                    viewer[f"{ROOT}/paving/{'inside' if verdict == 1 else 'boundary'}"].set_object(g.TriangularMeshGeometry(V, F), mat)
        display(show, viz, qs[0])
        starts = [0]
        if len(qs) > 1:
            starts = animate(show, viz, viewer, timeline(show.groups, delay, None))
        page = viewer.static_html()
    finally:
        server.stop()
    labels = (
        [f"witness {k + 1} of {len(qs)}" for k in range(len(qs))]
        if len(qs) > 1 or _witnesses(pv, model.nq)
        else ["reference configuration"]
    )
    return with_overlay(page, title, labels, [s / FPS for s in starts])


def to_html(pv, path: str | Path, delay: float = 1.5) -> Path:
    page = html(pv, delay)
    p = Path(path)
    try:
        p.write_text(page, encoding="utf-8")
    except OSError as e:
        raise InputError(f"cannot write {str(path)!r}: {e.strerror or e}") from None
    return p


def is_paving(path: Any) -> bool:
    """Is ``path`` a workspace paving file (``.npz``, or JSON of kind ``workspace``)?"""
    s = str(path)
    if s.endswith(".npz"):
        return True
    try:
        with open(s, encoding="utf-8") as f:
            head = f.read(200)
    except (OSError, UnicodeDecodeError):
        return False
    return '"kind": "workspace"' in head
