"""Soundness of the Bernstein-polytope contractor (Fünfzig et al. 2010, ``kinbox.search.bernstein``) on its own,
against exact arithmetic (Fractions, and python-flint's ``arb`` for the Farkas certificates).

The cases are those of ``test_soundness_arb.py``: small systems with a planted root that is
often not a float (a rational with denominator 3, 5 or 7), coefficients down to the
subnormals, pinned variables, boxes from a few ulps to 4 wide. Checked here:

* the rescaled rows (the system's rows in the unit box's coordinates, float coefficients,
  widened bounds) hold for *every* point of the unit box: with the exact rescaled coefficients
  ``c`` (Fractions) and the float ones ``c^``, the row bound is beyond ``tlo - K - sum max(0,
  c - c^)`` (the worst case over ``T in [0, 1]``); and the rescaling itself is the identity
  ``row(u + w X) = sum c T + K`` at sample points;
* the polytope rows and the column bounds hold at the exact ``(X, M)`` of every sample point
  of the box, the planted root included;
* LP bounds of single columns never cut off the planted root or a sampled solution, and a
  contraction (with and without the square-root reduction of Fünfzig et al. 2010, Sec. 6) keeps them;
* an "empty" verdict comes only on boxes without the planted root, each with a Farkas
  certificate that holds in exact arithmetic.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from flint import ctx
from hypothesis import event, given, note
from hypothesis import strategies as st

from kinbox.formulation.system import System
from kinbox.search.bernstein import BernsteinLP, BernsteinRelaxation
from tests.support.arb import (
    PREC,
    farkas_holds,
    grid_points,
    in_box,
    is_solution,
    lp_case,
    sound,
)


@pytest.fixture(autouse=True, scope="module")
def _exact_precision():
    old = ctx.prec
    ctx.prec = PREC
    yield
    ctx.prec = old


class RecordingBernstein(BernsteinLP):
    """Records every multiplier vector the Farkas check accepted."""

    def __init__(self, comp):
        super().__init__(comp)
        self.certificates: list[np.ndarray] = []

    def _farkas(self, y):
        ok = super()._farkas(y)
        if ok:
            self.certificates.append(np.array(y, dtype=float))
        return ok


def unit_point(lp, x) -> list[Fraction]:
    """The exact ``(X, M)`` of the point ``x`` (floats or Fractions) in the LP's unit box."""
    X = []
    for i, v in enumerate(x):
        w = Fraction(lp.w[i])
        X.append(Fraction(0) if w == 0 else (Fraction(v) - Fraction(lp.u[i])) / w)
    return X + [X[i] * X[j] for i, j in zip(lp.mi, lp.mj)]


def exact_rescaled(comp, u, w):
    """Per row: the exact coefficients of the row in ``(X, M)`` (a dict column -> Fraction) and
    its exact constant, from ``x_i = u_i + w_i X_i`` written out in Fractions."""
    A = comp.A.tocsr()
    n = comp.n
    out = []
    for r in range(A.shape[0]):
        coef: dict[int, Fraction] = {}
        K = Fraction(0)
        for p in range(A.indptr[r], A.indptr[r + 1]):
            c, a = int(A.indices[p]), Fraction(A.data[p])
            if c < n:
                coef[c] = coef.get(c, Fraction(0)) + a * Fraction(w[c])
                K += a * Fraction(u[c])
            else:
                i, j = int(comp.mi[c - n]), int(comp.mj[c - n])
                ui, uj, wi, wj = (Fraction(v) for v in (u[i], u[j], w[i], w[j]))
                coef[c] = coef.get(c, Fraction(0)) + a * wi * wj
                coef[i] = coef.get(i, Fraction(0)) + a * wi * uj
                coef[j] = coef.get(j, Fraction(0)) + a * ui * wj
                K += a * ui * uj
        out.append((coef, K))
    return out


def lp_row(lp, r) -> dict[int, Fraction]:
    a, b = lp.start[r], lp.start[r + 1]
    row: dict[int, Fraction] = {}
    for j, v in zip(lp.index[a:b].tolist(), lp.value[a:b].tolist()):
        row[j] = row.get(j, Fraction(0)) + Fraction(v)
    return row


def row_value(row: dict[int, Fraction], z: list[Fraction]) -> Fraction:
    return sum((a * z[j] for j, a in row.items()), Fraction(0))


def holds(lo: float, hi: float, v: Fraction) -> bool:
    return (lo == -math.inf or Fraction(lo) <= v) and (hi == math.inf or v <= Fraction(hi))


