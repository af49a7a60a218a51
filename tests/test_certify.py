"""The compiled Krawczyk test (``Certifier.krawczyk``) against the numpy code it replaced
(tests/krawczyk_reference.py), on every test that solves of an arm, the general 6R loop and a
platform ask for."""

from __future__ import annotations

import numpy as np
import pytest

import kinbox
from kinbox.search.certify import Certifier
from tests.krawczyk_reference import krawczyk_reference


def _recorded(monkeypatch, run) -> list:
    """Every Krawczyk test a solve asks for: (certifier, lo, hi, x0, exact)."""
    calls = []
    real = Certifier.krawczyk

    def spy(self, lo, hi, x0=None, exact=False):
        calls.append((self, np.array(lo, float), np.array(hi, float), None if x0 is None else np.array(x0, float), exact))
        return real(self, lo, hi, x0, exact)

    monkeypatch.setattr(Certifier, "krawczyk", spy)
    run()
    monkeypatch.setattr(Certifier, "krawczyk", real)
    return calls


def _ur5():
    ik = kinbox.IK("ur5", "tool0")
    for q in np.random.default_rng(3).uniform(-np.pi, np.pi, (3, 6)):
        ik.solve(ik.pose_at(q), progress=False)


RUNS = {
    "ur5-arm": _ur5,
    "general-6r": lambda: kinbox.solve("general-6r", progress=False),
    "3-rpr": lambda: kinbox.solve("3-rpr", progress=False),
}


@pytest.mark.parametrize("problem", sorted(RUNS))
def test_kernel_agrees_with_the_numpy_reference(monkeypatch, problem):
    """The same verdict on every test, and bounds equal up to the order of the sums (the
    kernel sums the rows of ``Y F(x0)`` in another order than BLAS: a few ulps of the radius)."""
    calls = _recorded(monkeypatch, RUNS[problem])
    assert len(calls) > 50
    statuses = set()
    for cert, lo, hi, x0, exact in calls:
        a = cert.krawczyk(lo, hi, x0, exact)
        b = krawczyk_reference(cert, lo, hi, x0, exact)
        assert a.status == b.status
        statuses.add(a.status)
        # Y F(x0) summed in another order: off by at most its error bound (the floor), and K's
        # radius by a few ulps of the widths
        floor = 0.0 if b.floor is None else 4.0 * b.floor
        scale = floor + 64 * np.finfo(float).eps * (np.abs(b.lo) + np.abs(b.hi) + (hi - lo) + (b.hi - b.lo)) + 1e-300
        assert np.all(np.abs(a.lo - b.lo) <= scale) and np.all(np.abs(a.hi - b.hi) <= scale)
        assert (a.floor is None) == (b.floor is None)
        if a.floor is not None:
            assert np.allclose(a.floor, b.floor, rtol=1e-13, atol=0)
    assert "unique" in statuses
