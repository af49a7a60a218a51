"""Replays of a result: every configuration on the robot, live in meshcat or as one HTML page.

``kinbox replay RESULT.json [--html OUT.html]``, :func:`kinbox.replay` and :func:`kinbox.to_html`
land here. What is shown, in order (:mod:`~kinbox.viz.motion`): every isolated solution (IK
solutions, assembly modes), each held for a while, then every curve component as a motion
along it. The work is split by job:

* :mod:`kinbox.answer.resultfile`: reading a result file, checked against its JSON Schema;
* :mod:`~kinbox.viz.motion`: what to show and in which order, and for how long;
* :mod:`~kinbox.viz.scene` and :mod:`~kinbox.viz.shapes`: the mechanism rebuilt from the
  result, with its meshes (URDF robots) or simple shapes (everything else);
* :mod:`~kinbox.viz.view`: the scene in meshcat through Pinocchio's ``MeshcatVisualizer``;
* :mod:`~kinbox.viz.server`: the meshcat server child (loopback only, ends with its parent);
* :mod:`~kinbox.viz.live` (live viewer) and :mod:`~kinbox.viz.page` (meshcat's static HTML
  export, animated);
* :mod:`~kinbox.viz.chromium`: pictures of the page with headless Chromium.
"""

from __future__ import annotations

from ..answer.resultfile import load_result
from .chromium import find_chromium, screenshot
from .live import replay, start_viewer, stop_viewer
from .motion import order_along_curve
from .page import html, to_html
from .scene import Show, mesh_model, prepare
from .shapes import simple_model

__all__ = [
    "Show",
    "find_chromium",
    "html",
    "load_result",
    "mesh_model",
    "order_along_curve",
    "prepare",
    "replay",
    "screenshot",
    "simple_model",
    "start_viewer",
    "stop_viewer",
    "to_html",
]
