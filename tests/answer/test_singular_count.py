"""The count a singular root states for the hull of its boxes (kinbox.answer.components,
``_singular_roots``): its multiplicity only where Newton from the group's boxes reaches no other
root; else "roots within d, how many not known" (``count_known`` False). Checked against the
roots computed at 40 digits from the system's own coefficients."""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pytest

from kinbox.answer import components
from kinbox.answer.components import analyse
from kinbox.answer.result import Solution
from kinbox.formulation.system import System
from kinbox.pipeline import solve_system
from kinbox.search.status import BoxStatus


def _two_double_roots(a: float, b: float):
    """``u = (x - a)(x - b)``, ``y = u^2``, ``y = 0``: a double root at each of the two roots of
    the quadratic (``u = y = 0``), and that quadratic's binary64 coefficients."""
    s = System()
    x, u, y = s.add_var("x", -1, 1), s.add_var("u", -1, 1), s.add_var("y", -1, 1)
    quad = (x - a) * (x - b)
    s.add_eq(u - quad)
    s.add_eq(y - u * u)
    s.add_eq(y)
    return s, [quad.terms[(0, 0)], quad.terms[(0,)], quad.terms[()]]


def _oracle(coeffs) -> list:
    """The roots ``(x, u, y)`` at 40 digits, each of multiplicity 2 (``u^2 = 0``)."""
    mp.mp.dps = 40
    xs = mp.polyroots([mp.mpf(c) for c in reversed(coeffs)], maxsteps=200, extraprec=200, asc=True)
    assert all(abs(mp.im(r)) < mp.mpf(10) ** -35 for r in xs)
    return [(mp.re(r), mp.mpf(0), mp.mpf(0)) for r in xs]


def _reached(c, roots) -> int:
    """The roots (with their multiplicity 2) within ``c.width`` of ``c.point`` in every variable."""
    return sum(2 for r in roots if all(abs(mp.mpf(float(p)) - v) <= c.width for p, v in zip(c.point, r)))


def _singular(a: float, b: float, sigma: float):
    s, coeffs = _two_double_roots(a, b)
    st = analyse(s, solve_system(s, sigma=sigma).boxes, sigma)
    return st, _oracle(coeffs)


def test_a_hull_of_two_double_roots_states_no_count():
    """Two double roots 0.1 apart, sigma 0.1: the search's singular boxes about both are one
    group (their points within sigma of each other), whose hull reaches all four roots. Its point
    was reported with the multiplicity found there (3) as the count of the whole hull; Newton
    from the group's boxes ends at both roots, and the count is now not known. No root is lost:
    every 40-digit root is within the reported point's width."""
    st, roots = _singular(0.3, 0.4, 0.1)
    assert not st.undecided
    sing = [c for c in st.components if c.singular]
    assert len(sing) == 1 and len(st.components) == 1
    c = sing[0]
    assert _reached(c, roots) == 4
    assert not c.count_known and c.to_dict()["count_known"] is False
    sol = Solution(c.point, 0.0, BoxStatus.UNCERTIFIED, c.width, c.point, singular=True, multiplicity=c.multiplicity, count_known=False)
    assert sol.to_dict()["roots_within"] == "not known"


def test_without_the_check_the_hull_claims_too_few(monkeypatch):
    """The same group with every group taken as one root (the rule before): a stated count
    below the roots its hull reaches, which the check above removes."""
    monkeypatch.setattr(components, "_one_singular_root", lambda *a, **k: True)
    st, roots = _singular(0.3, 0.4, 0.1)
    c = next(c for c in st.components if c.singular)
    assert c.count_known and c.multiplicity is not None and c.multiplicity < _reached(c, roots)


@pytest.mark.parametrize("sigma", [1e-2, 1e-3])
def test_separate_double_roots_keep_their_counts(sigma):
    """The same roots 0.1 apart with sigma below their distance: two groups, each reaching its
    own double root only, each stating a count (its multiplicity, at least the 2 it reaches)."""
    st, roots = _singular(0.3, 0.4, sigma)
    sing = [c for c in st.components if c.singular]
    assert len(sing) == 2
    for c in sing:
        assert c.count_known and c.multiplicity is not None and c.multiplicity >= _reached(c, roots) == 2
    got = sorted(float(c.point[0]) for c in sing)
    assert np.allclose(got, sorted(float(r[0]) for r in roots), atol=1e-6)


def test_a_singular_limit_among_undecided_boxes_states_no_count():
    """Two double roots 0.05 apart, sigma 0.1: the search leaves boxes whose Newton limit is
    one point, singular (``J`` drops rank there), reported uncertified with the hull of its
    boxes. It stated one root (a regular root's count) for a hull that reaches all four; a
    singular limit now states none."""
    st, roots = _singular(0.3, 0.35, 0.1)
    assert len(st.components) == 1
    c = st.components[0]
    assert not c.certified and _reached(c, roots) == 4
    assert not c.count_known
