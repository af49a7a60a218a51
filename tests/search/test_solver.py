"""Branch-and-prune on small systems with known answers (issue: engine)."""

import json

import numpy as np
import pytest

from kinbox.formulation.system import System
from kinbox.pipeline import solve_system
from kinbox.search.status import Status


def points(result):
    return sorted(tuple(np.round(b.x, 9)) for b in result.boxes)


def test_line_and_circle_two_certified_points():
    s = System()
    x, y = s.add_var("x", -3, 3), s.add_var("y", -3, 3)
    s.add_eq(x * x + y * y - 1)
    s.add_eq(x - y)
    r = solve_system(s, sigma=1e-6)
    assert r.complete and len(r.boxes) == 2 and len(r.certified) == 2
    h = np.sqrt(0.5)
    assert np.allclose(points(r), [(-h, -h), (h, h)], atol=1e-12)
    for b in r.boxes:
        assert b.residual < 1e-14
        assert np.all(b.enclosure[0] <= b.x) and np.all(b.x <= b.enclosure[1])


def two_circles(d):
    s = System()
    x, y = s.add_var("x", -5, 5), s.add_var("y", -5, 5)
    s.add_eq(x * x + y * y - 1)
    s.add_eq((x - d) * (x - d) + y * y - 1)
    return s


def test_two_circles_two_points():
    r = solve_system(two_circles(1.0), sigma=1e-6)
    assert r.complete and len(r.certified) == 2
    assert np.allclose(points(r), [(0.5, -np.sqrt(3) / 2), (0.5, np.sqrt(3) / 2)], atol=1e-12)


def test_tangent_circles_one_double_point_not_certified():
    r = solve_system(two_circles(2.0), sigma=1e-6)
    assert r.complete
    # a double root cannot be certified by a regular-root test: boxes next to (1, 0) only (the
    # rows hold to their slack in a band |y| ~ sqrt(slack) around it), one of them holding it
    assert len(r.boxes) >= 1 and not r.certified
    p = np.array([1.0, 0.0])
    for b in r.boxes:
        assert np.all(b.lo <= p + 1e-6) and np.all(b.hi >= p - 1e-6)
    assert any(np.all(b.lo <= p) and np.all(b.hi >= p) for b in r.boxes)


@pytest.mark.parametrize("gap", [1e-6, 1e-9])
def test_a_near_double_root_is_two_certified_roots_even_inside_one_sigma_box(gap):
    """Two circles a hair from tangency cross at (1, +-y), y ~ sqrt(gap): closer than sigma.
    Newton from the centre of a box holding both stalls between them; the box must still be
    split until each root is certified (one Dietmeier assembly mode was reported inside a box
    with its twin, and lost from the answer)."""
    y = np.sqrt(1.0 - (1.0 - gap / 2) ** 2)
    r = solve_system(two_circles(2.0 - gap), sigma=1e-2)
    assert r.complete and len(r.boxes) == 2 and len(r.certified) == 2
    assert sorted(b.x[1] for b in r.boxes) == pytest.approx([-y, y], rel=1e-6)


def test_disjoint_circles_proven_empty():
    r = solve_system(two_circles(2.5), sigma=1e-6)
    assert r.complete and r.success and r.boxes == [] and r.status == "complete"
    assert "no solution" in r.message


def test_sqrt2():
    s = System()
    x = s.add_var("x", -10, 10)
    s.add_eq(x * x - 2)
    r = solve_system(s)
    assert len(r.certified) == 2
    assert sorted(b.x[0] for b in r.boxes) == pytest.approx([-np.sqrt(2), np.sqrt(2)], abs=1e-15)


def test_bilinear_system():
    # x y = 1, x + y = 2.5  ->  (2, 0.5) and (0.5, 2)
    s = System()
    x, y = s.add_var("x", -4, 4), s.add_var("y", -4, 4)
    s.add_eq(x * y - 1)
    s.add_eq(x + y - 2.5)
    r = solve_system(s)
    assert len(r.certified) == 2
    assert np.allclose(points(r), [(0.5, 2.0), (2.0, 0.5)], atol=1e-12)


