"""Slices of a workspace paving (:func:`kinbox.workspace.reach`) as matplotlib images."""

from __future__ import annotations

import numpy as np

#: colours of the verdicts outside, inside, boundary
COLOURS = ("#d9d9d9", "#2ca02c", "#ff7f0e")
AXES = "xyz"


def slice_levels(region: np.ndarray, axis: int, count: int) -> np.ndarray:
    """``count`` levels across the region along ``axis``, each in the middle of its share."""
    lo, hi = float(region[0][axis]), float(region[1][axis])
    return lo + (np.arange(count) + 0.5) * (hi - lo) / count


def _boxes(ax, lo, hi, verdict, u: int, v: int, cut=None) -> None:
    from matplotlib.collections import PatchCollection
    from matplotlib.patches import Rectangle

    for verdict_id, colour in enumerate(COLOURS):
        sel = verdict == verdict_id if cut is None else cut & (verdict == verdict_id)
        rects = [Rectangle((a[u], a[v]), b[u] - a[u], b[v] - a[v]) for a, b in zip(lo[sel], hi[sel])]
        ax.add_collection(PatchCollection(rects, facecolor=colour, edgecolor="none"))


def _finish(fig, path: str, title: str) -> None:
    """The verdicts' legend and the title, then the figure written to ``path`` and closed."""
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    fig.legend(handles=[Patch(color=c, label=n) for c, n in zip(COLOURS, ("outside", "inside", "boundary"))], loc="lower center", ncol=3)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout(rect=(0, 0.08, 1, 0.95))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_plane(lo: np.ndarray, hi: np.ndarray, verdict: np.ndarray, region: np.ndarray, path: str, title: str = "") -> None:
    """Draw a planar paving (boxes of x and y), coloured by verdict."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.2, 5.4))
    _boxes(ax, lo, hi, verdict, 0, 1)
    ax.set_xlim(region[0][0], region[1][0])
    ax.set_ylim(region[0][1], region[1][1])
    ax.set_aspect("equal")
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    _finish(fig, path, title)


def plot_slices(
    lo: np.ndarray, hi: np.ndarray, verdict: np.ndarray, region: np.ndarray, path: str, axis: str = "z", count: int = 4, title: str = ""
) -> np.ndarray:
    """Draw ``count`` slices of the paving across ``axis`` (``"x"``, ``"y"`` or ``"z"``), one panel
    each: every box the slice plane crosses, coloured by its verdict. Returns the levels."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    k = AXES.index(axis)
    u, v = [i for i in range(3) if i != k]
    levels = slice_levels(region, k, count)
    fig, axes = plt.subplots(1, count, figsize=(3.6 * count, 3.8), squeeze=False)
    for ax, level in zip(axes[0], levels):
        _boxes(ax, lo, hi, verdict, u, v, cut=(lo[:, k] <= level) & (hi[:, k] >= level))
        ax.set_xlim(region[0][u], region[1][u])
        ax.set_ylim(region[0][v], region[1][v])
        ax.set_aspect("equal")
        ax.set_title(f"{AXES[k]} = {level:.3f} m", fontsize=9)
        ax.set_xlabel(f"{AXES[u]} (m)")
        ax.set_ylabel(f"{AXES[v]} (m)")
    _finish(fig, path, title)
    return levels
