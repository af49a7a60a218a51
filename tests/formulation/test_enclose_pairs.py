"""The general formulation's shadow build (``formulation/enclose_rows.py``) for spherical, planar,
translation, free-flyer and composite pairs and distance closures: the core rows carry their
distance to the rows of the model as given (``merr``, ``mgrad``), the answers keep their counts
and certificates, and every certified box holds the root of the model as given found at 40
digits (``tests/support/oracles/mp_mech.py``)."""

from __future__ import annotations

import numpy as np
import pytest

import kinbox
from kinbox.formulation import build, enclose_rows
from kinbox.formulation.build import formulate
from kinbox.formulation.errfloat import EF
from kinbox.problems.mechanism import choose_formulation
from tests.support.oracles import mp_mech
from tests.support.pair_mechanisms import KINDS, pair_mechanism


def _merr(sys_) -> np.ndarray:
    assert sys_.core_errors is not None
    comp = sys_.compile()
    assert np.all(comp.slack[: comp.n_core] >= comp.merr[: comp.n_core])
    return comp.merr[: comp.n_core]


@pytest.mark.parametrize(
    "name, legs, rounded",
    [
        ("delta", "auto", True),
        ("dietmeier", "squared", True),
        ("dietmeier", "vector", False),
        ("griffis-duffy", "squared", True),
        ("griffis-duffy", "vector", False),
    ],
)
def test_the_shadow_build_covers_platforms_and_legs(name, legs, rounded):
    """A translation pair (the delta robot's platform), a free-flyer (a Stewart platform's,
    eliminated in both builds alike where its translation is linear) and distance closures: the
    core rows carry ``merr`` and every core slack is at least it. With squared legs
    ``|pb - pa|^2 = l^2`` the products of the legs' end points and ``l^2`` are rounded: ``merr``
    is nonzero; with leg vectors (``pa + l d = pb``) on these platforms every coefficient is an
    input number or a difference with zero (each platform's first leg joins two origins): exact."""
    merr = _merr(choose_formulation(kinbox.load(name), legs=legs).system)
    assert merr.max() < 1e-13
    assert (merr.max() > 0) == rounded


@pytest.mark.parametrize("kind", KINDS)
def test_the_shadow_build_covers_every_pair(kind):
    """Spherical, spherical ZYX, planar and composite joints at a turned placement (its binary64
    matrix rounded): the core rows carry a nonzero ``merr``."""
    merr = _merr(formulate(pair_mechanism(kind)).system)
    assert 0 < merr.max() < 1e-12


def _oracle_gaps(mech, res, lengths=None) -> list[float]:
    return mp_mech.certified_gaps(mp_mech.Mech(mech, lengths), res)


def _solve_both(mech, monkeypatch, **kw):
    """The answer with the enclosures, and the one with the rows as rounded (taken as exact)."""
    res = kinbox.solve(mech, progress=False, **kw)
    with monkeypatch.context() as m:
        m.setattr(build, "_core_errors", lambda *a: None)
        res0 = kinbox.solve(mech, progress=False, **kw)
    return res, res0


@pytest.mark.parametrize("kind", KINDS)
def test_every_pair_certifies_the_model_as_given(kind, monkeypatch):
    """Each pair's mechanism through the general formulation: the same solutions as with the
    rows as rounded, every one certified, each certified box holding its 40-digit root."""
    mech = pair_mechanism(kind)
    res, res0 = _solve_both(mech, monkeypatch, formulation="general")
    assert res.complete and res.raw.system.core_errors is not None
    assert len(res.solutions) == len(res0.solutions) > 0
    assert all(s.certified for s in res.solutions) and all(s.certified for s in res0.solutions)
    assert max(_oracle_gaps(mech, res)) == 0.0


def test_the_delta_robot_certifies_the_model_as_given(monkeypatch):
    """The delta robot (translation platform, locked arms, distance legs): its two assembly
    modes certified with and without the enclosures, each certified box holding its 40-digit root."""
    mech = kinbox.load("delta")
    res, res0 = _solve_both(mech, monkeypatch)
    assert _merr(res.raw.system).min() > 0
    assert len(res.solutions) == len(res0.solutions) == 2
    assert all(s.certified for s in res.solutions + res0.solutions)
    assert _oracle_gaps(mech, res) == [0.0, 0.0]


