"""Compiled kernels that load numba only when they need it.

``@njit(cache=True)`` here stands for numba's ``@numba.njit(cache=True)``: it returns a
:class:`Kernel`, whose calls go to one of two compiled forms of the same Python source:

* the **ahead-of-time** module (``make setup`` builds it with numba's own ahead-of-time
  compiler, :mod:`kinbox.problems.aot`): an extension module holding the kernels with the
  argument types they were called with, which loads like any extension, without numba or
  LLVM. A kernel takes it when the module is current (built by this numba and Python from the
  kinbox sources it was compiled from, every file's digest checked at its first use) and the
  call's argument types are one of its compiled signatures;
* **numba** otherwise (no module, a source edited since, other argument types,
  ``NUMBA_DISABLE_JIT``): numba is imported at that call, and the kernel is a numba
  dispatcher from then on for those types, cached on disk as numba caches it.

Both compile the same source with the same LLVM and options (no fast-math: no contraction of
``a * b + c`` into a fused multiply-add, no reordering; ``math.sin``/``cos`` are the C
library's in both), so a call's answer does not depend on which one ran, bit for bit
(tests/search/test_jit.py::test_aot_and_numba_agree). numba's cache checks a kernel against
its own file only, though its machine code holds the kernels it calls; a kernel's cache entry
here is current only while every kinbox file it can be made of is unchanged
(:func:`_stamp_cache`), so neither form runs a callee's old code after an edit.
A kernel called from another kernel's compiled code is typed by numba as its dispatcher
(``_numba_type_``), so numba's kernels call each other as they did.

A process whose kernels all come from the ahead-of-time module never imports numba: some
0.7 s of CPU and 100 MB less for a small problem (numba's import, its set-up of LLVM's code
generation and the loading of cached kernels; docs/cuiksuite.md).
"""

from __future__ import annotations

import ast
import functools
import hashlib
import importlib
import importlib.machinery
import importlib.util
import json
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

#: every kernel made by :func:`njit`, in the order their modules defined them
REGISTRY: list[Kernel] = []
#: the ahead-of-time module's name (a file ``NAME.<python extension suffix>`` and ``NAME.json``)
AOT_NAME = "kinbox_kernels"
_PACKAGE = Path(__file__).resolve().parents[1]
#: seconds spent loading compiled code (the ahead-of-time module, numba's import and set-up
#: before a first numba kernel), reported with the kernels' loading
#: (:func:`kinbox.search.loading.load_clock`)
loading_seconds = [0.0]

_SCALARS: dict[type, str] = {float: "d", np.float64: "d", int: "q", np.int64: "q", bool: "?", np.bool_: "?"}


def arg_code(a: Any) -> Any:
    """The key of one argument's numba type among the ones the ahead-of-time module compiles:
    a C-contiguous writable array by its dtype and dimension, a float, an int or a bool, a
    tuple of those; None for any other (numba then types it)."""
    t = type(a)
    if t is np.ndarray:
        f = a.flags
        return (a.dtype.char, a.ndim) if f.c_contiguous and f.writeable else None
    if t is tuple:
        codes = tuple(map(arg_code, a))
        return ("T", *codes) if None not in codes else None
    return _SCALARS.get(t)


def aot_folder() -> Path:
    """Where the ahead-of-time module is built and looked for: numba's cache folder when
    :mod:`kinbox.jitcache` chose one, else ``kinbox/search/__pycache__`` (where numba caches
    kinbox's kernels)."""
    d = os.environ.get("NUMBA_CACHE_DIR")
    return Path(d) if d else Path(__file__).resolve().parent / "__pycache__"


def source_digest(files: list[str]) -> str:
    """sha256 over the kinbox source ``files`` (paths relative to the package), numba's
    version as recorded at the build aside."""
    h = hashlib.sha256()
    for rel in files:
        h.update(rel.encode() + b"\0")
        h.update((_PACKAGE / rel).read_bytes())
    return h.hexdigest()


