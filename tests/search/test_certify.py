"""The compiled Krawczyk test (``Certifier.krawczyk``) against the numpy code it replaced
(tests/support/krawczyk_reference.py), on every test that solves of an arm, the general 6R loop and a
platform ask for."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

import kinbox
from kinbox.formulation.system import System
from kinbox.search.certify import Certifier, lu_inverse
from tests.support.krawczyk_reference import krawczyk_reference


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
        ik.solve(ik.pose_at(q), progress=False, closed_form=False)  # the search's Krawczyk calls


RUNS = {
    "ur5-arm": _ur5,
    "general-6r": lambda: kinbox.solve("general-6r", progress=False),
    "3-rpr": lambda: kinbox.solve("3-rpr", progress=False),
}


@pytest.mark.parametrize("problem", sorted(RUNS))
def test_kernel_agrees_with_the_numpy_reference(monkeypatch, problem):
    """The same verdict on every test, and bounds equal up to the order of the sums (the
    kernel sums the rows of ``Y F(x0)`` in another order than BLAS: a few ulps of the radius).
    Both take ``Y`` from the kernel's inverse (:func:`test_inverse`)."""
    calls = _recorded(monkeypatch, RUNS[problem])
    assert len(calls) > 50
    statuses = set()
    for cert, lo, hi, x0, exact in calls:
        a = cert.krawczyk(lo, hi, x0, exact)
        b = krawczyk_reference(cert, lo, hi, x0, exact)
        # F(x0)'s bound is a few ulps of F itself, so on a proven box a few ulps wide (the
        # tightening, 1e-15 wide) K's bounds lie within ulps of the box's: whether they cut it
        # by an ulp ("contracted") or not ("none") then depends on the order of the sums
        ulp_box = bool(np.max(hi - lo) <= 1e-12)
        assert a.status == b.status or (ulp_box and {a.status, b.status} == {"none", "contracted"})
        statuses.add(a.status)
        # Y F(x0) summed in another order: off by at most its error bound (the floor), and K's
        # radius by a few ulps of the widths
        floor = 0.0 if b.floor is None else 4.0 * b.floor
        scale = floor + 64 * np.finfo(float).eps * (np.abs(b.lo) + np.abs(b.hi) + (hi - lo) + np.abs(b.hi - b.lo)) + 1e-300
        assert np.all(np.abs(a.lo - b.lo) <= scale) and np.all(np.abs(a.hi - b.hi) <= scale)
        assert (a.floor is None) == (b.floor is None)
        if a.floor is not None:
            assert np.allclose(a.floor, b.floor, rtol=1e-13, atol=0)
    assert "unique" in statuses


def test_inverse():
    """The kernel's inverse of ``J(x0)`` (LU with partial pivoting) against numpy's, and False
    on a singular matrix (numpy raises; the Krawczyk test then gives no verdict)."""
    rng = np.random.default_rng(0)
    for n in (1, 2, 6, 24):
        A = rng.normal(size=(n, n))
        Y = np.empty((n, n))
        assert lu_inverse(A, Y)
        cond = np.linalg.cond(A)
        assert np.allclose(Y, np.linalg.inv(A), rtol=0, atol=1e-14 * cond * np.abs(np.linalg.inv(A)).max())
        assert np.abs(Y @ A - np.eye(n)).max() <= 1e-13 * cond
    S = rng.normal(size=(5, 5))
    S[3] = 2.0 * S[1]
    assert not lu_inverse(S, np.empty((5, 5)))
    assert not lu_inverse(np.zeros((3, 3)), np.empty((3, 3)))
    N = np.eye(3)
    N[1, 1] = np.nan
    assert not lu_inverse(N, np.empty((3, 3)))


def _exact_rows(cert: Certifier, x: np.ndarray) -> list[Fraction]:
    """``F(x)`` of the certifier's core in exact rational arithmetic."""
    R = cert.R
    xf = [Fraction(float(v)) for v in x]
    out = []
    for r in range(len(R.c)):
        s = Fraction(float(R.c[r]))
        for q in range(R.indptr[r], R.indptr[r + 1]):
            k = int(R.indices[q])
            z = xf[k] if k < R.n else xf[int(R.mi[k - R.n])] * xf[int(R.mj[k - R.n])]
            s += Fraction(float(R.data[q])) * z
        out.append(s)
    return out


@pytest.mark.parametrize("problem", sorted(RUNS))
def test_F_enclosure_holds_the_exact_value(monkeypatch, problem):
    """``F(x0)`` and its bound (Dot2, :func:`kinbox.search.certify._f_enclosure_kernel`) against
    exact rational arithmetic at the points a solve's Krawczyk tests use -- many next to roots,
    where the rows cancel to 1e-12 of their terms -- and at those points moved by an ulp."""
    calls = _recorded(monkeypatch, RUNS[problem])
    rng = np.random.default_rng(0)
    picked = [calls[i] for i in rng.choice(len(calls), size=min(60, len(calls)), replace=False)]
    cancelled = 0
    for cert, lo, hi, x0, _ in picked:
        x = np.clip(0.5 * (lo + hi) if x0 is None else x0, lo, hi)
        for point in (x, np.nextafter(x, np.inf)):
            F, eF = cert.F_enclosure(point, model=False)
            for r, exact in enumerate(_exact_rows(cert, point)):
                assert abs(Fraction(float(F[r])) - exact) <= Fraction(float(eF[r])), (r, F[r], eF[r])
                # the bound is of F's own rounding, not of its terms: a few ulps of F (and
                # gamma_N^2 of the terms, ~1e-30 here; binary64 alone gives ~1e-16 of them)
                assert eF[r] <= 4 * np.spacing(abs(F[r])) + 1e-26
            cancelled += int(np.max(np.abs(F)) < 1e-9)
    assert cancelled > 0  # some points next to roots were checked


@pytest.mark.parametrize("x", [1.5061999e-182, 4.9704597e-181, 3e-160, 1e-200])
def test_F_enclosure_holds_when_a_monomial_underflows(x):
    """A monomial whose value underflows (x^2 ~ 1e-364) times a huge coefficient: the split of
    x^2 is off by a few subnormals, which the row multiplies by 4e180; the bound must cover that
    (the arb tests at KINBOX_SOUNDNESS_SCALE=3 found Krawczyk calling such a box empty)."""
    s = System()
    v = s.add_var("x0", 0.0, 1e-179)
    s.add_eq(3.10654e-182 - 2.125 * v + 4.14952e180 * v * v, "eq0")
    cert = Certifier(s.compile())
    point = np.array([x])
    F, eF = cert.F_enclosure(point)
    exact = _exact_rows(cert, point)[0]
    assert abs(Fraction(float(F[0])) - exact) <= Fraction(float(eF[0]))
