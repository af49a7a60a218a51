"""Shared helpers of tests/formulation/test_joints.py and tests/formulation/test_formulation.py (round trips)."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from kinbox.formulation.build import formulate
from kinbox.formulation.decode import check

TOL = 1e-12
INF = np.finfo(float).max


def random_rotation(rng) -> np.ndarray:
    return pin.exp3(rng.normal(size=3))


def random_placement(rng, scale: float = 0.5) -> pin.SE3:
    return pin.SE3(random_rotation(rng), rng.uniform(-scale, scale, 3))


def random_quaternion(rng) -> np.ndarray:
    v = rng.normal(size=4)
    return v / np.linalg.norm(v)


def add_joint(model, parent, jmodel, placement, name, lo=None, hi=None) -> int:
    """``model.addJoint`` with position limits (``None``: Pinocchio's +-DBL_MAX)."""
    nq = jmodel.nq
    lo = np.full(nq, -INF) if lo is None else np.atleast_1d(np.asarray(lo, float))
    hi = np.full(nq, INF) if hi is None else np.atleast_1d(np.asarray(hi, float))
    big = np.full(jmodel.nv, 1e3)
    return model.addJoint(parent, jmodel, placement, name, big, big, lo, hi)


def _random_part(jm, rng, lo, hi, q):
    short = jm.shortname().replace("JointModel", "")
    iq = jm.idx_q
    if short == "Composite":
        for sub in jm.extract().joints:
            _random_part(sub, rng, lo, hi, q)
        return

    def uni(k, default_lo, default_hi):
        a = lo[iq + k] if abs(lo[iq + k]) < 1e100 else default_lo
        b = hi[iq + k] if abs(hi[iq + k]) < 1e100 else default_hi
        return rng.uniform(a, b)

    if short in ("RX", "RY", "RZ", "RevoluteUnaligned", "PX", "PY", "PZ", "PrismaticUnaligned"):
        q[iq] = uni(0, -math.pi, math.pi)
    elif short.startswith("RUB") or short == "RevoluteUnboundedUnaligned":
        t = rng.uniform(-math.pi, math.pi)
        q[iq : iq + 2] = [math.cos(t), math.sin(t)]
    elif short == "Spherical":
        q[iq : iq + 4] = random_quaternion(rng)
    elif short == "SphericalZYX":
        q[iq : iq + 3] = [rng.uniform(-3, 3), rng.uniform(-1.5, 1.5), rng.uniform(-3, 3)]
    elif short == "FreeFlyer":
        q[iq : iq + 3] = [uni(k, -1, 1) for k in range(3)]
        q[iq + 3 : iq + 7] = random_quaternion(rng)
    elif short == "Planar":
        t = rng.uniform(-math.pi, math.pi)
        q[iq : iq + 4] = [uni(0, -1, 1), uni(1, -1, 1), math.cos(t), math.sin(t)]
    elif short == "Translation":
        q[iq : iq + 3] = [uni(k, -1, 1) for k in range(3)]
    else:  # pragma: no cover
        raise AssertionError(short)


def random_q(model, rng) -> np.ndarray:
    """A random configuration within the finite limits (angles in [-pi, pi] otherwise)."""
    q = pin.neutral(model)
    lo, hi = model.lowerPositionLimit, model.upperPositionLimit
    for jid in range(1, model.njoints):
        _random_part(model.joints[jid], rng, lo, hi, q)
    return q


def _wrap(a):
    return math.remainder(a, 2 * math.pi)


def _compare_part(jm, lo, hi, qe, qg, errs):
    short = jm.shortname().replace("JointModel", "")
    iq, nq = jm.idx_q, jm.nq
    if short == "Composite":
        for sub in jm.extract().joints:
            _compare_part(sub, lo, hi, qe, qg, errs)
        return
    a, b = qe[iq : iq + nq], qg[iq : iq + nq]
    if short in ("RX", "RY", "RZ", "RevoluteUnaligned"):
        limited = abs(lo[iq]) < 1e100 and abs(hi[iq]) < 1e100 and hi[iq] - lo[iq] < 2 * math.pi
        errs.append(abs(a[0] - b[0]) if limited else abs(_wrap(a[0] - b[0])))
        if not limited:
            errs.append(0.0 if -math.pi < b[0] <= math.pi else 1.0)  # decoded into (-pi, pi]
    elif short == "Spherical":
        errs.append(min(np.abs(a - b).max(), np.abs(a + b).max()))
    elif short == "FreeFlyer":
        errs.append(np.abs(a[:3] - b[:3]).max())
        errs.append(min(np.abs(a[3:] - b[3:]).max(), np.abs(a[3:] + b[3:]).max()))
    else:
        errs.append(np.abs(a - b).max())


def q_error(form, q_expected, q_got) -> float:
    """Largest difference between two configurations, joint by joint, as documented:
    unlimited angles modulo 2 pi, quaternions up to sign, locked joints against their locked
    values and dropped joints against ``pin.neutral``."""
    mech = form.mechanism
    model = mech.model
    neutral = pin.neutral(model)
    lo, hi = model.lowerPositionLimit, model.upperPositionLimit
    errs = [0.0]
    for jid in range(1, model.njoints):
        jm, name = model.joints[jid], model.names[jid]
        sl = slice(jm.idx_q, jm.idx_q + jm.nq)
        if name in mech.locked:
            v = np.atleast_1d(np.asarray(mech.locked[name], float))
            errs.append(np.abs(q_got[sl] - v).max())
        elif name in form.dropped_joints:
            errs.append(np.abs(q_got[sl] - neutral[sl]).max())
        else:
            _compare_part(jm, lo, hi, q_expected, q_got, errs)
    return float(max(errs))


def roundtrip(mech, q, tol: float = TOL, closed: bool = True):
    """Formulate ``mech``, encode ``q`` and decode it back; return the formulation.

    Checks that the system point satisfies every equation (core and redundant) and every
    inequality up to ``tol`` (when ``closed``: ``q`` satisfies the closures), that decoding
    gives ``q`` back (see :func:`q_error`) and that the decoded ``q`` encodes to the same
    point.
    """
    form = formulate(mech)
    sysm = form.system
    x = form.encode(q)
    assert x.shape == (sysm.n,)
    lo, hi = sysm.domain()
    assert np.all(x >= lo - tol) and np.all(x <= hi + tol), "encoded point outside the domain"
    if closed:
        res = np.abs(sysm.residuals(x))
        assert res.size == 0 or res.max() < tol, (res.max(), sysm.compile().row_names[int(res.argmax())])
        if sysm.count("ineq"):
            g = sysm.compile().eval_ineqs(x)
            assert g.max() <= tol, g.max()
    q2 = form.decode(x)
    assert q2.shape == (mech.model.nq,)
    assert q_error(form, q, q2) < tol, (q_error(form, q, q2), q, q2)
    x2 = form.encode(q2)
    assert np.abs(x2 - x).max() < 1e-10
    if closed:
        c = check(mech, q2)
        assert c["max_position"] < 1e-9 and c["max_orientation"] < 1e-9, c
    return form
