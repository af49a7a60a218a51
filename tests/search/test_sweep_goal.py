"""The seven-joint sweep certifies its points on the pose as given (kinbox.search.sweep.Anchors):
the parameters it binds at a sample ``t`` of the swept joint carry a radius that reaches the
exact goal of the pose with the joint exactly at ``t``, checked against the arm template's own
enclosure of that goal on the six-joint arm locked at ``t`` (a different path: the model's exact
constants at that lock value, the pose's XYZQUAT in extended precision)."""

from __future__ import annotations

import copy

import numpy as np
import pytest

import kinbox
from kinbox.formulation.arm import NPARAMS
from kinbox.problems.selfmotion import _frame, linear_goal
from kinbox.search.closed_form import _params


@pytest.fixture(scope="module")
def panda():
    return kinbox.IK("panda", "panda_hand")


def _locked_enclosure(ik, name: str, t: float, goal):
    rob = copy.copy(ik.robot)
    rob.locked = dict(ik.robot.locked)
    sub = type(ik)(rob, ik.frame, ik.base, lock={name: t})
    return sub.closed_form.certifier.arm.params_enclosure(goal)


@pytest.mark.parametrize("seed", [1, pytest.param(2, marks=pytest.mark.slow)])
def test_sample_parameters_reach_the_exact_goal(panda, seed):
    """At each sample the anchors' parameters lie within their radius of the arm template's
    enclosure of the exact goal at that lock value, where the linear goal's binary64 value does
    not (its rounding exceeds the exact goal's enclosure)."""
    sw = panda.sweeper
    m = panda.robot.model
    q = np.random.default_rng(seed).uniform(m.lowerPositionLimit[:7], m.upperPositionLimit[:7])
    goal = panda.pose_at(q)
    lin = linear_goal(sw.values[:3], [_frame(cf, goal) for cf in sw.forms[:3]])
    anchors = sw.anchors(goal)
    assert anchors is not None  # the Panda's last joint: the six joints' frames do not move
    ts = np.linspace(sw.swept.lo + 0.1, sw.swept.hi - 0.1, 4)
    GR = np.empty((len(ts), 3, 3))
    Gt = np.empty((len(ts), 3))
    for k, t in enumerate(ts):
        GR[k], Gt[k] = lin.at(t)
    P = np.empty((len(ts), NPARAMS))
    PM = np.empty((len(ts), NPARAMS))
    _params(GR, Gt, np.linalg.norm(Gt, axis=1), sw.forms[0].tmag0, P, PM)
    mid, rad = anchors.params(ts)
    assert np.all(rad[:, 1:] < 1e-13)
    linear_off = 0
    for k, t in enumerate(ts):
        pt, rt = _locked_enclosure(panda, sw.swept.name, float(t), goal)
        assert np.all(np.abs(mid[k] - pt) <= rad[k] + rt)  # the anchors reach the exact goal
        linear_off += bool(np.any(np.abs(P[k] - pt) > rt))
    # the linear goal's binary64 value, which the certificates bound before, is not the exact goal
    assert linear_off >= 1


def test_slab_enclosures_hold_the_exact_goal(panda):
    """Over a slab of the swept joint the goal's enclosure, and the anchors' enclosure of the
    exact goal, meet the arm template's enclosure of the exact goal on the arm locked at each
    sample inside."""
    sw = panda.sweeper
    m = panda.robot.model
    q = np.random.default_rng(3).uniform(m.lowerPositionLimit[:7], m.upperPositionLimit[:7])
    goal = panda.pose_at(q)
    lin = linear_goal(sw.values[:3], [_frame(cf, goal) for cf in sw.forms[:3]])
    lin.anchors = sw.anchors(goal)
    a, b = sw.swept.lo + 0.2, sw.swept.lo + 0.5
    Rlo, Rhi, plo, phi = lin.enclosure(a, b)
    slab = (np.concatenate([Rlo.ravel(), plo]), np.concatenate([Rhi.ravel(), phi]))
    anchored = lin.anchors.enclosure(*(x for pair in _cos_sin(a, b) for x in pair))
    for t in np.linspace(a, b, 4):
        pt, rt = _locked_enclosure(panda, sw.swept.name, float(t), goal)
        for lo, hi in (slab, anchored):
            assert np.all(lo <= pt[1:13] + rt[1:13]) and np.all(pt[1:13] - rt[1:13] <= hi)


def _cos_sin(a: float, b: float):
    from kinbox.search.sweep import cos_sin_range

    return cos_sin_range(a, b)


def test_the_pad_holds_the_exact_goal_or_the_hull_is_taken(panda):
    """Where the linear goal's pad is shown to hold the exact goal (its coefficients within the
    pad of the anchors' enclosed ones) the anchors' hull is skipped; a linear goal moved by
    more than its pad is not taken for the exact one, and its slabs' enclosures then hold the
    anchors' enclosure."""
    sw = panda.sweeper
    m = panda.robot.model
    q = np.random.default_rng(4).uniform(m.lowerPositionLimit[:7], m.upperPositionLimit[:7])
    goal = panda.pose_at(q)
    lin = linear_goal(sw.values[:3], [_frame(cf, goal) for cf in sw.forms[:3]])
    lin.anchors = sw.anchors(goal)
    assert lin._pad_holds_exact()
    moved = linear_goal(sw.values[:3], [_frame(cf, goal) for cf in sw.forms[:3]])
    moved.p = (moved.p[0] + 1e-9, moved.p[1], moved.p[2])
    moved.anchors = lin.anchors
    assert not moved._pad_holds_exact()
    (cl, ch), (sl, sh) = _cos_sin(0.1, 0.3)
    lo, hi = lin.anchors.enclosure(cl, ch, sl, sh)
    _, _, plo, phi = moved.enclosure(0.1, 0.3)
    assert np.all(plo <= lo[9:]) and np.all(hi[9:] <= phi)


