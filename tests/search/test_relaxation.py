"""Safe LP bounds of the linear relaxation (relaxation.py): never past a solution."""

import gc
import time
import weakref

import highspy
import numpy as np
import pytest
import scipy.sparse as sp

from kinbox import interval as iv
from kinbox.formulation.system import System
from kinbox.search import relaxation
from kinbox.search.propagate import Propagator
from kinbox.search.relaxation import Relaxation
from tests.support import paths as PATHS
from tests.support.lp_reference import safe_lower


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


def test_a_cold_lp_runs_the_dual_simplex_and_the_rest_the_primal(monkeypatch):
    """From HiGHS's slack basis (no basis passed) the first LP of a box runs the dual simplex,
    which needs no phase 1 on boxed columns; the LPs after it on the same model, and a box
    started from a basis, run the primal one, which keeps the basis feasible across a change
    of objective."""
    rng = np.random.default_rng(3)
    s, x0 = dyadic_system(rng, 4)
    comp = s.compile()
    prop = Propagator(comp)
    relax = Relaxation(comp)
    seen = []
    run = highspy.Highs.run

    def spy(h):
        seen.append(h.getOptionValue("simplex_strategy")[1])
        return run(h)

    monkeypatch.setattr(highspy.Highs, "run", spy)
    lo, hi = box_around(rng, x0)
    relax.build(lo, hi, *prop.monomials(lo, hi))
    for k in range(2):
        for sense in (1, -1):
            relax.bound(k, sense)
    assert seen == [relaxation.DUAL] + [relaxation.PRIMAL] * 3
    seen.clear()
    relax.build(lo, hi, *prop.monomials(lo, hi), relax.basis())
    relax.bound(0, 1)
    relax.bound(0, -1)
    assert seen == [relaxation.PRIMAL] * 2
    assert relax._h.getOptionValue("simplex_strategy")[1] == relaxation.PRIMAL


def _replay(relax: Relaxation, name: str, as_built: bool = False):
    """Put a stored LP (HiGHS's column-wise arrays) into ``relax`` in place of a built box's,
    with the arrays its safe bound reads; ``as_built``: with the column bounds HiGHS gets from
    :meth:`Relaxation.build`, else exactly as stored. Returns the objective ``(column, sense)``."""
    d = np.load(PATHS.DATA / name)
    nrow, ncol = len(d["row_lower"]), len(d["col_lower"])
    G = sp.csc_matrix((d["value"], d["index"], d["start"]), shape=(nrow, ncol)).tocsr()
    G.sort_indices()
    relax.start, relax.index, relax.value = G.indptr.astype(np.int32), G.indices.astype(np.int32), G.data
    relax.row_lo, relax.row_hi = d["row_lower"].copy(), d["row_upper"].copy()
    relax.zlo, relax.zhi = d["col_lower"].copy(), d["col_upper"].copy()
    relax.zmag = np.maximum(np.abs(relax.zlo), np.abs(relax.zhi))
    col_nnz = np.bincount(relax.index, minlength=ncol)
    relax.gamma_col, relax.tiny_col = iv.gamma(col_nnz + 2), (col_nnz + 1) * iv.TINY
    lp = highspy.HighsLp()
    lp.num_col_, lp.num_row_ = ncol, nrow
    lp.col_cost_ = np.zeros(ncol)
    lp.col_lower_, lp.col_upper_ = relaxation.for_highs(relax.zlo, relax.zhi) if as_built else (relax.zlo, relax.zhi)
    lp.row_lower_, lp.row_upper_ = relax.row_lo, relax.row_hi
    lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
    lp.a_matrix_.start_, lp.a_matrix_.index_, lp.a_matrix_.value_ = d["start"], d["index"], d["value"]
    relax._h.passModel(lp)
    relax._cost_col = None
    relax._cold = False  # replayed as they ran: with the primal simplex, from where they started
    k, sense = (int(v) for v in d["objective"])
    return k, sense


def _small_relaxation():
    s, _ = dyadic_system(np.random.default_rng(0), 3)
    return Relaxation(s.compile())


