"""System.materialize: an expression made a variable once is that variable again."""

from __future__ import annotations

import numpy as np

from kinbox.formulation.system import System


def test_materialize_reuses_an_expression_and_its_negative():
    s = System()
    c1, s1, c2, s2 = (s.add_var(n, -1.0, 1.0) for n in ("c1", "s1", "c2", "s2"))
    # a planar rotation product: R = [[a, -b], [b, a]]
    a = s.materialize(c1 * c2 - s1 * s2, "R00", -1.0, 1.0)
    b = s.materialize(s1 * c2 + c1 * s2, "R10", -1.0, 1.0)
    minus_b = s.materialize(-1.0 * (s1 * c2 + c1 * s2), "R01", -2.0, 0.5)
    again = s.materialize(c1 * c2 - s1 * s2, "R11", -0.5, 3.0)
    assert s.n == 6 and s.count("core") == 2  # two definitions, not four
    assert again.terms == a.terms
    assert minus_b.terms == (-1.0 * b).terms
    # the domains met: R01 = -R10 in [-2, 0.5] gives R10 in [-0.5, 2]; R11 = R00 in [-0.5, 3]
    i_a, i_b = s.index("R00"), s.index("R10")
    assert (s.lo[i_b], s.hi[i_b]) == (-0.5, 1.0)
    assert (s.lo[i_a], s.hi[i_a]) == (-0.5, 1.0)
    # the definitions hold at a point of the rotation, and the reused expressions evaluate right
    x = np.zeros(s.n)
    t1, t2 = 0.3, -1.1
    x[:4] = np.cos(t1), np.sin(t1), np.cos(t2), np.sin(t2)
    x[i_a], x[i_b] = np.cos(t1 + t2), np.sin(t1 + t2)
    assert np.max(np.abs(s.residuals(x))) < 1e-15


def test_materialize_keeps_different_expressions_apart():
    s = System()
    c1, s1 = s.add_var("c1", -1.0, 1.0), s.add_var("s1", -1.0, 1.0)
    s.materialize(c1 * s1, "p", -1.0, 1.0)
    s.materialize(2.0 * c1 * s1, "q", -2.0, 2.0)  # a multiple, not the same expression
    s.materialize(c1 * s1 + 1e-17 * c1, "r", -2.0, 2.0)
    assert s.n == 5 and s.count("core") == 3


def test_a_redundant_equation_already_there_is_left_out():
    s = System()
    x, y = s.add_var("x", -1.0, 1.0), s.add_var("y", -1.0, 1.0)
    s.add_eq(x * x + y * y - 1.0, "unit")
    s.add_eq(x * x + y * y - 1.0, "unit again", redundant=True)  # the same row
    s.add_eq(1.0 - x * x - y * y, "its negative", redundant=True)
    assert [c.name for c in s.constraints] == ["unit"]
    s.add_eq(x * x + y * y - 1.0 + 1e-17 * x, "another", redundant=True)  # differs in a term
    s.add_ineq(x - y, "an inequality")
    s.add_eq(x - y, "not the inequality", redundant=True)
    s.add_eq(x * x + y * y - 1.0, "a core row is always kept")
    assert [c.name for c in s.constraints] == ["unit", "another", "an inequality", "not the inequality", "a core row is always kept"]


def test_a_template_leaves_out_a_redundant_equation_it_has():
    from kinbox.formulation.template import Template

    t = Template(2)
    x, y = t.add_var("x", -1.0, 1.0), t.add_var("y", -1.0, 1.0)
    t.add_eq({0: x * x - 1.0, 1: y}, "core")
    t.add_eq({0: 1.0 - x * x, 1: -1.0 * y}, "negative", redundant=True)
    t.add_eq({0: x * x - 1.0, 1: -1.0 * y}, "one part negated", redundant=True)  # another equation
    t.add_eq({0: x * x - 1.0}, "other parameters", redundant=True)
    assert [r.name for r in t.rows] == ["core", "one part negated", "other parameters"]
