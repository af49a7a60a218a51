"""Builders: each mechanism's Pinocchio model reproduces its geometry (checked with Pinocchio FK)."""

import json
import math

import mpmath as mp
import numpy as np
import pinocchio as pin
import pytest
from scipy.optimize import least_squares

from kinbox.errors import InputError
from kinbox.model.builders import delta, dh_chain, dh_matrix, four_bar, set_leg_lengths, stewart, three_rpr
from kinbox.model.mechanism import Mechanism
from tests.support import paths as PATHS

REF = PATHS.DATA / "reference"


def ref(name):
    return json.loads((REF / name).read_text())


# -- helpers ---------------------------------------------------------------------------------
def closure_vector(mech: Mechanism, q: np.ndarray) -> np.ndarray:
    """Signed residuals of all closures (for least squares); zero iff assembled."""
    data = mech.model.createData()
    pin.forwardKinematics(mech.model, data, q)
    out = []
    for c in mech.closures:
        Ma = data.oMi[c.joint_a] * c.placement_a
        Mb = data.oMi[c.joint_b] * c.placement_b
        dp = Ma.translation - Mb.translation
        if c.kind == "distance":
            out.append([np.linalg.norm(dp) - c.length])
        else:
            out.append(dp)
            if c.kind == "weld":
                out.append(pin.log3(Ma.rotation.T @ Mb.rotation))
    return np.concatenate(out) if out else np.zeros(0)


def base_config(mech: Mechanism) -> tuple[np.ndarray, np.ndarray]:
    """(neutral q with locked joints applied, mask of the free velocity entries)."""
    model = mech.model
    q = pin.neutral(model)
    free = np.ones(model.nv, dtype=bool)
    for name, val in mech.locked.items():
        j = model.joints[model.getJointId(name)]
        q[j.idx_q : j.idx_q + j.nq] = val
        free[j.idx_v : j.idx_v + j.nv] = False
    return q, free


def assemble(mech: Mechanism, rng, tries: int = 50, scale: float = math.pi, q0=None) -> np.ndarray:
    """Some assembled configuration, by least squares from random starts."""
    qb, free = base_config(mech) if q0 is None else (q0, base_config(mech)[1])
    best = None
    for _ in range(tries):
        v0 = rng.uniform(-scale, scale, int(free.sum()))

        def f(v):
            dv = np.zeros(mech.model.nv)
            dv[free] = v
            return closure_vector(mech, pin.integrate(mech.model, qb, dv))

        r = least_squares(f, v0, xtol=1e-15, ftol=1e-15, gtol=1e-15)
        if np.linalg.norm(r.fun) < 1e-10:
            dv = np.zeros(mech.model.nv)
            dv[free] = r.x
            return pin.integrate(mech.model, qb, dv)
        if best is None or np.linalg.norm(r.fun) < best:
            best = np.linalg.norm(r.fun)
    raise AssertionError(f"no assembly found for {mech.name} (best residual {best})")


def max_residual(mech: Mechanism, q) -> float:
    return max(max(p, o) for _, p, o in mech.closure_residuals(q))


def frame_pos(mech: Mechanism, q, frame: str) -> np.ndarray:
    data = mech.model.createData()
    pin.framesForwardKinematics(mech.model, data, q)
    return data.oMf[mech.model.getFrameId(frame)].translation.copy()


