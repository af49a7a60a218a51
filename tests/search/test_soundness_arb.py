"""Soundness of each contractor on its own, against exact arithmetic (python-flint's ``arb``).

kinbox is only complete if nothing that discards or narrows a box ever loses a solution. The
other tests compare the compiled kernels with numpy copies of the same logic, which cannot
catch a mistake both share. Here every contractor is checked against an independent exact
reference, one contractor at a time (HC4 alone, the LP alone, Krawczyk alone), so that a bug
in one cannot hide behind another:

* interval operations (``kinbox.interval``, and the HC4 kernel's own products and division)
  contain the exact value (``arb`` at several thousand bits: exact for sums and products of
  binary64 numbers) at sample points of their inputs, including real points beyond the floats
  (``2**3000``, ``2**-3000``) in unbounded intervals or next to zero;
* HC4 (``Propagator.contract``) keeps a *planted* root: systems whose coefficients and root
  make the constant that lets each row vanish exact in binary64 (checked with fractions; the
  root itself may be a rational that is no float), with tiny, subnormal and underflowed
  coefficients, pinned variables and degenerate or unbounded boxes; ``eval_rows`` contains the
  exact row values at points of the box;
* the LP (``Relaxation``): its relaxation rows hold at every point of the box, the safe bound
  (``_safe_lower``) is below the exact dual bound for any multipliers, its bounds keep the
  planted root and every exact solution found by sampling, and every "infeasible" verdict
  carries a Farkas certificate that holds in exact arithmetic;
* Krawczyk (``Certifier.krawczyk``) never calls a box holding a root empty, its enclosures hold
  the root, and it never proves uniqueness in a box holding two planted roots;
* domain and slack (``System.search_domain``, ``Compiled.slack``): a redundant row or an
  inequality derived in floating point (coefficients a few ulps off) holds at a root of the
  core within its slack, so neither HC4 nor the LP prunes that root; core rows get no slack.

arb's comparisons are true only when certain, so an inexact reference could only make a check
fail, never pass wrongly. Cases are drawn by hypothesis, derandomized so runs are
reproducible. The counts written below total about 5600 cases; the default suite runs 0.3 of
them (``KINBOX_SOUNDNESS_SCALE``, default 0.3), ``make test-slow`` three times them, and
``KINBOX_SOUNDNESS_SCALE=20`` gives a long run;
``--hypothesis-show-statistics`` shows how often HC4 narrows, which Krawczyk verdicts occur and
how often an LP infeasibility comes with a Farkas certificate.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from flint import arb, ctx
from hypothesis import assume, event, example, given, note
from hypothesis import strategies as st

# -- the code under test -------------------------------------------------------------------------
from kinbox import interval as iv
from kinbox.formulation.system import SLACK, Expr, System
from kinbox.search.certify import Certifier
from kinbox.search.propagate import Propagator, _div_into, _monomials
from kinbox.search.relaxation import Relaxation, _safe_lower
from tests.support.arb import (
    DENOMINATORS,
    INF,
    MAXF,
    PREC,
    SUB,
    TINY,
    X,
    exact_value,
    farkas_holds,
    float_down,
    float_up,
    fz,
    grid_points,
    in_box,
    is_solution,
    lp_case,
    lp_rows,
    planted,
    rows_q,
    sound,
    to_float_exact,
)

#: real numbers outside the binary64 range: far beyond the largest float, and between zero and
#: the smallest subnormal. An unbounded interval holds the first, one next to zero the second.
HUGE = arb(2) ** 3000
EPS = arb(2) ** -3000


@pytest.fixture(autouse=True, scope="module")
def _exact_precision():
    old = ctx.prec
    ctx.prec = PREC
    yield
    ctx.prec = old


# -- exact helpers ---------------------------------------------------------------------------


def encloses(lo, hi, v: arb) -> bool:
    """``[lo, hi]`` (floats, ends possibly infinite) certainly holds the real number ``v``."""
    lo, hi = float(lo), float(hi)
    if math.isnan(lo) or math.isnan(hi):  # a NaN end encloses nothing
        return False
    return (lo == -INF or X(lo) <= v) and (hi == INF or v <= X(hi))


def arb_down(v: arb) -> float:
    """A float ``<= v`` (v exact)."""
    if v < X(-MAXF):
        return -INF
    if v > X(MAXF):
        return MAXF
    f = float(v.mid())
    while not X(f) <= v:
        f = float(np.nextafter(f, -INF))
    return f


def arb_up(v: arb) -> float:
    return -arb_down(-v)


def exact_z(comp, x) -> list[arb]:
    """``z = (x, x_i x_j)`` at the point ``x`` (floats or arbs), exactly."""
    xa = [v if isinstance(v, arb) else X(v) for v in x]
    return xa + [xa[i] * xa[j] for i, j in zip(comp.mi, comp.mj)]


def exact_rows(comp, x) -> list[arb]:
    """The row values ``A z + c`` at ``x``, exactly."""
    z = exact_z(comp, x)
    A = comp.A.tocsr()
    out = []
    for r in range(A.shape[0]):
        s = X(comp.c[r])
        for p in range(A.indptr[r], A.indptr[r + 1]):
            s += X(A.data[p]) * z[A.indices[p]]
        out.append(s)
    return out


# -- strategies: floats and intervals --------------------------------------------------------

SPECIAL = [0.0, SUB, 3 * SUB, 1e-320, TINY, 1e-300, 2.0**-60, 1e-17, 1e-8, 0.5, 1.0, 1.5, 3.0, 1e8, 1e17, 2.0**60, 1e150, 1e300, MAXF]
reals = st.one_of(
    st.sampled_from(SPECIAL + [-v for v in SPECIAL] + [-0.0]),
    st.floats(allow_nan=False, allow_infinity=False),
    st.floats(-4.0, 4.0),
    st.integers(-64, 64).map(lambda m: m / 16.0),
    st.floats(-1e-300, 1e-300),  # subnormals and tiny normals
)


@st.composite
def intervals(draw, unbounded=True):
    a, b = draw(reals), draw(reals)
    lo, hi = min(a, b), max(a, b)
    shapes = ["plain"] * 5 + ["point", "huge"] + (["lo-inf", "hi-inf", "both-inf"] if unbounded else [])
    shape = draw(st.sampled_from(shapes))
    if shape == "huge":  # both ends near the largest float, where sums and products overflow
        sign = draw(st.sampled_from([1.0, -1.0]))
        a, b = (sign * draw(st.sampled_from([1e307, 1e308, MAXF])) for _ in range(2))
        lo, hi = min(a, b), max(a, b)
    elif shape == "point":
        hi = lo
    elif shape == "lo-inf":
        lo = -INF
    elif shape == "hi-inf":
        hi = INF
    elif shape == "both-inf":
        lo, hi = -INF, INF
    return lo, hi


def points(lo, hi, extra=()) -> list[arb]:
    """Exact real points of ``[lo, hi]``: its ends (or reals beyond the floats on an unbounded
    side), zero and the reals just next to it when inside, the midpoint, and ``extra``."""
    pts = [X(lo) if lo > -INF else -HUGE, X(hi) if hi < INF else HUGE]
    if lo <= 0.0 <= hi:
        pts.append(arb(0))
    if lo < 0.0 <= hi:
        pts.append(-EPS)
    if lo <= 0.0 < hi:
        pts.append(EPS)
    if -INF < lo < hi < INF:
        pts.append((X(lo) + X(hi)) / 2)
    pts += [X(v) for v in extra if lo <= v <= hi]
    return pts


def one(v) -> np.ndarray:
    return np.array([float(v)])


def run(f, *args):
    with np.errstate(all="ignore"):
        return [float(r[0]) if np.ndim(r) else float(r) for r in f(*args)]


# -- interval operations ---------------------------------------------------------------------


@sound(300)
@given(intervals(), intervals(), reals, reals)
def test_mul_encloses_every_product(a, b, u, v):
    lo, hi = run(iv.mul, one(a[0]), one(a[1]), one(b[0]), one(b[1]))
    for p in points(*a, extra=[u]):
        for q in points(*b, extra=[v]):
            assert encloses(lo, hi, p * q), (a, b, lo, hi, p, q)


@sound(400)
@given(reals, intervals(), reals)
def test_scale_encloses_every_product(c, b, v):
    lo, hi = run(iv.scale, one(c), one(b[0]), one(b[1]))
    for q in points(*b, extra=[v]):
        assert encloses(lo, hi, X(c) * q), (c, b, lo, hi, q)


@sound(400)
@given(intervals(), reals)
def test_sqr_encloses_every_square(a, u):
    lo, hi = run(iv.sqr, one(a[0]), one(a[1]))
    for p in points(*a, extra=[u]):
        assert encloses(lo, hi, p * p), (a, lo, hi, p)


@sound(300)
@given(intervals(), reals)
def test_sqrt_hull_encloses_every_root(a, u):
    qlo, qhi = a
    qhi = abs(qhi)  # its domain: qhi >= 0 (a negative part is ignored)
    lo, hi = run(iv.sqrt_hull, one(qlo), one(qhi))
    for p in points(max(qlo, 0.0), qhi, extra=[abs(u)]):
        assert encloses(lo, hi, p.sqrt()), (a, lo, hi, p)


@sound(300)
@given(intervals(), intervals(), reals, reals)
def test_div_encloses_every_quotient(a, b, u, v):
    lo, hi = run(iv.div, one(a[0]), one(a[1]), one(b[0]), one(b[1]))
    for q in points(*b, extra=[v]):
        if q.is_zero():
            continue
        for p in points(*a, extra=[u]):
            assert encloses(lo, hi, p / q), (a, b, lo, hi, p, q)


@sound(300)
@given(st.lists(intervals(), min_size=1, max_size=7), st.data())
def test_dot_bounds_encloses_every_sum(terms, data):
    tlo = np.array([t[0] for t in terms])
    thi = np.array([t[1] for t in terms])
    with np.errstate(all="ignore"):
        lo, hi = (float(v) for v in iv.dot_bounds(tlo, thi))
    pts = [points(*t) for t in terms]
    # the exact range: all lowest points, all highest points; and a few mixed choices
    choices = [
        [min(range(len(p)), key=lambda k: float(p[k].mid())) for p in pts],
        [max(range(len(p)), key=lambda k: float(p[k].mid())) for p in pts],
    ]
    for _ in range(3):
        choices.append([data.draw(st.integers(0, len(p) - 1)) for p in pts])
    for ch in choices:
        s = arb(0)
        for p, k in zip(pts, ch):
            s += p[k]
        assert encloses(lo, hi, s), (terms, lo, hi, s)


def test_interval_regression_dot_bounds_overflow():
    """Two terms of -MAXF: the float sum overflows to -inf and so does the bound on its
    rounding error; -inf + inf gave a NaN upper bound, an enclosure of nothing."""
    lo, hi = iv.dot_bounds(np.array([-MAXF, -MAXF]), np.array([-MAXF, -MAXF]))
    assert lo == -INF and encloses(lo, hi, X(-MAXF) * 2)
    lo, hi = iv.dot_bounds(np.array([MAXF, MAXF]), np.array([MAXF, MAXF]))
    assert hi == INF and encloses(lo, hi, X(MAXF) * 2)


@st.composite
def angle_intervals(draw):
    kind = draw(st.sampled_from(["small", "small", "near-extremum", "near-extremum", "wide", "point", "unbounded"]))
    if kind == "small":
        a, b = draw(st.floats(-20, 20)), draw(st.floats(-20, 20))
        return min(a, b), max(a, b)
    if kind == "wide":
        a = draw(st.floats(-1e6, 1e6))
        return a, a + draw(st.sampled_from([2 * math.pi, 6.3, 7.0, 100.0]))
    if kind == "point":
        a = draw(reals)
        return a, a
    if kind == "unbounded":
        a = draw(reals)
        return draw(st.sampled_from([(-INF, a), (a, INF), (-INF, INF)]))
    # near k pi / 2 (an extremum of sin or cos), at any scale
    k = draw(
        st.one_of(st.integers(-40, 40), st.integers(-(10**7), 10**7), st.integers(-(10**16), 10**16), st.integers(-(10**300), 10**300))
    )
    with ctx.workprec(1400):
        t = arb.pi() * k / 2
        c = float(t.mid())
    if not math.isfinite(c):
        c = MAXF
    lo = c
    for _ in range(draw(st.integers(0, 4))):
        lo = float(np.nextafter(lo, -INF))
    width = draw(st.sampled_from([0.0, 1e-300, 1e-12, 1e-9, 1e-6, 0.1, 1.0]))
    hi = lo + width
    for _ in range(draw(st.integers(0, 4))):
        hi = float(np.nextafter(hi, INF))
    return lo, hi


def trig_values(name: str, lo: float, hi: float) -> list[arb]:
    """The exact extreme values of cos or sin over ``[lo, hi]`` (as arbs)."""
    if lo == -INF or hi == INF:
        return [arb(1), arb(-1)]
    peak = 0 if name == "cos" else 1  # extrema at (peak/2 + k) pi
    with ctx.workprec(1400):
        L, H = X(lo), X(hi)
        vals = [getattr(L, name)(), getattr(H, name)()]
        pi = arb.pi()
        k0 = ((L / pi) - arb(peak) / 2).floor().unique_fmpz()
        k1 = ((H / pi) - arb(peak) / 2).ceil().unique_fmpz()
        assert k0 is not None and k1 is not None
        if int(k1) - int(k0) > 4:
            return vals + [arb(1), arb(-1)]
        for k in range(int(k0) - 1, int(k1) + 2):
            t = pi * (arb(k) + arb(peak) / 2)
            if L <= t <= H:
                vals.append(arb(1) if (k % 2 == 0) else arb(-1))
    return vals


@sound(400)
@given(angle_intervals())
def test_cos_and_sin_ranges_enclose_the_exact_range(a):
    lo, hi = a
    for name, f in (("cos", iv.cos_range), ("sin", iv.sin_range)):
        with np.errstate(all="ignore"):
            rlo, rhi = f(lo, hi)
        assert -1.0 <= rlo <= rhi <= 1.0
        for v in trig_values(name, lo, hi):
            # the true value is in [-1, 1]: a bound at +-1 holds even where arb's ball (of
            # cos(1e-275), say) still straddles it
            assert (rlo == -1.0 or X(rlo) <= v) and (rhi == 1.0 or v <= X(rhi)), (name, lo, hi, rlo, rhi, v)


def test_interval_regression_trig_range_far_from_zero():
    """sin reaches -1 at (k + 1/2) pi, k = 2258932293839, inside [7096645099282.913,
    7096645099282.914], but sin_range returned [-0.99999996, -0.99999975]: the extremum
    computed in floating point, pi/2 + k * float(pi) = 7096645099282.912, is off by about
    k (pi - float(pi)) = 2.8e-4, far more than the 1e-12 the search allowed for."""
    lo, hi = 7096645099282.913, 7096645099282.914
    assert any(v == -1 for v in trig_values("sin", lo, hi))
    rlo, _ = iv.sin_range(lo, hi)
    assert rlo == -1.0


# -- planted systems -------------------------------------------------------------------------
# A root x* is drawn as floats (mostly dyadic), some divided by 3, 5 or 7: real roots that are
# not floats, so that the last rounding of a bound matters too (rounding to nearest is
# monotone: it can never move a bound past a root that is itself a float). Coefficients are
# drawn as floats and multiplied by those denominators where that is exact; each row's constant
# is the value that makes it vanish at x* when that is a float (an equation), else the row
# becomes an inequality with its constant rounded towards the feasible side. Coefficients are
# scaled per term and per row by powers of two down to the subnormals, so some underflow to
# exactly zero and stay in the expression, as ``Expr * float`` leaves them. Roots are
# Fractions; every check on them is exact.


WIDTHS = [0.0, 0.0, SUB, 1e-300, 2.0**-40, 1e-8, 0.25, 1.0, 3.0, 1e10, 1e300]


def step(v: float, k: int) -> float:
    """``v`` moved ``|k|`` floats up (k > 0) or down."""
    for _ in range(abs(k)):
        v = float(np.nextafter(v, INF if k > 0 else -INF))
    return v


@st.composite
def box_around(draw, x, unbounded=False):
    """A float box holding the point ``x`` (Fractions): per side a width, a few ulps, or
    infinity; often some variables in the tightest float interval around their root."""
    widths = WIDTHS + ([INF] if unbounded else [])
    # a row then narrows the others tightly around theirs, where any missing outward rounding
    # cuts the root off
    pin = draw(st.booleans())
    lo, hi = [], []
    for v in x:
        if pin and draw(st.booleans()):
            lo.append(float_down(v))
            hi.append(float_up(v))
            continue
        ends = []
        for sign in (-1, 1):
            if draw(st.integers(0, 5)) == 0:  # a few ulps
                e = step(float_down(v) if sign < 0 else float_up(v), sign * draw(st.integers(1, 4)))
            else:
                w = draw(st.sampled_from(widths))
                e = sign * INF if w == INF else (float_down(v - Fraction(w)) if sign < 0 else float_up(v + Fraction(w)))
            ends.append(e)
        lo.append(ends[0])
        hi.append(ends[1])
    return np.array(lo), np.array(hi)


def check_planted(comp, x):
    """The generator's promise, checked in exact arithmetic: x* satisfies every row exactly."""
    for r, v in enumerate(rows_q(comp, x)):
        if r < comp.n_eq:
            assert v == 0, (r, v)
        else:
            assert v <= 0, (r, v)


