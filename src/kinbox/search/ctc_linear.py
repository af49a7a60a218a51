"""SHRINK-BOX over the linear relaxation of Porta, Ros and Thomas 2009 as a contractor (:mod:`kinbox.search.relaxation`)."""

from __future__ import annotations

import time

import numpy as np

from ..formulation.system import Compiled
from .contract import Box, Context, Contraction, ContractStatus
from .relaxation import Relaxation

#: a round of LPs moves on to the next variable only if the last one shrank by this share of
#: its width (1: one variable per round, the widest; another round follows if it paid)
LP_VAR_PAYS = 1.0


class LinearRelaxation:
    """SHRINK-BOX (Porta, Ros and Thomas 2009, Algorithm 2) spending LPs only where they pay: one LP model for the box,
    the independent variables (``mask``) bounded by min/max LPs, widest first (relative to
    ``root_w``). After each pair, if the variable shrank by less than ``pay`` of its width the
    round ends: on this box LPs cost more than splitting. The first LP also tests feasibility.

    A round stops early, with what it has proven so far, when ``deadline`` (a
    ``time.perf_counter`` value) has passed: the box is then handed back unfinished.
    """

    def __init__(self, comp: Compiled, mask: np.ndarray, root_w: np.ndarray, pay: float = LP_VAR_PAYS):
        self.relax = Relaxation(comp)
        self.mask, self.root_w, self.pay = mask, root_w, pay
        self.deadline: float | None = None

    def contract(self, lo, hi, mlo=None, mhi=None, basis=None) -> Contraction:
        """One round on the box; ``basis`` (from :meth:`Relaxation.basis`) starts the first LP."""
        relax = self.relax
        if mlo is None or mhi is None:
            raise ValueError("the LP relaxation needs the monomial bounds (run propagation first)")
        relax.lps = 0
        relax.build(lo, hi, mlo, mhi, basis)
        lo, hi = lo.copy(), hi.copy()
        rel = (hi - lo) / self.root_w
        order = [int(i) for i in np.argsort(-rel, kind="stable") if self.mask[i] and hi[i] > lo[i]]
        for i in order:
            if self.deadline is not None and time.perf_counter() > self.deadline:
                break
            w = hi[i] - lo[i]
            for sense in (+1, -1):
                b, infeasible = relax.bound(i, sense)
                if infeasible:
                    return Contraction(ContractStatus.EMPTY, lo, hi, work=relax.lps)
                if b is not None and sense > 0 and b > lo[i]:
                    lo[i] = b
                if b is not None and sense < 0 and b < hi[i]:
                    hi[i] = b
            if lo[i] > hi[i]:
                return Contraction(ContractStatus.EMPTY, lo, hi, work=relax.lps)
            relax.set_bounds(i, lo[i], hi[i])
            if hi[i] - lo[i] > (1.0 - self.pay) * w:
                break
        return Contraction(ContractStatus.NARROWED, lo, hi, work=relax.lps)


class CtcLP:
    """One LP round of a relaxation ``engine`` (:class:`LinearRelaxation` or
    :class:`~kinbox.search.bernstein.BernsteinRelaxation`) behind the contractor interface: it
    reads the monomial bounds and the warm-start basis from the context and returns the simplex
    iterations spent and the basis the round ended on."""

    def __init__(self, engine):
        self.engine = engine
        self.relax = engine.relax

    @property
    def deadline(self) -> float | None:
        return self.engine.deadline

    @deadline.setter
    def deadline(self, value: float | None) -> None:
        self.engine.deadline = self.relax.deadline = value

    def contract(self, box: Box, ctx: Context) -> Contraction:
        its0 = self.relax.iterations
        s = self.engine.contract(box[0], box[1], ctx.mlo, ctx.mhi, ctx.basis)
        s.iterations = self.relax.iterations - its0
        if not s.empty:
            s.basis = self.relax.basis()
        return s


class CtcLinear(CtcLP):
    """The linear relaxation of Porta, Ros and Thomas 2009 (secants, tangents, McCormick)."""

    def __init__(self, comp: Compiled, mask: np.ndarray, root_w: np.ndarray, pay: float = LP_VAR_PAYS):
        super().__init__(LinearRelaxation(comp, mask, root_w, pay))
