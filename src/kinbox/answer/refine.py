"""Newton refinement of a configuration on Pinocchio's loop-closure residuals.

The solver polishes its points in the system's variables; decoding to ``q`` (atan2,
quaternions) and Pinocchio's forward kinematics add a few ulps. A couple of Gauss-Newton steps
on the closure errors themselves, with Pinocchio's Jacobians, bring them back to machine
precision. A step is kept only if it is tiny and lowers the residual, so refinement can never
move a configuration to another solution.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..model.mechanism import Closure, Mechanism
from ..search.lstsq import lstsq

#: closure errors at most this large are rounding noise of forward kinematics: nothing to refine
AT_PRECISION = 1e-15


def _closure_error(model, data, c: Closure, jac: dict | None):
    """Error vector of one closure, and its Jacobian (w.r.t. v) if ``jac`` is given (the
    joints' Jacobians computed so far, by joint id); FK (and the Jacobians) computed."""
    Ma = data.oMi[c.joint_a] * c.placement_a
    Mb = data.oMi[c.joint_b] * c.placement_b
    if jac is not None:
        Ja = _frame_jac(model, data, c.joint_a, c.placement_a, jac)
        Jb = _frame_jac(model, data, c.joint_b, c.placement_b, jac)
    if c.kind == "weld":
        M = Ma.inverse() * Mb
        e = pin.log6(M).vector
        if jac is None:
            return e, None
        delta = Jb - M.inverse().toActionMatrix() @ Ja
        return e, pin.Jlog6(M) @ delta
    d = Mb.translation - Ma.translation
    if c.kind == "point":
        return d, None if jac is None else Mb.rotation @ Jb[:3] - Ma.rotation @ Ja[:3]
    n = float(np.linalg.norm(d))
    if jac is None:
        return np.array([n - c.length]), None
    u = d / n if n > 0 else np.zeros(3)
    return np.array([n - c.length]), (u @ (Mb.rotation @ Jb[:3] - Ma.rotation @ Ja[:3]))[None, :]


def _frame_jac(model, data, jid: int, placement: pin.SE3, jac: dict) -> np.ndarray:
    if jid == 0:
        return np.zeros((6, model.nv))
    if jid not in jac:  # a platform's legs share its joint: one copy of its Jacobian
        jac[jid] = pin.getJointJacobian(model, data, jid, pin.ReferenceFrame.LOCAL)
    return placement.inverse().toActionMatrix() @ jac[jid]


def closure_errors(mech: Mechanism, data: pin.Data, q: np.ndarray, jacobian: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """The error vectors of all closures of ``mech`` at ``q``, stacked, and (``jacobian``) their
    Jacobian w.r.t. the velocity (``data``: the model's data, used as scratch)."""
    model = mech.model
    if jacobian:
        pin.computeJointJacobians(model, data, q)
    else:
        pin.forwardKinematics(model, data, q)
    jac: dict | None = {} if jacobian else None
    es, Js = [], []
    for c in mech.closures:
        e, J = _closure_error(model, data, c, jac)
        es.append(e)
        Js.append(J)
    return np.concatenate(es), (np.vstack(Js) if jacobian else None)


def refine(
    mech: Mechanism, q: np.ndarray, free_v: np.ndarray, iters: int = 6, max_step: float = 1e-6, data: pin.Data | None = None
) -> np.ndarray:
    """Gauss-Newton on all closures over the velocity indices ``free_v``; ``data``: the model's
    data to use as scratch (default: a new one). The Jacobian is computed only where a step is
    taken from: a point already at precision, or a step that does not lower the error (the
    curves of a Griffis-Duffy platform whose leg lengths, given to 12 decimals, hold it only
    nearly), costs forward kinematics alone."""
    model = mech.model
    data = data if data is not None else model.createData()

    if not mech.closures or len(free_v) == 0:
        return q
    e, _ = closure_errors(mech, data, q, jacobian=False)
    best_q, best = q, float(np.max(np.abs(e)))
    if best <= AT_PRECISION:
        return q  # a few ulps already (the solver's polished roots): a step would only add noise
    moved = 0.0
    for _ in range(iters):
        e, J = closure_errors(mech, data, best_q)
        assert J is not None
        dv = np.zeros(model.nv)
        dv[free_v] = -lstsq(np.ascontiguousarray(J[:, free_v]), np.ascontiguousarray(e, dtype=float))[0]
        moved += float(np.max(np.abs(dv)))
        if not moved <= max_step:  # too far, or not finite (a Jacobian that is not: NaN steps)
            break
        qn = pin.integrate(model, best_q, dv)
        e, _ = closure_errors(mech, data, qn, jacobian=False)
        r = float(np.max(np.abs(e)))
        if r >= best:
            break
        best_q, best = qn, r
    return best_q


def free_velocity_indices(model: pin.Model, joint_names) -> np.ndarray:
    idx: list[int] = []
    for name in joint_names:
        if model.existJointName(name):
            j = model.joints[model.getJointId(name)]
            idx.extend(range(j.idx_v, j.idx_v + j.nv))
    return np.array(sorted(idx), dtype=int)