# The first LP of a UR5 pose's search (kinbox ik ur5 --frame tool0 --pose 0.08246775261833508
# -0.5979744537509144 0.28892455801373795 -0.16326894312906107 -0.48308623431340497
# 0.47881376152991645 0.7146385969117436): HiGHS's primal phase 1 flips nonbasic variables
# between their bounds forever, and flips are not simplex iterations, so the iteration limit
# never stopped it and the search sat in one LP. Columns pinned to 0 up to underflow (bounds
# of a few 1e-308) are part of the trigger. "thread": the hang is inside HiGHS, where a signal
# handler never runs.
@pytest.mark.timeout(60, method="thread")
def test_lp_that_flips_forever_is_stopped_by_the_step_limit():
    relax = _small_relaxation()
    k, sense = _replay(relax, "lp_flip_cycle.npz")
    b, infeasible = relax.bound(k, sense)
    assert not infeasible
    assert relax._steps[0] <= relaxation.STEP_LIMIT + 1
    if b is None:  # stopped (a HiGHS without the cycle may solve it)
        assert relax._h.getModelStatus() == highspy.HighsModelStatus.kInterrupt
        # by the steps that are not iterations, long before the step limit
        iterations = relax._h.getInfo().simplex_iteration_count
        assert relax._steps[0] - iterations == relaxation.FLIP_LIMIT + 1


@pytest.mark.timeout(60, method="thread")
def test_the_step_limit_still_stops_a_cycle_when_flips_are_allowed(monkeypatch):
    monkeypatch.setattr(relaxation, "FLIP_LIMIT", 10**12)
    relax = _small_relaxation()
    k, sense = _replay(relax, "lp_flip_cycle.npz")
    b, infeasible = relax.bound(k, sense)
    assert not infeasible
    assert relax._steps[0] <= relaxation.STEP_LIMIT + 1
    if b is None:
        assert relax._h.getModelStatus() == highspy.HighsModelStatus.kInterrupt
        assert relax._steps[0] == relaxation.STEP_LIMIT + 1


@pytest.mark.timeout(60, method="thread")
def test_lp_that_flips_forever_solves_as_built():
    # columns zero up to underflow go to HiGHS fixed at 0: then the LP solves, and the bound,
    # computed with the stored bounds, is at most the LP's optimum
    relax = _small_relaxation()
    k, sense = _replay(relax, "lp_flip_cycle.npz", as_built=True)
    b, infeasible = relax.bound(k, sense)
    assert relax._h.getModelStatus() == highspy.HighsModelStatus.kOptimal
    assert not infeasible and b is not None
    h = relaxation.new_highs()
    h.setOptionValue("output_flag", False)
    h.setOptionValue("simplex_strategy", 1)
    h.passModel(relax._h.getLp())
    h.changeColsBounds(len(relax.zlo), np.arange(len(relax.zlo), dtype=np.int32), relax.zlo, relax.zhi)
    h.run()
    assert h.getModelStatus() == highspy.HighsModelStatus.kOptimal
    assert sense * b <= h.getInfo().objective_function_value + 1e-9


def test_columns_zero_up_to_underflow_go_to_highs_fixed():
    relax = _small_relaxation()
    lo, hi = -np.ones(relax.n), np.ones(relax.n)
    lo[0], hi[0] = -3 * iv.TINY, 2 * iv.TINY
    relax.build(lo, hi, *Propagator(relax.comp).monomials(lo, hi))
    lp = relax._h.getLp()
    assert lp.col_lower_[0] == 0.0 == lp.col_upper_[0] and relax.zlo[0] == lo[0]
    assert lp.col_lower_[1] == -1.0
    relax.set_bounds(1, 0.0, iv.TINY)
    lp = relax._h.getLp()
    assert lp.col_upper_[1] == 0.0 and relax.zhi[1] == iv.TINY
    relax.bound(2, +1)
    assert relax._h.getModelStatus() in (highspy.HighsModelStatus.kOptimal, highspy.HighsModelStatus.kInfeasible)


@pytest.mark.timeout(60, method="thread")
def test_wall_clock_cap_stops_an_lp_that_the_step_limit_misses(monkeypatch):
    monkeypatch.setattr(relaxation, "STEP_LIMIT", 10**12)
    monkeypatch.setattr(relaxation, "FLIP_LIMIT", 10**12)
    monkeypatch.setattr(relaxation, "LP_SECONDS", 0.2)
    relax = _small_relaxation()
    for _ in range(2):  # the run clock of HiGHS's time limit adds up over runs: the second LP
        k, sense = _replay(relax, "lp_flip_cycle.npz")  # gets its own LP_SECONDS too
        b, infeasible = relax.bound(k, sense)
        assert not infeasible
        if b is None:
            assert relax._h.getModelStatus() == highspy.HighsModelStatus.kTimeLimit
            assert relax._steps[0] > 100


