"""The meshcat server of a replay: a child process that serves the viewer page on loopback only.

meshcat's own server (``meshcat.servers.zmqserver``) serves its web page on every interface and
outlives a parent killed by a signal. This one runs meshcat's server code
(``ZMQWebSocketBridge``) with two changes:

* the web page is served on ``host`` only (default ``127.0.0.1``); served on loopback, it
  answers only requests whose ``Host`` header names this machine's loopback (``127.0.0.1``,
  ``localhost``, ``[::1]``): a web page of another site that rebinds its DNS name to
  127.0.0.1 gets 403;
* the command socket (ZeroMQ) is not a TCP port that any local process could send scene
  commands to: it is a Unix socket in a folder of its own, created readable by this user
  only (mode 0700), so only processes of the same user reach it. ZeroMQ's REQ/REP commands
  of meshcat carry no credential, and its client (``meshcat.Visualizer``) cannot add one:
  the file system's permission is the authentication;
* the child dies with its parent, however the parent ends: it exits when its stdin (a pipe
  from the parent) reaches end of file, which happens when the parent exits, is killed (even
  by SIGKILL) or calls :meth:`Server.stop`; on Linux the kernel also sends it SIGTERM when the
  parent dies (``PR_SET_PDEATHSIG``).

``python -m kinbox.viz.server [--host H] [--port P]`` is the child; :func:`start` starts it.
"""

from __future__ import annotations

import argparse
import atexit
import contextlib
import io
import os
import selectors
import signal
import subprocess
import sys
import tempfile
import threading
import time
import warnings
from typing import Any

from ..errors import InputError

LOOPBACK = "127.0.0.1"
_WILDCARD = ("", "0.0.0.0", "::")


def meshcat_module() -> Any:
    """``import meshcat`` without its pyzmq deprecation warning (``zmq.eventloop.ioloop``)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", category=DeprecationWarning, module=r"meshcat\..*")
        warnings.filterwarnings("ignore", message=r".*zmq\.eventloop\.ioloop is deprecated.*")
        import meshcat
        import meshcat.animation  # noqa: F401
        import meshcat.servers.zmqserver  # noqa: F401
    return meshcat


def is_loopback(host: str) -> bool:
    return host in ("localhost", "::1") or host.startswith("127.")


def host_is_loopback(header: str) -> bool:
    """Does an HTTP ``Host`` header (``name[:port]``) name this machine's loopback?"""
    name = header.strip().lower()
    if name.startswith("["):  # [::1]:7000
        name = name[1 : name.find("]")] if "]" in name else ""
    else:
        name = name.rsplit(":", 1)[0] if name.count(":") == 1 else name
    return name in ("localhost", "::1") or (name.startswith("127.") and name.replace(".", "").isdigit())


class Server:
    """A running server child: ``zmq_url`` (commands), ``web_url`` (the page), ``proc``."""

    def __init__(self, proc: subprocess.Popen, zmq_url: str, web_url: str):
        self.proc = proc
        self.zmq_url = zmq_url
        self.web_url = web_url

    def stop(self, timeout: float = 5.0) -> None:
        """End the child and wait for it (closing its stdin asks it to exit; then SIGKILL)."""
        if self.proc.stdin is not None and not self.proc.stdin.closed:
            with contextlib.suppress(OSError):
                self.proc.stdin.close()
        try:
            self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        if self.proc.stdout is not None:
            self.proc.stdout.close()
        if self.zmq_url.startswith("ipc://"):  # the child's socket folder
            import shutil

            shutil.rmtree(os.path.dirname(self.zmq_url[len("ipc://") :]), ignore_errors=True)


def _check_address(host: str) -> None:
    """An InputError unless a server can listen on ``host`` (an address of this machine)."""
    import socket

    try:
        infos = socket.getaddrinfo(host or None, 0, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)
        family, kind, proto, _, addr = infos[0]
        with socket.socket(family, kind, proto) as s:
            s.bind(addr)
    except (OSError, UnicodeError) as e:
        raise InputError(f"cannot serve on host {host!r}: {getattr(e, 'strerror', None) or e}") from None


