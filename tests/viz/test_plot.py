"""Pictures with matplotlib: box projections (kinbox plot), the benchmark's runtime-versus-error
plot, the boxes in the result JSON, and progress lines on stderr during a solve."""

from __future__ import annotations

import json
import math
import os
import pty
import subprocess
import sys

import numpy as np
import pytest

import kinbox
from kinbox.answer.result import Result
from kinbox.cli import main
from kinbox.errors import InputError
from kinbox.viz import plot

TAB_BLUE = np.array([31, 119, 180])  # matplotlib tab10 colour 0: the first component


def _synthetic(n=80) -> dict:
    """A result dict with a curve (a helix in c[x], s[x], y) and two isolated solutions."""
    t = np.linspace(-math.pi, math.pi, n, endpoint=False)
    centres = np.stack([np.cos(t), np.sin(t), t / 10], axis=1)
    iso = np.array([[0.2, 0.3, 0.9], [-0.4, 0.1, -0.8]])
    w = 0.04
    lo = np.vstack([centres - w, iso - 1e-9]).tolist()
    hi = np.vstack([centres + w, iso + 1e-9]).tolist()
    return {
        "problem": "synthetic",
        "source": {"kind": "solve", "mechanism": "four-bar", "set": {}},
        "joint_names": ["x.cos", "x.sin", "y"],
        "complete": True,
        "message": "",
        "solutions": [{"q": list(q)} for q in iso],
        "components": [
            {"dimension": 1, "boxes": n, "certified": False, "samples": centres.tolist()},
            {"dimension": 0, "boxes": 1, "certified": True},
            {"dimension": 0, "boxes": 1, "certified": True},
        ],
        "stats": {},
        "boxes": {"variables": ["c[x]", "s[x]", "y"], "count": n + 2, "lo": lo, "hi": hi, "component": [0] * n + [1, 2]},
    }


def _pixels_near(png, rgb, tol=40) -> int:
    from PIL import Image

    a = np.asarray(Image.open(png).convert("RGB")).astype(int)
    return int((np.abs(a - rgb).max(axis=2) < tol).sum())


# -------------------------------------------------------------------------------------------
# boxes in the JSON
# -------------------------------------------------------------------------------------------
def test_result_json_carries_the_boxes():
    res = kinbox.solve("four-bar", set={"crank": 0.7})
    d = json.loads(res.to_json())
    b = d["boxes"]
    assert b["variables"] == list(res.raw.system.names)
    assert b["count"] == len(res.raw.boxes) == len(b["lo"]) == len(b["hi"]) == len(b["component"])
    for k, box in enumerate(res.raw.boxes):
        assert np.all(np.array(b["lo"][k]) <= box.lo) and np.all(np.array(b["hi"][k]) >= box.hi)  # outward
        assert np.allclose(b["lo"][k], box.lo, atol=1e-5) and np.allclose(b["hi"][k], box.hi, atol=1e-5)
        assert k in res.components[b["component"][k]].boxes


def test_boxes_are_left_out_of_big_results(monkeypatch, tmp_path):
    res = kinbox.solve("four-bar", set={"crank": 0.7})
    monkeypatch.setattr(Result, "MAX_JSON_BOXES", 1)
    d = res.to_dict()
    assert "lo" not in d["boxes"] and "more than 1" in d["boxes"]["omitted"] and d["boxes"]["count"] == 2
    with pytest.raises(InputError, match="no boxes.*more than 1"):
        plot.plot_boxes(d, "c[coupler],s[coupler]", tmp_path / "x.png")
    assert plot.plot_boxes(d, "coupler,rocker", tmp_path / "j.png").stat().st_size > 0  # joints still work


