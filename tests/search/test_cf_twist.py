"""The closed form on arms whose link rotations are no signed permutations (a twist that is no
multiple of a right angle, a right angle written to 15 digits): the kernels take enclosures of the
links' orthogonal polar factors (kinbox.search.cf_delta.kernel_links), the goal's widening is
proven against that arm, and the closed form decides the poses itself: every certified box
holds the 40-digit root of the model as given, the same roots as the branch and prune's."""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pytest

import kinbox
from kinbox.search import cf_delta
from tests.support import kr6_dh
from tests.support.arms import _same_sets
from tests.support.curves import judge
from tests.support.kr6_dh import TWISTED


@pytest.fixture(scope="module", params=sorted(TWISTED))
def twisted(request, tmp_path_factory):
    family = request.param
    path = tmp_path_factory.mktemp("twisted") / f"{family}.urdf"
    path.write_text(kr6_dh.urdf(TWISTED[family], name=f"twisted_{family.replace('-', '_')}"))
    ik = kinbox.IK(str(path), "tool0")
    assert ik.closed_form is not None and ik.closed_form.family.name == family
    return ik


def _polar(X):
    """The orthogonal polar factor of ``X`` at the working precision (Newton: ``Q <- (Q + Q^-T) / 2``)."""
    Q = mp.matrix(X)
    for _ in range(10):  # quadratic from within 1e-15 of orthogonal: far below 60 digits after 6
        Q = (Q + mp.inverse(Q).T) / 2
    return Q


def _rx(a):
    c, s = mp.cos(a), mp.sin(a)
    return mp.matrix([[1, 0, 0], [0, c, -s], [0, s, c]])


def _rz(a):
    c, s = mp.cos(a), mp.sin(a)
    return mp.matrix([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def test_orthogonal_radii_hold_the_polar_factor():
    """Binary64 roundings of rotations (general ones, and ``Rz`` blocks whose ``z`` row and
    column are exactly ``e_z``): each entry of the polar factor, at 60 digits, lies within its
    radius of the binary64 matrix, and the rows and columns that are exactly unit vectors are
    the polar factor's own (radius 0); a signed permutation has radius 0."""
    rng = np.random.default_rng(4)
    mp.mp.dps = 60
    mats = [_rz(float(a)) * _rx(float(b)) * _rz(float(c)) for a, b, c in rng.uniform(-3, 3, (20, 3))]
    mats += [_rz(float(a)) for a in rng.uniform(-3, 3, 5)] + [_rx(mp.pi / 2), _rx(mp.pi / 6)]
    for M in mats:
        X = np.array([[float(M[i, j]) for j in range(3)] for i in range(3)])
        e = cf_delta.orthogonal_radii(X)
        assert e is not None
        Q = _polar(mp.matrix(X.tolist()))
        assert mp.det(Q) > 0
        for i in range(3):
            for j in range(3):
                assert abs(Q[i, j] - mp.mpf(float(X[i, j]))) <= mp.mpf(float(e[i, j])), (X, i, j)
        assert np.all(e <= 1e-15)
        for k in range(3):
            if np.abs(X[k]).sum() == 1.0 and np.abs(X[:, k]).sum() == 1.0:
                assert not np.any(e[k]) and not np.any(e[:, k])
    P = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]])
    assert not np.any(cf_delta.orthogonal_radii(P))
    assert cf_delta.orthogonal_radii(np.eye(3) * 0.5) is None  # no rotation near it: no bound


def test_kernel_links_keep_the_structure_exact(twisted):
    """The twisted arms' kernels take enclosures (the bound proven against the polar factors'
    arm), whose entries fixed by the family's structure (a link between parallel lines: its
    ``z`` row and column ``+-e_z``) are points, and which hold the binary64 links."""
    cf = twisted.closed_form
    assert cf.delta.proven and cf.LR.ndim == 4
    LR = cf.family.LR
    assert np.all(cf.LR[..., 0] <= LR) and np.all(LR <= cf.LR[..., 1])
    assert np.any(cf.LR[..., 0] < cf.LR[..., 1])
    parallel = [1] if cf.family.name == "wrist-parallel" else [1, 2]
    for i in parallel:
        assert np.all(cf.LR[i, 2, :, 0] == cf.LR[i, 2, :, 1]) and np.all(cf.LR[i, :, 2, 0] == cf.LR[i, :, 2, 1])
        assert abs(cf.LR[i, 2, 2, 0]) == 1.0


