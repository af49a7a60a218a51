"""The compiled HC4 kernel (``kinbox.propagate``): against the numpy reference it replaced, and
on its own (never cuts a root off, proves empty boxes empty)."""

from __future__ import annotations

import numpy as np
import pytest

import kinbox
from kinbox.formulation.system import System
from kinbox.search.propagate import SWEEP_TOL, SWEEPS, Propagator
from kinbox.search.solver import BoxProcessor, SolverOptions
from tests.support.hc4_reference import contract_reference


def _recorded(monkeypatch, run) -> list:
    """Every contraction a solve asks for: (propagator, lo, hi)."""
    calls = []
    real = Propagator.contract

    def spy(self, lo, hi, *a, **k):
        calls.append((self, np.array(lo, float), np.array(hi, float)))
        return real(self, lo, hi, *a, **k)

    monkeypatch.setattr(Propagator, "contract", spy)
    run()
    monkeypatch.setattr(Propagator, "contract", real)
    return calls


def _apart(a, b) -> np.ndarray:
    """|a - b| relative to 1 + |a| (0 where both are the same infinity). The two codes sum the
    terms of a row in another order, so they differ by rounding errors of the size of the
    terms, which are of order one here."""
    same = a == b
    return np.where(same, 0.0, np.abs(a - b) / (1.0 + np.abs(np.where(same, 0, a))))


@pytest.mark.parametrize("problem", ["general-6r", "four-bar", "dietmeier", "ur5", "ur5-arm"])
def test_kernel_agrees_with_the_numpy_reference(monkeypatch, problem):
    """Same emptiness verdicts and the same boxes up to the order of the sums (solves without
    LPs: HC4 does all the pruning, and the path does not depend on timing)."""
    if problem.startswith("ur5"):  # the general formulation, and the arm formulation (fewer boxes)
        ik = kinbox.IK("ur5", "tool0", formulation="arm" if problem == "ur5-arm" else "general")
        qs = ([0.3, -1.2, 1.5, -0.8, 1.2, 0.4], [2.1, -0.4, -2.6, 1.9, -0.7, 2.8], [-1.3, 2.2, 0.9, -2.4, 2.6, -1.1])
        goals = [ik.pose_at(np.array(q)) for q in qs]
        run = lambda: [ik.solve(g, max_boxes=150, lp=False, progress=False, closed_form=False) for g in goals]  # noqa: E731
    else:
        run = lambda: kinbox.solve(problem, max_boxes=150, lp=False, progress=False)  # noqa: E731
    calls = _recorded(monkeypatch, run)
    assert len(calls) > (50 if problem == "ur5-arm" else 100)
    empty = 0
    for prop, lo, hi in calls:
        got, ref = prop.contract(lo, hi), contract_reference(prop, lo, hi, SWEEPS, SWEEP_TOL)
        assert (got is None) == (ref is None)
        if got is None:
            empty += 1
            continue
        worst = max(float(np.max(_apart(g, r), initial=0.0)) for g, r in zip(got, ref))
        assert worst <= 1e-12, worst
    assert empty > 0 or problem == "general-6r"


def _six_r():
    res = kinbox.solve("general-6r", progress=False)
    assert len(res.solutions) == 16
    return res, BoxProcessor(res.raw.system, SolverOptions())


def test_kernel_never_cuts_a_root_off():
    res, proc = _six_r()
    rng = np.random.default_rng(0)
    lo0, hi0 = proc.lo0, proc.hi0
    for s in res.raw.boxes:
        lo_e, hi_e = s.enclosure  # proven to hold the root
        for scale in (1e-9, 1e-4, 1e-2, 0.3):
            w = scale * (hi0 - lo0)
            lo = np.maximum(lo_e - w * rng.uniform(0.1, 1.0, len(w)), lo0)
            hi = np.minimum(hi_e + w * rng.uniform(0.1, 1.0, len(w)), hi0)
            r = proc.prop.contract(lo, hi)
            assert r is not None
            assert np.all(r[0] <= lo_e) and np.all(r[1] >= hi_e)


