"""General 6R arms by elimination and eigenvalues (kinbox.search.eigen6r, kinbox.answer.eigen6r):
the answer where the proof holds is the branch and prune's, as a set; where it does not, the
pose falls back to the branch and prune."""

from __future__ import annotations

import json
import math

import numpy as np
import pinocchio as pin
import pytest

import kinbox
from kinbox.formulation.arm import get_angle, put_angle
from kinbox.model.builders import dh_chain
from kinbox.search import eigen6r as E
from tests.support import fuzz_arms as fa
from tests.support import paths


def _serial6r(tmp_path) -> str:
    """The general 6R loop of the CuikSuite example (kinbox's built-in ``general-6r``: the loop
    prod Rx(alpha_i) Tx(a_i) Rz(theta_i) Tz(d_i) = I) as an arm whose tool must reach the identity."""
    dh = json.loads((paths.ROOT / "src" / "kinbox" / "robots" / "general-6r.json").read_text())["dh"]
    rows = [(r["alpha"], r["a"], r["d"], 0.0, "R") for r in dh]
    arm = fa.arm_from_dh("general_6r", np.random.default_rng(0), rows, gauge="random")
    for j in arm.joints:
        j.kind, j.lower, j.upper = "continuous", -math.pi, math.pi
    path = tmp_path / "serial6r.urdf"
    path.write_text(arm.urdf("serial6r"))
    return str(path)


def _values(model, res) -> list[np.ndarray]:
    return [fa.joint_values(model, s.q) for s in res.solutions]


def _same_sets(model, a, b) -> None:
    va, vb = _values(model, a), _values(model, b)
    assert len(va) == len(vb), (len(va), len(vb))
    for x in va:
        assert min(fa.value_distance(model, x, y) for y in vb) < 1e-6
    for y in vb:
        assert min(fa.value_distance(model, x, y) for x in va) < 1e-6


def test_serial6r_all_16_roots_as_the_search(tmp_path):
    path = _serial6r(tmp_path)
    ik = kinbox.IK(path, "tool")
    assert ik.closed_form is None and ik.eigen6r is not None
    res = ik.solve(pin.SE3.Identity())
    assert res.stats["method"] == "eigen-6r"
    assert res.complete and len(res.solutions) == 16  # the published count (Porta, Ros, Thomas 2009)
    assert all(s.certified for s in res.solutions)
    ref = ik.solve(pin.SE3.Identity(), closed_form=False)
    assert ref.stats["method"] == "branch-and-prune" and ref.complete
    _same_sets(ik.robot.model, res, ref)
    model = pin.buildModelFromXML(open(path).read())
    for s in res.solutions:
        assert fa.pose_error(model, "tool", s.q, pin.SE3.Identity()) < fa.FK_TOL


def test_the_published_general_6r_by_eigenvalues(reference):
    """The general 6R loop of Porta, Ros and Thomas 2009 (Table I) as the IK of its DH chain
    (kinbox's builder, not a URDF): its 16 real roots by the eigenvalue path, each closing the
    chain by Pinocchio's forward kinematics."""
    ref = reference("general_6r.json")
    mech = dh_chain(ref["dh"], closed=False, name="arm")
    ik = kinbox.IK(mech, "tool")
    res = ik.solve(pin.SE3.Identity())
    assert res.stats["method"] == "eigen-6r"
    assert res.complete and len(res.solutions) == ref["expected"]["real_solutions"]
    data = mech.model.createData()
    for s in res.solutions:
        assert s.certified
        pin.framesForwardKinematics(mech.model, data, s.q)
        assert np.abs(data.oMf[mech.model.getFrameId("tool")].homogeneous - np.eye(4)).max() < 1e-9


