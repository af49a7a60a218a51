"""The transverse Krawczyk operator keeps every point of a curve and narrows boxes across it."""

from __future__ import annotations

import numpy as np
import pytest

from kinbox.formulation.build import formulate
from kinbox.formulation.system import System
from kinbox.model.loading import load
from kinbox.search.certify import Certifier, set_newton
from kinbox.search.transverse import Transverse, least_squares_inverse
from tests.support.transverse_reference import operator_reference


def viviani() -> System:
    s = System()
    x, y, z = s.add_var("x", -3, 3), s.add_var("y", -3, 3), s.add_var("z", -3, 3)
    s.add_eq(x * x + y * y + z * z - 4)
    s.add_eq((x - 1) * (x - 1) + y * y - 1)
    return s


def _boxes_around(x: np.ndarray, rng: np.random.Generator, count: int):
    """Random boxes holding ``x``, of widths from 1e-6 to 0.3, ``x`` anywhere inside."""
    for _ in range(count):
        w = 10.0 ** rng.uniform(-6, -0.5, size=x.shape)
        a = rng.uniform(0, 1, size=x.shape)
        yield x - a * w, x + (1 - a) * w


def _check_keeps(tv: Transverse, points, rng, per_point: int = 40) -> int:
    narrowed = 0
    for x in points:
        for lo, hi in _boxes_around(x, rng, per_point):
            t = tv.contract(lo, hi)
            assert t.status != "empty", (x, lo, hi)
            tol = 1e-12 * (1 + np.abs(x))
            assert np.all(t.lo <= x + tol) and np.all(x - tol <= t.hi), (x, lo, hi, t.lo, t.hi)
            narrowed += int(t.status == "narrowed" and np.any(t.hi - t.lo < 0.5 * (hi - lo)))
    return narrowed


def test_transverse_keeps_viviani_points():
    comp = viviani().compile()
    tv = Transverse(Certifier(comp))
    rng = np.random.default_rng(7)
    pts = []
    for t in rng.uniform(0.1, 2 * np.pi - 0.1, size=25):
        x = 1 + np.cos(t)
        pts.append(np.array([x, np.sin(t), np.sign(np.pi - t) * np.sqrt(max(0.0, 2 - 2 * np.cos(t)))]))
    n = _check_keeps(tv, pts, rng)
    assert n > 0.2 * 25 * 40  # it does narrow small boxes across the curve


def test_transverse_empty_away_from_the_curve():
    comp = viviani().compile()
    tv = Transverse(Certifier(comp))
    # a small box 0.1 off the sphere: no point of the curve in it
    x = np.array([2.0, 0.0, 0.0]) * 1.05
    assert tv.contract(x - 1e-3, x + 1e-3).status == "empty"


@pytest.mark.parametrize("name", ["four-bar", "bricard"])
def test_transverse_keeps_mechanism_curves(name):
    system = formulate(load(name)).system
    comp = system.compile()
    tv = Transverse(Certifier(comp))
    rng = np.random.default_rng(3)
    lo, hi = system.domain()
    pts = []
    for _ in range(200):
        x = set_newton(comp, rng.uniform(lo, hi), iters=40)
        if np.max(np.abs(comp.eval_eqs(x)), initial=0.0) < 1e-13 and np.all(x >= lo) and np.all(x <= hi):
            pts.append(x)
        if len(pts) == 6:
            break
    assert len(pts) >= 3
    _check_keeps(tv, pts, rng, per_point=30)


