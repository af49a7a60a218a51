"""Certifying one point: the search stage's single entry for the answer stage.

The answer stage finds points the search left uncertified (a root on a face between two
boxes, a candidate assembly decoded from another formulation) and asks for their proof here:
the same Krawczyk test, domain and inequality checks as a box of the search, on a tiny box
around the point. It never builds search machinery itself
(tests/answer/test_answer.py::test_answer_stage_builds_no_search_machinery).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ..formulation.system import System
from .boxes import SolutionBox
from .options import SolverOptions

#: half-width of the box around a point, relative to ``1 + |x|``
POINT_RADIUS = 1e-9
#: a Newton polish of the point is kept when the core equations hold this well at its end
POLISHED = 1e-10

#: ``prove(x, newton_iters=0)``: a certified solution box around ``x``, or None
PointCertifier = Callable[..., "SolutionBox | None"]


def point_certifier(system: System) -> PointCertifier:
    """A function ``prove(x, newton_iters=0)`` for points of ``system``: the certified solution
    box (one root, proven by Krawczyk, inside the domain, inequalities holding) of a box of
    relative half-width :data:`POINT_RADIUS` around ``x`` -- first moved by up to
    ``newton_iters`` Newton steps on the square core when those end on a root to
    :data:`POLISHED` -- or None where no proof is found (a singular root, a point off the
    solution set, a system that is not square). The box processor behind it is built at the
    first call, once per function."""
    from .processor import BoxProcessor  # the kernels load only when a point is proven

    made: list[BoxProcessor] = []

    def prove(x: np.ndarray, newton_iters: int = 0) -> SolutionBox | None:
        if not made:
            made.append(BoxProcessor(system, SolverOptions(lp=False)))
        proc = made[0]
        x = np.asarray(x, dtype=float)
        if newton_iters > 0:
            if not proc.cert.square:
                return None
            y = proc.cert.newton(x, iters=newton_iters)
            if np.all(np.isfinite(y)) and np.max(np.abs(proc.cert.F(y)), initial=0.0) <= POLISHED:
                x = y
        r = POINT_RADIUS * (1.0 + np.abs(x))
        o = proc.process(x - r, x + r)
        return o.solution if o.solution is not None and o.solution.certified else None

    return prove


class SeededCertifier:
    """Proofs for the answer stage about a point the search left uncertified next to a
    singularity (:mod:`kinbox.search.seeded`): :meth:`prove` certifies the root Newton reaches
    from it in a box grown about Newton's point, with the same domain and inequality checks as
    a box of the search; :meth:`settles` says whether a box of the search holds that root or
    nothing. The box processor behind it is built at the first call."""

    def __init__(self, system: System):
        self.system = system
        self._proc: Any = None  # a BoxProcessor, built at the first call

    def _processor(self):
        if self._proc is None:
            from .processor import BoxProcessor  # the kernels load only when a point is proven

            self._proc = BoxProcessor(self.system, SolverOptions(lp=False))
        return self._proc

    def prove(self, x: np.ndarray) -> SolutionBox | None:
        """A certified solution box (its ``lo``, ``hi`` the region proven to hold exactly one
        root, its ``enclosure`` that root's) about the root Newton reaches from ``x``, or None."""
        from .seeded import prove_about

        proc = self._processor()
        cert = proc.cert
        if not cert.square:
            return None
        y = cert.newton(np.asarray(x, dtype=float), iters=NEWTON_STEPS)
        if not np.all(np.isfinite(y)):
            return None
        found = prove_about(cert, y)
        if found is None:
            return None
        _, (blo, bhi, klo, khi) = found
        o = proc.accept.certified(blo, bhi, klo, khi)
        return o.solution if o.solution is not None and o.solution.certified else None

    def settles(self, lo: np.ndarray, hi: np.ndarray, proof: SolutionBox) -> bool:
        """Is every solution the search kept in ``[lo, hi]`` the root of ``proof`` (a box of
        :meth:`prove`)? True when the box lies in the proof's region, when Krawczyk proves the
        hull of the two to hold exactly one zero (then the proof's), or when it proves the box
        empty (no zero of the rows within their slacks); False decides nothing."""
        lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
        if np.all(lo >= proof.lo) and np.all(hi <= proof.hi):
            return True
        cert = self._processor().cert
        k = cert.krawczyk(np.minimum(lo, proof.lo), np.maximum(hi, proof.hi), proof.x)
        if k.status == "unique":
            return True
        return cert.krawczyk(lo, hi).status == "empty"


#: Newton steps on the core from the point :meth:`SeededCertifier.prove` is given
NEWTON_STEPS = 30
