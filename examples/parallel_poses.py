"""Many IK poses over worker processes: the same answers as one at a time, in the same order.

``workers=N`` spreads the poses over N processes (the arm is formulated once, before the
workers start); each pose is solved in one process, with the answer it has alone. The
command-line equivalent is ``kinbox ik ur5 --frame tool0 --poses FILE --workers 2``.

Run: ``python examples/parallel_poses.py``.
"""

import numpy as np

import kinbox

ik = kinbox.IK("ur5", "tool0")
rng = np.random.default_rng(0)
poses = [ik.pose_at(q) for q in rng.uniform(-3, 3, (6, 6))]  # six reachable poses

if __name__ == "__main__":  # worker processes import this file: solve in the main one only
    together = ik.solve_many(poses, workers=2)
    alone = ik.solve_many(poses)  # one after the other, in this process
    for k, (a, b) in enumerate(zip(together, alone)):
        print(f"pose {k}: {len(a.solutions)} solutions over workers, {len(b.solutions)} alone, complete={a.complete}")
        assert len(a.solutions) == len(b.solutions)