def box_holds(lo, hi, comp, x):
    """Every ``z_k(x*)`` is inside ``[lo_k, hi_k]`` (``lo``/``hi`` over x, or over z)."""
    return in_box(lo, hi, fz(comp, x))


# -- HC4 alone -------------------------------------------------------------------------------


@sound(300)
@given(intervals(), intervals(), reals, reals)
def test_hc4_kernel_monomials_enclose_every_product_and_square(a, b, u, v):
    """The compiled kernel's own products and squares (``_monomials``)."""
    xlo, xhi = np.array([a[0], b[0]]), np.array([a[1], b[1]])
    mi, mj = np.array([0, 0, 1], dtype=np.int64), np.array([1, 0, 1], dtype=np.int64)
    sq = mi == mj
    mlo, mhi = np.empty(3), np.empty(3)
    with np.errstate(all="ignore"):
        _monomials(xlo, xhi, mi, mj, sq, mlo, mhi)
    pa, pb = points(*a, extra=[u]), points(*b, extra=[v])
    for p in pa:
        assert encloses(mlo[1], mhi[1], p * p)
        for q in pb:
            assert encloses(mlo[0], mhi[0], p * q), (a, b, mlo[0], mhi[0], p, q)
    for q in pb:
        assert encloses(mlo[2], mhi[2], q * q)


