"""Constant relations between two frames: a locked joint (its motion at the locked value) and
the orientation part of a weld closure. No variables; the orientation is ``R_child = R_parent K``
(:func:`~.algebra.const_propagate`), closed on a cycle by :func:`~.closures.weld_orientation`."""

from __future__ import annotations

import pinocchio as pin

from ...errors import FormulationError
from .family import DecodeView, FamilyBase, Part, register


class Fixed(FamilyBase):
    """A constant relative pose (``kind``: ``"fixed"`` for a locked joint, ``"weld"``)."""

    rotation = "const"
    translation = "none"
    pinocchio_types = ()

    def __init__(self, kind: str):
        self.kind = kind

    def part(self, jmodel, short: str, placement: pin.SE3, path: tuple) -> Part:  # pragma: no cover
        raise FormulationError(f"internal: a {self.kind} edge is not a joint's part")

    def decode(self, part: Part, variables: dict, view: DecodeView) -> None:
        return None


FIXED = register(Fixed("fixed"))
WELD = register(Fixed("weld"))
