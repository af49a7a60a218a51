"""Workspaces with the tool's orientation free (the position workspace) or within a cone.

:func:`~kinbox.workspace.serial.reach` with ``orientation="any"`` or ``cone=(ax, ay, az, angle)``
paves the positions of a frame reached with *some* orientation (any, or one whose tool axis --
the frame's ``z`` axis -- lies within ``angle`` of the unit direction ``(ax, ay, az)``):

* **outside**: no configuration within the joint limits puts the frame in the box (with its
  tool axis in the cone). Proven by a branch and prune over the chain's joint values
  (:func:`joint_search`): each box of joint values is enclosed by interval forward kinematics of
  the frame's position (and tool axis) -- the chain written as rotations about and slides along
  its joints' lines, each line in a frame of its own, evaluated from the frame back to the base
  in interval arithmetic with every result widened outward (:func:`_rotate`, :func:`_move`) --
  and discarded when that enclosure misses the position box (or the cone). Every joint box
  discarded within :data:`OUTSIDE_BOXES` proves the box outside: each configuration lies in one
  of them.
* **inside**: every position of the box is reached by a configuration within the limits with
  *one* orientation ``R`` (in the cone): the fixed-orientation test of
  :class:`~kinbox.workspace.arm.Reach` (the interval closed form over the box, or, without a
  closed form, the parametric Krawczyk test) proves it. Proving the box for one orientation is
  sufficient (each of its positions is reached with ``R``), not necessary: a box reached only
  with orientations varying across it stays undecided and is split. The orientations tried are
  that of a configuration the joint search met in the box (its forward kinematics by Pinocchio)
  and a fixed list (:func:`candidate_orientations`); the witness is a root at the box's centre.
* **boundary**: neither, at the resolution (after each of the box's eighths is tried).

Each verdict depends on the box alone (fixed budgets, fixed orders), so the paving is the same
serial, over processes, or on Dask. ``tests/workspace/test_free.py`` checks the enclosures
against Pinocchio's forward kinematics and the verdicts against sampled configurations.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Sequence

import numba as nb
import numpy as np
import pinocchio as pin

from ..errors import InputError
from ..formulation.arm import serial_chain
from ..pipeline import IK
from .arm import Reach, _eighth
from .paving import BOUNDARY, INSIDE, OUTSIDE

#: joint boxes the branch and prune may process to prove a position box outside
OUTSIDE_BOXES = 20000
#: ...and for each eighth of a box at the resolution
EIGHTH_BOXES = 5000
#: joint boxes it may process to meet a configuration in a box (a candidate orientation)
MEET_BOXES = 400
#: relative and absolute (times the chain's scale) outward widening of every enclosure step:
#: far above the rounding of the few operations of a step (a few ulps) and of the chain's frames
REL = 1e-12
ABS = 1e-12
#: weight of joints 1 and 2 in the halving order, whose invariants are tested without halving them
FIRST_JOINTS = 0.25
#: orientation weight (times the chain's scale) of a revolute joint's width when a cone is asked
CONE_WEIGHT = 0.5


def self_scale(pts) -> float:
    return max(1.0, max(float(np.linalg.norm(p)) for p in pts))


class Chain6:
    """The chain from the base to the frame as six joints, each a line with a frame of its own
    (``z`` along the line, positive motion), for interval forward kinematics:
    ``TR[0], Tt[0]`` place joint 1's frame in the base, ``TR[i], Tt[i]`` joint ``i+1``'s in joint
    ``i``'s; ``p6``/``u6`` are the frame's origin and ``z`` axis in joint 6's frame, at ``q_ref``.
    Joint values are offsets ``q - q_ref`` within ``lo``/``hi``."""

    def __init__(self, ik: IK):
        chain = serial_chain(ik.robot, ik.frame, ik.base)
        if chain is None:
            raise InputError(f"frame {ik.frame!r} is not reached by six revolute or prismatic joints: no workspace paving for it")
        F = []
        for j in chain.joints:
            z = j.axis / np.linalg.norm(j.axis)
            e = np.zeros(3)
            e[int(np.argmin(np.abs(z)))] = 1.0
            x = e - (e @ z) * z
            x /= np.linalg.norm(x)
            F.append(pin.SE3(np.column_stack([x, np.cross(z, x), z]), np.asarray(j.point, dtype=float)))
        Ts = [F[0]] + [F[i - 1].inverse() * F[i] for i in range(1, 6)]
        self.TR = np.array([T.rotation for T in Ts])
        self.Tt = np.array([T.translation for T in Ts])
        tool = F[5].inverse() * chain.tool
        self.p6 = np.array(tool.translation)
        self.u6 = np.array(tool.rotation[:, 2])
        self.kinds = np.array([0 if j.kind == "revolute" else 1 for j in chain.joints], dtype=np.int64)
        q_ref = chain.q_ref
        lo, hi = np.empty(6), np.empty(6)
        for i, j in enumerate(chain.joints):
            ref = float(q_ref[j.idx_q])
            if j.kind == "revolute":
                a, b = (j.lo - ref, j.hi - ref) if math.isfinite(j.lo) and math.isfinite(j.hi) else (-math.pi, math.pi)
                if b - a >= 2 * math.pi:  # a whole turn: every angle once
                    a, b = -math.pi, math.pi
            else:
                a, b = j.lo - ref, j.hi - ref
                if not (math.isfinite(a) and math.isfinite(b)):
                    raise InputError(f"prismatic joint {j.name!r} has no finite limits: no workspace paving with the orientation free")
            lo[i], hi[i] = a, b
        self.lo, self.hi = lo, hi
        pts = [np.asarray(j.point, dtype=float) for j in chain.joints] + [np.asarray(chain.tool.translation)]
        self.scale = max(1.0, max(float(np.linalg.norm(p)) for p in pts))
        # how far the frame may move per unit of each joint (the branching order only)
        lever = np.zeros(6)
        for i in range(6):
            if chain.joints[i].kind == "prismatic":
                lever[i] = 1.0
                continue
            path = sum(float(np.linalg.norm(pts[k + 1] - pts[k])) for k in range(i + 1, 6))
            u = chain.joints[i].axis / np.linalg.norm(chain.joints[i].axis)
            d = pts[i + 1] - pts[i]
            lever[i] = float(np.linalg.norm(d - (d @ u) * u)) + path
        self.lever = lever
        # the point o of line 2 nearest line 1 (base frame, where joint 1 puts it at q_ref; on
        # line 1 when the lines meet), in joint 2's frame with the distance e of its image from line
        # 1: as joint 1 turns, o moves on a circle of radius e about line 1
        u1, u2 = F[0].rotation[:, 2], F[1].rotation[:, 2]
        p1, p2 = F[0].translation, F[1].translation
        w = np.cross(u1, u2)
        if float(np.linalg.norm(w)) > 1e-9:
            s_ = float(np.cross(p2 - p1, u1) @ w / (w @ w))
            on2 = p2 + s_ * u2
        else:
            on2 = p2
        foot = p1 + float((on2 - p1) @ u1) * u1
        e_ = float(np.linalg.norm(on2 - foot))
        o2l = F[1].inverse() * on2
        o2l = np.array([0.0, 0.0, float(o2l[2])])  # on line 2 exactly
        on2 = F[1] * o2l
        foot = p1 + float((on2 - p1) @ u1) * u1
        e_ = float(np.linalg.norm(on2 - foot))
        self.o = foot
        self.o2 = np.array([0.0, 0.0, float(o2l[2]), 2 * e_ + 1e-12 * self_scale(pts)])
        self.chain = chain
        self.idx_q = np.array([j.idx_q for j in chain.joints], dtype=np.int64)

    def configuration(self, delta: np.ndarray) -> np.ndarray:
        q = np.array(self.chain.q_ref, dtype=float)
        q[self.idx_q] += delta
        return q

    def enclose(self, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(pm, pr, um, ur)``: the frame's position within ``pm +- pr`` and its ``z`` axis
        within ``um +- ur`` for every joint offset in ``[lo, hi]``."""
        pm, pr, um, ur = _enclose(lo, hi, self.kinds, self.TR, self.Tt, self.p6, self.u6, ABS * self.scale)
        return np.array(pm), np.array(pr), np.array(um), np.array(ur)


