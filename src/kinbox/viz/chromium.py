"""Pictures of a page with headless Chromium (software WebGL, no network): for the tests of the
HTML page and the README pictures."""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import subprocess
import tempfile
from pathlib import Path

from ..errors import InputError


def find_chromium() -> str | None:
    """A Chromium / Chrome executable on PATH, or None."""
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        exe = shutil.which(name)
        if exe:
            return exe
    return None


def screenshot(
    html_path: str | os.PathLike,
    png_path: str | os.PathLike,
    size: tuple[int, int] = (800, 600),
    budget_ms: int = 1000,
    timeout: float = 30.0,
    browser: str | None = None,
) -> Path:
    """Render a page with headless Chromium (software WebGL, no network) into a PNG.

    ``budget_ms`` is Chromium's virtual time budget: the page runs that long (animation
    included) before the picture is taken. Chromium occasionally hangs at start-up in
    containers: a run that exceeds ``timeout`` seconds is killed and tried once more.
    """
    exe = browser or find_chromium()
    if exe is None:
        raise InputError("no Chromium found on PATH (Debian: apt-get install chromium)")
    png = Path(png_path).resolve()
    if png.exists():
        png.unlink()
    url = Path(html_path).resolve().as_uri()
    last = ""
    for _ in range(2):
        with tempfile.TemporaryDirectory(prefix="kinbox-chromium-") as profile, tempfile.TemporaryFile() as err:
            args = [
                exe,
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--enable-unsafe-swiftshader",
                "--disable-quic",
                "--no-first-run",
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
                "--hide-scrollbars",
                f"--user-data-dir={profile}",
                f"--window-size={int(size[0])},{int(size[1])}",
                f"--virtual-time-budget={int(budget_ms)}",
                f"--screenshot={png}",
                url,
            ]
            proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=err, start_new_session=True)
            timed_out = False
            try:
                proc.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                timed_out = True
                last = f"timed out after {timeout} s"
            finally:
                with contextlib.suppress(ProcessLookupError, PermissionError):
                    os.killpg(proc.pid, signal.SIGKILL)  # the browser we started, and its children
                proc.wait()
            if timed_out:
                continue
            err.seek(0)
            lines = err.read().decode("utf-8", "replace").strip().splitlines()
            last = lines[-1] if lines else ""
            if png.is_file() and png.stat().st_size > 0:
                return png
    raise RuntimeError(f"Chromium did not write {png.name}: {last}")
