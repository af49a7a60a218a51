"""The universal pair (Pinocchio's ``JointModelUniversal``): two revolute pairs in sequence about
orthogonal axes through one point, ``M(q) = exp(a1 q1) exp(a2 q2)`` in the joint's frame.

It is written as two revolute parts (:mod:`.revolute`: ``c, s`` of each angle with its limits),
the first at the joint's placement, the second at the frame the first rotation leaves; each
part's own motion is given to the formulation (``Part.motion``), since Pinocchio has no
sub-joint for it. ``q = (q1, q2)``: each angle read back as a revolute's.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ...errors import FormulationError
from .family import FamilyBase, Part, register


def _rotation(axis: np.ndarray, iq: int):
    def motion(q: np.ndarray) -> pin.SE3:
        return pin.SE3(pin.exp3(axis * float(q[iq])), np.zeros(3))

    return motion


class Universal(FamilyBase):
    """Universal: two revolute parts (``kind`` of each: ``"revolute"``)."""

    kind = "universal"
    rotation = "rev"
    translation = "none"
    pinocchio_types = ("Universal",)

    def parts(self, jmodel, short: str, placement: pin.SE3, path: tuple) -> list[Part]:
        ext = jmodel.extract() if hasattr(jmodel, "extract") else jmodel
        axes = []
        for a in (ext.axis1, ext.axis2):
            a = np.array(a, dtype=float)
            n = float(np.linalg.norm(a))
            if not (np.isfinite(n) and n > 1e-9):
                raise FormulationError(f"universal joint axis {a.tolist()} is not a unit vector")
            axes.append(a / n)
        iq = int(jmodel.idx_q)
        return [
            Part("revolute", placement, iq, 1, axes[0], path=path, motion=_rotation(axes[0], iq)),
            Part("revolute", pin.SE3.Identity(), iq + 1, 1, axes[1], path=path, motion=_rotation(axes[1], iq + 1)),
        ]

    def decode(self, part, variables, view):  # pragma: no cover - its parts are revolute parts
        raise FormulationError("internal: a universal joint is decoded by its revolute parts")


UNIVERSAL = register(Universal())
