"""Exact references for the contractor soundness tests: python-flint ``arb`` at high precision, planted
roots, hypothesis strategies for LP cases."""

from __future__ import annotations

import math
import os
import sys
from fractions import Fraction

import numpy as np
from flint import arb
from hypothesis import HealthCheck, assume, settings
from hypothesis import strategies as st

from kinbox.formulation.system import Expr, System

INF = math.inf


MAXF = sys.float_info.max


TINY = sys.float_info.min  # smallest normal


SUB = 5e-324  # smallest subnormal


#: working precision of the exact reference: sums of products of up to three binary64 numbers
#: span less than 6400 bits, so they are exact at this precision
PREC = 8192


SCALE = float(os.environ.get("KINBOX_SOUNDNESS_SCALE", "0.3"))


def sound(n: int):
    """Hypothesis settings of a test with ``n`` cases (times ``KINBOX_SOUNDNESS_SCALE``)."""
    return settings(
        max_examples=max(1, int(n * SCALE)),
        deadline=None,
        derandomize=True,
        database=None,
        print_blob=True,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much, HealthCheck.data_too_large],
    )


def X(v) -> arb:
    """The float ``v`` as an exact arb."""
    return arb(float(v))


def to_float_exact(q: Fraction):
    """``q`` as a float if it is one exactly, else None."""
    try:
        f = float(q)
    except OverflowError:
        return None
    return f if math.isfinite(f) and Fraction(f) == q else None


def float_down(q: Fraction) -> float:
    """The largest float ``<= q`` (``-inf`` below the floats)."""
    try:
        f = float(q)
    except OverflowError:
        return -INF if q < 0 else MAXF
    if f == INF:
        return MAXF
    if f == -INF:
        return -INF
    return f if Fraction(f) <= q else float(np.nextafter(f, -INF))


def float_up(q: Fraction) -> float:
    return -float_down(-q)


ROOTS = st.one_of(
    st.sampled_from([0.0, 0.0, 0.0, 1.0, -1.0, 0.5, -0.375, 2.0]),
    st.integers(-64, 64).map(lambda m: m / 16.0),
    st.builds(math.ldexp, st.integers(-15, 15), st.integers(-40, 40)),
    st.sampled_from([SUB, -SUB, 3 * SUB, 2.0**-1070, -TINY, 2.0**-600, 2.0**300, -(2.0**400), 1e-17, 0.1, 1 / 3]),
)


DENOMINATORS = st.sampled_from([1, 1, 1, 3, 5, 7])


EXPONENTS = st.sampled_from([0] * 8 + [-2, 3, -30, -56, -60, -300, -1020, -1060, -1074, -1078, -1080, 40, 300])


COEFS = st.one_of(
    st.builds(math.ldexp, st.sampled_from([m for m in range(-8, 9) if m]), EXPONENTS),
    st.sampled_from([0.1, -1e-17, 6.123233995736766e-17, 1 / 3, -2.5e-320]),
)


def exact_value(terms: dict, x) -> Fraction:
    s = Fraction(0)
    for k, a in terms.items():
        z = Fraction(a)
        for i in k:
            z *= Fraction(x[i])
        s += z
    return s


def domain_of(v: Fraction) -> tuple[float, float]:
    w = max(1, abs(v))
    return float_down(v - w), float_up(v + w)


def fz(comp, x) -> list[Fraction]:
    """``z = (x, x_i x_j)`` at the point ``x`` (floats or Fractions), exactly."""
    xq = [Fraction(v) for v in x]
    return xq + [xq[i] * xq[j] for i, j in zip(comp.mi, comp.mj)]


def rows_q(comp, x) -> list[Fraction]:
    """The row values ``A z + c`` at ``x``, exactly (Fractions)."""
    z = fz(comp, x)
    A = comp.A.tocsr()
    return [
        Fraction(comp.c[r]) + sum((Fraction(A.data[p]) * z[A.indices[p]] for p in range(A.indptr[r], A.indptr[r + 1])), Fraction(0))
        for r in range(A.shape[0])
    ]


def is_solution(comp, x) -> bool:
    """``x`` satisfies every row within the targets the solver uses (``A z`` in
    ``[target_lo, target_hi]``), exactly."""
    tlo, thi = comp.target_lo, comp.target_hi
    return all(tlo[r] <= v - Fraction(comp.c[r]) <= thi[r] for r, v in enumerate(rows_q(comp, x)))


def in_box(lo, hi, vals) -> bool:
    """Every value (a Fraction) lies in its interval ``[lo_k, hi_k]`` (floats), exactly."""
    return all(a <= v <= b for a, b, v in zip(lo, hi, vals))


def with_denominator(a: float, d: int) -> float:
    """``a * d`` if that is a float exactly, else ``a``."""
    v = to_float_exact(Fraction(a) * d)
    return a if v is None else v


