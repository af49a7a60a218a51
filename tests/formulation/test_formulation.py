"""formulate(): sizes, round trips q -> system point -> q, and bad input.

System sizes (variables / core / redundant / inequalities), asserted below:

==========================================  ========================================
problem                                     size
==========================================  ========================================
UR5 IK (tool0)                              28 / 28 / 19 / 1   (square; 4 from its parallel joints)
Panda IK, panda_joint3 locked, fingers out  28 / 28 / 15 / 7   (square)
general 6R loop (Porta et al. 2009, T. I)   26 / 26 / 15 / 1   (square; paper: 45 / 51)
6-6 Stewart platform (Dietmeier)            27 / 27 / 3 / 0    (square; paper: 27 / 27)
planar four-bar (point closure)             8 / 7 / 2 / 0      (one degree of freedom)
==========================================  ========================================
"""

from __future__ import annotations

import json
import math

import numpy as np
import pinocchio as pin
import pytest
from scipy.optimize import least_squares

from kinbox.errors import FormulationError, InputError, KinboxError, ModelError, NameNotFound
from kinbox.formulation.build import formulate
from kinbox.formulation.decode import check
from kinbox.formulation.pairs import wrap_angle
from kinbox.model.mechanism import Closure, Mechanism
from tests.support import paths as PATHS
from tests.support.formulation_helpers import TOL, add_joint, q_error, random_q, roundtrip

REF = PATHS.DATA / "reference"
PI = math.pi


def core_jacobian_min_sv(form, x) -> float:
    """Smallest singular value of the core Jacobian (square systems: > 0 at a regular
    solution, which is what a Krawczyk test needs)."""
    C = form.system.compile()
    return float(np.linalg.svd(C.jacobian(x, slice(0, C.n_core)), compute_uv=False).min())


def sizes(form):
    s = form.system
    return (s.n, s.count("core"), s.count("redundant"), s.count("ineq"))


def T(v) -> pin.SE3:
    return pin.SE3(np.eye(3), np.asarray(v, dtype=float))


def Rx(a) -> pin.SE3:
    return pin.SE3(pin.exp3(np.array([a, 0.0, 0.0])), np.zeros(3))


# ----------------------------------------------------------------------------------------------
# example-robot-data arms, IK goals
# ----------------------------------------------------------------------------------------------
ROBOTS = {
    # name: (goal frame, joint to lock or None, expected sizes or None, dropped joints)
    "ur5": ("tool0", None, (28, 28, 19, 1), []),  # 4 redundant: its three parallel joints
    "panda": ("panda_hand_tcp", "panda_joint3", (28, 28, 15, 7), ["panda_finger_joint1", "panda_finger_joint2"]),
    "kinova": ("j2s6s200_end_effector", None, None, []),
    "xarm7": ("link_eef", "joint3", None, []),
    "z1": ("link06", None, None, ["jointGripper"]),
}


@pytest.fixture(scope="module")
def robot_models():
    erd = pytest.importorskip("example_robot_data")
    return {name: erd.load(name).model for name in ROBOTS}


def ik_mechanism(model, frame, q, lock=None, name="robot"):
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    mech = Mechanism(model, name=name)
    if lock:
        j = model.joints[model.getJointId(lock)]
        mech.lock(lock, q[j.idx_q : j.idx_q + j.nq])
    mech.add_goal(frame, data.oMf[model.getFrameId(frame)])
    return mech


@pytest.mark.parametrize("name", list(ROBOTS))
def test_robot_ik_roundtrip_and_square(robot_models, name):
    frame, lock, expected, dropped = ROBOTS[name]
    model = robot_models[name]
    rng = np.random.default_rng(7)
    for _ in range(3):
        q = random_q(model, rng)
        mech = ik_mechanism(model, frame, q, lock, name)
        form = roundtrip(mech, q)
        assert form.system.is_square, sizes(form)
        assert core_jacobian_min_sv(form, form.encode(q)) > 1e-4
        assert form.dropped_joints == dropped
        if expected:
            assert sizes(form) == expected
        active = [n for n in model.names[1:] if n not in dropped and n != lock]
        assert sorted(form.joint_vars) == sorted(active)
        for jn in active:
            assert f"c[{jn}]" in form.joint_vars[jn] and f"s[{jn}]" in form.joint_vars[jn]