@functools.cache
def _kinbox_imports(rel: str) -> frozenset[str]:
    """kinbox source files (relative to the package) that the module at ``rel`` imports from."""
    tree = ast.parse((_PACKAGE / rel).read_text())
    pkg = Path(rel).parent
    out = set()
    for node in tree.body:  # a kernel sees its module's globals: the imports at its top level
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg
                for _ in range(node.level - 1):
                    base = base.parent
            elif node.module and node.module.split(".")[0] == "kinbox":
                base, node = Path(), ast.ImportFrom(module=node.module.partition(".")[2], names=node.names, level=1)
            else:
                continue
            target = base.joinpath(*node.module.split(".")) if node.module else base
            cands = [target / f"{a.name}.py" for a in node.names]  # modules imported by name
            if node.module:  # the module (or package) whose names are imported
                cands += [target.with_suffix(".py"), target / "__init__.py"]
            for cand in cands:
                if (_PACKAGE / cand).is_file():
                    out.add(cand.as_posix())
    return frozenset(out)


def source_files(modules: set[str]) -> list[str]:
    """The files of ``modules`` (kinbox module names) and every kinbox file they import, at
    any depth: what a compiled kernel can be made of."""
    todo = [Path(*m.split(".")[1:]).with_suffix(".py").as_posix() for m in modules]
    seen: set[str] = set()
    while todo:
        rel = todo.pop()
        if rel in seen:
            continue
        seen.add(rel)
        todo.extend(_kinbox_imports(rel) - seen)
    return sorted(seen)


_module_digests: dict[str, str] = {}


def _stamp_cache(d: Any, module: str) -> None:
    """Make the on-disk cache of numba dispatcher ``d`` (a kernel of ``module``) current only
    while every kinbox file its code can be made of is unchanged (:func:`source_files`).

    numba checks a cached kernel against its own file only (modification time and size), yet
    the cached machine code holds the code of every kernel it calls: after an edit of a callee
    in another file (``cf_certify.krawczyk6`` under ``eigen6r_kernel.proof_kernel``) numba
    would run the old callee. The digest of the files joins numba's stamp, so such an edit
    recompiles the kernel (tests/search/test_jit.py::test_an_edited_callee_is_not_taken_from_the_cache)."""
    cache_file = getattr(getattr(d, "_cache", None), "_cache_file", None)
    if cache_file is None or not module.startswith("kinbox."):  # no cache (NullCache); a kernel outside kinbox
        return
    if module not in _module_digests:
        try:
            # this file aside: it holds no kernel code (an edit of it recompiles nothing)
            _module_digests[module] = source_digest([f for f in source_files({module}) if f != "search/jit.py"])
        except (OSError, SyntaxError, ValueError):  # not a kinbox source file: numba's stamp alone
            return
    cache_file._source_stamp = (cache_file._source_stamp, _module_digests[module])


class _Aot:
    """The ahead-of-time module, loaded at the first kernel call that could use it."""

    table: dict[str, dict[tuple, Callable]] | None = None
    #: the kernels compiled at the module's build, on numba (all of them) or ahead of time
    built: frozenset[str] = frozenset()

    @classmethod
    def lookup(cls, name: str) -> dict[tuple, Callable]:
        if cls.table is None:
            t0 = time.perf_counter()
            cls.table, cls.built = _load_aot()
            loading_seconds[0] += time.perf_counter() - t0
        return cls.table.get(name, {})


def built_with_module(name: str) -> bool:
    """Was kernel ``name`` compiled (on numba, cached, or ahead of time) by the build of the
    current ahead-of-time module? (False without one.)"""
    _Aot.lookup(name)
    return name in _Aot.built