@nb.njit(cache=True)
def _wid(m, r, eabs):
    return r * (1.0 + REL) + REL * abs(m) + eabs


@nb.njit(cache=True)
def _move(R, t0, t1, t2, m0, m1, m2, r0, r1, r2, eabs):
    """``R v + t`` for ``v`` in ``m +- r``, widened outward."""
    a0 = t0 + R[0, 0] * m0 + R[0, 1] * m1 + R[0, 2] * m2
    a1 = t1 + R[1, 0] * m0 + R[1, 1] * m1 + R[1, 2] * m2
    a2 = t2 + R[2, 0] * m0 + R[2, 1] * m1 + R[2, 2] * m2
    w0 = abs(R[0, 0]) * r0 + abs(R[0, 1]) * r1 + abs(R[0, 2]) * r2
    w1 = abs(R[1, 0]) * r0 + abs(R[1, 1]) * r1 + abs(R[1, 2]) * r2
    w2 = abs(R[2, 0]) * r0 + abs(R[2, 1]) * r1 + abs(R[2, 2]) * r2
    # the rounding of a sum of three products is below 4 ulps of |R| |m| + |t|
    e0 = REL * (abs(t0) + abs(R[0, 0] * m0) + abs(R[0, 1] * m1) + abs(R[0, 2] * m2))
    e1 = REL * (abs(t1) + abs(R[1, 0] * m0) + abs(R[1, 1] * m1) + abs(R[1, 2] * m2))
    e2 = REL * (abs(t2) + abs(R[2, 0] * m0) + abs(R[2, 1] * m1) + abs(R[2, 2] * m2))
    return a0, a1, a2, _wid(a0, w0, eabs) + e0, _wid(a1, w1, eabs) + e1, _wid(a2, w2, eabs) + e2


