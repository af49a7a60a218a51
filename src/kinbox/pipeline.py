"""The public entry points of every problem kind, in one place (:mod:`kinbox.problems` holds them).

* :func:`ik` / :class:`IK`: every inverse-kinematics solution of a frame of an arm;
* :func:`solve` / :class:`Problem`: every configuration of a mechanism with loops;
* :func:`assemble` / :class:`Assemble`: every assembly of a geometric constraint system;
* :func:`check`: the diagnosis of a constraint system or a mechanism before solving;
* :func:`run`: the one search-and-answer step every kind goes through.

Example::

    import kinbox
    res = kinbox.ik("ur5", "tool0", [0.3, 0.2, 0.4, 0, 1, 0, 0])   # x y z qx qy qz qw
    for s in res.solutions:
        print(s.q, s.residual, s.certified)
"""

from __future__ import annotations

from .problems.choices import ARM_FORMULATIONS, CONSTRAINT_FORMULATIONS, LEGS, MECHANISM_FORMULATIONS
from .problems.constraints import (
    CONSTRAINTS_SIGMA,
    MAX_FAMILY_DIMENSION,
    Assemble,
    Check,
    assemble,
    check,
    choose_constraint_formulation,
    refuse_if_underconstrained,
)
from .problems.ik import IK, IK_SIGMA, ik, parse_pose
from .problems.kernels import load_all_kernels
from .problems.mechanism import (
    MECHANISM_SIGMA,
    AnyFormulation,
    Locks,
    Problem,
    choose_formulation,
    local_dimensions,
    solve,
)
from .problems.run import MAX_SIGMA, compile_kernels, load_kernels, run, solve_system, unconfirmed_curve_boxes
from .problems.scene import Scene

__all__ = [
    "ARM_FORMULATIONS",
    "CONSTRAINTS_SIGMA",
    "CONSTRAINT_FORMULATIONS",
    "IK",
    "IK_SIGMA",
    "LEGS",
    "MAX_FAMILY_DIMENSION",
    "MAX_SIGMA",
    "MECHANISM_FORMULATIONS",
    "MECHANISM_SIGMA",
    "AnyFormulation",
    "Assemble",
    "Check",
    "Locks",
    "Problem",
    "Scene",
    "assemble",
    "check",
    "choose_constraint_formulation",
    "choose_formulation",
    "compile_kernels",
    "ik",
    "load_all_kernels",
    "load_kernels",
    "local_dimensions",
    "parse_pose",
    "refuse_if_underconstrained",
    "run",
    "solve",
    "solve_system",
    "unconfirmed_curve_boxes",
]