@sound(300)
@given(intervals(), intervals(), intervals(), reals, reals)
def test_hc4_kernel_division_keeps_every_quotient(m, b, x, u, v):
    """``_div_into`` narrows x to m / b: every quotient of points of m and b that lay in x
    must still lie in it (b holding zero: no narrowing at all)."""
    xlo, xhi = np.array([x[0]]), np.array([x[1]])
    with np.errstate(all="ignore"):
        _div_into(m[0], m[1], b[0], b[1], 0, xlo, xhi)
    if b[0] <= 0.0 <= b[1]:
        assert (xlo[0], xhi[0]) == x
    for q in points(*b, extra=[v]):
        if q.is_zero():
            continue
        for p in points(*m, extra=[u]):
            r = p / q
            if encloses(x[0], x[1], r):
                assert encloses(xlo[0], xhi[0], r), (m, b, x, xlo[0], xhi[0], p, q)


@sound(350)
@given(planted(), st.data())
def test_hc4_keeps_a_planted_root(case, data):
    s, x = case
    comp = s.compile()
    check_planted(comp, x)
    prop = Propagator(comp)
    lo, hi = data.draw(box_around(x, unbounded=True))
    note(f"x*={x} lo={lo.tolist()} hi={hi.tolist()}")
    for _ in range(2):  # contract, then contract the result again
        sweeps = data.draw(st.integers(1, 8))
        tol = data.draw(st.sampled_from([1e-3, 0.0]))
        r = prop.contract(lo, hi, max_sweeps=sweeps, tol=tol)
        assert r is not None, "HC4 declared a box holding a root empty"
        xlo, xhi, mlo, mhi = r
        assert box_holds(np.concatenate([xlo, mlo]), np.concatenate([xhi, mhi]), comp, x)
        event(f"HC4 narrowed x: {bool(np.any(xlo > lo) or np.any(xhi < hi))}")
        lo, hi = xlo, xhi