def test_ur5_variable_names_and_tags(robot_models):
    model = robot_models["ur5"]
    q = random_q(model, np.random.default_rng(1))
    mech = ik_mechanism(model, "tool0", q)
    s = formulate(mech).system
    assert s.tags[s.index("c[shoulder_pan_joint]")] == "cos"
    assert s.tags[s.index("s[wrist_3_joint]")] == "sin"
    assert any(n.startswith("R[") or n.startswith("Rin[") for n in s.names)
    assert {s.tags[i] for i, n in enumerate(s.names) if n.startswith("R")} <= {"rot", "aux"}
    lo, hi = s.domain()
    assert np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))
    assert all(c.expr.degree <= 2 for c in s.constraints)


def test_kinova_continuous_and_limited_joints_decode(robot_models):
    model = robot_models["kinova"]
    rng = np.random.default_rng(3)
    q = random_q(model, rng)
    form = roundtrip(ik_mechanism(model, "j2s6s200_end_effector", q), q)
    q2 = form.decode(form.encode(q))
    j1 = model.joints[model.getJointId("j2s6s200_joint_1")]  # continuous: (cos, sin)
    assert j1.nq == 2 and abs(np.hypot(*q2[j1.idx_q : j1.idx_q + 2]) - 1) < 1e-15
    j2 = model.joints[model.getJointId("j2s6s200_joint_2")]  # limited to [0.82, 5.46]
    assert model.lowerPositionLimit[j2.idx_q] <= q2[j2.idx_q] <= model.upperPositionLimit[j2.idx_q]


def test_locked_joint_inside_the_chain(robot_models):
    model = robot_models["ur5"]
    q = random_q(model, np.random.default_rng(5))
    mech = ik_mechanism(model, "tool0", q, lock="elbow_joint")
    form = roundtrip(mech, q)
    assert "elbow_joint" not in form.joint_vars and form.dropped_joints == []
    s = form.system
    assert s.count("core") > s.n  # 5 joints for a 6-dof goal: over-determined
    q2 = form.decode(form.encode(q))
    assert q2[model.joints[3].idx_q] == mech.locked["elbow_joint"][0]


# ----------------------------------------------------------------------------------------------
# loops
# ----------------------------------------------------------------------------------------------
def four_bar(ground=1.0, crank=0.4, coupler=1.1, rocker=0.8, base=None):
    """Crank/coupler/rocker RZ chain; point closure of the rocker's end to the ground pivot.

    With ``base`` (a joint model), the linkage hangs from a moving base joint (left out).
    """
    model = pin.Model()
    parent = 0
    if base is not None:
        parent = add_joint(model, 0, base, pin.SE3(pin.exp3(np.array([0.3, 0.2, 0.1])), np.array([0.1, 0, 0.2])), "base")
    j1 = add_joint(model, parent, pin.JointModelRZ(), pin.SE3.Identity(), "crank")
    j2 = add_joint(model, j1, pin.JointModelRZ(), T([crank, 0, 0]), "coupler")
    j3 = add_joint(model, j2, pin.JointModelRZ(), T([coupler, 0, 0]), "rocker")
    mech = Mechanism(model, name="four-bar")
    mech.closures.append(Closure("point", j3, T([rocker, 0, 0]), parent, T([ground, 0, 0]), name="ground_pivot"))
    return mech


def four_bar_q(theta1, ground=1.0, crank=0.4, coupler=1.1, rocker=0.8, branch=1):
    B = crank * np.array([math.cos(theta1), math.sin(theta1)])
    D = np.array([ground, 0.0])
    dv = D - B
    dist = np.linalg.norm(dv)
    a = (coupler**2 - rocker**2 + dist**2) / (2 * dist)
    h = math.sqrt(coupler**2 - a**2)
    C = B + a * dv / dist + branch * h * np.array([-dv[1], dv[0]]) / dist
    phi2 = math.atan2(*(C - B)[::-1])
    phi3 = math.atan2(*(D - C)[::-1])
    return np.array([theta1, phi2 - theta1, phi3 - phi2])


