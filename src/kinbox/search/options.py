"""The options of a search, in one place: their defaults, their ranges, their choices, and which
of them shape the tree.

A field that changes which boxes the search makes is marked once, with :func:`tree`; the
resume check (:meth:`kinbox.search.state.SearchState.check`) compares exactly the marked fields,
so an option added later cannot be left out of it (``tests/search/test_resume.py``,
``test_every_tree_option_is_checked_on_resume``). A field with a fixed set of values names
them with ``choices=``; the command line offers the same tuple (:func:`choices`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

from ..errors import InputError
from .policy import POLICIES
from .steps import SEQUENCE

#: the LP contractors ``SolverOptions.relaxation`` names
RELAXATIONS = ("auto", "linear", "bernstein", "none")


def tree(default: Any, choices: tuple | None = None) -> Any:
    """A field that shapes the tree: a saved search is resumed only under the same value."""
    return field(default=default, metadata={"tree": True, "choices": choices})


@dataclass
class SolverOptions:
    sigma: float = tree(1e-3)
    rho: float = tree(0.95)
    max_boxes: int | None = 500_000
    time_limit: float | None = None
    lp: bool = tree(True)
    certify: bool = tree(True)
    progress: bool | None = None  # None: only when stderr is a terminal
    lp_rounds: int = tree(20)
    #: square systems: a box below sigma that holds a regular-looking root is split further
    #: (until Krawczyk proves it or it is narrower than this), since sigma is meant for
    #: positive-dimensional sets and certification, not width, decides isolated roots
    min_width: float = tree(1e-11)
    #: a box below sigma in which no approximate solution is found is split down to
    #: ``sigma * resolve`` before it is returned (uncertified)
    resolve: float = tree(1e-3)
    #: the ``time.perf_counter()`` the time limit counts from (None: the start of the search),
    #: so that a limit can cover loading and formulation too
    started: float | None = None
    #: bytes the boxes held by the search (pending and solution boxes) may take, estimated from
    #: their number and size (:func:`kinbox.search.waves.held_bytes`): the search stops,
    #: incomplete, beyond it
    max_memory: float | None = 2e9
    #: the LP contractor: ``"linear"`` (Porta, Ros and Thomas 2009: secants, tangents, McCormick),
    #: ``"bernstein"`` (Fünfzig et al. 2010: the Bernstein polytope of each box's unit box),
    #: ``"none"`` (intervals only: propagation and Krawczyk; the same as ``lp=False``) or
    #: ``"auto"``: Bernstein, which was as fast or faster on every problem measured but one
    #: (benchmarks/relaxations.py);
    #: :class:`kinbox.problems.mechanism.Problem` picks linear for that one's kind, mobile platforms with
    #: leg vectors
    relaxation: str = tree("auto", RELAXATIONS)
    #: a box wider than sigma whose zeros the transverse test proves to lie on one graph over
    #: a single parameter, which a corrector finds to be a piece of a curve of solutions (at
    #: every sample a point where every equation holds to a small multiple of its slack and the
    #: Jacobian is singular to working precision), is returned at once (a *curve box*: the
    #: answer stage follows the curve through it) instead of being split down to sigma; False:
    #: every uncertified box is narrower than sigma. Self-motions take seconds with it and
    #: minutes without (docs/soundness.md, "Curve boxes")
    curve_boxes: bool = tree(True)
    #: how the LP policy starts (:data:`kinbox.search.policy.POLICIES`): ``"steady"``, or
    #: ``"quick"`` (a cold round's cost assumed, first rounds replace the priors), which
    #: :class:`kinbox.IK` uses: its searches are short
    policy: str = tree("steady", tuple(POLICIES))
    #: the optional steps of the per-box sequence to run too, comma-separated names of
    #: :data:`kinbox.search.steps.SEQUENCE` whose step is ``optional`` (``"shave"``: the 3BCID
    #: shaving contractor, :mod:`kinbox.search.ctc_shave`); ``""``: the default sequence
    extra_steps: str = tree("")


#: the options that shape the tree, derived from the marks (:func:`tree`)
TREE_OPTIONS: tuple[str, ...] = tuple(f.name for f in dataclasses.fields(SolverOptions) if f.metadata.get("tree"))


def choices(name: str) -> tuple:
    """The values option ``name`` takes (for the command line's ``choices=``)."""
    for f in dataclasses.fields(SolverOptions):
        if f.name == name and f.metadata.get("choices"):
            return tuple(f.metadata["choices"])
    raise KeyError(f"solver option {name!r} has no fixed set of values")


def tree_options(options: SolverOptions) -> dict:
    """The values of the options that shape the tree (saved with a search's state)."""
    return {k: getattr(options, k) for k in TREE_OPTIONS}


def make_options(options: SolverOptions | None = None, **kw) -> SolverOptions:
    """``options`` (default: the defaults) with the keyword arguments set, as a new object."""
    opt = options or SolverOptions()
    fields = {f.name for f in dataclasses.fields(SolverOptions)}
    for k in kw:
        if k not in fields:
            raise TypeError(f"unknown solver option {k!r}")
    opt = dataclasses.replace(opt, **kw)
    check_options(opt)
    return opt


def _positive(v, integer: bool = False) -> bool:
    import numpy as np

    if isinstance(v, bool):
        return False
    if integer:
        return bool(isinstance(v, (int, np.integer)) and v >= 1)
    return bool(isinstance(v, (int, float, np.integer, np.floating)) and math.isfinite(v) and v > 0)


def check_options(opt: SolverOptions) -> None:
    """Raise :class:`~kinbox.errors.InputError` for an option out of its range: sizes and
    budgets are positive and finite (a budget of None: no budget), a choice is one of its
    values."""
    checks = [
        ("sigma", opt.sigma, False, False),
        ("rho", opt.rho, False, False),
        ("lp_rounds", opt.lp_rounds, True, False),
        ("min_width", opt.min_width, False, False),
        ("resolve", opt.resolve, False, False),
        ("max_boxes", opt.max_boxes, True, True),
        ("time_limit", opt.time_limit, False, True),
        ("max_memory", opt.max_memory, False, True),
    ]
    for name, v, integer, optional in checks:
        if optional and v is None:
            continue
        if not _positive(v, integer):
            what = "a positive integer" if integer else "a positive finite number"
            raise InputError(f"solver option {name} must be {what}{' or None' if optional else ''}, got {v!r}")
    if opt.rho > 1:
        raise InputError(f"solver option rho must be at most 1, got {opt.rho!r}")
    if opt.started is not None and not (isinstance(opt.started, (int, float)) and math.isfinite(opt.started)):
        raise InputError(f"solver option started must be a time.perf_counter() value, got {opt.started!r}")
    names = opt.extra_steps.split(",") if isinstance(opt.extra_steps, str) else [opt.extra_steps]
    for name in filter(None, names):
        if name not in SEQUENCE:
            raise InputError(f"extra_steps names steps of {', '.join(SEQUENCE)}, got {name!r}")
    for f in dataclasses.fields(SolverOptions):
        values = f.metadata.get("choices")
        if values and getattr(opt, f.name) not in values:
            raise InputError(f"{f.name} must be one of {', '.join(values)}, got {getattr(opt, f.name)!r}")