@nb.njit(cache=True)
def _rotate(a, b, m0, m1, m2, r0, r1, r2, eabs):
    """``Rz(theta) v`` for every ``theta`` in ``[a, b]`` and ``v`` in ``m +- r``: the
    intersection of a centred form about the middle angle (``|cos|``, ``|sin|`` bounded by their
    middle values plus the half width, the centre moved by at most ``2 sin(h/2) |m_xy|``) and the
    disc ``|v_xy| <= |m_xy| + |r_xy|`` (any angle)."""
    th = 0.5 * (a + b)
    h = 0.5 * (b - a) * (1.0 + REL) + 1e-15
    c = math.cos(th)
    s = math.sin(th)
    C = min(1.0, abs(c) + h + 1e-15)
    S = min(1.0, abs(s) + h + 1e-15)
    nxy = math.sqrt(m0 * m0 + m1 * m1) * (1.0 + REL)
    drift = 2.0 * min(1.0, math.sin(min(0.5 * h, 0.5 * math.pi)) * (1.0 + REL) + 1e-15) * nxy + 1e-300
    cx = c * m0 - s * m1
    cy = s * m0 + c * m1
    rx = C * r0 + S * r1 + drift + REL * nxy
    ry = S * r0 + C * r1 + drift + REL * nxy
    rho = (nxy + math.sqrt(r0 * r0 + r1 * r1)) * (1.0 + REL)
    lo = max(cx - rx, -rho)
    hi = min(cx + rx, rho)
    x0, q0 = 0.5 * (lo + hi), 0.5 * (hi - lo)
    lo = max(cy - ry, -rho)
    hi = min(cy + ry, rho)
    x1, q1 = 0.5 * (lo + hi), 0.5 * (hi - lo)
    return x0, x1, m2, _wid(x0, q0, eabs), _wid(x1, q1, eabs), _wid(m2, r2, eabs)