@pytest.mark.parametrize("curve_boxes", [False, True])
def test_circle_positive_dimensional_cover(curve_boxes):
    s = System()
    x, y = s.add_var("x", -2, 2), s.add_var("y", -2, 2)
    s.add_eq(x * x + y * y - 1)
    r = solve_system(s, sigma=0.05, curve_boxes=curve_boxes)
    assert r.complete and r.boxes and not r.certified
    los = np.array([b.lo for b in r.boxes])
    his = np.array([b.hi for b in r.boxes])
    # every sampled point of the circle is in some box
    for t in np.linspace(0, 2 * np.pi, 997):
        p = np.array([np.cos(t), np.sin(t)])
        assert np.any(np.all((los <= p) & (p <= his), axis=1)), t
    # every box touches the circle: the distance of the box to the origin brackets 1
    for lo, hi in zip(los, his):
        near = np.linalg.norm(np.clip(0.0, lo, hi))
        far = np.linalg.norm(np.maximum(np.abs(lo), np.abs(hi)))
        assert near <= 1 + 1e-9 and far >= 1 - 1e-9
    wide = [np.max(hi - lo) > 0.05 for lo, hi in zip(los, his)]
    flagged = [b.curve for b in r.boxes]
    if not curve_boxes:
        assert not any(wide) and not any(flagged)
    else:  # curve boxes: the circle is a graph over x or y in each, not split down to sigma
        assert sum(wide) >= len(wide) // 2
        assert all(f for f, w in zip(flagged, wide) if w)  # flagged, whatever their width
        for lo, hi, w in zip(los, his, wide):
            if w:  # the circle crosses it: the arc over one variable stays in the box's hull
                t = np.linspace(0, 2 * np.pi, 4001)
                p = np.c_[np.cos(t), np.sin(t)]
                assert np.any(np.all((lo <= p) & (p <= hi), axis=1))


def test_roots_on_the_domain_boundary_are_kept():
    # Fünfzig et al. 2010, Sec. 5: x^2 - x = 0 on [0, 1]; a relaxation off by rounding loses both roots
    s = System()
    x = s.add_var("x", 0, 1)
    s.add_eq(x * x - x)
    r = solve_system(s, sigma=1e-9)
    xs = sorted(b.x[0] for b in r.boxes)
    assert len(xs) == 2 and xs[0] == pytest.approx(0, abs=1e-12) and xs[1] == pytest.approx(1, abs=1e-12)


def test_inexact_coefficients_keep_roots():
    # roots 0.1 and 0.3 are not floats: (x - 0.1)(x - 0.3) = x^2 - 0.4 x + 0.03
    s = System()
    x = s.add_var("x", 0.1, 0.3)  # the domain ends exactly at the (rounded) roots
    s.add_eq(x * x - 0.4 * x + 0.03)
    r = solve_system(s, sigma=1e-12)
    assert len(r.boxes) == 2


def random_system(rng, n):
    """A random square quadratic system with a known root x0 inside [-1, 1]^n."""
    x0 = rng.uniform(-0.9, 0.9, n)
    s = System()
    xs = [s.add_var(f"x{i}", -1, 1) for i in range(n)]
    for _ in range(n):
        e = 0.0
        for i in range(n):
            e = e + rng.normal() * xs[i]
            j = rng.integers(n)
            e = e + rng.normal() * xs[i] * xs[j]
        e = e - e.value(x0)  # x0 is a root (up to rounding of the constant)
        s.add_eq(e)
    return s, x0


@pytest.mark.parametrize("seed", range(40))
def test_random_systems_never_lose_the_known_root(seed):
    rng = np.random.default_rng(seed)
    s, x0 = random_system(rng, int(rng.integers(2, 5)))
    r = solve_system(s, sigma=1e-7, max_boxes=20000)
    assert r.complete
    tol = 1e-9
    hit = [b for b in r.boxes if np.all(b.lo - tol <= x0) and np.all(x0 <= b.hi + tol)]
    assert hit, f"root {x0} lost; boxes: {[b.x for b in r.boxes]}"


def test_budget_reports_incomplete():
    s = System()
    x, y = s.add_var("x", -2, 2), s.add_var("y", -2, 2)
    s.add_eq(x * x + y * y - 1)
    r = solve_system(s, sigma=1e-4, max_boxes=20)
    assert not r.complete and not r.success
    assert "budget" in r.message and r.pending
    assert r.stats["boxes"] == 20
    # why it stopped is an enum that JSON writes as its value
    assert r.status is Status.BOX_BUDGET and json.dumps({"status": r.status}) == '{"status": "box budget"}'
    assert "status='box budget'" in repr(r)


def test_components_of_circle_and_points():
    from kinbox.answer.components import components

    s = System()
    x, y = s.add_var("x", -2, 2), s.add_var("y", -2, 2)
    s.add_eq(x * x + y * y - 1)
    r = solve_system(s, sigma=0.05)
    comps = components(s, r.boxes, 0.05)
    assert len(comps) == 1 and comps[0].dimension == 1 and len(comps[0].boxes) == len(r.boxes)

    r = solve_system(two_circles(1.0), sigma=1e-6)
    comps = components(r.system, r.boxes, 1e-6)
    assert [c.dimension for c in comps] == [0, 0]


