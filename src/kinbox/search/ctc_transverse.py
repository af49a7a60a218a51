"""The transverse Krawczyk test as a contractor (:mod:`kinbox.search.transverse`)."""

from __future__ import annotations

from .certify import Certifier
from .contract import Box, Context, Contraction, ContractStatus, Step
from .policy import T_GAIN, TRANSVERSE
from .transverse import Transverse


class CtcTransverse:
    """Narrows the box across the graph of the core's zeros over the free variables; with
    ``ctx.graph``, also tries to prove that every zero of the box lies on one graph over one
    variable (``graph_box``, ``params``: a candidate curve box)."""

    def __init__(self, cert: Certifier):
        self.test = Transverse(cert)

    def contract(self, box: Box, ctx: Context | None = None) -> Contraction:
        t = self.test.contract(box[0], box[1], graph=ctx is not None and ctx.graph)
        return Contraction(ContractStatus(t.status), t.lo, t.hi, graph_box=t.graph_box, params=t.params)


def _build(proc) -> CtcTransverse | None:
    return CtcTransverse(proc.cert) if proc.comp.n_core > 0 else None


STEP = Step("transverse", _build, TRANSVERSE, T_GAIN, curve=True, not_after="krawczyk")
