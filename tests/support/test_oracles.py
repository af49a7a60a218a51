"""Tests of the independent oracles (tests/support/oracles) and of the DLS baseline (benchmarks/dls_baseline.py).

These do not test kinbox; they make sure the references kinbox is compared against are right.
"""

from __future__ import annotations

import importlib.util
import math
import os
import sys

import numpy as np
import pinocchio as pin
import pytest

from tests.support import paths as PATHS

ROOT = str(PATHS.ROOT)
from tests.support.oracles.planar import (  # noqa: E402
    four_bar_assemblies,
    four_bar_relative_angles,
    three_rpr_assemblies,
    three_rpr_residuals,
    three_rpr_sextic,
)
from tests.support.oracles.ur_ik import (  # noqa: E402
    UR_DH,
    WORLD_T_DHBASE,
    expand_within_limits,
    fk,
    load_model,
    same_mod_2pi,
    ur_ik,
)


def _load_dls():
    spec = importlib.util.spec_from_file_location("dls_baseline", os.path.join(ROOT, "benchmarks", "dls_baseline.py"))
    mod = importlib.util.module_from_spec(spec)
    sys.modules["dls_baseline"] = mod
    spec.loader.exec_module(mod)
    return mod


ROBOTS = ["ur3", "ur5", "ur10"]


@pytest.fixture(scope="module", params=ROBOTS)
def ur(request):
    m = load_model(request.param)
    return request.param, m, m.createData()


def _pin_pose(m, d, q, frame="tool0"):
    pin.forwardKinematics(m, d, q)
    pin.updateFramePlacements(m, d)
    return d.oMf[m.getFrameId(frame)].homogeneous.copy()


# ------------------------------------------------------------------------------------ UR


def test_ur_models_are_the_published_robots(ur):
    """load_model gives the URDF whose offsets match the published DH (the UR3 really is a UR3)."""
    name, m, _ = ur
    d1, a2, a3, d4, d5, d6 = UR_DH[name]
    jp = m.jointPlacements
    assert jp[1].translation[2] == pytest.approx(d1)
    assert jp[3].translation[2] == pytest.approx(-a2)
    assert jp[4].translation[2] == pytest.approx(-a3)
    assert jp[2].translation[1] + jp[3].translation[1] + jp[5].translation[1] == pytest.approx(d4)
    assert jp[6].translation[2] == pytest.approx(d5)


def test_ur_conventions(ur):
    """The frame / offset mapping of the oracle (world = base_link, DH base = Rz(pi) = frame 'base',
    q = theta_DH, tool0 = DH flange) reproduces Pinocchio FK for tool0, ee_link and wrist_3_link."""
    name, m, d = ur
    rng = np.random.default_rng(0)
    base = m.frames[m.getFrameId("base")].placement.homogeneous
    assert np.abs(base - WORLD_T_DHBASE).max() < 1e-10
    for _ in range(20):
        q = rng.uniform(m.lowerPositionLimit, m.upperPositionLimit)
        for frame in ("tool0", "ee_link", "wrist_3_link"):
            # the URDF writes pi/2 as 1.57079632679: agreement ~1e-11, not 1e-16
            assert np.abs(fk(name, q, frame) - _pin_pose(m, d, q, frame)).max() < 1e-10


def test_ur_ik_random_poses(ur):
    """200 random q: the oracle's set for the tool0 pose contains q (mod 2 pi) and every returned
    solution reproduces the pose through Pinocchio FK to 1e-9."""
    name, m, d = ur
    rng = np.random.default_rng(42)
    counts = {}
    worst_fk = worst_q = 0.0
    for _ in range(200):
        q = rng.uniform(m.lowerPositionLimit, m.upperPositionLimit)
        T = _pin_pose(m, d, q)
        sols = ur_ik(name, T)
        counts[len(sols)] = counts.get(len(sols), 0) + 1
        assert 1 <= len(sols) <= 8 and len(sols) % 2 == 0
        dist = min(np.abs(np.angle(np.exp(1j * (q - s)))).max() for s in sols)
        worst_q = max(worst_q, dist)
        assert dist < 1e-7, (q, sols)
        for i, s in enumerate(sols):
            assert np.all(s > -math.pi) and np.all(s <= math.pi)
            for t in sols[:i]:
                assert not same_mod_2pi(s, t, 1e-6)
            worst_fk = max(worst_fk, np.abs(_pin_pose(m, d, s) - T).max())
    assert worst_fk < 1e-9
    # typical random pose: 8 solutions most of the time, otherwise 6, 4 or 2
    assert counts.get(8, 0) >= 100, counts
    print(
        f"\n{name}: solution counts over 200 random poses {dict(sorted(counts.items()))}, "
        f"worst FK error {worst_fk:.1e}, worst |q - nearest sol| {worst_q:.1e}"
    )


