"""The fixed cost of a kinbox process: what `make setup` compiles, what a small answer loads."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

_SIGNATURES = """
import sys
from numba.core.registry import CPUDispatcher
from kinbox.search.jit import Kernel

def signatures():
    out = set()
    for name, mod in list(sys.modules.items()):
        if name.startswith("kinbox"):
            for key, v in vars(mod).items():
                d = getattr(v, "_dispatcher", None) if isinstance(v, Kernel) else v  # numba's, made at a first numba call
                if isinstance(d, CPUDispatcher):
                    out.update(f"{v.__module__}.{key}{s}" for s in d.signatures)
    return out
"""


def _run(code: str, **extra: str) -> str:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT / "src"), str(ROOT), os.environ.get("PYTHONPATH", "")]), **extra)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=900)
    assert out.returncode == 0, out.stderr[-3000:]
    return out.stdout


def test_all_kernels_leave_nothing_to_compile():
    """After ``load_all_kernels`` (what ``make setup`` runs), the demo's answers, a curve, a
    general 6R arm's eigenvalue path, poses near the UR5's singularities (searched in the closed
    form's enclosures) and arms of the other closed-form families, also with link rotations
    that are no signed permutations (enclosed links), compile no kernel
    signature of their own: every kernel they call was compiled (and cached) with the argument
    types they pass. Checked on numba's kernels (``KINBOX_NO_AOT``: what a process uses when
    the ahead-of-time module is stale or lacks a signature; the module itself:
    tests/search/test_jit.py)."""
    code = (
        _SIGNATURES
        + f"DATA = {str(ROOT / 'tests' / 'data' / 'arms') + '/'!r}\n"
        + """
import json, numpy as np, kinbox, kinbox.pipeline as p
p.load_all_kernels()
before = signatures()
kinbox.solve("general-6r")
ik = kinbox.IK("ur5", "tool0")
ik.solve(ik.pose_at(np.array([0.3, -1.2, 1.5, -0.8, 1.2, 0.4])))
for q in ([0.2, -1.0, 1.3, -0.7, 1e-8, 0.5], [0.3, -1.2, 1e-8, -0.8, 1.2, 0.4]):  # near-singular: enclosures
    assert ik.solve(ik.pose_at(np.array(q))).stats["searched"]
kinbox.solve("four-bar")
from kinbox.model.builders import dh_chain  # a general 6R arm: the eigenvalue path
dh = json.loads(open(kinbox.__file__.rsplit("/", 1)[0] + "/robots/general-6r.json").read())["dh"]
dh[0]["a"] += 0.01  # another arm than load_all_kernels' own
import pinocchio as pin
kinbox.IK(dh_chain(dh, closed=False, name="arm"), "tool").solve(pin.SE3.Identity())
from kinbox.model.loading import load  # arms of the other two closed-form families than the UR5's
for name in ("irb120_dh.json", "kr6_dh.json"):
    for twist in (0.0, 0.5):  # and with a twist of no right angle: the kernels' enclosed links
        dh = json.load(open(DATA + name))["dh"]
        dh[1]["alpha"] += twist
        arm = kinbox.IK(load({"kind": "dh-arm", "dh": dh}), "tool")
        assert arm.closed_form is not None and arm.closed_form.LR.ndim == (4 if twist else 3)
        arm.solve(arm.pose_at(np.array([0.3, -0.5, 0.4, -0.8, 1.2, 0.4])))
print(json.dumps({"before": len(before), "new": sorted(signatures() - before)}))
"""
    )
    got = json.loads(_run(code, KINBOX_NO_AOT="1").strip().splitlines()[-1])
    assert got["before"] > 10
    assert got["new"] == []


def test_json_answer_loads_no_viz():
    """A JSON answer on the command line imports neither the viz stage nor its libraries
    (matplotlib, meshcat), nor Dask or the parallel search."""
    code = """
import sys, io, contextlib
from kinbox.cli import main
with contextlib.redirect_stdout(io.StringIO()):
    try:
        main(["solve", "general-6r", "--json"])
    except SystemExit:
        pass
heavy = ("matplotlib", "meshcat", "dask", "distributed", "kinbox.viz", "kinbox.search.parallel")
print(sorted(m for m in sys.modules if m.split(".")[0] in heavy or any(m.startswith(h) for h in heavy)))
"""
    assert _run(code).strip().splitlines()[-1] == "[]"


def test_the_program_makes_no_full_collection_on_a_small_problem():
    """The ``kinbox`` program (:func:`kinbox.cli.command`) answers a small problem without a full
    pass of the collector over the libraries' objects (with Python's default thresholds: two)."""
    code = """
import gc, io, contextlib, sys
import kinbox.cli
sys.argv = ["kinbox", "solve", "double-butterfly", "--json"]
with contextlib.redirect_stdout(io.StringIO()):
    code = kinbox.cli.command()
print(code, gc.get_stats()[2]["collections"])
"""
    assert _run(code).strip().splitlines()[-1] == "0 0"