@sound(100)
@given(lp_case(near=True), st.data())
def test_bernstein_rows_enclose_the_exact_rescaled_rows(case, data):
    s, x, lo, hi = case
    comp = s.compile()
    lp = BernsteinLP(comp)
    with np.errstate(all="ignore"):
        lp.build(lo, hi)
    # the unit box: w_i is at least the width, zero only for a pinned variable
    for i in range(comp.n):
        assert Fraction(lp.u[i]) == Fraction(lo[i])
        assert Fraction(lp.w[i]) >= Fraction(hi[i]) - Fraction(lo[i])
        assert lp.w[i] > 0 or lo[i] == hi[i]
    exact = exact_rescaled(comp, lp.u, lp.w)
    tlo, thi = comp.target_lo, comp.target_hi
    dropped = 0
    for r, (coef, K) in enumerate(exact):
        rl, rh = lp.row_lo[r], lp.row_hi[r]
        assert not (math.isnan(rl) or math.isnan(rh))
        row = lp_row(lp, r)
        if rl == -math.inf and rh == math.inf:
            dropped += 1
            continue
        for j, c in coef.items():
            assert c == 0 or j in row, (r, j, c)
        over = sum((max(Fraction(0), c - row.get(j, Fraction(0))) for j, c in coef.items()), Fraction(0))
        under = sum((max(Fraction(0), row.get(j, Fraction(0)) - c) for j, c in coef.items()), Fraction(0))
        extra = [a for j, a in row.items() if j not in coef]  # pattern entries of the row with no term
        over += sum((max(Fraction(0), -a) for a in extra), Fraction(0))
        under += sum((max(Fraction(0), a) for a in extra), Fraction(0))
        if tlo[r] > -math.inf:
            assert rl == -math.inf or Fraction(rl) <= Fraction(tlo[r]) - K - over, (r, rl)
        if thi[r] < math.inf:
            assert rh == math.inf or Fraction(rh) >= Fraction(thi[r]) - K + under, (r, rh)
    event(f"rows dropped: {'some' if dropped else 'none'}")
    # the rescaling is the identity: the row of the system at u + w X equals sum c T + K
    A = comp.A.tocsr()
    for _ in range(2):
        Xs = [Fraction(data.draw(st.integers(0, 8)), 8) for _ in range(comp.n)]
        xs = [Fraction(lp.u[i]) + Fraction(lp.w[i]) * Xs[i] for i in range(comp.n)]
        z = xs + [xs[i] * xs[j] for i, j in zip(comp.mi, comp.mj)]
        T = Xs + [Xs[i] * Xs[j] for i, j in zip(comp.mi, comp.mj)]
        for r, (coef, K) in enumerate(exact):
            direct = sum((Fraction(A.data[p]) * z[A.indices[p]] for p in range(A.indptr[r], A.indptr[r + 1])), Fraction(0))
            assert direct == sum((c * T[j] for j, c in coef.items()), Fraction(0)) + K


@sound(80)
@given(lp_case(near=True))
def test_bernstein_polytope_and_columns_hold_at_every_point_of_the_box(case):
    s, x, lo, hi = case
    comp = s.compile()
    lp = BernsteinLP(comp)
    with np.errstate(all="ignore"):
        lp.build(lo, hi)
    pts = [[Fraction(v) for v in p] for p in grid_points(lo, hi)] + [x]
    rows = [lp_row(lp, r) for r in range(lp.nrow)]
    for p in pts:
        z = unit_point(lp, p)
        assert in_box(lp.zlo, lp.zhi, z)
        for r in range(lp.n_base, lp.nrow):
            assert holds(lp.row_lo[r], lp.row_hi[r], row_value(rows[r], z)), (r, p)
        for r in range(lp.n_base):  # base rows: hold wherever the point solves the row
            if is_solution(comp, p):
                assert holds(lp.row_lo[r], lp.row_hi[r], row_value(rows[r], z)), (r, p)


@sound(80)
@given(lp_case(near=True))
def test_bernstein_bounds_keep_the_planted_root_and_every_sampled_solution(case):
    s, x, lo, hi = case
    comp = s.compile()
    lp = RecordingBernstein(comp)
    with np.errstate(all="ignore"):
        lp.build(lo, hi)
    sols = [x] + [[Fraction(v) for v in p] for p in grid_points(lo, hi) if is_solution(comp, p)]
    zs = [unit_point(lp, p) for p in sols]
    for k in range(lp.nz):
        for sense in (1, -1):
            b, infeasible = lp.bound(k, sense)
            assert not infeasible, "the Bernstein LP declared a box holding a root empty"
            if b is None:
                continue
            for z in zs:
                assert (b <= z[k]) if sense > 0 else (z[k] <= b), (k, sense, b, z[k])
            if k < comp.n:  # mapped back to x
                xl, xh = lp.to_x(k, b, b)
                for p in sols:
                    assert (Fraction(xl) <= p[k]) if sense > 0 else (p[k] <= Fraction(xh))


