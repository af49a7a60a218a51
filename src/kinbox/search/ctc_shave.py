"""Shaving (3BCID, in the manner of Ibex's ``Ctc3BCid`` and ``CtcAcid``) as a contractor.

For one variable ``x_i`` of the box, cut its range into :data:`SLICES` slices and run the cheap
contractor (propagation, :class:`~kinbox.search.ctc_propagation.CtcPropagation`) on the box
restricted to a slice, from the lower end up: a slice it proves empty is dropped, and the first
one it does not sets the new lower bound of ``x_i`` (3B); the same from the upper end down. Then
the box is the hull of what propagation kept of the first slice, of the last one, and of the
range between them (CID: every solution lies in one of the three, and each is narrowed soundly,
so their hull holds every solution and narrows the other variables too).

Soundness in floating point needs nothing beyond propagation's: the slices' ends are floats
``e_0 = lo < e_1 <= ... <= e_S = hi`` and consecutive slices share their ends, so the slices
cover the range exactly whatever the rounding of the ends; a slice is only dropped when the
sound contractor proves it holds no solution, and every bound comes from a box propagation kept
(``tests/search/test_ctc_shave.py``, against planted roots checked in exact arithmetic and python-flint's
``arb``).

Which variables, as in ACID: the widest first (relative to the root box), and the next one only
while the last one paid (removed :data:`VAR_GAIN` of log-volume or more) -- the number of
variables shaved adapts to the box; whether boxes are shaved at all is the policy's
:data:`SHAVE` gate, learnt from the counts of the tests that paid, the same on every run.

It is an optional step (``SolverOptions.extra_steps="shave"``, ``--extra-steps shave``): on the
quick benchmarks and the mechanisms it saved boxes on four problems of six but CPU on one
(Bricard), each slice being one more propagation call (``benchmarks/shaving.py``; the numbers
are in CONTRIBUTING.md).
"""

from __future__ import annotations

import math

import numpy as np

from .contract import Box, Context, Contraction, ContractStatus, Gate, Step
from .ctc_propagation import CtcPropagation
from .policy import register_gate

#: slices per variable: one end is shaved a slice at a time, at most this many
SLICES = 8
#: the next variable is shaved only while the last one removed this much log-volume
VAR_GAIN = 0.05
#: a shaving pays when it removes this much log-volume (or proves the box empty)
GAIN = 0.1
#: the gate: shaving runs on every box while this share of the recent tests paid, else on one
#: box in :data:`PROBE` (bits 48 on of the box identifier: other boxes than the other gates')
RATE, PROBE = 0.25, 8
SHAVE = register_gate(Gate("shave", RATE, PROBE, 48, start=1.0))


class CtcShave:
    """3BCID over the variables of ``mask``, widest first (relative to ``root_w``), with ``ctc``
    (propagation) as the contractor of each slice; ``slices`` per variable, the next variable
    only while the last one removed ``var_gain`` of log-volume."""

    def __init__(self, ctc: CtcPropagation, mask: np.ndarray, root_w: np.ndarray, slices: int = SLICES, var_gain: float = VAR_GAIN):
        if slices < 2:
            raise ValueError("shaving needs at least two slices per variable")
        self.ctc, self.mask, self.root_w = ctc, np.asarray(mask, dtype=bool), np.asarray(root_w, dtype=float)
        self.slices, self.var_gain = int(slices), float(var_gain)
        #: propagations run so far (the cost of the shavings, for benchmarks)
        self.calls = 0

    def _logvol(self, lo: np.ndarray, hi: np.ndarray) -> float:
        return float(np.sum(np.log(np.maximum((hi - lo) / self.root_w, 1e-30))))

    def _slice(self, lo: np.ndarray, hi: np.ndarray, i: int, a: float, b: float) -> Contraction:
        slo, shi = lo.copy(), hi.copy()
        slo[i], shi[i] = a, b
        self.calls += 1
        return self.ctc.contract(Box(slo, shi))

    def shave(self, lo: np.ndarray, hi: np.ndarray, i: int) -> tuple[np.ndarray, np.ndarray] | None:
        """3BCID on variable ``i`` of the box: the narrowed box, or None (no solution in it)."""
        a, b = float(lo[i]), float(hi[i])
        S = self.slices
        # the ends of the slices: e_0 = a, e_S = b, non-decreasing whatever the rounding
        ends = np.minimum(np.maximum.accumulate(np.array([a] + [a + (b - a) * k / S for k in range(1, S)] + [b])), b)
        ends[0], ends[-1] = a, b
        kl, left = 0, None
        while kl < S:
            c = self._slice(lo, hi, i, ends[kl], ends[kl + 1])
            if not c.empty:
                left = c
                break
            kl += 1
        if left is None:
            return None
        kr, right = S - 1, None
        while kr > kl:
            c = self._slice(lo, hi, i, ends[kr], ends[kr + 1])
            if not c.empty:
                right = c
                break
            kr -= 1
        pieces = [left] + ([right] if right is not None else [])
        if right is not None and kr > kl + 1:  # CID: the range between the two kept slices
            c = self._slice(lo, hi, i, ends[kl + 1], ends[kr])
            if not c.empty:
                pieces.append(c)
        nlo = np.maximum(lo, np.min([p.lo for p in pieces], axis=0))
        nhi = np.minimum(hi, np.max([p.hi for p in pieces], axis=0))
        return nlo, nhi

    def contract(self, box: Box, ctx: Context | None = None) -> Contraction:
        lo, hi = np.asarray(box[0], dtype=float).copy(), np.asarray(box[1], dtype=float).copy()
        lo0, hi0 = lo.copy(), hi.copy()
        rel = (hi - lo) / self.root_w
        order = [int(i) for i in np.argsort(-rel, kind="stable") if self.mask[i] and hi[i] > lo[i] and math.isfinite(hi[i] - lo[i])]
        for i in order:
            if not hi[i] > lo[i]:
                continue
            v0 = self._logvol(lo, hi)
            r = self.shave(lo, hi, i)
            if r is None:
                return Contraction(ContractStatus.EMPTY, lo0, hi0)
            lo, hi = r
            if v0 - self._logvol(lo, hi) < self.var_gain:
                break
        if np.array_equal(lo, lo0) and np.array_equal(hi, hi0):
            return Contraction(ContractStatus.NONE, lo0, hi0)
        return Contraction(ContractStatus.NARROWED, lo, hi)


def _build(proc) -> CtcShave | None:
    return CtcShave(proc.hc4, proc.split_mask, proc.root_w) if proc.comp.n > 0 else None


STEP = Step("shave", _build, SHAVE, GAIN, optional=True)