def test_a_length_known_within_a_radius_is_carried_to_the_boxes(monkeypatch):
    """Each leg's length of the delta robot entered as known only within 1e-10 (its ``EF`` radius):
    the certified boxes hold the 40-digit roots of the legs 1e-10 longer and 1e-10 shorter. With
    the radius left at 0 (the error dropped) the boxes are a few ulps wide and miss those roots:
    what the check would catch if an error were lost on the way (``errfloat.square``,
    the free-flyer's elimination, ``core_errors``)."""
    r = 1e-10
    mech = kinbox.load("delta")
    legs = [c.name for c in mech.closures if c.kind == "distance"]
    res0 = kinbox.solve(mech, progress=False)
    with monkeypatch.context() as m:
        m.setattr(enclose_rows, "length", lambda v: EF(float(v), r))
        res = kinbox.solve(mech, progress=False)
    assert len(res.solutions) == 2 and all(s.certified for s in res.solutions)
    for sign in (1.0, -1.0):
        lengths = {c.name: c.length + sign * r for c in mech.closures if c.name in legs}
        assert _oracle_gaps(mech, res, lengths) == [0.0, 0.0]
        assert min(_oracle_gaps(mech, res0, lengths)) > 0


@pytest.mark.slow
def test_dietmeier_certifies_the_model_as_given(monkeypatch):
    """Dietmeier's platform (free-flyer, six squared legs): the published 40 assemblies, all
    certified as with the rows as rounded, each certified box holding its 40-digit root."""
    mech = kinbox.load("dietmeier")
    res, res0 = _solve_both(mech, monkeypatch)
    assert _merr(res.raw.system).max() > 0
    assert len(res.solutions) == len(res0.solutions) == 40
    assert all(s.certified for s in res.solutions + res0.solutions)
    assert max(_oracle_gaps(mech, res)) == 0.0


@pytest.mark.slow
def test_griffis_duffy_gives_the_answer_of_the_rounded_rows(monkeypatch):
    """The Griffis-Duffy platform (free-flyer, leg vectors as ``legs="auto"`` picks them) with its
    rows' errors: the same components, boxes and no isolated certified assembly as with the rows
    as rounded (its leg vectors' coefficients are exact: ``merr`` 0)."""
    res, res0 = _solve_both("griffis-duffy", monkeypatch, legs="vector", sigma=0.25)
    assert res.complete and res.raw.system.core_errors is not None
    assert res.stats["boxes"] == res0.stats["boxes"]
    assert [(c.dimension, len(c.boxes)) for c in res.components] == [(c.dimension, len(c.boxes)) for c in res0.components]
    assert all(c.dimension == 1 for c in res.components)
    assert not [s for s in res.solutions if s.certified]


def test_a_square_and_a_reciprocal_bound_their_distance_to_the_exact_value():
    """``errfloat.square`` (a leg's ``l^2``) and ``b / a`` of :class:`EF` numbers (the pivot of a
    free-flyer's elimination): the exact result on exact inputs within the starting errors lies
    within the carried bound, and the value is the plain float's, bit for bit."""
    from fractions import Fraction

    from kinbox.formulation.errfloat import square

    rng = np.random.default_rng(7)
    for _ in range(300):
        vals = rng.normal(size=2) * 10.0 ** rng.integers(-3, 3, size=2)
        errs = np.abs(vals) * rng.uniform(0, 1e-12, size=2) * rng.integers(0, 2, size=2)
        shifts = rng.uniform(-1, 1, size=2)
        ex = [Fraction(float(v)) + Fraction(float(e)) * Fraction(float(s)) for v, e, s in zip(vals, errs, shifts)]
        a, b = (EF(float(v), float(e)) for v, e in zip(vals, errs))
        sq, q = square(a), b / a
        assert float(sq) == float(vals[0]) ** 2 and float(q) == float(vals[1]) / float(vals[0])
        assert abs(ex[0] * ex[0] - Fraction(float(sq))) <= Fraction(sq.err)
        assert abs(ex[1] / ex[0] - Fraction(float(q))) <= Fraction(q.err)
        assert square(float(vals[0])) == float(vals[0]) ** 2 and type(square(float(vals[0]))) is float
