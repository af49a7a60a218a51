"""A constraint system's core rows as enclosures of the input as given.

The coordinate formulation (:mod:`kinbox.formulation.geometry`) and the distance formulation
(:mod:`kinbox.formulation.distance`) write their rows from the input's binary64 numbers and
numbers computed from them in binary64: a distance's square, a squared distance's square root
squared again, an angle's cosine or sine, a direction divided by its length, a plane's offset
``normal . point``, the squared distances between fixed points (or a body's), products of
those in the Cayley-Menger determinants, the inverse of the anchors' matrix in the
trilateration. The input *as given* is the file's numbers as binary64 values, taken exactly
(a direction stands for its exact unit vector, a ``squared`` distance for its exact square
root, an angle for its exact cosine and sine).

Each formulation is written a second time (*the shadow build*) with every input number an
:class:`~kinbox.formulation.errfloat.EF` (:class:`EnclosedNumbers`): its binary64 value, bit for
bit the first build's, and a bound on its distance to the exact number (zero for the file's own
numbers; the derived ones enclosed in 120-bit interval arithmetic, or computed exactly in
rationals: the squared distances of fixed points, the trilateration's inverse matrix). Every sum
and product of the build carries the bound through, so each core row's coefficients end with
a bound on their distance to the exact row's; :func:`kinbox.formulation.enclose_rows.core_errors`
turns them into ``merr`` and ``mgrad`` per core row (``System.core_errors``), and Krawczyk's
proofs and every slack hold for the input as given
(``tests/formulation/test_enclose_constraints.py``).

An angle of binary64 ``pi/2`` between lines or planes (``pi`` between a line and a plane) is
written as the one row ``u . v = 0``; ``pi/2`` and ``pi`` are not binary64 numbers, and the exact
angle's row is ``u . v = +-t`` (``t`` its cosine, 6.1e-17, or sine, 1.2e-16): the shadow build
gives the row an error ``t`` (:meth:`EnclosedNumbers.snapped`), so the proof covers both senses.

Not covered (the rows stay as rounded, ``System.core_errors`` None): an angle written as one
shared direction (binary64 ``pi`` between lines or planes, ``pi/2`` between a line and a plane:
the exact angle leaves a cone of directions, no row to carry it), and any system whose shadow
build differs from the first build in its variables or core rows.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from fractions import Fraction
from typing import Any

import numpy as np
from mpmath import iv

from ..errors import FormulationError
from ..model.constraints import Constraint, ConstraintSystem, Entity
from . import constants as K
from .enclose_rows import NotEnclosed, _precision, core_errors
from .errfloat import EF
from .geometry import Numbers
from .system import System


def _up(x: Fraction) -> float:
    """A float at least ``x`` (``x >= 0``)."""
    f = float(x)
    if Fraction(f) < x:
        f = math.nextafter(f, math.inf)
    return f


def _exact_error(value: float, exact: Fraction | int) -> EF:
    return EF(value, _up(abs(Fraction(value) - exact)))


class EnclosedNumbers(Numbers):
    """The input's numbers as :class:`EF`: the values :class:`~kinbox.formulation.geometry.Numbers`
    gives, bit for bit, each with a bound on its distance to the exact number of the input."""

    def value(self, m: ConstraintSystem, c: Constraint) -> Any:
        v = m.value(c)
        if not c.squared:
            return EF(v, 0.0)  # the file's number itself
        raw = m.parameters[c.param] if c.param is not None else c.value
        assert raw is not None  # the model checked every distance's value
        with _precision():
            return EF(v, K._dist(iv.sqrt(iv.mpf(float(raw))), v))

    def trig(self, m: ConstraintSystem, c: Constraint, v: float, sine: bool) -> Any:
        val = super().trig(m, c, v, sine)
        with _precision():
            x = iv.mpf(float(m.value(c)))  # sin(pi - a) = sin a, |cos(pi - a)| = |cos a|
            exact = iv.sin(x) if sine else abs(iv.cos(x))
            return EF(val, K._dist(exact, val))

    def snapped(self, m: ConstraintSystem, c: Constraint, row: bool) -> Any:
        x = m.value(c)
        if x == 0.0:
            return 0.0  # exactly parallel
        if not row:
            # the binary64 angle leaves the directions a cone apart: no row to carry it
            raise NotEnclosed(f"constraint {c.label}: an angle taken as parallelism")
        # the exact angle's row is u . v = +-t (t = |cos x| between lines or between planes,
        # sin x between a line and a plane), each sense within t of u . v = 0
        with _precision():
            ta, tb = m.types(c)
            X = iv.mpf(float(x))
            t = abs(iv.cos(X)) if ta == tb else abs(iv.sin(X))
            return EF(0.0, K._dist(t, 0.0))

    def point(self, e: Entity) -> list:
        return [EF(float(v), 0.0) for v in e.point]

    def _unit(self, e: Entity) -> list:
        raw = e.direction if e.given_direction is None else e.given_direction
        v = [iv.mpf(float(x)) for x in raw]
        n = iv.sqrt(sum(x * x for x in v))
        return [x / n for x in v]

    def direction(self, e: Entity) -> list:
        with _precision():
            u = self._unit(e)
            return [EF(float(d), K._dist(x, float(d))) for d, x in zip(e.direction, u)]

    def offset(self, e: Entity) -> Any:
        h = super().offset(e)
        with _precision():
            u = self._unit(e)
            exact = sum(x * iv.mpf(float(p)) for x, p in zip(u, e.point))
            return EF(h, K._dist(exact, h))

    def sqdist(self, p: np.ndarray, q: np.ndarray) -> Any:
        exact = sum((Fraction(float(a)) - Fraction(float(b))) ** 2 for a, b in zip(p, q))
        return _exact_error(super().sqdist(p, q), exact)

    def trilateration(self, P0: np.ndarray) -> tuple[Any, list]:
        Minv, cs = super().trilateration(P0)
        P = [[Fraction(float(x)) for x in row] for row in P0]
        M = [[2 * (P[k + 1][j] - P[0][j]) for j in range(3)] for k in range(3)]
        inv = _inverse3(M)
        out = np.empty((3, 3), dtype=object)
        for i in range(3):
            for j in range(3):
                out[i, j] = _exact_error(float(Minv[i][j]), inv[i][j])
        sq = [sum(x * x for x in row) for row in P]
        return out, [_exact_error(cs[k - 1], sq[k] - sq[0]) for k in range(1, 4)]


def _inverse3(M: list[list[Fraction]]) -> list[list[Fraction]]:
    """The exact inverse of a 3 x 3 rational matrix (its adjugate over its determinant)."""
    (a, b, c), (d, e, f), (g, h, i) = M
    det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
    if det == 0:
        raise NotEnclosed("the anchors' exact matrix is singular")
    adj = [
        [e * i - f * h, c * h - b * i, b * f - c * e],
        [f * g - d * i, a * i - c * g, c * d - a * f],
        [d * h - e * g, b * g - a * h, a * e - b * d],
    ]
    return [[x / det for x in row] for row in adj]


def enclosed_core(first: System, shadow_build: Callable[[Numbers], System]) -> tuple[np.ndarray, np.ndarray] | None:
    """``System.core_errors`` of ``first`` (a constraint system's rows, built with binary64
    numbers) from the shadow build ``shadow_build(EnclosedNumbers())``, or None where it does
    not cover the system (the rows are then taken as rounded). Rows that ``first`` made
    redundant after it was built (:func:`~kinbox.formulation.geometry.square_core`) are made
    redundant in the shadow too, by name."""
    try:
        shadow = shadow_build(EnclosedNumbers())
    except (NotEnclosed, FormulationError):
        return None
    kinds: dict[str, str] = {}
    for c in first.constraints:
        kinds.setdefault(c.name, c.kind)
    for c in shadow.constraints:
        if c.kind != "ineq" and kinds.get(c.name, c.kind) != "ineq":
            c.kind = kinds.get(c.name, c.kind)
    shadow.invalidate()
    return core_errors(first, shadow)


def enclose(system: System, shadow_build: Callable[[Numbers], System]) -> None:
    """Give ``system`` its core rows' errors (:func:`enclosed_core`), in place."""
    system.core_errors = enclosed_core(system, shadow_build)
    system.invalidate()
