"""Small mechanisms with one joint of a given pair type, closed by distance legs: for the shadow
build of the general formulation (``tests/formulation/test_enclose_pairs.py``).

A joint of the pair (spherical, spherical ZYX, planar or a composite of a revolute about ``z``
and one about ``x``) hangs from the world at a placement turned by roll, pitch and yaw (so that
its binary64 matrix is rounded), carrying a body; legs (``distance`` closures) join points of the
body to points of the world, as many as the joint has degrees of freedom, their lengths read off
a random configuration: the assemblies are isolated.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from kinbox.model.mechanism import Closure, Mechanism

KINDS = ("spherical", "spherical_zyx", "planar", "composite")


def _se3(rpy, xyz) -> pin.SE3:
    return pin.SE3(pin.rpy.rpyToMatrix(np.asarray(rpy, dtype=float)), np.asarray(xyz, dtype=float))


def pair_mechanism(kind: str, seed: int = 0) -> Mechanism:
    """The mechanism of the module docstring for a pair ``kind`` (one of :data:`KINDS`)."""
    rng = np.random.default_rng(seed)
    model = pin.Model()
    model.name = f"pair-{kind}"
    top = _se3([0.3, -0.2, 0.5], [0.1, 0.2, 0.05])
    if kind == "spherical":
        jm, lo, hi = pin.JointModelSpherical(), -np.ones(4), np.ones(4)
    elif kind == "spherical_zyx":
        jm, lo, hi = pin.JointModelSphericalZYX(), np.full(3, -4.0), np.full(3, 4.0)
    elif kind == "planar":
        jm, lo, hi = pin.JointModelPlanar(), np.array([-3.0, -3.0, -1.0, -1.0]), np.array([3.0, 3.0, 1.0, 1.0])
    elif kind == "composite":
        jm = pin.JointModelComposite()
        jm.addJoint(pin.JointModelRZ(), _se3([0.1, 0.7, -0.3], [0.0, 0.0, 0.0]))
        jm.addJoint(pin.JointModelRX(), _se3([-0.4, 0.2, 0.9], [0.05, 0.3, -0.1]))
        lo, hi = np.full(2, -4.0), np.full(2, 4.0)
    else:
        raise ValueError(kind)
    big = np.full(jm.nv, 1e3)
    jid = model.addJoint(0, jm, top, kind, big, big, lo, hi)
    mech = Mechanism(model, name=model.name)
    if kind == "spherical":
        v = rng.normal(size=4)
        q0 = v / np.linalg.norm(v)
    elif kind == "planar":
        q0 = np.r_[rng.uniform(-1.0, 1.0, 2), np.cos(0.7), np.sin(0.7)]
    else:
        q0 = rng.uniform(-1.5, 1.5, jm.nq)
    data = model.createData()
    pin.forwardKinematics(model, data, q0)
    for i in range(jm.nv):
        P = pin.SE3(np.eye(3), rng.uniform(-1.0, 1.0, 3))
        Q = pin.SE3(np.eye(3), rng.uniform(-0.6, 0.6, 3))
        length = float(np.linalg.norm((data.oMi[jid] * Q).translation - P.translation))
        mech.closures.append(Closure("distance", 0, P, jid, Q, length=length, name=f"leg{i + 1}"))
    return mech


#: joints of several axes that a mechanism may hold locked (:func:`locked_mechanism`)
LOCKED_KINDS = ("spherical", "spherical_zyx", "free_flyer", "planar", "translation", "universal", "composite")


def lock_value(kind: str, rng: np.random.Generator) -> np.ndarray:
    """A generic lock value of a joint of ``kind``: a quaternion or ``(cos, sin)`` pair
    normalized in binary64 (so within an ulp of unit length, not exactly), angles, lengths."""
    if kind in ("spherical", "free_flyer"):
        v = rng.normal(size=4)
        quat = v / np.linalg.norm(v)
        return quat if kind == "spherical" else np.r_[rng.uniform(-0.3, 0.3, 3), quat]
    if kind == "planar":
        a = rng.uniform(-3.0, 3.0)
        return np.r_[rng.uniform(-0.3, 0.3, 2), np.cos(a), np.sin(a)]
    if kind in ("universal", "composite"):
        return rng.uniform(-1.2, 1.2, 2)
    return rng.uniform(-1.2, 1.2, 3)


def locked_mechanism(kind: str, seed: int = 0) -> Mechanism:
    """A joint of several axes (one of :data:`LOCKED_KINDS`) hanging from the world at a turned
    placement, locked at a generic value (:func:`lock_value`), and below it a free spherical
    joint at another turned placement carrying a body, closed by three distance legs to the
    world whose lengths are read off a random configuration: the locked joint's rotation and
    translation enter every leg's row."""
    rng = np.random.default_rng(seed)
    model = pin.Model()
    model.name = f"locked-{kind}"
    jm = {
        "spherical": pin.JointModelSpherical,
        "spherical_zyx": pin.JointModelSphericalZYX,
        "free_flyer": pin.JointModelFreeFlyer,
        "planar": pin.JointModelPlanar,
        "translation": pin.JointModelTranslation,
        "universal": lambda: pin.JointModelUniversal(_unit_axis(rng), _unit_axis(rng)),
        "composite": _composite,
    }[kind]()
    big = np.full(jm.nv, 1e3)
    lj = model.addJoint(0, jm, _se3([0.3, -0.2, 0.5], [0.1, 0.2, 0.05]), "lock", big, big, np.full(jm.nq, -4.0), np.full(jm.nq, 4.0))
    sph = pin.JointModelSpherical()
    big = np.full(3, 1e3)
    jid = model.addJoint(lj, sph, _se3([-0.6, 0.4, 0.1], [0.2, -0.1, 0.3]), "ball", big, big, -np.ones(4), np.ones(4))
    mech = Mechanism(model, name=model.name)
    mech.locked["lock"] = lock_value(kind, rng)
    v = rng.normal(size=4)
    q0 = pin.neutral(model)
    q0[model.joints[lj].idx_q : model.joints[lj].idx_q + jm.nq] = mech.locked["lock"]
    q0[model.joints[jid].idx_q :] = v / np.linalg.norm(v)
    data = model.createData()
    pin.forwardKinematics(model, data, q0)
    for i in range(3):
        P = pin.SE3(np.eye(3), rng.uniform(-1.0, 1.0, 3))
        Q = pin.SE3(np.eye(3), rng.uniform(-0.6, 0.6, 3))
        length = float(np.linalg.norm((data.oMi[jid] * Q).translation - P.translation))
        mech.closures.append(Closure("distance", 0, P, jid, Q, length=length, name=f"leg{i + 1}"))
    return mech


def _unit_axis(rng: np.random.Generator) -> np.ndarray:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def _composite():
    jm = pin.JointModelComposite()
    jm.addJoint(pin.JointModelRZ(), _se3([0.1, 0.7, -0.3], [0.0, 0.0, 0.0]))
    jm.addJoint(pin.JointModelRX(), _se3([-0.4, 0.2, 0.9], [0.05, 0.3, -0.1]))
    return jm