def test_ur_ik_other_frames():
    name = "ur5"
    m = load_model(name)
    d = m.createData()
    rng = np.random.default_rng(1)
    for frame in ("ee_link", "wrist_3_link"):
        for _ in range(20):
            q = rng.uniform(-math.pi, math.pi, 6)
            T = _pin_pose(m, d, q, frame)
            sols = ur_ik(name, T, frame=frame)
            assert any(same_mod_2pi(q, s, 1e-7) for s in sols)
            for s in sols:
                assert np.abs(_pin_pose(m, d, s, frame) - T).max() < 1e-9


def test_ur_ik_unreachable_and_copies():
    T = np.eye(4)
    T[:3, 3] = (2.0, 0.0, 0.5)  # 2 m away: out of reach of a UR5
    assert ur_ik("ur5", T) == []
    m = load_model("ur5")
    q = np.array([0.3, -1.0, 2.0, -0.5, 1.2, -2.5])
    copies = expand_within_limits(q, m.lowerPositionLimit, m.upperPositionLimit)
    assert len(copies) == 32  # elbow limited to [-pi, pi]: 2**5 copies
    d = m.createData()
    T = _pin_pose(m, d, q)
    for c in copies[:4]:
        assert np.abs(_pin_pose(m, d, c) - T).max() < 1e-12


# ------------------------------------------------------------------------------------ four-bar


def _four_bar_brute(ground, crank, coupler, rocker, crank_angle, n=200_000):
    """Dense scan of the rocker angle + bisection on |C - B| - coupler."""
    B = np.array([crank * math.cos(crank_angle), crank * math.sin(crank_angle)])
    th = np.linspace(-math.pi, math.pi, n, endpoint=False)

    def f(t):
        return np.hypot(ground + rocker * np.cos(t) - B[0], rocker * np.sin(t) - B[1]) - coupler

    v = f(th)
    out = []
    for i in np.flatnonzero(np.sign(v) != np.sign(np.roll(v, -1))):
        a, b = th[i], th[i] + 2 * math.pi / n
        for _ in range(60):
            mid = 0.5 * (a + b)
            if np.sign(f(mid)) == np.sign(f(a)):
                a = mid
            else:
                b = mid
        r = math.remainder(0.5 * (a + b), 2 * math.pi)
        # a tangent (double) root can show up as two sign changes 1e-8 apart: merge them
        if not any(abs(math.remainder(r - o, 2 * math.pi)) < 1e-6 for o in out):
            out.append(r)
    return sorted(out)


@pytest.mark.parametrize(
    "dims",
    [(4.0, 1.0, 3.0, 3.5), (3.0, 2.0, 2.5, 1.5), (5.0, 2.0, 4.0, 2.0), (1.0, 2.0, 2.5, 3.0)],
)
def test_four_bar_vs_brute_force(dims):
    ground, crank, coupler, rocker = dims
    for ang in np.linspace(-math.pi, math.pi, 37):
        sols = four_bar_assemblies(ground, crank, coupler, rocker, ang)
        brute = _four_bar_brute(ground, crank, coupler, rocker, ang)
        assert len(sols) == len(brute), (dims, ang, sols, brute)
        for s in sols:
            # 1e-9 generically; a tangent (double) root is located by bisection only to ~sqrt(eps)
            assert min(abs(math.remainder(s.theta_rocker - b, 2 * math.pi)) for b in brute) < (1e-9 if len(sols) == 2 else 1e-6)
            B = np.array([crank * math.cos(ang), crank * math.sin(ang)])
            C = np.array(s.C)
            assert abs(np.linalg.norm(C - B) - coupler) < 1e-12
            assert abs(np.linalg.norm(C - (ground, 0.0)) - rocker) < 1e-12
            assert np.allclose(C, B + coupler * np.array([math.cos(s.theta_coupler), math.sin(s.theta_coupler)]))
            qa, qb, qc = four_bar_relative_angles(ang, s)
            # walk the chain A -> B -> C -> D with the relative angles: must close at D
            t1 = qa
            t2 = t1 + qb
            t3 = t2 + qc
            P = crank * np.array([math.cos(t1), math.sin(t1)])
            P = P + coupler * np.array([math.cos(t2), math.sin(t2)])
            P = P + rocker * np.array([math.cos(t3), math.sin(t3)])
            assert np.allclose(P, (ground, 0.0), atol=1e-12)


