"""Outward-rounded interval arithmetic on numpy arrays.

numpy cannot switch the FPU rounding mode, so every operation here is computed with the
default round-to-nearest and then widened by a bound on its rounding error:

* a single IEEE operation (``+ - * /``, ``sqrt``) is off by at most half an ulp, so moving
  the result one ulp outward with ``np.nextafter`` encloses the exact value;
* a sum of ``n`` terms computed in any order is off by at most ``gamma(n) * sum(|t_k|)``
  (Higham, *Accuracy and Stability of Numerical Algorithms*, Eq. 4.4), widened further by
  ``n * TINY`` to cover underflow.

An interval is a pair of arrays ``(lo, hi)``; empty intervals have ``lo > hi``.

The compiled kernels of the search (``search/propagate.py``: HC4 sweeps; ``search/relaxation.py``:
the safe LP bound) apply these same rules to scalars, one element at a time, because numba
cannot call these array functions per element; they take ``U`` and ``TINY`` from here, and the
tests check them against this module (``tests/support/hc4_reference.py``, ``tests/search/test_soundness_arb.py``).
"""

from __future__ import annotations

import numpy as np

U = 2.0**-53  # unit roundoff of binary64
TINY = float(np.finfo(float).tiny)  # smallest normal number: covers underflow of a product
SMALLEST = 5e-324  # smallest subnormal number
INF = np.inf


def gamma(n: int | np.ndarray) -> np.ndarray | float:
    """Higham's gamma_n = n u / (1 - n u), a bound on the relative error of an n-term sum."""
    nu = np.asarray(n, dtype=float) * U
    return nu / (1.0 - nu)


def flushing_subnormals() -> str | None:
    """Which of flush-to-zero (FTZ) and denormals-are-zero (DAZ) is on in this thread, or None.

    Both break the rules above: FTZ rounds a subnormal result to zero, more than half an ulp,
    and DAZ reads a subnormal operand as zero. A shared library built with ``-ffast-math`` can
    switch them on for the whole process when it is loaded, so the search checks before it
    trusts its bounds."""
    modes = []
    if not SMALLEST > 0.0:  # a comparison makes no result to flush: only DAZ can fail it
        modes.append("denormals-are-zero")
    if np.float64(TINY / 4.0).view(np.int64) == 0:  # normal operands: only FTZ zeroes the result
        modes.append("flush-to-zero")
    return " and ".join(modes) or None


def down(x):
    """Largest float strictly below ``x`` (one ulp down); infinities are kept."""
    return np.nextafter(x, -INF)


def up(x):
    """Smallest float strictly above ``x`` (one ulp up); infinities are kept."""
    return np.nextafter(x, INF)


def mul(alo, ahi, blo, bhi):
    """Enclosure of the product of intervals ``[alo, ahi] * [blo, bhi]`` (elementwise)."""
    with np.errstate(invalid="ignore"):
        p1, p2, p3, p4 = alo * blo, alo * bhi, ahi * blo, ahi * bhi
    lo = np.minimum(np.minimum(p1, p2), np.minimum(p3, p4))
    hi = np.maximum(np.maximum(p1, p2), np.maximum(p3, p4))
    if np.isnan(lo).any() or np.isnan(hi).any():
        # 0 * inf = nan: a zero factor gives a zero product
        p = np.stack(np.broadcast_arrays(p1, p2, p3, p4))
        p = np.where(np.isnan(p), 0.0, p)
        lo, hi = p.min(axis=0), p.max(axis=0)
    return down(lo) - TINY, up(hi) + TINY


def scale(a, lo, hi):
    """Enclosure of ``a * [lo, hi]`` for a float array ``a`` (elementwise)."""
    with np.errstate(invalid="ignore"):
        p1, p2 = a * lo, a * hi
    p1 = np.where(np.isnan(p1), 0.0, p1)
    p2 = np.where(np.isnan(p2), 0.0, p2)
    return down(np.minimum(p1, p2)) - TINY, up(np.maximum(p1, p2)) + TINY


def sqr(lo, hi):
    """Enclosure of ``{x^2 : x in [lo, hi]}``."""
    a, b = lo * lo, hi * hi
    mx = up(np.maximum(a, b))
    mn = np.where((lo <= 0.0) & (hi >= 0.0), 0.0, down(np.minimum(a, b)))
    return np.maximum(mn - TINY, 0.0), mx + TINY