@sound(250)
@given(planted(kinds=("core", "redundant", "ineq")), st.data())
def test_eval_rows_encloses_the_exact_row_values(case, data):
    s, _ = case
    comp = s.compile()
    prop = Propagator(comp)
    boxes = [data.draw(intervals()) for _ in range(comp.n)]
    lo = np.array([b[0] for b in boxes])
    hi = np.array([b[1] for b in boxes])
    with np.errstate(all="ignore"):
        rlo, rhi = prop.eval_rows(lo, hi)
    pts = [points(a, b) for a, b in boxes]
    for _ in range(4):
        x = [p[data.draw(st.integers(0, len(p) - 1))] for p in pts]
        for r, v in enumerate(exact_rows(comp, x)):
            assert encloses(rlo[r], rhi[r], v), (r, rlo[r], rhi[r], v)


def test_eval_rows_regression_overflowed_sum():
    """x0^2 + x1 at x0 = 1e307, x1 = 1e300: the monomial's lower end is MAX, the float sum
    of the lower ends overflows to +inf, so does the sum of their magnitudes, and inf - inf
    made the row's lower bound NaN (row_sums)."""
    s = System()
    x0 = s.add_var("x0", -1, 1)
    x1 = s.add_var("x1", -1, 1)
    s.add_ineq(x0 * x0 + x1)
    comp = s.compile()
    x = [1e307, 1e300]
    with np.errstate(all="ignore"):
        rlo, rhi = Propagator(comp).eval_rows(np.array(x), np.array(x))
    assert encloses(rlo[0], rhi[0], exact_rows(comp, x)[0])


def test_hc4_regression_zero_coefficient():
    """A coefficient that underflowed to 0.0 (``Expr * float`` keeps it) made the projection
    divide by zero: numba raised ZeroDivisionError (with IEEE division it would have turned
    ``[-1, 1] / 0`` into an empty interval)."""
    s = System()
    x0 = s.add_var("x0", -1, 1)
    x1 = s.add_var("x1", -1, 1)
    s.add_eq((x0 * 1e-300 + x1 * 2.0**600 - 0.5 * 2.0**600) * 1e-300)  # x0's coefficient: 0.0
    comp = s.compile()
    assert 0.0 in comp.A.data
    r = Propagator(comp).contract(np.array([-1.0, -1.0]), np.array([1.0, 1.0]))
    assert r is not None
    assert r[0][0] == -1.0 and r[1][0] == 1.0 and r[0][1] <= 0.5 <= r[1][1]


# -- the LP alone ----------------------------------------------------------------------------


def exact_monomial_hull(comp, lo, hi):
    """The exact range of every monomial over the box, rounded outward (independent of
    kinbox.interval)."""
    mlo, mhi = [], []
    for i, j in zip(comp.mi, comp.mj):
        if i == j:
            vals = [X(lo[i]) ** 2, X(hi[i]) ** 2] + ([arb(0)] if lo[i] <= 0 <= hi[i] else [])
        else:
            vals = [X(a) * X(b) for a in (lo[i], hi[i]) for b in (lo[j], hi[j])]
        mlo.append(arb_down(min(vals, key=lambda v: float(v.mid()))))
        mhi.append(arb_up(max(vals, key=lambda v: float(v.mid()))))
    return np.array(mlo, dtype=float), np.array(mhi, dtype=float)


