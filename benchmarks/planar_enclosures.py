"""The cost of the planar formulation's rows as enclosures of the model as given: the planar
examples and a planar arm's IK (its goal a weld closure, whose angle the shadow build encloses:
``enclose_rows.PlanarConstants.weld``) solved with the core rows carrying ``merr``/``mgrad``
from the shadow build (the default) and without them (the rows as rounded taken as exact),
interleaved in one process so that the ratio is measured on the same machine state.

    python benchmarks/planar_enclosures.py [--poses 4] [--repeat 3] [--json]

Problems: four-bar, rhombus, Watt six-bar, Watt-Baranov, 3-RPR and Double Butterfly (their
default sigma), and ``--poses`` random poses of a planar 3R arm whose tip is off its last
axis. One warm-up run of every variant of every problem precedes the timed ones. Per problem:
the median CPU seconds of each variant over ``--repeat`` interleaved runs
(``time.process_time``), their ratio, the boxes of each and the solutions (found and certified);
for the examples, the CPU seconds of the shadow build with its frame caches empty (a first
solve in a fresh process: the timed runs find the frames enclosed already).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time

import numpy as np
import report


def planar_arm():
    """A planar 3R arm (DH twists 0) with a tip 0.6, 0.25 off its last joint, turned by 0.7 rad."""
    import pinocchio as pin

    import kinbox

    mech = kinbox.load({"kind": "dh-arm", "dh": [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.8, 0.0, 0.0]]})
    model = mech.model
    tool = model.getFrameId("tool")
    tip = pin.SE3(pin.exp3(np.array([0.0, 0.0, 0.7])), np.array([0.6, 0.25, 0.0]))
    model.addFrame(pin.Frame("tip", model.frames[tool].parentJoint, tool, tip, pin.FrameType.OP_FRAME))
    return mech


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses", type=int, default=4, help="random poses of the planar arm")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args(argv)

    import kinbox
    from kinbox.formulation import planar

    shadow = planar._core_errors

    def off(*args):  # the rows as rounded, taken as exact
        return None

    def variant_on(on: bool) -> None:
        planar._core_errors = shadow if on else off

    cases = []
    for name in ("four-bar", "rhombus", "watt-six-bar", "watt-baranov", "3-rpr", "double-butterfly"):
        cases.append((name, lambda name=name: kinbox.solve(name, progress=False)))
    ik = kinbox.IK(planar_arm(), "tip")
    rng = np.random.default_rng(a.seed)
    for k, q in enumerate(rng.uniform(-np.pi, np.pi, (a.poses, 3))):
        goal = ik.pose_at(q)
        cases.append((f"planar 3R arm, weld goal {k}", lambda goal=goal: ik.solve(goal, progress=False)))

    from kinbox.formulation import enclose_rows

    def cold(name: str) -> float:
        """CPU seconds of the shadow build of a fresh process (its frame caches empty): the
        planar formulation with it less without."""
        mech = kinbox.load(name)
        for cache in (enclose_rows._FRAMES, enclose_rows._GIVEN_FRAMES, enclose_rows._PLANAR):
            cache.clear()
        c0 = time.process_time()
        planar.formulate_planar(mech)
        c1 = time.process_time()
        variant_on(False)
        planar.formulate_planar(mech)
        c2 = time.process_time()
        variant_on(True)
        return (c1 - c0) - (c2 - c1)

    rows = []
    for label, run in cases:
        row = report.interleaved(label, run, variant_on, a.repeat)
        if not label.startswith("planar 3R arm"):
            row["shadow_build_cold_s"] = round(cold(label), 4)
        rows.append(row)
        print(json.dumps(row), file=sys.stderr)
    ratios = [r["ratio"] for r in rows]
    summary = {"rows": rows, "median_ratio": statistics.median(ratios), "mean_ratio": round(statistics.fmean(ratios), 3)}
    if a.json:
        print(json.dumps(summary, indent=1))
    else:
        for r in rows:
            print(
                f"{r['problem']:<40} {r['cpu_enclosed_s']:8.3f} {r['cpu_rounded_s']:8.3f} {r['ratio']:6.3f} "
                f"boxes {r['boxes_enclosed']}/{r['boxes_rounded']} sols {r['solutions']} cert {r['certified']}"
            )
        print(f"median ratio {summary['median_ratio']:.3f}, mean {summary['mean_ratio']:.3f}")
    return summary


if __name__ == "__main__":
    main()