def start(host: str = LOOPBACK, port: int | None = None, timeout: float = 60.0) -> Server:
    """Start a server child serving the viewer page on ``host`` (see the module docstring).

    ``port``: the web page's port (default: the first free one from 7000, as meshcat does).
    Raises :class:`InputError` if the child does not come up (e.g. ``host`` is not an address
    of this machine), with the child's last message.
    """
    _check_address(host)
    args = [sys.executable, "-u", "-m", "kinbox.viz.server", "--host", host]
    if port is not None:
        args += ["--port", str(int(port))]
    env = dict(os.environ)  # the child imports this kinbox, wherever it came from
    top = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    env["PYTHONPATH"] = os.pathsep.join([top] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    err = tempfile.TemporaryFile()
    # a session of its own: Ctrl-C in a terminal reaches the parent only, which then stops it
    # unbuffered: the selector below sees the pipe, so no line may wait in a buffer
    proc = subprocess.Popen(args, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=err, start_new_session=True, env=env, bufsize=0)
    lines: list[str] = []
    sel = selectors.DefaultSelector()
    assert proc.stdout is not None
    sel.register(proc.stdout, selectors.EVENT_READ)
    deadline = time.monotonic() + timeout
    try:
        while len(lines) < 2:
            left = deadline - time.monotonic()
            if left <= 0 or not sel.select(left):
                raise TimeoutError
            line = proc.stdout.readline().decode("utf-8", "replace").strip()
            if not line:  # end of file: the child is gone
                raise ChildProcessError
            if line.startswith(("zmq_url=", "web_url=")):
                lines.append(line)
    except (TimeoutError, ChildProcessError):
        Server(proc, "", "").stop(timeout=1.0)
        err.seek(0)
        msg = [ln for ln in err.read().decode("utf-8", "replace").splitlines() if ln.strip()]
        raise InputError(f"the meshcat server did not start on {host!r}: {msg[-1].strip() if msg else 'no answer'}") from None
    finally:
        sel.close()
        err.close()
    urls = dict(line.split("=", 1) for line in lines)
    server = Server(proc, urls["zmq_url"], urls["web_url"])
    atexit.register(server.stop)
    return server


def connect(server: Server) -> Any:
    """A ``meshcat.Visualizer`` talking to ``server`` (``viewer.window.server_proc`` is its child)."""
    meshcat = meshcat_module()
    with contextlib.redirect_stdout(io.StringIO()):  # meshcat prints the URL; callers say it their way
        viewer = meshcat.Visualizer(zmq_url=server.zmq_url)
    viewer.window.server_proc = server.proc
    return viewer


# -- the child ---------------------------------------------------------------------------------
def _die_with_parent() -> None:
    """Exit when the parent goes: at end of file on stdin, and (Linux) on its death signal."""
    if sys.platform.startswith("linux"):
        with contextlib.suppress(Exception):
            import ctypes

            PR_SET_PDEATHSIG = 1
            ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)

    def watch() -> None:  # a parent that died before prctl: its end of the pipe is closed already
        with contextlib.suppress(Exception):
            sys.stdin.buffer.read()  # returns at end of file
        os._exit(0)

    threading.Thread(target=watch, daemon=True).start()


def _bridge(host: str, port: int | None) -> Any:
    meshcat_module()
    from meshcat.servers.zmqserver import ZMQWebSocketBridge

    class Bridge(ZMQWebSocketBridge):
        """meshcat's bridge with its web page served on ``web_host`` only."""

        def __init__(self) -> None:
            self.web_host = host
            self.sockets = tempfile.mkdtemp(prefix="kinbox-meshcat-")  # mode 0700
            zmq_url = f"ipc://{os.path.join(self.sockets, 'commands')}"
            with contextlib.redirect_stdout(io.StringIO()):  # "Port in use, trying another"
                super().__init__(zmq_url=zmq_url, host=LOOPBACK, port=port)
            shown = LOOPBACK if host in _WILDCARD else f"[{host}]" if ":" in host else host
            self.web_url = f"http://{shown}:{self.fileserver_port}/static/"

        def make_app(self) -> Any:
            import tornado.web

            app = super().make_app()
            listen = app.listen
            app.listen = lambda p, **kw: listen(p, address=self.web_host, **kw)
            if is_loopback(self.web_host):
                find = app.find_handler

                def only_loopback(request, **kw):  # tests/cli/test_hostile.py::test_viewer_checks_host
                    if not host_is_loopback(request.headers.get("Host", "")):
                        return app.get_handler_delegate(request, tornado.web.ErrorHandler, {"status_code": 403})
                    return find(request, **kw)

                app.find_handler = only_loopback
            return app

    return Bridge()


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(prog="python -m kinbox.viz.server", description="meshcat server on one address, ending with its parent")
    p.add_argument("--host", default=LOOPBACK)
    p.add_argument("--port", type=int)
    a = p.parse_args(argv)
    _die_with_parent()
    signal.signal(signal.SIGTERM, lambda *_: os._exit(0))
    bridge = _bridge(a.host, a.port)
    print(f"zmq_url={bridge.zmq_url}", flush=True)
    print(f"web_url={bridge.web_url}", flush=True)
    with contextlib.suppress(KeyboardInterrupt):
        bridge.run()


if __name__ == "__main__":
    main()