class RecordingRelaxation(Relaxation):
    """Records every multiplier vector the Farkas check accepted."""

    def __init__(self, comp):
        super().__init__(comp)
        self.certificates = []

    def _farkas(self, y):
        ok = super()._farkas(y)
        if ok:
            self.certificates.append(np.array(y, dtype=float))
        return ok


@sound(150)
@given(lp_case(near=True))
def test_lp_relaxation_rows_hold_at_every_point_of_the_box(case):
    s, _, lo, hi = case
    comp = s.compile()
    relax = Relaxation(comp)
    mlo, mhi = exact_monomial_hull(comp, lo, hi)
    relax.build(lo, hi, mlo, mhi)
    rows = lp_rows(relax)
    # tangent points of the parabolas (where the tangent rows are tight)
    tangents = [[2 * (lo[i] + f * (hi[i] - lo[i])) / 2 for i in range(comp.n)] for f in (0.0, 1.0, 0.5)]
    for p in grid_points(lo, hi, tangents):
        z = exact_z(comp, p)
        for r in range(relax.n_base, relax.nrow):  # the relaxation rows: valid everywhere
            v = arb(0)
            for j, a in rows[r]:
                v += X(a) * z[j]
            rl, rh = relax.row_lo[r], relax.row_hi[r]
            # a NaN bound (products that overflowed) is read as no bound by HiGHS and the checks
            assert math.isnan(rl) or rl == -INF or X(rl) <= v, (r, rl, v, p)
            assert math.isnan(rh) or rh == INF or v <= X(rh), (r, rh, v, p)


@sound(150)
@given(lp_case(near=True), st.data())
def test_safe_lower_is_below_the_exact_dual_bound(case, data):
    """Any multipliers give a valid bound; the compiled one must be below its exact value."""
    s, _, lo, hi = case
    comp = s.compile()
    relax = Relaxation(comp)
    relax.build(lo, hi, *exact_monomial_hull(comp, lo, hi))
    # multipliers of mixed magnitudes make the sums cancel, where their rounding shows
    ys = st.one_of(
        st.just(0.0),
        reals,
        st.floats(-2.0, 2.0),
        st.sampled_from([1.0, -1.0, 0.5]),
        st.builds(math.ldexp, st.integers(-7, 7), st.integers(-60, 60)),
    )
    y = np.array([data.draw(ys) for _ in range(relax.nrow)])
    k = data.draw(st.integers(0, relax.nz - 1))
    sense = data.draw(st.sampled_from([1.0, -1.0]))
    with np.errstate(all="ignore"):
        lb = _safe_lower(
            k,
            sense,
            y,
            relax.start,
            relax.index,
            relax.value,
            relax.row_lo,
            relax.row_hi,
            relax.zlo,
            relax.zhi,
            relax.zmag,
            relax.gamma_col,
            relax.tiny_col,
        )
    if lb == -INF:
        return
    assert not math.isnan(lb)
    # exact: sense z_k = r^T z + y~^T G z >= min_box r^T z + min_rows y~^T w
    bound = exact_dual_bound(k, sense, y, relax.start, relax.index, relax.value, relax.row_lo, relax.row_hi, relax.zlo, relax.zhi)
    assert X(lb) <= bound, (lb, bound)


SYN_VALUES = [1.0, 1.0, -1.0, 0.5, 0.1, -1 / 3, 2.0**40, 1e-17, SUB]
SYN_BOUNDS = [1.0, -1.0, 1.0, -1.0, 0.0, 0.1, 2.0**60, -(2.0**60), 1e-300]
SYN_Y = [1.0, -1.0, 2.0**60, -(2.0**60), 2.0**60, -(2.0**60), 0.0, 0.1, -1 / 3, 1e-17, -SUB]


@st.composite
def synthetic_lp(draw):
    """Small LPs for _safe_lower alone, with values, bounds and multipliers from pools, so
    that equal magnitudes cancel and the rounding of its sums matters."""
    nz, nrow = draw(st.integers(1, 4)), draw(st.integers(1, 6))
    start, index, value = [0], [], []
    for _ in range(nrow):
        cols = draw(st.lists(st.integers(0, nz - 1), min_size=1, max_size=3, unique=True))
        index += cols
        value += [draw(st.sampled_from(SYN_VALUES)) for _ in cols]
        start.append(len(index))
    row_lo, row_hi = [], []
    for _ in range(nrow):
        a, b = draw(st.sampled_from(SYN_BOUNDS)), draw(st.sampled_from(SYN_BOUNDS))
        lo_, hi_ = min(a, b), max(a, b)
        shape = draw(st.sampled_from(["both", "both", "eq", "le", "ge"]))
        row_lo.append(-INF if shape == "le" else (hi_ if shape == "eq" else lo_))
        row_hi.append(INF if shape == "ge" else hi_)
    zlo, zhi = [], []
    for _ in range(nz):
        # often a variable pinned at 0: its term then carries no rounding slack of its own
        a, b = (0.0, 0.0) if draw(st.booleans()) else (draw(st.sampled_from(SYN_BOUNDS)), draw(st.sampled_from(SYN_BOUNDS)))
        zlo.append(min(a, b))
        zhi.append(max(a, b))
    y = [draw(st.sampled_from(SYN_Y)) for _ in range(nrow)]
    return (
        np.array(start, dtype=np.int32),
        np.array(index, dtype=np.int32),
        np.array(value),
        np.array(row_lo),
        np.array(row_hi),
        np.array(zlo),
        np.array(zhi),
        np.array(y),
        draw(st.integers(0, nz - 1)),
        draw(st.sampled_from([1.0, -1.0])),
    )


