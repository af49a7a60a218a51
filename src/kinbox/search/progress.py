"""Progress of a search on stderr, drawn by tqdm; what it shows never feeds back into the search."""

from __future__ import annotations

import os
import sys
import time
from typing import Any

import numpy as np


class Progress:
    """Progress of a search on stderr, drawn by tqdm: boxes so far and their rate, pending boxes,
    solutions, and the share of the domain's volume still to explore (the boxes ``done..`` of
    the wave and the next wave so far). Refreshed at most every ``INTERVAL`` seconds; what is
    shown never feeds back into the search."""

    INTERVAL = 0.25

    def __init__(self, enabled: bool, root_logvol: np.ndarray):
        self.enabled = enabled
        self.last = time.perf_counter()
        self.root_w = root_logvol
        self.bar: Any = None
        if enabled:
            from tqdm import tqdm

            # smoothing=0: the rate is boxes over the whole run, not a noisy recent average.
            # A terminal that reports a size of 0 x 0 (a bare pty) would get no line at all
            # from tqdm: no width limit there, and room for the line.
            size = {"ncols": 0, "nrows": 20} if _columns(sys.stderr) == 0 else {}
            self.bar = tqdm(
                desc="kinbox",
                unit=" boxes",
                file=sys.stderr,
                leave=True,
                mininterval=0,
                smoothing=0,
                bar_format="{desc}: {n_fmt}{unit}{postfix} [{elapsed}, {rate_fmt}]",
                **size,
            )

    def report(self, stats, wave, done: int, nxt, force=False):
        """Update the line (``force``: now, and the final time: the line is closed)."""
        if self.bar is None:
            return
        now = time.perf_counter()
        if not force and now - self.last < self.INTERVAL:
            return
        self.last = now
        todo = list(wave[done:]) + list(nxt)
        vol = sum(float(np.prod(np.clip((b[1] - b[0]) / self.root_w, 0, 1))) for b in todo)
        self.bar.set_postfix_str(
            f"{len(todo)} pending, {stats['solutions']} solutions ({stats['certified']} certified), volume left {vol:.3e}", refresh=False
        )
        self.bar.n = stats["boxes"]
        if force:
            self.bar.close()  # draws the final state once more and ends the line
            self.bar = None
        else:
            self.bar.refresh()


def show_progress(option: bool | None) -> bool:
    """Whether to draw: the option, or (None) when stderr is a terminal."""
    return bool(option if option is not None else sys.stderr.isatty())


def _columns(stream: Any) -> int | None:
    """The width of the terminal ``stream`` writes to, or None if it is not a terminal."""
    try:
        return os.get_terminal_size(stream.fileno()).columns
    except (AttributeError, OSError, ValueError):
        return None
