"""Interval constraint propagation (HC4-revise) as a contractor (:mod:`kinbox.search.propagate`)."""

from __future__ import annotations

from ..formulation.system import Compiled
from .contract import Box, Context, Contraction, ContractStatus
from .propagate import SWEEP_TOL, SWEEPS, Propagator


class CtcPropagation:
    """HC4 sweeps until the box stops shrinking by ``tol`` of its widths (at most ``sweeps``);
    the result carries the monomial bounds the LP relaxations are built on."""

    def __init__(self, comp: Compiled, sweeps: int = SWEEPS, tol: float = SWEEP_TOL):
        self.prop = Propagator(comp)
        self.sweeps, self.tol = sweeps, tol

    def contract(self, box: Box, ctx: Context | None = None) -> Contraction:
        r = self.prop.contract(box[0], box[1], self.sweeps, self.tol)
        if r is None:
            return Contraction(ContractStatus.EMPTY, box[0], box[1])
        return Contraction(ContractStatus.NARROWED, *r)