def test_elimination_holds_at_solutions(tmp_path):
    """P(t3) X(t4, t5) = Q Y(t1, t2) (the 14 equations) at configurations of a random arm, to
    the rounding; and the pencil has its factor (1 + x^2)^4: four eigenvalues at i and at -i."""
    case = fa.make_case("general_6r", 3, tmp_path)
    ik = kinbox.IK(case.robot, case.frame)
    es = ik.eigen6r
    geom = es.arm.geometry
    rng = np.random.default_rng(5)
    for _ in range(3):
        q = fa.config_from_values(case.model, rng.uniform(-3, 3, 6))
        goal = ik.pose_at(q)
        th = np.array([get_angle(q, j) for j in geom.chain.joints]) + geom.gamma
        mats = es.e6.matrices(*es.goal(goal.rotation, goal.translation))
        (Am, Ar), (Pm, Qm, _a, _b) = mats
        b = [np.array([math.cos(t), math.sin(t), 1.0]) for t in th]
        X = np.outer(b[3], b[4]).reshape(9)
        Y = np.outer(b[0], b[1]).reshape(9)[:8]
        lhs = np.einsum("k,krx,x->r", b[2], Pm, X)
        assert np.max(np.abs(lhs - Qm @ Y)) < 1e-9
        x3 = math.tan(th[2] / 2)
        assert np.min(np.linalg.svd(Am[0] + Am[1] * x3 + Am[2] * x3**2, compute_uv=False)) < 1e-9
        w, _ = E.eigen_candidates(Am)
        assert np.sum(np.abs(w - 1j) < 1e-3) == 4 and np.sum(np.abs(w + 1j) < 1e-3) == 4


@pytest.mark.parametrize("seed", [1, 2, 4])
def test_random_general_arms_agree_with_the_search(seed, tmp_path):
    case = fa.make_case("general_6r", seed, tmp_path)
    ik = kinbox.IK(case.robot, case.frame)
    assert ik.eigen6r is not None
    rng = np.random.default_rng(seed)
    goals = [case.goal] + [ik.pose_at(fa.config_from_values(case.model, rng.uniform(-3, 3, 6))) for _ in range(2)]
    methods = []
    for goal in goals:
        res = ik.solve(goal)
        ref = ik.solve(goal, closed_form=False, max_boxes=200_000)
        assert res.complete and ref.complete
        methods.append(res.stats["method"])
        _same_sets(case.model, res, ref)
    assert "eigen-6r" in methods


def _singular_configuration(model, frame: str, rng) -> np.ndarray:
    """A configuration where the frame Jacobian is singular: a sign change of its determinant
    along a segment, bisected."""
    data = model.createData()
    fid = model.getFrameId(frame)

    def det(v):
        q = fa.config_from_values(model, v)
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        return float(np.linalg.det(pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)))

    while True:
        a, b = rng.uniform(-3, 3, 6), rng.uniform(-3, 3, 6)
        if det(a) * det(b) < 0:
            break
    for _ in range(200):
        m = 0.5 * (a + b)
        if det(a) * det(m) <= 0:
            b = m
        else:
            a = m
    return fa.config_from_values(model, 0.5 * (a + b))


def test_theta3_at_pi_falls_back(tmp_path):
    """A root with t3 = pi has x3 = tan(t3 / 2) at infinity (A2 singular): not one of 16 finite
    eigenvalues proven with their roots, so the pose goes to the branch and prune, which finds it."""
    path = _serial6r(tmp_path)
    ik = kinbox.IK(path, "tool")
    model = pin.buildModelFromXML(open(path).read())
    geom = ik.eigen6r.arm.geometry
    th = np.array([0.4, -1.1, math.pi, 0.7, 2.0, -0.3])
    q = geom.chain.q_ref.copy()
    for j, t, gam in zip(geom.chain.joints, th, geom.gamma):
        put_angle(q, j, float(t - gam))
    goal = ik.pose_at(q)
    res = ik.solve(goal)
    assert res.stats["method"] == "branch-and-prune" and res.complete
    assert any(fa.value_distance(model, fa.joint_values(model, s.q), fa.joint_values(model, q)) < 1e-6 for s in res.solutions)


@pytest.mark.slow
def test_a_singular_pose_falls_back(tmp_path):
    """At a singular configuration two roots meet: no 16 simple eigenvalues, so the proof
    fails and the branch and prune answers."""
    path = _serial6r(tmp_path)
    ik = kinbox.IK(path, "tool")
    model = pin.buildModelFromXML(open(path).read())
    q = _singular_configuration(model, "tool", np.random.default_rng(2))
    goal = ik.pose_at(q)
    es = ik.eigen6r
    assert es.candidates(goal.rotation, goal.translation) is None
    res = ik.solve(goal, max_boxes=200_000)
    assert res.stats["method"] == "branch-and-prune"
    assert any(fa.value_distance(model, fa.joint_values(model, s.q), fa.joint_values(model, q)) < 1e-4 for s in res.solutions)