# -------------------------------------------------------------------------------------------
# box plots
# -------------------------------------------------------------------------------------------
@pytest.mark.parametrize("names", ["c[x],s[x]", "c[x],s[x],y"])
def test_box_projection_draws_the_components(tmp_path, names):
    out = plot.plot_boxes(_synthetic(), names, tmp_path / "boxes.png")
    assert out.stat().st_size > 10_000
    assert _pixels_near(out, TAB_BLUE) > 2000  # the curve's boxes, in the first component colour
    assert _pixels_near(out, np.array([13, 13, 13]), tol=20) > 30  # the isolated solutions (black)


def test_blank_plot_would_fail_the_colour_check(tmp_path):
    d = _synthetic()
    d["boxes"]["lo"] = d["boxes"]["lo"][-2:]
    d["boxes"]["hi"] = d["boxes"]["hi"][-2:]
    d["boxes"]["component"] = [1, 2]
    out = plot.plot_boxes(d, "c[x],s[x]", tmp_path / "iso.png")
    assert _pixels_near(out, TAB_BLUE) < 200  # only the legend could be blue


def test_joint_axes_from_json_and_from_a_result(tmp_path):
    out = plot.plot_boxes(_synthetic(), ["x", "y"], tmp_path / "joints.png")
    assert _pixels_near(out, TAB_BLUE) > 300
    res = kinbox.solve("four-bar", set={"crank": 0.7})
    assert plot.plot_boxes(res, "coupler,rocker", tmp_path / "r.png").stat().st_size > 0
    # a system variable against a joint: only from a Result (boxes decoded to q)
    assert plot.plot_boxes(res, "c[coupler],rocker", tmp_path / "mixed.png").stat().st_size > 0
    with pytest.raises(InputError, match="mixing"):
        plot.plot_boxes(json.loads(res.to_json()), "c[coupler],rocker", tmp_path / "m.png")


def test_a_curve_is_drawn_as_a_line_in_order_along_it(tmp_path):
    d = _synthetic(80)
    samples = d["components"][0]["samples"]
    sparse = samples[::7]  # evenly spread along the helix, then shuffled
    d["components"][0]["samples"] = [sparse[i] for i in np.random.default_rng(2).permutation(len(sparse))]
    data = plot._Data(d)
    ((g, line),) = data.curves
    x = [math.atan2(q[1], q[0]) for q in line]
    assert g == 0 and len(line) == 12
    assert sum(abs(math.remainder(b - a, 2 * math.pi)) for a, b in zip(x, x[1:])) < 2.3 * math.pi  # one lap
    P = plot._broken_at_jumps(np.array([[xi, 0.0] for xi in x]), [True, False])
    assert np.isnan(P).any() and not np.isnan(P).all()  # broken where the angle jumps from pi to -pi
    t = np.linspace(0, 1, 50)
    P = plot._broken_at_jumps(np.stack([t, np.where(t < 0.5, t, t - 0.9)], axis=1), [False, False])
    assert np.isnan(P[:, 0]).sum() == 1  # a jump of a joint that is not continuous: a break too
    with_line = _pixels_near(plot.plot_boxes(d, ["x", "y"], tmp_path / "line.png"), TAB_BLUE)
    d["components"][0]["polyline"] = d["components"][0]["samples"][:1]  # a polyline wins: one point
    dots_only = _pixels_near(plot.plot_boxes(d, ["x", "y"], tmp_path / "dots.png"), TAB_BLUE)
    assert with_line > 2 * dots_only, (with_line, dots_only)


def test_plot_input_errors(tmp_path):
    with pytest.raises(InputError, match="two or three"):
        plot.parse_vars("a")
    with pytest.raises(InputError, match="two or three"):
        plot.parse_vars("a,b,c,d")
    with pytest.raises(InputError, match="differ"):
        plot.parse_vars("a,a")
    assert plot.parse_vars(" d[platform][0] , y ") == ["d[platform][0]", "y"]
    with pytest.raises(InputError, match=r"unknown variable or joint 'q'.*c\[x\].*joints: x, y"):
        plot.plot_boxes(_synthetic(), "q,y", tmp_path / "x.png")