def test_kernel_proves_a_box_off_the_unit_circle_empty():
    res, proc = _six_r()
    names = list(res.raw.system.names)
    c = next(i for i, n in enumerate(names) if n.startswith("c["))
    s = names.index("s[" + names[c][2:])
    lo, hi = proc.lo0.copy(), proc.hi0.copy()
    lo[c], hi[c], lo[s], hi[s] = 0.8, 1.0, 0.8, 1.0  # c^2 + s^2 >= 1.28
    assert proc.prop.contract(lo, hi) is None


def test_kernel_next_float_is_nextafter_bit_for_bit():
    """HC4's one-ulp steps (read from the float's bits, not the C library's nextafter) give
    np.nextafter's result exactly: at zeros, subnormals, the normal/subnormal boundary, the
    largest float, infinities, and at random floats of every exponent and sign."""
    from kinbox.search.propagate import next_up_down

    tiny, big, den = np.finfo(float).tiny, np.finfo(float).max, 5e-324
    special = [0.0, -0.0, den, -den, 2 * den, tiny, -tiny, tiny - den, -(tiny - den), big, -big, np.inf, -np.inf, 1.0, -1.0, 0.5, 2.0**53]
    rng = np.random.default_rng(7)
    bits = rng.integers(np.iinfo(np.int64).min, np.iinfo(np.int64).max, 200_000, dtype=np.int64, endpoint=True).view(float)
    scaled = rng.standard_normal(200_000) * 10.0 ** rng.integers(-320, 308, 200_000)
    x = np.concatenate([special, bits, scaled])
    x = x[~np.isnan(x)]
    up, dn = next_up_down(x)
    assert np.array_equal(up.view(np.int64), np.nextafter(x, np.inf).view(np.int64))
    assert np.array_equal(dn.view(np.int64), np.nextafter(x, -np.inf).view(np.int64))
    nan_up, nan_dn = next_up_down(np.array([np.nan]))
    assert np.isnan(nan_up[0]) and np.isnan(nan_dn[0])


def test_kernel_agrees_with_the_reference_on_random_rows_and_unbounded_boxes():
    """Random quadratic systems (equations and inequalities, dominant and balanced terms,
    coefficients from 0.03 to 30) on random boxes, some unbounded, some a point in a variable:
    the kernel, which projects only the terms wide enough to be narrowed, against the reference,
    which projects every term. The same verdicts and bounds (up to the order of the sums), and
    no root planted in the box cut off."""
    rng = np.random.default_rng(7)
    checked = empty = 0
    for _ in range(300):
        s = System()
        n = int(rng.integers(2, 6))
        xs = [s.add_var(f"x{i}", -3.0, 3.0) for i in range(n)]
        root = rng.uniform(-1.0, 1.0, n)
        for _ in range(int(rng.integers(1, n + 2))):
            e = 0.0
            for _ in range(int(rng.integers(1, 6))):
                c = float(rng.choice([-1.0, 1.0]) * 10.0 ** rng.uniform(-1.5, 1.5))
                i, j = (int(k) for k in rng.integers(0, n, 2))
                kind = rng.integers(0, 3)
                e = e + (c * xs[i] if kind == 0 else c * xs[i] * xs[j] if kind == 1 else c * xs[i] * xs[i])
            value = float(e.value(root))
            if rng.random() < 0.25:
                s.add_ineq(e - value - abs(rng.normal()))  # holds at the root
            else:
                s.add_eq(e - value)
        prop = Propagator(s.compile())
        for _ in range(4):
            lo = root - rng.uniform(0.0, 2.0, n) * (rng.random(n) < 0.8)
            hi = root + rng.uniform(0.0, 2.0, n) * (rng.random(n) < 0.8)
            lo[rng.random(n) < 0.15] = -np.inf
            hi[rng.random(n) < 0.15] = np.inf
            with np.errstate(all="ignore"):  # the reference's sums of infinite bounds
                ref = contract_reference(prop, lo, hi, SWEEPS, SWEEP_TOL)
            got = prop.contract(lo, hi)
            assert (got is None) == (ref is None)
            if got is None:
                empty += 1
                continue
            checked += 1
            # terms up to ~300, summed in another order and divided by coefficients down to 0.03
            worst = max(float(np.max(_apart(g, r), initial=0.0)) for g, r in zip(got, ref))
            assert worst <= 1e-10, worst
            assert np.all(got[0] <= root + 1e-9) and np.all(got[1] >= root - 1e-9)
    assert checked > 500 and empty == 0
