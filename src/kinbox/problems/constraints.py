"""Geometric constraint systems (points, lines, planes and bodies under distances, angles,
incidences): diagnosed, formulated, solved (:class:`Assemble`, :func:`assemble`), or only
diagnosed (:func:`check`, also for mechanisms).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ..errors import FormulationError, InputError
from ..formulation.system import System
from ..search.solver import SolveResult
from ..search.state import SearchState
from .choices import CONSTRAINT_FORMULATIONS
from .run import run, start_clock

if TYPE_CHECKING:
    from ..answer.assembly import AssemblyResult


#: box size below which the search stops splitting on a constraint system (positive-dimensional
#: sets are drawn at this resolution; isolated assemblies are certified whatever the size)
CONSTRAINTS_SIGMA = 0.05


class Assemble:
    """A constraint system prepared once: diagnosed (degrees of freedom, redundant and
    inconsistent constraints), formulated, solved on demand.

    ``formulation``: ``"coordinates"`` (:mod:`kinbox.formulation.geometry`), ``"distances"``
    (:mod:`kinbox.formulation.distance`, systems of points and lines under distances only) or
    ``"auto"`` (see :func:`choose_constraint_formulation`). An inconsistent system raises
    :class:`~kinbox.errors.InconsistentError` naming a minimal set of inconsistent constraints
    (proven by a complete search on that set) unless ``check=False``.
    """

    def __init__(
        self,
        system,
        set: Mapping[str, float] | None = None,
        formulation: str = "auto",  # noqa: A002
        check: bool = True,
    ):
        from ..model.constraints import load_constraints
        from .diagnosis import diagnose, refuse_if_inconsistent

        if formulation not in CONSTRAINT_FORMULATIONS:
            raise InputError(f"formulation must be one of {', '.join(CONSTRAINT_FORMULATIONS)}, got {formulation!r}")
        self.model = load_constraints(system).with_parameters(set)
        self.source = {
            "kind": "constraints",
            "system": system if isinstance(system, str) else None,
            "set": {k: float(v) for k, v in (set or {}).items()},
        }
        self.diagnosis = diagnose(self.model) if check else None
        if self.diagnosis is not None:
            refuse_if_inconsistent(self.model, self.diagnosis)
        self.formulation = choose_constraint_formulation(self.model, self.diagnosis) if formulation == "auto" else formulation
        pin = self.diagnosis.pin if self.diagnosis is not None else None
        from ..formulation.geometry import formulate as formulate_geometry

        self.geometry = formulate_geometry(self.model, pin=pin)
        if self.diagnosis is not None:  # after the formulation's own refusals (an unbounded entity)
            refuse_if_underconstrained(self.model, self.diagnosis)
        if self.diagnosis is not None and self.diagnosis.solution is not None:
            # redundant constraints: a square core of full rank at the solution found, for Krawczyk
            from ..formulation.geometry import square_core
            from .diagnosis import in_frame

            places, poses = in_frame(self.model, self.geometry, *self.diagnosis.solution)
            square_core(self.geometry.system, self.geometry.encode(places, poses))
        self.distances = None
        if self.formulation == "distances":
            from ..formulation.distance import formulate as formulate_distances

            at = self.diagnosis.solution[0] if self.diagnosis is not None and self.diagnosis.solution else None
            try:
                self.distances = formulate_distances(self.model, self.geometry, at=at)
            except FormulationError:
                # auto never picks a formulation that refuses the system (four points with six
                # distances: test_auto_formulation_never_refuses); an explicit choice is refused
                if formulation != "auto":
                    raise
                self.formulation = "coordinates"
        self._enclose(pin)

    def _enclose(self, pin) -> None:
        """The core rows of both formulations as enclosures of the input as given (the
        coordinate rows prove the assemblies of either: ``answer.assembly.Prover``), in the
        shadow build of :mod:`kinbox.formulation.enclose_constraints`."""
        from ..formulation.enclose_constraints import enclose
        from ..formulation.geometry import formulate as formulate_geometry

        model = self.model
        enclose(self.geometry.system, lambda num: formulate_geometry(model, pin=pin, numbers=num).system)
        if self.distances is not None:
            from ..formulation.distance import formulate as formulate_distances

            at = self.diagnosis.solution[0] if self.diagnosis is not None and self.diagnosis.solution else None
            geo = self.geometry
            enclose(self.distances.system, lambda num: formulate_distances(model, geo, at=at, numbers=num).system)

    @property
    def system(self) -> System:
        return self.distances.system if self.distances is not None else self.geometry.system

    #: the box size of the search (:data:`CONSTRAINTS_SIGMA`), any sigma taken
    sigma = CONSTRAINTS_SIGMA
    max_sigma: float | None = None

    def relaxation(self) -> str:
        """``relaxation="auto"`` is left to the search (:class:`~kinbox.search.options.SolverOptions`)."""
        return "auto"

    def answer(self, raw: SolveResult, sigma: float) -> AssemblyResult:
        """The boxes of a search of this system as assemblies, checked on their placements."""
        import functools

        from ..answer.assembly import build_assembly_result, distance_assemblies

        decode = functools.partial(distance_assemblies, self.distances) if self.distances is not None else None
        return build_assembly_result(
            f"assemble {self.model.name}",
            raw,
            self.geometry,
            sigma,
            decode=decode,
            formulation=self.formulation,
            source=self.source,
            diagnosis=self.diagnosis.to_dict() if self.diagnosis is not None else {},
        )

    def solve(self, resume: SearchState | None = None, **solver_options) -> AssemblyResult:
        """Search and decode (:func:`~kinbox.problems.run.run`). ``resume``: a stopped search of
        this system (``result.raw.state``, or :meth:`SearchState.load`); ``started``: the
        ``time.perf_counter()`` a ``time_limit`` counts from (default: now)."""
        res: AssemblyResult = run(self, resume=resume, **solver_options)
        return res


#: a system whose assemblies form families of this dimension or more is refused before the
#: search: boxes cannot sample a surface to sigma in reasonable time, and the answer would
#: say nothing the diagnosis does not (test_underconstrained_system_is_refused_at_once)
MAX_FAMILY_DIMENSION = 1


def refuse_if_underconstrained(model, diagnosis) -> None:
    """Refuse (:class:`InputError`, one line) a system the diagnosis found under-constrained
    both generically and at its solution by more than :data:`MAX_FAMILY_DIMENSION` degrees of
    freedom (rigid motions of a system with nothing fixed taken out): its degrees of freedom,
    the entities or bodies left free, and what to do. Curves (one degree of freedom) and
    isolated assemblies are solved."""
    d = diagnosis
    if d.dof is None or d.generic_dof is None or min(d.dof, d.generic_dof) <= MAX_FAMILY_DIMENSION:
        return
    dof = min(d.dof, d.generic_dof)
    free = ", ".join(f"{n} ({k} dof)" for n, k in d.underconstrained.items()) or "?"
    raise InputError(
        f"{model.name} is under-constrained: {dof} degrees of freedom (`kinbox check` shows them), so its assemblies "
        f"form families of dimension {dof}, not isolated assemblies or curves; free: {free}; fix entities or bodies "
        f'("fixed") or add constraints to take away {dof - MAX_FAMILY_DIMENSION} or more (all {dof} for isolated assemblies)'
    )


def choose_constraint_formulation(model, diagnosis=None) -> str:
    """The formulation ``"auto"`` picks: ``"distances"`` for the pure distance problems of
    Porta et al. 2005 -- free points only (nothing fixed, no body, no line) under point-point distances,
    with isolated assemblies expected (the diagnosis found no degree of freedom at its
    solution) -- else ``"coordinates"`` (tests/answer/test_assemble.py, automatic choice of
    formulation). Measured by ``benchmarks/constraints.py``: the distance
    formulation took fewer boxes on the octahedral manipulators, more on the tangent lines,
    the cyclohexane's curve and the Stewart platform."""
    from ..formulation.distance import supports

    if supports(model) is not None or model.has_fixed or model.bodies:
        return "coordinates"
    if any(e.type != "point" for e in model.entities.values()):
        return "coordinates"
    if diagnosis is None or diagnosis.dof != 0:
        return "coordinates"
    return "distances"