def test_cli_plot(tmp_path, capsys):
    src = tmp_path / "r.json"
    src.write_text(json.dumps(_synthetic()))
    out = tmp_path / "o.png"
    assert main(["plot", str(src), "--vars", "c[x],s[x],y", "-o", str(out)]) == 0
    assert out.stat().st_size > 10_000
    assert main(["plot", str(src), "--vars", "c[x]", "-o", str(out)]) == 2
    assert "kinbox: error: --vars takes two or three" in capsys.readouterr().err
    assert main(["plot", str(tmp_path / "none.json"), "--vars", "a,b", "-o", str(out)]) == 2
    assert "kinbox: error: cannot read result file" in capsys.readouterr().err


# -------------------------------------------------------------------------------------------
# benchmark picture
# -------------------------------------------------------------------------------------------
def test_runtime_vs_error(tmp_path):
    rows = [
        {"problem": p, "sigma": s, "cpu_seconds": t, "max_residual": e}
        for p, k in (("general-6r", 1.0), ("ur5 ik", 3.0))
        for s, t, e in ((1e-2, 0.5 * k, 1e-9), (1e-4, 1.0 * k, 1e-13), (1e-6, 2.5 * k, 0.0))
    ]
    rows.append({"problem": "broken", "sigma": 1e-3, "cpu_seconds": float("nan"), "max_residual": 1e-3})
    out = plot.plot_runtime_vs_error(rows, tmp_path / "bench.png")
    assert out.stat().st_size > 10_000
    assert _pixels_near(out, TAB_BLUE) > 50
    assert plot.plot_runtime_vs_error([], tmp_path / "empty.png").stat().st_size > 0
    with pytest.raises(InputError, match="problem, sigma, cpu_seconds, max_residual"):
        plot.plot_runtime_vs_error([{"problem": "x"}], tmp_path / "bad.png")


# -------------------------------------------------------------------------------------------
# progress on stderr (the solver prints it; the CLI switches it)
# -------------------------------------------------------------------------------------------
CMD = [sys.executable, "-m", "kinbox.cli", "solve", "four-bar", "--set", "crank=0.7"]
PROGRESS = "kinbox: "  # "kinbox: N boxes, P pending, S solutions (C certified), volume left V, R boxes/s"


def _progress_lines(text: str) -> list[str]:
    return [ln for ln in text.splitlines() if ln.startswith(PROGRESS) and "volume left" in ln and "boxes/s" in ln]


def test_progress_off_when_stderr_is_not_a_terminal():
    p = subprocess.run(CMD, capture_output=True, text=True, timeout=120)
    assert p.returncode == 0 and not _progress_lines(p.stderr)
    p = subprocess.run(CMD + ["--progress"], capture_output=True, text=True, timeout=120)
    lines = _progress_lines(p.stderr)
    assert p.returncode == 0 and lines
    assert "2 solutions" in lines[-1] and "volume left 0.000e+00" in lines[-1]
    p = subprocess.run(CMD + ["--progress", "--quiet"], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0 and not _progress_lines(p.stderr)


def _run_with_tty_stderr(args) -> str:
    master, slave = pty.openpty()
    try:
        proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=slave, stdin=subprocess.DEVNULL)
        os.close(slave)
        chunks = []
        while True:
            try:
                data = os.read(master, 4096)
            except OSError:  # EIO: the child closed the terminal
                break
            if not data:
                break
            chunks.append(data)
        proc.wait(timeout=120)
    finally:
        os.close(master)
    return b"".join(chunks).decode("utf-8", "replace").replace("\r\n", "\n")


@pytest.mark.slow
def test_progress_on_a_terminal_unless_quiet():
    assert _progress_lines(_run_with_tty_stderr(CMD))
    assert not _progress_lines(_run_with_tty_stderr(CMD + ["--quiet"]))
