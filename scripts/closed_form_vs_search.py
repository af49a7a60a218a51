"""Closed form against the branch and prune, pose by pose: the same configurations?

    python scripts/closed_form_vs_search.py --poses 100        # each arm of tests/support/arms.py

Random configurations within the limits of each arm of a closed-form family (a UR5, an IRB 120
and a KR 6-like DH arm, a Panda with ``panda_joint7`` locked); each pose is solved by
``IK.solve`` (closed form where it decides) and by ``IK.solve(closed_form=False)``, and the two
answers are compared as sets (angles modulo 2 pi, 1e-6). One line per arm on stdout (JSON).
Needs the repository root on ``sys.path`` (run from the root).
"""

from __future__ import annotations

import argparse
import json
import sys

from tests.support.arms import ARMS, _ik, _poses, _same_sets


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--poses", type=int, default=100)
    ap.add_argument("--seed", type=int, default=2024)
    a = ap.parse_args(argv)
    bad = 0
    for robot, frame, lock, family in ARMS:
        ik = _ik(robot, frame, lock)
        rec = {"arm": robot, "family": family, "poses": 0, "closed_form": 0, "same": 0, "roots": 0, "incomplete": 0}
        for k, pose in enumerate(_poses(ik, a.poses, a.seed)):
            fast = ik.solve(pose)
            slow = ik.solve(pose, closed_form=False)
            rec["poses"] += 1
            rec["closed_form"] += fast.stats["method"] == "closed-form"
            rec["same"] += _same_sets(ik, fast, slow)
            rec["roots"] += len(fast.solutions)
            rec["incomplete"] += not (fast.complete and slow.complete)
            print(f"{family} {k + 1}/{a.poses}", file=sys.stderr, end="\r")
        bad += rec["poses"] - rec["same"]
        print(json.dumps(rec), flush=True)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
