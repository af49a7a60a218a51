"""Pairs that rotate freely: spherical (quaternion or ZYX angles) and, for its orientation, the
free-flyer. Their frames' orientations are free rotations (Porta, Ros and Thomas 2009, Eqs. 3-6): 9 variables, 6 core
equations; the pair itself has no variable and no equation."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..system import System
from .algebra import Rot, add_eq, from_columns, vcross, vdot
from .family import DecodeView, FamilyBase, Part, register


def free_rotation(sys: System, frame: str) -> Rot:
    """A free rotation ``R = [u v w]`` (spherical pair, free-flyer): 9 variables ``R[frame][r,k]``.

    Core ``|u|^2 = 1, |v|^2 = 1, u . v = 0, w = u x v`` (Eqs. 3-6: 6 equations, 3 degrees of
    freedom, ``det R = +1``); redundant ``|w|^2 = 1, u . w = 0, v . w = 0``.
    """
    # u and v are unknowns; w = u x v is derived ("aux": the solver never splits it)
    cols = [[sys.add_var(f"R[{frame}][{r},{k}]", -1.0, 1.0, "rot" if k < 2 else "aux") for r in range(3)] for k in range(3)]
    u, v, w = cols
    add_eq(sys, vdot(u, u) - 1.0, f"unit:R[{frame}][0]")
    add_eq(sys, vdot(v, v) - 1.0, f"unit:R[{frame}][1]")
    add_eq(sys, vdot(u, v), f"ortho:R[{frame}][0,1]")
    uxv = vcross(u, v)
    for r in range(3):
        add_eq(sys, w[r] - uxv[r], f"cross:R[{frame}][{r}]")
    add_eq(sys, vdot(w, w) - 1.0, f"unit:R[{frame}][2]", redundant=True)
    add_eq(sys, vdot(u, w), f"ortho:R[{frame}][0,2]", redundant=True)
    add_eq(sys, vdot(v, w), f"ortho:R[{frame}][1,2]", redundant=True)
    return Rot(from_columns(cols))


def project_rotation(R: np.ndarray) -> np.ndarray:
    """The rotation matrix nearest to ``R`` (Frobenius norm)."""
    U, _, Vt = np.linalg.svd(R)
    D = np.diag([1.0, 1.0, float(np.sign(np.linalg.det(U @ Vt)) or 1.0)])
    return U @ D @ Vt


def quaternion(R: np.ndarray) -> np.ndarray:
    """Unit quaternion ``(x, y, z, w)`` of a rotation matrix (projected first), ``w >= 0``."""
    qv = pin.Quaternion(project_rotation(R)).coeffs().copy()
    qv /= np.linalg.norm(qv)
    return -qv if qv[3] < 0 else qv


def zyx_angles(R: np.ndarray) -> np.ndarray:
    """Angles ``(z, y, x)`` of ``R = Rz Ry Rx`` (Pinocchio's ``SphericalZYX`` ordering)."""
    r, p, y = pin.rpy.matrixToRpy(project_rotation(R))
    return np.array([y, p, r])


class Spherical(FamilyBase):
    """Spherical: ``q`` a unit quaternion of the relative rotation."""

    kind = "spherical"
    rotation = "free"
    translation = "none"
    pinocchio_types = ("Spherical",)

    def part(self, jmodel, short: str, placement: pin.SE3, path: tuple) -> Part:
        return Part(self.kind, placement, int(jmodel.idx_q), int(jmodel.nq), path=path)

    def decode(self, part: Part, variables: dict, view: DecodeView) -> np.ndarray:
        return quaternion(view.relative_rotation())


class SphericalZYX(Spherical):
    """SphericalZYX: ``q`` the Euler angles ``(z, y, x)`` of the relative rotation."""

    kind = "spherical_zyx"
    label = "spherical ZYX"
    pinocchio_types = ("SphericalZYX",)

    def decode(self, part: Part, variables: dict, view: DecodeView) -> np.ndarray:
        return zyx_angles(view.relative_rotation())


SPHERICAL = register(Spherical())
SPHERICAL_ZYX = register(SphericalZYX())