@sound(80)
@given(lp_case(near=True), st.booleans(), st.data())
def test_bernstein_contraction_keeps_the_planted_root(case, squares, data):
    s, x, lo, hi = case
    comp = s.compile()
    mask = np.ones(comp.n, dtype=bool)
    con = BernsteinRelaxation(comp, mask, np.maximum(hi - lo, 1e-300), pay=data.draw(st.sampled_from([1.0, 0.0])), squares=squares)
    sols = [x] + [[Fraction(v) for v in p] for p in grid_points(lo, hi) if is_solution(comp, p)]
    note(f"x*={x} lo={lo.tolist()} hi={hi.tolist()}")
    for _ in range(3):  # contract, then contract the result again (a new unit box each time)
        with np.errstate(all="ignore"):
            c = con.contract(lo, hi)
        assert not c.empty, "the Bernstein contractor declared a box holding a root empty"
        for p in sols:
            assert in_box(c.lo, c.hi, p), (p, c.lo, c.hi)
        event(f"narrowed: {bool(np.any(c.lo > lo) or np.any(c.hi < hi))}")
        lo, hi = c.lo, c.hi


@sound(80)
@given(lp_case(near=False), st.booleans())
def test_bernstein_empty_verdicts_only_without_roots_and_with_exact_certificates(case, squares):
    s, x, lo, hi = case
    comp = s.compile()
    holds_root = in_box(lo, hi, x)
    con = BernsteinRelaxation(comp, np.ones(comp.n, dtype=bool), np.maximum(hi - lo, 1e-300), pay=0.0, squares=squares)
    rec = RecordingBernstein(comp)
    con.relax = rec
    with np.errstate(all="ignore"):
        c = con.contract(lo, hi)
    if c.empty:
        assert not holds_root
    elif holds_root:
        assert in_box(c.lo, c.hi, x)
    event(f"empty: {c.empty}; Farkas certificates: {'some' if rec.certificates else 'none'}")
    for y in rec.certificates:
        assert farkas_holds(rec, y)


def test_bernstein_reduction_example_of_the_paper():
    """Fünfzig et al. 2010, Sec. 4.2: 4 x^2 + x - 3 = 0 on [0, 1] reduces x to [3/5, 7/9] in the Bernstein
    polytope; the root 3/4 stays in it, and the square-root reduction (Sec. 6) narrows further
    around it."""
    s = System()
    x = s.add_var("x", 0, 1)
    s.add_eq(x * x * 4.0 + x - 3.0)
    comp = s.compile()
    con = BernsteinRelaxation(comp, np.ones(1, dtype=bool), np.ones(1))
    c = con.contract(np.zeros(1), np.ones(1))
    assert c.status == "narrowed"
    assert abs(c.lo[0] - 0.6) < 1e-9 and abs(c.hi[0] - 7 / 9) < 1e-9
    assert c.lo[0] <= 0.75 <= c.hi[0]
    sq = BernsteinRelaxation(comp, np.ones(1, dtype=bool), np.ones(1), squares=True).contract(np.zeros(1), np.ones(1))
    assert sq.lo[0] <= 0.75 <= sq.hi[0] and sq.hi[0] - sq.lo[0] < c.hi[0] - c.lo[0]


def test_bernstein_proves_an_empty_box_empty():
    """x^2 + y^2 = 1 and (x - 3)^2 + y^2 = 1 do not meet."""
    s = System()
    x = s.add_var("x", -4, 4)
    y = s.add_var("y", -4, 4)
    s.add_eq(x * x + y * y - 1.0)
    s.add_eq((x - 3.0) * (x - 3.0) + y * y - 1.0)
    comp = s.compile()
    lp = RecordingBernstein(comp)
    con = BernsteinRelaxation(comp, np.ones(2, dtype=bool), np.full(2, 8.0), pay=0.0)
    con.relax = lp
    lo, hi = np.array([-4.0, -4.0]), np.array([4.0, 4.0])
    for _ in range(20):
        c = con.contract(lo, hi)
        if c.empty:
            break
        lo, hi = c.lo, c.hi
    assert c.empty
