"""Numbers computed from the input, with an enclosure of their exact value.

A goal pose is given as ``x y z qx qy qz qw`` (Pinocchio's XYZQUAT; a ``pinocchio.SE3`` is read
as the XYZQUAT Pinocchio gives for it, the pose the answer records): those binary64 numbers
are the input, exactly. Its rotation is the one of the unit quaternion ``q / |q|``, whose
entries are rational functions of the four numbers (``R = I + 2 (...) / |q|^2``), so every
number derived from the pose by products and sums (an arm's goal parameters,
:meth:`kinbox.formulation.arm.ArmTemplate.params`) has an exact rational value. It is computed
in x87 extended precision (a 64-bit significand, where numpy's ``longdouble`` is that type),
with the same expression evaluated on magnitudes to bound its rounding (at most ``gamma(K)``
of the magnitude for ``K`` roundings on any path, Higham's rule, with the extended unit
roundoff), and rounded once to binary64: the radius of the enclosure is the distance between
the two plus that bound. Where ``longdouble`` is binary64 itself the numbers are computed in
exact rational arithmetic (``fractions.Fraction``) instead, rounded once. ``tests/formulation/test_enclosures.py``
checks both against 40-digit arithmetic.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pinocchio as pin

#: the extended type, when it has at least 63 bits of significand (x86: the x87 format)
EXT = np.longdouble if np.finfo(np.longdouble).nmant >= 63 else None
#: roundings on any path of :func:`affine_chain` and the quaternion's matrix: at most 3 per
#: product of two 3x3 matrices (a product and two sums), 4 such products, the matrix of the
#: quaternion (9), and the three sums of the parameters (6): 40, counted as 64
ROUNDINGS = 64

Matrix = list[list[Fraction]]
Vector = list[Fraction]


def exact(v: float) -> Fraction:
    return Fraction(float(v))


def pose_exact(T: pin.SE3) -> tuple[Matrix, Vector]:
    """``(R, t)`` of a pose as its XYZQUAT numbers define it: ``t`` as given, ``R`` the rotation
    of the quaternion divided by its norm (exactly orthogonal)."""
    v = pin.SE3ToXYZQUAT(T)
    t = [exact(a) for a in v[:3]]
    x, y, z, w = (exact(a) for a in v[3:])
    n = x * x + y * y + z * z + w * w
    s = 2 / n
    R = [
        [1 - s * (y * y + z * z), s * (x * y - z * w), s * (x * z + y * w)],
        [s * (x * y + z * w), 1 - s * (x * x + z * z), s * (y * z - x * w)],
        [s * (x * z - y * w), s * (y * z + x * w), 1 - s * (x * x + y * y)],
    ]
    return R, t


def frame_exact(T: pin.SE3) -> tuple[Matrix, Vector]:
    """``(R, t)`` of a pose whose matrix entries are taken as they are (a constant of the model)."""
    return [[exact(a) for a in row] for row in T.rotation], [exact(a) for a in T.translation]


def inverse(F: tuple[Matrix, Vector]) -> tuple[Matrix, Vector]:
    """``(R^T, -R^T t)``: the inverse of a rigid motion whose ``R`` is orthogonal (for a model
    constant, the motion this formula defines)."""
    R, t = F
    Rt = [[R[k][r] for k in range(3)] for r in range(3)]
    return Rt, [-sum((Rt[r][k] * t[k] for k in range(3)), Fraction(0)) for r in range(3)]


def compose(A: tuple[Matrix, Vector], B: tuple[Matrix, Vector]) -> tuple[Matrix, Vector]:
    """``A * B`` of two rigid motions ``(R, t)``."""
    RA, tA = A
    RB, tB = B
    R = [[sum((RA[r][k] * RB[k][c] for k in range(3)), Fraction(0)) for c in range(3)] for r in range(3)]
    t = [sum((RA[r][k] * tB[k] for k in range(3)), Fraction(0)) + tA[r] for r in range(3)]
    return R, t


def rounded(values: list[Fraction]) -> tuple[np.ndarray, np.ndarray]:
    """Each exact value rounded to the nearest binary64, and a radius ``r`` (a float) with
    ``|value - rounded| <= r``."""
    mid = np.array([float(v) for v in values])
    rad = np.empty(len(values))
    for i, (v, m) in enumerate(zip(values, mid)):
        e = abs(v - Fraction(float(m)))
        r = float(e)  # correctly rounded: at most half an ulp below e
        rad[i] = math.nextafter(r, math.inf) if Fraction(r) < e else r
    return mid, rad


def _ext_gamma(k: int) -> float:
    """``gamma(k)`` for the extended type's unit roundoff, rounded up to a binary64 number."""
    assert EXT is not None
    u = float(np.finfo(EXT).eps) / 2.0
    return math.nextafter(k * u / (1.0 - k * u), math.inf)


