"""The cost of the planar formulation's rows as enclosures of the model as given: the planar
examples and a planar arm's IK (its goal a weld closure, whose angle the shadow build encloses:
``enclose_rows.PlanarConstants.weld``) solved with the core rows carrying ``merr``/``mgrad``
from the shadow build (the default) and without them (the rows as rounded taken as exact),
interleaved in one process so that the ratio is measured on the same machine state.

    python benchmarks/planar_enclosures.py [--poses 4] [--repeat 3] [--json] [--only WORD ...]

Problems: four-bar, rhombus, Watt six-bar, Watt-Baranov, 3-RPR and Double Butterfly (their
default sigma), ``--poses`` random poses of a planar 3R arm whose tip is off its last axis,
and two joints and two bars in a plane whose axis is no coordinate axis (``tilted plane``).
``--only WORD``: the problems whose label holds ``WORD`` (repeatable). One warm-up run of
every variant of every problem precedes the timed ones. Per problem: the median CPU seconds of
each variant over ``--repeat`` interleaved runs (``time.process_time``), their ratio, the boxes
of each and the solutions (found and certified); for the examples, the CPU seconds of the
shadow build with its frame caches empty (a first solve in a fresh process: the timed runs
find the frames enclosed already).
"""

from __future__ import annotations

import argparse
import json
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


def tilted_plane():
    """Two revolute joints in a chain about the axis (0.3, -0.5, 0.8) normalized in binary64
    (``JointModelRevoluteUnaligned``, frames not turned), each link closed to the ground by a
    bar whose length is read off a configuration: isolated assemblies in a tilted plane."""
    import pinocchio as pin

    from kinbox.model.mechanism import Closure, Mechanism

    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    model = pin.Model()
    lo, hi = np.full(1, -4.0), np.full(1, 4.0)
    j1 = model.addJoint(
        0, pin.JointModelRevoluteUnaligned(axis), pin.SE3(np.eye(3), np.array([0.1, 0.2, -0.1])), "j1", np.ones(1), np.ones(1), lo, hi
    )
    j2 = model.addJoint(
        j1, pin.JointModelRevoluteUnaligned(axis), pin.SE3(np.eye(3), np.array([0.9, 0.3, 0.4])), "j2", np.ones(1), np.ones(1), lo, hi
    )
    data = model.createData()
    pin.forwardKinematics(model, data, np.array([0.4, -1.1]))
    mech = Mechanism(model, name="tilted-plane")
    ends = ((j2, [1.1, -0.4, 0.7], [0.3, -0.2, 0.1]), (j1, [-0.8, 0.9, 0.2], [0.2, 0.4, -0.3]))
    for i, (jid, p, q) in enumerate(ends):
        P, Q = pin.SE3(np.eye(3), np.array(p)), pin.SE3(np.eye(3), np.array(q))
        length = float(np.linalg.norm((data.oMi[jid] * Q).translation - P.translation))
        mech.closures.append(Closure("distance", 0, P, jid, Q, length=length, name=f"bar{i + 1}"))
    return mech


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses", type=int, default=4, help="random poses of the planar arm")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--only", action="append", default=[], help="only problems whose label holds this word")
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
    tilted = tilted_plane()
    cases.append(("tilted plane", lambda: kinbox.solve(tilted, progress=False)))
    if a.only:
        cases = [(label, run) for label, run in cases if any(w in label for w in a.only)]

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
        if not label.startswith(("planar 3R arm", "tilted")):
            row["shadow_build_cold_s"] = round(cold(label), 4)
        rows.append(row)
        print(json.dumps(row), file=sys.stderr)
    return report.interleaved_summary(rows, a.json, 40)


if __name__ == "__main__":
    main()
