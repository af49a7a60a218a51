"""A solve runs its linear algebra on one thread (search/threads.py) and gives the process its
thread counts back afterwards."""

from threadpoolctl import threadpool_info, threadpool_limits

from kinbox.formulation.system import System
from kinbox.pipeline import solve_system
from kinbox.search import solver


def blas_threads() -> set[int]:
    return {i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"}


def test_a_solve_runs_blas_on_one_thread_and_restores_the_count(monkeypatch):
    s = System()
    x, y = s.add_var("x", -3, 3), s.add_var("y", -3, 3)
    s.add_eq(x * x + y * y - 1)
    s.add_eq(x - y)
    seen = []
    process = solver.BoxProcessor.process

    def watched(self, *args, **kw):
        seen.append(blas_threads())
        return process(self, *args, **kw)

    monkeypatch.setattr(solver.BoxProcessor, "process", watched)
    solve_system(s, sigma=1e-6)  # loads the kernels, and with them scipy's LAPACK
    with threadpool_limits(limits=2):
        assert blas_threads() == {2}
        seen.clear()
        r = solve_system(s, sigma=1e-6)
        assert blas_threads() == {2}  # given back
    assert len(r.certified) == 2
    assert seen and all(t == {1} for t in seen)
