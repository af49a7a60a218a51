"""The Krawczyk operator on the square core as a contractor (:mod:`kinbox.search.certify`)."""

from __future__ import annotations

import numpy as np

from .certify import Certifier
from .contract import Box, Context, Contraction, ContractStatus, Step
from .policy import KRAWCZYK

#: a box narrower than this whose test is inconclusive is tested again inflated
INFLATE_BELOW = 1e-4


class CtcKrawczyk:
    """The Krawczyk operator on the square core: empty, unique (with the proof box), or narrowed.

    A box whose test is inconclusive is tested again inflated (epsilon-inflation) when it is tiny
    (narrower than ``inflate_below``) or thinner in some coordinate than the width ``K`` has even
    for a point box (the error of ``F(x0)`` and the rows' slack through ``Y``: propagation pins
    some variables to a sliver, and no box that thin can be proven unique). A zero proven unique
    in the inflated box is the only candidate of the box; the enclosure returned may lie outside
    the box (then the box is empty).
    """

    def __init__(self, cert: Certifier, inflate_below: float = INFLATE_BELOW):
        self.cert = cert
        self.inflate_below = inflate_below

    def contract(self, box: Box, ctx: Context | None = None) -> Contraction:
        lo, hi = box
        k = self.cert.krawczyk(lo, hi)
        if k.status == "empty":
            return Contraction(ContractStatus.EMPTY, lo, hi)
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
                return Contraction(ContractStatus.EMPTY, lo, hi)  # the only candidate lies outside the box
            return Contraction(ContractStatus.UNIQUE, k.lo, k.hi, proof=(vlo, vhi))
        if k.status == "contracted":  # the certifier's word for a narrower box
            return Contraction(ContractStatus.NARROWED, k.lo, k.hi)
        return Contraction(ContractStatus.NONE, lo, hi)


#: Krawczyk tests again on a box its last test (and propagation after it) narrowed by at least
#: :data:`K_GAIN` of log-volume, at most this many times: the contraction of a box next to a
#: root is quadratic while it pays, and a box split instead came back a wave later for the same
#: test (benchmarks/ur_poses.py: fewer boxes over 100 UR5 poses than without the repeats)
K_REPEATS = 3
#: a Krawczyk test pays when it removes this much log-volume (or proves the box empty or unique)
K_GAIN = 0.1
#: Krawczyk runs on every box narrower than this many sigma, whatever its gate says: isolated
#: roots get certified there
K_ALWAYS_BELOW = 2.0


def _build(proc) -> CtcKrawczyk | None:
    """The processor's own (its acceptance rules certify with it too); None: not a square core
    or ``certify=False``."""
    return proc.krawczyk


STEP = Step("krawczyk", _build, KRAWCZYK, K_GAIN, repeats=K_REPEATS, always_below=K_ALWAYS_BELOW, without_lp=True)