@st.composite
def planted(draw, n_max=4, kinds=("core", "core", "redundant", "ineq")):
    """A system with a planted root: ``(System, x*)``, x* a list of Fractions."""
    n = draw(st.integers(1, n_max))
    den = [draw(DENOMINATORS) for _ in range(n)]
    x = [Fraction(draw(ROOTS)) / d for d in den]
    s = System()
    for i in range(n):
        s.add_var(f"x{i}", *domain_of(x[i]))
    keys = [(i,) for i in range(n)] + [(i, j) for i in range(n) for j in range(i, n)]

    def coef(k):  # a coefficient for the term k: a multiple of its denominators if it can be
        return with_denominator(draw(COEFS), math.prod(den[i] for i in k))

    for _ in range(draw(st.integers(1, n + 3))):
        template = draw(st.sampled_from(["random"] * 5 + ["pin", "square-pin", "difference", "cancel"]))
        zeros = [i for i in range(n) if x[i] == 0]
        equal = [(i, j) for i in range(n) for j in range(n) if i < j and x[i] == x[j]]
        terms: dict = {}
        if template in ("pin", "square-pin") and zeros:  # a row that forces x_i = 0
            i = draw(st.sampled_from(zeros))
            k = (i,) if template == "pin" else (i, i)
            terms[k] = coef(k)
        elif template == "difference" and equal:  # a x_i - a x_j: coefficients summing to 0
            i, j = draw(st.sampled_from(equal))
            terms[(i,)] = coef((i,))
            terms[(j,)] = -terms[(i,)]
        elif template == "cancel" and equal:
            # A x_i + b z - A x_j with z between them in column order (a monomial of x_i, or
            # x_l for i < l < j): A x_i and -A x_j cancel at the root, and the rounding of the
            # partial sum A x_i + b z is what the bound of the row's sum must cover
            i, j = draw(st.sampled_from(equal))
            big = with_denominator(math.ldexp(draw(st.sampled_from([1, 3, -5])), draw(st.sampled_from([30, 53, 60, 80]))), den[i])
            terms[(i,)] = big
            k = draw(st.sampled_from([(l,) for l in range(i + 1, j)] + [(i, i)]))
            terms[k] = coef(k)
            terms[(j,)] = -big
        for _ in range(draw(st.integers(0 if terms else 1, 4))):
            k = draw(st.sampled_from(keys))
            terms[k] = coef(k)
        row_scale = math.ldexp(1.0, draw(EXPONENTS))
        terms = {k: a * row_scale for k, a in terms.items()}  # may underflow to 0.0: kept
        if not all(math.isfinite(a) for a in terms.values()):
            continue
        S = exact_value(terms, x)
        kind = draw(st.sampled_from(kinds))
        c = to_float_exact(-S)
        if c is None or kind == "ineq":
            kind = "ineq"
            c = float_down(-S - draw(st.sampled_from([0, 0, 0, Fraction(1, 2**20), 1])))
            if not math.isfinite(c):
                continue
        e = Expr(dict(terms))
        if c != 0.0:
            e.terms[()] = c
        if kind == "ineq":
            s.add_ineq(e)
        else:
            s.add_eq(e, redundant=kind == "redundant")
    assume(s.constraints)
    return s, x


@st.composite
def lp_case(draw, kinds=("core", "core", "redundant", "ineq"), near=True):
    s, x = draw(planted(n_max=3, kinds=kinds))
    # finite boxes of moderate size: HiGHS treats |bounds| >= 1e20 as infinite
    assume(all(abs(v) <= 2.0**40 for v in x))
    widths = [0.0, SUB, 1e-300, 2.0**-30, 1e-6, 0.25, 1.0, 4.0]
    lo = np.array([float_down(v - Fraction(draw(st.sampled_from(widths)))) for v in x])
    hi = np.array([float_up(v + Fraction(draw(st.sampled_from(widths)))) for v in x])
    if not near:  # shift the box off the root: often infeasible
        for i in range(len(x)):
            d = draw(st.sampled_from([0.0, 0.5, -0.5, 2.0, -3.0, 1e-6]))
            lo[i] += d
            hi[i] += d
            if lo[i] > hi[i]:
                lo[i], hi[i] = hi[i], lo[i]
    return s, x, lo, hi


def lp_rows(relax):
    """The rows of the LP as built: (index, value) lists and bounds."""
    rows = []
    for r in range(relax.nrow):
        a, b = relax.start[r], relax.start[r + 1]
        rows.append(list(zip(relax.index[a:b].tolist(), relax.value[a:b].tolist())))
    return rows


def farkas_holds(relax, y) -> bool:
    """The Farkas argument of ``Relaxation._farkas`` for ``y`` (or ``-y``), in exact
    arithmetic: max over the box of ``(G^T y) z`` < min over the row bounds of ``y w``."""
    rows = lp_rows(relax)
    for sign in (1.0, -1.0):
        yy = sign * y
        yy = np.where((yy > 0) & ~np.isfinite(relax.row_lo), 0.0, yy)
        yy = np.where((yy < 0) & ~np.isfinite(relax.row_hi), 0.0, yy)
        g = [arb(0) for _ in range(relax.nz)]
        wmin = arb(0)
        for r, row in enumerate(rows):
            if yy[r] == 0.0:
                continue
            for j, a in row:
                g[j] += X(a) * X(yy[r])
            wmin += X(yy[r]) * X(relax.row_lo[r] if yy[r] > 0 else relax.row_hi[r])
        zmax = arb(0)
        for j in range(relax.nz):
            zmax += max(g[j] * X(relax.zlo[j]), g[j] * X(relax.zhi[j]), key=lambda v: float(v.mid()))
        if zmax < wmin:
            return True
    return False


def grid_points(lo, hi, extra_per_var=()):
    """Corners of the box (all of them for up to 3 variables) and midpoints, as float lists."""
    n = len(lo)
    out = []
    for mask in range(2**n):
        out.append([hi[i] if mask >> i & 1 else lo[i] for i in range(n)])
    # clipped: 0.5 * lo + 0.5 * hi underflows to 0 for a point box at the smallest subnormal,
    # and a "solution" outside the box is nothing a contractor of the box must keep
    out.append([min(max(0.5 * lo[i] + 0.5 * hi[i], lo[i]), hi[i]) for i in range(n)])
    for e in extra_per_var:
        out.append([min(max(e[i], lo[i]), hi[i]) for i in range(n)])
    return out