def _ext_quat_matrix(v: np.ndarray):
    """The quaternion's rotation matrix (extended) and its magnitude counterpart."""
    assert EXT is not None
    x, y, z, w = (EXT(a) for a in v)
    n = x * x + y * y + z * z + w * w
    s = EXT(2) / n
    R = np.array(
        [
            [1 - s * (y * y + z * z), s * (x * y - z * w), s * (x * z + y * w)],
            [s * (x * y + z * w), 1 - s * (x * x + z * z), s * (y * z - x * w)],
            [s * (x * z - y * w), s * (y * z + x * w), 1 - s * (x * x + y * y)],
        ],
        dtype=EXT,
    )
    ax, ay, az, aw = abs(x), abs(y), abs(z), abs(w)
    M = np.array(
        [
            [1 + s * (ay * ay + az * az), s * (ax * ay + az * aw), s * (ax * az + ay * aw)],
            [s * (ax * ay + az * aw), 1 + s * (ax * ax + az * az), s * (ay * az + ax * aw)],
            [s * (ax * az + ay * aw), s * (ay * az + ax * aw), 1 + s * (ax * ax + ay * ay)],
        ],
        dtype=EXT,
    )
    return R, M


class ExtFrame:
    """A rigid motion ``(R, t)`` in the extended type, with the magnitudes ``(|R|, |t|)`` of the
    expression that computed it (for the rounding bound)."""

    def __init__(self, R, t, MR, Mt):
        self.R, self.t, self.MR, self.Mt = R, t, MR, Mt

    @staticmethod
    def constant(T: pin.SE3) -> ExtFrame:
        R = np.asarray(T.rotation, dtype=EXT)
        t = np.asarray(T.translation, dtype=EXT)
        return ExtFrame(R, t, np.abs(R), np.abs(t))

    @staticmethod
    def pose(T: pin.SE3) -> ExtFrame:
        v = pin.SE3ToXYZQUAT(T)
        R, M = _ext_quat_matrix(v[3:])
        t = np.asarray(v[:3], dtype=EXT)
        return ExtFrame(R, t, M, np.abs(t))

    def inverse(self) -> ExtFrame:
        Rt = self.R.T.copy()
        return ExtFrame(Rt, -(Rt @ self.t), self.MR.T.copy(), self.MR.T @ self.Mt)

    def __mul__(self, other: ExtFrame) -> ExtFrame:
        return ExtFrame(
            self.R @ other.R,
            self.R @ other.t + self.t,
            self.MR @ other.MR,
            self.MR @ other.Mt + self.Mt,
        )


def ext_rounded(values, mags) -> tuple[np.ndarray, np.ndarray]:
    """Extended values rounded to binary64, with the radius: the distance to the extended value
    plus :data:`ROUNDINGS` roundings of the magnitude, rounded up."""
    values = np.asarray(values, dtype=EXT)
    mid = values.astype(float)
    diff = np.abs(values - mid.astype(EXT)).astype(float)
    bound = _ext_gamma(ROUNDINGS) * (1.0 + 1e-12) * np.asarray(mags, dtype=EXT).astype(float)
    rad = np.nextafter(np.nextafter(diff, np.inf) + bound, np.inf)
    return mid, rad
