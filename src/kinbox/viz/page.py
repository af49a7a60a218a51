"""The offline HTML page of a result: meshcat's own static export of the scene, animated.

The scene is drawn in a meshcat server started for the export (on loopback, stopped at once)
and exported by meshcat (``Visualizer.static_html()``: its viewer and the scene inlined, the
geometry as ``data:`` URLs, so the page opens offline). The configurations are one looping
meshcat animation: each isolated solution held ``delay`` seconds, each curve component swept as
a motion (:func:`kinbox.viz.motion.timeline`). kinbox adds a small bar on top: the label of the
configuration on screen and a slider to pick one (meshcat's own controls, top right, play,
pause and scrub the animation too).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from ..errors import InputError
from .motion import FPS, timeline
from .scene import Show, prepare
from .server import connect, start
from .view import animate, display, frame_camera, show_nothing, visualizer


def html(result: Any, delay: float = 1.0, sweep: float | None = None) -> str:
    """The self-contained HTML page of a result (a Result, a result dict or a :class:`Show`);
    see the module docstring."""
    show = result if isinstance(result, Show) else prepare(result)
    timing = timeline(show.groups, delay, sweep)
    server = start()
    try:
        viewer = connect(server)
        viz = visualizer(show, viewer)
        frame_camera(show, viewer)
        starts = [0]
        if not show.qs:  # nothing to show but an IK goal, if any
            show_nothing(show, viz, viewer)
        else:
            display(show, viz, show.qs[0])
            if len(show.qs) > 1:
                starts = animate(show, viz, viewer, timing)
        page = viewer.static_html()
    finally:
        server.stop()
    labels = show.labels or ["no configuration found"]
    return with_overlay(page, show.title, labels, [s / FPS for s in starts])


def with_overlay(page: str, title: str, labels: list[str], starts: list[float]) -> str:
    """``page`` (meshcat's static export) with kinbox's label bar and slider: one label per
    configuration, shown from ``starts[i]`` seconds of the animation on."""
    overlay = _OVERLAY.format(
        title=_js(title), labels=_js(labels), starts=_js(starts), last=len(labels) - 1, slider="" if len(labels) > 1 else "display:none"
    )
    return page.replace("</body>", overlay + "</body>", 1)


def _js(v: Any) -> str:
    """``v`` as a JavaScript literal inside ``<script>``: no ``<``, ``>`` or ``&`` at all (a
    title holding ``<!--<script>`` would otherwise keep the script from ending), written as
    JSON escapes (tests/cli/test_hostile.py::test_page_title_escaped)."""
    return json.dumps(v).replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")


_OVERLAY = """<div id="kinbox-bar" style="position:absolute;left:8px;top:8px;font:14px sans-serif;color:#fff;
background:rgba(0,0,0,0.45);padding:4px 8px;border-radius:4px">
<div id="kinbox-label"></div>
<input id="kinbox-slider" type="range" min="0" max="{last}" step="1" value="0" style="width:320px;{slider}"
 title="pick a configuration (pauses the animation; meshcat's controls play it again)">
</div>
<script>
(function () {{
  var title = {title}, labels = {labels}, starts = {starts};
  var label = document.getElementById("kinbox-label"), slider = document.getElementById("kinbox-slider");
  function now() {{
    var t = 0;
    try {{ viewer.animator.actions.forEach(function (a) {{ t = Math.max(t, a.time); }}); }} catch (e) {{}}
    return t;
  }}
  function index(t) {{
    var lo = 0, hi = starts.length - 1;
    while (lo < hi) {{ var m = (lo + hi + 1) >> 1; if (starts[m] <= t + 1e-6) lo = m; else hi = m - 1; }}
    return lo;
  }}
  slider.addEventListener("input", function () {{
    try {{ viewer.animator.pause(); viewer.animator.seek(starts[+slider.value]); }} catch (e) {{}}
  }});
  function loop() {{
    var k = index(now());
    label.textContent = "kinbox: " + title + " \\u2014 " + labels[Math.min(k, labels.length - 1)];
    if (document.activeElement !== slider) slider.value = k;
    requestAnimationFrame(loop);
  }}
  loop();
}})();
</script>
"""


def to_html(result: Any, path: str | Path, delay: float = 1.0, sweep: float | None = None) -> Path:
    """Write :func:`html` to ``path``; returns the path."""
    page = html(result, delay, sweep)
    p = Path(path)
    try:
        p.write_text(page, encoding="utf-8")
    except OSError as e:
        raise InputError(f"cannot write {str(path)!r}: {e.strerror or e}") from None
    return p