def test_two_separate_curves():
    # (x^2 + y^2 - 1) = 0 and z^2 = 1/4 : two circles at z = +-1/2
    s = System()
    x, y, z = (s.add_var(n, -2, 2) for n in "xyz")
    s.add_eq(x * x + y * y - 1)
    s.add_eq(z * z - 0.25)
    r = solve_system(s, sigma=0.1)
    from kinbox.answer.components import components

    comps = components(s, r.boxes, 0.1)
    assert len(comps) == 2 and all(c.dimension == 1 for c in comps)


@pytest.mark.parametrize("names, certified", [(("c[j]", "s[j]"), 2), (("x", "y"), 2)])
def test_roots_on_a_unit_bound(names, certified):
    """c = +-1, s = 0 lie on the domain's bounds, whatever the variables are called: the search
    domain is the domain widened by the slack of derived rows, so the roots are inside it and
    certified although their proof boxes cross the bounds."""
    s = System()
    c, si = s.add_var(names[0], -1.0, 1.0), s.add_var(names[1], -1.0, 1.0)
    s.add_eq(c * c + si * si - 1.0)
    s.add_eq(si + 0.0 * c)
    r = solve_system(s, sigma=1e-6)
    assert r.complete
    assert len(r.certified) == certified
    xs = sorted(float(b.x[0]) for b in r.boxes)
    assert np.isclose(xs[0], -1.0, atol=1e-9) and np.isclose(xs[-1], 1.0, atol=1e-9)


# -- the compiled Newton and the Jacobian pattern (system.Rows) ------------------------------------
def test_jacobian_matches_finite_differences_and_newton_converges():
    from kinbox.formulation.build import formulate
    from kinbox.model.loading import load
    from kinbox.search.certify import Certifier, gauss_newton

    system = formulate(load("general-6r")).system
    comp = system.compile()
    rng = np.random.default_rng(1)
    x = rng.uniform(-1, 1, comp.n)
    h = 1e-6
    fd = np.column_stack([(comp.eval_eqs(x + h * e) - comp.eval_eqs(x - h * e)) / (2 * h) for e in np.eye(comp.n)])
    assert np.allclose(comp.jacobian(x), fd, atol=1e-7)
    cert = Certifier(comp)
    assert np.allclose(cert.J(x), fd[: comp.n_core], atol=1e-7)

    root = solve_system(system).certified[0].x
    x0 = root + 1e-3 * rng.standard_normal(comp.n)
    for x1 in (cert.newton(x0), gauss_newton(comp, x0)):
        assert np.max(np.abs(comp.eval_eqs(x1))) < 1e-13
        assert np.max(np.abs(x1 - root)) < 1e-9
    lo, hi = root - 1e-4, root + 1e-4  # kept in a box: the iterates are clipped to it
    x2 = cert.newton(root + 5e-3, lo, hi)
    assert np.all(x2 >= lo) and np.all(x2 <= hi)
    # far out the iteration overflows: it stops (it raised LinAlgError once) with the best point
    for far in (np.full(comp.n, 1e150), np.full(comp.n, 1e200)):  # F finite / not finite there
        for y in (cert.newton(far), gauss_newton(comp, far)):
            assert np.all(np.isfinite(y))


def test_a_double_root_is_a_point_not_a_curve():
    """x^2 = 0, y = 1: J is singular at the root, so the rank alone says dimension 1; a component
    no wider than sigma is a point (the UR5 at its elbow singularity was reported as a curve and
    lost its solution on some search paths)."""
    from kinbox.answer.components import components

    s = System()
    x, y = s.add_var("x", -1, 1), s.add_var("y", -2, 2)
    s.add_eq(x * x)
    s.add_eq(y - 1)
    r = solve_system(s, sigma=1e-3)
    assert r.complete and r.boxes
    comps = components(s, r.boxes, 1e-3)
    assert len(comps) == 1 and comps[0].dimension == 0
    assert all(abs(b.x[0]) < 1e-3 and abs(b.x[1] - 1) < 1e-9 for b in r.boxes)


def test_load_kernels_loads_the_search_kernels():
    """``load_kernels`` (what a solve runs before its clock starts when a kernel is not cached
    yet) calls every search kernel once: from the ahead-of-time module, or compiled (or loaded
    from numba's cache)."""
    from kinbox.search import relaxation
    from kinbox.search.jit import loaded_kernels
    from kinbox.search.solver import load_kernels

    load_kernels()
    assert relaxation._safe_lower.name in dict(loaded_kernels())


