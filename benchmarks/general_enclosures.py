"""The cost of the general and planar formulations' rows as enclosures of the model as given:
the same problems solved with the core rows carrying ``merr``/``mgrad`` from the shadow build
(:mod:`kinbox.formulation.enclose_rows`, the default) and without them (the rows as rounded
taken as exact), interleaved in one process so that the ratio is measured on the same machine
state.

    python benchmarks/general_enclosures.py [--poses 6] [--repeat 3] [--json]

Problems: the general 6R loop (``kinbox.solve``, the benchmark suite's sigma), the planar
mechanisms four-bar, rhombus, 3-RPR, Watt six-bar and Double Butterfly (their default sigma),
the delta robot, Dietmeier's platform and the Griffis-Duffy platform (leg vectors, sigma 0.25)
through the general formulation (translation, free-flyer, distance legs), UR5 poses through
``formulation="general"`` (random ones and three near its elbow and wrist singularities), and
two of those poses of a UR5 on a free-flyer locked at a generic pose.
``--only WORD``: the problems whose label holds ``WORD`` (repeatable). The first search of a process loads the compiled kernels: one warm-up
run of every variant of every problem precedes the timed ones. Per problem: the median CPU seconds of each variant over
``--repeat`` interleaved runs (``time.process_time``; one warm-up run of each first), their
ratio, the boxes of each (the same unless an enclosure made a contractor weaker) and the
solutions (found and certified).
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np
import report


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses", type=int, default=6, help="random UR5 poses")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--only", action="append", default=[], help="only problems whose label holds this word")
    a = ap.parse_args(argv)

    import kinbox
    from kinbox.formulation import build, planar

    shadows = (build._core_errors, planar._core_errors)

    def off(*args):  # the rows as rounded, taken as exact
        return None

    def variant_on(on: bool) -> None:
        build._core_errors, planar._core_errors = shadows if on else (off, off)

    ik = kinbox.IK("ur5", "tool0", formulation="general")
    rng = np.random.default_rng(a.seed)
    qs = [list(q) for q in rng.uniform(-np.pi, np.pi, (a.poses, 6))]
    qs += [[0.3, -1.2, 1e-5, -0.8, 1.2, 0.4], [0.3, -1.2, 1e-6, -0.8, 1.2, 0.4], [0.3, -1.2, 1.5, -0.8, 1e-6, 0.4]]
    cases = [("general-6r", lambda: kinbox.solve("general-6r", sigma=1e-4, progress=False))]
    for name in ("four-bar", "rhombus", "3-rpr", "watt-six-bar", "double-butterfly"):
        cases.append((name, lambda name=name: kinbox.solve(name, progress=False)))
    for name in ("delta", "dietmeier"):
        cases.append((name, lambda name=name: kinbox.solve(name, progress=False)))
    cases.append(("griffis-duffy", lambda: kinbox.solve("griffis-duffy", legs="vector", sigma=0.25, progress=False)))
    for k, q in enumerate(qs):
        goal = ik.pose_at(q)
        label = f"ur5 general q={np.round(q, 6).tolist()}" if k >= a.poses else f"ur5 general random {k}"
        cases.append((label, lambda goal=goal: ik.solve(goal, closed_form=False, progress=False)))

    # a UR5 on a free-flyer locked at a generic pose (its fixed motion enclosed from the lock
    # values as given: constants._several)
    ff = _locked_free_flyer_ur5(kinbox)
    for k, q in enumerate(qs[:2]):
        goal = ff.pose_at(q)
        cases.append((f"ur5 on a locked free-flyer, general {k}", lambda goal=goal: ff.solve(goal, closed_form=False, progress=False)))

    if a.only:
        cases = [(label, run) for label, run in cases if any(w in label for w in a.only)]
    rows = []
    for label, run in cases:
        row = report.interleaved(label, run, variant_on, a.repeat)
        rows.append(row)
        print(json.dumps(row), file=sys.stderr)
    return report.interleaved_summary(rows, a.json, 60)


def _locked_free_flyer_ur5(kinbox):
    """``kinbox.IK`` of a UR5 loaded on a free-flyer root locked at a generic pose, through the
    general formulation."""
    import os

    import example_robot_data as erd

    rel = "ur_description/urdf/ur5_robot.urdf"
    robot = kinbox.load(os.path.join(erd.getModelPath(rel), rel), root_joint="freeflyer")
    quat = np.array([0.3, -0.2, 0.5, 0.1]) / np.linalg.norm([0.3, -0.2, 0.5, 0.1])
    return kinbox.IK(robot, "tool0", lock={"root_joint": np.r_[0.1, 0.2, 0.3, quat]}, formulation="general")


if __name__ == "__main__":
    main()
