"""Position analysis of mechanisms with loops: ``kinbox.solve``.

Every assembly mode of a parallel platform, every configuration of a linkage with its inputs
set, and the full configuration curve(s) of a mobile linkage, as one :class:`~kinbox.result.Result`.
"""

from __future__ import annotations

import copy
from typing import Mapping

from .errors import FormulationError
from .formulation import formulate
from .mechanism import load
from .refine import free_velocity_indices, refine
from .result import Result, build_result
from .solver import SolverOptions, solve_system

DEFAULT_SIGMA = 0.05


def solve(mechanism, set: Mapping[str, float] | None = None, legs: str = "auto",  # noqa: A002
          **solver_options) -> Result:
    """All configurations of ``mechanism`` (a built-in name, a file, or a Mechanism).

    ``set``: joints held at given values (leg lengths, input angles). ``legs``: equations of
    distance closures (legs of platforms): ``"auto"``/``"squared"`` (fastest for isolated
    assembly modes) or ``"vector"`` (a unit vector per leg: tighter, for mobile platforms whose
    configurations form curves, see :func:`kinbox.formulation.formulate`). Solver options:
    ``sigma`` (box size for positive-dimensional sets), ``time_limit``, ``max_boxes``,
    ``progress``.
    """
    mech = copy.copy(load(mechanism))
    mech.closures = list(mech.closures)
    mech.locked = dict(mech.locked)
    for name, value in (set or {}).items():
        mech.lock(name, value)
    if not mech.closures:
        raise FormulationError(f"{mech.name!r} has no loop closure and no goal: nothing to solve "
                               "(for a serial arm use `kinbox ik`)")
    form = formulate(mech, legs=legs)
    opts = SolverOptions(sigma=DEFAULT_SIGMA)
    raw = solve_system(form.system, opts, **solver_options)
    if not raw.complete and legs != "vector" and any(c.kind == "distance" for c in mech.closures):
        raw.message += "; if the configurations form curves (a mobile platform), try legs='vector' (--legs vector)"
    free_v = free_velocity_indices(mech.model, form.joint_vars.keys())
    source = {"kind": "solve", "mechanism": mechanism if isinstance(mechanism, str) else None,
              "set": {k: float(v) for k, v in (set or {}).items()}}
    return build_result(f"solve {mech.name}", raw, form, opts.sigma,
                        polish=lambda q: refine(mech, q, free_v), source=source)
