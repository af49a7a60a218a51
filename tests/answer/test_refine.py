"""Pinocchio's closure errors and their Jacobian (kinbox.answer.refine), and the refinement."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import kinbox
from kinbox.answer.refine import closure_errors, free_velocity_indices, refine
from kinbox.model.loading import load


def _mechanisms():
    ik = kinbox.IK("ur5", "tool0")
    goal = ik.pose_at(np.array([0.3, -1.1, 1.4, -0.7, 1.2, 0.4]))
    yield "ur5 goal (weld)", ik.problem(goal).mechanism
    yield "griffis-duffy (distances, one shared joint)", load("griffis-duffy")
    yield "four-bar (point)", load("four-bar")


@pytest.mark.parametrize("name, mech", list(_mechanisms()))
def test_the_jacobian_is_the_derivative_of_the_errors(name, mech):
    model, data = mech.model, mech.model.createData()
    rng = np.random.default_rng(4)
    q = pin.integrate(model, pin.neutral(model), rng.uniform(-0.8, 0.8, model.nv))
    e, J = closure_errors(mech, data, q)
    e_only, none = closure_errors(mech, data, q, jacobian=False)
    assert none is None and np.array_equal(e, e_only)
    h = 1e-6
    for k in range(model.nv):
        dv = np.zeros(model.nv)
        dv[k] = h
        fd = (
            closure_errors(mech, data, pin.integrate(model, q, dv), False)[0]
            - closure_errors(mech, data, pin.integrate(model, q, -dv), False)[0]
        ) / (2 * h)
        assert np.allclose(J[:, k], fd, atol=1e-7), (name, k)


def test_refine_brings_a_nearby_configuration_back_to_precision():
    ik = kinbox.IK("ur5", "tool0")
    q0 = np.array([0.3, -1.1, 1.4, -0.7, 1.2, 0.4])
    mech = ik.problem(ik.pose_at(q0)).mechanism
    data = mech.model.createData()
    q = q0 + 1e-9 * np.array([1.0, -2.0, 0.5, 1.5, -1.0, 0.3])
    before = np.max(np.abs(closure_errors(mech, data, q, False)[0]))
    out = refine(mech, q, free_velocity_indices(mech.model, [mech.model.names[i] for i in range(1, 7)]), data=data)
    after = np.max(np.abs(closure_errors(mech, data, out, False)[0]))
    assert before > 1e-9 and after < 1e-14
    assert np.max(np.abs(out - q0)) < 1e-12
    # at precision already: returned as it is
    assert refine(mech, out, np.arange(6), data=data) is out
