"""The free-flyer pair: a free rotation of its frame (:mod:`.spherical`) and the frame's world
position ``t[name]``, eliminated after the formulation (:meth:`System.eliminate_linear`)."""

from __future__ import annotations

import numpy as np

from ..system import Expr, System
from .algebra import add_ineq, finite_limit, lincomb, vsub
from .family import DecodeView, Part, register
from .spherical import Spherical, quaternion


def free_flyer_translation(sys: System, name: str, lo: np.ndarray, hi: np.ndarray) -> list[Expr]:
    """World position ``t[name][k]`` of a free-flyer's frame, domain ``[lo, hi]``.

    The formulation eliminates these variables afterwards (:meth:`System.eliminate_linear`),
    so the domain is a placeholder unless the elimination is impossible. Joint limits (on the
    translation in the frame before the motion) are :func:`free_flyer_limits`.
    """
    return [sys.add_var(f"t[{name}][{k}]", lo[k], hi[k], "disp") for k in range(3)]


def free_flyer_limits(sys: System, name: str, t: list, base: list, R_pre: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> None:
    """Inequalities ``lo <= R_pre^T (t - base) <= hi`` for a free-flyer whose frame before the
    motion has a constant orientation ``R_pre`` (linear in ``t``; skipped for infinite limits)."""
    rel = vsub(t, base)
    for k in range(3):
        if not finite_limit(lo[k], hi[k]):
            continue
        v = lincomb(R_pre[:, k], rel)
        add_ineq(sys, v - float(hi[k]), f"limit:{name}[{k}]:hi")
        add_ineq(sys, float(lo[k]) - v, f"limit:{name}[{k}]:lo")


class FreeFlyer(Spherical):
    """FreeFlyer: ``q = (translation in the frame before the motion, quaternion)``."""

    kind = "free"
    label = "free-flyer"
    translation = "world"
    pinocchio_types = ("FreeFlyer",)

    def decode(self, part: Part, variables: dict, view: DecodeView) -> np.ndarray:
        return np.concatenate([view.relative_translation(), quaternion(view.relative_rotation())])


FREE_FLYER = register(FreeFlyer())