def assemble(
    system,
    set: Mapping[str, float] | None = None,
    formulation: str = "auto",  # noqa: A002
    check: bool = True,
    **solver_options,
):
    """Every assembly of a geometric constraint system (a file, a built-in name or a dict).

    ``set``: parameter values; ``formulation``: ``"auto"``, ``"coordinates"`` or
    ``"distances"``. Solver options: ``sigma``, ``time_limit``, ``max_boxes``, ``progress``,
    ``workers``; ``resume``: a stopped search of this system. Returns an
    :class:`~kinbox.answer.assembly.AssemblyResult`.
    """
    start_clock(solver_options)  # the limit covers diagnosis too
    return Assemble(system, set, formulation, check).solve(**solver_options)


@dataclass
class Check:
    """A diagnosis before solving (:func:`check`): ``diagnosis`` (a constraint system's
    :class:`~kinbox.problems.diagnosis.Diagnosis` or a mechanism's mobility), and for a
    constraint system proven inconsistent, ``inconsistent``: the one-line reason naming a
    minimal inconsistent set (None otherwise)."""

    problem: str
    diagnosis: Any
    inconsistent: str | None = None

    def to_dict(self) -> dict:
        return {"problem": self.problem, **self.diagnosis.to_dict()}

    def table(self) -> str:
        text: str = self.diagnosis.report(self.problem)
        return text

    def __str__(self) -> str:
        return self.table()


def check(target, set: Mapping[str, float] | None = None) -> Check:  # noqa: A002
    """Diagnose ``target`` before solving it (``kinbox check``): for a geometric constraint
    system (a file, a built-in name or a dict), its degrees of freedom (generic and at a
    solution), redundant constraints, under-constrained entities and a minimal inconsistent
    set (``inconsistent``, proven by a complete search on that set); for a mechanism, its
    mobility by counting and by the closure Jacobian's rank at configurations found. ``set``:
    parameter values (constraint systems) or locked joints (mechanisms)."""
    from ..errors import InconsistentError
    from ..model.constraints import is_constraints_source

    values = dict(set or {})
    if is_constraints_source(target):
        from ..model.constraints import load_constraints
        from .diagnosis import diagnose, refuse_if_inconsistent

        model = load_constraints(target).with_parameters(values)
        d = diagnose(model)
        try:
            refuse_if_inconsistent(model, d)
            err = None
        except InconsistentError as e:
            err = str(e)
        return Check(model.name, d, err)
    from ..model.loading import load
    from .diagnosis import diagnose_mechanism

    mech = load(target)
    for name, value in values.items():
        mech.lock(name, value)
    return Check(mech.name, diagnose_mechanism(mech))
