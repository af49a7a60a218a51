"""Outward rounding under the x86 flush-to-zero (FTZ) and denormals-are-zero (DAZ) modes, which a
library built with -ffast-math can switch on for the whole process: the one-ulp steps must stay
outward, and the search must refuse to run rather than trust bounds it cannot keep."""

import contextlib
import ctypes
import platform

import numpy as np
import pytest

from kinbox.errors import FloatingPointModeError
from kinbox.formulation.system import System
from kinbox.interval import flushing_subnormals
from kinbox.pipeline import solve_system
from kinbox.search.propagate import next_up_down

pytestmark = pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"), reason="MXCSR is x86's")

FTZ, DAZ = 0x8000, 0x0040

# MXCSR read and written by two LLVM intrinsics, JIT-compiled with llvmlite (numba's own backend):
# no C compiler needed
IR = r"""
declare void @llvm.x86.sse.ldmxcsr(i8*)
declare void @llvm.x86.sse.stmxcsr(i8*)
define void @set_mxcsr(i32 %v) {
  %p = alloca i32
  store i32 %v, i32* %p
  %q = bitcast i32* %p to i8*
  call void @llvm.x86.sse.ldmxcsr(i8* %q)
  ret void
}
define i32 @get_mxcsr() {
  %p = alloca i32
  %q = bitcast i32* %p to i8*
  call void @llvm.x86.sse.stmxcsr(i8* %q)
  %v = load i32, i32* %p
  ret i32 %v
}
"""


@pytest.fixture(scope="module")
def mxcsr():
    llvm = pytest.importorskip("llvmlite.binding")
    llvm.initialize_native_target()
    llvm.initialize_native_asmprinter()
    mod = llvm.parse_assembly(IR)
    mod.verify()
    engine = llvm.create_mcjit_compiler(mod, llvm.Target.from_default_triple().create_target_machine())
    engine.finalize_object()
    get = ctypes.CFUNCTYPE(ctypes.c_uint32)(engine.get_function_address("get_mxcsr"))
    put = ctypes.CFUNCTYPE(None, ctypes.c_uint32)(engine.get_function_address("set_mxcsr"))

    @contextlib.contextmanager
    def mode(bits: int):
        old = get()
        put(old | bits)
        try:
            yield
        finally:
            put(old)

    yield mode, engine  # the engine owns the code: keep it alive


def expected_up(x: np.ndarray) -> np.ndarray:
    """The next float up, by integer arithmetic on the bits only (no float operation)."""
    i = x.view(np.int64).copy()
    zero = (i & 0x7FFFFFFFFFFFFFFF) == 0
    i = np.where(i > 0, i + 1, i - 1)
    i[zero] = 1
    return i.view(float)


BOTH = "denormals-are-zero and flush-to-zero"


@pytest.mark.parametrize("bits, named", [(DAZ, "denormals-are-zero"), (FTZ, "flush-to-zero"), (DAZ | FTZ, BOTH)])
def test_each_mode_is_seen(mxcsr, bits, named):
    mode, _ = mxcsr
    assert flushing_subnormals() is None
    with mode(bits):
        assert flushing_subnormals() == named
    assert flushing_subnormals() is None


def test_one_ulp_steps_stay_outward_on_subnormals_when_denormals_are_zero(mxcsr):
    mode, _ = mxcsr
    rng = np.random.default_rng(3)
    sub = rng.integers(1, 2**52, 10_000, dtype=np.int64).view(float)  # positive subnormals
    x = np.concatenate([sub, -sub, [0.0, -0.0, 5e-324, -5e-324, np.finfo(float).tiny, 1.0, -1.0]])
    for bits in (DAZ, FTZ, DAZ | FTZ):
        with mode(bits):
            up, dn = next_up_down(x)
        assert np.array_equal(up.view(np.int64), expected_up(x).view(np.int64))
        assert np.array_equal(dn.view(np.int64), (-expected_up(-x)).view(np.int64))


def test_the_search_refuses_to_run_with_subnormals_flushed(mxcsr):
    mode, _ = mxcsr
    s = System()
    x, y = s.add_var("x", -3, 3), s.add_var("y", -3, 3)
    s.add_eq(x * x + y * y - 1)
    s.add_eq(x - y)
    for bits in (DAZ, FTZ):
        with mode(bits), pytest.raises(FloatingPointModeError, match="flush-to-zero|denormals-are-zero"):
            solve_system(s, sigma=1e-6)
    assert len(solve_system(s, sigma=1e-6).certified) == 2