@nb.njit(cache=True)
def _enclose(lo, hi, kinds, TR, Tt, p6, u6, eabs):
    m0, m1, m2 = p6[0], p6[1], p6[2]
    r0 = r1 = r2 = 0.0
    n0, n1, n2 = u6[0], u6[1], u6[2]
    s0 = s1 = s2 = 0.0
    for i in range(5, -1, -1):
        if kinds[i] == 0:
            m0, m1, m2, r0, r1, r2 = _rotate(lo[i], hi[i], m0, m1, m2, r0, r1, r2, eabs)
            n0, n1, n2, s0, s1, s2 = _rotate(lo[i], hi[i], n0, n1, n2, s0, s1, s2, 0.0)
        else:
            m2 = m2 + 0.5 * (lo[i] + hi[i])
            r2 = _wid(m2, r2 + 0.5 * (hi[i] - lo[i]), eabs)
        m0, m1, m2, r0, r1, r2 = _move(TR[i], Tt[i, 0], Tt[i, 1], Tt[i, 2], m0, m1, m2, r0, r1, r2, eabs)
        n0, n1, n2, s0, s1, s2 = _move(TR[i], 0.0, 0.0, 0.0, n0, n1, n2, s0, s1, s2, 0.0)
    return (m0, m1, m2), (r0, r1, r2), (n0, n1, n2), (s0, s1, s2)


@nb.njit(cache=True)
def _ball(lo, hi, kinds, TR, Tt, p6, eabs):
    """The frame's position within the ball ``|p - m| <= rad`` for every joint offset in
    ``[lo, hi]``: a rotation by ``theta`` in ``[a, b]`` moves the ball's centre along an arc of
    chord at most ``2 sin(h/2) |m_xy|`` about the middle angle's image; a slide moves it by at most
    its half width; the joints' frames move balls rigidly (no wrapping), widened outward."""
    m0, m1, m2 = p6[0], p6[1], p6[2]
    rad = 0.0
    v1 = (0.0, 0.0, 0.0, 0.0)
    v2 = (0.0, 0.0, 0.0, 0.0)
    for i in range(5, -1, -1):
        if i == 1:
            v2 = (m0, m1, m2, rad)
        elif i == 0:
            v1 = (m0, m1, m2, rad)
        h = 0.5 * (hi[i] - lo[i]) * (1.0 + REL) + 1e-15
        mid = 0.5 * (lo[i] + hi[i])
        if kinds[i] == 0:
            c = math.cos(mid)
            s = math.sin(mid)
            nxy = math.sqrt(m0 * m0 + m1 * m1) * (1.0 + REL)
            rad += 2.0 * min(1.0, math.sin(min(0.5 * h, 0.5 * math.pi)) * (1.0 + REL) + 1e-15) * nxy
            m0, m1 = c * m0 - s * m1, s * m0 + c * m1
        else:
            m2 = m2 + mid
            rad += h
        R = TR[i]
        m0, m1, m2 = (
            Tt[i, 0] + R[0, 0] * m0 + R[0, 1] * m1 + R[0, 2] * m2,
            Tt[i, 1] + R[1, 0] * m0 + R[1, 1] * m1 + R[1, 2] * m2,
            Tt[i, 2] + R[2, 0] * m0 + R[2, 1] * m1 + R[2, 2] * m2,
        )
        # rounding of the centre (a few ulps of its terms) and of the radius
        rad = rad * (1.0 + REL) + REL * (abs(m0) + abs(m1) + abs(m2) + abs(Tt[i, 0]) + abs(Tt[i, 1]) + abs(Tt[i, 2])) + eabs
    return (m0, m1, m2), rad, v1, v2


@nb.njit(cache=True)
def _point(delta, kinds, TR, Tt, p6, u6):
    """The frame's position and ``z`` axis at joint offsets ``delta`` (binary64, no enclosure:
    used only to order and pick configurations, never to decide)."""
    m0, m1, m2 = p6[0], p6[1], p6[2]
    n0, n1, n2 = u6[0], u6[1], u6[2]
    for i in range(5, -1, -1):
        if kinds[i] == 0:
            c = math.cos(delta[i])
            s = math.sin(delta[i])
            m0, m1 = c * m0 - s * m1, s * m0 + c * m1
            n0, n1 = c * n0 - s * n1, s * n0 + c * n1
        else:
            m2 = m2 + delta[i]
        R = TR[i]
        m0, m1, m2 = (
            Tt[i, 0] + R[0, 0] * m0 + R[0, 1] * m1 + R[0, 2] * m2,
            Tt[i, 1] + R[1, 0] * m0 + R[1, 1] * m1 + R[1, 2] * m2,
            Tt[i, 2] + R[2, 0] * m0 + R[2, 1] * m1 + R[2, 2] * m2,
        )
        n0, n1, n2 = (
            R[0, 0] * n0 + R[0, 1] * n1 + R[0, 2] * n2,
            R[1, 0] * n0 + R[1, 1] * n1 + R[1, 2] * n2,
            R[2, 0] * n0 + R[2, 1] * n1 + R[2, 2] * n2,
        )
    return (m0, m1, m2), (n0, n1, n2)