def exact_dual_bound(k, sense, y, start, index, value, row_lo, row_hi, zlo, zhi) -> arb:
    """min over the box of r^T z plus min over the row bounds of y~^T w, exactly, with
    r = sense e_k - G^T y~ and y~ = y without the rows unbounded on their side."""
    nz = len(zlo)
    r = [arb(0) for _ in range(nz)]
    r[k] = arb(sense)
    bound = arb(0)
    for i in range(len(start) - 1):
        yi = y[i]
        b = row_lo[i] if yi > 0 else row_hi[i]
        if yi == 0.0 or abs(b) == INF:  # a row unbounded on its side counts with y_i = 0
            continue
        for p in range(start[i], start[i + 1]):
            r[index[p]] -= X(value[p]) * X(yi)
        bound += X(yi) * X(b)
    for j in range(nz):
        bound += min(r[j] * X(zlo[j]), r[j] * X(zhi[j]), key=lambda v: float(v.mid()))
    return bound


# 2^60 + 1 - 2^60 summed in this order is 0, not 1, and the one column is pinned at 0, so no
# slack for the rounding of r covers it: only the final gamma of the sum keeps the bound below
# the exact one (-1). Random pools find such cases only every few thousand draws.
CANCELLING_LP = (
    np.array([0, 1, 2, 3], dtype=np.int32),
    np.zeros(3, dtype=np.int32),
    np.ones(3),
    np.array([1.0, -1.0, 1.0]),
    np.array([1.0, -1.0, 1.0]),
    np.zeros(1),
    np.zeros(1),
    np.array([2.0**60, 1.0, -(2.0**60)]),
    0,
    1.0,
)


@sound(300)
@given(synthetic_lp())
@example(CANCELLING_LP)
def test_safe_lower_on_synthetic_lps(lp):
    start, index, value, row_lo, row_hi, zlo, zhi, y, k, sense = lp
    col_nnz = np.bincount(index, minlength=len(zlo))  # as Relaxation sets them up
    gamma_col, tiny_col = iv.gamma(col_nnz + 2), (col_nnz + 1) * TINY
    zmag = np.maximum(np.abs(zlo), np.abs(zhi))
    with np.errstate(all="ignore"):
        lb = _safe_lower(k, sense, y, start, index, value, row_lo, row_hi, zlo, zhi, zmag, gamma_col, tiny_col)
    if lb == -INF:
        return
    assert X(lb) <= exact_dual_bound(k, sense, y, start, index, value, row_lo, row_hi, zlo, zhi)


@sound(150)
@given(lp_case(near=True))
def test_lp_bounds_keep_the_planted_root_and_every_sampled_solution(case):
    s, x, lo, hi = case
    comp = s.compile()
    relax = RecordingRelaxation(comp)
    relax.build(lo, hi, *exact_monomial_hull(comp, lo, hi))
    sols = [x] + [p for p in grid_points(lo, hi) if is_solution(comp, p)]
    zs = [fz(comp, p) for p in sols]
    for k in range(relax.nz):
        for sense in (1, -1):
            b, infeasible = relax.bound(k, sense)
            assert not infeasible, "the LP declared a box holding a root empty"
            if b is None:
                continue
            for z in zs:
                assert (b <= z[k]) if sense > 0 else (z[k] <= b), (k, sense, b, z[k])


@sound(150)
@given(lp_case(near=False))
def test_lp_infeasible_verdicts_carry_an_exact_farkas_certificate(case):
    s, x, lo, hi = case
    comp = s.compile()
    relax = RecordingRelaxation(comp)
    relax.build(lo, hi, *exact_monomial_hull(comp, lo, hi))
    holds_root = in_box(lo, hi, x)
    for k in range(relax.nz):
        for sense in (1, -1):
            _, infeasible = relax.bound(k, sense)
            if infeasible:
                assert not holds_root
                assert relax.certificates and farkas_holds(relax, relax.certificates[-1])
    event(f"Farkas certificates: {'some' if relax.certificates else 'none'}")
    for y in relax.certificates:
        assert farkas_holds(relax, y)


def test_lp_farkas_path_is_reached_and_exact():
    """0.1 x0 = 0 on x0 in [0.5, 0.5]: infeasible, and HiGHS returns a dual ray (with its
    primal simplex it often proves infeasibility without one, and then nothing is pruned)."""
    s = System()
    x0 = s.add_var("x0", -1, 1)
    x1 = s.add_var("x1", -1, 1)
    s.add_eq(x0 * 0.1)
    s.add_eq(x1 * x1 - 0.25)
    comp = s.compile()
    relax = RecordingRelaxation(comp)
    lo, hi = np.array([0.5, -1.0]), np.array([0.5, 1.0])
    relax.build(lo, hi, *exact_monomial_hull(comp, lo, hi))
    assert relax.bound(1, 1) == (None, True)
    assert relax.certificates and all(farkas_holds(relax, y) for y in relax.certificates)


# -- Krawczyk alone --------------------------------------------------------------------------

SMALL = st.integers(-4, 4)


