"""The planar pair: in-plane displacements ``d[name][0], d[name][1]`` and a rotation about ``z``."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from .family import DecodeView, FamilyBase, Part, register
from .prismatic import displacement
from .revolute import revolute_angle

_Z = np.array([0.0, 0.0, 1.0])


class Planar(FamilyBase):
    """Planar: Pinocchio moves by ``(x, y, 0)`` in the frame before the motion, then rotates
    about ``z``: the in-plane displacements ``d[name][0], d[name][1]`` and a revolute rotation
    with an unlimited range."""

    kind = "planar"
    rotation = "rev"
    translation = "local"
    pinocchio_types = ("Planar",)

    def part(self, jmodel, short: str, placement: pin.SE3, path: tuple) -> Part:
        return Part(self.kind, placement, int(jmodel.idx_q), int(jmodel.nq), _Z.copy(), path=path)

    def angle(self, sys, name, part, lo, hi):
        return revolute_angle(sys, name)

    def displacements(self, sys, name, part, lo, hi):
        return [(displacement(sys, f"d[{name}][{k}]", name, float(lo[k]), float(hi[k])), np.eye(3)[k]) for k in range(2)]

    def decode(self, part: Part, variables: dict, view: DecodeView) -> np.ndarray:
        c, s = view.value(variables["c"]), view.value(variables["s"])
        nrm = math.hypot(c, s) or 1.0
        return np.array([view.value(v) for v in variables["d"]] + [c / nrm, s / nrm])


PLANAR = register(Planar())