def sqrt_hull(qlo, qhi):
    """Enclosure of ``sqrt([qlo, qhi])`` for ``qhi >= 0`` (negative part ignored)."""
    lo = np.sqrt(np.maximum(qlo, 0.0))
    hi = np.sqrt(np.maximum(qhi, 0.0))
    return np.maximum(down(lo), 0.0), up(hi)


def div(alo, ahi, blo, bhi):
    """Enclosure of ``[alo, ahi] / [blo, bhi]``; unbounded where the divisor holds zero."""
    zero_in = (blo <= 0.0) & (bhi >= 0.0)
    sb_lo = np.where(zero_in, 1.0, blo)
    sb_hi = np.where(zero_in, 1.0, bhi)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        p1, p2, p3, p4 = alo / sb_lo, alo / sb_hi, ahi / sb_lo, ahi / sb_hi
    plo = np.minimum(np.minimum(p1, p2), np.minimum(p3, p4))
    phi = np.maximum(np.maximum(p1, p2), np.maximum(p3, p4))
    if np.isnan(plo).any() or np.isnan(phi).any():  # inf / inf: no information, as 0
        p = np.stack(np.broadcast_arrays(p1, p2, p3, p4))
        p = np.where(np.isnan(p), 0.0, p)
        plo, phi = p.min(axis=0), p.max(axis=0)
    lo = down(plo) - TINY
    hi = up(phi) + TINY
    return np.where(zero_in, -INF, lo), np.where(zero_in, INF, hi)


def dot_bounds(terms_lo: np.ndarray, terms_hi: np.ndarray, axis: int = -1):
    """Enclosure of ``sum(t)`` for ``t_k in [terms_lo_k, terms_hi_k]`` along ``axis``."""
    n = terms_lo.shape[axis]
    slo = terms_lo.sum(axis=axis)
    shi = terms_hi.sum(axis=axis)
    g = gamma(max(n, 1))
    elo = g * np.abs(terms_lo).sum(axis=axis) + n * TINY
    ehi = g * np.abs(terms_hi).sum(axis=axis) + n * TINY
    lo, hi = down(slo - elo), up(shi + ehi)
    # a sum that overflowed to -inf plus its error bound (then +inf) is NaN: no upper bound
    return np.where(np.isnan(lo), -INF, lo)[()], np.where(np.isnan(hi), INF, hi)[()]


def cos_range(lo: float, hi: float) -> tuple[float, float]:
    """Enclosure of ``cos`` over ``[lo, hi]`` (radians), rounded outward by 4 ulps."""
    return _trig_range(np.cos, lo, hi, 0.0)


def sin_range(lo: float, hi: float) -> tuple[float, float]:
    """Enclosure of ``sin`` over ``[lo, hi]`` (radians), rounded outward by 4 ulps."""
    return _trig_range(np.sin, lo, hi, np.pi / 2)


def _trig_range(f, lo: float, hi: float, peak: float) -> tuple[float, float]:
    big = max(abs(lo), abs(hi))
    # beyond 2^50 the floats are 1/4 apart and k below may be off by more than the one
    # spare k on each side: no finer answer is worth it there
    if hi - lo >= 2 * np.pi or not big < 2.0**50:
        return -1.0, 1.0
    vals = [f(lo), f(hi)]
    # extrema of f lie at peak + k*pi (max for even k, min for odd k)
    k0 = int(np.floor((lo - peak) / np.pi)) - 1
    k1 = int(np.ceil((hi - peak) / np.pi)) + 1
    # t below is off from the true extremum by k (pi - float(pi)) and its own roundings, under
    # 3e-16 |t| in all (3e-4 at |t| = 7e12): include extrema within 4 ulps of the ends
    near = 1e-12 + 4 * np.spacing(big)
    for k in range(k0, k1 + 1):
        t = peak + k * np.pi
        if lo - near <= t <= hi + near:
            vals.append(1.0 if k % 2 == 0 else -1.0)
    a, b = min(vals), max(vals)
    pad = 4 * np.spacing(1.0)
    return max(-1.0, a - pad), min(1.0, b + pad)