def test_four_bar_sizes_and_roundtrip():
    mech = four_bar()
    for t1, br in ((0.3, 1), (2.0, -1), (-1.0, 1)):
        q = four_bar_q(t1, branch=br)
        assert check(mech, q)["max_position"] < 1e-12
        form = roundtrip(mech, q)
    # crank, coupler, rocker: 6 c/s; the coupler frame is materialized: its z entries are
    # constants and of the four that move two are the other two up to sign (a rotation about
    # z), so 2 variables; the rocker frame is only used in the loop equation and stays
    # bilinear. Loop: 2 equations (the z row is 0 = 0). Redundant: |u| = |v| = 1 (the same
    # row twice: kept once) and u . v = 0 (identically 0, dropped)
    assert sizes(form) == (8, 7, 1, 0)
    assert form.system.n - form.system.count("core") == 1  # one degree of freedom


def test_four_bar_on_a_moving_base_leaves_the_base_out():
    mech = four_bar(base=pin.JointModelRY())
    rng = np.random.default_rng(0)
    for _ in range(3):
        q = np.concatenate([[rng.uniform(-3, 3)], four_bar_q(rng.uniform(-3, 3))])
        assert check(mech, q)["max_position"] < 1e-12
        form = roundtrip(mech, q)  # the loop does not depend on the base angle
        assert form.dropped_joints == ["base"]
        assert form.decode(form.encode(q))[0] == 0.0  # dropped: pin.neutral


def test_distance_closure_loop():
    """Crank and coupler (RZ), the coupler's end at distance 0.8 from a ground point."""
    model = pin.Model()
    j1 = add_joint(model, 0, pin.JointModelRZ(), pin.SE3.Identity(), "crank", [-2.5], [2.5])
    j2 = add_joint(model, j1, pin.JointModelRZ(), T([0.4, 0, 0]), "coupler")
    mech = Mechanism(model, name="distance-loop")
    mech.closures.append(Closure("distance", j2, T([1.1, 0, 0]), 0, T([1.0, 0.2, 0]), length=0.8, name="rod"))
    rng = np.random.default_rng(2)
    for _ in range(3):
        t1 = rng.uniform(-1, 1)
        B = 0.4 * np.array([math.cos(t1), math.sin(t1)])
        # coupler end C on the circle |C - (1, 0.2)| = 0.8 at distance 1.1 from B
        D = np.array([1.0, 0.2])
        dv = D - B
        dist = np.linalg.norm(dv)
        a = (1.1**2 - 0.8**2 + dist**2) / (2 * dist)
        C = B + a * dv / dist + math.sqrt(1.1**2 - a**2) * np.array([-dv[1], dv[0]]) / dist
        q = np.array([t1, math.atan2(*(C - B)[::-1]) - t1])
        form = roundtrip(mech, q)
    assert sizes(form) == (7, 6, 0, 1)  # c, s twice, a unit vector; one degree of freedom
    assert form.closure_vars["rod"] == ["dir[rod][0]", "dir[rod][1]", "dir[rod][2]"]


def stewart_mechanism(limits=None):
    D = json.loads((REF / "dietmeier_66.json").read_text())
    P, Q, L = np.array(D["base_points"]), np.array(D["platform_points"]), np.array(D["leg_lengths"])
    model = pin.Model()
    lo = hi = None
    if limits is not None:
        lo = [-limits] * 3 + [-1.01] * 4
        hi = [limits] * 3 + [1.01] * 4
    add_joint(model, 0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "platform", lo, hi)
    mech = Mechanism(model, name="stewart")
    for i in range(6):
        mech.closures.append(Closure("distance", 1, T(Q[i]), 0, T(P[i]), length=float(L[i]), name=f"leg{i + 1}"))
    return mech, P, Q, L


