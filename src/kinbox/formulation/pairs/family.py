"""What every pair family tells the formulation (:class:`PairFamily`), the registry of families,
and the split of a Pinocchio joint into its pairs (:func:`joint_parts`).

A family is one kind of elementary pair (revolute, prismatic, ...). It says which Pinocchio
joint types it covers, how the child frame's orientation follows the parent's, which
variables carry its motion (with the joint limits as their domain), and how to read the joint's
``q`` back from a system point. :mod:`kinbox.formulation.build` walks the kinematic tree and
asks the family of each edge; adding a pair means adding one module here and registering it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import pinocchio as pin

from ...errors import FormulationError
from ..system import Expr
from .algebra import Equations


@dataclass
class Part:
    """One elementary pair of a Pinocchio joint (a composite joint has several, in sequence).

    The motion of the part is ``placement * motion(q)``, with ``kind`` the name of its
    :class:`PairFamily`. ``idx_q``/``nq``: its entries of the Pinocchio ``q``; ``unbounded``: a
    continuous revolute (``nq = 2``, ``q = (cos, sin)``); ``path``: see :func:`sub_joint`.
    """

    kind: str
    placement: pin.SE3
    idx_q: int
    nq: int
    axis: np.ndarray | None = None
    unbounded: bool = False
    #: where the part sits in a composite joint: indices into ``.joints`` of nested composites
    path: tuple = ()
    #: the part's own motion at the model's ``q``, for a part that is not a whole (sub-)joint
    #: of Pinocchio's (each rotation of a universal joint); None: the motion of the joint at
    #: ``path`` (:func:`sub_joint`)
    motion: Callable[[np.ndarray], pin.SE3] | None = None


@dataclass
class DecodeView:
    """What a family's :meth:`PairFamily.decode` may read at a system point."""

    #: value of a variable's expression (an ``Expr`` or a float) at the point
    value: Callable[[Any], float]
    #: ``R_pre^T R_child``: the rotation of the part's motion (frame after over frame before)
    relative_rotation: Callable[[], np.ndarray]
    #: the part's translation in the frame before its motion
    relative_translation: Callable[[], np.ndarray]
    #: the model's position limits of the joint's ``q`` entries
    lo: np.ndarray
    hi: np.ndarray


class PairFamily(Protocol):
    """One kind of pair: its variables, their limits, its equations and its decoding."""

    @property
    def kind(self) -> str:
        """The ``Part.kind`` of its parts."""
        ...

    @property
    def rotation(self) -> str:
        """How the child frame's orientation follows the parent's: ``"rev"`` (a rotation about
        the part's axis by an angle whose ``c, s`` are variables: :meth:`angle`), ``"const"`` (a
        constant rotation), ``"free"`` (not determined: a free rotation of the frame)."""
        ...

    @property
    def translation(self) -> str:
        """The part's own translation: ``"none"``, ``"local"`` (variables along directions of
        the frame before the motion: :meth:`displacements`) or ``"world"`` (a free-flyer's world
        position, eliminated after the formulation)."""
        ...

    @property
    def pinocchio_types(self) -> tuple[str, ...]:
        """Pinocchio joint types (short names without ``JointModel``) that are one part of
        this kind."""
        ...

    @property
    def label(self) -> str:
        """How the supported types are named to a user (``"revolute, continuous"``; empty: the
        kind)."""
        ...

    def part(self, jmodel, short: str, placement: pin.SE3, path: tuple) -> Part:
        """The part of a Pinocchio joint of one of :attr:`pinocchio_types`."""
        ...

    def parts(self, jmodel, short: str, placement: pin.SE3, path: tuple) -> list[Part]:
        """The parts of such a joint, in sequence (one: :meth:`part`; a universal joint: two
        revolute parts)."""
        ...

    def angle(self, sys: Equations, name: str, part: Part, lo: np.ndarray, hi: np.ndarray) -> tuple[Expr, Expr]:
        """``c[name], s[name]`` of a ``"rev"`` family, limited by ``lo, hi`` where they apply."""
        ...

    def displacements(self, sys: Equations, name: str, part: Part, lo: np.ndarray, hi: np.ndarray) -> list[tuple[Expr, np.ndarray]]:
        """The variables of a ``"local"`` translation, each with its direction in the frame
        before the motion (the joint limits are their domains)."""
        ...

    def decode(self, part: Part, variables: dict, view: DecodeView) -> np.ndarray | None:
        """The part's ``q`` entries at a point (``None``: a part with no ``q`` of its own)."""
        ...

    def limits_search(self, part: Part, lo: np.ndarray, hi: np.ndarray) -> bool:
        """Whether the model's limits narrow the search (reported with the answer)."""
        ...