def test_four_bar_special_cases():
    # tangent: |BD| = coupler + rocker -> exactly one assembly, C = (2, 0)
    sols = four_bar_assemblies(3.0, 1.0, 1.0, 1.0, 0.0)
    assert len(sols) == 1 and np.allclose(sols[0].C, (2.0, 0.0))
    assert four_bar_assemblies(4.0, 1.0, 1.5, 2.0, math.pi) == []  # |BD| = 5 > 3.5
    # generic: the two modes are mirror images about the line B-D
    s1, s2 = four_bar_assemblies(4.0, 1.0, 3.0, 3.5, 1.0)
    B = np.array([math.cos(1.0), math.sin(1.0)])
    v = np.array([4.0, 0.0]) - B
    w1, w2 = np.array(s1.C) - B, np.array(s2.C) - B
    c1 = v[0] * w1[1] - v[1] * w1[0]
    c2 = v[0] * w2[1] - v[1] * w2[0]
    assert c1 > 0 > c2


# ------------------------------------------------------------------------------------ 3-RPR

# A 3-RPR with 6 real assembly modes (constructed: integer design found by a search, every mode
# verified below by an independent Newton brute force).
RPR6 = dict(
    base_pts=[(0.0, 0.0), (10.0, 0.0), (0.0, 10.0)],
    platform_pts=[(0.0, 0.0), (12.0, 0.0), (12.0, 10.0)],
    leg_lengths=[13.0, 10.0, 11.0],
)


def _rpr_brute(A, b, rho, n=(14, 14, 48), iters=50):
    """Independent check: vectorized Newton on the 3 leg equations from a dense (x, y, phi) grid."""
    A, b, rho = (np.asarray(v, float) for v in (A, b, rho))
    R0 = rho[0] + np.linalg.norm(b[0])
    grid = np.meshgrid(
        np.linspace(A[0, 0] - R0, A[0, 0] + R0, n[0]),
        np.linspace(A[0, 1] - R0, A[0, 1] + R0, n[1]),
        np.linspace(-math.pi, math.pi, n[2], endpoint=False),
        indexing="ij",
    )
    X = np.array(grid).reshape(3, -1).T

    def legs(X):
        c, s = np.cos(X[:, 2:3]), np.sin(X[:, 2:3])
        Bx = X[:, 0:1] + c * b[:, 0] - s * b[:, 1]
        By = X[:, 1:2] + s * b[:, 0] + c * b[:, 1]
        return Bx - A[:, 0], By - A[:, 1], -s * b[:, 0] - c * b[:, 1], c * b[:, 0] - s * b[:, 1]

    for _ in range(iters):
        dx, dy, dbx, dby = legs(X)
        f = dx**2 + dy**2 - rho**2
        J = np.stack([2 * dx, 2 * dy, 2 * (dx * dbx + dy * dby)], axis=2)
        ok = np.abs(np.linalg.det(J)) > 1e-12
        step = np.zeros_like(X)
        step[ok] = np.linalg.solve(J[ok], -f[ok][..., None])[..., 0]
        step *= np.minimum(1.0, R0 / (np.abs(step).max(axis=1, keepdims=True) + 1e-300))
        X = X + step
    dx, dy, _, _ = legs(X)
    good = X[np.abs(np.hypot(dx, dy) - rho).max(axis=1) < 1e-9]
    sols = []
    for q in good:
        q = q.copy()
        q[2] = math.remainder(q[2], 2 * math.pi)
        if not any(abs(math.remainder(q[2] - r[2], 2 * math.pi)) < 1e-7 and np.abs(q[:2] - r[:2]).max() < 1e-7 for r in sols):
            sols.append(q)
    return sols


def _same_pose_sets(s1, s2, tol=1e-7):
    if len(s1) != len(s2):
        return False
    for p in s1:
        if not any(abs(math.remainder(p[2] - q[2], 2 * math.pi)) < tol and abs(p[0] - q[0]) < tol and abs(p[1] - q[1]) < tol for q in s2):
            return False
    return True