def stewart_pose(P, Q, L):
    """An assembled pose by least squares: |t + R q_i - p_i| = l_i."""

    def res(z):
        R = pin.exp3(z[3:])
        return np.linalg.norm(z[:3] + Q @ R.T - P, axis=1) - L

    for seed in range(20):
        sol = least_squares(res, np.random.default_rng(seed).normal(size=6), xtol=1e-15, ftol=1e-15, gtol=1e-15)
        if np.abs(sol.fun).max() < 1e-14:
            return np.concatenate([sol.x[:3], pin.Quaternion(pin.exp3(sol.x[3:])).coeffs()])
    raise AssertionError("no assembled pose found")  # pragma: no cover


def test_stewart_platform_27_by_27():
    mech, P, Q, L = stewart_mechanism()
    q = stewart_pose(P, Q, L)
    form = roundtrip(mech, q)
    s = form.system
    # 9 rotation entries + 6 unit vectors; the platform translation (3) is eliminated
    assert (s.n, s.count("core")) == (27, 27), "the paper's count: 27 equations in 27 variables"
    # redundant: the rotation's third column (3), the squared form of legs 2-6 (5)
    assert sizes(form) == (27, 27, 8, 0)
    assert core_jacobian_min_sv(form, form.encode(q)) > 1e-4
    assert sorted(s.eliminated) == ["t[platform][0]", "t[platform][1]", "t[platform][2]"]
    assert form.joint_vars == {"platform": [f"R[platform][{r},{k}]" for k in range(3) for r in range(3)]}


def test_vector_legs_get_their_squared_form_and_are_derived():
    """Each leg vector whose loop rows read ``e + c d = 0`` (``e`` linear) gets ``sum (e/c)^2 = 1``
    as a redundant row, and is derived (not split, not bounded by LPs) unless another leg's rows
    read it: the first leg's vector, which the eliminated platform translation became."""
    mech, P, Q, L = stewart_mechanism()
    form = formulate(mech, legs="vector")
    s = form.system
    legs = [c.name for c in s.constraints if c.name.startswith("leg:")]
    assert legs == [f"leg:{n}" for n in form.closure_vars][1:]
    assert all(c.kind == "redundant" for c in s.constraints if c.name in legs)
    first = set(next(iter(form.closure_vars.values())))
    for i, nm in enumerate(s.names):
        if nm.startswith("dir["):
            assert (s.tags[i] == "aux") == (nm not in first), nm
    assert int(s.independent().sum()) == 9  # the rotation's two columns and the first leg
    comp = s.compile()
    rows = [comp.row_names.index(n) for n in legs]
    # the row is |d|^2 - 1 with d from the loop rows, anywhere: random rotation columns and first
    # leg, the other legs' vectors solved from their (linear) loop rows
    rng = np.random.default_rng(0)
    loops = {c.name: c.expr for c in s.constraints if c.name.startswith("loop:")}
    for _ in range(5):
        x = rng.uniform(-1, 1, s.n)
        for leg, names in form.closure_vars.items():
            if f"leg:{leg}" not in legs:
                continue
            for k, nm in enumerate(names):
                d = s.index(nm)
                x[d] = 0.0
                e = loops[f"loop:{leg}[{k}]"]
                x[d] = -e.value(x) / e.terms[(d,)]
        vals = comp.eval_rows(x)[rows]
        want = [sum(x[s.index(nm)] ** 2 for nm in form.closure_vars[n[4:]]) - 1.0 for n in legs]
        assert np.allclose(vals, want, atol=1e-12)
    # and zero at an assembly, as every redundant row
    q = stewart_pose(P, Q, L)
    assert np.max(np.abs(comp.eval_rows(form.encode(q))[rows])) < 1e-12
    # squared legs (a bounded translation): no leg vector, nothing to add
    bounded = formulate(stewart_mechanism(limits=3.0)[0], legs="squared").system
    assert not [c for c in bounded.constraints if c.name.startswith("leg:")]


