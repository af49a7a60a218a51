"""The translation pair (three prismatic pairs): ``d[name][k]``, the joint limits as domains."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from .family import Part, register
from .prismatic import Prismatic, displacement


class Translation(Prismatic):
    """Translation: three prismatic pairs, ``d[name][k]``; orientation ``R_child = R_pre``,
    position term ``R_pre (x, y, z)``."""

    kind = "translation"
    pinocchio_types = ("Translation",)

    def part(self, jmodel, short: str, placement: pin.SE3, path: tuple) -> Part:
        return Part(self.kind, placement, int(jmodel.idx_q), int(jmodel.nq), path=path)

    def displacements(self, sys, name, part, lo, hi):
        return [(displacement(sys, f"d[{name}][{k}]", name, float(lo[k]), float(hi[k])), np.eye(3)[k]) for k in range(3)]

    def limits_search(self, part: Part, lo: np.ndarray, hi: np.ndarray) -> bool:
        return False


TRANSLATION = register(Translation())
