"""The contractors of the search, behind one interface.

A contractor takes a box and returns a :class:`Contraction`: the box proven empty, a narrower
box, or (Krawczyk) a proof that a box holds exactly one solution. Every contractor keeps every
solution of the system that lies in the box it is given: that is the whole soundness contract
(``docs/soundness.md``), and each is tested alone against an independent interval library.

* :class:`Propagation`: interval constraint propagation (HC4-revise) over the rows and the
  monomials of the expanded system (:mod:`kinbox.search.propagate`);
* :class:`LinearRelaxation`: bounds of the variables over the LP relaxation of Porta, Ros and Thomas 2009
  (:mod:`kinbox.search.relaxation`), one SHRINK-BOX round;
* :class:`Krawczyk`: the Krawczyk operator on the square core (:mod:`kinbox.search.certify`);
* :class:`~kinbox.search.bernstein.BernsteinRelaxation` (in :mod:`kinbox.search.bernstein`): the
  LP over the Bernstein polytope of Fünfzig et al. 2010, an alternative to :class:`LinearRelaxation` chosen by
  ``SolverOptions.relaxation``.

The solver (:mod:`kinbox.search.solver`) composes them; which one runs on which box is
:mod:`kinbox.search.policy`'s decision.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ..formulation.system import Compiled
from .certify import Certifier
from .propagate import SWEEP_TOL, SWEEPS, Propagator
from .relaxation import Relaxation

#: a round of LPs moves on to the next variable only if the last one shrank by this share of
#: its width (1: one variable per round, the widest; another round follows if it paid)
LP_VAR_PAYS = 1.0


@dataclass
class Contraction:
    """What a contractor made of a box.

    ``status``: ``"empty"`` (no solution in the box), ``"narrowed"`` (every solution of the box
    lies in ``[lo, hi]``), ``"unique"`` (``[vlo, vhi]`` = ``proof`` holds exactly one solution of
    the square core, which lies in ``[lo, hi]``) or ``"none"`` (nothing learnt). ``mlo``/``mhi``
    bound the monomials where the contractor computed them. ``work``: LPs solved.
    """

    status: str
    lo: np.ndarray
    hi: np.ndarray
    mlo: np.ndarray | None = None
    mhi: np.ndarray | None = None
    proof: tuple[np.ndarray, np.ndarray] | None = None
    work: int = 0

    @property
    def empty(self) -> bool:
        return self.status == "empty"


class Contractor(Protocol):
    def contract(self, lo: np.ndarray, hi: np.ndarray, mlo: np.ndarray | None = None, mhi: np.ndarray | None = None) -> Contraction: ...


class Propagation:
    """HC4 sweeps until the box stops shrinking by ``tol`` of its widths (at most ``sweeps``)."""

    def __init__(self, comp: Compiled, sweeps: int = SWEEPS, tol: float = SWEEP_TOL):
        self.prop = Propagator(comp)
        self.sweeps, self.tol = sweeps, tol

    def contract(self, lo, hi, mlo=None, mhi=None) -> Contraction:
        r = self.prop.contract(lo, hi, self.sweeps, self.tol)
        if r is None:
            return Contraction("empty", lo, hi)
        return Contraction("narrowed", *r)


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
                    return Contraction("empty", lo, hi, work=relax.lps)
                if b is not None and sense > 0 and b > lo[i]:
                    lo[i] = b
                if b is not None and sense < 0 and b < hi[i]:
                    hi[i] = b
            if lo[i] > hi[i]:
                return Contraction("empty", lo, hi, work=relax.lps)
            relax.set_bounds(i, lo[i], hi[i])
            if hi[i] - lo[i] > (1.0 - self.pay) * w:
                break
        return Contraction("narrowed", lo, hi, work=relax.lps)


class Krawczyk:
    """The Krawczyk operator on the square core: empty, unique (with the proof box), or narrowed.

    A box whose test is inconclusive is tested again inflated (epsilon-inflation) when it is tiny
    (narrower than ``inflate_below``) or thinner in some coordinate than the width ``K`` has even
    for a point box (the error of ``F(x0)`` and the rows' slack through ``Y``: propagation pins
    some variables to a sliver, and no box that thin can be proven unique). A zero proven unique
    in the inflated box is the only candidate of the box; the enclosure returned may lie outside
    the box (then the box is empty).
    """

    def __init__(self, cert: Certifier, inflate_below: float = 1e-4):
        self.cert = cert
        self.inflate_below = inflate_below

    def contract(self, lo, hi, mlo=None, mhi=None) -> Contraction:
        k = self.cert.krawczyk(lo, hi)
        if k.status == "empty":
            return Contraction("empty", lo, hi)
        vlo, vhi = lo, hi
        thin = k.floor is not None and np.any(hi - lo < 4.0 * k.floor)
        if k.status != "unique" and (thin or np.max(hi - lo) < self.inflate_below):
            c = 0.5 * (lo + hi)
            r = np.maximum(2.0 * (hi - lo), 1e-10 * (1.0 + np.abs(c)))
            if k.floor is not None:
                r = np.maximum(r, 4.0 * k.floor)
            k2 = self.cert.krawczyk(c - r, c + r)
            if k2.status == "unique":
                k, vlo, vhi = k2, c - r, c + r
        if k.status == "unique":
            if np.any(k.hi < lo) or np.any(k.lo > hi):
                return Contraction("empty", lo, hi)  # the only candidate lies outside the box
            return Contraction("unique", k.lo, k.hi, proof=(vlo, vhi))
        if k.status == "contracted":
            return Contraction("narrowed", k.lo, k.hi)
        return Contraction("none", lo, hi)