def test_stewart_with_translation_limits_is_compact():
    # limited translation: legs become |t + R q_i - p_i|^2 = l_i^2 (12 variables: R and t),
    # and the limits are the domain of t
    mech, P, Q, L = stewart_mechanism(limits=3.0)
    q = stewart_pose(P, Q, L)
    form = roundtrip(mech, q)
    assert sizes(form)[:2] == (12, 12) and form.system.is_square
    s = form.system
    lo, hi = s.domain()
    x = form.encode(q)
    assert np.all(lo <= x) and np.all(x <= hi)
    it = s.index("t[platform][0]")
    assert lo[it] == pytest.approx(-3.0, abs=1e-6) and hi[it] == pytest.approx(3.0, abs=1e-6)
    q_far = q.copy()
    q_far[0] = 3.5  # beyond the limit: outside the domain
    assert form.encode(q_far)[it] > hi[it]


def general_6r():
    dh = json.loads((REF / "general_6r.json").read_text())["dh"]
    model = pin.Model()
    parent, d_prev = 0, 0.0
    for i, row in enumerate(dh):
        M = T([0, 0, d_prev]) * Rx(row["alpha"]) * T([row["a"], 0, 0])
        parent = model.addJoint(parent, pin.JointModelRZ(), M, f"j{i + 1}")
        d_prev = row["d"]
    mech = Mechanism(model, name="general-6r")
    mech.closures.append(Closure("weld", parent, T([0, 0, d_prev]), 0, pin.SE3.Identity(), name="loop"))
    return mech, d_prev


def test_general_6r_loop_is_square_and_smaller_than_the_paper():
    """prod Rx(alpha_i) Tx(a_i) Rz(theta_i) Tz(d_i) = I as an RZ chain welded to the world.

    The paper's formulation of this loop has 45 variables and 51 equations; ours has
    26 variables and 26 core equations (plus 15 redundant ones and 1 inequality).
    """
    mech, d6 = general_6r()
    model = mech.model
    data = model.createData()

    def res(q):
        pin.forwardKinematics(model, data, q)
        return pin.log6(data.oMi[6] * T([0, 0, d6])).vector

    found = 0
    for seed in range(30):
        sol = least_squares(res, np.random.default_rng(seed).uniform(-3, 3, 6), xtol=1e-15, ftol=1e-15, gtol=1e-15)
        if np.abs(sol.fun).max() < 1e-14:
            form = roundtrip(mech, sol.x)
            found += 1
            if found == 2:
                break
    assert found == 2
    s = form.system
    assert s.is_square and sizes(form) == (26, 26, 15, 1)
    assert core_jacobian_min_sv(form, form.encode(sol.x)) > 1e-4
    assert s.n < 45 and s.count("core") + s.count("redundant") < 51 + 1


def test_weld_between_two_moving_chains_closes_the_orientation_cycle():
    """Two 3R chains from the world welded tip to tip: the weld's orientation part is a
    closing equation (both tips are reached from the world), the system is square."""
    from tests.support.formulation_helpers import random_placement

    rng = np.random.default_rng(11)
    model = pin.Model()
    tips = []
    for chain in "ab":
        parent = 0
        for k in range(3):
            jm = [pin.JointModelRX(), pin.JointModelRY(), pin.JointModelRZ()][k]
            parent = add_joint(model, parent, jm, random_placement(rng), f"{chain}{k}")
        tips.append(parent)
    q = random_q(model, rng)
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    rel = data.oMi[tips[1]].inverse() * data.oMi[tips[0]]
    mech = Mechanism(model, name="two-chains")
    mech.closures.append(Closure("weld", tips[0], pin.SE3.Identity(), tips[1], rel, name="tips"))
    form = roundtrip(mech, q)
    s = form.system
    assert s.is_square and any(c.name.startswith("weld:tips") for c in s.constraints)
    assert core_jacobian_min_sv(form, form.encode(q)) > 1e-6


