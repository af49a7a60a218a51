"""Kinematic families with closed-form inverse kinematics, read off an arm's geometry.

An arm of six revolute joints whose canonical frames (:func:`kinbox.formulation.arm.canonical`)
show one of these structures has an IK problem that splits into subproblems with at most two
solutions each (Paden-Kahan subproblems, Pieper's wrist centre):

* ``"wrist"``: lines 4, 5, 6 meet in one point (a spherical wrist: link 4 and link 5 without
  offset, no displacement along lines 5 and 6). The wrist centre is then the goal's position,
  and it is placed by joints 1, 2, 3 when lines 1 and 2 meet (``"wrist-meet"``: ``|w|`` decides
  joint 3) or when lines 2 and 3 are parallel (``"wrist-parallel"``: the offset along line 2
  decides joint 1); lines 4, 5, 6 then give the orientation (ZYZ-like);
* ``"parallel"``: lines 2, 3, 4 parallel and lines 5 and 6 meeting (the UR series): the
  offset along line 2 of the point where lines 5 and 6 meet decides joint 1, the direction of
  line 6 along line 2 decides joint 5, the rest of that direction joint 6, and joints 2, 3, 4
  are a planar arm.

The tests are exact comparisons on the numbers of the system's geometry (zeros and units of
the link matrices, as the formulation wrote them): a structure that holds only nearly is not
this family, and its pose is solved by the branch and prune. Nothing here looks at a name
(``tests/search/test_closed_form.py::test_detection_from_geometry_not_names``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .arm import Geometry, canonical

#: family codes used by the compiled solver (:mod:`kinbox.search.closed_form`)
FAMILY_CODES = {"wrist-meet": 1, "wrist-parallel": 2, "parallel": 3}


@dataclass
class Family:
    """A closed-form family of one arm: which, and the geometry it was found in (canonical
    frames of the chain, possibly the reversed one)."""

    name: str
    geometry: Geometry
    LR: np.ndarray  # (5, 3, 3) link rotations
    Lt: np.ndarray  # (5, 3) link translations
    d: np.ndarray  # (6,) offsets along the lines
    gamma: np.ndarray  # (6,) zero offsets: theta = q + gamma

    @property
    def code(self) -> int:
        return FAMILY_CODES[self.name]


def _parallel(R: np.ndarray) -> bool:
    """Does the link map line ``i+1``'s direction exactly onto ``+-`` line ``i``'s (``z`` column
    and ``z`` row of its rotation exactly ``+-e_z``)?"""
    return bool(R[0, 2] == 0.0 and R[1, 2] == 0.0 and R[2, 0] == 0.0 and R[2, 1] == 0.0 and abs(R[2, 2]) == 1.0)


def _meet(t: np.ndarray) -> bool:
    """Do two consecutive lines meet (the link's offset exactly zero)?"""
    return bool(np.all(t == 0.0))


def family_of(geom: Geometry) -> str | None:
    """The closed-form family of a geometry (exact tests, see the module docstring), or None."""
    if any(j.kind != "revolute" for j in geom.chain.joints):
        return None
    LR = [L.R for L in geom.links]
    Lt = [L.t for L in geom.links]
    d = geom.d
    if _meet(Lt[3]) and _meet(Lt[4]) and d[4] == 0.0 and d[5] == 0.0 and not _parallel(LR[3]) and not _parallel(LR[4]):
        if _meet(Lt[0]) and not _parallel(LR[0]):
            return "wrist-meet"
        if _parallel(LR[1]) and not _parallel(LR[0]):
            return "wrist-parallel"
    if _parallel(LR[1]) and _parallel(LR[2]) and _meet(Lt[4]) and not _parallel(LR[0]) and not _parallel(LR[3]) and not _parallel(LR[4]):
        return "parallel"
    return None


def _mirrored(geom: Geometry, name: str) -> bool:
    """Does ``geom`` itself show, read from its other end, the structure of family ``name``
    (exact tests on its own numbers)? Lines meeting and lines parallel do not depend on the
    direction a chain is read in: the reversed chain's link ``i`` is this chain's link ``4 - i``."""
    LR = [L.R for L in geom.links]
    Lt = [L.t for L in geom.links]
    d = geom.d
    if name.startswith("wrist"):  # lines 1, 2, 3 of this chain meet in a point
        if not (_meet(Lt[0]) and _meet(Lt[1]) and d[1] == 0.0):
            return False
        return _meet(Lt[4]) if name == "wrist-meet" else _parallel(LR[3])
    return _parallel(LR[3]) and _parallel(LR[2]) and _meet(Lt[0])  # lines 5, 4, 3 parallel, 2 and 1 meet


def detect(geom: Geometry) -> Family | None:
    """The family of an arm in the orientation of ``geom`` or, failing that, of the reversed
    chain (the same IK problem seen from the frame; the goal is then inverted). The structure
    must hold exactly in ``geom``'s own numbers, those the arm's system is written with, in
    either orientation."""
    for g in (geom, None):
        if g is None:
            try:
                g = canonical(geom.chain.reverse())
            except (np.linalg.LinAlgError, ValueError, ZeroDivisionError):  # pragma: no cover - degenerate chains
                return None
            name = family_of(g)
            if name is not None and not _mirrored(geom, name):
                return None
        else:
            name = family_of(g)
        if name is not None:
            LR = np.array([L.R for L in g.links], dtype=float)
            Lt = np.array([L.t for L in g.links], dtype=float)
            return Family(name, g, LR, Lt, np.array(g.d, dtype=float), np.array(g.gamma, dtype=float))
    return None