def test_three_rpr_six_assemblies():
    sols = three_rpr_assemblies(**RPR6)
    assert len(sols) == 6
    for s in sols:
        assert np.abs(three_rpr_residuals(RPR6["base_pts"], RPR6["platform_pts"], RPR6["leg_lengths"], s)).max() < 1e-9
    sextic, rem, _ = three_rpr_sextic(RPR6["base_pts"], RPR6["platform_pts"], RPR6["leg_lengths"])
    assert len(sextic) - 1 == 6 and rem < 1e-12  # degree 8 = (1 + t^2) * sextic
    brute = _rpr_brute(RPR6["base_pts"], RPR6["platform_pts"], RPR6["leg_lengths"])
    assert _same_pose_sets(sols, brute), (sols, brute)


# The design of robots/3-rpr.json (believed to be the classic six-mode example of the 3-RPR
# literature: A1=(0,0), A2=(15.91,0), A3=(0,10); B1B2 = 17.04, B1B3 = 20.84, angle at B1 0.882603 rad;
# legs 14.98, 15.38, 12).
RPR_CLASSIC = dict(
    base_pts=[(0.0, 0.0), (15.91, 0.0), (0.0, 10.0)],
    platform_pts=[(0.0, 0.0), (17.04, 0.0), (20.84 * math.cos(0.882603), 20.84 * math.sin(0.882603))],
    leg_lengths=[14.98, 15.38, 12.0],
)


def test_three_rpr_classic_example():
    sols = three_rpr_assemblies(**RPR_CLASSIC)
    assert len(sols) == 6
    for s in sols:
        assert np.abs(three_rpr_residuals(RPR_CLASSIC["base_pts"], RPR_CLASSIC["platform_pts"], RPR_CLASSIC["leg_lengths"], s)).max() < 1e-9
    brute = _rpr_brute(RPR_CLASSIC["base_pts"], RPR_CLASSIC["platform_pts"], RPR_CLASSIC["leg_lengths"])
    assert _same_pose_sets(sols, brute), (sols, brute)


def test_three_rpr_random_designs():
    rng = np.random.default_rng(5)
    counts = {}
    for k in range(40):
        A = rng.uniform(-1, 1, (3, 2))
        b = rng.uniform(-1, 1, (3, 2))
        x, y, phi = rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-math.pi, math.pi)
        c, s = math.cos(phi), math.sin(phi)
        B = np.array([x, y]) + b @ np.array([[c, -s], [s, c]]).T
        rho = np.linalg.norm(B - A, axis=1)
        sols = three_rpr_assemblies(A, b, rho)
        counts[len(sols)] = counts.get(len(sols), 0) + 1
        assert any(abs(p[0] - x) < 1e-8 and abs(p[1] - y) < 1e-8 and abs(math.remainder(p[2] - phi, 2 * math.pi)) < 1e-8 for p in sols)
        for p in sols:
            assert np.abs(three_rpr_residuals(A, b, rho, p)).max() < 1e-9
        if k < 6:
            assert _same_pose_sets(sols, _rpr_brute(A, b, rho, n=(10, 10, 36))), k
    assert set(counts) <= {2, 4, 6}


def test_three_rpr_unreachable():
    # legs far too short to reach the platform pivots: no assembly
    assert three_rpr_assemblies(RPR6["base_pts"], RPR6["platform_pts"], [0.1, 0.1, 0.1]) == []


# ------------------------------------------------------------------------------------ DLS


def test_dls_baseline_ur5():
    dls = _load_dls()
    m = load_model("ur5")
    d = m.createData()
    rng = np.random.default_rng(3)
    q = rng.uniform(m.lowerPositionLimit, m.upperPositionLimit)
    T = _pin_pose(m, d, q)
    goal = pin.SE3(T)
    sols, st = dls.dls_solutions(m, "tool0", goal, restarts=100, seed=0)
    assert st["restarts"] == 100 and len(st["time"]) == 100
    assert len(sols) >= 1 and st["residual"][st["converged"]].max() < 1e-10
    ref = ur_ik("ur5", T)
    for s in sols:  # every DLS solution is one of the oracle's
        assert any(same_mod_2pi(s, r, 1e-6) for r in ref)
        assert np.abs(_pin_pose(m, d, s) - T).max() < 1e-9
    cov = dls.coverage_from_stats(m, sols, st, ref)
    assert cov["extra"] == []
    out = dls.restarts_until_complete(m, "tool0", goal, ref, max_restarts=500, seed=1)
    assert out["missing"] == [] and out["restarts"] == out["stats"]["restarts"] <= 500
