"""The compiled minimum-norm least squares (search/lstsq.py) against numpy's (LAPACK's SVD)."""

import numpy as np
import pytest

from kinbox.search.lstsq import lstsq

EPS = float(np.finfo(float).eps)


def _case(rng, m, n, rank):
    if rank < min(m, n):
        A = rng.normal(size=(m, rank)) @ rng.normal(size=(rank, n))
    else:
        A = rng.normal(size=(m, n))
    return A * 10.0 ** rng.uniform(-3, 3), rng.normal(size=m)


@pytest.mark.parametrize("seed", range(6))
def test_equals_numpy_on_full_and_deficient_rank(seed):
    rng = np.random.default_rng(seed)
    for _ in range(200):
        m, n = (int(v) for v in rng.integers(1, 40, 2))
        rank = int(rng.integers(0, min(m, n) + 1)) if rng.random() < 0.4 else min(m, n)
        A, b = _case(rng, m, n, rank)
        rcond = 10 * EPS * max(m, n)
        A0, b0 = A.copy(), b.copy()
        x, r = lstsq(A, b, rcond)
        ref, _, r_ref, _ = np.linalg.lstsq(A, b, rcond=rcond)
        assert r == r_ref
        assert np.linalg.norm(x - ref) <= 1e-8 * max(np.linalg.norm(ref), 1e-300)
        assert np.array_equal(A, A0) and np.array_equal(b, b0)  # inputs kept


def test_minimum_norm_where_columns_repeat():
    # x1 + x2 = 2 (twice): every (t, 2 - t) fits; the minimum-norm solution is (1, 1)
    A = np.array([[1.0, 1.0], [1.0, 1.0]])
    x, r = lstsq(A, np.array([2.0, 2.0]), 1e-12)
    assert r == 1
    assert np.allclose(x, [1.0, 1.0], rtol=0, atol=1e-15)


def test_wide_system_gives_the_minimum_norm_point():
    A = np.array([[1.0, 2.0, 2.0]])
    x, r = lstsq(A, np.array([9.0]), 1e-12)
    assert r == 1
    assert np.allclose(x, [1.0, 2.0, 2.0], rtol=0, atol=1e-14)


def test_zero_matrix_gives_zero():
    x, r = lstsq(np.zeros((3, 2)), np.ones(3), 1e-12)
    assert r == 0 and np.array_equal(x, np.zeros(2))


def test_pivots_below_the_cut_off_count_as_zero():
    # a column 1e-14 of the first: dependent at cut-off 1e-12, independent at 1e-16
    A = np.array([[1.0, 1e-14], [0.0, 0.0], [0.0, 1e-14]])
    b = np.array([1.0, 0.0, 1.0])
    x, r = lstsq(A, b, 1e-12)
    assert r == 1 and np.allclose(x, [1.0, 0.0])
    x, r = lstsq(A, b, 1e-16)
    assert r == 2 and np.allclose(x, [1.0 - 1.0, 1e14], rtol=1e-12)


def test_huge_and_tiny_matrices_are_scaled_not_overflowed():
    rng = np.random.default_rng(3)
    A, b = rng.normal(size=(6, 4)), rng.normal(size=6)
    ref = np.linalg.lstsq(A, b, rcond=None)[0]
    for s in (1e-200, 1e150, 2.0**1000):
        x, r = lstsq(A * s, b, 1e-12)
        assert r == 4 and np.allclose(x * s, ref, rtol=1e-12, atol=0)


def test_entries_that_are_not_finite_give_nan_without_raising():
    for bad in (np.inf, np.nan):
        A = np.ones((3, 2))
        A[1, 1] = bad
        x, r = lstsq(A, np.ones(3), 1e-12)
        assert r == 0 and np.all(np.isnan(x))


def test_default_cut_off_is_numpys():
    rng = np.random.default_rng(5)
    for m, n in ((9, 4), (4, 9), (6, 6)):
        A = rng.normal(size=(m, 2)) @ rng.normal(size=(2, n))  # rank 2
        A[0, 0] += 1e-15 * np.abs(A).max()  # a perturbation below numpy's cut-off
        b = rng.normal(size=m)
        x, r = lstsq(A, b)
        ref, _, r_ref, _ = np.linalg.lstsq(A, b, rcond=None)
        assert r == r_ref == 2
        assert np.allclose(x, ref, rtol=1e-9, atol=0)
        assert np.array_equal(x, lstsq(A, b, EPS * max(m, n))[0])
