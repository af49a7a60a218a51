"""The ahead-of-time module of kinbox's compiled kernels, built by ``make setup``.

    python -m kinbox.problems.aot     # load_all_kernels, then the module (a minute of CPU)

It runs on numba what ``make setup`` always ran (:func:`kinbox.problems.kernels.load_all_kernels`:
every kernel compiled and cached) and two small searches (the general 6R loop, the Double
Butterfly), then compiles every kernel of :mod:`kinbox.search.jit` that was called from Python
into one extension module, with each argument signature it was called with from Python (a
signature numba compiled for a kernel's own callers only is left out), by numba's own
ahead-of-time compiler (``numba.pycc``, the same typing and LLVM as the JIT). The module and a
record (``kinbox_kernels.json``: the signatures, the kinbox source files the kernels are made
from and their digest) go to :func:`kinbox.search.jit.aot_folder`. A kernel uses it only while
those files are unchanged; a signature the module lacks, or a failed build (no C compiler),
leaves the kernel to numba, as before.
"""

from __future__ import annotations

import importlib.machinery
import json
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from ..search import jit

_PACKAGE = Path(jit.__file__).resolve().parents[1]


#: kernels left to numba (none): the build's compiled forms answer bit for bit as numba's
#: (tests/search/test_jit.py::test_aot_and_numba_agree)
NOT_AHEAD: frozenset[str] = frozenset()


#: kernels compiled once per closed-form family (their first argument the family's tag,
#: :func:`kinbox.search.closed_form.family_tag`): ``make setup`` compiles every family's
#: (:func:`kinbox.search.cf_batch.load_family_kernels`) with the other argument types of an arm's
#: call, and the module takes them all, so an arm of any family answers without numba
PER_FAMILY = frozenset({"kinbox.search.closed_form.solve_batch_kernel", "kinbox.search.cf_certify.solve_batch_joint"})


def _called(k: jit.Kernel, codes: tuple) -> bool:
    """Was kernel ``k`` called from Python with argument codes ``codes`` (for a kernel of
    :data:`PER_FAMILY`: with those codes but the family's tag)?"""
    if codes in k.seen:
        return True
    return k.name in PER_FAMILY and bool(codes) and codes[0][0] == "T" and any(s[1:] == codes[1:] for s in k.seen)


def _code(t: Any) -> Any:
    """The argument code (:func:`kinbox.search.jit.arg_code`) of numba type ``t``, or None for
    a type the module does not take."""
    import numpy as np
    from numba.core import types

    if isinstance(t, types.Array):
        if t.layout != "C" or t.mutable is False:
            return None
        return [np.dtype(str(t.dtype)).char, t.ndim]
    if isinstance(t, types.BaseTuple) and not isinstance(t, types.BaseNamedTuple):
        codes = [_code(e) for e in t.types]  # type: ignore[attr-defined]  # Tuple and UniTuple both have .types
        return None if None in codes else ["T", *codes]
    return {types.float64: "d", types.int64: "q", types.boolean: "?"}.get(t)


#: the kinbox files a kernel module's compiled code can be made of (:func:`kinbox.search.jit.source_files`)
source_files = jit.source_files


def _compiled(k: jit.Kernel) -> bool:
    """Is kernel ``k`` compiled in this process or in numba's cache?"""
    from numba.core.caching import NullCache

    d = k.dispatcher
    cache = getattr(d, "_cache")  # noqa: B009 - not in numba's stubs
    return bool(d.overloads) or (not isinstance(cache, NullCache) and bool(cache._cache_file._load_index()))


def exercise() -> None:
    """Every kernel called on numba with the argument types of real calls: what ``make setup``
    always ran, two searches, a general 6R arm's JSON answer (its boxes certified on the kinbox
    system too)."""
    import pinocchio as pin

    from ..model.loading import load
    from . import mechanism
    from .ik import IK
    from .kernels import load_all_kernels

    load_all_kernels()
    for name in ("general-6r", "double-butterfly"):
        mechanism.solve(name).to_dict()
    dh = json.loads((_PACKAGE / "robots" / "general-6r.json").read_text())["dh"]
    IK(load({"kind": "dh-arm", "dh": dh}), "tool").solve(pin.SE3.Identity()).to_dict()


def build(folder: Path | None = None, log=print) -> Path | None:
    """Build the module (module docstring); its path, or None when numba's compiler failed."""
    jit._Aot.table = {}  # this process runs every kernel on numba
    jit.record = True
    t0 = time.process_time()
    exercise()
    from numba.pycc import CC

    kernels = [k for k in jit.REGISTRY if k.calls[1] and k._dispatcher is not None and k.name not in NOT_AHEAD]
    files = source_files({k.__module__ for k in jit.REGISTRY})
    digest = jit.source_digest(files)
    folder = folder or jit.aot_folder()
    folder.mkdir(parents=True, exist_ok=True)
    exports: list[dict] = []
    with tempfile.TemporaryDirectory(dir=folder, prefix=".aot-") as tmp:
        cc = CC(jit.AOT_NAME)
        cc.output_dir = tmp
        cc.target_cpu = "host"  # built where it runs, as numba's cache is
        cc.verbose = False
        for k in kernels:
            for sig, cres in k._dispatcher.overloads.items():
                codes = [_code(t) for t in sig]
                if any(c is None for c in codes) or not _called(k, tuple(map(jit._key, codes))):
                    continue  # a type the module does not take; a signature compiled but not called
                symbol = f"k{len(exports):04d}_{digest[:16]}"  # compiled in this order (by name): the registry's
                cc.export(symbol, cres.signature)(k.py_func)
                exports.append({"kernel": k.name, "symbol": symbol, "args": codes})
        try:
            # numba's typing of a kernel has failed here when a closed-form batch kernel (inline
            # overloads) was compiled before it in the same module: the registry's order (the
            # search's kernels first) is the one that compiles
            cc.compile()
        except Exception as e:  # noqa: BLE001 - no C compiler, a numba without pycc: numba's JIT stays
            log(f"kinbox: the ahead-of-time kernels were not built ({type(e).__name__}: {e}); numba compiles them instead")
            return None
        suffix = importlib.machinery.EXTENSION_SUFFIXES[0]
        built = next(Path(tmp).glob(jit.AOT_NAME + "*"))
        so = folder / (jit.AOT_NAME + suffix)
        os.replace(built, so)
        from numba import __version__ as numba_version

        compiled = sorted(k.name for k in jit.REGISTRY if _compiled(k))
        meta = {"python": sys.version, "suffix": suffix, "numba": numba_version, "files": files, "digest": digest}
        meta |= {"exports": exports, "kernels": compiled}
        tmp_meta = Path(tmp) / "meta.json"
        tmp_meta.write_text(json.dumps(meta, indent=1) + "\n")
        os.replace(tmp_meta, folder / (jit.AOT_NAME + ".json"))
    cpu = time.process_time() - t0
    log(f"kinbox: {len(exports)} signatures of {len(kernels)} kernels compiled ahead of time ({cpu:.0f} s CPU): {so}")
    return so


if __name__ == "__main__":
    build()  # a module not built leaves the kernels to numba: setup goes on