def _load_aot() -> tuple[dict[str, dict[tuple, Callable]], frozenset[str]]:
    """``{kernel: {argument codes: compiled function}}`` from a current ahead-of-time module and
    the kernels its build compiled, or ({}, {}) (none, stale, another Python, jit disabled,
    ``KINBOX_NO_AOT`` set)."""
    none: tuple[dict, frozenset] = ({}, frozenset())
    if os.environ.get("NUMBA_DISABLE_JIT", "0") not in ("", "0") or os.environ.get("KINBOX_NO_AOT"):
        return none
    folder = aot_folder()
    suffix = importlib.machinery.EXTENSION_SUFFIXES[0]
    so, meta_file = folder / (AOT_NAME + suffix), folder / (AOT_NAME + ".json")
    try:
        meta = json.loads(meta_file.read_text())
        if meta.get("python") != sys.version or meta.get("suffix") != suffix:
            return none
        if meta["digest"] != source_digest(meta["files"]):
            return none
        spec = importlib.util.spec_from_file_location(AOT_NAME, so)
        if spec is None or spec.loader is None:
            return none
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        out: dict[str, dict[tuple, Callable]] = {}
        for entry in meta["exports"]:  # each symbol ends with the digest: a module and a record of one build
            out.setdefault(entry["kernel"], {})[tuple(_key(c) for c in entry["args"])] = getattr(mod, entry["symbol"])
        built = frozenset(meta["kernels"])
    except (OSError, ValueError, KeyError, ImportError, AttributeError):
        return none
    return out, built


def _key(code: Any) -> Any:
    """An argument code as recorded in JSON (lists) -> as :func:`arg_code` makes it (tuples)."""
    return tuple(map(_key, code)) if isinstance(code, list) else code


#: the kernels note the argument types of the calls numba answers (:mod:`kinbox.problems.aot`)
record = False
#: called once numba is imported (a :func:`kinbox.search.loading.load_clock` starts listening)
after_import: list[Callable[[], None]] = []


#: overloads (:func:`overload`) not yet registered with numba
_overloads: list[tuple[Callable, dict[str, Any], Callable]] = []


def _numba() -> Any:
    """numba, imported (the import timed with the kernels' loading), with every overload
    declared by :func:`overload` registered."""
    if "numba" not in sys.modules:
        t0 = time.perf_counter()
        import numba  # noqa: F401

        loading_seconds[0] += time.perf_counter() - t0
    while after_import:
        after_import.pop()()
    if _overloads:
        from numba.extending import overload as numba_overload

        while _overloads:
            func, options, impl = _overloads.pop(0)
            numba_overload(func, **options)(impl)
    return sys.modules["numba"]


def overload(func: Callable, **options: Any) -> Callable[[Callable], Callable]:
    """``numba.extending.overload(func, **options)``, registered with numba when numba is
    imported (:func:`_numba`, before any kernel is typed): a module that declares one does not
    import numba. The overload's body imports what it needs of numba itself."""

    def declare(impl: Callable) -> Callable:
        _overloads.append((func, options, impl))
        if "numba" in sys.modules:
            _numba()  # numba already loaded: registered now
        return impl

    return declare