# -- DH chains ----------------------------------------------------------------------------------
def test_dh_chain_reproduces_the_reference_convention():
    rows = ref("general_6r.json")["dh"]
    mech = dh_chain(rows, closed=False, name="arm")
    model = mech.model
    assert [model.names[i] for i in range(1, 7)] == [f"joint{i}" for i in range(1, 7)]
    assert model.existFrame("tool") and not mech.closures
    data = model.createData()
    rng = np.random.default_rng(1)
    for _ in range(20):
        q = rng.uniform(-math.pi, math.pi, 6)
        pin.framesForwardKinematics(model, data, q)
        M = np.eye(4)
        for r, t in zip(rows, q):
            M = M @ dh_matrix(r["a"], r["d"], r["alpha"], t)
        explicit = np.diag([1, 1, 1, 1.0])
        for r, t in zip(rows, q):  # independent product Rx Tx Rz Tz
            ca, sa, ct, st = math.cos(r["alpha"]), math.sin(r["alpha"]), math.cos(t), math.sin(t)
            Rx = np.array([[1, 0, 0, 0], [0, ca, -sa, 0], [0, sa, ca, 0], [0, 0, 0, 1.0]])
            Tx = np.eye(4)
            Tx[0, 3] = r["a"]
            Rz = np.array([[ct, -st, 0, 0], [st, ct, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])
            Tz = np.eye(4)
            Tz[2, 3] = r["d"]
            explicit = explicit @ Rx @ Tx @ Rz @ Tz
        assert np.allclose(M, explicit, atol=1e-12)
        assert np.allclose(data.oMf[model.getFrameId("tool")].homogeneous, explicit, atol=1e-12)
        # joint i's axis is the z axis of link frame F_i
        F = np.eye(4)
        for i, (r, t) in enumerate(zip(rows, q), start=1):
            F = F @ dh_matrix(r["a"], r["d"], r["alpha"], t)
            assert np.allclose(data.oMi[i].rotation, F[:3, :3], atol=1e-12)


def test_dh_theta_offset_and_limits():
    rows = [{"a": 0.3, "d": 0.1, "alpha": 0.5, "theta": 0.7, "lower": -1, "upper": 2}, (1.0, 0.2, -0.4)]
    mech = dh_chain(rows)
    q = np.array([0.2, -0.5])
    data = mech.model.createData()
    pin.framesForwardKinematics(mech.model, data, q)
    M = dh_matrix(0.3, 0.1, 0.5, 0.9) @ dh_matrix(1.0, 0.2, -0.4, -0.5)
    assert np.allclose(data.oMf[mech.model.getFrameId("tool")].homogeneous, M)
    assert np.allclose(mech.model.lowerPositionLimit, [-1, -math.pi])
    assert np.allclose(mech.model.upperPositionLimit, [2, math.pi])


@pytest.mark.parametrize("file", ["general_6r.json", "bricard_6r.json"])
def test_dh_loop_closes_at_a_solution(file):
    mech = dh_chain(ref(file)["dh"], closed=True, name=file)
    assert [(c.kind, c.name, c.joint_a, c.joint_b) for c in mech.closures] == [("weld", "loop", 6, 0)]
    rng = np.random.default_rng(3)
    q = assemble(mech, rng)
    assert max_residual(mech, q) < 1e-9
    data = mech.model.createData()
    pin.framesForwardKinematics(mech.model, data, q)
    assert np.allclose(data.oMf[mech.model.getFrameId("tool")].homogeneous, np.eye(4), atol=1e-9)
    assert max_residual(mech, rng.uniform(-3, 3, 6)) > 1e-3


@pytest.mark.parametrize(
    "rows, msg",
    [
        ([], "at least one"),
        ([{"a": 1, "d": 0}], "missing"),
        ([{"a": 1, "d": 0, "alpha": float("nan")}], "not finite"),
        ([{"a": 1, "d": 0, "alpha": 0, "b": 2}], "unknown key"),
        ([(1, 2)], "3 or 4"),
        ([{"a": "x", "d": 0, "alpha": 0}], "number"),
        ([{"a": 1, "d": 0, "alpha": 0, "lower": 2, "upper": 1}], "lower"),
        ("abc", "list"),
    ],
)
def test_dh_chain_rejects_bad_rows(rows, msg):
    with pytest.raises(InputError, match=msg):
        dh_chain(rows)


# -- Stewart platforms -----------------------------------------------------------------------
def test_stewart_griffis_duffy_assembled_pose():
    gd = ref("griffis_duffy.json")
    mech = stewart(gd["base_points"], gd["platform_points"], gd["leg_lengths_consistent"])
    model = mech.model
    assert model.njoints == 2 and model.names[1] == "platform"
    assert model.joints[1].shortname() == "JointModelFreeFlyer"
    assert [c.name for c in mech.closures] == [f"leg{i}" for i in range(1, 7)]
    assert all(c.kind == "distance" and c.joint_a == 0 and c.joint_b == 1 for c in mech.closures)
    pose = gd["pose_rotvec_t"]
    R = pin.exp3(np.array(pose[:3]))
    q = np.concatenate([pose[3:], pin.Quaternion(R).coeffs()])
    assert max_residual(mech, q) < 1e-7
    for i, (p, l) in enumerate(zip(gd["base_points"], gd["leg_lengths_consistent"]), start=1):
        assert abs(np.linalg.norm(frame_pos(mech, q, f"platform_anchor{i}") - np.array(p)) - l) < 1e-7
        assert np.allclose(frame_pos(mech, q, f"base_anchor{i}"), p)
    lo, hi = model.lowerPositionLimit, model.upperPositionLimit
    assert np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))
    assert np.all(np.abs(q[:3]) <= hi[:3])