@nb.njit(cache=True)
def _gap(p, c, h):
    """How far ``p`` lies outside the box ``c +- h`` (max norm; 0 within)."""
    g = 0.0
    for k in range(3):
        g = max(g, abs(p[k] - c[k]) - h[k])
    return g


@nb.njit(cache=True)
def joint_search(lo0, hi0, kinds, TR, Tt, p6, u6, eabs, weights, c, h, cone_a, cone_cos, use_cone, budget, meet, inv, o2):
    """Branch and prune over joint offsets in ``[lo0, hi0]`` for a configuration putting the
    frame in the box ``c +- h`` (its ``z`` axis ``u`` with ``cone_a . u >= cone_cos`` when
    ``use_cone``). Best first: the joint box whose middle puts the frame nearest the box (ties
    by the order of creation), halved across the joint of largest ``weights * width``.

    Returns ``(status, boxes, delta)``: status 0 when every joint box was discarded (proven: no
    configuration), 1 when ``meet`` and the middle of a joint box puts the frame strictly within
    the box (and cone) -- ``delta`` is that configuration -- and 2 when the budget ran out or a
    joint box could not be halved further.

    ``inv``: bounds on the box's positions of what joints 1 and 2 keep (``zmin zmax rhomin
    rhomax`` in joint 1's frame, ``dmin dmax`` from the point ``o``); ``o2``: ``o`` in joint 2's
    frame and the radius of the circle it moves on (:meth:`FreeReach._invariants`)."""
    cap = 2 * budget + 2
    blo = np.empty((cap, 6))
    bhi = np.empty((cap, 6))
    blo[0] = lo0
    bhi[0] = hi0
    heap = [(0.0, 0)]
    made = 1
    n = 0
    delta = 0.5 * (lo0 + hi0)
    while len(heap) > 0:
        _, idx = heapq.heappop(heap)
        lo = blo[idx]
        hi = bhi[idx]
        n += 1
        if n > budget:
            return 2, n, delta
        pm, pr, um, ur = _enclose(lo, hi, kinds, TR, Tt, p6, u6, eabs)
        miss = False
        for k in range(3):
            if abs(pm[k] - c[k]) > pr[k] + h[k]:
                miss = True
        if not miss:
            bm, brad, v1, v2 = _ball(lo, hi, kinds, TR, Tt, p6, eabs)
            d2 = 0.0
            for k in range(3):
                e = max(0.0, abs(bm[k] - c[k]) - h[k])
                d2 += e * e
            miss = math.sqrt(d2) * (1.0 - REL) > brad
            if not miss and kinds[0] == 0:
                # joint 1 turns the frame about its line: distance from the line and height along
                # it, in joint 1's frame, are the same at every angle of joint 1
                r = v1[3] * (1.0 + REL) + eabs
                z = v1[2]
                rho = math.sqrt(v1[0] * v1[0] + v1[1] * v1[1])
                miss = z - r > inv[1] or z + r < inv[0] or rho * (1.0 - REL) - r > inv[3] or rho * (1.0 + REL) + r < inv[2]
            if not miss and kinds[0] == 0 and kinds[1] == 0:
                # joints 1 and 2 turn the frame about the point o of line 2 nearest line 1: its
                # distance from o is the same at every angle of both, o moves by at most e
                dx = v2[0] - o2[0]
                dy = v2[1] - o2[1]
                dz = v2[2] - o2[2]
                dist = math.sqrt(dx * dx + dy * dy + dz * dz)
                r = v2[3] * (1.0 + REL) + eabs + o2[3]
                miss = dist * (1.0 - REL) - r > inv[5] or dist * (1.0 + REL) + r < inv[4]
        if miss:
            continue
        if use_cone:
            top_dot = 0.0
            for k in range(3):
                top_dot += cone_a[k] * um[k] + abs(cone_a[k]) * ur[k]
            if top_dot * (1.0 + REL) + REL < cone_cos:
                continue
        mid = 0.5 * (lo + hi)
        if meet:
            p, u = _point(mid, kinds, TR, Tt, p6, u6)
            inside = True
            for k in range(3):
                if not abs(p[k] - c[k]) < h[k] * (1.0 - 1e-6):
                    inside = False
            if inside and use_cone:
                inside = cone_a[0] * u[0] + cone_a[1] * u[1] + cone_a[2] * u[2] > cone_cos + 1e-9
            if inside:
                return 1, n, mid
        best = -1
        bw = 0.0
        for k in range(6):
            w = weights[k] * (hi[k] - lo[k])
            if w > bw:
                bw = w
                best = k
        if best < 0 or bw < 1e-12 or made + 2 > cap:
            return 2, n, delta
        m = mid[best]
        blo[made] = lo
        bhi[made] = hi
        bhi[made, best] = m
        blo[made + 1] = lo
        bhi[made + 1] = hi
        blo[made + 1, best] = m
        for j in range(made, made + 2):
            p, u = _point(0.5 * (blo[j] + bhi[j]), kinds, TR, Tt, p6, u6)
            g = _gap(p, c, h)
            if use_cone:
                g += max(0.0, cone_cos - (cone_a[0] * u[0] + cone_a[1] * u[1] + cone_a[2] * u[2]))
            heapq.heappush(heap, (g, j))
        made += 2
    return 0, n, delta


