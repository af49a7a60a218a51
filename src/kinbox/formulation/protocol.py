"""What every formulation of a mechanism gives the stages after it (:class:`MechanismFormulation`).

A formulation writes a mechanism's (or one pose's) polynomial system and maps configurations to
system points and back. The general one (:class:`~kinbox.formulation.build.Formulation`), the
planar one (:class:`~kinbox.formulation.planar.PlanarFormulation`) and the arm templates' (
:class:`~kinbox.formulation.arm.ArmFormulation`) all have this shape; the answer stage and the
pipeline read a formulation through it only (mypy checks the three against it below).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

import numpy as np

from ..model.mechanism import Mechanism
from .system import System

if TYPE_CHECKING:
    from .arm import ArmFormulation
    from .build import Formulation
    from .planar import PlanarFormulation


class MechanismFormulation(Protocol):
    """A mechanism's system and the maps between its configurations and system points."""

    @property
    def kind(self) -> str:
        """The formulation's name: ``"general"``, ``"planar"``, ``"arm"`` or ``"invariants"``
        (what a result calls it: :attr:`kinbox.answer.result.Result.formulation`)."""
        ...

    @property
    def mechanism(self) -> Mechanism:
        """The mechanism (its Pinocchio model, locked joints and closures)."""
        ...

    @property
    def system(self) -> System:
        """The polynomial system the search solves."""
        ...

    @property
    def dropped_joints(self) -> list[str]:
        """Joints on no closure path and not locked: left out of the system (``q`` at neutral)."""
        ...

    @property
    def joint_vars(self) -> dict[str, list[str]]:
        """Every joint that enters the system -> the names of its variables."""
        ...

    @property
    def closure_vars(self) -> dict[str, list[str]]:
        """Closure name -> the names of its variables (unit vectors of distance closures)."""
        ...

    def encode(self, q: np.ndarray) -> np.ndarray:
        """The system point of a configuration ``q``."""
        ...

    def decode(self, x: np.ndarray) -> np.ndarray:
        """The configuration ``q`` of a system point ``x``."""
        ...

    @property
    def limits_after(self) -> bool:
        """Whether some joint limits are left out of the system, so that :meth:`admissible`
        is to be asked at each root (the arm templates: a joint without a variable of its own)."""
        ...

    def admissible(self, x: np.ndarray, width: float = 0.0) -> bool:
        """Are the joint values of a root at ``x`` (a box of ``width`` around it) inside the
        limits the system did not keep?"""
        ...


def _conforms(general: Formulation, planar: PlanarFormulation, arm: ArmFormulation) -> list[MechanismFormulation]:
    return [general, planar, arm]  # mypy: each formulation class has the protocol's members
