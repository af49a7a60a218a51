"""The prismatic pair: ``d[name]``, its joint limits as domain (Porta, Ros and Thomas 2009, Table III, ``delta_i``).
Infinite limits raise :class:`FormulationError` (lock the joint or give it limits)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ...errors import FormulationError
from ..system import Expr
from .algebra import Equations, finite_limit
from .family import DecodeView, FamilyBase, Part, joint_axis, register

_AXES = {"X": np.array([1.0, 0.0, 0.0]), "Y": np.array([0.0, 1.0, 0.0]), "Z": np.array([0.0, 0.0, 1.0])}


def displacement(sys: Equations, var: str, joint: str, lo: float, hi: float) -> Expr:
    """A displacement variable ``var`` of ``joint`` with domain ``[lo, hi]`` (finite)."""
    if not finite_limit(lo, hi):
        raise FormulationError(f"joint {joint!r} has no finite position limits ([{lo:g}, {hi:g}]); give it limits or lock it")
    if lo > hi:
        raise FormulationError(f"joint {joint!r} has an empty range [{lo}, {hi}]")
    return sys.add_var(var, lo, hi, "disp")


class Prismatic(FamilyBase):
    """PX, PY, PZ, PrismaticUnaligned: ``d[name]``; orientation ``R_child = R_parent Rp``,
    position term ``d R_pre a``."""

    kind = "prismatic"
    rotation = "const"
    translation = "local"
    pinocchio_types: tuple[str, ...] = ("PX", "PY", "PZ", "PrismaticUnaligned")

    def part(self, jmodel, short: str, placement: pin.SE3, path: tuple) -> Part:
        axis = _AXES[short[1]].copy() if short in ("PX", "PY", "PZ") else joint_axis(jmodel, False)
        return Part(self.kind, placement, int(jmodel.idx_q), int(jmodel.nq), axis, path=path)

    def displacements(self, sys, name, part, lo, hi):
        return [(displacement(sys, f"d[{name}]", name, float(lo[0]), float(hi[0])), part.axis * 1.0)]

    def decode(self, part: Part, variables: dict, view: DecodeView) -> np.ndarray:
        return np.array([view.value(v) for v in variables["d"]])

    def limits_search(self, part: Part, lo: np.ndarray, hi: np.ndarray) -> bool:
        return bool(np.isfinite(lo[0]) and np.isfinite(hi[0]))


PRISMATIC = register(Prismatic())