def candidate_orientations(cone: tuple[np.ndarray, float] | None) -> list[np.ndarray]:
    """A fixed list of rotations to try a box with: the 24 rotations of the cube (any
    orientation), or rotations whose ``z`` axis is the cone's axis or tilted towards it by half
    its angle in four directions, each at four turns about that axis (a cone)."""
    out: list[np.ndarray] = []
    if cone is None:
        for perm in ((0, 1, 2), (1, 2, 0), (2, 0, 1), (1, 0, 2), (0, 2, 1), (2, 1, 0)):
            for signs in ((1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1), (-1, -1, -1), (-1, 1, 1), (1, -1, 1), (1, 1, -1)):
                M = np.zeros((3, 3))
                for r, (cidx, sg) in enumerate(zip(perm, signs)):
                    M[r, cidx] = sg
                if np.linalg.det(M) > 0:
                    out.append(M)
        return out
    a, ang = cone
    e = np.zeros(3)
    e[int(np.argmin(np.abs(a)))] = 1.0
    x = e - (e @ a) * a
    x /= np.linalg.norm(x)
    y = np.cross(a, x)
    axes = [a] + [
        math.cos(0.5 * ang) * a + math.sin(0.5 * ang) * (math.cos(k * math.pi / 2) * x + math.sin(k * math.pi / 2) * y) for k in range(4)
    ]
    for z in axes:
        z = z / np.linalg.norm(z)
        e = np.zeros(3)
        e[int(np.argmin(np.abs(z)))] = 1.0
        x0 = e - (e @ z) * z
        x0 /= np.linalg.norm(x0)
        y0 = np.cross(z, x0)
        for k in range(4):
            phi = k * math.pi / 2
            xx = math.cos(phi) * x0 + math.sin(phi) * y0
            out.append(np.column_stack([xx, np.cross(z, xx), z]))
    return out


def _frames_about(z: np.ndarray, turns: int = 4) -> list[np.ndarray]:
    """Rotations whose ``z`` axis is ``z``, at ``turns`` angles about it."""
    z = z / np.linalg.norm(z)
    e = np.zeros(3)
    e[int(np.argmin(np.abs(z)))] = 1.0
    x0 = e - (e @ z) * z
    x0 /= np.linalg.norm(x0)
    y0 = np.cross(z, x0)
    out = []
    for k in range(turns):
        phi = 2 * math.pi * k / turns
        xx = math.cos(phi) * x0 + math.sin(phi) * y0
        out.append(np.column_stack([xx, np.cross(z, xx), z]))
    return out


def _about(d: np.ndarray) -> list[np.ndarray]:
    """Rotations whose ``z`` axis points along ``d`` (the box seen from the chain's first joint)
    or against it: an arm stretched towards a far box, folded towards a near one."""
    n = float(np.linalg.norm(d))
    if not n > 1e-9:
        return []
    return _frames_about(d / n) + _frames_about(-d / n)