def _configurations(ik, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    qs = rng.uniform(-2.5, 2.5, (n, 6))
    qs[:, 4] = np.sign(qs[:, 4]) * np.maximum(np.abs(qs[:, 4]), 0.3)  # away from the wrist singularity
    qs[:, 2] = np.sign(qs[:, 2]) * np.maximum(np.abs(qs[:, 2]), 0.3)  # and from a straight elbow
    return qs


def _check_pose(ik, q, branch_and_prune: bool = True) -> None:
    goal = ik.pose_at(q)
    res = ik.solve(goal)
    assert res.stats["method"] == "closed-form" and res.status == "complete", res.stats
    rep = judge(ik, goal, res, q)
    assert rep["real"] == rep["certified"] == len(res.solutions), rep
    assert rep["lost"] == rep["cert_missing"] == rep["merged"] == rep["duplicates"] == 0, rep
    if branch_and_prune:
        bp = ik.solve(goal, closed_form=False)
        assert bp.stats["method"] == "branch-and-prune"
        assert _same_sets(ik, res, bp, tol=1e-9)


def test_a_twisted_arm_is_decided_by_the_closed_form(twisted):
    """Poses of each twisted arm: answered by the closed form (no branch and prune), each root
    certified in a box that holds the 40-digit root of the model as given, none lost, the same
    roots as the branch and prune's (on the UR-like arm, whose branch and prune and 40-digit
    roots take seconds a pose, one pose and no branch and prune: the slow suite has more)."""
    ur_like = twisted.closed_form.family.name == "parallel"
    for q in _configurations(twisted, 1 if ur_like else 2, seed=7):
        _check_pose(twisted, q, not ur_like)


@pytest.mark.slow
def test_many_poses_of_a_twisted_arm(twisted):
    for q in _configurations(twisted, 25, seed=8):
        _check_pose(twisted, q)


def test_a_twisted_arms_batch_is_decided_by_the_closed_form(twisted):
    """``solve_array`` over poses of a twisted arm: every pose by the closed form, the same
    roots as one pose at a time."""
    import pinocchio as pin

    qs = _configurations(twisted, 6, seed=9)
    poses = [twisted.pose_at(q) for q in qs]
    ans = twisted.solve_array(np.array([pin.SE3ToXYZQUAT(p) for p in poses]))
    assert ans.method == ["closed-form"] * len(poses)
    for k, p in enumerate(poses):
        one = twisted.solve(p)
        assert ans.count[k] == len(one.solutions) and ans.certified[ans.first[k] : ans.first[k] + ans.count[k]].all()


def test_a_twisted_arms_workspace_boxes_are_decided(twisted):
    """The workspace's closed-form verdicts on a twisted arm (the kernels with enclosed links;
    the centred form, which takes binary64 links only, leaves its boxes to the rest): a box
    about a reached position inside, with a witness reaching its centre; a box beyond the
    reach outside."""
    import pinocchio as pin

    from kinbox.workspace import INSIDE, OUTSIDE, Reach

    q = _configurations(twisted, 1, seed=10)[0]
    goal = twisted.pose_at(q)
    r = Reach(twisted, pin.SE3ToXYZQUAT(goal)[3:], "auto")
    v, w, st = r.decide(np.array([2.0, 2.0, 2.0]), np.array([2.1, 2.1, 2.1]), 0.05)
    assert v == OUTSIDE and st["closed_form"] >= 1
    lo, hi = goal.translation - 0.002, goal.translation + 0.002
    v, w, _ = r.decide(lo, hi, 0.05)
    assert v == INSIDE
    assert np.allclose(twisted.pose_at(w).translation, 0.5 * (lo + hi), atol=1e-9)
