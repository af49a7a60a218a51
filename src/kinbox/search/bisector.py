"""Bisection: which variable a box is cut along, and where.

The rule is the *smear* (|J| at the box centre times the width), or, with ``rule="error"``, the
*linearization error* (what the nonlinear terms leave to the relaxation: ``|a| w_i^2`` for a term
``a x_i^2``, ``|a| w_i w_j / 2`` to each of ``x_i``, ``x_j`` for ``a x_i x_j``; CuikSuite's
error-based split), restricted to independent variables that are not much narrower than the
widest; split ranks and derived variables have rules of their own (:meth:`Bisector.variable`).
Every constant here shapes the tree.
"""

from __future__ import annotations

import numpy as np

from .certify import Certifier
from .options import BISECTIONS
from .policy import Hint

#: a split slightly off the middle: solutions rarely sit on the cut
SPLIT_POINT = 0.4937
#: split candidates are at least this wide relative to the widest: no flat boxes
RATIO = 0.1
#: with split ranks, the variables of a rank are split first while one is wider than this
#: share of its domain
RANK_DONE = 0.02
#: derived variables are split once every independent one is narrower than this share of its
#: domain and a derived one is this many times wider (see :meth:`Bisector.variable`)
AUX_SPLIT_BELOW = 1e-4
AUX_WIDER = 100.0


class Bisector:
    """Cuts a box in two along the variable of largest smear, at :data:`SPLIT_POINT`."""

    def __init__(self, cert: Certifier, root_w: np.ndarray, split_mask: np.ndarray, ranks: np.ndarray | None, rule: str = "smear"):
        if rule not in BISECTIONS:
            raise ValueError(f"bisection rule must be one of {', '.join(BISECTIONS)}, got {rule!r}")
        self.cert = cert
        self.rule = rule
        comp = cert.comp
        # the weight of each monomial x_i x_j in the core rows (sum of |coefficient|): the
        # linearization error of a box is sum_k weight_k w_i w_j (rule "error")
        core = abs(comp.A[: comp.n_core, comp.n :]) if comp.n_core else None
        self.mono_w = np.asarray(core.sum(axis=0)).ravel() if core is not None else np.zeros(comp.nm)
        self.mi, self.mj = comp.mi, comp.mj
        self.n_core = cert.comp.n_core
        self.root_w = root_w
        self.split_mask = split_mask
        self.ranks = ranks
        #: the independent variables of each rank, lowest rank first
        self.rank_masks = [] if ranks is None else [split_mask & (ranks == r) for r in np.unique(ranks[split_mask])]

    def variable(self, lo, hi) -> int:
        """The independent variable of largest *smear*: sum_r |dF_r/dx_j| * width_j (rule
        ``"smear"``), or of largest linearization error (rule ``"error"``, :meth:`error`).

        The smear (|J| at the box centre times the width) measures how much the equations vary
        along ``x_j``; cutting there reduces the linearization error most. Derived (``aux``)
        variables are not cut while an independent one is wider than :data:`AUX_SPLIT_BELOW` of
        its domain; past that, the widest derived variable is, if it is :data:`AUX_WIDER` times
        wider (a derived variable that the independent ones leave free: an arm whose joint 4
        lines up with joint 1 turns about that line, and splitting the pinned independents
        again and again never ended). Falls back to the widest relative width when the Jacobian
        is not at hand.
        """
        w = hi - lo
        rel = w / self.root_w
        mask = self.split_mask
        if not mask.all():
            ind, aux = float(rel[mask].max()), float(rel[~mask].max())
            if ind < AUX_SPLIT_BELOW and aux > AUX_WIDER * ind:
                return int(np.argmax(np.where(mask, -1.0, rel)))
        if self.ranks is not None:  # the lowest rank that is not narrow yet
            for m in self.rank_masks:
                if rel[m].max() > RANK_DONE:
                    mask = m
                    break
        if self.rule == "error" and self.mono_w.any():
            smear = self.error(w)
        elif self.n_core:
            smear = np.abs(self.cert.J(0.5 * (lo + hi))).sum(axis=0) * w
        else:
            smear = w / self.root_w
        # ignore variables already much narrower than the others: the Jacobian at the centre
        # may vanish along a wide one (then the widest is cut, below)
        smear = np.where(mask & (rel >= RATIO * rel[mask].max()), smear, -1.0)
        i = int(np.argmax(smear))
        if smear[i] <= 0:
            i = int(np.argmax(np.where(mask, w / self.root_w, -1.0)))
        return i

    def error(self, w: np.ndarray) -> np.ndarray:
        """Per variable, its share of the linearization error of the core rows over a box of
        widths ``w``: ``|a| w_i^2`` for each term ``a x_i^2``, ``|a| w_i w_j / 2`` to each of
        ``x_i`` and ``x_j`` for ``a x_i x_j`` (twice the Hessian-weighted half-widths)."""
        t = self.mono_w * w[self.mi] * w[self.mj]
        sq = self.mi == self.mj
        e = np.bincount(self.mi[sq], weights=t[sq], minlength=len(w))
        e += np.bincount(self.mi[~sq], weights=0.5 * t[~sq], minlength=len(w))
        e += np.bincount(self.mj[~sq], weights=0.5 * t[~sq], minlength=len(w))
        return e

    def split(self, lo, hi, hint: Hint, basis: tuple | None) -> list:
        """The two children ``(lo, hi, hint)`` of the box, the upper one first."""
        i = self.variable(lo, hi)
        cut = lo[i] + SPLIT_POINT * (hi[i] - lo[i])
        hi1 = hi.copy()
        hi1[i] = cut
        lo2 = lo.copy()
        lo2[i] = cut
        return [(lo2, hi, hint.child(0, basis)), (lo, hi1, hint.child(1, basis))]
