"""Every compiled kernel of kinbox loaded at once: :func:`load_all_kernels` (what ``make setup``
runs), by solving a problem of each kind that has kernels of its own. It sits above the problem
kinds it calls, so :mod:`kinbox.problems.run`, which they all import, imports none of them back
(``tests/support/test_source_shape.py``).
"""

from __future__ import annotations

from .ik import IK
from .run import load_kernels


def load_all_kernels() -> None:
    """Load every compiled kernel of kinbox: the search's
    (:func:`~kinbox.problems.run.load_kernels`), the curve tracer's and the answer's least
    squares. After an install the first call compiles and caches them all (``make setup`` does
    it once), so that no first solve of any kind compiles."""
    import numpy as np

    from ..answer import trace
    from ..search.lstsq import lstsq

    load_kernels()
    trace.load_kernel()
    A, b = np.ones((2, 1)), np.ones(2)
    lstsq(A, b)
    lstsq(A, b, 1e-12)
    # the closed forms' kernels, with the argument types of a real call: one UR5 pose, alone
    # and as an array (tests/cli/test_startup.py::test_all_kernels_leave_nothing_to_compile)
    import json
    from pathlib import Path

    import pinocchio as pin

    from ..model.builders import dh_chain
    from ..search.cf_batch import load_family_kernels

    ik_ = IK("ur5", "tool0")
    q = [0.3, -1.2, 1.5, -0.8, 1.2, 0.4]
    ik_.solve(ik_.pose_at(q))
    # poses 1e-9 from the wrist singularity and 1e-7 from a straight elbow: the search inside
    # the closed form's enclosures
    ik_.solve(ik_.pose_at([0.3, -1.2, 1.5, -0.8, 1e-9, 0.4]))
    ik_.solve(ik_.pose_at([0.3, -1.2, 1e-7, -0.8, 1.2, 0.4]))
    ik_.solve_array(pin.SE3ToXYZQUAT(ik_.pose_at(q))[None, :])
    # an arm whose link rotations are no signed permutations (lines 1 and 2 at 45 degrees): the
    # kernels with enclosed links (kinbox.search.cf_delta.kernel_links), alone and as an array
    twist = [dict(a=0.0, d=0.4, alpha=0.0), dict(a=0.025, d=0.0, alpha=-0.7853981633974483), dict(a=0.315, d=0.0, alpha=0.0)]
    twist += [dict(a=0.035, d=0.365, alpha=-np.pi / 2), dict(a=0.0, d=0.0, alpha=np.pi / 2), dict(a=0.0, d=0.08, alpha=-np.pi / 2)]
    tw = IK(dh_chain(twist, closed=False, name="arm"), "tool")
    tw.solve(tw.pose_at(q))
    tw.solve(tw.pose_at([0.3, -1.2, 1.5, -0.8, 1e-9, 0.4]))  # near its wrist: the system's certificate
    tw.solve_array(pin.SE3ToXYZQUAT(tw.pose_at(q))[None, :])
    load_family_kernels()  # and the other closed-form families' (an arm's first answer compiles its own only)
    # the general 6R's eigenvalue path: the built-in general 6R loop as an arm (its DH chain)
    dh = json.loads((Path(__file__).resolve().parents[1] / "robots" / "general-6r.json").read_text())["dh"]
    IK(dh_chain(dh, closed=False, name="arm"), "tool").solve(pin.SE3.Identity())
