"""Pictures of results with matplotlib (Agg backend: files only, no window).

* :func:`plot_boxes` (``kinbox plot RESULT.json --vars A,B[,C] -o out.png``): the solution
  boxes projected onto two or three axes, one colour per connected component, in the manner of
  Porta, Ros and Thomas (2009), Figs. 7-10. An axis is a **system variable** (as named in the
  result's ``boxes.variables``, e.g. ``c[rocker]``, ``d[platform][0]``) or a **joint** (its angle
  for revolute joints, its value for prismatic ones, ``platform[0]`` for one ``q`` entry of a
  multi-dof joint; as in the result's ``joint_names``). With system variables only, the boxes
  themselves are drawn (rectangles, or cuboids in 3-D); as soon as one axis is a joint, each box
  is drawn as one point: from a :class:`~kinbox.result.Result`, every box's polished point
  decoded to ``q``; from a JSON file, the isolated solutions and the components' samples.
  Isolated solutions also get a black marker, so that boxes narrower than a pixel show. On
  joint axes a curve component is also drawn as a line through its configurations in order
  along it (its ``polyline``, else its samples chained by nearest neighbours), broken where an
  angle wraps around.
* :func:`plot_runtime_vs_error`: the benchmark's runtime-versus-error picture.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from .motion import order_along_curve, result_dict


def _mpl():
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


# ======================================================================================
# Data from a Result or a result dict
# ======================================================================================
def _joint_columns(q_names: list[str]) -> dict[str, object]:
    """Joint label -> index into q, or (cos index, sin index) for a continuous joint."""
    out: dict[str, object] = {}
    for i, n in enumerate(q_names):
        if n.endswith(".cos") and i + 1 < len(q_names) and q_names[i + 1] == n[:-4] + ".sin":
            out[n[:-4]] = (i, i + 1)
        elif n.endswith(".sin") and i > 0 and q_names[i - 1] == n[:-4] + ".cos":
            continue
        else:
            out[n] = i
    return out


def _joint_value(col, q: np.ndarray) -> float:
    if isinstance(col, tuple):
        return float(math.atan2(q[col[1]], q[col[0]]))
    return float(q[col])


class _Data:
    """Boxes (system variables), points (q) and their components, from a Result or a dict."""

    def __init__(self, result: Any) -> None:
        if isinstance(result, dict):
            d = result
            self.result = None
        else:
            d = result.to_dict()
            self.result = result
        self.title = str(d.get("problem", "result"))
        self.q_names = list(d.get("joint_names") or [])
        comps = d.get("components") or []
        self.dims = [int(c.get("dimension", 0)) for c in comps]
        b = d.get("boxes") or {}
        self.variables = list(b.get("variables") or [])
        self.omitted = b.get("omitted") if "lo" not in b else None
        self.lo: np.ndarray | None = None
        self.hi: np.ndarray | None = None
        if "lo" in b:
            self.lo = np.array(b["lo"], dtype=float).reshape(-1, len(self.variables))
            self.hi = np.array(b["hi"], dtype=float).reshape(-1, len(self.variables))
            self.box_comp = np.array(b.get("component") or [-1] * len(self.lo), dtype=int)
        else:
            self.box_comp = np.zeros(0, dtype=int)
        # points in q with their component (-1: an isolated solution not matched to one)
        # points in q (and, from a Result, in the system's variables) with their group
        self.qs: list[np.ndarray] = []
        self.xs: list[np.ndarray] | None = None
        self.q_group: list[int] = []
        if self.result is not None and self.result.formulated is not None and self.result.raw is not None:
            comp_of = {}
            for ci, c in enumerate(self.result.components):
                for k in c.boxes:
                    comp_of[k] = ci
            dec = self.result.formulated.decode
            self.xs = []
            for k, bx in enumerate(self.result.raw.boxes):
                self.qs.append(np.asarray(dec(bx.x), dtype=float))
                self.xs.append(np.asarray(bx.x, dtype=float))
                self.q_group.append(self.group(comp_of.get(k, -1)))
        else:
            for s in d.get("solutions") or []:
                self.qs.append(np.asarray(s["q"], dtype=float))
                self.q_group.append(-1)
            for ci, c in enumerate(comps):
                for q in c.get("samples") or []:
                    self.qs.append(np.asarray(q, dtype=float))
                    self.q_group.append(self.group(ci))
        self.box_group = np.array([self.group(int(c)) for c in self.box_comp], dtype=int)
        self.joints = _joint_columns(self.q_names)
        # each curve component's configurations in order along it, drawn as a line
        self.curves: list[tuple[int, list[np.ndarray]]] = []
        curve_dicts = result_dict(result)["components"] if self.result is not None else comps
        for ci, c in enumerate(curve_dicts):
            if self.group(ci) < 0:
                continue
            line = c.get("polyline")
            if line:
                self.curves.append((ci, [np.asarray(q, dtype=float) for q in line]))
            elif c.get("samples"):
                qs = [np.asarray(q, dtype=float) for q in c["samples"]]
                self.curves.append((ci, [qs[i] for i in order_along_curve(qs)]))

    def group(self, ci: int) -> int:
        """-1 for isolated solutions (components of dimension 0), else the component index."""
        return ci if 0 <= ci < len(self.dims) and self.dims[ci] >= 1 else -1

    def group_label(self, g: int, count: int, noun: str = "box") -> str:
        if g < 0:
            return f"isolated solutions ({count})"
        n = [i for i, d in enumerate(self.dims) if d >= 1].index(g) + 1
        plural = noun + ("es" if noun.endswith("x") else "s") if count != 1 else noun
        return f"component {n}: dimension {self.dims[g]}, {count} {plural}"

    def group_color(self, g: int):
        if g < 0:
            return (0.05, 0.05, 0.05, 1.0)
        curves = [i for i, d in enumerate(self.dims) if d >= 1]
        return _colors(len(curves))[curves.index(g)]

    def resolve(self, names: list[str]) -> list[tuple[str, Any]]:
        """[(kind, key)]: ("var", index into variables) or ("joint", q column)."""
        # a name that is both (a prismatic joint kept as a variable) follows the others
        all_vars = all(n in self.variables for n in names)
        out: list[tuple[str, Any]] = []
        for n in names:
            if n in self.variables and (all_vars or n not in self.joints):
                out.append(("var", self.variables.index(n)))
            elif n in self.joints:
                out.append(("joint", self.joints[n]))
            else:
                vs = ", ".join(self.variables[:30]) + (", ..." if len(self.variables) > 30 else "")
                js = ", ".join(self.joints)
                raise InputError(
                    f"unknown variable or joint {n!r}; system variables: {vs or '(none in this file)'}; joints: {js or '(none)'}"
                )
        return out


def parse_vars(text: str) -> list[str]:
    """``"A,B[,C]"`` -> ["A", "B"(, "C")]; names may contain brackets (``d[platform][0]``)."""
    names = [t.strip() for t in str(text).split(",") if t.strip()]
    if len(names) not in (2, 3):
        raise InputError(f"--vars takes two or three comma-separated names, got {len(names)}: {text!r}")
    if len(set(names)) != len(names):
        raise InputError(f"--vars names must differ: {text!r}")
    return names


def _colors(n: int):
    plt = _mpl()
    cmap = plt.get_cmap("tab10" if n <= 10 else "tab20")
    return [cmap(i % cmap.N) for i in range(max(n, 1))]


# ======================================================================================
# Box plots
# ======================================================================================
def plot_boxes(result: Any, variables: str | Sequence[str], path: str | Path, title: str | None = None, dpi: int = 150) -> Path:
    """Projection of the solution boxes of ``result`` onto 2 or 3 ``variables``; see the
    module docstring. ``result``: a Result, a result dict, or a JSON file path."""
    if isinstance(result, (str, Path)):
        from ..answer.resultfile import load_result

        result = load_result(result)
    names = parse_vars(variables) if isinstance(variables, str) else list(variables)
    if len(names) not in (2, 3):
        raise InputError(f"plot takes two or three variables, got {len(names)}")
    data = _Data(result)
    axes = data.resolve(names)
    boxes_mode = all(k == "var" for k, _ in axes)
    if boxes_mode and data.lo is None:
        raise InputError(
            "this result has no boxes (" + (data.omitted or "not in the file") + "); "
            "plot joints instead (" + ", ".join(list(data.joints)[:8]) + ")"
        )
    if not boxes_mode and any(k == "var" for k, _ in axes) and data.xs is None:
        raise InputError(
            "mixing system variables and joints needs the solver's boxes: plot from "
            "Python (kinbox.viz.plot.plot_boxes(result, ...)), or use only variables or only joints"
        )
    plt = _mpl()
    three = len(names) == 3
    fig = plt.figure(figsize=(6.4, 5.2))
    ax = fig.add_subplot(111, projection="3d") if three else fig.add_subplot(111)
    handles = []
    if boxes_mode and data.lo is not None and data.hi is not None:  # (no boxes: refused above)
        idx = [k for _, k in axes]
        lo, hi = data.lo[:, idx], data.hi[:, idx]
        for g in sorted(set(data.box_group.tolist()), key=lambda g: (g < 0, g)):
            sel = np.flatnonzero(data.box_group == g)
            col = data.group_color(g)
            if three:
                _cuboids(ax, lo[sel], hi[sel], col)
            else:
                _rectangles(ax, lo[sel], hi[sel], col)
            centres = 0.5 * (lo[sel] + hi[sel])
            iso = g < 0
            h = ax.scatter(
                *centres.T,
                s=22 if iso else 2,
                color=col,
                marker="o" if iso else ".",
                edgecolors="w" if iso else "none",
                linewidths=0.5,
                label=data.group_label(g, len(sel)),
                zorder=3,
            )
            handles.append(h)
        _limits(ax, lo, hi, three)
    else:
        if not data.qs:
            raise InputError("this result has no configurations to plot")
        xs = data.xs or []  # system points: there whenever an axis is a variable (checked above)
        P = np.array(
            [[_joint_value(key, q) if kind == "joint" else float(xs[i][key]) for kind, key in axes] for i, q in enumerate(data.qs)]
        )
        grp = np.array(data.q_group)
        if all(kind == "joint" for kind, _ in axes):
            for g, line in data.curves:
                L = _broken_at_jumps(
                    np.array([[_joint_value(key, q) for _, key in axes] for q in line]), [isinstance(key, tuple) for _, key in axes]
                )
                ax.plot(*L.T, "-", color=data.group_color(g), lw=1.2, zorder=2)
        for g in sorted(set(grp.tolist()), key=lambda g: (g < 0, g)):
            sel = grp == g
            iso = g < 0
            h = ax.scatter(
                *P[sel].T,
                s=24 if iso else 5,
                color=data.group_color(g),
                edgecolors="w" if iso else "none",
                linewidths=0.5,
                label=data.group_label(g, int(sel.sum()), "box" if data.xs is not None else "point"),
                zorder=3,
            )
            handles.append(h)
    ax.set_xlabel(names[0])
    ax.set_ylabel(names[1])
    if three:
        ax.set_zlabel(names[2])
    ax.set_title(title or data.title, fontsize=10)
    if handles and len(handles) <= 12:
        from matplotlib.patches import Patch

        proxies = [Patch(facecolor=h.get_facecolor()[0], edgecolor="k", lw=0.4, label=h.get_label()) for h in handles]
        ax.legend(handles=proxies, fontsize=7, loc="best")
    elif handles:
        ax.text2D(0.01, 0.99, f"{len(handles)} components", transform=ax.transAxes, va="top") if three else ax.text(
            0.01, 0.99, f"{len(handles)} components", transform=ax.transAxes, va="top"
        )
    if not three:
        ax.grid(True, lw=0.3, alpha=0.5)
    return _save(fig, path, dpi)


def _broken_at_jumps(P: np.ndarray, angle: list[bool]) -> np.ndarray:
    """The points ``P`` of a line with a NaN row wherever it jumps, so that no segment is drawn
    across the plot: where a continuous joint's angle wraps around (a step of more than pi), or
    where a step covers more than a quarter of an axis' range (an angle wrapping at its
    limits, or samples chained out of order)."""
    if len(P) < 3:
        return P
    dP = np.diff(P, axis=0)
    span = np.ptp(P, axis=0)
    step = np.linalg.norm(dP / np.where(span > 0, span, 1.0), axis=1)
    jump = step > 0.25
    if any(angle):
        jump |= np.any(np.abs(dP[:, angle]) > math.pi, axis=1)
    out = []
    for k in range(len(P)):
        if k > 0 and jump[k - 1]:
            out.append(np.full(P.shape[1], np.nan))
        out.append(P[k])
    return np.array(out)


def _save(fig, path, dpi: int) -> Path:
    """Write ``fig`` to ``path`` (a clear InputError if it cannot be written) and close it."""
    import io

    import matplotlib.pyplot as plt

    fig.tight_layout()
    out = Path(path)
    buf = io.BytesIO()  # drawn first, then written here, where every write error is seen
    try:  # (matplotlib lost the error of a full disk: tests/cli/test_hostile.py::test_output_errors)
        fig.savefig(buf, dpi=dpi, format=out.suffix[1:].lower() or "png")
        with open(out, "wb") as f:
            f.write(buf.getvalue())
    except (OSError, ValueError) as e:
        raise InputError(f"cannot write {str(path)!r}: {getattr(e, 'strerror', None) or e}") from None
    finally:
        plt.close(fig)
    return out


def _rectangles(ax, lo: np.ndarray, hi: np.ndarray, color) -> None:
    from matplotlib.collections import PolyCollection

    verts = [[(a[0], a[1]), (b[0], a[1]), (b[0], b[1]), (a[0], b[1])] for a, b in zip(lo, hi)]
    fc = (*color[:3], 0.35)
    ax.add_collection(PolyCollection(verts, facecolors=fc, edgecolors=color[:3], linewidths=0.4))


def _cuboids(ax, lo: np.ndarray, hi: np.ndarray, color, max_boxes: int = 4000) -> None:
    if len(lo) > max_boxes:  # too many faces for mplot3d: the centres are drawn anyway
        return
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    faces = []
    for a, b in zip(lo, hi):
        x0, y0, z0 = a
        x1, y1, z1 = b
        c = [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0), (x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)]
        for f in ((0, 1, 2, 3), (4, 5, 6, 7), (0, 1, 5, 4), (2, 3, 7, 6), (1, 2, 6, 5), (0, 3, 7, 4)):
            faces.append([c[i] for i in f])
    ax.add_collection3d(Poly3DCollection(faces, facecolors=(*color[:3], 0.25), edgecolors=(*color[:3], 0.6), linewidths=0.2))


def _limits(ax, lo: np.ndarray, hi: np.ndarray, three: bool) -> None:
    if len(lo) == 0:
        return
    a, b = lo.min(axis=0), hi.max(axis=0)
    pad = 0.05 * np.maximum(b - a, 1e-9)
    ax.set_xlim(a[0] - pad[0], b[0] + pad[0])
    ax.set_ylim(a[1] - pad[1], b[1] + pad[1])
    if three:
        ax.set_zlim(a[2] - pad[2], b[2] + pad[2])


# ======================================================================================
# Benchmark picture
# ======================================================================================
def plot_runtime_vs_error(rows: Iterable[dict], path: str | Path, title: str = "kinbox: runtime versus error", dpi: int = 150) -> Path:
    """Runtime (CPU seconds) against the largest residual, one series per problem.

    ``rows``: dicts with ``problem``, ``sigma``, ``cpu_seconds``, ``max_residual`` (a row with
    a missing or non-finite runtime is skipped; a residual of 0 is drawn at 1e-17, the bottom
    of the log axis). Points of one problem are joined in order of ``sigma`` and labelled
    with it. Returns the path written.
    """
    plt = _mpl()
    series: dict[str, list[tuple[float, float, float]]] = {}
    zero = False
    for r in rows:
        try:
            prob = str(r["problem"])
            t = float(r["cpu_seconds"])
            e = float(r["max_residual"])
            s = float(r.get("sigma", float("nan")))
        except (KeyError, TypeError, ValueError):
            raise InputError(f"each row needs problem, sigma, cpu_seconds, max_residual; got {r!r}") from None
        if not (math.isfinite(t) and t >= 0) or math.isnan(e):
            continue
        zero = zero or e <= 1e-17
        series.setdefault(prob, []).append((s, max(e, 1e-17), max(t, 1e-4)))
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    colors = _colors(len(series))
    markers = "osD^v<>ph*"
    for k, (prob, pts) in enumerate(sorted(series.items())):
        pts.sort(key=lambda p: (math.isnan(p[0]), -p[0] if not math.isnan(p[0]) else 0))
        errors = [p[1] for p in pts]
        times = [p[2] for p in pts]
        ax.plot(errors, times, "-", color=colors[k], lw=1, alpha=0.7)
        ax.scatter(errors, times, color=colors[k], marker=markers[k % len(markers)], s=30, label=prob, zorder=3)
        for s, ee, tt in pts:
            if math.isfinite(s):
                ax.annotate(f"σ={s:g}", (ee, tt), textcoords="offset points", xytext=(4, 3), fontsize=6, color=colors[k])
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("largest residual of a solution (m or rad)" + ("; 0 drawn at 1e-17" if zero else ""))
    ax.set_ylabel("CPU time (s)")
    ax.set_title(title, fontsize=10)
    ax.grid(True, which="both", lw=0.3, alpha=0.5)
    if series:
        ax.legend(fontsize=7, loc="best")
    else:
        ax.text(0.5, 0.5, "no rows", transform=ax.transAxes, ha="center")
    return _save(fig, path, dpi)
