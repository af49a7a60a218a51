"""Make the README pictures in docs/img/.

* ``replay_ur5.png``: headless-Chromium screenshot of ``kinbox replay --html`` for all IK
  solutions of a UR5 (``kinbox.ik`` -> ``Result.to_html`` -> ``kinbox.viz.replay.screenshot``);
* ``boxes_four_bar.png``: ``kinbox plot`` of the four-bar's configuration curve, its solution
  boxes projected onto three system variables (the two circuits in two colours).

Usage: ``python scripts/make_pictures.py [--out docs/img]``. Needs Chromium (Debian package
``chromium``). Takes about a minute (two solves).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import kinbox
from kinbox.viz import plot, replay

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "docs" / "img"), help="folder for the PNG files")
    a = ap.parse_args(argv)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)

    t = time.perf_counter()
    ik = kinbox.IK("ur5", "tool0")
    res = ik.solve(ik.pose_at([0.3, -1.2, 1.5, -0.8, 1.2, 0.4]), progress=False)
    print(f"ur5 ik: {len(res.solutions)} solutions in {time.perf_counter() - t:.1f} s", file=sys.stderr)
    with tempfile.TemporaryDirectory() as tmp:
        page = kinbox.to_html(res, Path(tmp) / "ur5.html", delay=2.0)
        png = replay.screenshot(page, out / "replay_ur5.png", size=(900, 600), budget_ms=800)
    print(f"wrote {png}", file=sys.stderr)

    t = time.perf_counter()
    curve = kinbox.solve("four-bar", progress=False)
    print(f"four-bar: {len(curve.raw.boxes)} boxes in {time.perf_counter() - t:.1f} s", file=sys.stderr)
    png = plot.plot_boxes(
        curve,
        ["c[coupler]", "s[coupler]", "c[rocker]"],
        out / "boxes_four_bar.png",
        title="four-bar: solution boxes of the configuration curve",
    )
    print(f"wrote {png}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