@st.composite
def square_with_roots(draw, two: bool):
    """A square system (n core equations) with one planted root, or two:
    ``(System, roots, scale)``.

    Each equation is a random quadratic ``q`` plus linear terms; with two roots r1, r2 that
    differ by a power of two in coordinate p, the coefficient of x_p and the constant are
    solved for so that both vanish. Then everything is moved to another scale (``x = 2^e y``:
    quadratic coefficients times ``2^-e``, constants times ``2^e``, down to the subnormals and
    up to 2^300) and each equation scaled by a power of two. Coordinates of the roots may be
    divided by 3, 5 or 7 (real roots that are not floats), their coefficients then multiplied
    by it; every coefficient is checked to be exactly a float. Roots are Fractions."""
    n = draw(st.integers(1, 3))
    p = draw(st.integers(0, n - 1))
    den = [1 if two and i == p else draw(DENOMINATORS) for i in range(n)]
    r1 = [Fraction(draw(st.integers(-32, 32)), 16 * d) for d in den]
    r2 = list(r1)
    if two:
        gap = Fraction(2) ** draw(st.sampled_from([1, 0, -3, -10, -20, -30, -40]))
        r2[p] = r1[p] + gap * draw(st.sampled_from([1, -1]))
        for i in range(n):
            if i != p and draw(st.booleans()):
                r2[i] = r1[i] + Fraction(draw(SMALL), 8)
    e = draw(st.sampled_from([0, 0, 0, 0, -30, 40, -600, -1000, -1030, 300]))
    scale = Fraction(2) ** e
    r1 = [v * scale for v in r1]
    r2 = [v * scale for v in r2]
    keys = [(i, j) for i in range(n) for j in range(i, n)]
    s = System()
    for i in range(n):
        lo_, hi_ = min(r1[i], r2[i]), max(r1[i], r2[i])
        s.add_var(f"x{i}", float_down(lo_ - 4 * scale), float_up(hi_ + 4 * scale))
    for _ in range(n):
        q = {k: Fraction(draw(SMALL)) * den[k[0]] * den[k[1]] / scale for k in draw(st.lists(st.sampled_from(keys), max_size=3))}
        lin = {(i,): Fraction(draw(SMALL)) * den[i] for i in range(n)}
        if two:
            dq = exact_value(q, r1) - exact_value(q, r2)
            rest = sum(lin[(i,)] * (r1[i] - r2[i]) for i in range(n) if i != p)
            lin[(p,)] = -(dq + rest) / (r1[p] - r2[p])
        row = Fraction(2) ** draw(st.sampled_from([0, 0, 0, -40, 30, -1000]))
        terms = {k: v * row for k, v in {**q, **lin}.items() if v != 0}
        c = -exact_value(terms, r1)
        fl = {k: to_float_exact(v) for k, v in terms.items()}
        cf = to_float_exact(c) if c != 0 else 0.0
        assume(cf is not None and all(v is not None for v in fl.values()))
        ex = Expr(fl)
        if cf != 0.0:
            ex.terms[()] = cf
        assume(ex.degree > 0)
        s.add_eq(ex)
    assume(s.count("core") == n)
    roots = [r1] + ([r2] if two else [])
    return s, roots, scale


@st.composite
def box_around_all(draw, roots, scale=Fraction(1)):
    """The tightest float box around the roots, widened per side by a width times the scale."""
    n = len(roots[0])
    widths = [0, 2**-52, 2**-44, 2**-38, 2**-38, 1e-9, 1e-9, 2**-20, 0.01, 0.25, 1]
    lo = [float_down(min(r[i] for r in roots) - scale * Fraction(draw(st.sampled_from(widths)))) for i in range(n)]
    hi = [float_up(max(r[i] for r in roots) + scale * Fraction(draw(st.sampled_from(widths)))) for i in range(n)]
    return np.array(lo), np.array(hi)


def approx(r) -> np.ndarray:
    return np.array([float(v) for v in r])


def krawczyk_checked(comp, roots, lo, hi, x0):
    for r in roots:
        assert all(v == 0 for v in rows_q(comp, r))  # both are roots, exactly
    res = Certifier(comp).krawczyk(lo, hi, x0)
    event(f"Krawczyk: {res.status}")  # --hypothesis-show-statistics: how often each verdict
    assert res.status != "empty", "Krawczyk declared a box holding a root empty"
    for r in roots:
        assert in_box(res.lo, res.hi, r), (res, r)
    return res


@sound(300)
@given(square_with_roots(two=False), st.data())
def test_krawczyk_keeps_a_planted_root(case, data):
    s, roots, scale = case
    comp = s.compile()
    lo, hi = data.draw(box_around_all(roots, scale))
    x0 = data.draw(st.sampled_from([None, "root", "corner"]))
    x0 = {None: None, "root": approx(roots[0]), "corner": lo.copy()}[x0]
    res = krawczyk_checked(comp, roots, lo, hi, x0)
    if res.status == "unique":  # iterate as tighten does: the root stays in every K(B)
        for _ in range(3):
            res = krawczyk_checked(comp, roots, res.lo, res.hi, None)


@sound(300)
@given(square_with_roots(two=True), st.data())
def test_krawczyk_never_proves_uniqueness_with_two_roots(case, data):
    s, roots, scale = case
    comp = s.compile()
    lo, hi = data.draw(box_around_all(roots, scale))
    x0 = data.draw(st.sampled_from([None, 0, 1]))
    x0 = None if x0 is None else approx(roots[x0])
    res = krawczyk_checked(comp, roots, lo, hi, x0)
    assert res.status != "unique", "Krawczyk proved uniqueness in a box with two roots"
    # one root alone, in a box narrower than the gap to the other: near a second root the
    # Jacobian is nearly singular and Y = J(x0)^-1 magnifies every rounding error; the root
    # must stay in K(B), also as tighten iterates it
    r1, r2 = roots
    gap = max(abs(a - b) for a, b in zip(r1, r2))
    f = Fraction(data.draw(st.sampled_from([2**-60, 2**-40, 2**-20, 2**-8, 2**-3, 0.25])))
    lo = np.array([float_down(v - f * gap) for v in r1])
    hi = np.array([float_up(v + f * gap) for v in r1])
    res = krawczyk_checked(comp, [r1], lo, hi, None)
    for _ in range(3):
        if res.status not in ("unique", "contracted"):
            break
        res = krawczyk_checked(comp, [r1], res.lo, res.hi, None)


@sound(300)
@given(square_with_roots(two=True), st.data())
def test_uniqueness_condition_fails_on_a_box_holding_two_roots(case, data):
    """Krawczyk's uniqueness condition alone (:meth:`Certifier.at_most_one_zero`): on a box
    holding both planted roots, about any ``x0`` in it, it must not claim at most one zero. The
    Krawczyk tests above rarely reach it with two roots (``K`` around both seldom lies inside
    the box), so it is tested here by itself."""
    s, roots, scale = case
    comp = s.compile()
    lo, hi = data.draw(box_around_all(roots, scale))
    t = np.array(data.draw(st.lists(st.sampled_from([0.0, 0.25, 0.5, 0.9, 1.0]), min_size=len(lo), max_size=len(lo))))
    x0 = np.clip(lo + t * (hi - lo), lo, hi)
    holds = Certifier(comp).at_most_one_zero(lo, hi, x0)
    event(f"uniqueness condition: {holds}")
    assert not holds, "the uniqueness condition held on a box with two roots"


