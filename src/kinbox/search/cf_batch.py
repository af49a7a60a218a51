"""The closed form over a batch of goals, each root certified one way or the other.

:func:`run_batch` solves many goals of one arm at once through the compiled closed form
(:mod:`kinbox.search.closed_form`) and proves each root by Krawczyk, either on the kinbox system
(:class:`~kinbox.search.closed_form.TemplateCertifier`, inside the closed form's kernel) or in
the six joint angles on the pose as given (:mod:`kinbox.search.cf_certify`, whose kernel runs
the closed form's roots and certifies them). :func:`closed_form` makes an arm's
:class:`~kinbox.search.closed_form.ClosedForm` with both certifiers. The module sits above the
two it joins, so neither imports the other back (``tests/support/test_source_shape.py``).
"""

from __future__ import annotations

import numpy as np

from .cf_certify import JointCertifier, solve_batch_joint
from .closed_form import MAX_ROOTS, Batch, ClosedForm, TemplateCertifier, _no_certifier, call_batch_kernel, solve_batch_kernel


def closed_form(family, arm=None) -> ClosedForm:
    """The closed form of ``arm``'s family (:func:`kinbox.formulation.families.detect`), with
    Krawczyk in the joint angles (:class:`~kinbox.search.cf_certify.JointCertifier`) where every
    joint of the arm's chain is revolute."""
    cf = ClosedForm(family, arm)
    if arm is not None and all(j.kind == "revolute" for j in arm.geometry.chain.joints):
        cf.joint_certifier = JointCertifier(arm.geometry, cf.joints, cf.gamma, arm.constants)
    return cf


def run_batch(
    cf: ClosedForm, tc: TemplateCertifier | None, R: np.ndarray, t: np.ndarray, V: np.ndarray | None = None, certificate: str = "system"
) -> Batch:
    """:func:`~kinbox.search.closed_form.solve_batch_kernel` over goals ``(R, t)`` ((N, 3, 3),
    (N, 3)). ``certificate``: ``"system"`` (Krawczyk on the kinbox system, with ``tc``; none if
    ``tc`` is None),
    ``"joint"`` (Krawczyk in the joint angles, :mod:`kinbox.search.cf_certify`, on the poses
    as given: ``V`` (N, 7) XYZQUAT, from ``R``, ``t`` through Pinocchio if not given) or
    ``"none"``."""

    R = np.ascontiguousarray(R, dtype=float).reshape(-1, 3, 3)
    t = np.ascontiguousarray(t, dtype=float).reshape(-1, 3)
    N = R.shape[0]
    Rlo, Rhi, tlo, thi = (np.ascontiguousarray(a) for a in cf.goal_arrays(R, t))
    if certificate == "joint" and cf.joint_certifier is not None:
        return _run_joint(cf, R, t, V, Rlo, Rhi, tlo, thi)
    certify = certificate == "system" and tc is not None and tc.ok
    if certify:
        assert tc is not None
        P, PM = (np.ascontiguousarray(a) for a in tc.params(R, t))
        MERR, MGRAD = (np.ascontiguousarray(a) for a in tc.model_errors(R, t, P, PM))
        args = tc.kernel_args()
        n = tc.n
    else:
        P = PM = np.zeros((N, 1))
        MERR = MGRAD = np.zeros((N, 0))
        args = _no_certifier()
        n = 0
    return call_batch_kernel(cf, cf.limits, (Rlo, Rhi, tlo, thi), P, PM, MERR, MGRAD, args, n, certify)


def _run_joint(cf: ClosedForm, R, t, V, Rlo, Rhi, tlo, thi) -> Batch:
    """:func:`run_batch` with Krawczyk in the joint angles."""
    import pinocchio as pin

    N = R.shape[0]
    if V is None:
        V = np.array([pin.SE3ToXYZQUAT(pin.SE3(R[k], t[k])) for k in range(N)]).reshape(N, 7)
    V = np.ascontiguousarray(V, dtype=float)
    jc = cf.joint_certifier
    assert isinstance(jc, JointCertifier)  # run_batch takes this path only with a joint certifier
    # the kernel writes every pose's status, first and count, and the rows it returns
    status = np.empty(N, dtype=np.int64)
    first = np.empty(N, dtype=np.int64)
    count = np.empty(N, dtype=np.int64)
    M = MAX_ROOTS * N
    theta = np.empty((M, 6))
    jlo = np.empty((M, 6))
    jhi = np.empty((M, 6))
    m = solve_batch_joint(
        cf.family_tag, cf.LR, cf.Lt, cf.d, cf.limits, Rlo, Rhi, tlo, thi, V, *jc.kernel_args(), status, first, count, theta, jlo, jhi
    )
    e = np.zeros((0, 0))
    return Batch(status, first, count, theta[:m], e, e, e, np.zeros(0), True, "joint", jlo[:m], jhi[:m])


def load_family_kernels() -> None:
    """Load (the first time after an install: compile and cache) the batch kernels for every
    family with the argument types they were already loaded with for one arm's family: each
    kernel is compiled per family (:func:`~kinbox.search.closed_form.family_tag`), so that after ``make setup`` an arm of
    another family compiles nothing either."""
    from numba import types

    for kernel in (solve_batch_kernel, solve_batch_joint):
        for sig in list(kernel.signatures):
            for code in (1, 2, 3):
                kernel.compile((types.UniTuple(types.int64, code), *sig[1:]))