@pytest.mark.parametrize("problem", ["four-bar", "ur5"])
def test_operator_kernel_agrees_with_the_numpy_reference(monkeypatch, problem):
    """The compiled operator against the numpy code it replaced (tests/support/transverse_reference.py)
    on every call of a solve: both finite or neither, bounds a few ulps apart (the sums in
    another order), the same ``Y`` in both (:func:`least_squares_inverse`, tested below)."""
    import kinbox

    calls = []
    real = Transverse._operator

    def spy(self, lo, hi, P, V, J0=None, unique=True):
        # replayed below with the uniqueness test on, whatever the search asked for
        calls.append((self, lo.copy(), hi.copy(), P.copy(), V.copy(), None if J0 is None else J0.copy()))
        return real(self, lo, hi, P, V, J0, unique)

    monkeypatch.setattr(Transverse, "_operator", spy)
    if problem == "ur5":
        ik = kinbox.IK("ur5", "tool0")
        for q in np.random.default_rng(1).uniform(-np.pi, np.pi, (40, 6)):
            # the steady start: the quick one leaves out most transverse tests of a UR5 (by its
            # isolated roots), and the operator's calls are what this test compares
            ik.solve(ik.pose_at(q), progress=False, policy="steady", closed_form=False)
    else:
        kinbox.solve(problem, progress=False)
    monkeypatch.setattr(Transverse, "_operator", real)
    assert len(calls) > 20
    eps = np.finfo(float).eps
    contracts = []
    for tv, lo, hi, P, V, J0 in calls[:400]:
        a = tv._operator(lo, hi, P, V, J0)
        b = operator_reference(tv, lo, hi, P, V, J0)
        assert (a is None) == (b is None)
        if a is None or b is None:
            continue
        # Y F(x0) summed in another order: off by gamma(m) |Y| |F(x0)|, and K's radius by a few
        # ulps of the widths
        x0 = 0.5 * (lo + hi)
        Jc = tv.cert.J(x0) if J0 is None else J0
        yf = np.abs(least_squares_inverse(np.ascontiguousarray(Jc[:, V]))[1]) @ np.abs(tv.cert.F_enclosure(x0)[0])
        scale = 64 * eps * (np.abs(b[0]) + np.abs(b[1]) + (b[1] - b[0]) + len(lo) * yf) + 1e-300
        assert np.all(np.abs(a[0] - b[0]) <= scale) and np.all(np.abs(a[1] - b[1]) <= scale)
        contracts.append(a[2])
        assert a[2] == b[2]
    if problem == "four-bar":  # both verdicts of the uniqueness condition were compared
        assert any(contracts) and not all(contracts)


def test_least_squares_inverse_is_the_pseudo_inverse_or_nothing():
    """``Y`` of the transverse operator: numpy's pseudo-inverse for a matrix of full column rank
    (to rounding), no verdict for one that is rank-deficient, wider than tall or not finite."""
    rng = np.random.default_rng(3)
    for m, k in [(1, 1), (3, 2), (6, 6), (26, 25), (12, 9)]:
        A = rng.normal(size=(m, k)) * rng.choice([1e-3, 1.0, 1e3], size=k)
        ok, Y = least_squares_inverse(A)
        assert ok
        np.testing.assert_allclose(Y, np.linalg.pinv(A), rtol=1e-8, atol=1e-10 * np.abs(np.linalg.pinv(A)).max())
    A = rng.normal(size=(5, 3))
    A[:, 2] = 0.0  # an exact zero column: R has a zero on its diagonal
    assert not least_squares_inverse(A)[0]
    assert not least_squares_inverse(rng.normal(size=(2, 3)))[0]
    B = rng.normal(size=(4, 2))
    B[1, 1] = np.nan
    assert not least_squares_inverse(B)[0]


def test_correct_on_slice_lands_on_the_curve():
    """The curve-box corrector: from near a point of the four-bar's curve, one variable held, it
    reaches a point where every equation holds to its slack, that variable unmoved; from a point
    whose rows are not finite it gives up."""
    from kinbox.search.transverse import correct_on_slice

    system = formulate(load("four-bar")).system
    comp = system.compile()
    rows = comp.rows(comp.n_eq)
    slack = comp.slack[: comp.n_eq]
    rng = np.random.default_rng(11)
    lo0, hi0 = system.domain()
    landed = tried = 0
    for _ in range(40):
        x = set_newton(comp, rng.uniform(lo0, hi0), iters=40)
        if not np.max(np.abs(comp.eval_eqs(x)), initial=0.0) < 1e-13:
            continue
        j = int(rng.integers(comp.n))
        y = x + rng.normal(scale=1e-3, size=comp.n)
        held = y[j]
        tried += 1
        assert correct_on_slice(rows, y, j, 0.5 * slack, 12, 0.5)
        assert y[j] == held
        landed += int(np.all(np.abs(comp.eval_eqs(y)) <= slack))
    assert tried >= 10 and landed >= 0.8 * tried
    y = np.full(comp.n, np.nan)
    assert not correct_on_slice(rows, y, 0, 0.5 * slack, 12, 0.5)