def _axis_rows(form):
    return {c.name: c for c in form.system.constraints if c.name.startswith(("axis-loop", "axis-run"))}


def test_ur5_parallel_joints_give_the_closed_form_base_equation(robot_models):
    """The UR5's three parallel joints: the loop projected on their common axis is linear in
    the base angle's (c, s) alone, as in the closed-form solution; its two roots on the
    circle include the base angle of the configuration that reached the pose."""
    model = robot_models["ur5"]
    rng = np.random.default_rng(3)
    for _ in range(3):
        q = random_q(model, rng)
        form = roundtrip(ik_mechanism(model, "tool0", q, name="ur5"), q)
        rows = _axis_rows(form)
        loop = rows["axis-loop:goal:shoulder_lift_joint"].expr
        names = form.system.names
        assert {names[i] for i in loop.variables()} == {"c[shoulder_pan_joint]", "s[shoulder_pan_joint]"}
        assert loop.degree == 1 and len(rows) == 4
        x = form.encode(q)
        assert all(abs(c.expr.value(x)) < 1e-12 for c in rows.values())
        # a c + b s + k = 0 on the unit circle: two base angles, one of them q[0]
        a = loop.terms[(names.index("c[shoulder_pan_joint]"),)]
        b = loop.terms[(names.index("s[shoulder_pan_joint]"),)]
        k = loop.constant
        r, phi = math.hypot(a, b), math.atan2(b, a)
        roots = [phi + sg * math.acos(-k / r) for sg in (1, -1)]
        assert min(abs(wrap_angle(t - q[0])) for t in roots) < 1e-9
        # not an identity: another configuration (another pose) violates it
        assert abs(loop.value(form.encode(random_q(model, rng)))) > 1e-6


def test_parallel_run_on_the_far_side_of_a_loop_holds_at_its_configurations():
    """Two chains from the world joined by a point closure; the second (RZ RZ RZ) is a run of
    parallel joints on the ``pb`` side of the loop (the UR5's is on the ``pa`` side). Its
    projected loop is zero at configurations that close the loop and not elsewhere. The
    first chain's pair of parallel RY joints gives none here: the projection would be of
    degree 3. A run whose axes are only nearly parallel (1e-9 rad) is cut there."""
    from tests.support.formulation_helpers import random_placement

    rng = np.random.default_rng(5)

    def build(tilt):
        model = pin.Model()
        tips, parent = [], 0
        for k, jm in enumerate([pin.JointModelRX(), pin.JointModelRY(), pin.JointModelRY()]):
            pl = random_placement(rng) if k == 0 else T(rng.uniform(-0.5, 0.5, 3))
            parent = add_joint(model, parent, jm, pl, f"a{k}")
        tips.append(parent)
        parent = 0
        for k in range(3):
            pl = random_placement(rng) if k == 0 else T(rng.uniform(-0.5, 0.5, 3))
            parent = add_joint(model, parent, pin.JointModelRZ(), Rx(tilt) * pl if k == 1 else pl, f"b{k}")
        tips.append(parent)
        return model, tips

    model, tips = build(0.0)
    q = random_q(model, rng)
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    pb = data.oMi[tips[1]].inverse() * data.oMi[tips[0]] * T([0.1, 0.2, 0.3])
    mech = Mechanism(model, name="two-runs")
    mech.closures.append(Closure("point", tips[0], T([0.1, 0.2, 0.3]), tips[1], pb, name="tips"))
    form = roundtrip(mech, q)
    rows = _axis_rows(form)
    assert sorted(rows) == ["axis-loop:tips:b0"]
    loop = rows["axis-loop:tips:b0"].expr
    assert abs(loop.value(form.encode(q))) < 1e-12
    assert abs(loop.value(form.encode(random_q(model, rng)))) > 1e-6  # does not close the loop

    model, tips = build(1e-9)
    mech = Mechanism(model, name="tilted")
    mech.closures.append(Closure("point", tips[0], pin.SE3.Identity(), tips[1], pin.SE3.Identity()))
    rows = _axis_rows(formulate(mech))
    assert "axis-loop:point0:b1" in rows and "axis-loop:point0:b0" not in rows


