"""Mechanisms (linkages, parallel robots, and an IK pose's closed chain): joint-space problems.

:class:`Problem` holds a mechanism and its polynomial system, built once; :meth:`Problem.solve`
runs it (:func:`kinbox.problems.run.run`) and turns the boxes into checked joint-space
solutions (:class:`~kinbox.answer.result.Result`). :func:`solve` is every configuration of a
mechanism with loops (assembly modes, curves); :mod:`kinbox.problems.ik` builds one
:class:`Problem` per pose.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping, Sequence

import numpy as np
import pinocchio as pin

from ..answer.refine import free_velocity_indices, refine
from ..answer.result import Result, build_result
from ..answer.turns import add_turns
from ..errors import FormulationError, InputError
from ..formulation.arm import ArmFormulation
from ..formulation.build import Formulation, formulate
from ..formulation.planar import PARALLEL_TOL, PlanarFormulation, circles_and_lines, formulate_planar
from ..formulation.system import System
from ..model.loading import load
from ..model.mechanism import Mechanism
from ..search.certify import set_newton
from ..search.solver import SolveResult
from ..search.state import SearchState
from .choices import MECHANISM_FORMULATIONS
from .run import MAX_SIGMA, run, start_clock
from .scene import Scene

#: joints held fixed: name -> value (a number, or the joint's ``q`` entries, e.g. a free-flyer's 7)
Locks = Mapping[str, float | Sequence[float]]

#: what the answer stage is given: the system of one problem with its encode and decode
AnyFormulation = Formulation | ArmFormulation | PlanarFormulation

#: box size below which a search stops splitting on a mechanism: it may have curves, drawn at
#: this resolution (isolated roots are certified whatever the box size)
MECHANISM_SIGMA = 0.05
#: ``legs="auto"`` looks for this many points of the solution set, from at most this many starts
MOBILITY_SAMPLES = 4
MOBILITY_STARTS = 64
#: singular values of the Jacobian below this share of the largest count as zero
RANK_TOL = 1e-7


def local_dimensions(system: System, samples: int = MOBILITY_SAMPLES, starts: int = MOBILITY_STARTS, seed: int = 0) -> list[int]:
    """The local dimension (variables minus the rank of the equations' Jacobian) of the solution
    set of ``system`` at up to ``samples`` of its points, found by Gauss-Newton from seeded random
    starts in the domain (the same points on every run). Empty if none was found."""
    comp = system.compile()
    lo, hi = system.domain()
    rng = np.random.default_rng(seed)
    dims: list[int] = []
    for _ in range(starts):
        x = set_newton(comp, rng.uniform(lo, hi), iters=40)
        if not (np.all(np.isfinite(x)) and np.all(x >= lo) and np.all(x <= hi)):
            continue
        if np.max(np.abs(comp.eval_eqs(x)), initial=0.0) > 1e-10:
            continue
        sv = np.linalg.svd(comp.jacobian(x), compute_uv=False)
        dims.append(comp.n - int(np.sum(sv > RANK_TOL * sv[0])) if len(sv) and sv[0] > 0 else comp.n)
        if len(dims) == samples:
            break
    return dims


def choose_formulation(mechanism: Mechanism, legs: str = "auto", formulation: str = "auto") -> Formulation | PlanarFormulation:
    """The planar formulation of a planar mechanism (``formulation`` ``"auto"`` or ``"planar"``,
    :func:`~kinbox.formulation.planar.formulate_planar`), else ``formulate(mechanism, legs)``;
    for ``legs="auto"``, the leg equations that suit the solution set. ``"auto"`` takes the
    planar one only for a model planar as given (not one whose axes are parallel only to
    ``PARALLEL_TOL``: ``PlanarFormulation.not_planar``).

    Squared legs (fewest variables) are fastest on isolated assembly modes; on a curve their
    relaxation is loose and the search neither ends in time nor separates the curves, while
    leg vectors (linear loop equations) give them. Whether the configurations form curves is
    read from the squared system itself: the local dimension at sample points of its solution
    set. Positive at every sample (a mobile mechanism, however its equations count): vectors.
    """
    if formulation not in MECHANISM_FORMULATIONS:
        raise InputError(f"formulation must be one of {', '.join(MECHANISM_FORMULATIONS)}, not {formulation!r}")
    if formulation != "general":
        pf = formulate_planar(mechanism, legs=legs)
        # a model planar only to PARALLEL_TOL is not planar as given: its own (general)
        # formulation, unless the planar one is asked for
        # (tests/formulation/test_planar_enclosures.py::test_a_nearly_planar_model_goes_to_the_general_formulation)
        if pf is not None and (pf.not_planar is None or formulation == "planar"):
            return pf
        if formulation == "planar":
            raise InputError(
                f"{mechanism.name!r} is not planar: its loops need joints whose axes are all parallel (revolute) or across them (prismatic)"
            )
    f = formulate(mechanism, legs=legs)
    if legs != "auto" or not any(c.kind == "distance" for c in mechanism.closures):
        return f
    dims = local_dimensions(f.system)
    if dims and min(dims) >= 1:
        return formulate(mechanism, legs="vector")
    return f


class Problem:
    """A mechanism formulated once, solved on demand: a joint-space problem kind of
    :func:`~kinbox.problems.run.run` (:class:`~kinbox.problems.run.Searchable`)."""

    #: the largest sigma it takes (:data:`~kinbox.problems.run.MAX_SIGMA`)
    max_sigma: float | None = MAX_SIGMA

    def __init__(
        self,
        mechanism: Mechanism,
        label: str,
        sigma: float,
        source: dict | None = None,
        legs: str = "auto",
        formulation: AnyFormulation | None = None,
    ):
        self.mechanism = mechanism
        self.label = label
        self.sigma = sigma
        self.source = source or {}
        self.formulation: AnyFormulation = formulation if formulation is not None else choose_formulation(mechanism, legs)
        self._free_v = free_velocity_indices(mechanism.model, self.formulation.joint_vars.keys())
        self._data: pin.Data | None = None

    def polish(self, q: np.ndarray) -> np.ndarray:
        """Newton on the closures with Pinocchio, moving only the joints of the system."""
        if self._data is None:  # scratch for Pinocchio, one per problem (not per solution)
            self._data = self.mechanism.model.createData()
        return refine(self.mechanism, q, self._free_v, data=self._data)

    def relaxation(self) -> str:
        """The LP contractor for ``relaxation="auto"``: the linear relaxation (Porta, Ros and Thomas 2009) when the legs are
        unit vectors (a mobile platform, see :func:`choose_formulation`), where it ran 1.16x
        faster than the Bernstein polytope; Bernstein elsewhere, where it was as fast (general
        6R, the four-bar) or faster (UR5 0.93x, Dietmeier 0.83x) (``benchmarks/relaxations.py``;
        tests/search/test_relaxations.py checks that every relaxation gives the same answers)."""
        legs = self.formulation.closure_vars
        return "linear" if any(legs.values()) else "bernstein"

    def search_defaults(self) -> dict:
        """Solver options this problem's system starts from (the caller's options replace them).
        A square system whose rows are linear but for the unit circles of its cosine/sine pairs
        (:func:`~kinbox.formulation.planar.circles_and_lines`: a planar linkage of revolute
        joints without bars) gets CuikSuite's search: the linear relaxation, exact on every row
        but the circles, bounding every variable (``lp_sweep``) on every box from the root on
        (policy ``eager``: the gate still closes where rounds stop paying), boxes cut where the
        circles' linearization error is largest (``bisection="error"``). The Double Butterfly:
        13 boxes instead of 121 (CuikSuite: 11-21), search CPU 0.18-0.22 against 0.14-0.17 s
        (docs/cuiksuite.md; tests/formulation/test_planar.py)."""
        if isinstance(self.formulation, PlanarFormulation) and circles_and_lines(self.formulation.system):
            return {"relaxation": "linear", "lp_sweep": True, "policy": "eager", "bisection": "error"}
        return {}

    @property
    def system(self) -> System:
        return self.formulation.system

    def answer(self, raw: SolveResult, sigma: float) -> Result:
        """The boxes of a search of this problem as checked joint-space solutions."""
        return build_result(self.label, raw, self.formulation, sigma, polish=self.polish, source=self.source)

    def solve(self, resume: SearchState | None = None, all_turns: bool = False, **solver_options) -> Result:
        """Search and check (:func:`~kinbox.problems.run.run`). ``resume``: a stopped search of
        this problem (``result.raw.state``, or :meth:`SearchState.load`) to go on with;
        ``started``: the ``time.perf_counter()`` a ``time_limit`` counts from (default: now);
        ``all_turns``: list every copy ``q + 2 pi k`` within the limits of a joint whose range
        is wider than a turn (:mod:`kinbox.answer.turns`); ``workers``, ``executor`` and the
        other solver options as :func:`~kinbox.problems.run.run` takes them."""
        given = {k: v for k, v in solver_options.items() if not (k == "relaxation" and v == "auto")}
        solver_options = {**solver_options, **self.search_defaults(), **given}
        res = run(self, resume=resume, **solver_options)
        add_turns(res, all_turns)
        f = self.formulation
        if isinstance(f, PlanarFormulation) and f.not_planar:  # formulation="planar" asked for
            res.notes.append(
                f"the model is planar only to {PARALLEL_TOL:g} ({f.not_planar}): this answer is of its planar "
                "projection, not of the model as given (formulation 'auto' solves the model as given)"
            )
        elif isinstance(f, PlanarFormulation) and f.rounded:  # e.g. a plane whose axis is no coordinate axis
            res.notes.append(
                f"{f.rounded}: the model is not proven exactly planar as given, and this answer's certificates are "
                "of its planar projection's rows as rounded (formulation 'general' solves the model as given)"
            )
        return res


def solve(
    mechanism,
    set: Mapping[str, float] | None = None,
    legs: str = "auto",  # noqa: A002
    formulation: str = "auto",
    scene=None,
    srdf: str | None = None,
    **solver_options,
) -> Result:
    """All configurations of ``mechanism`` (a built-in name, a file, or a Mechanism).

    ``set``: joints held at given values (leg lengths, input angles). ``legs``: equations of
    distance closures (legs of platforms): ``"squared"`` (fastest for isolated assembly modes) or
    ``"vector"`` (a unit vector per leg: tighter, for mobile platforms whose configurations form
    curves, see :func:`kinbox.formulation.build.formulate`); ``"auto"`` picks by the local
    dimension of the solution set (:func:`choose_formulation`). ``formulation``: ``"auto"`` (the
    planar formulation when every loop joint turns about parallel axes), ``"planar"`` or
    ``"general"``. Solver options:
    ``sigma`` (box size for positive-dimensional sets), ``time_limit``, ``max_boxes``,
    ``progress``, ``workers``. ``scene``: a scene (file, built-in name or dict) for a
    mechanism loaded from a URDF or MJCF file with collision shapes: every configuration gets
    its collision verdict, every curve its free stretches (``collision_free=True`` keeps the
    free isolated ones).
    """
    collision_free = bool(solver_options.pop("collision_free", False))
    mech = copy.copy(load(mechanism))
    mech.closures = list(mech.closures)
    mech.locked = dict(mech.locked)
    for name, value in (set or {}).items():
        mech.lock(name, value)
    if not mech.closures:
        raise FormulationError(f"{mech.name!r} has no loop closure and no goal: nothing to solve (for a serial arm use `kinbox ik`)")
    source = {
        "kind": "solve",
        "mechanism": mechanism if isinstance(mechanism, str) else None,
        "set": {k: float(v) for k, v in (set or {}).items()},
    }
    checker = Scene(mech, mechanism, scene, srdf) if scene is not None else None
    if checker is not None:
        source["scene"] = checker.name
    elif collision_free:
        raise InputError("collision_free needs a scene (scene=..., --scene FILE)")
    start_clock(solver_options)  # the limit covers loading too
    prob = Problem(mech, f"solve {mech.name}", MECHANISM_SIGMA, source, formulation=choose_formulation(mech, legs, formulation))
    res = prob.solve(**solver_options)
    if checker is not None:
        checker.annotate(res, collision_free, prob.polish)
    vectors = any(prob.formulation.closure_vars.values())  # legs="auto" may have chosen them
    if (
        not res.complete
        and not vectors
        and any(c.kind == "distance" for c in mech.closures)
        and _on_a_curve(res.raw, prob.formulation.system)
    ):
        res.message += "; the configurations seem to form curves (a mobile platform): try legs='vector' (--legs vector)"
    return res


def _on_a_curve(raw: SolveResult, system: System, tries: int = 32) -> bool:
    """Signs that the solutions of a stopped search form curves: an uncertified solution box, or
    a solution point (Levenberg-Marquardt from the centres of the first pending boxes) at which
    the equations' Jacobian is rank-deficient. Isolated regular solutions show neither."""
    from scipy.optimize import least_squares

    if any(not b.certified for b in raw.boxes):
        return True
    comp = system.compile()
    if comp.n == 0:
        return False
    lo0, hi0 = system.search_domain()

    def jac(x):
        return comp.jacobian(x, slice(0, comp.n_eq))

    for lo, hi in raw.pending[:tries]:
        x = least_squares(comp.eval_eqs, 0.5 * (lo + hi), jac=jac, method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=200).x
        if not (np.all(np.isfinite(x)) and np.all(x >= lo0) and np.all(x <= hi0)):
            continue
        if np.max(np.abs(comp.eval_eqs(x)), initial=0.0) > 1e-9:
            continue
        sv = np.linalg.svd(jac(x), compute_uv=False)
        if len(sv) < comp.n or sv[-1] <= 1e-8 * sv[0]:
            return True
    return False
