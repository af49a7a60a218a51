"""A live replay: the configurations of a result shown one after the other in a meshcat viewer
(isolated solutions held ``delay`` seconds, curve components swept as motions), the label of
each printed as it comes."""

from __future__ import annotations

import signal
import sys
import threading
import time
from typing import IO, Any

from .motion import Group, timeline
from .scene import Show, prepare
from .server import LOOPBACK, Server, connect, is_loopback, start
from .view import display, frame_camera, show_nothing, visualizer


def start_viewer(host: str = LOOPBACK, port: int | None = None) -> Any:
    """A meshcat viewer with a server child of its own (:mod:`kinbox.viz.server`) serving the page
    on ``host``; its URL is ``viewer.url()``. Stop it with :func:`stop_viewer` (it also stops
    when this process ends, however it ends)."""
    server = start(host, port)
    if not is_loopback(host):
        print(
            f"kinbox: warning: the viewer is served on {host or 'every interface'!r}: other hosts that "
            "reach this address can see the scene (no authentication)",
            file=sys.stderr,
            flush=True,
        )
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


def replay(
    result: Any, viewer: Any = None, delay: float = 1.0, cycles: int = 1, log: IO[str] | bool | None = None, sweep: float | None = None
) -> Any:
    """Show every configuration of ``result`` in meshcat: isolated solutions ``delay`` seconds
    each, each curve component as a motion of ``sweep`` seconds (default: 5 delays).

    ``viewer``: a ``meshcat.Visualizer`` (default: :func:`start_viewer`, its URL printed).
    ``cycles``: passes through the configurations (0: until Ctrl-C). ``log``: where to print
    the labels (default: stderr; ``False``: nowhere). Returns the
    ``pinocchio.visualize.MeshcatVisualizer`` (its ``viewer`` is the meshcat one).
    """
    show = result if isinstance(result, Show) else prepare(result)
    timing = timeline(show.groups, delay, sweep)
    out: IO[str] | None = sys.stderr if log is None or log is True else (log or None)
    if viewer is None:
        viewer = start_viewer()
        if out:
            print(f"kinbox: meshcat viewer at {viewer.url()}", file=out, flush=True)
    with _Signals() as signals:
        viz = visualizer(show, viewer)
        frame_camera(show, viewer)
        signals.check()
        if not show.qs:
            if out:
                print(f"kinbox: {show.title}: no configuration to show", file=out, flush=True)
            show_nothing(show, viz, viewer)
            return viz
        n = 0
        while cycles <= 0 or n < cycles:
            for g, first in _firsts(show):
                if out and g.curve:
                    print(f"kinbox: {g.head}: a motion through {len(g.qs)} configurations", file=out, flush=True)
                for k, q in enumerate(g.qs):
                    seconds, _ = timing[first + k]
                    t0 = time.monotonic()
                    display(show, viz, q)
                    signals.check()
                    if out and not g.curve:
                        print(f"kinbox: {g.labels()[k]}", file=out, flush=True)
                    time.sleep(max(0.0, seconds - (time.monotonic() - t0)))
            n += 1
    return viz


def _firsts(show: Show) -> list[tuple[Group, int]]:
    """(group, index of its first configuration in ``show.qs``) for every group."""
    out, k = [], 0
    for g in show.groups:
        out.append((g, k))
        k += len(g.qs)
    return out


class _Signals:
    """Ctrl-C (KeyboardInterrupt) and SIGTERM (SystemExit 143) that are never lost in a replay.

    pyzmq (27) checks for signals after a successful call and drops the exception the handler
    raised, so a Ctrl-C that lands in a meshcat command would vanish; these handlers also note
    the signal, and :meth:`check` (after each command) raises it again. The previous handlers
    come back on exit; outside the main thread (where handlers cannot be set) nothing changes.
    """

    def __enter__(self) -> _Signals:
        self.got: int | None = None
        self.saved: dict[int, Any] = {}
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                self.saved[sig] = signal.signal(sig, self._handler)
        return self

    def __exit__(self, *exc: object) -> None:
        for sig, h in self.saved.items():
            signal.signal(sig, h)

    @staticmethod
    def _exception(signum: int) -> BaseException:
        return KeyboardInterrupt() if signum == signal.SIGINT else SystemExit(128 + signum)

    def _handler(self, signum: int, frame: object) -> None:
        self.got = signum
        raise self._exception(signum)

    def check(self) -> None:
        if self.got is not None:
            raise self._exception(self.got)