# --- a swept first joint: the six others rooted on it (kinbox.formulation.swept_goal) ---------


@pytest.fixture(scope="module")
def shoulder7():
    """A seven-joint arm whose first joint only is swept (tests/data/arms/skew_shoulder7_dh.json)."""
    from tests.support.paths import DATA

    return kinbox.IK(str(DATA / "arms" / "skew_shoulder7_dh.json"), "tool")


def _pose(ik, seed: int):
    m = ik.robot.model
    q = np.random.default_rng(seed).uniform(m.lowerPositionLimit[:7], m.upperPositionLimit[:7])
    return ik.pose_at(q)


def test_first_joint_swept_on_the_arm_rooted_on_it(shoulder7):
    """The sweeper takes the first joint where the last gives no family, and writes the six
    others as one arm rooted at a frame on it: the same closed form at every lock value, the
    goal seen from that frame, and the anchors of the exact goal (not the linear goal alone)."""
    sw = shoulder7.sweeper
    assert sw is not None and sw.root is not None
    assert sw.swept.name == shoulder7.robot.model.names[shoulder7.chain[0]]
    assert all(cf is sw.forms[0] for cf in sw.forms)
    assert sw.anchors(_pose(shoulder7, 3)) is not None


def _binary64_params(sw, goal, ts):
    lin = linear_goal(sw.values[:3], sw.frames(goal)[:3])
    GR = np.empty((len(ts), 3, 3))
    Gt = np.empty((len(ts), 3))
    for k, t in enumerate(ts):
        GR[k], Gt[k] = lin.at(t)
    P = np.empty((len(ts), NPARAMS))
    PM = np.empty((len(ts), NPARAMS))
    _params(GR, Gt, np.linalg.norm(Gt, axis=1), sw.forms[0].tmag0, P, PM)
    return lin, P


def test_first_joint_samples_bind_the_exact_goal(shoulder7, monkeypatch):
    """The parameters the sweep binds to certify its samples (``solve_points``) reach, within
    their radius, the arm template's enclosure of the exact goal on the seven-joint arm locked
    at each sample (its own canonical frames, the pose in extended precision), where the linear
    goal's binary64 value does not."""
    from kinbox.formulation import template
    from kinbox.search.sweep import solve_points

    sw = shoulder7.sweeper
    goal = _pose(shoulder7, 3)
    ts = np.linspace(sw.swept.lo + 0.1, sw.swept.hi - 0.1, 4)
    lin, P64 = _binary64_params(sw, goal, ts)
    lin.anchors = sw.anchors(goal)
    seen = {}
    real = template.model_errors

    def spy(T, P, PM, PRAD):
        seen["P"], seen["PRAD"] = P.copy(), PRAD.copy()
        return real(T, P, PM, PRAD)

    monkeypatch.setattr(template, "model_errors", spy)
    solve_points(sw.forms[0], lin, ts, certify=True)
    P, rad = seen["P"], seen["PRAD"]
    assert np.all(rad[:, 1:] < 1e-13)
    linear_off = 0
    for k, t in enumerate(ts):
        pt, rt = _locked_enclosure(shoulder7, sw.swept.name, float(t), goal)
        assert np.all(np.abs(P[k] - pt) <= rad[k] + rt)
        linear_off += bool(np.any(np.abs(P64[k] - pt) > rt))
    assert linear_off >= 1


def test_first_joint_slab_enclosures_hold_the_exact_goal(shoulder7):
    """Over a slab of the swept first joint the goal's enclosure (its pad proven to hold the
    exact goal), and the anchors' enclosure of the exact goal, meet the arm template's
    enclosure on the arm locked at samples inside."""
    sw = shoulder7.sweeper
    goal = _pose(shoulder7, 5)
    lin = linear_goal(sw.values[:3], sw.frames(goal)[:3])
    lin.anchors = sw.anchors(goal)
    assert lin._pad_holds_exact()  # the linear goal's pad proven to hold the exact goal
    a, b = sw.swept.lo + 1.0, sw.swept.lo + 1.3
    Rlo, Rhi, plo, phi = lin.enclosure(a, b)
    slab = (np.concatenate([Rlo.ravel(), plo]), np.concatenate([Rhi.ravel(), phi]))
    anchored = lin.anchors.enclosure(*(x for pair in _cos_sin(a, b) for x in pair))
    for t in np.linspace(a, b, 3):
        pt, rt = _locked_enclosure(shoulder7, sw.swept.name, float(t), goal)
        for lo, hi in (slab, anchored):
            assert np.all(lo <= pt[1:13] + rt[1:13]) and np.all(pt[1:13] - rt[1:13] <= hi)
