"""The one interface of every contractor: ``contract(box, ctx) -> Contraction``.

A contractor takes a box and returns a :class:`Contraction` whose ``status`` is one
:class:`ContractStatus`: the box proven empty, a narrower box, a proof that a box holds exactly
one solution (Krawczyk), or nothing learnt. Every contractor keeps every solution of the system
that lies in the box it is given: that is the whole soundness contract (``docs/soundness.md``),
and each is tested alone against an independent interval library (``tests/search/test_soundness_*``).

What a contractor needs beyond the box comes in the :class:`Context` of the box being
processed: the monomial bounds the last propagation computed (the LP relaxations are built on
them), the LP basis to warm-start from, whether the transverse test is to look for a graph.

The contractors, each in its own module: :mod:`~kinbox.search.ctc_propagation`,
:mod:`~kinbox.search.ctc_krawczyk`, :mod:`~kinbox.search.ctc_transverse`,
:mod:`~kinbox.search.ctc_shave`, :mod:`~kinbox.search.ctc_linear`,
:mod:`~kinbox.search.ctc_bernstein`. A contractor of the per-box sequence also defines its
:class:`Step` (``STEP`` in its module: when it runs, what counts as paying, how it is built);
which run, in which order, is :mod:`kinbox.search.steps`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from typing import TYPE_CHECKING, Any, NamedTuple, Protocol

if TYPE_CHECKING:  # numpy only in annotations: the command line imports this module before numpy (tests/cli/test_cli.py)
    import numpy as np


class ContractStatus(str, Enum):
    """What a contractor made of a box (a string enum: ``ContractStatus.EMPTY == "empty"``)."""

    #: no solution in the box
    EMPTY = "empty"
    #: every solution of the box lies in ``[lo, hi]``
    NARROWED = "narrowed"
    #: ``proof`` holds exactly one solution of the square core, which lies in ``[lo, hi]``
    UNIQUE = "unique"
    #: nothing learnt
    NONE = "none"

    def __str__(self) -> str:
        return self.value


class Box(NamedTuple):
    lo: np.ndarray
    hi: np.ndarray


@dataclass
class Context:
    """What the contractors of one box share while it is processed."""

    #: bounds of the monomials, from the last propagation (the LP relaxations need them)
    mlo: np.ndarray | None = None
    mhi: np.ndarray | None = None
    #: the LP basis to warm-start the next LP round from (an ancestor's, or this box's last)
    basis: tuple | None = None
    #: the transverse test also looks for a graph over one variable (a curve box)
    graph: bool = False


@dataclass
class Contraction:
    """What a contractor made of a box (see :class:`ContractStatus`). ``mlo``/``mhi`` bound the
    monomials where the contractor computed them; ``work``: LPs solved, ``iterations``: their
    simplex iterations, ``basis``: the LP basis the round ended on; ``graph_box`` and ``params``:
    the transverse test's graph (:mod:`kinbox.search.transverse`)."""

    status: ContractStatus
    lo: np.ndarray
    hi: np.ndarray
    mlo: np.ndarray | None = None
    mhi: np.ndarray | None = None
    proof: tuple[np.ndarray, np.ndarray] | None = None
    work: int = 0
    iterations: int = 0
    basis: tuple | None = None
    graph_box: tuple[np.ndarray, np.ndarray] | None = None
    params: np.ndarray | None = None

    def __post_init__(self) -> None:
        self.status = ContractStatus(self.status)

    @property
    def empty(self) -> bool:
        return self.status is ContractStatus.EMPTY

    @property
    def box(self) -> Box:
        return Box(self.lo, self.hi)


class Contractor(Protocol):
    """Keeps every solution in ``box``; says what it learnt."""

    def contract(self, box: Box, ctx: Context) -> Contraction: ...


@dataclass(frozen=True)
class Gate:
    """When a step of the per-box sequence (:mod:`kinbox.search.steps`) runs: on every box while
    at least ``rate`` of its recent tests paid, else on one box in ``probe``, picked by the bits
    of the box's identifier from ``bits`` on (different bits per gate, so the probes of two
    gates fall on different boxes). ``start``: the share assumed before any test. ``adaptive``:
    the probes are spaced by the cost of a test and the closing rate of the other boxes
    (:meth:`kinbox.search.policy.Policy.probe_every`), and ``prior`` is the weight of ``start``
    against the first tests under the quick start (:data:`kinbox.search.policy.QUICK`). Made by a
    contractor's module with :func:`kinbox.search.policy.register_gate`."""

    name: str
    rate: float
    probe: int
    bits: int = 0
    start: float = 1.0
    adaptive: bool = False
    prior: float | None = None


@dataclass(frozen=True)
class Step:
    """One contractor of the per-box sequence (:mod:`kinbox.search.steps`), defined as ``STEP``
    in the contractor's module.

    ``build``: makes the contractor from the :class:`~kinbox.search.processor.BoxProcessor` of
    a system (its ``comp``, ``cert``, ``hc4``, ``split_mask``, ``root_w``, ``opt``), once per
    system (None: the step is skipped for that system); ``gate``: when it runs; ``gain``: the
    log-volume a test must remove to pay; ``repeats``: more runs on the box it narrowed, while
    they pay; ``always_below``: it also runs, gate closed, on boxes narrower than this many
    sigma; ``curve``: a test that pays marks the box as lying around a piece of a curve (LP
    rounds there follow their own gate) and a graph it proves is tried as a curve box;
    ``not_after``: the step of this name, when its first test on the box paid, closes this
    one under a policy that says so (:meth:`~kinbox.search.policy.Policy.runs_after_paid`);
    ``without_lp``: where the search has no LP rounds, the step runs on every box, gate open
    (it is then the only test that settles a box); ``optional``: the step runs only when
    ``SolverOptions.extra_steps`` names it (a contractor kept as an option)."""

    name: str
    build: Callable[[Any], Contractor | None]
    gate: Gate
    gain: float
    repeats: int = 0
    always_below: float = 0.0
    curve: bool = False
    not_after: str | None = None
    without_lp: bool = False
    optional: bool = False
