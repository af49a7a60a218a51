"""Safe LP bounds of the linear relaxation (relaxation.py): never past a solution."""

import numpy as np
import pytest
from lp_reference import safe_lower

from kinbox.formulation.system import System
from kinbox.search import relaxation
from kinbox.search.propagate import Propagator
from kinbox.search.relaxation import Relaxation


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


@pytest.mark.parametrize("warm", [0, 1])  # HiGHS's slack basis / the basis the box before ended on
@pytest.mark.parametrize("dense", [True, False])
@pytest.mark.parametrize("seed", range(12))
def test_bounds_never_cut_off_the_root(seed, dense, warm, monkeypatch):
    monkeypatch.setattr(relaxation, "DENSE", 10**9 if dense else 0)
    rng = np.random.default_rng(seed)
    s, x0 = dyadic_system(rng, int(rng.integers(2, 6)))
    comp = s.compile()
    assert np.all(comp.eval_eqs(x0) == 0.0)
    relax = Relaxation(comp)
    prop = Propagator(comp)
    tight = 0
    basis = None
    for _ in range(5):
        lo, hi = box_around(rng, x0)
        mlo, mhi = prop.monomials(lo, hi)
        relax.build(lo, hi, mlo, mhi, basis)
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
        basis = relax.basis() if warm else None
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


def test_a_bound_depends_on_the_box_and_its_basis_only():
    """The search is repeatable only if an LP's bound does not depend on the LPs solved before
    in the same HiGHS object (for other boxes): the same box and starting basis give the same
    bound, bit for bit, after any history."""
    rng = np.random.default_rng(7)
    s, x0 = dyadic_system(rng, 5)
    comp = s.compile()
    prop = Propagator(comp)
    boxes = [box_around(rng, x0) for _ in range(6)]

    def bounds(relax, lo, hi, basis=None):
        relax.build(lo, hi, *prop.monomials(lo, hi), basis)
        return [relax.bound(k, sense)[0] for k in range(comp.n) for sense in (1, -1)]

    fresh = Relaxation(comp)
    ref = bounds(fresh, *boxes[0])
    basis = fresh.basis()
    ref_warm = bounds(Relaxation(comp), *boxes[1], basis)
    used = Relaxation(comp)
    for lo, hi in boxes[2:]:
        bounds(used, lo, hi)
    assert bounds(used, *boxes[0]) == ref
    assert bounds(used, *boxes[1], basis) == ref_warm
