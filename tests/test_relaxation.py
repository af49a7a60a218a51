"""Safe LP bounds of the linear relaxation (relaxation.py): never past a solution."""

import numpy as np
import pytest

from kinbox.search import relaxation
from lp_reference import safe_lower
from kinbox.search.propagate import Propagator
from kinbox.search.relaxation import Relaxation
from kinbox.formulation.system import System


def dyadic_system(rng, n):
    """A random quadratic system whose root ``x0`` is exact: dyadic root and coefficients, so
    every constant is computed without rounding and ``x0`` is a root of the system as stored."""
    x0 = rng.integers(-48, 49, n) / 64.0
    s = System()
    xs = [s.add_var(f"x{i}", -1, 1) for i in range(n)]
    for _ in range(n + 1):  # one more equation than variables: a redundant-like row
        e = 0.0
        for i in range(n):
            e = e + float(rng.integers(-16, 17) / 16.0) * xs[i]
            j = int(rng.integers(n))
            e = e + float(rng.integers(-16, 17) / 16.0) * xs[i] * xs[j]
        s.add_eq(e - e.value(x0))
    return s, x0


def box_around(rng, x0):
    lo = np.maximum(x0 - rng.integers(1, 40, len(x0)) / 64.0, -1.0)
    hi = np.minimum(x0 + rng.integers(1, 40, len(x0)) / 64.0, 1.0)
    return lo, hi


@pytest.mark.parametrize("warm", [0, 1])  # the previous LP's basis / the objective's last optimal one
@pytest.mark.parametrize("dense", [True, False])
@pytest.mark.parametrize("seed", range(12))
def test_bounds_never_cut_off_the_root(seed, dense, warm, monkeypatch):
    monkeypatch.setattr(relaxation, "DENSE", 10**9 if dense else 0)
    monkeypatch.setattr(Relaxation, "_arm", lambda self: warm)
    rng = np.random.default_rng(seed)
    s, x0 = dyadic_system(rng, int(rng.integers(2, 6)))
    comp = s.compile()
    assert np.all(comp.eval_eqs(x0) == 0.0)
    relax = Relaxation(comp)
    prop = Propagator(comp)
    tight = 0
    for _ in range(5):
        lo, hi = box_around(rng, x0)
        mlo, mhi = prop.monomials(lo, hi)
        relax.build(lo, hi, mlo, mhi)
        for k in range(comp.n):
            for sense in (+1, -1):
                b, infeasible = relax.bound(k, sense)
                assert not infeasible, "a box holding a root was declared empty"
                if b is None:
                    continue
                assert (b <= x0[k]) if sense > 0 else (b >= x0[k])
                obj = sense * relax._h.getInfo().objective_function_value
                tight += abs(b - obj) < 1e-7
                # the compiled bound is the numpy reference's, up to the order of summation
                cost = np.zeros(relax.nz)
                cost[k] = sense
                y = np.asarray(relax._h.getSolution().row_dual, dtype=float)
                ref = sense * safe_lower(relax, cost, y)
                assert abs(b - ref) <= 1e-12 * (1.0 + abs(ref))
    assert tight >= comp.n * 5  # the safe bound is the LP optimum up to rounding, not a loose one


def test_empty_relaxation_is_proven_infeasible():
    # x^2 + y^2 = 1 and (x - 3)^2 + y^2 = 1 do not meet: 6 x = 9 forces x = 1.5, then y^2 < 0
    s = System()
    x, y = s.add_var("x", -1, 4), s.add_var("y", -1, 1)
    s.add_eq(x * x + y * y - 1.0)
    s.add_eq((x - 3.0) * (x - 3.0) + y * y - 1.0)
    comp = s.compile()
    relax = Relaxation(comp)
    lo, hi = np.array([-1.0, -1.0]), np.array([4.0, 1.0])
    relax.build(lo, hi, *Propagator(comp).monomials(lo, hi))
    b, infeasible = relax.bound(0, +1)
    assert infeasible and b is None


def test_warm_start_uses_the_faster_way_and_keeps_trying_the_other():
    s = System()
    x = s.add_var("x", -1, 1)
    s.add_eq(x * x - 0.25)
    relax = Relaxation(s.compile())
    relax._arm_seconds = [2e-4, 1e-4]  # per-objective bases measured faster
    arms = [relax._arm() for _ in range(128)]
    assert arms.count(0) == 2 and arms[63] == 0 and arms[127] == 0
    relax._arm_seconds = [1e-4, 2e-4]
    assert [relax._arm() for _ in range(64)].count(1) == 1