# ----------------------------------------------------------------------------------------------
# bookkeeping
# ----------------------------------------------------------------------------------------------
def test_no_closure_drops_everything():
    mech = four_bar()
    mech.closures.clear()
    form = formulate(mech)
    assert form.system.n == 0 and form.dropped_joints == ["crank", "coupler", "rocker"]
    assert np.array_equal(form.decode(np.zeros(0)), pin.neutral(mech.model))


def test_wrap_angle():
    assert wrap_angle(-PI) == PI and wrap_angle(3 * PI / 2) == pytest.approx(-PI / 2)
    assert wrap_angle(-1.0, 1.0, 5.5) == pytest.approx(2 * PI - 1.0)
    assert wrap_angle(0.1, -2 * PI, 2 * PI) == 0.1


def test_check_reports_each_closure():
    mech = four_bar()
    q = four_bar_q(0.5)
    c = check(mech, q)
    assert set(c["closures"]) == {"ground_pivot"} and c["max_position"] < 1e-12
    c = check(mech, q + 0.1)
    assert c["closures"]["ground_pivot"]["position"] > 1e-3 and c["max_orientation"] == 0.0


# ----------------------------------------------------------------------------------------------
# bad input
# ----------------------------------------------------------------------------------------------
def test_unknown_names_raise(robot_models):
    model = robot_models["ur5"]
    mech = Mechanism(model, name="ur5")
    with pytest.raises(NameNotFound, match="no_such_frame"):
        mech.add_goal("no_such_frame", pin.SE3.Identity())
    with pytest.raises(NameNotFound, match="no_such_joint"):
        mech.lock("no_such_joint", 0.0)
    mech.add_goal("tool0", pin.SE3.Identity())
    mech.locked["no_such_joint"] = np.array([0.0])  # bypassing lock()
    with pytest.raises(NameNotFound, match="no_such_joint"):
        formulate(mech)


def test_bad_numbers_raise():
    mech = four_bar()
    mech.closures.append(Closure("point", 1, T([math.nan, 0, 0]), 0, T([0, 0, 0]), name="bad"))
    with pytest.raises(KinboxError, match="bad"):
        formulate(mech)
    mech = four_bar()
    mech.closures.append(Closure("distance", 1, T([0, 0, 0]), 0, T([0, 0, 0]), length=math.nan, name="rod"))
    with pytest.raises(FormulationError, match="rod"):
        formulate(mech)
    mech = four_bar()
    mech.locked["crank"] = np.array([math.inf])
    with pytest.raises(InputError, match="crank"):
        formulate(mech)


def test_closure_on_a_missing_joint_raises():
    mech = four_bar()
    mech.closures.append(Closure("point", 42, pin.SE3.Identity(), 0, pin.SE3.Identity(), name="ghost"))
    with pytest.raises(ModelError, match="ghost.*42"):
        formulate(mech)


def test_encode_decode_reject_bad_vectors():
    mech = four_bar()
    form = formulate(mech)
    with pytest.raises(InputError):
        form.encode(np.zeros(5))
    with pytest.raises(InputError):
        form.encode(np.array([0.0, math.nan, 0.0]))
    with pytest.raises(InputError):
        form.decode(np.zeros(form.system.n + 1))
    q = four_bar_q(0.2)
    assert q_error(form, q, form.decode(form.encode(q))) < TOL


def test_formulation_pickles():
    """Formulations travel to worker processes: no lambdas, no Pinocchio joint objects inside."""
    import pickle

    mech, P, Q, L = stewart_mechanism(limits=3.0)
    q = stewart_pose(P, Q, L)
    form = formulate(mech)
    copy = pickle.loads(pickle.dumps(form))
    assert np.array_equal(copy.encode(q), form.encode(q))
    assert np.array_equal(copy.decode(form.encode(q)), form.decode(form.encode(q)))
