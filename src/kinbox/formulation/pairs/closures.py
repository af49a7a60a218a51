"""Closures: the loop equations between two points (point and weld closures), the orientation
part of a weld, and spherical-spherical legs of a given length (Porta, Ros and Thomas 2009, Eq. 23 and Table III)."""

from __future__ import annotations

import numpy as np

from ..errfloat import num, square
from ..system import Expr, System, degree
from .algebra import PLACEHOLDER_BOUND, Rot, add_eq, add_ineq, columns, mat_mul_const, simplify, vadd, vdot, vscale, vsub


def weld_orientation(sys: System, name: str, Ra: Rot, Ka: np.ndarray, Rb: Rot, Kb: np.ndarray) -> None:
    """Orientation part of a weld between two reached frames: ``(Ra Ka)^T (Rb Kb) = I``.

    With ``M = (Ra Ka)^T (Rb Kb)``: core ``M[1,0] = M[2,0] = M[2,1] = 0``; inequalities
    ``M[k,k] >= 0``; redundant ``M[0,1] = M[0,2] = M[1,2] = 0``, ``M[k,k] = 1``. (An orthogonal
    matrix with a zero lower triangle and a non-negative diagonal is the identity.) Also the
    closing equation of a prismatic/translation pair or a locked joint on a cycle.
    """
    A = columns(mat_mul_const(Ra.linear(), Ka))
    Bc = columns(mat_mul_const(Rb.linear(), Kb))

    def M(i, j):
        return vdot(A[i], Bc[j])

    for i, j in ((1, 0), (2, 0), (2, 1)):
        add_eq(sys, M(i, j), f"weld:{name}[{i},{j}]")
    for k in range(3):
        add_ineq(sys, -M(k, k), f"weld-sign:{name}[{k}]")
    for i, j in ((0, 1), (0, 2), (1, 2)):
        add_eq(sys, M(i, j), f"weld:{name}[{i},{j}]", redundant=True)
    for k in range(3):
        add_eq(sys, M(k, k) - 1.0, f"weld:{name}[{k},{k}]", redundant=True)


def point_closure(sys: System, name: str, pa: list, pb: list) -> None:
    """A loop equation (Eq. 23): the points ``pa`` and ``pb`` coincide (3 core equations)."""
    for k in range(3):
        add_eq(sys, simplify(pa[k] - pb[k]), f"loop:{name}[{k}]")


def unit_vector(sys: System, name: str) -> list[Expr]:
    """A unit vector ``dir[name]`` (3 variables in ``[-1, 1]``, core ``|d|^2 = 1``)."""
    d = [sys.add_var(f"dir[{name}][{k}]", -1.0, 1.0, "unit") for k in range(3)]
    add_eq(sys, vdot(d, d) - 1.0, f"unit:dir[{name}]")
    return d


def distance_closure(sys: System, name: str, pa: list, pb: list, length: float, squared: bool = True) -> list[Expr]:
    """Spherical-spherical leg: ``|pb - pa| = l``.

    ``length`` is a float, or an :class:`~kinbox.formulation.errfloat.EF` in the shadow build
    (:mod:`kinbox.formulation.enclose_rows`): ``l^2`` is then a rounded square with its error
    (:func:`~kinbox.formulation.errfloat.square`), ``l d`` exact in ``l``.

    When ``squared`` and both end points are linear in unknowns with real (finite, not
    placeholder) domains, ``|pb - pa|^2 = l^2`` (1 core equation): a platform's translation then
    stays a variable.
    Otherwise Table III, last row: ``pa + l d = pb``, ``|d| = 1`` with a unit vector ``d``
    (4 core equations, 3 variables), which is returned. A zero length is a point closure.
    """
    if length == 0.0:
        point_closure(sys, name, pa, pb)
        return []
    ends = list(pa) + list(pb)
    used = {i for v in ends if isinstance(v, Expr) for i in v.variables()}
    bounded = all(max(abs(sys.lo[i]), abs(sys.hi[i])) < PLACEHOLDER_BOUND for i in used)
    if squared and bounded and all(degree(v) <= 1 for v in ends):
        # both ends linear in the unknowns (e.g. a base point and t + R q on a platform):
        # |pb - pa|^2 = l^2 is already quadratic: 1 core equation, no new variables
        diff = vsub(pb, pa)
        add_eq(sys, vdot(diff, diff) - square(length), f"dist:{name}")
        return []
    d = unit_vector(sys, name)
    point_closure(sys, name, vadd(pa, vscale(num(length), d)), pb)
    return d