class FreeReach:
    """One arm and frame, the tool's orientation free or within a cone, prepared to decide
    position boxes (a :class:`~kinbox.workspace.paving.Decider`; see the module's text)."""

    def __init__(self, ik: IK, cone: Sequence[float] | None = None, method: str = "auto"):
        self.ik = ik
        self.method = method
        self.fk = Chain6(ik)
        self.nq = int(ik.robot.model.nq)
        self.cone: tuple[np.ndarray, float] | None = None
        if cone is not None:
            c = np.asarray(cone, dtype=float).reshape(-1)
            if c.shape != (4,) or not np.all(np.isfinite(c)):
                raise InputError("the cone takes four finite numbers: AX AY AZ ANGLE (a direction and an angle in radians)")
            n = float(np.linalg.norm(c[:3]))
            if not n > 0 or not 0.0 <= c[3] <= math.pi:
                raise InputError("the cone's axis must be a nonzero direction and its angle within [0, pi] radians")
            self.cone = (c[:3] / n, float(c[3]))
        self.candidates = candidate_orientations(self.cone)
        # the fixed-orientation deciders are made on first use (each compiles a closed form)
        self._fixed: dict[int, Reach] = {}
        w = np.array(self.fk.lever)
        if self.cone is not None:
            w = w + CONE_WEIGHT * self.fk.scale * (self.fk.kinds == 0)
        # joints 1 and 2 keep the tests of their invariants (joint_search): halved later
        w[:2] *= np.where(self.fk.kinds[:2] == 0, FIRST_JOINTS, 1.0)
        self.weights = w

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_fixed"] = {}
        return state

    def _search(self, lo: np.ndarray, hi: np.ndarray, budget: int, meet: bool) -> tuple[int, int, np.ndarray]:
        fk = self.fk
        c = 0.5 * (lo + hi)
        # c +- h holds [lo, hi] whatever the rounding of c and h (a few ulps of each)
        h = 0.5 * (hi - lo) * (1.0 + 1e-15) + 1e-15 * np.abs(c) + 1e-300
        a, cc, use = (self.cone[0], math.cos(self.cone[1]), True) if self.cone is not None else (np.zeros(3), -2.0, False)
        inv = self._invariants(c, h)
        st, n, delta = joint_search(
            fk.lo, fk.hi, fk.kinds, fk.TR, fk.Tt, fk.p6, fk.u6, ABS * fk.scale, self.weights, c, h, a, cc, use, budget, meet, inv, fk.o2
        )
        return int(st), int(n), np.asarray(delta)

    def _invariants(self, c: np.ndarray, h: np.ndarray) -> np.ndarray:
        """Bounds over the box ``c +- h`` of what joints 1 and 2 keep (see :func:`joint_search`):
        height and distance from line 1 in joint 1's frame (the box mapped there and enclosed),
        distance from the point ``o``, each widened outward."""
        fk = self.fk
        R0, t0 = fk.TR[0], fk.Tt[0]
        cl = R0.T @ (c - t0)
        hl = np.abs(R0.T) @ h
        hl = hl * (1 + 1e-12) + 1e-12 * (np.abs(cl) + np.abs(c) + np.abs(t0) + fk.scale)
        near = np.maximum(np.abs(cl[:2]) - hl[:2], 0.0)
        far = np.abs(cl[:2]) + hl[:2]
        d = np.maximum(np.abs(c - fk.o) - h, 0.0)
        D = np.abs(c - fk.o) + h
        out = np.array(
            [
                cl[2] - hl[2],
                cl[2] + hl[2],
                float(np.linalg.norm(near)),
                float(np.linalg.norm(far)),
                float(np.linalg.norm(d)),
                float(np.linalg.norm(D)),
            ]
        )
        e = 1e-12 * (fk.scale + float(np.abs(out).max()))
        return out + np.array([-e, e, -e, e, -e, e])

    def _fixed_reach(self, R: np.ndarray) -> Reach:
        key = hash(R.tobytes())
        if key not in self._fixed:
            q = pin.Quaternion(R).coeffs()  # x y z w
            self._fixed[key] = Reach(self.ik, np.asarray(q) / np.linalg.norm(q), self.method)
        return self._fixed[key]

    def _in_cone(self, R: np.ndarray) -> bool:
        if self.cone is None:
            return True
        a, ang = self.cone
        return bool(a @ R[:, 2] >= math.cos(ang) + 1e-9)

    def _rotations(self, lo: np.ndarray, hi: np.ndarray, found: np.ndarray | None) -> list[np.ndarray]:
        """The orientations to try a box with, in order: that of the configuration ``found``
        (Pinocchio's forward kinematics), the box seen from the first joint, the fixed list;
        those outside the cone dropped."""
        rots = []
        if found is not None:
            R = np.array(self.ik.pose_at(self.fk.configuration(found).tolist()).rotation)
            U, _, Vt = np.linalg.svd(R)
            rots.append(U @ Vt)
        rots += _about(0.5 * (lo + hi) - self.fk.Tt[0]) + self.candidates
        return [R for R in rots if self._in_cone(R)]

    def _prove_inside(self, lo: np.ndarray, hi: np.ndarray, rots: list[np.ndarray], stats: dict) -> np.ndarray | None:
        """A witness if the box is proven inside for one of ``rots`` (see the module's text)."""
        for R in rots:
            fixed = self._fixed_reach(R)
            stats["orientations"] += 1
            if fixed.closed_form() is not None:
                got = fixed.closed_form_verdict(lo, hi)
                if got is not None and got[0] == INSIDE:
                    return got[1]
            else:
                v, w, st = fixed.decide(lo, hi, float(np.max(hi - lo)))
                for k, x in st.items():
                    stats[k] = stats.get(k, 0) + x
                if v == INSIDE:
                    return w
        return None

    def _verdict(self, lo: np.ndarray, hi: np.ndarray, stats: dict, budget: int = OUTSIDE_BOXES) -> tuple[int, np.ndarray | None] | None:
        """Inside, outside, or None (undecided). With a closed form, the orientations whose
        closed form reaches the box's centre within the limits are tried first: one of them
        makes the box not outside (no search for that); else the joint search decides outside,
        or meets a configuration whose orientation is tried."""
        cf = self.ik.closed_form if self.method == "auto" else None
        if cf is not None:
            c = 0.5 * (lo + hi)
            reaching = []
            for R in self._rotations(lo, hi, None):
                n, _, ins = cf.roots(R, c)
                stats["centre_solves"] += 1
                if n > 0 and np.any(ins[:n] == 1):
                    reaching.append(R)
            if reaching:
                w = self._prove_inside(lo, hi, reaching, stats)
                return (INSIDE, w) if w is not None else None
        st, n, delta = self._search(lo, hi, budget, True)
        stats["joint_boxes"] += n
        if st == 0:
            return OUTSIDE, None
        if st != 1:
            return None
        rots = self._rotations(lo, hi, delta)
        w = self._prove_inside(lo, hi, rots[:1] if cf is not None else rots, stats)
        return (INSIDE, w) if w is not None else None

    def decide(self, lo: np.ndarray, hi: np.ndarray, resolution: float) -> tuple[int, np.ndarray | None, dict]:
        """The verdict on one position box: :data:`OUTSIDE`, :data:`INSIDE` (with a witness),
        :data:`BOUNDARY`, or -1 (split it); at the resolution the box's eighths are tried."""
        stats = {"joint_boxes": 0, "orientations": 0, "centre_solves": 0}
        got = self._verdict(lo, hi, stats)
        if got is not None:
            return got[0], got[1], stats
        if float(np.max(hi - lo)) > resolution:
            return -1, None, stats
        parts = [self._verdict(*_eighth(lo, hi, k), stats, EIGHTH_BOXES) for k in range(8)]
        kinds = {p[0] if p is not None else BOUNDARY for p in parts}
        if kinds == {INSIDE}:
            return INSIDE, next(p[1] for p in parts if p is not None), stats
        if kinds == {OUTSIDE}:
            return OUTSIDE, None, stats
        return BOUNDARY, None, stats


__all__ = ["FreeReach", "Chain6", "joint_search", "candidate_orientations"]
