"""Inverse kinematics of a serial chain at 40 digits: complex Newton in mpmath on the pose as given.

Independent of kinbox's formulation: the chain is the Pinocchio model's own joints (revolute about
x, y, z or an unaligned axis) and placements, the goal the pose as given. Both are read as exact
numbers: a translation as its binary64 value, a rotation as the unit quaternion of its
binary64 quaternion (Pinocchio's XYZQUAT for the goal, ``pin.Quaternion(R)`` for a placement,
divided by its norm at 40 digits). A model built from a table of numbers (a DH table, rpy
angles) can give its exact placements instead (:class:`Chain` ``placements=``).

The equations are the position of the frame (3) and the skew part of ``R_goal^T R(q)`` (3):
square, analytic in ``q``, so Newton runs on complex ``q`` as well (a pair of roots that has
become complex is found as such). A root is reported with the smallest singular value of the
Jacobian there (its conditioning): roots are told apart at the 40-digit level, far below any
distance kinbox can resolve.
"""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pinocchio as pin

#: digits the roots are certain to (the working precision is :data:`WORK` digits: Newton's last
#: step next to a root 1e-12 from singular is 1e12 times the rounding of the residual)
DPS = 40
WORK = 64


def _quat_matrix(x, y, z, w):
    n = x * x + y * y + z * z + w * w
    s = 2 / n
    return mp.matrix(
        [
            [1 - s * (y * y + z * z), s * (x * y - z * w), s * (x * z + y * w)],
            [s * (x * y + z * w), 1 - s * (x * x + z * z), s * (y * z - x * w)],
            [s * (x * z - y * w), s * (y * z + x * w), 1 - s * (x * x + y * y)],
        ]
    )


def exact_rotation(R: np.ndarray):
    """The rotation of the unit quaternion of a binary64 rotation matrix."""
    c = pin.Quaternion(np.asarray(R, dtype=float)).coeffs()  # x y z w
    return _quat_matrix(*(mp.mpf(float(v)) for v in c))


def exact_pose(T: pin.SE3):
    """``(R, t)`` of a goal pose as its XYZQUAT numbers define it."""
    v = pin.SE3ToXYZQUAT(T)
    return _quat_matrix(*(mp.mpf(float(a)) for a in v[3:])), mp.matrix([mp.mpf(float(a)) for a in v[:3]])


def _axis(shortname: str, joint) -> np.ndarray:
    if shortname.endswith("RX") or shortname.endswith("RUBX"):
        return np.array([1.0, 0.0, 0.0])
    if shortname.endswith("RY") or shortname.endswith("RUBY"):
        return np.array([0.0, 1.0, 0.0])
    if shortname.endswith("RZ") or shortname.endswith("RUBZ"):
        return np.array([0.0, 0.0, 1.0])
    if "RevoluteUnaligned" in shortname:
        return np.asarray(joint.extract().axis, dtype=float)
    raise ValueError(f"the oracle handles revolute joints only, not {shortname}")


def _rot(axis, a):
    """Rotation by ``a`` (complex allowed) about a unit axis (Rodrigues)."""
    x, y, z = axis
    c, s = mp.cos(a), mp.sin(a)
    C = 1 - c
    return mp.matrix(
        [
            [c + x * x * C, x * y * C - z * s, x * z * C + y * s],
            [y * x * C + z * s, c + y * y * C, y * z * C - x * s],
            [z * x * C - y * s, z * y * C + x * s, c + z * z * C],
        ]
    )


