"""The contractors of the search, behind one interface (:mod:`kinbox.search.contract`).

* :class:`CtcPropagation`: interval constraint propagation (HC4-revise) over the rows and the
  monomials of the expanded system (:mod:`kinbox.search.propagate`);
* :class:`CtcKrawczyk`: the Krawczyk operator on the square core (:mod:`kinbox.search.certify`);
* :class:`CtcTransverse`: the transverse Krawczyk test (:mod:`kinbox.search.transverse`);
* :class:`CtcLinear`: bounds of the variables over the LP relaxation of Porta, Ros and Thomas 2009
  (:mod:`kinbox.search.relaxation`), one SHRINK-BOX round;
* :class:`CtcBernstein`: the LP over the Bernstein polytope of Fünfzig et al. 2010
  (:mod:`kinbox.search.bernstein`), an alternative to :class:`CtcLinear` chosen by
  ``SolverOptions.relaxation``;
* :class:`CtcShave`: shaving (3BCID) over propagation, in the manner of Ibex's ``CtcAcid``
  (:mod:`kinbox.search.ctc_shave`), an optional step (``SolverOptions.extra_steps``).

Each lives in a module of its own; this one gathers them. The per-box sequence that composes
them is :mod:`kinbox.search.steps`; which one runs on which box is the policy's decision
(:mod:`kinbox.search.policy`).
"""

from __future__ import annotations

from .contract import Box, Context, Contraction, Contractor, ContractStatus
from .ctc_bernstein import CtcBernstein
from .ctc_krawczyk import CtcKrawczyk
from .ctc_linear import LP_VAR_PAYS, CtcLinear, CtcLP, LinearRelaxation
from .ctc_propagation import CtcPropagation
from .ctc_shave import CtcShave
from .ctc_transverse import CtcTransverse

__all__ = [
    "LP_VAR_PAYS",
    "Box",
    "Context",
    "ContractStatus",
    "Contraction",
    "Contractor",
    "CtcBernstein",
    "CtcKrawczyk",
    "CtcLP",
    "CtcLinear",
    "CtcPropagation",
    "CtcShave",
    "CtcTransverse",
    "LinearRelaxation",
]
