"""Kernels that load numba only when they need it (kinbox.search.jit, kinbox.problems.aot)."""

from __future__ import annotations

import importlib.machinery
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from kinbox.problems import aot
from kinbox.search import jit

ROOT = Path(__file__).resolve().parents[2]


def _scale(x, out):
    for i in range(x.shape[0]):
        out[i] = 2.0 * x[i]
    return out[0]


scale = jit.Kernel(_scale, {"cache": False})


def _shift(x, by=1.0):
    return x[0] + by


def test_a_default_left_out_is_given_to_the_compiled_form():
    k = jit.Kernel(_shift, {"cache": False})
    k._aot = {(("d", 1), "d"): lambda x, by: ("ahead of time", by)}
    assert k(np.zeros(2)) == ("ahead of time", 1.0)
    assert k(np.zeros(2), 3.0) == ("ahead of time", 3.0)


def _calls_scale(x, out):
    return scale(x, out) + 1.0


def test_a_call_takes_the_compiled_form_of_its_argument_types():
    """A call goes to the ahead-of-time form whose argument codes it has; any other types (a
    strided array, ints) go to numba, which answers the same."""
    k = jit.Kernel(_scale, {"cache": False})
    k._aot = {(("d", 1), ("d", 1)): lambda x, out: "ahead of time"}
    x, out = np.arange(4.0), np.zeros(4)
    assert k(x, out) == "ahead of time"
    assert k.calls == [1, 0]
    assert k(np.arange(8.0)[::2], out) == 0.0  # not contiguous: numba
    assert k(np.arange(4), np.zeros(4)) == 0.0  # int64 array: numba
    assert k.calls == [1, 2]
    assert jit.arg_code(np.zeros(3)) == ("d", 1)
    assert jit.arg_code((np.zeros((2, 2)), 1, 2.0, True)) == ("T", ("d", 2), "q", "d", "?")
    ro = np.zeros(3)
    ro.flags.writeable = False
    assert jit.arg_code(ro) is None and jit.arg_code("x") is None


def test_numba_compiles_a_kernel_that_calls_a_kernel():
    """A kernel in another kernel's compiled code is typed as its numba dispatcher."""
    import numba

    f = numba.njit(_calls_scale)
    x, out = np.arange(3.0), np.zeros(3)
    assert f(x, out) == 1.0 and out.tolist() == [0.0, 2.0, 4.0]


def test_a_stale_module_is_not_used(tmp_path, monkeypatch):
    """A record whose sources changed since the build (or of another Python) loads nothing."""
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("KINBOX_NO_AOT", raising=False)
    files = ["interval.py"]
    suffix = importlib.machinery.EXTENSION_SUFFIXES[0]
    meta = {"python": sys.version, "suffix": suffix, "files": files, "digest": jit.source_digest(files), "exports": [], "kernels": ["a"]}
    (tmp_path / (jit.AOT_NAME + ".json")).write_text(json.dumps(meta))
    assert jit._load_aot() == ({}, frozenset())  # the record is current, but no module was built
    meta["digest"] = "0" * 64
    (tmp_path / (jit.AOT_NAME + meta["suffix"])).write_bytes(b"")
    (tmp_path / (jit.AOT_NAME + ".json")).write_text(json.dumps(meta))
    assert jit._load_aot() == ({}, frozenset())


def test_the_digest_covers_what_a_kernel_imports():
    """The files a kernel module's compiled code can see: its own and every kinbox module it
    imports from at its top level, at any depth."""
    files = aot.source_files({"kinbox.search.certify"})
    assert {"search/certify.py", "search/lstsq.py", "interval.py", "search/jit.py"} <= set(files)
    assert "cli.py" not in files and "search/solver.py" not in files


def _built() -> bool:
    code = "from kinbox.search import jit, certify; print(bool(certify._krawczyk_full.aot()))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=_env(), timeout=300)
    return out.stdout.strip() == "True"


def _env(**extra: str) -> dict[str, str]:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")]))
    env.pop("KINBOX_NO_AOT", None)
    env.update(extra)
    return env


_ANSWER = """
import io, contextlib, json, sys
from kinbox.cli import main
from kinbox.search import jit
buf = io.StringIO()
with contextlib.redirect_stdout(buf):
    main(sys.argv[1:])
res = json.loads(buf.getvalue())
print(json.dumps({"numba": "numba" in sys.modules, "kernels": jit.loaded_kernels(), "solutions": res["solutions"],
                  "boxes": res["stats"].get("boxes"), "certified": res["stats"].get("certified")}))
"""


_Q6 = "0.3,-0.5,0.4,-0.8,1.2,0.4"