#: family name -> family; filled by the family modules (see :mod:`kinbox.formulation.pairs`)
FAMILIES: dict[str, PairFamily] = {}
_BY_TYPE: dict[str, PairFamily] = {}


def register(fam: PairFamily) -> PairFamily:
    FAMILIES[fam.kind] = fam
    for t in fam.pinocchio_types:
        _BY_TYPE[t] = fam
    return fam


def family(kind: str) -> PairFamily:
    """The registered family of a ``Part.kind`` (or of ``"fixed"``/``"weld"`` edges)."""
    return FAMILIES[kind]


def joint_axis(jmodel, revolute: bool) -> np.ndarray:
    """Unit axis of an unaligned revolute/prismatic joint model.

    Read from ``.axis`` where the Python binding has it, else measured from the joint's own
    motion (``calc``) at a quarter turn / unit displacement (the binding of
    ``RevoluteUnboundedUnaligned`` has no ``axis``).
    """
    ext = jmodel.extract()
    if "axis" in type(ext).__dict__ or hasattr(type(ext), "axis"):
        a = np.array(ext.axis, dtype=float)
    else:
        iq = int(jmodel.idx_q)
        q = np.zeros(iq + int(jmodel.nq))
        if int(jmodel.nq) == 2:  # continuous: (cos, sin) of a quarter turn
            q[iq : iq + 2] = [0.0, 1.0]
        else:
            q[iq] = 1.0 if not revolute else math.pi / 2
        jd = jmodel.createData()
        jmodel.calc(jd, q)
        a = pin.log3(jd.M.rotation) / (math.pi / 2) if revolute else np.array(jd.M.translation)
    n = float(np.linalg.norm(a))
    if not (math.isfinite(n) and n > 1e-9):
        raise FormulationError(f"joint axis {a.tolist()} is not a unit vector")
    return a / n


def joint_parts(jmodel, name: str, placement: pin.SE3 | None = None, path: tuple = ()) -> list[Part]:
    """The pairs of a Pinocchio joint model, in sequence: one part of the family that lists the
    joint's type, or the parts of each sub-joint of a composite joint, in order.

    Types no family lists (helical, mimic, ellipsoid) raise
    :class:`FormulationError` naming the joint and its type.
    """
    placement = pin.SE3.Identity() if placement is None else placement
    short = jmodel.shortname().replace("JointModel", "")
    fam = _BY_TYPE.get(short)
    if fam is not None:
        return fam.parts(jmodel, short, placement, path)
    if short == "Composite":
        comp = jmodel.extract()
        parts: list[Part] = []
        for k, (sub, P) in enumerate(zip(comp.joints, comp.jointPlacements)):
            Pk = placement * P if k == 0 else pin.SE3(P)
            parts += joint_parts(sub, name, Pk, path + (k,))
        return parts
    raise FormulationError(
        f"joint {name!r} has type {short}, which kinbox does not support "
        f"(supported: {supported()} and composites of them); lock it to leave it out"
    )


def supported() -> str:
    """The joint types the registered families cover, named for a user."""
    return ", ".join(f.label or f.kind.replace("_", " ") for f in FAMILIES.values() if f.pinocchio_types)


def part_limits(model, part: Part) -> tuple[np.ndarray, np.ndarray]:
    """The model's position limits of the part's ``q`` entries (lower, upper)."""
    sl = slice(part.idx_q, part.idx_q + part.nq)
    return (np.asarray(model.lowerPositionLimit[sl], dtype=float), np.asarray(model.upperPositionLimit[sl], dtype=float))


def sub_joint(jmodel, path: tuple):
    """The sub-joint model of a (nested) composite joint at ``path`` (the joint itself for ())."""
    for k in path:
        jmodel = jmodel.extract().joints[k]
    return jmodel


class FamilyBase:
    """The attributes of a :class:`PairFamily`, and defaults for the hooks a family without a
    rotation angle or a local translation does not need."""

    kind: str
    rotation: str
    translation: str
    pinocchio_types: tuple[str, ...] = ()

    #: how a user reads the types it covers (empty: the kind)
    label: str = ""

    def part(self, jmodel, short: str, placement: pin.SE3, path: tuple) -> Part:  # pragma: no cover - a family bug
        raise FormulationError(f"internal: pair family {self.kind!r} makes no single part")

    def parts(self, jmodel, short: str, placement: pin.SE3, path: tuple) -> list[Part]:
        return [self.part(jmodel, short, placement, path)]

    def angle(self, sys, name, part, lo, hi):  # pragma: no cover - a formulation bug
        raise FormulationError(f"internal: pair {name!r} has no rotation angle")

    def displacements(self, sys, name, part, lo, hi):
        return []

    def limits_search(self, part, lo, hi) -> bool:
        return False
