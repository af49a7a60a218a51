"""A locked joint of several axes (spherical, spherical ZYX, free-flyer, planar, translation) in
the general formulation: its fixed motion is enclosed from the exact lock values
(``constants._several``), so the rows carry their distance to the model as given and every
certified box holds the 40-digit root of the mechanism with the joint at its lock values as
given (``tests/support/oracles/mp_mech.py``)."""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pinocchio as pin
import pytest
from mpmath import iv

import kinbox
from kinbox.formulation import build, enclose_rows
from kinbox.formulation import constants as K
from tests.support.oracles import mp_mech
from tests.support.pair_mechanisms import LOCKED_KINDS, lock_value, locked_mechanism


@pytest.mark.parametrize("kind", LOCKED_KINDS)
def test_a_joints_motion_of_several_axes_holds_the_exact_one(kind):
    """The enclosure of a joint's motion at its values holds the 40-digit motion of the oracle
    (the quaternion's unit rotation, the normalized ``(cos, sin)``, Rz Ry Rx) and lies within
    an ulp or so of Pinocchio's binary64 motion."""
    mech = locked_mechanism(kind)
    model = mech.model
    rng = np.random.default_rng(11)
    for _ in range(5):
        v = lock_value(kind, rng)
        q = pin.neutral(model)
        q[: v.size] = v
        old = iv.prec
        iv.prec = K._PREC
        try:
            F = K._motion(model, 1, q)
            mp.mp.dps = 40
            R, t = mp_mech._motion(model.joints[1], [mp.mpf(float(x)) for x in v])
            for i in range(3):
                assert F.t[i].a <= t[i] <= F.t[i].b
                for k in range(3):
                    assert F.R[i][k].a <= R[i, k] <= F.R[i][k].b
            data = model.createData()
            pin.forwardKinematics(model, data, q)
            M = model.jointPlacements[1].inverse() * data.liMi[1]
            rR, rt = F.radius(M)
        finally:
            iv.prec = old
        assert rR.max() < 1e-15 and rt.max() < 1e-15


def _solve_both(mech, monkeypatch):
    res = kinbox.solve(mech, progress=False, formulation="general")
    with monkeypatch.context() as m:
        m.setattr(build, "_core_errors", lambda *a: None)
        res0 = kinbox.solve(mech, progress=False, formulation="general")
    return res, res0


#: the default suite solves two kinds (a quaternion, two axes); the others are slow tests
SOLVED = [k if k in ("free_flyer", "universal") else pytest.param(k, marks=pytest.mark.slow) for k in LOCKED_KINDS]


@pytest.mark.parametrize("kind", SOLVED)
def test_a_locked_joint_of_several_axes_certifies_the_model_as_given(kind, monkeypatch):
    """The locked joint's rows carry ``merr``; the same assemblies as with the rows as rounded,
    every one certified, each certified box holding its 40-digit root."""
    mech = locked_mechanism(kind)
    res, res0 = _solve_both(mech, monkeypatch)
    sys_ = res.raw.system
    assert res.complete and sys_.core_errors is not None and sys_.compile().merr.max() > 0
    assert len(res.solutions) == len(res0.solutions) > 0
    assert all(s.certified for s in res.solutions + res0.solutions)
    assert max(mp_mech.certified_gaps(mp_mech.Mech(mech), res)) == 0.0


def test_a_lock_known_within_a_radius_is_carried_to_the_boxes(monkeypatch):
    """A free-flyer's lock enclosed only within 1e-10 (each entry of its fixed motion's error
    widened by that): the certified boxes hold the 40-digit roots of the free-flyer locked
    3e-11 rad turned and 3e-11 m moved, both ways; with the lock's own error (a few ulps) the
    boxes miss them: what the test catches if the lock's enclosure were lost on the way
    (``constants._several``, ``enclose_rows.relative``, the build's locked edge)."""
    r, eps = 1e-10, 3e-11
    mech = locked_mechanism("free_flyer", seed=2)
    res0 = kinbox.solve(mech, progress=False, formulation="general")
    relative = enclose_rows.relative

    def wide(*args):
        R, t = relative(*args)
        return (
            enclose_rows.ef_array([float(x) for x in R.ravel()], [x.err + r for x in R.ravel()]).reshape(3, 3),
            enclose_rows.ef_array([float(x) for x in t], [x.err + r for x in t]),
        )

    with monkeypatch.context() as m:
        m.setattr(enclose_rows, "relative", wide)
        res = kinbox.solve(mech, progress=False, formulation="general")
    assert len(res.solutions) == len(res0.solutions) > 0 and all(s.certified for s in res.solutions)
    v = np.asarray(mech.locked["lock"], dtype=float)
    for sign in (1.0, -1.0):
        turn = pin.Quaternion(pin.exp3(sign * eps * np.array([0.6, 0.0, 0.8])))
        quat = pin.Quaternion(v[6], *v[3:6]) * turn
        moved = np.r_[v[:3] + sign * eps, quat.coeffs()]
        mech.locked["lock"] = moved
        try:
            oracle = mp_mech.Mech(mech)
        finally:
            mech.locked["lock"] = v
        assert mp_mech.certified_gaps(oracle, res) == [0.0] * len(res.solutions)
        assert min(mp_mech.certified_gaps(oracle, res0)) > 0


def test_an_arm_on_a_locked_free_flyer_has_its_constants_enclosed():
    """A UR5 loaded on a free-flyer root locked at a generic pose: the arm template's constants
    (the base frame through the locked root) are enclosed (``enclose_links``), within a few
    ulps of the binary64 ones."""
    import os

    import example_robot_data as erd

    rel = "ur_description/urdf/ur5_robot.urdf"
    robot = kinbox.load(os.path.join(erd.getModelPath(rel), rel), root_joint="freeflyer")
    quat = np.array([0.3, -0.2, 0.5, 0.1]) / np.linalg.norm([0.3, -0.2, 0.5, 0.1])
    ik = kinbox.IK(robot, "tool0", lock={"root_joint": np.r_[0.1, 0.2, 0.3, quat]})
    radii = ik.arm.constants
    assert radii is not None
    assert max(float(np.max(r)) for pair in [*radii["links"], radii["A"], radii["B"]] for r in pair) < 1e-13
