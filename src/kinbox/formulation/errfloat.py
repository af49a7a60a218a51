"""Floats that carry a bound on their distance to an exact value.

An arm's template (:mod:`kinbox.formulation.arm`) is written from constants of the model
(link matrices, offsets) computed in binary64: the model's exact constants lie within a few
ulps of them (:mod:`kinbox.formulation.constants` encloses them). Its coefficients are sums of
products of those constants. :class:`EF` is a ``float`` (its value is the binary64 number the
template stores, bit for bit what a plain float computation gives) with ``err``, a bound on
``|exact - value|``: every ``+ - *`` with another float adds the propagated error
(``|a| e_b + |b| e_a + e_a e_b``) and the rounding of the result (half an ulp, counted as
``2^-53 |r|`` and widened by a relative ``2^-50`` and the smallest normal number for the
rounding of the bound itself and for underflow). A value that comes out exactly zero keeps its
error: an :class:`~kinbox.formulation.system.Expr` keeps such a term (it is no term of the
pattern, its error is carried to the row: :meth:`kinbox.formulation.template.Template.freeze`).
"""

from __future__ import annotations

U = 2.0**-53
_GROW = 1.0 + 2.0**-50
_TINY = 2.2250738585072014e-308


def err(v) -> float:
    """The error bound of a number (0 for a plain float)."""
    return v.err if type(v) is EF else 0.0


def keep(v) -> bool:
    """Is ``v`` a term worth keeping: non-zero, or zero with an error?"""
    return v != 0.0 or (type(v) is EF and v.err > 0.0)


def num(v):
    """``float(v)`` that keeps an :class:`EF`."""
    return v if type(v) is EF else float(v)


def _out(r: float, e: float, exact: bool = False) -> EF:
    if exact:  # no rounding: a sum with zero, a product with 0, +-1, +-2 or +-1/2
        return EF(r, e * _GROW if e else 0.0)
    return EF(r, (e + U * abs(r)) * _GROW + _TINY)


_EXACT_FACTORS = (0.0, 1.0, -1.0, 2.0, -2.0, 0.5, -0.5)


class EF(float):
    """A float and a bound ``err`` on its distance to the exact value it stands for."""

    __slots__ = ("err",)
    err: float

    def __new__(cls, value: float, error: float = 0.0):
        self = super().__new__(cls, value)
        self.err = float(error)
        return self

    def __repr__(self) -> str:
        return f"EF({float(self)!r}, {self.err:.3g})"

    def __add__(self, o):
        if not isinstance(o, (float, int)):
            return NotImplemented
        a, b = float(self), float(o)
        return _out(a + b, self.err + err(o), a == 0.0 or b == 0.0)

    __radd__ = __add__

    def __sub__(self, o):
        if not isinstance(o, (float, int)):
            return NotImplemented
        a, b = float(self), float(o)
        return _out(a - b, self.err + err(o), a == 0.0 or b == 0.0)

    def __rsub__(self, o):
        if not isinstance(o, (float, int)):
            return NotImplemented
        a, b = float(self), float(o)
        return _out(b - a, self.err + err(o), a == 0.0 or b == 0.0)

    def __mul__(self, o):
        if not isinstance(o, (float, int)):
            return NotImplemented
        a, b, ea, eb = float(self), float(o), self.err, err(o)
        return _out(a * b, (abs(a) * eb + abs(b) * ea + ea * eb) * _GROW, a in _EXACT_FACTORS or b in _EXACT_FACTORS)

    __rmul__ = __mul__

    def __neg__(self):
        return EF(-float(self), self.err)

    def __pos__(self):
        return self

    def __truediv__(self, o):
        b, eb = float(o), err(o)
        if eb:  # by an inexact number (an eliminated free-flyer's pivot): as its reflected division
            return EF.__rtruediv__(o, self)
        return _out(float(self) / b, self.err / abs(b) * _GROW)

    def __rtruediv__(self, o):
        if not isinstance(o, (float, int)):
            return NotImplemented
        a, e, b, eb = float(self), self.err, float(o), err(o)
        if e >= abs(a):
            raise ZeroDivisionError("division by a number whose enclosure holds zero")
        # |b'/a' - b/a| <= (eb |a| + |b| e) / (|a| (|a| - e)) for |a' - a| <= e, |b' - b| <= eb
        bound = (eb * abs(a) + abs(b) * e) / (abs(a) * (abs(a) - e)) * _GROW if (e or eb) else 0.0
        return _out(b / a, bound, a in (1.0, -1.0) or b == 0.0)

    def __reduce__(self):
        return (EF, (float(self), self.err))


def square(v):
    """``float(v) ** 2`` (the value bit for bit), as an :class:`EF` with its error when ``v``
    is one (the power counted as one operation within an ulp), else as a float."""
    r = float(v) ** 2
    if type(v) is not EF:
        return r
    a, e = abs(float(v)), v.err
    return EF(r, ((2.0 * a * e + e * e) * _GROW + 2.0 * U * r) * _GROW + _TINY)


def matmul(A, B):
    """``A @ B`` for arrays of which one at least holds :class:`EF` (object arrays, 2-d times
    2-d or 1-d), with the values of numpy's float product of the plain floats, bit for bit
    (whatever order and fused operations it sums in): the product term by term in :class:`EF`
    arithmetic, and where its value differs from the float product's, that value with the
    difference added to the error."""
    import numpy as np  # noqa: PLC0415

    A, B = np.asarray(A), np.asarray(B)
    seq = A @ B
    val = A.astype(float) @ B.astype(float)
    out = np.empty(val.shape, dtype=object)
    for idx in np.ndindex(val.shape):
        x, v = seq[idx], float(val[idx])
        d = abs(float(x) - v)
        out[idx] = x if d == 0.0 and type(x) is EF else EF(v, (err(x) + d) * _GROW + _TINY if (err(x) or d) else 0.0)
    return out
