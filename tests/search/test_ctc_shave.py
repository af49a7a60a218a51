"""The shaving contractor (3BCID over propagation, :mod:`kinbox.search.ctc_shave`) alone, and as
the optional step of the search.

Alone it must keep every solution of the box it is given. Two independent checks:

* planted roots: polynomial systems whose root is a dyadic rational (a float, or a third of one:
  a real that is no float), every row written so that it vanishes there exactly (checked with
  Fractions); boxes around the root, often with the root on the end of a slice;
* roots that are no floats at all, enclosed by python-flint's ``arb``: a circle and a line, or
  two circles, whose intersections are irrational; every root that lies in the box before it is
  shaved must not be certainly outside the box after.

In the search: the same answers as without it on the published problems (the general 6R loop's
16 certified solutions, the four-bar's two curves).
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from flint import arb, ctx
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from kinbox.errors import InputError
from kinbox.formulation.system import Expr, System
from kinbox.search.contract import Box, ContractStatus
from kinbox.search.ctc_propagation import CtcPropagation
from kinbox.search.ctc_shave import SLICES, STEP, CtcShave

CASES = settings(max_examples=120, deadline=None, derandomize=True, database=None, suppress_health_check=[HealthCheck.too_slow])


def shaver(s: System, lo: np.ndarray, hi: np.ndarray, slices: int = SLICES) -> CtcShave:
    comp = s.compile()
    return CtcShave(CtcPropagation(comp), np.ones(comp.n, dtype=bool), np.maximum(hi - lo, 1e-300), slices=slices)


# -- planted roots, exact in Fractions ---------------------------------------------------------

ROOTS = st.one_of(st.integers(-24, 24).map(lambda m: Fraction(m, 8)), st.integers(-24, 24).map(lambda m: Fraction(m, 24)))
COEFS = st.sampled_from([-3.0, -2.0, -1.0, -0.5, 0.25, 0.5, 1.0, 2.0, 3.0])


@st.composite
def planted(draw):
    """``(System, root)``: n <= 3 variables, n to n + 2 rows of degree <= 2 vanishing at the root
    (its constant exact), or an inequality it satisfies when the constant is no float."""
    n = draw(st.integers(1, 3))
    x = [draw(ROOTS) for _ in range(n)]
    s = System()
    for i in range(n):
        s.add_var(f"x{i}", -4.0, 4.0)
    keys = [(i,) for i in range(n)] + [(i, j) for i in range(n) for j in range(i, n)]
    for _ in range(draw(st.integers(n, n + 2))):
        ks = draw(st.lists(st.sampled_from(keys), min_size=1, max_size=4, unique=True))
        terms = {k: draw(COEFS) for k in ks}
        val = sum((Fraction(a) * math.prod((x[i] for i in k), start=Fraction(1)) for k, a in terms.items()), Fraction(0))
        e = Expr(dict(terms))
        if Fraction(float(-val)) == -val:
            if val != 0:
                e.terms[()] = float(-val)
            s.add_eq(e)
        else:  # a constant that is no float: the inequality e + c <= 0 with c rounded down
            c = float(-val)
            if Fraction(c) > -val:
                c = float(np.nextafter(c, -math.inf))
            e.terms[()] = c
            s.add_ineq(e)
    return s, x


def rows_at(comp, x) -> list[Fraction]:
    xq = [Fraction(v) for v in x]
    z = xq + [xq[i] * xq[j] for i, j in zip(comp.mi, comp.mj)]
    A = comp.A.tocsr()
    return [
        Fraction(comp.c[r]) + sum((Fraction(A.data[p]) * z[A.indices[p]] for p in range(A.indptr[r], A.indptr[r + 1])), Fraction(0))
        for r in range(A.shape[0])
    ]


def down(q: Fraction) -> float:
    f = float(q)
    return f if Fraction(f) <= q else float(np.nextafter(f, -math.inf))


def up(q: Fraction) -> float:
    return -down(-q)


@st.composite
def box_around(draw, x):
    """A box holding ``x``: per variable a width on each side, or the root on the end of one of
    the slices (``lo = root - k w / SLICES`` exactly), or the tightest float interval."""
    lo, hi = [], []
    for v in x:
        shape = draw(st.sampled_from(["widths", "widths", "slice-end", "tight"]))
        if shape == "tight":
            lo.append(down(v))
            hi.append(up(v))
        elif shape == "slice-end" and Fraction(float(v)) == v:
            w = draw(st.sampled_from([0.5, 1.0, 2.0, 4.0]))
            k = draw(st.integers(0, SLICES))
            lo.append(float(v) - k * w / SLICES)
            hi.append(lo[-1] + w)
        else:
            lo.append(down(v - Fraction(draw(st.sampled_from([0, 1, 3, 8, 40])), 16)))
            hi.append(up(v + Fraction(draw(st.sampled_from([0, 1, 3, 8, 40])), 16)))
    return np.array(lo), np.array(hi)


@CASES
@given(planted(), st.data())
def test_shaving_keeps_a_planted_root(case, data):
    s, x = case
    comp = s.compile()
    for r, v in enumerate(rows_at(comp, x)):  # the generator's promise, exactly
        assert v == 0 if r < comp.n_eq else v <= 0
    lo, hi = data.draw(box_around(x))
    assert all(Fraction(a) <= v <= Fraction(b) for a, b, v in zip(lo, hi, x))
    ctc = shaver(s, lo, hi, slices=data.draw(st.sampled_from([2, 3, SLICES])))
    r = ctc.contract(Box(lo, hi))
    event(f"shaving: {r.status}")
    assert r.status is not ContractStatus.EMPTY, "shaving declared a box holding a root empty"
    assert all(Fraction(a) <= v <= Fraction(b) for a, b, v in zip(r.lo, r.hi, x)), (r.lo, r.hi, x)
    assert np.all(r.lo >= lo) and np.all(r.hi <= hi)


# -- irrational roots, enclosed by arb -----------------------------------------------------------


@pytest.fixture(autouse=True, scope="module")
def _precision():
    old = ctx.prec
    ctx.prec = 256
    yield
    ctx.prec = old


def circle_line_roots(a, b, c, r2) -> list[tuple[arb, arb]]:
    """The real points of ``x^2 + y^2 = r2``, ``a x + b y = c`` (b != 0), as arb balls."""
    A, B, C, R = arb(a), arb(b), arb(c), arb(r2)
    # y = (C - A x) / B: (B^2 + A^2) x^2 - 2 A C x + C^2 - B^2 R = 0
    qa, qb, qc = B * B + A * A, -2 * A * C, C * C - B * B * R
    disc = qb * qb - 4 * qa * qc
    if not disc > 0:
        return []
    out = []
    for sign in (1, -1):
        x = (-qb + sign * disc.sqrt()) / (2 * qa)
        out.append((x, (C - A * x) / B))
    return out


def certainly_in(lo: float, hi: float, v: arb) -> bool:
    return arb(lo) <= v and v <= arb(hi)


def certainly_out(lo: float, hi: float, v: arb) -> bool:
    return v < arb(lo) or v > arb(hi)


SMALL = st.integers(-12, 12).map(lambda m: m / 4.0)


@CASES
@given(SMALL, SMALL.filter(lambda v: v != 0), SMALL, st.sampled_from([0.5, 1.0, 2.0, 3.0, 5.0]), st.data())
def test_shaving_keeps_irrational_roots_enclosed_by_arb(a, b, c, r2, data):
    s = System()
    x, y = s.add_var("x", -3.0, 3.0), s.add_var("y", -3.0, 3.0)
    s.add_eq(x * x + y * y - r2)
    s.add_eq(x * a + y * b - c)
    roots = circle_line_roots(a, b, c, r2)
    lo = np.array([data.draw(st.sampled_from([-3.0, -2.0, -1.0, -0.5, 0.0])) for _ in range(2)])
    hi = lo + np.array([data.draw(st.sampled_from([0.5, 1.0, 2.0, 3.0, 6.0])) for _ in range(2)])
    inside = [p for p in roots if certainly_in(lo[0], hi[0], p[0]) and certainly_in(lo[1], hi[1], p[1])]
    r = shaver(s, lo, hi).contract(Box(lo, hi))
    event(f"roots inside: {len(inside)}, shaving: {r.status}")
    if inside:
        assert r.status is not ContractStatus.EMPTY
        for p in inside:
            assert not (certainly_out(r.lo[0], r.hi[0], p[0]) or certainly_out(r.lo[1], r.hi[1], p[1])), (p, r.lo, r.hi)
    else:
        outside = all(certainly_out(lo[0], hi[0], p[0]) or certainly_out(lo[1], hi[1], p[1]) for p in roots)
        if outside:  # no root in the box: it may well be proven empty, never narrowed past a root
            event("no root in the box")


def test_shaving_narrows_where_propagation_alone_does_not():
    """x^2 + y^2 = 1 and x = y: propagation keeps [-1, 1]^2, shaving cuts to the two roots' hull
    (about +-0.7071 in each coordinate) and keeps both."""
    s = System()
    x, y = s.add_var("x", -1.0, 1.0), s.add_var("y", -1.0, 1.0)
    s.add_eq(x * x + y * y - 1.0)
    s.add_eq(x - y)
    lo, hi = np.array([-1.0, -1.0]), np.array([1.0, 1.0])
    p = CtcPropagation(s.compile()).contract(Box(lo, hi))
    r = shaver(s, lo, hi).contract(Box(lo, hi))
    assert r.status is ContractStatus.NARROWED
    assert np.all(r.hi - r.lo < p.hi - p.lo)  # narrower than propagation's box
    root = 1 / arb(2).sqrt()
    for v in (root, -root):
        assert certainly_in(r.lo[0], r.hi[0], v) and certainly_in(r.lo[1], r.hi[1], v)


def test_an_emptied_divisor_is_not_divided_by():
    """HC4's projection of a product onto a factor skips a divisor interval that an earlier
    projection of the same pass emptied (its end may be 0): the caller finds the box empty."""
    from kinbox.search.propagate import _div_into

    xlo, xhi = np.array([-1.0]), np.array([1.0])
    _div_into(0.5, 1.0, 0.5, 0.0, 0, xlo, xhi)
    assert (xlo[0], xhi[0]) == (-1.0, 1.0)


# -- registration and the search ------------------------------------------------------------------


def test_the_step_is_registered_by_its_name_and_optional():
    from kinbox.search.options import make_options
    from kinbox.search.policy import Events, Policy, gates
    from kinbox.search.steps import SEQUENCE, steps

    assert "shave" in SEQUENCE and STEP in steps() and STEP.optional
    assert STEP.gate in gates()
    p = Policy().next(Events(tests={"shave": 20}, paid={"shave": 0}))  # its rate is learnt from counts
    assert p.rates["shave"] < STEP.gate.start
    assert make_options(extra_steps="shave").extra_steps == "shave"
    with pytest.raises(InputError, match="extra_steps"):
        make_options(extra_steps="shaving")


def _answer(r):
    return (len(r.solutions), sum(s.certified for s in r.solutions), sorted(c.dimension for c in r.components), r.complete)


@pytest.mark.parametrize(
    ("mech", "sigma", "expected"), [("general-6r", 1e-4, (16, 16, [0] * 16, True)), ("four-bar", 0.1, (0, 0, [1, 1], True))]
)
def test_the_search_with_shaving_gives_the_published_answer(mech, sigma, expected):
    import kinbox

    plain = kinbox.solve(mech, sigma=sigma, progress=False)
    shaved = kinbox.solve(mech, sigma=sigma, progress=False, extra_steps="shave")
    assert _answer(plain) == _answer(shaved) == expected
    for a, b in zip(sorted(plain.solutions, key=lambda s: tuple(s.q)), sorted(shaved.solutions, key=lambda s: tuple(s.q))):
        assert np.allclose(a.q, b.q, atol=1e-6)
    assert shaved.stats["boxes"] != plain.stats["boxes"]  # the step ran and shaped the tree


def test_the_command_line_runs_the_optional_step_and_names_a_wrong_one(capsys):
    import json

    from kinbox.cli import main

    assert main(["solve", "general-6r", "--sigma", "1e-4", "--extra-steps", "shave", "--json", "--quiet"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert len(out["solutions"]) == 16
    assert main(["solve", "general-6r", "--extra-steps", "shaving"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("kinbox: error:") and "shaving" in err[0]
