"""The closed form over a box of positions in centred form (kinbox.workspace.centred): its
enclosures hold the values at every position of the box, its roots those of the closed form at
sampled positions, and its verdicts agree with the closed form at sampled positions next to the
workspace's border, where the plain enclosure decides less."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from kinbox.pipeline import IK
from kinbox.search import closed_form as C
from kinbox.search.closed_form import MAX_ROOTS
from kinbox.workspace import Reach
from kinbox.workspace import centred as ct
from kinbox.workspace.arm import _eighths, _verdicts
from tests.support.arms import ARMS

QUAT = (1.0, 0.0, 0.0, 0.0)


@pytest.fixture(scope="module")
def ur5():
    ik = IK("ur5", "tool0", formulation="arm")
    r = Reach(ik, QUAT)
    assert r.closed_form() is not None and r.closed_form().code in ct.CENTRED_FAMILIES
    return r


def _position(c, r, M):
    """The centred vector ``M p`` of a position ``p`` within ``r`` of ``c``."""
    out = []
    for i in range(3):
        m = float(M[i] @ c)
        e = 1e-15 * (1.0 + abs(m))
        v = (m - float(np.abs(M[i]) @ r) - e, m + float(np.abs(M[i]) @ r) + e)
        out.append(((m - e, m + e), v, (M[i, 0], M[i, 0]), (M[i, 1], M[i, 1]), (M[i, 2], M[i, 2])))
    return tuple(out)


def test_centred_arithmetic_encloses_a_function_at_every_position_of_the_box():
    """``|M p|^2``, its square root, a quotient and a rotation by the angle they define, over a
    box: the box enclosure holds the value at random positions, and is narrower than the plain
    interval value (the dependencies of the terms of a difference cancel in the mean-value form)."""
    rng = np.random.default_rng(3)
    narrower = 0
    for _ in range(50):
        M = rng.normal(size=(3, 3))
        c = rng.normal(size=3)
        r = 10 ** rng.uniform(-4, -1) * rng.uniform(0.2, 1.0, 3)
        t = _position(c, r, M)
        n2 = ct.vnorm2(t, r)
        n = ct.csqrt(n2, r)
        cos = ct.cdiv(t[0], n, r)
        sin = ct.cdiv(t[1], n, r)
        u = ct.rzt(cos, sin, t, r)
        d = ct.csub(ct.vnorm2(u, r), n2, r)  # each term of the order of |t|^2, their difference smaller
        pt = tuple(q[1] for q in t)  # the same in plain interval arithmetic
        pn2 = C.vnorm2(pt)
        pn = C.isqrt(pn2)
        pu = C.rzt(C.idiv(pt[0], pn), C.idiv(pt[1], pn), pt)
        pd = C.isub(C.vnorm2(pu), pn2)
        assert d[1][1] - d[1][0] <= pd[1] - pd[0]
        narrower += (d[1][1] - d[1][0]) < 0.5 * (pd[1] - pd[0])
        for p in c + rng.uniform(-1, 1, (40, 3)) * r:
            x = M @ p
            nn = float(x @ x)
            cc, ss = x[0] / np.sqrt(nn), x[1] / np.sqrt(nn)
            uu = np.array([cc * x[0] + ss * x[1], cc * x[1] - ss * x[0], x[2]])
            for q, val in ((n2, nn), (n, np.sqrt(nn)), (cos, cc), (sin, ss), (u[0], uu[0]), (u[1], uu[1]), (d, uu @ uu - nn)):
                assert q[1][0] <= val <= q[1][1], (q, val)
                assert q[0][0] <= q[0][1]
    assert narrower >= 40


def _border_boxes(r, side, count, rng, start=None):
    """Boxes of side ``side`` near the border of ``r``'s map: from a reached position ``start``,
    a ray to one not reached, bisected to the border, a box put at a random offset of up to
    two sides from it."""
    cf = r.closed_form()

    def reached(p):
        n, _, ins = cf.roots(r.R, p)
        return n > 0 and bool(np.any(ins[: max(n, 0)] == 1))

    start = 0.3 * np.array([1.0, 0.0, 0.0]) if start is None else start
    assert reached(start)
    out = []
    while len(out) < count:
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        a, b = start, start + 2.5 * u
        if reached(b):
            continue
        for _ in range(40):
            m = 0.5 * (a + b)
            a, b = (m, b) if reached(m) else (a, m)
        c = a + rng.uniform(-2.0, 2.0, 3) * side
        out.append((c - 0.5 * side, c + 0.5 * side))
    return out, reached


def _plain(r, lo, hi):
    """The verdicts of the plain interval closed form alone (kinbox.workspace.arm._verdicts)."""
    cf = r.closed_form()
    c = 0.5 * (lo + hi)
    Rlo, Rhi, tlo, thi = cf.goal_arrays(np.broadcast_to(r.R, (len(c), 3, 3)), c)
    out = np.zeros(len(c), dtype=np.int8)
    J = -(cf.A.rotation @ r.R.T) if cf.reversed else cf.A.rotation
    rad = np.nextafter(0.5 * (hi - lo), np.inf)
    _verdicts(cf.code, cf.LR, cf.Lt, cf.d, cf.limits, Rlo, Rhi, tlo, thi, np.ascontiguousarray(np.abs(J)), rad, out)
    return out


def _check_border(r, start, rng, side=0.004, count=150, each=10):
    boxes, reached = _border_boxes(r, side, count, rng, start)
    lo = np.array([b[0] for b in boxes])
    hi = np.array([b[1] for b in boxes])
    v = r.closed_form_batch(lo, hi)
    plain = _plain(r, lo, hi)
    assert np.all((plain < 0) | (plain == v))  # the centred form is tried only where the plain one fails
    assert np.sum((plain < 0) & (v >= 0)) >= 10
    assert np.sum(v == 1) >= each and np.sum(v == 0) >= each
    for k in np.flatnonzero(v >= 0):
        corners = [np.where(np.array(b, dtype=bool), hi[k], lo[k]) for b in np.ndindex(2, 2, 2)]
        for p in [*corners, *rng.uniform(lo[k], hi[k], (8, 3))]:
            assert reached(p) == (v[k] == 1), (lo[k], hi[k], v[k], p)


def test_verdicts_next_to_the_border_agree_with_the_closed_form_at_sampled_positions(ur5):
    """Boxes of 4 mm within two sides of the UR5's border (tool down): every box the centred
    form proves inside has a root within the limits at each sampled position (its corners among
    them), every box it proves outside none; and it decides boxes the plain enclosure leaves
    undecided."""
    _check_border(ur5, None, np.random.default_rng(11))


@pytest.mark.parametrize("robot,frame,lock,family", [a for a in ARMS if a[3] != "parallel"])
def test_the_spherical_wrist_families_next_to_the_border(robot, frame, lock, family):
    """The same for the spherical-wrist families (a Panda with a joint locked: a chain solved
    from the hand, with joint limits), at the orientation and from the position of a random
    configuration (a border at a joint's limit is decided less often: a root's enclosure
    there meets the limit)."""
    ik = IK(robot, frame, lock=lock, formulation="arm")
    rng = np.random.default_rng(2)
    model = ik.robot.model
    lo, hi = model.lowerPositionLimit, model.upperPositionLimit
    q = np.where(np.isfinite(lo) & np.isfinite(hi), lo + rng.uniform(0.1, 0.9, model.nq) * (hi - lo), pin.neutral(model))
    for name, val in lock.items():
        q[model.joints[model.getJointId(name)].idx_q] = val
    pose = ik.pose_at(q)
    quat = pin.Quaternion(pose.rotation).coeffs()
    r = Reach(ik, tuple(float(x) for x in quat))
    assert r.closed_form() is not None and r.closed_form().family.name == family
    _check_border(r, pose.translation, rng, count=60, each=2)


def test_roots_over_a_box_hold_the_roots_of_each_position(ur5):
    """Each root the centred form proves over a box near the border encloses a root of the
    closed form at each sampled position of the box (the same branch, followed across it)."""
    rng = np.random.default_rng(5)
    boxes, _ = _border_boxes(ur5, 0.004, 40, rng)
    cf = ur5.closed_form()
    J = cf.A.rotation
    Ji = np.ascontiguousarray(np.stack([J - 1e-12, J + 1e-12], axis=-1))
    checked = 0
    for lo, hi in boxes:
        c = 0.5 * (lo + hi)
        r = 0.5 * (hi - lo) * (1 + 1e-12) + 1e-300
        Rlo, Rhi, tlo, thi = cf.goal_arrays(ur5.R[None], c[None])
        R = tuple(tuple(ct.cconst((Rlo[0, i, j], Rhi[0, i, j])) for j in range(3)) for i in range(3))
        t = []
        for i in range(3):
            v = (tlo[0, i] - float(np.abs(J[i]) @ r) * 1.001, thi[0, i] + float(np.abs(J[i]) @ r) * 1.001)
            t.append(((tlo[0, i], thi[0, i]), v, *((Ji[i, j, 0], Ji[i, j, 1]) for j in range(3))))
        enc = np.zeros((MAX_ROOTS, 6, 4))
        n, _ = ct.planar_centred(cf.LR, cf.Lt, cf.d, R, tuple(t), tuple(r), enc)
        for p in rng.uniform(lo, hi, (6, 3)):
            m, penc, _ = cf.roots(ur5.R, p)
            if m < 0:
                continue
            mid = 0.5 * (penc[:m, :, 0::2] + penc[:m, :, 1::2])  # (m, 6, 2): c, s of each root
            for k in range(n):
                inside = (mid[:, :, 0] >= enc[k, :, 0]) & (mid[:, :, 0] <= enc[k, :, 1])
                inside &= (mid[:, :, 1] >= enc[k, :, 2]) & (mid[:, :, 1] <= enc[k, :, 3])
                assert np.any(np.all(inside, axis=1)), (lo, hi, k, p)
                checked += 1
    assert checked > 50


def test_pieces_of_a_cell_the_border_crosses(ur5):
    """A cell at the resolution the border crosses: of its 512 pieces (three halvings) the
    centred form leaves undecided only those near the border, under a third of those the plain
    enclosure leaves."""
    lo = np.array([-0.9, 0.2, -0.196875])
    plo, phi = lo[None], (lo + 0.03)[None]
    for _ in range(3):
        plo, phi = _eighths(plo, phi)
    v = ur5.closed_form_batch(plo, phi)
    plain = _plain(ur5, plo, phi)
    assert np.any(v == 1) and np.any(v == 0)
    assert 3 * np.sum(v < 0) < np.sum(plain < 0)


def test_the_relaxed_closed_form_proves_outside_where_two_borders_meet(ur5):
    """Cells about the first axis at the top and bottom of the UR5's reach (tool down), where
    the cylinder about the axis that the tool cannot enter meets the end of the reach: the first
    discriminant changes sign across such a cell, so no branch is decided over it and neither
    form proves it; the relaxed closed form follows both roots' enclosures and proves some
    outside. No sampled position of those is reached."""
    s = 1.8 / 64
    cells = [np.array([x, y, z]) for x in np.arange(-0.15, 0.15, s) for y in np.arange(-0.15, 0.15, s) for z in (-0.886, 0.886)]
    lo = np.array([c - s / 2 for c in cells])
    hi = lo + s
    cf = ur5.closed_form()
    v = _plain(ur5, lo, hi)
    both = v.copy()
    c = 0.5 * (lo + hi)
    Rlo, Rhi, tlo, thi = cf.goal_arrays(np.broadcast_to(ur5.R, (len(c), 3, 3)), c)
    J = np.ascontiguousarray(np.stack([cf.A.rotation - 1e-12, cf.A.rotation + 1e-12], axis=-1))
    r = np.nextafter(0.5 * (hi - lo), np.inf)
    ct.centred_verdicts(cf.code, cf.LR, cf.Lt, cf.d, cf.limits, Rlo, Rhi, tlo, thi, J, r, both < 0, both)
    relaxed = both.copy()
    ct.relaxed_outside(cf.code, cf.LR, cf.Lt, cf.d, cf.limits, Rlo, Rhi, tlo, thi, np.abs(cf.A.rotation), r, relaxed)
    new = np.flatnonzero((both < 0) & (relaxed == 0))
    assert len(new) >= 4
    assert np.all(relaxed[both >= 0] == both[both >= 0])
    rng = np.random.default_rng(4)
    for k in new:
        for p in rng.uniform(lo[k], hi[k], (30, 3)):
            n, _, ins = cf.roots(ur5.R, p)
            assert not (n > 0 and np.any(ins[: max(n, 0)] == 1)), (lo[k], hi[k], p)