def _cross(a, b):
    return mp.matrix([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


class Chain:
    """The joints from the world to ``frame``: per joint its placement ``(R, t)`` in its parent
    (exact) and its unit axis; then the frame's placement. ``placements``: exact ``(R, t)`` per
    joint of the path and for the frame, in that order (default: read off the model)."""

    def __init__(self, model: pin.Model, frame: str, placements=None):
        mp.mp.dps = WORK
        fid = model.getFrameId(frame)
        path = []
        j = model.frames[fid].parentJoint
        while j > 0:
            path.append(j)
            j = model.parents[j]
        path.reverse()
        self.joints = path
        self.idx_q = [model.joints[j].idx_q for j in path]
        self.axes = []
        self.place = []
        for k, j in enumerate(path):
            ax = _axis(model.joints[j].shortname(), model.joints[j])
            self.axes.append([mp.mpf(float(v)) for v in ax / np.linalg.norm(ax)])
            if placements is None:
                M = model.jointPlacements[j]
                self.place.append((exact_rotation(M.rotation), mp.matrix([mp.mpf(float(v)) for v in M.translation])))
            else:
                self.place.append(placements[k])
        if placements is None:
            F = model.frames[fid].placement
            self.tool = (exact_rotation(F.rotation), mp.matrix([mp.mpf(float(v)) for v in F.translation]))
        else:
            self.tool = placements[len(path)]

    def fk(self, q):
        """``(R, p, axes, origins)``: the frame's pose and each joint's world axis and origin."""
        R = mp.eye(3)
        p = mp.matrix([0, 0, 0])
        axes, origins = [], []
        for (Rp, tp), ax, qi in zip(self.place, self.axes, q):
            p = p + R * tp
            R = R * Rp
            axes.append(R * mp.matrix(ax))
            origins.append(p)
            R = R * _rot(ax, qi)
        Rt, tt = self.tool
        p = p + R * tt
        R = R * Rt
        return R, p, axes, origins

    def residual_jacobian(self, q, goal):
        Rg, tg = goal
        R, p, axes, origins = self.fk(q)
        M = Rg.T * R
        f = mp.matrix(6, 1)
        for r in range(3):
            f[r] = p[r] - tg[r]
        f[3] = (M[2, 1] - M[1, 2]) / 2
        f[4] = (M[0, 2] - M[2, 0]) / 2
        f[5] = (M[1, 0] - M[0, 1]) / 2
        n = len(q)
        Jm = mp.matrix(6, n)
        for i in range(n):
            dp = _cross(axes[i], p - origins[i])
            a = axes[i]
            W = mp.matrix([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
            dM = Rg.T * (W * R)
            for r in range(3):
                Jm[r, i] = dp[r]
            Jm[3, i] = (dM[2, 1] - dM[1, 2]) / 2
            Jm[4, i] = (dM[0, 2] - dM[2, 0]) / 2
            Jm[5, i] = (dM[1, 0] - dM[0, 1]) / 2
        return f, Jm

    def _float_newton(self, q0, goal, iters: int = 40) -> np.ndarray | None:
        """Complex Newton in binary64 (a start for :meth:`newton`): the same equations with
        the chain's numbers rounded."""
        Rg = np.array([[complex(goal[0][r, c]) for c in range(3)] for r in range(3)])
        tg = np.array([complex(goal[1][r]) for r in range(3)])
        places = [
            (np.array([[complex(P[0][r, c]) for c in range(3)] for r in range(3)]), np.array([complex(P[1][r]) for r in range(3)]))
            for P in self.place + [self.tool]
        ]
        axes = [np.array([float(v) for v in ax]) for ax in self.axes]
        q = np.array(q0, dtype=complex)
        for _ in range(iters):
            R, p = np.eye(3, dtype=complex), np.zeros(3, dtype=complex)
            wa, wo = [], []
            for (Rp, tp), ax, qi in zip(places[:-1], axes, q):
                p = p + R @ tp
                R = R @ Rp
                wa.append(R @ ax)
                wo.append(p)
                x, y, z = ax
                c, sn = np.cos(qi), np.sin(qi)
                C = 1 - c
                R = R @ np.array(
                    [
                        [c + x * x * C, x * y * C - z * sn, x * z * C + y * sn],
                        [y * x * C + z * sn, c + y * y * C, y * z * C - x * sn],
                        [z * x * C - y * sn, z * y * C + x * sn, c + z * z * C],
                    ]
                )
            p = p + R @ places[-1][1]
            R = R @ places[-1][0]
            M = Rg.T @ R
            f = np.r_[p - tg, (M[2, 1] - M[1, 2]) / 2, (M[0, 2] - M[2, 0]) / 2, (M[1, 0] - M[0, 1]) / 2]
            Jm = np.empty((6, len(q)), dtype=complex)
            for i, (a, o) in enumerate(zip(wa, wo)):
                W = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
                dM = Rg.T @ (W @ R)
                Jm[:3, i] = np.cross(a, p - o)
                Jm[3:, i] = [(dM[2, 1] - dM[1, 2]) / 2, (dM[0, 2] - dM[2, 0]) / 2, (dM[1, 0] - dM[0, 1]) / 2]
            try:
                dq = np.linalg.solve(Jm, -f)
            except np.linalg.LinAlgError:
                return None
            if not np.all(np.isfinite(dq)) or np.linalg.norm(dq) > 10:
                return None
            q = q + dq
            if np.linalg.norm(dq) < 1e-13:
                break
        return q

    def newton(self, q0, goal, iters: int = 30, start_in_binary64: bool = True):
        """Complex Newton from ``q0``: ``(q, converged)`` (``q`` a list of mp complex numbers),
        started in binary64 (unless ``start_in_binary64`` is False: next to a double root its
        rounding decides which of the pair it reaches) and finished at :data:`WORK` digits."""
        qf = self._float_newton(q0, goal) if start_in_binary64 else np.asarray(q0, dtype=complex)
        if qf is None:
            return [mp.mpc(complex(v)) for v in q0], False
        q = [mp.mpc(complex(v)) for v in qf]
        tol = mp.mpf(10) ** (-DPS)
        for _ in range(iters):
            f, Jm = self.residual_jacobian(q, goal)
            try:
                dq = mp.lu_solve(Jm, -f)
            except ZeroDivisionError:
                return q, False
            q = [a + b for a, b in zip(q, dq)]
            if mp.norm(dq) < tol:
                f, _ = self.residual_jacobian(q, goal)
                return q, bool(mp.norm(f) < tol)
            if mp.norm(dq) > 1e3:
                return q, False
        return q, False

    def sigma_min(self, q, goal) -> float:
        _, Jm = self.residual_jacobian(q, goal)
        J = np.array([[complex(Jm[r, c]) for c in range(Jm.cols)] for r in range(Jm.rows)])
        return float(np.linalg.svd(J, compute_uv=False)[-1])


def wrap(a):
    """An angle (mp real) in (-pi, pi]."""
    two = 2 * mp.pi
    a = a - two * mp.floor((a + mp.pi) / two)
    return a if a > -mp.pi else a + two


def roots(chain: Chain, goal, seeds, imag_tol: float = 1e-25) -> tuple[list, list]:
    """The distinct roots Newton reaches from ``seeds`` (each a joint vector): ``(real, complex)``,
    real ones as lists of mp reals wrapped to (-pi, pi], each root once (modulo 2 pi)."""
    real, cplx = [], []
    # binary64 Newton from every seed first; the 40-digit one from each distinct limit only
    starts: list[np.ndarray] = []
    raw: list[np.ndarray] = []  # seeds next to a singular point: Newton at 40 digits from them
    for s in seeds:
        qf = chain._float_newton(s, goal)
        if qf is None:
            continue
        if chain.sigma_min([mp.mpc(complex(v)) for v in qf], goal) < 1e-6:
            raw.append(np.asarray(s, dtype=complex))
        w = np.angle(np.exp(1j * qf.real)) + 1j * qf.imag
        if not any(np.max(np.abs(np.angle(np.exp(1j * (w.real - o.real)))) + np.abs(w.imag - o.imag)) < 1e-12 for o in starts):
            starts.append(w)
    for s, fast in [(s, True) for s in starts] + [(s, False) for s in raw]:
        q, ok = chain.newton(s, goal, start_in_binary64=fast)
        if not ok:
            continue
        if max(abs(mp.im(v)) for v in q) < imag_tol:
            r = [wrap(mp.re(v)) for v in q]
            if not any(max(abs(wrap(a - b)) for a, b in zip(r, o)) < 1e-30 for o in real):
                real.append(r)
        elif not any(max(abs(a - b) for a, b in zip(q, o)) < 1e-30 for o in cplx):
            cplx.append(q)
    return real, cplx


def wrist_and_elbow_seeds(q: np.ndarray) -> list[np.ndarray]:
    """``q`` and its images under the usual branch flips of a 6R arm with a wrist (joints 4, 6
    by pi with joint 5 mirrored) and the elbow mirrored: starting points only."""
    q = np.asarray(q, dtype=float)
    out = [q]
    w = q.copy()
    w[3] += np.pi
    w[4] = -w[4]
    w[5] += np.pi
    out.append(w)
    for base in list(out):
        e = base.copy()
        e[2] = -e[2]
        out.append(e)
    return out


def wrist_curve_seeds(q: np.ndarray, steps: int = 24) -> list[np.ndarray]:
    """Starting points along the self-motion a wrist has at its singularity (joints 4 and 6 on
    one line when joint 5 is at 0: ``q4 + t``, ``q6 -+ t``), with joint 5 as given and mirrored:
    near that singularity the roots lie close to this curve, anywhere along it."""
    q = np.asarray(q, dtype=float)
    out = []
    for t in np.linspace(0.0, 2 * np.pi, steps, endpoint=False):
        for sign in (1.0, -1.0):
            for q5 in (q[4], -q[4]):
                s = q.copy()
                s[3] += t
                s[5] -= sign * t
                s[4] = q5
                out.append(s)
    return out
