"""One way to run a problem: the clock, the options, the search, the answer, the search again.

Every problem kind (:mod:`kinbox.problems.mechanism` for mechanisms and the poses of an IK,
:mod:`kinbox.problems.constraints` for geometric constraint systems) is a :class:`Searchable`:
its polynomial system, its default box size, and how boxes become its answer. :func:`run`
does the rest, the same for every kind:

1. the clock: a ``time_limit`` counts from ``started`` (default: now, once the compiled
   kernels are in numba's cache: compiling them is not the problem's time);
2. the options: :class:`~kinbox.search.options.SolverOptions` with the kind's sigma, its
   choice for ``relaxation="auto"``, checked;
3. the search (:func:`solve_system`: in this process, over local processes or on Dask);
4. the answer (``problem.answer(raw, sigma)``);
5. the search again: curve boxes the answer put on no curve are searched again down to
   sigma, and the answer rebuilt, until every curve box is on a curve
   (:func:`unconfirmed_curve_boxes`, docs/soundness.md "Curve boxes").
"""

from __future__ import annotations

import time
from typing import Protocol

from ..errors import InputError
from ..formulation.system import System
from ..search import solver
from ..search.loading import kernels_cached
from ..search.outcome import Outcome
from ..search.solver import SolveResult, SolverOptions
from ..search.state import SearchState
from ..search.threads import single_threaded

#: the largest sigma a joint-space problem takes: its variables (cosines, sines, rotation
#: entries, metres) are of unit size, and an answer box wider than this could hold several
#: solutions, which the answer would report as one (the general 6R loop loses half of its 16
#: at sigma 10)
MAX_SIGMA = 0.5


class Answer(Protocol):
    """What :func:`run` needs of an answer: its components (curves among them)."""

    components: list


class Searchable(Protocol):
    """A problem kind as :func:`run` sees it."""

    #: the box size below which the search stops splitting, unless ``sigma=`` says otherwise
    sigma: float
    #: the largest ``sigma`` it takes (None: any)
    max_sigma: float | None

    @property
    def system(self) -> System: ...

    def relaxation(self) -> str:
        """The LP contractor ``relaxation="auto"`` stands for."""
        ...

    def answer(self, raw: SolveResult, sigma: float) -> Outcome:
        """The answer built from the search's boxes."""
        ...


def solve_system(
    system: System,
    options: SolverOptions | None = None,
    *,
    workers: int | None = None,
    executor=None,
    resume: SearchState | None = None,
    **kw,
) -> SolveResult:
    """Enclose every solution of ``system`` in its domain. Keyword arguments set options.

    ``workers=N`` explores the boxes with N local processes (0: one per core), ``executor=`` a
    ``dask.distributed.Client`` (or scheduler address) on a Dask cluster; see
    :mod:`kinbox.search.parallel`. ``resume``: the ``state`` of an incomplete result of the same
    system (or :meth:`SearchState.load` of a saved one): the search goes on from there.
    """
    opt = solver.make_options(options, **kw)
    if workers is not None or executor is not None:
        from ..search.parallel import solve_parallel  # Dask and multiprocessing only when asked

        return solve_parallel(system, opt, workers=workers, executor=executor, resume=resume)
    return solver.solve_system(system, opt, resume=resume)


def options_of(problem: Searchable, solver_options: dict) -> SolverOptions:
    """The solver options of a run of ``problem``: its sigma and its ``relaxation="auto"``
    unless given, checked (a sigma above the kind's largest is refused, one line)."""
    if solver_options.get("relaxation", "auto") == "auto":
        solver_options["relaxation"] = problem.relaxation()
    opts = solver.make_options(SolverOptions(sigma=problem.sigma), **solver_options)
    if problem.max_sigma is not None and opts.sigma > problem.max_sigma:
        raise InputError(
            f"sigma {opts.sigma:g} is too large: at most {problem.max_sigma} (an answer box wider than that could hold several solutions)"
        )
    return opts


@single_threaded
def run(
    problem: Searchable,
    workers: int | None = None,
    executor=None,
    resume: SearchState | None = None,
    within: list | None = None,
    **solver_options,
):
    """Search ``problem`` and build its answer (see the module's text). ``resume``: a stopped
    search of this problem (``result.raw.state``, or :meth:`SearchState.load`) to go on with;
    ``started``: the ``time.perf_counter()`` a ``time_limit`` counts from (default: now);
    ``within``: boxes ``(lo, hi)`` holding every solution, searched instead of the whole
    domain (in this process; :func:`kinbox.search.solver.solve_system`);
    other keywords are solver options (:class:`~kinbox.search.options.SolverOptions`)."""
    start_clock(solver_options)
    opts = options_of(problem, solver_options)
    if within is not None and workers is None and executor is None and resume is None:
        raw = solver.solve_system(problem.system, opts, within=within)
    else:
        raw = solve_system(problem.system, opts, workers=workers, executor=executor, resume=resume)
    res = problem.answer(raw, opts.sigma)
    while redo := unconfirmed_curve_boxes(raw, res.components):  # type: ignore[attr-defined]
        raw = solver.search_again(problem.system, raw, redo, opts)
        res = problem.answer(raw, opts.sigma)
    return res


def unconfirmed_curve_boxes(raw: SolveResult, components) -> list[int]:
    """The curve boxes of a complete search that the answer put on no curve (``components``:
    dimension 1):
    :func:`kinbox.search.solver.search_again` resolves them like any other box. The answer
    stage is the second judge of a curve box, after the solver's samples along it: its
    continuation must leave the box's point along a curve, else the box may hold isolated roots
    next to a curve that its one point would stand for (docs/soundness.md, "Curve boxes")."""
    if not raw.complete:
        return []  # an incomplete answer says so; resuming it ends with this check
    curve = [i for i, b in enumerate(raw.boxes) if b.curve]
    if not curve:
        return []
    on_curve = {i for c in components if c.dimension >= 1 for i in c.boxes}
    return [i for i in curve if i not in on_curve]


def load_kernels() -> None:
    """Load the search's compiled kernels (compiled and cached on disk after an install); the
    answer's curve tracer loads its own when it first follows a curve."""
    solver.load_kernels()


def compile_kernels() -> None:
    """Compile the search's kernels now if numba's cache lacks any (the first run after an
    install: tens of seconds), else nothing: a cached kernel loads at its first call, so a
    process loads only the kernels its problem calls (the general 6R loop eight of the search's,
    the Double Butterfly four, a closed-form IK pose none). What a ``time_limit`` leaves out is the
    compiling; loading from the cache (a fraction of a second) is the problem's time, as
    loading its model is (tests/cli/test_cli.py::test_a_time_limit_leaves_out_loading_the_kernels)."""
    global _kernels_ready
    if _kernels_ready:  # checked once a process: numba's cache index read at every solve costs ms
        return
    if not kernels_cached():
        load_kernels()
    _kernels_ready = True


#: the search's kernels are known compiled (and cached) in this process (:func:`compile_kernels`)
_kernels_ready = False


def start_clock(solver_options: dict) -> None:
    """Set ``started`` (what a ``time_limit`` counts from) to now, unless given, once the
    compiled kernels are in numba's cache (:func:`compile_kernels`): the limit covers loading the
    model and solving, not compiling the kernels, which the first solve after an install does
    (tens of seconds)."""
    if "started" not in solver_options:
        compile_kernels()
        solver_options["started"] = time.perf_counter()
