"""One pose through the compiled closed form with what every call shares built once.

:meth:`kinbox.problems.ik.IK.solve_array` of a single pose spends most of its time, outside
the kernel, on what does not change from pose to pose: the kernels' dispatch on the types of
their twenty-odd arguments (:class:`kinbox.search.jit.Kernel` keys every argument; numba's
dispatcher types every argument), the small arrays of inputs and outputs allocated anew, and
the checks and gathers of a batch of any size. :class:`OnePose` makes them once per arm and
certificate: the goal's buffers (XYZQUAT, rotation, the canonical goal frame and its
enclosure), the kernels' outputs, and each kernel bound to its compiled function for those
argument types (:func:`bind`). A call copies the pose in, runs the same kernels on the same
numbers as the batch path (:func:`kinbox.answer.closed_form.solve_array` through
:func:`kinbox.search.cf_batch.run_batch`), and copies the roots out into a fresh
:class:`~kinbox.answer.closed_form.BatchAnswer`: the same roots, bit for bit, and the same
certificates (``tests/answer/test_cf_pose.py::test_one_pose_path_is_the_batch_path``).

A pose it does not take -- not seven finite numbers with a unit quaternion, a pose the closed
form leaves to the branch and prune, a call while another thread holds the buffers -- gives
None, and the caller takes the batch path, which answers or refuses it as before.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from typing import Any

import numpy as np

from ..search import jit
from ..search.cf_certify import JointCertifier, solve_batch_joint
from ..search.closed_form import (
    MAX_ROOTS,
    POSE_CLOSED_FORM,
    Batch,
    ClosedForm,
    _frames,
    _no_certifier,
    goal_widening,
    solve_batch_kernel,
)
from .closed_form import BatchAnswer, _quaternions, _wrap

#: the certificates a :class:`OnePose` takes (``solve_array``'s ``certify`` as the batch names it)
MODES = ("joint", "none")


def bind(kernel: Any, args: tuple) -> Callable:
    """The compiled function that ``kernel(*args)`` runs for these arguments' types, to be
    called again with arguments of the same types only (the kernel called once before, so that
    it is loaded): the ahead-of-time module's function where it has one, else numba's compiled
    entry point for those types (numba's dispatcher if it has none)."""
    f = kernel.aot().get(tuple(map(jit.arg_code, args)))
    if f is not None:
        return f
    d = kernel.dispatcher
    try:
        cres = d.overloads.get(tuple(d.typeof_pyval(a) for a in args))
    except Exception:  # noqa: BLE001 - numba's internals: its dispatcher then
        cres = None
    return cres.entry_point if cres is not None else d


class OnePose:
    """The closed form of one pose of ``cf``'s arm with the certificate ``mode`` (:data:`MODES`):
    :meth:`solve` (module docstring). Its buffers are reused from call to call: one call at a
    time (a second thread meanwhile gets None)."""

    def __init__(self, cf: ClosedForm, mode: str):
        if mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, not {mode!r}")
        if mode == "joint" and not isinstance(cf.joint_certifier, JointCertifier):
            raise ValueError("no joint certifier")
        self.cf = cf
        self.mode = mode
        self._lock = threading.Lock()
        self.V = np.zeros((1, 7))
        self.R = np.zeros((1, 3, 3))
        self.t = np.zeros((1, 3))
        # the canonical goal frame G (rotation and translation, 12 numbers in a row) and its
        # enclosure G + E, both bounds at once: E's rows are -err and +err (goal_widening: the
        # rotation's once, the translation's per pose), and x + (-e) is x - e exactly, as
        # _goal_arrays computes it
        self.G = np.zeros(12)
        self.GR, self.Gt = self.G[:9].reshape(1, 3, 3), self.G[9:].reshape(1, 3)
        self.tn = np.zeros(1)
        self.E = np.zeros((2, 12))
        er = goal_widening(cf.delta)
        self.E[0, :9], self.E[1, :9] = -er, er
        self.lohi = np.zeros((2, 12))
        self.Rlo, self.Rhi = self.lohi[0, :9].reshape(1, 3, 3), self.lohi[1, :9].reshape(1, 3, 3)
        self.tlo, self.thi = self.lohi[0, 9:].reshape(1, 3), self.lohi[1, 9:].reshape(1, 3)
        self._ones = np.ones(MAX_ROOTS, dtype=bool)
        self._zeros = np.zeros(MAX_ROOTS, dtype=bool)
        self.status = np.zeros(1, dtype=np.int64)
        self.first = np.zeros(1, dtype=np.int64)
        self.count = np.zeros(1, dtype=np.int64)
        self.theta = np.zeros((MAX_ROOTS, 6))
        AR, At, BR, Bt = cf._frame_arrays
        self._frames_args = (self.R, self.t, AR, At, BR, Bt, cf.reversed, self.GR, self.Gt, self.tn)
        if mode == "joint":
            jc = cf.joint_certifier
            assert isinstance(jc, JointCertifier)
            self.jlo, self.jhi = np.zeros((MAX_ROOTS, 6)), np.zeros((MAX_ROOTS, 6))
            self._kernel = solve_batch_joint
            self._args = (
                cf.family_tag, cf.LR, cf.Lt, cf.d, cf.limits, self.Rlo, self.Rhi, self.tlo, self.thi, self.V, *jc.kernel_args(),
                self.status, self.first, self.count, self.theta, self.jlo, self.jhi,
            )  # fmt: skip
        else:  # the batch's arguments for no certificate (kinbox.search.cf_batch.run_batch)
            from .. import interval as ivl

            z1, z0 = np.zeros((1, 1)), np.zeros((1, 0))
            out0 = (np.zeros((0, 0)), np.zeros((0, 0)), np.zeros((0, 0)), np.zeros(0))
            self._kernel = solve_batch_kernel
            self._args = (
                cf.family_tag, cf.LR, cf.Lt, cf.d, cf.gamma, cf.limits, self.Rlo, self.Rhi, self.tlo, self.thi, z1, z1, z0, z0,
                *_no_certifier(), np.zeros(0), ivl.TINY, ivl.U, False, self.status, self.first, self.count, self.theta, *out0,
            )  # fmt: skip
        self._wrap_consts = (cf.gamma, cf.lo, cf.hi, cf.unbounded, cf.model_order)
        #: the kernels bound to their compiled functions at the first call (:func:`bind`)
        self._bound: tuple[Callable, Callable, Callable] | None = None
        self._wrap_fn: Callable = _wrap

    @property
    def bound(self) -> bool:
        """Have the kernels been bound (the first call made)?"""
        return self._bound is not None

    def __reduce__(self) -> tuple:  # buffers and lock made anew where it is unpickled
        return (OnePose, (self.cf, self.mode))

    def solve(self, pose: Any) -> BatchAnswer | None:
        """The answer of one pose (an array of shape (1, 7) or (7,), ``x y z qx qy qz qw``) as
        :func:`kinbox.answer.closed_form.solve_array` gives it, or None (module docstring)."""
        if not self._lock.acquire(blocking=False):
            return None
        try:
            m = self._run(pose)
            if m < 0:
                return None
            q = np.empty((m, 6))
            self._wrap_fn(self.theta[:m], *self._wrap_consts, q)
            zero = np.zeros(1, dtype=np.int64)
            return BatchAnswer(
                list(self.cf.model_names), zero, self.count.copy(), q, self._ones[:m].copy(), self._zeros[:m].copy(), ["closed-form"],
                self._ones[:1].copy(), zero.copy(),
            )  # fmt: skip
        finally:
            self._lock.release()

    def batch(self, pose: Any, rotation: np.ndarray | None = None) -> Batch | None:
        """The kernel's record of one pose as :func:`kinbox.search.cf_batch.run_batch` gives it
        (certificate ``"joint"``: the roots' angles and proof boxes), or None (module docstring).
        ``rotation``: the goal's rotation matrix, as ``run_batch`` is given it (default: from the
        quaternion, as :func:`kinbox.answer.closed_form.poses_array` makes it)."""
        if self.mode != "joint" or not self._lock.acquire(blocking=False):
            return None
        try:
            m = self._run(pose, rotation)
            if m < 0:
                return None
            e = np.zeros((0, 0))
            return Batch(
                self.status.copy(), self.first.copy(), self.count.copy(), self.theta[:m].copy(), e, e, e, np.zeros(0), True, "joint",
                self.jlo[:m].copy(), self.jhi[:m].copy(),
            )  # fmt: skip
        finally:
            self._lock.release()

    def _run(self, pose: Any, rotation: np.ndarray | None = None) -> int:
        """The kernel on one pose (its rotation matrix from its quaternion unless given), its
        roots in the buffers: their number, or -1 (not taken)."""
        V = self.V
        try:
            V[0] = pose  # (7,) or (1, 7): numbers, copied; any other shape raises
            if rotation is not None:
                self.R[0] = rotation
        except (TypeError, ValueError):
            return -1
        if not math.isfinite(V[0, 0] + V[0, 1] + V[0, 2]):  # a NaN or an infinity makes the sum one
            return -1
        if self._bound is None:  # the first call: each kernel through its Kernel (loaded, or compiled, as any call), then bound
            R = self.R if rotation is None else np.empty((1, 3, 3))  # a given rotation kept: the quaternions' kernel loaded aside
            if _quaternions(V, R) >= 0 and rotation is None:
                return -1
            m = self._after_rotation(_frames, self._kernel)
            wrap_args = (self.theta[:1], *self._wrap_consts, np.empty((1, 6)))
            _wrap(*wrap_args)
            self._bound = (bind(_quaternions, (V, R)), bind(_frames, self._frames_args), bind(self._kernel, self._args))
            self._wrap_fn = bind(_wrap, wrap_args)
            return m
        quaternions, frames, kernel = self._bound
        if rotation is None and quaternions(V, self.R) >= 0:  # not a unit quaternion: the batch path says so
            return -1
        return self._after_rotation(frames, kernel)

    def _after_rotation(self, frames: Callable, kernel: Callable) -> int:
        """From the rotation in :attr:`R` on: the goal enclosure, the kernel; the number of
        roots, or -1 (the pose goes to the branch and prune)."""
        self.t[0] = self.V[0, :3]
        frames(*self._frames_args)
        # the goal enclosure as kinbox.search.closed_form._goal_arrays computes it, operation by operation
        et = goal_widening(self.cf.delta, self.cf.tmag0, self.tn[0])
        E = self.E
        E[0, 9:] = -et
        E[1, 9:] = et
        np.add(self.G, E, out=self.lohi)
        m = kernel(*self._args)
        return m if self.status[0] == POSE_CLOSED_FORM else -1