def test_griffis_duffy_lengths_are_its_reference_assembly_to_rounding():
    """The robot's leg lengths are those of the reference pose at 60 digits, rounded to binary64:
    its rows close along the curves to rounding (given to 12 decimals, only to about 1e-13)."""
    gd = ref("griffis_duffy.json")
    with mp.workdps(60):
        r = [mp.mpf(v) for v in gd["pose_rotvec_t"][:3]]
        th = mp.sqrt(sum(v * v for v in r))
        k = [v / th for v in r]
        K = mp.matrix([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
        R = mp.eye(3) + mp.sin(th) * K + (1 - mp.cos(th)) * K * K
        t = [mp.mpf(v) for v in gd["pose_rotvec_t"][3:]]
        for b, p, length in zip(gd["base_points"], gd["platform_points"], gd["leg_lengths_consistent"]):
            v = R * mp.matrix([mp.mpf(c) for c in p])
            exact = mp.sqrt(sum((v[i] + t[i] - mp.mpf(b[i])) ** 2 for i in range(3)))
            assert length == float(exact)
    assert max(abs(a - b) for a, b in zip(gd["leg_lengths"], gd["leg_lengths_consistent"])) < 2e-8


def test_stewart_dietmeier_assembles():
    d = ref("dietmeier_66.json")
    mech = stewart(d["base_points"], d["platform_points"], d["leg_lengths"], name="dietmeier")
    q = assemble(mech, np.random.default_rng(0), scale=1.0)
    assert max_residual(mech, q) < 1e-9
    data = mech.model.createData()
    pin.forwardKinematics(mech.model, data, q)
    t, R = data.oMi[1].translation, data.oMi[1].rotation
    for p, qq, l in zip(d["base_points"], d["platform_points"], d["leg_lengths"]):
        assert abs(np.linalg.norm(t + R @ np.array(qq) - np.array(p)) - l) < 1e-9


def test_stewart_lengths_later_and_bad_inputs():
    P = np.random.default_rng(0).normal(size=(6, 3))
    mech = stewart(P, P)
    assert all(math.isnan(c.length) for c in mech.closures)
    set_leg_lengths(mech, [1, 2, 3, 4, 5, 6])
    assert [c.length for c in mech.closures] == [1, 2, 3, 4, 5, 6]
    with pytest.raises(InputError, match="shape"):
        set_leg_lengths(mech, [1, 2])
    with pytest.raises(InputError, match="positive"):
        set_leg_lengths(mech, [1, 2, 3, 4, 5, -6])
    with pytest.raises(InputError, match="platform_points"):
        stewart(P, P[:5])
    with pytest.raises(InputError, match="base_points"):
        stewart([[0, 0]], [[0, 0, 0]])
    bad = P.copy()
    bad[2, 1] = np.inf
    with pytest.raises(InputError, match="non-finite"):
        stewart(bad, P)


# -- four-bar -------------------------------------------------------------------------------------
def test_four_bar_closes():
    mech = four_bar(3.0, 1.0, 3.0, 2.0)
    model = mech.model
    assert [model.names[i] for i in range(1, 4)] == ["crank", "coupler", "rocker"]
    assert all(model.joints[i].shortname() == "JointModelRZ" for i in range(1, 4))
    (c,) = mech.closures
    assert (c.kind, c.name, c.joint_a, c.joint_b) == ("point", "ground_pivot", 3, 0)
    assert np.allclose(c.placement_b.translation, [3, 0, 0])
    mech.lock("crank", 0.7)
    q = assemble(mech, np.random.default_rng(0))
    assert abs(q[0] - 0.7) < 1e-15
    assert max_residual(mech, q) < 1e-9
    A = frame_pos(mech, q, "coupler")
    C = frame_pos(mech, q, "rocker")
    assert np.allclose(A, [math.cos(0.7), math.sin(0.7), 0])
    assert abs(np.linalg.norm(C - A) - 3.0) < 1e-9
    assert abs(np.linalg.norm(C - np.array([3.0, 0, 0])) - 2.0) < 1e-9
    assert np.allclose(frame_pos(mech, q, "rocker_tip"), [3, 0, 0], atol=1e-9)


def test_four_bar_bad_lengths():
    with pytest.raises(InputError, match="crank"):
        four_bar(3, -1, 3, 2)
    with pytest.raises(InputError, match="ground"):
        four_bar(float("nan"), 1, 3, 2)
    with pytest.raises(InputError, match="coupler_point"):
        four_bar(3, 1, 3, 2, coupler_point=[1, 2, 3])


# -- 3-RPR -----------------------------------------------------------------------------------
RPR_A = [[0, 0], [15.91, 0], [0, 10]]
RPR_B = [[0, 0], [17.04, 0], [20.84 * math.cos(0.882603), 20.84 * math.sin(0.882603)]]
RPR_RHO = [14.98, 15.38, 12.0]


def test_three_rpr_structure_and_assembly():
    mech = three_rpr(RPR_A, RPR_B, RPR_RHO)
    model = mech.model
    assert list(model.names)[1:] == ["base1", "leg1", "pivot1", "base2", "leg2", "base3", "leg3"]
    kinds = [model.joints[i].shortname() for i in range(1, 8)]
    assert kinds == ["JointModelRZ", "JointModelPX", "JointModelRZ"] + ["JointModelRZ", "JointModelPX"] * 2
    assert [c.name for c in mech.closures] == ["anchor2", "anchor3"]
    assert all(c.kind == "point" for c in mech.closures)
    assert set(mech.locked) == {"leg1", "leg2", "leg3"}
    assert np.all(np.isfinite(model.lowerPositionLimit)) and np.all(np.isfinite(model.upperPositionLimit))
    q = assemble(mech, np.random.default_rng(2))
    assert max_residual(mech, q) < 1e-9
    data = mech.model.createData()
    pin.framesForwardKinematics(model, data, q)
    Mp = data.oMf[model.getFrameId("platform")]
    for i in range(3):
        Bi = np.array(RPR_B[i] + [0.0])
        world = Mp.act(Bi)
        assert abs(world[2]) < 1e-12
        assert abs(np.linalg.norm(world - np.array(RPR_A[i] + [0.0])) - RPR_RHO[i]) < 1e-9
        assert np.allclose(frame_pos(mech, q, f"platform_anchor{i + 1}"), world, atol=1e-9)


def test_three_rpr_bad_inputs():
    with pytest.raises(InputError, match="base_points"):
        three_rpr(RPR_A[:2], RPR_B)
    with pytest.raises(InputError, match="planar"):
        three_rpr([[0, 0, 1], [1, 0, 0], [0, 1, 0]], RPR_B)
    with pytest.raises(InputError, match="leg_limits"):
        three_rpr(RPR_A, RPR_B, leg_limits=(5, 1))
    with pytest.raises(InputError, match="outside"):
        three_rpr(RPR_A, RPR_B, RPR_RHO, leg_limits=(0, 10))


# -- Delta -----------------------------------------------------------------------------------
def test_delta_structure_and_assembly():
    mech = delta(0.2, 0.05, 0.3, 0.8, arm_angles=[0.3, 0.5, 0.4])
    model = mech.model
    assert list(model.names)[1:] == ["arm1", "arm2", "arm3", "platform"]
    assert model.joints[4].shortname() == "JointModelTranslation"
    assert [c.name for c in mech.closures] == ["leg1", "leg2", "leg3"]
    assert all(c.kind == "distance" and c.length == 0.8 for c in mech.closures)
    assert np.all(np.isfinite(model.lowerPositionLimit)) and np.all(np.isfinite(model.upperPositionLimit))
    q0 = pin.neutral(model)
    q0[:3] = [0.3, 0.5, 0.4]
    q0[3:] = [0, 0, -0.8]
    q = assemble(mech, np.random.default_rng(0), scale=0.1, q0=q0)
    assert max_residual(mech, q) < 1e-9
    assert q[5] < 0  # found the mode below the base
    for i in range(3):
        e = frame_pos(mech, q, f"elbow{i + 1}")
        a = frame_pos(mech, q, f"platform_anchor{i + 1}")
        assert abs(np.linalg.norm(e - a) - 0.8) < 1e-9
    # q > 0 moves arm 1 (pointing along +x) down
    assert frame_pos(mech, q, "elbow1")[2] < 0


def test_delta_bad_inputs():
    with pytest.raises(InputError, match="forearm_length"):
        delta(0.2, 0.05, 0.3, 0)
    with pytest.raises(InputError, match="arm_angles"):
        delta(0.2, 0.05, 0.3, 0.8, arm_angles=[1, 2])
