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
:mod:`~kinbox.search.ctc_linear`, :mod:`~kinbox.search.ctc_bernstein`. Which runs on which box,
in which order, is :mod:`kinbox.search.steps`.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from typing import NamedTuple, Protocol

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