class Kernel:
    """A compiled kernel: its ahead-of-time form when current and the argument types match,
    else numba's dispatcher of the same function (module docstring)."""

    def __init__(self, py_func: Callable, options: dict[str, Any]) -> None:
        self.py_func = py_func
        self.options = options
        self.__name__ = py_func.__name__
        self.__qualname__ = py_func.__qualname__
        self.__module__ = py_func.__module__
        self.__doc__ = py_func.__doc__
        self.__wrapped__ = py_func
        self.name = f"{py_func.__module__}.{py_func.__qualname__}"
        #: the arguments a call may leave out: the ahead-of-time form is called with their defaults
        self._nargs = py_func.__code__.co_argcount
        self._defaults = py_func.__defaults__ or ()
        self._aot: dict[tuple, Callable] | None = None
        self._dispatcher: Any = None
        #: calls answered by the ahead-of-time module and by numba in this process
        self.calls = [0, 0]
        #: the argument codes of the calls numba answered, while :data:`record` is set (the build)
        self.seen: set[tuple] = set()
        REGISTRY.append(self)

    @property
    def targetoptions(self) -> dict[str, Any]:
        """The options numba compiles this kernel with. numba inlines a call to any global
        whose ``targetoptions`` say ``inline`` (its pass InlineInlinables, which then compiles
        the global's ``py_func`` into the caller), so a kernel inlined into its callers needs no
        numba dispatcher until it is called from Python; the overloads (:func:`overload`) its
        code may call are registered first, whichever kernel (kinbox's, or a plain numba one)
        inlines it (tests/search/test_jit.py::test_a_plain_numba_kernel_inlines_a_closed_form_step)."""
        if self.options.get("inline", "never") == "never":
            return self.dispatcher.targetoptions
        pending = bool(_overloads)
        _numba()
        if pending:  # registered while numba compiles the caller: its typing context sees them after a refresh
            from numba.core.registry import cpu_target

            cpu_target.typing_context.refresh()
        return self.options

    @property
    def dispatcher(self) -> Any:
        """numba's dispatcher of this kernel (importing numba)."""
        if self._dispatcher is None:
            d = _numba().njit(**self.options)(self.py_func)
            _stamp_cache(d, self.__module__)
            self._dispatcher = d
        return self._dispatcher

    @property
    def _numba_type_(self) -> Any:  # how numba types this kernel in another kernel's code
        return _numba().core.types.Dispatcher(self.dispatcher)

    def aot(self) -> dict[tuple, Callable]:
        """The ahead-of-time forms of this kernel: ``{argument codes: function}`` ({} if none)."""
        if self._aot is None:
            self._aot = _Aot.lookup(self.name)
        return self._aot

    def __call__(self, *args: Any) -> Any:
        forms = self._aot if self._aot is not None else self.aot()
        if forms:
            full = args
            if len(args) < self._nargs and self._defaults:  # a default left out: given (same value)
                full = args + self._defaults[len(args) - self._nargs :]
            f = forms.get(tuple(map(arg_code, full)))
            if f is not None:
                self.calls[0] += 1
                return f(*full)
        self.calls[1] += 1
        if record:
            self.seen.add(tuple(map(arg_code, args)))
        return self.dispatcher(*args)

    def __getattr__(self, attr: str) -> Any:  # numba's own attributes (signatures, overloads, ...)
        if attr.startswith("__") or attr in ("_dispatcher", "_aot"):
            raise AttributeError(attr)
        return getattr(self.dispatcher, attr)

    def __reduce__(self) -> tuple:  # pickled by name, as a function is
        return (_by_name, (self.__module__, self.__qualname__))

    def __repr__(self) -> str:
        return f"<kinbox kernel {self.name}>"


def _by_name(module: str, qualname: str) -> Kernel:
    obj: Any = importlib.import_module(module)
    for part in qualname.split("."):
        obj = getattr(obj, part)
    return obj


def njit(*args: Any, **options: Any) -> Any:
    """``numba.njit`` as a :class:`Kernel` (module docstring): ``@njit(cache=True)`` or ``@njit``.
    A kernel to be inlined into its callers (``inline="always"``) is one too: numba inlines it
    into the kernels that call it, as its own dispatcher would be (the kernel's
    ``targetoptions``), and a call from Python goes to its ahead-of-time form or to numba."""
    if args and callable(args[0]) and not options:
        return Kernel(args[0], {})
    return lambda f: Kernel(f, options)


def loaded_kernels() -> list[tuple[str, str]]:
    """``(kernel, "aot" | "numba" | "aot+numba")`` for every kernel called in this process."""
    out = []
    for k in REGISTRY:
        if k.calls[0] or k.calls[1]:
            out.append((k.name, "+".join(n for n, c in zip(("aot", "numba"), k.calls, strict=True) if c)))
    return out