def test_arms_of_lower_degree_fall_back(tmp_path):
    """A general positioning arm with a spherical wrist has at most 8 roots: eigenvalues at
    infinity, no proof of 16, so its poses go to the branch and prune."""
    case = fa.make_case("spherical_wrist", 1, tmp_path)
    ik = kinbox.IK(case.robot, case.frame)
    assert ik.closed_form is None and ik.eigen6r is not None
    assert ik.eigen6r.candidates(case.goal.rotation, case.goal.translation) is None
    res = ik.solve(case.goal)
    assert res.stats["method"] != "eigen-6r"


@pytest.mark.parametrize("seed", [2, 3])
def test_compiled_proof_agrees_with_the_numpy_reference(seed, tmp_path):
    """The compiled kernels (kinbox.search.eigen6r_kernel) and the numpy reference of the same
    proof (EigenSolver.candidates, certify_reference on the kinbox system) decide the same poses
    and give the same roots: each real eigenvalue's disc of one meets exactly one of the other's,
    and each root of one lies in the proof box of one root of the other."""
    case = fa.make_case("general_6r", seed, tmp_path)
    ik = kinbox.IK(case.robot, case.frame)
    es = ik.eigen6r
    tc = es.certifier
    rng = np.random.default_rng(seed + 10)
    goals = [case.goal] + [ik.pose_at(fa.config_from_values(case.model, rng.uniform(-3, 3, 6))) for _ in range(4)]
    for goal in goals:
        fast = E.certify(es, goal.rotation, goal.translation)
        ref = E.certify_reference(es, goal.rotation, goal.translation)
        assert (fast is None) == (ref is None)
        if fast is None:
            continue
        assert len(fast.theta) == len(ref.x)
        for th, lo, hi in zip(fast.theta, fast.lo, fast.hi):
            assert np.all(lo <= th) and np.all(th <= hi)
            c, s = ref.x[:, tc.cvar], ref.x[:, tc.svar]  # (k, 6): the reference roots' (cos, sin)
            near = np.max(np.abs(np.cos(th) - c) + np.abs(np.sin(th) - s), axis=1)
            assert np.sum(near < 1e-9) == 1
        cand = es.candidates(goal.rotation, goal.translation)
        st, m = es.pencil(goal.rotation, goal.translation)
        assert st == 0 and cand is not None
        w, vecs = np.linalg.eig(m["L"])
        centres, radii, vv = np.empty(16), np.empty(16), np.empty((12, 16))
        st, k = E.K.prove_count_kernel(m["Am"], m["Ar"], w.astype(complex), vecs.astype(complex), centres, radii, vv)
        assert st == 0 and k == len(cand.centre)
        for c, r in zip(centres[:k], radii[:k]):
            assert np.sum(np.abs(cand.centre - c) <= cand.radius + r) == 1


def test_eigen_answer_reads_as_a_search_answer(tmp_path):
    """The eigenvalue path's answer (built as the closed form's fast answer) gives the bound
    system and the solver-style record with one certified system box per solution on demand,
    each solution's point inside its box, and its JSON."""
    path = _serial6r(tmp_path)
    ik = kinbox.IK(path, "tool")
    res = ik.solve(pin.SE3.Identity())
    assert res.stats["method"] == "eigen-6r" and res.stats["certificate"] == "joint angles"
    assert res.formulated.system.n == len(res.solutions[0].x)
    boxes = res.raw.boxes
    assert len(boxes) == len(res.solutions) == 16 and all(b.certified for b in boxes)
    for s in res.solutions:
        assert sum(bool(np.all(b.lo - 1e-9 <= s.x) and np.all(s.x <= b.hi + 1e-9)) for b in boxes) == 1
        assert s.residual < 1e-9
    assert json.loads(json.dumps(res.to_dict()))["solutions"]