def test_a_stopped_lp_does_not_stop_the_next(monkeypatch):
    # HiGHS keeps the callback's interrupt flag from one run to the next
    relax = _small_relaxation()
    lo, hi = -np.ones(relax.n), np.ones(relax.n)
    relax.build(lo, hi, *Propagator(relax.comp).monomials(lo, hi))
    monkeypatch.setattr(relaxation, "STEP_LIMIT", 0)
    assert relax.bound(0, +1) == (None, False)
    assert relax._h.getModelStatus() == highspy.HighsModelStatus.kInterrupt
    monkeypatch.setattr(relaxation, "STEP_LIMIT", 10_000)
    b, infeasible = relax.bound(0, -1)
    assert relax._h.getModelStatus() == highspy.HighsModelStatus.kOptimal and b is not None


def test_no_lp_runs_after_the_deadline():
    relax = _small_relaxation()
    lo, hi = -np.ones(relax.n), np.ones(relax.n)
    relax.build(lo, hi, *Propagator(relax.comp).monomials(lo, hi))
    relax.deadline = time.perf_counter() - 1.0
    assert relax.bound(0, +1) == (None, False)
    assert relax.lps == 0


def test_relaxations_are_garbage_collected():
    # HiGHS holds the step callback: it must not refer back to the Relaxation
    relax = _small_relaxation()
    ref = weakref.ref(relax)
    del relax
    gc.collect()
    assert ref() is None


def _pass_as_highs_lp(relax: Relaxation, basis=None) -> None:
    """The model pass as it was made before ``passModel``'s array form: a ``HighsLp`` filled
    field by field (and the basis through the enum dict)."""
    lp = highspy.HighsLp()
    lp.num_col_, lp.num_row_ = relax.nz, relax.nrow
    lp.col_cost_ = np.zeros(relax.nz)
    lp.col_lower_, lp.col_upper_ = relaxation.for_highs(relax.zlo, relax.zhi)
    lp.row_lower_ = np.where(np.isfinite(relax.row_lo), relax.row_lo, -highspy.kHighsInf)
    lp.row_upper_ = np.where(np.isfinite(relax.row_hi), relax.row_hi, highspy.kHighsInf)
    lp.a_matrix_.format_ = highspy.MatrixFormat.kRowwise
    lp.a_matrix_.start_, lp.a_matrix_.index_, lp.a_matrix_.value_ = relax.start, relax.index, relax.value
    relax._h.passModel(lp)
    if basis is not None:
        b = highspy.HighsBasis()
        b.col_status = [relaxation.BASIS_STATUS[int(v)] for v in basis[0]]
        b.row_status = [relaxation.BASIS_STATUS[int(v)] for v in basis[1]]
        b.valid = True
        relax._h.setBasis(b)
    relax._cost_col = None
    relax._cold = basis is None


@pytest.mark.parametrize("bernstein", [False, True])
def test_array_model_pass_gives_highs_the_same_lp_and_the_same_steps(bernstein, monkeypatch):
    """``pass_model`` hands HiGHS its arrays through ``passModel``'s array form (cheaper than a
    ``HighsLp``): HiGHS must hold the same LP, take the same simplex steps from the same basis,
    and give the same duals, bit for bit, so the search does not change."""
    from kinbox.search.bernstein import BernsteinLP

    rng = np.random.default_rng(11)
    s, x0 = dyadic_system(rng, 5)
    comp = s.compile()
    prop = Propagator(comp)
    make = BernsteinLP if bernstein else Relaxation

    def run(relax, lo, hi, basis):
        relax.build(lo, hi, *prop.monomials(lo, hi), basis)
        h = relax._h
        lp = h.getLp()
        model = [np.asarray(getattr(lp, f)) for f in ("col_cost_", "col_lower_", "col_upper_", "row_lower_", "row_upper_")]
        model += [np.asarray(getattr(lp.a_matrix_, f)) for f in ("start_", "index_", "value_")]
        model.append(np.asarray([int(v) for v in lp.integrality_ if int(v) != 0]))  # nothing integer
        solves = []
        for k in range(comp.n):
            for sense in (1, -1):
                b = relax.bound(k, sense)
                solves.append((b, h.getInfo().simplex_iteration_count, relax._steps[0], np.asarray(h.getSolution().row_dual).tobytes()))
        return model, solves, relax.basis()

    new, old = make(comp), make(comp)
    monkeypatch.setattr(old, "pass_model", lambda basis=None: _pass_as_highs_lp(old, basis))
    basis_new = basis_old = None
    for _ in range(4):
        lo, hi = box_around(rng, x0)
        m_new, s_new, b_new = run(new, lo, hi, basis_new)
        m_old, s_old, b_old = run(old, lo, hi, basis_old)
        assert len(m_new) == len(m_old)
        for a, b in zip(m_new, m_old, strict=True):
            assert a.tobytes() == b.tobytes()
        assert s_new == s_old
        assert all(np.array_equal(a, b) for a, b in zip(b_new, b_old, strict=True))
        basis_new, basis_old = b_new, b_old