def test_the_search_is_repeatable_box_for_box():
    """No decision depends on a clock or on the boxes processed before: two runs with LPs on
    give the same boxes and the same counts."""
    from kinbox.formulation.build import formulate
    from kinbox.model.loading import load

    system = formulate(load("general-6r")).system
    a, b = (solve_system(system, sigma=1e-4) for _ in range(2))
    keys = ("boxes", "empty", "split", "lps", "krawczyk", "solutions", "certified")
    assert [a.stats[k] for k in keys] == [b.stats[k] for k in keys]
    assert len(a.boxes) == len(b.boxes) == 16
    for p, q in zip(a.boxes, b.boxes):
        assert np.array_equal(p.lo, q.lo) and np.array_equal(p.hi, q.hi) and np.array_equal(p.x, q.x)


def test_a_derived_row_that_cancels_to_rounding_noise_is_dropped_not_kept_as_a_contradiction():
    """A redundant row that elimination turns into a constant holds up to the rounding of the
    terms that cancelled; kept with an exact target it would prove every box empty."""
    s = System()
    x, t = s.add_var("x", -1, 1), s.add_var("t", -100, 100)
    s.add_eq(t - 3 * x - 0.1)
    s.add_eq(x * x - 0.25)
    # the same row scaled by 0.1 then 10: after t is eliminated its constant is rounding noise
    s.add_eq((t - 3 * x - 0.1) * 0.1 * 10.0 - 1e-15, redundant=True)
    e = s.eliminate_linear(["t"])
    assert all(not c.expr.is_constant() for c in e.constraints)
    r = solve_system(e, sigma=1e-6)
    assert r.complete and len(r.certified) == 2
    # a genuinely failing constant (far above the rounding of what cancelled) still empties it
    s.add_eq(t - 3 * x - 0.1 + 1.0, redundant=True)
    assert solve_system(s.eliminate_linear(["t"]), sigma=1e-6).boxes == []


def test_progress_is_a_tqdm_line_refreshed_a_few_times_a_second(monkeypatch):
    import io
    import time

    from kinbox.search.solver import Progress

    err = io.StringIO()
    monkeypatch.setattr("sys.stderr", err)
    p = Progress(True, np.ones(2))
    stats = {"boxes": 0, "solutions": 1, "certified": 1}
    box = (np.zeros(2), np.full(2, 0.5))
    t0 = time.perf_counter()
    while time.perf_counter() - t0 < 0.6:  # many calls, as the search makes one per box
        stats["boxes"] += 1
        p.report(stats, [box], 0, [])
    p.report(stats, [], 0, [], force=True)
    frames = [f for f in err.getvalue().replace("\n", "\r").split("\r") if f.strip()]
    assert 2 <= len(frames) <= 2 + 0.6 / Progress.INTERVAL + 2, len(frames)  # not one per call
    assert frames[-1].startswith(f"kinbox: {stats['boxes']} boxes, 0 pending, 1 solutions (1 certified)")
    assert "volume left 0.000e+00" in frames[-1] and "boxes/s]" in frames[-1]
    assert "volume left 2.500e-01" in frames[-2]  # one box a quarter of the domain
    assert err.getvalue().endswith("\n") and p.bar is None
    quiet = Progress(False, np.ones(2))
    quiet.report(stats, [], 0, [], force=True)
    assert quiet.bar is None


def test_near_singular_platform_every_assembly_once_certified(reference):
    """Dietmeier's geometry with the legs of a pose 1e-5 from a singular
    one (seed 1) has four assemblies, two of them a near-double pair 3e-5 apart. A box 0.047 wide
    holding a regular assembly (condition 2e3) was accepted below sigma, because Newton from its
    centre did not converge and the nearest approximate root, a Newton iterate 3e-8 from a root
    of the pair, was not proven regular; the answer lost that assembly and said complete. A box
    1e-7 beside the pair was reported as a singular root of its own. Every assembly multi-start
    Newton finds must be there, certified, and nothing else."""

    import kinbox
    from kinbox.model.builders import stewart
    from tests.support.oracles import stewart as sw

    ref = reference("dietmeier_66.json")
    P, Q = ref["base_points"], ref["platform_points"]
    gen, twin, L = sw.near_singular_poses(P, Q, 1, 1e-5)
    truths = [sw.pose_q(gen), sw.pose_q(twin)]
    for a in sw.assemblies(P, Q, L, starts=100, seed=1):
        if all(sw.pose_distance(a, t) > 1e-7 for t in truths):
            truths.append(a)
    assert len(truths) == 4  # premise: what Newton finds on this geometry
    res = kinbox.solve(stewart(P, Q, L), time_limit=120)
    assert res.complete
    for t in truths:
        assert min(sw.pose_distance(s.q, t) for s in res.solutions) < 1e-8
    assert len(res.solutions) == 4 and all(s.certified for s in res.solutions)
