"""kinbox: every configuration of a robot mechanism, certified.

Data flows one way: model -> mechanism -> equations -> solver -> solutions -> checks.

* :mod:`kinbox.mechanism`: Pinocchio model + loop closures + locked joints (loaders);
* :mod:`kinbox.builders`: DH chains, Stewart platforms, planar linkages;
* :mod:`kinbox.formulation` / :mod:`kinbox.joints`: the quadratic system (003, Sec. III);
* :mod:`kinbox.system`: polynomial systems and their expansion (003, Sec. IV-A);
* :mod:`kinbox.solver`: branch-and-prune (with :mod:`~kinbox.propagate`,
  :mod:`~kinbox.relaxation`, :mod:`~kinbox.certify`);
* :mod:`kinbox.result` / :mod:`kinbox.components`: joint-space solutions and structure;
* :func:`kinbox.ik`, :func:`kinbox.solve`: the two entry points.
"""

from .errors import FormulationError, InputError, KinboxError, ModelError, NameNotFound
from .system import Expr, System
from .solver import SolveResult, SolverOptions, solve_system

__version__ = "0.1.0"


def __getattr__(name):  # the robot layer imports Pinocchio: load it on first use only
    if name in ("ik", "IK"):
        from . import inverse_kinematics as _ik

        return getattr(_ik, name)
    if name == "solve":
        from .linkage import solve

        return solve
    if name in ("Mechanism", "Closure", "load"):
        from . import mechanism

        return getattr(mechanism, name)
    raise AttributeError(name)


__all__ = ["ik", "IK", "solve", "load", "Mechanism", "Closure", "System", "Expr", "solve_system",
           "SolveResult", "SolverOptions", "KinboxError", "ModelError", "NameNotFound",
           "FormulationError", "InputError"]
