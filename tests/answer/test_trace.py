"""The curve follower (``answer/trace.py``): every point of a trace lies on the solution set."""

from __future__ import annotations

import math

import numpy as np

from kinbox.answer.trace import Tracer
from kinbox.formulation.system import System


def test_the_start_of_a_trace_is_corrected_onto_the_curve():
    """A trace starts from a Newton limit, which next to a curve (a singular Jacobian along it)
    stalls off it: a Griffis-Duffy platform's start point closed its legs only to 5e-12, its
    curve's other points to 1e-16, and the curve failed the closure test
    (``components._is_a_curve``). Started 1e-11 off a circle, the trace begins on it."""
    s = System()
    x, y = s.add_var("x", -2.0, 2.0), s.add_var("y", -2.0, 2.0)
    s.add_eq(x * x + y * y - 1.0, "circle")
    comp = s.compile()
    lo, hi = s.search_domain()
    tracer = Tracer(comp, lo, hi, h_max=0.05, h_min=5e-5)
    t = 0.7
    start = (1.0 + 1e-11) * np.array([math.cos(t), math.sin(t)])
    assert abs(float(comp.eval_eqs(start)[0])) > 1e-11
    tr = tracer.trace(start)
    assert tr is not None and tr.closed
    worst = max(abs(float(comp.eval_eqs(np.asarray(p))[0])) for p in tr.points)
    assert worst <= 4e-16, worst
    assert float(np.max(np.abs(tr.points[0] - start))) <= 2e-11
