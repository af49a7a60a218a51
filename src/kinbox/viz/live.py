"""A live replay: the configurations of a result shown one after the other in a meshcat viewer,
the label of each printed as it comes."""

from __future__ import annotations

import sys
import time
from typing import IO, Any

from .motion import timeline
from .scene import Show, prepare
from .server import LOOPBACK, Server, connect, is_loopback, start
from .view import display, frame_camera, show_nothing, visualizer


def start_viewer(host: str = LOOPBACK, port: int | None = None) -> Any:
    """A meshcat viewer with a server child of its own (:mod:`kinbox.viz.server`) serving the page
    on ``host``; its URL is ``viewer.url()``. Stop it with :func:`stop_viewer` (it also stops
    when this process ends, however it ends)."""
    server = start(host, port)
    if not is_loopback(host):
        print(f"kinbox: warning: the viewer is served on {host or 'every interface'!r}: other hosts that "
              "reach this address can see the scene (no authentication)", file=sys.stderr, flush=True)
    try:
        viewer = connect(server)
    except BaseException:
        server.stop()
        raise
    viewer.window.kinbox_server = server
    return viewer


def stop_viewer(viewer: Any) -> None:
    """Stop the server child of a viewer made by :func:`start_viewer`."""
    window = getattr(viewer, "window", None)
    server = getattr(window, "kinbox_server", None)
    if isinstance(server, Server):
        server.stop()
        return
    proc = getattr(window, "server_proc", None)  # a viewer that started meshcat's own server
    if proc is not None and proc.poll() is None:
        proc.kill()
        proc.wait()


def replay(result: Any, viewer: Any = None, delay: float = 1.0, cycles: int = 1,
           log: IO[str] | bool | None = None) -> Any:
    """Show every configuration of ``result`` in meshcat, ``delay`` seconds each.

    ``viewer``: a ``meshcat.Visualizer`` (default: :func:`start_viewer`, its URL printed).
    ``cycles``: passes through the configurations (0: until Ctrl-C). ``log``: where to print
    the labels (default: stderr; ``False``: nowhere). Returns the
    ``pinocchio.visualize.MeshcatVisualizer`` (its ``viewer`` is the meshcat one).
    """
    show = result if isinstance(result, Show) else prepare(result)
    timing = timeline(show.groups, delay)
    out: IO[str] | None = sys.stderr if log is None or log is True else (log or None)
    if viewer is None:
        viewer = start_viewer()
        if out:
            print(f"kinbox: meshcat viewer at {viewer.url()}", file=out, flush=True)
    viz = visualizer(show, viewer)
    frame_camera(show, viewer)
    if not show.qs:
        if out:
            print(f"kinbox: {show.title}: no configuration to show", file=out, flush=True)
        show_nothing(show, viz, viewer)
        return viz
    n = 0
    while cycles <= 0 or n < cycles:
        for q, label, (seconds, _) in zip(show.qs, show.labels, timing):
            t0 = time.monotonic()
            display(show, viz, q)
            if out:
                print(f"kinbox: {label}", file=out, flush=True)
            time.sleep(max(0.0, seconds - (time.monotonic() - t0)))
        n += 1
    return viz
