"""The LP over the Bernstein polytope (Fünfzig et al. 2010) as a contractor (:mod:`kinbox.search.bernstein`)."""

from __future__ import annotations

import numpy as np

from ..formulation.system import Compiled
from .bernstein import BernsteinRelaxation
from .ctc_linear import LP_VAR_PAYS, CtcLP


class CtcBernstein(CtcLP):
    """The Bernstein relaxation of each box's unit box (Fünfzig et al. 2010), one SHRINK-BOX round."""

    def __init__(self, comp: Compiled, mask: np.ndarray, root_w: np.ndarray, pay: float = LP_VAR_PAYS):
        super().__init__(BernsteinRelaxation(comp, mask, root_w, pay))
