"""kinbox: every configuration of a robot mechanism, certified.

Data flows one way, and the subpackages are its stages:

* :mod:`kinbox.model`: Pinocchio models, loop closures, locked joints; loading and builders;
* :mod:`kinbox.formulation`: the quadratic polynomial system of a mechanism (Porta, Ros and Thomas 2009, Sec. III-IV);
* :mod:`kinbox.search`: branch-and-prune with its contractors (propagation, LP relaxation,
  Krawczyk), serial or parallel;
* :mod:`kinbox.answer`: solutions in joint space, components, checks with Pinocchio;
* :mod:`kinbox.viz`: replay in meshcat, plots;
* :mod:`kinbox.problems`: the problem kinds around one :func:`run` (the clock, the options, the
  search, the answer, the search again): :func:`ik`, :class:`IK`, :func:`solve` (build once,
  solve, check), :func:`assemble` for geometric constraint systems (points, lines, planes; Porta
  et al. 2005, Ruiz 1994) and :func:`check` (diagnosis before solving); :mod:`kinbox.pipeline`
  gathers them.

Every result (:class:`Result`, :class:`AssemblyResult`, :class:`SolveResult`) is an
:class:`Outcome`: ``status`` (a :class:`Status`), ``complete``, ``message``, ``stats``,
``to_json()``, ``table()``.

The robot layer imports Pinocchio, the search numba: both load on first use only.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING

from . import jitcache
from .errors import FormulationError, InconsistentError, InputError, KinboxError, ModelError, NameNotFound

jitcache.choose()  # before numba loads: a cache folder that can be written, or none

__version__ = "0.1.0"

_LAZY = {
    "ik": "pipeline",
    "IK": "pipeline",
    "solve": "pipeline",
    "solve_system": "pipeline",
    "Problem": "pipeline",
    "assemble": "pipeline",
    "Assemble": "pipeline",
    "check": "pipeline",
    "run": "pipeline",
    "load_constraints": "model.constraints",
    "ConstraintSystem": "model.constraints",
    "load": "model.loading",
    "Mechanism": "model.mechanism",
    "Closure": "model.mechanism",
    "System": "formulation.system",
    "Expr": "formulation.system",
    "SolveResult": "search.solver",
    "SolverOptions": "search.solver",
    "Result": "answer.result",
    "AssemblyResult": "answer.assembly",
    "Outcome": "search.outcome",
    "Status": "search.status",
    "BoxStatus": "search.status",
    "replay": "viz.replay",
    "to_html": "viz.replay",
    "reach": "workspace",
    "reach_platform": "workspace",
    "Paving": "workspace",
}

# What type checkers and IDEs see; at run time these names load on first use, through
# __getattr__ (tests/cli/test_public_api.py keeps this block equal to _LAZY).
if TYPE_CHECKING:
    from .answer.assembly import AssemblyResult
    from .answer.result import Result
    from .formulation.system import Expr, System
    from .model.constraints import ConstraintSystem, load_constraints
    from .model.loading import load
    from .model.mechanism import Closure, Mechanism
    from .pipeline import IK, Assemble, Problem, assemble, check, ik, run, solve, solve_system
    from .search.outcome import Outcome
    from .search.solver import SolveResult, SolverOptions
    from .search.status import BoxStatus, Status
    from .viz.replay import replay, to_html
    from .workspace import Paving, reach, reach_platform


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module 'kinbox' has no attribute {name!r}")


# the lazy names of _LAZY and the errors (tests/cli/test_public_api.py checks it)
__all__ = [
    "ik",
    "IK",
    "solve",
    "solve_system",
    "Problem",
    "assemble",
    "Assemble",
    "check",
    "run",
    "load_constraints",
    "ConstraintSystem",
    "load",
    "Mechanism",
    "Closure",
    "System",
    "Expr",
    "SolveResult",
    "SolverOptions",
    "Result",
    "AssemblyResult",
    "Outcome",
    "Status",
    "BoxStatus",
    "replay",
    "to_html",
    "reach",
    "reach_platform",
    "Paving",
    "KinboxError",
    "ModelError",
    "NameNotFound",
    "FormulationError",
    "InputError",
    "InconsistentError",
]


def __dir__() -> list[str]:
    """The public API (``dir(kinbox)``), though most of it loads on first use."""
    return sorted({*globals(), *__all__})