@pytest.mark.parametrize(
    "args",
    [
        ["solve", "general-6r", "--json", "--time-limit", "900"],
        ["ik", "{arm}", "--frame", "tool", "--pose", "0", "0", "0", "0", "0", "0", "1", "--json", "--time-limit", "900"],
        ["ik", "ur5", "--frame", "tool0", "--from-q", _Q6, "--json", "--time-limit", "900"],
        ["ik", "{irb}", "--frame", "tool", "--from-q", _Q6, "--json", "--time-limit", "900"],
        ["ik", "panda", "--frame", "panda_hand", "--lock", "panda_joint7=0.5", "--from-q", _Q6 + ",0.5", "--json", "--time-limit", "900"],
    ],
    ids=["general-6r loop", "general-6r arm", "ur5 closed form", "irb120 closed form", "panda closed form"],
)
def test_aot_and_numba_agree(args, tmp_path):
    """The general 6R loop, its arm's IK (the eigenvalue path) and the closed forms of three arm
    families answer the same, solution for solution, from the ahead-of-time module (``make
    setup`` builds it) and from numba; with the module none of them imports numba."""
    if not _built():
        pytest.skip("no current ahead-of-time module (make setup, or python -m kinbox.problems.aot)")
    dh = json.loads((ROOT / "src" / "kinbox" / "robots" / "general-6r.json").read_text())["dh"]
    arm = tmp_path / "arm.json"
    arm.write_text(json.dumps({"kind": "dh-arm", "dh": dh}))
    irb = ROOT / "tests" / "data" / "arms" / "irb120_dh.json"
    argv = [a.replace("{arm}", str(arm)).replace("{irb}", str(irb)) for a in args]
    got = {}
    for name, env in (("aot", _env()), ("numba", _env(KINBOX_NO_AOT="1"))):
        out = subprocess.run([sys.executable, "-c", _ANSWER, *argv], capture_output=True, text=True, env=env, timeout=900)
        assert out.returncode == 0, out.stderr[-3000:]
        got[name] = json.loads(out.stdout.strip().splitlines()[-1])
    assert got["aot"]["kernels"] and all(how == "aot" or k in aot.NOT_AHEAD for k, how in got["aot"]["kernels"])
    assert all(how == "numba" for _, how in got["numba"]["kernels"])
    for key in ("solutions", "boxes", "certified"):
        assert got["aot"][key] == got["numba"][key]
    assert got["aot"]["solutions"]
    assert got["aot"]["numba"] is False


_EDITED = """
import sys, importlib.util
from pathlib import Path
from kinbox.search import jit
root = Path(sys.argv[1])
jit._PACKAGE = root  # the fake kernel modules' files stand for kinbox's
mods = {}
for name in ("fake_callee", "fake_caller"):
    spec = importlib.util.spec_from_file_location(f"kinbox.search.{name}", root / "search" / f"{name}.py")
    mods[name] = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mods[name]
    spec.loader.exec_module(mods[name])
print(mods["fake_caller"].x(1.0))
"""


def test_an_edited_callee_is_not_taken_from_the_cache(tmp_path):
    """numba's cache checks a kernel against its own file only, and holds the code of the
    kernels it calls: a kernel whose callee (in another file) was edited since it was cached
    is compiled again, not loaded with the old callee (kinbox.search.jit._stamp_cache)."""
    (tmp_path / "search").mkdir()
    callee = tmp_path / "search" / "fake_callee.py"
    head = "from kinbox.search import jit as nb\n\n\n@nb.njit(cache=True)\n"
    callee.write_text(head + "def y(t):\n    return t + 1.0\n")
    (tmp_path / "search" / "fake_caller.py").write_text(
        "from kinbox.search.fake_callee import y\n" + head + "def x(t):\n    return 2.0 * y(t)\n"
    )
    env = _env(KINBOX_NO_AOT="1", NUMBA_CACHE_DIR=str(tmp_path / "cache"))

    def run() -> float:
        out = subprocess.run([sys.executable, "-c", _EDITED, str(tmp_path)], capture_output=True, text=True, env=env, timeout=300)
        assert out.returncode == 0, out.stderr[-3000:]
        return float(out.stdout.strip().splitlines()[-1])

    assert run() == 4.0
    assert any((tmp_path / "cache").rglob("*fake_caller*.nbi"))  # cached
    callee.write_text(head + "def y(t):\n    return t + 5.0\n")
    assert run() == 12.0


_PLAIN = """
import sys
import numpy as np
from kinbox.search import closed_form as cf

assert "numba" not in sys.modules  # the closed form's module declares its kernels and overload without numba
import numba


@numba.njit
def plain(family, LR, Lt, d, Rlo, Rhi, tlo, thi, out, rp):
    return cf.solve_pose(family, LR, Lt, d, Rlo, Rhi, tlo, thi, out, rp)


rng = np.random.default_rng(0)
LR = np.ascontiguousarray(np.stack([np.linalg.qr(rng.normal(size=(3, 3)))[0] for _ in range(6)]))
Lt, d = rng.normal(size=(6, 3)), rng.normal(size=6)
R = np.linalg.qr(rng.normal(size=(3, 3)))[0]
t = rng.normal(size=3)
out, rp = np.zeros((cf.MAX_ROOTS, 6, 4)), np.zeros((4, 3, 4))
n = plain(cf.family_tag(3), LR, Lt, d, R - 1e-12, R + 1e-12, t - 1e-12, t + 1e-12, out, rp)
print(int(n))
"""


def test_a_plain_numba_kernel_inlines_a_closed_form_step():
    """A kernel compiled by numba itself (not through kinbox.search.jit) that calls a closed-form
    step inlines it, the family overload registered on the way (Kernel.targetoptions), though no
    kinbox kernel had set numba up in the process."""
    out = subprocess.run([sys.executable, "-c", _PLAIN], capture_output=True, text=True, env=_env(KINBOX_NO_AOT="1"), timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    assert int(out.stdout.strip().splitlines()[-1]) >= -1 - 2 * 8