def test_uniqueness_condition_tells_one_root_from_two():
    """``x^2 = 2``: the condition holds on a box around one root and fails on one around both."""
    s = System()
    s.add_var("x", -4.0, 4.0)
    s.add_eq(Expr({(0, 0): 1.0, (): -2.0}))
    cert = Certifier(s.compile())
    r = math.sqrt(2.0)
    one = np.array([r - 0.01]), np.array([r + 0.01])
    both = np.array([-1.5]), np.array([1.5])
    assert cert.at_most_one_zero(*one, np.array([r]))
    assert not cert.at_most_one_zero(*both, np.array([0.5]))


# -- domain and slack ------------------------------------------------------------------------


@sound(300)
@given(st.lists(st.tuples(reals, reals), min_size=1, max_size=4))
def test_search_domain_is_the_domain_widened_by_the_slack(doms):
    s = System()
    for k, (a, b) in enumerate(doms):
        s.add_var(f"x{k}", min(a, b), max(a, b))
    lo, hi = s.domain()
    with np.errstate(all="ignore"):
        slo, shi = s.search_domain()
    for a, b, sa, sb in zip(lo, hi, slo, shi):
        assert sa < a and sb > b
        for end, wide in ((a, sa), (b, sb)):
            if math.isfinite(wide):  # widened by SLACK of the bound (at least of 1), rounding aside
                gap = abs(Fraction(wide) - Fraction(end))
                assert gap >= Fraction(SLACK) * max(1, abs(Fraction(end))) * Fraction(99, 100)


def perturbed(v: float, ulps: int) -> float:
    return step(v, ulps)


@st.composite
def derived_case(draw):
    """A square core with one planted root, plus a redundant equation and an inequality that
    are exact combinations of the core rows at the root, then moved a few ulps per coefficient
    as a floating-point derivation leaves them."""
    s, roots, scale = draw(square_with_roots(two=False))
    x = roots[0]
    core = [c.expr for c in s.constraints]
    for kind in ("redundant", "ineq"):
        comb: dict = {}
        for e in core:  # a combination with float multipliers, as a derivation computes it
            lam = draw(st.sampled_from([1.0, -0.5, 0.1, 3.0, 1 / 3, 0.0]))
            for k, v in e.terms.items():
                comb[k] = comb.get(k, 0.0) + lam * v  # rounded: that is the point
        comb = {k: perturbed(v, draw(st.integers(-8, 8))) for k, v in comb.items() if v != 0.0}
        if not any(k for k in comb):
            continue
        e = Expr(comb)
        if kind == "ineq":  # tight at the root up to the perturbation, either side
            s.add_ineq(e)
        else:
            s.add_eq(e, redundant=True)
    return s, x, scale


@sound(200)
@given(derived_case(), st.data())
def test_derived_rows_hold_within_their_slack_and_nothing_prunes_the_root(case, data):
    s, x, scale = case
    comp = s.compile()
    # every row, core included, holds up to a positive slack: its targets are -c -+ slack
    assert np.all(comp.slack > 0.0)
    assert np.array_equal(comp.target_lo[: comp.n_eq], -comp.c[: comp.n_eq] - comp.slack[: comp.n_eq])
    assert np.array_equal(comp.target_hi, -comp.c + comp.slack)
    assert np.all(comp.target_lo[comp.n_eq :] == -INF)
    # the derived rows hold at the root within their slack (exactly), so x* is a solution
    assert is_solution(comp, x)
    # HC4 alone, from the search domain and from boxes around the root
    prop = Propagator(comp)
    slo, shi = s.search_domain()
    for lo, hi in [(slo, shi), data.draw(box_around(x))]:
        r = prop.contract(lo, hi, max_sweeps=8, tol=0.0)
        assert r is not None, "HC4 pruned a root of the core with a derived row"
        assert box_holds(np.concatenate([r[0], r[2]]), np.concatenate([r[1], r[3]]), comp, x)
    # the LP alone, on a small box around the root
    w = scale * Fraction(data.draw(st.sampled_from([0, 2**-40, 1e-6, 0.25])))
    lo = np.array([float_down(v - w) for v in x])
    hi = np.array([float_up(v + w) for v in x])
    relax = Relaxation(comp)
    relax.build(lo, hi, *exact_monomial_hull(comp, lo, hi))
    z = fz(comp, x)
    for k in range(comp.n):
        for sense in (1, -1):
            b, infeasible = relax.bound(k, sense)
            assert not infeasible
            if b is not None:
                assert (b <= z[k]) if sense > 0 else (z[k] <= b)


def test_slack_regression_rows_of_subnormal_size():
    """2^1000 x^2 = 2^-1060 (root 2^-1030, domain |x| <= 2^-1028), and the same row derived 8
    ulps off in its (subnormal) constant. The row's size was |c| + 2^1000 (2^-1028)^2 with the
    square underflowing to 0, and 1e-10 |c| underflows too: the derived row got no slack, so
    the exact LP of any box around the root was empty (hidden only by the TINY paddings of the
    contractors). Sizes now count every coefficient as at least the smallest normal number."""
    s = System()
    x = s.add_var("x", -(2.0**-1028), 2.0**-1028)
    s.add_eq(x * x * 2.0**1000 - 2.0**-1060)
    s.add_eq(x * x * 2.0**1000 - step(2.0**-1060, 8), redundant=True)
    comp = s.compile()
    assert comp.slack[1] > 0.0
    assert is_solution(comp, [Fraction(2) ** -1030])


def test_root_a_few_ulps_outside_the_domain_is_in_the_search_domain():
    """A bound computed in floating point (a limit's cosine) can miss the root by ulps."""
    s = System()
    c = s.add_var("c", -1.0, float(np.nextafter(0.5, -INF)))  # the root c = 0.5 is 1 ulp out
    s.add_eq(c * 2.0 - 1.0)
    lo, hi = s.search_domain()
    assert lo[0] <= 0.5 <= hi[0]
    r = Propagator(s.compile()).contract(lo, hi)
    assert r is not None and r[0][0] <= 0.5 <= r[1][0]
