"""The error-based bisection and full LP sweeps (``SolverOptions.bisection``, ``lp_sweep``)."""

from __future__ import annotations

import numpy as np

from kinbox.formulation.system import System
from kinbox.search.bisector import Bisector
from kinbox.search.certify import Certifier
from kinbox.search.contract import Box
from kinbox.search.ctc_linear import LinearRelaxation
from kinbox.search.ctc_propagation import CtcPropagation
from kinbox.search.policy import EAGER, LP, LP_RATE, Events, Hint, Policy


def circle_and_line() -> System:
    """x^2 + y^2 = 1, 10 z + x + y = 0.5 (z only linear, with the largest coefficient)."""
    s = System()
    x, y, z = s.add_var("x", -1, 1, "cos"), s.add_var("y", -1, 1, "sin"), s.add_var("z", -1, 1)
    s.add_eq(x * x + y * y - 1.0, "unit")
    s.add_eq(10.0 * z + x + y - 0.5, "line")
    s.add_eq(z - 0.1 * x, "z")
    return s


def test_error_rule_cuts_where_the_nonlinear_terms_are():
    comp = circle_and_line().compile()
    cert = Certifier(comp)
    w = np.array([0.5, 1.0, 2.0])
    b = Bisector(cert, np.ones(3) * 2.0, np.ones(3, dtype=bool), None, "error")
    assert np.allclose(b.error(w), [0.25, 1.0, 0.0])  # |a| w_i^2 of x^2, y^2; z is linear
    lo, hi = np.array([-0.25, -0.5, -1.0]), np.array([0.25, 0.5, 1.0])
    assert b.variable(lo, hi) == 1  # y: the widest circle variable, not the widest (z)
    smear = Bisector(cert, np.ones(3) * 2.0, np.ones(3, dtype=bool), None, "smear")
    assert smear.variable(lo, hi) == 2  # the smear cuts the linear z (coefficient 10)


def test_a_sweep_bounds_every_variable():
    """One round of LPs: with ``pay=0`` every variable is bounded, with the default only the
    first (it does not shrink to a point)."""
    s = System()
    x, y = s.add_var("x", -1, 1), s.add_var("y", -1, 1)
    s.add_eq(x + y - 1.0, "sum")
    s.add_eq(x - y, "difference")  # propagation stops at [0, 1]^2; the LPs give x = y = 1/2
    comp = s.compile()
    lo, hi = s.search_domain()
    c = CtcPropagation(comp).contract(Box(lo, hi))
    lo, hi, mlo, mhi = c.lo, c.hi, c.mlo, c.mhi
    full = LinearRelaxation(comp, np.ones(2, dtype=bool), np.ones(2) * 2.0, pay=0.0).contract(lo, hi, mlo, mhi)
    one = LinearRelaxation(comp, np.ones(2, dtype=bool), np.ones(2) * 2.0).contract(lo, hi, mlo, mhi)
    assert np.all(hi - lo > 0.5)
    assert np.all(full.hi - full.lo < 1e-6)  # both bounded
    assert sum(bool(w < 1e-6) for w in one.hi - one.lo) == 1


def test_the_eager_start_opens_lp_rounds_until_they_stop_paying():
    assert EAGER.opens(LP, Hint()) and not Policy().with_rates(lp=0.0).opens(LP, Hint(id=0))
    after = EAGER
    for _ in range(10):  # waves of rounds that did not pay
        after = after.next(Events(tests={"lp": 4}, paid={"lp": 0}, lp_iterations=40))
    assert after.rates["lp"] < LP_RATE