@pytest.mark.parametrize("gap", [1.0, 1e-3, 1e-6])
def test_graph_test_never_passes_on_a_box_across_two_curves(gap):
    """Two lines ``y = +-a``, ``z = a x`` (of ``y^2 = a^2``, ``z = x y``): a box holding a piece of
    each is not one graph over ``x``, so the graph test must fail on it; on a box around one
    line alone it passes (the test is not vacuous) unless the lines are so close that the rows'
    slack, through ``|Y| ~ 1/a``, is wider than such a box."""
    a = gap / 2
    s = System()
    x, y, z = s.add_var("x", -3, 3), s.add_var("y", -3, 3), s.add_var("z", -3, 3)
    s.add_eq(y * y - a * a)
    s.add_eq(z - x * y)
    tv = Transverse(Certifier(s.compile()))
    rng = np.random.default_rng(3)
    passed = held = 0
    for _ in range(300):
        x0 = rng.uniform(-1, 1)
        w = 10.0 ** rng.uniform(-7, 0, size=4) * np.array([1.0, gap, 1.0, gap])
        lo = np.array([x0 - w[0], -a - w[1], -a * (abs(x0) + w[0]) - w[2]])
        hi = np.array([x0 + w[0], a + w[3], a * (abs(x0) + w[0]) + w[2]])
        assert not tv.contract(lo, hi, graph=True).graph, (lo, hi)
        assert not _y_unique(tv, lo, hi), (lo, hi)  # the uniqueness condition alone
        one_lo, one_hi = lo.copy(), hi.copy()
        one_lo[1], one_hi[1] = a - w[1] * 1e-3, a + w[1] * 1e-3
        one_lo[2], one_hi[2] = a * x0 - a * w[0] - w[2], a * x0 + a * w[0] + w[2]
        passed += tv.contract(one_lo, one_hi, graph=True).graph
        held += _y_unique(tv, one_lo, one_hi)
    assert (passed > 30 and held > 30) or gap < 1e-3


def _y_unique(tv: Transverse, lo, hi) -> bool:
    """The uniqueness condition in ``y, z`` (``x`` held) on the box itself, ``Y`` the
    pseudo-inverse of ``J_yz`` at the centre, as the graph test takes it."""
    from kinbox import interval as iv
    from kinbox.search.certify import at_most_one_kernel, box_jacobian_radius

    x0 = 0.5 * (lo + hi)
    V = np.array([1, 2])
    J0 = tv.cert.J(x0)
    ok, Y = least_squares_inverse(np.ascontiguousarray(J0[:, V]))
    if not ok:
        return False
    c = tv.cert
    d, Jrad, _ = box_jacobian_radius(lo, hi, x0, c.Ax, c.t_var, c.t_flat, c.t_abs, c.g_slope, iv.TINY, c.mgrad_core)
    return bool(at_most_one_kernel(d, np.ascontiguousarray(J0), Y, V, Jrad, J0.shape[0], iv.TINY))


def test_uniqueness_scaled_by_any_positive_vector_only_below_spectral_radius_one():
    """``at_most_one_scaled`` accepts ``M = |I - Y J_V(x0)| + |Y| Jrad_V`` exactly where its
    spectral radius is below one (with a margin for rounding), whatever the box's radius: a
    radius narrow in one variable and wide in another, as on a piece of the rhombus's curve
    where one link hardly turns, fails the test scaled by the radius alone."""
    from kinbox import interval as iv
    from kinbox.search.certify import at_most_one_kernel, at_most_one_scaled

    rng = np.random.default_rng(3)
    k = 4
    V = np.arange(k)
    J0 = np.eye(k)
    radius_only = passed = 0
    for _ in range(400):
        C = rng.uniform(-1, 1, (k, k)) * rng.uniform(0, 0.6)
        Y = np.eye(k) - C  # I - Y J0 = C
        Jrad = np.abs(rng.uniform(0, 0.1, (k, k)))
        d = 10.0 ** rng.uniform(-rng.uniform(0, 6), 0, k)  # equal to six orders apart
        M = np.abs(C) + np.abs(Y) @ Jrad
        rho = float(np.max(np.abs(np.linalg.eigvals(M))))
        ok = bool(at_most_one_scaled(d, J0, Y, V, Jrad, k, iv.TINY))
        if ok:
            assert rho < 1.0
            passed += 1
        elif rho < 0.99:
            raise AssertionError(f"spectral radius {rho} but not accepted")
        radius_only += bool(at_most_one_kernel(d, J0, Y, V, Jrad, k, iv.TINY))
    assert passed > radius_only + 50 and radius_only > 0


def test_rhombus_curve_pieces_are_proven_curve_boxes():
    """Along the rhombus four-bar's curve some links hardly turn while others turn with the
    parameter: the graph test's uniqueness, scaled by the box's radius alone, held on 13 of
    its boxes; scaled by ``(I - M)^-1 1`` it holds on most pieces away from the three
    bifurcation points. The curve is the same: one component of four branches through three
    bifurcation points (where the linkage folds flat)."""
    import kinbox
    from kinbox.search.status import BoxStatus

    r = kinbox.solve("rhombus", progress=False)
    curve_boxes = sum(1 for b in r.raw.boxes if b.status is BoxStatus.CURVE)
    assert curve_boxes > 60
    assert r.complete and not r.solutions
    (comp,) = r.components
    assert comp.dimension == 1 and len(comp.polylines) == 4 and len(comp.bifurcations) == 3
