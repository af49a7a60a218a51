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


_LAPACK_FIRST = """
import json, sys
import numpy, scipy.sparse
from threadpoolctl import threadpool_info
from kinbox.search import threads

def blas():
    return sorted((i["filepath"], i["num_threads"]) for i in threadpool_info() if i["user_api"] == "blas")

with threads.one_thread():
    linalg_before = "scipy.linalg" in sys.modules
    before = blas()
    import scipy.linalg.cython_lapack  # what numba's np.linalg calls, imported inside a solve
    after = blas()
print(json.dumps({"linalg_before": linalg_before, "before": before, "after": after}))
"""


def test_scipys_lapack_is_on_one_thread_before_scipy_linalg_is_imported():
    """The library behind scipy.linalg.cython_lapack is loaded (without importing scipy.linalg)
    before the thread limit's scan: imported later inside a solve, it adds no library and runs
    on one thread."""
    import json
    import os
    import subprocess
    import sys
    from pathlib import Path

    src = str(Path(__file__).resolve().parents[2] / "src")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([src, os.environ.get("PYTHONPATH", "")]))
    out = subprocess.run([sys.executable, "-c", _LAPACK_FIRST], capture_output=True, text=True, env=env, timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    got = json.loads(out.stdout.strip().splitlines()[-1])
    assert got["linalg_before"] is False
    assert got["before"] == got["after"] and got["after"]
    assert all(n == 1 for _, n in got["after"])
