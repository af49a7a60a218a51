"""Gough-Stewart platforms by plain numerics (independent of kinbox): leg lengths, the
Jacobian, poses near a singularity and assemblies by multi-start Newton.

A pose is ``p = (w, t)``: rotation vector ``w`` (``R = exp(w)``) and translation ``t`` of the
platform frame in the world. Leg ``i`` joins the base point ``P[i]`` (world) to the platform
point ``Q[i]`` (platform frame): ``l_i = |t + R Q[i] - P[i]|``, the convention of
``tests/data/reference`` and of ``kinbox.model.builders.stewart``.

Multi-start Newton is *not* complete: it finds some assemblies. A complete solver must
find at least those, which is how the tests use it.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
from scipy.optimize import brentq, least_squares

__all__ = ["leg_lengths", "pose_q", "pose_of_q", "pose_distance", "twist_jacobian", "near_singular_poses", "assemblies"]


def _R(p) -> np.ndarray:
    return pin.exp3(np.asarray(p[:3], float))


def leg_lengths(P, Q, p) -> np.ndarray:
    """The six leg lengths at pose ``p = (w, t)``."""
    P, Q = np.asarray(P, float), np.asarray(Q, float)
    return np.linalg.norm(np.asarray(p[3:], float) + Q @ _R(p).T - P, axis=1)


def pose_q(p) -> np.ndarray:
    """Pinocchio FreeFlyer ``q = (t, quaternion xyzw)`` of the pose ``p``."""
    return np.r_[np.asarray(p[3:], float), pin.Quaternion(_R(p)).coeffs()]


def pose_of_q(q) -> tuple[np.ndarray, np.ndarray]:
    """(R, t) of a FreeFlyer ``q``."""
    q = np.asarray(q, float)
    quat = q[3:7] / np.linalg.norm(q[3:7])
    return pin.Quaternion(quat[3], *quat[:3]).toRotationMatrix(), q[:3].copy()


def pose_distance(q1, q2) -> float:
    """max(|t1 - t2|, rotation angle between R1 and R2) of two FreeFlyer configurations."""
    R1, t1 = pose_of_q(q1)
    R2, t2 = pose_of_q(q2)
    return max(float(np.max(np.abs(t1 - t2))), float(np.linalg.norm(pin.log3(R1.T @ R2))))


def twist_jacobian(P, Q, p) -> np.ndarray:
    """Rows ``(u_i, (R Q_i) x u_i)``: leg-length rates per platform twist ``(dt, dw)``, ``dw``
    in the world frame (u_i the leg's unit vector). The platform is singular where its
    determinant vanishes."""
    P, Q = np.asarray(P, float), np.asarray(Q, float)
    rq = Q @ _R(p).T
    d = np.asarray(p[3:], float) + rq - P
    u = d / np.linalg.norm(d, axis=1)[:, None]
    return np.hstack([u, np.cross(rq, u)])


def _jac_wt(P, Q, p) -> np.ndarray:
    """d(leg lengths)/d(w, t): the twist Jacobian times d(world twist)/dw = R Jr(w)."""
    J = twist_jacobian(P, Q, p)
    return np.hstack([J[:, 3:] @ _R(p) @ pin.Jexp3(np.asarray(p[:3], float)), J[:, :3]])


def _newton(P, Q, L, p0, iters: int = 30) -> np.ndarray:
    """Levenberg-Marquardt to get close, then Newton with the exact twist Jacobian (quadratic
    convergence, also to the nearly double roots next to a singularity)."""
    L = np.asarray(L, float)
    p = least_squares(lambda x: leg_lengths(P, Q, x) - L, p0, jac=lambda x: _jac_wt(P, Q, x), method="lm", max_nfev=100).x
    R, t = _R(p), p[3:].copy()
    for _ in range(iters):
        pose = np.r_[pin.log3(R), t]
        r = leg_lengths(P, Q, pose) - L
        if not np.all(np.isfinite(r)) or np.max(np.abs(r)) > 1e-3:
            break
        try:
            d = np.linalg.solve(twist_jacobian(P, Q, pose), -r)
        except np.linalg.LinAlgError:
            break
        t = t + d[:3]
        R = pin.exp3(d[3:]) @ R
        if np.max(np.abs(d)) < 1e-16:
            break
    return np.r_[pin.log3(R), t]


def near_singular_poses(P, Q, seed: int, offset: float):
    """``(p_gen, p_twin, L)``: a pose ``offset`` away from a singular pose, its leg lengths,
    and the second assembly with the same legs that merges with it at the singularity.

    A random line in pose space is followed to the nearest sign change of the Jacobian's
    determinant (bisection to rounding); the pose is moved ``offset`` along the line. Near a
    fold the twin sits at ``O(offset)`` on the other side: it is found by Newton from points
    around the singular pose along the Jacobian's kernel, and must be distinct from the
    generating pose with the opposite sign of the determinant.
    """
    rng = np.random.default_rng(seed)
    P, Q = np.asarray(P, float), np.asarray(Q, float)
    for _ in range(100):
        p0 = np.r_[rng.normal(0.0, 0.5, 3), rng.uniform(-0.5, 0.5, 2), rng.uniform(0.5, 1.2)]
        v = rng.normal(size=6)
        v /= np.linalg.norm(v)
        f = lambda s: float(np.linalg.det(twist_jacobian(P, Q, p0 + s * v)))  # noqa: E731
        grid = np.linspace(-1.0, 1.0, 201)
        vals = [f(s) for s in grid]
        roots = [brentq(f, a, b, xtol=1e-15, rtol=1e-15) for a, b, fa, fb in zip(grid, grid[1:], vals, vals[1:]) if fa * fb < 0]
        if roots:
            break
    else:  # pragma: no cover - never seen
        raise RuntimeError("no singular pose found")
    ps = p0 + min(roots, key=abs) * v
    gen = ps + offset * v
    L = leg_lengths(P, Q, gen)
    k = np.linalg.svd(_jac_wt(P, Q, ps))[2][-1]  # kernel direction at the singular pose
    w = v - (v @ k) * k
    det_gen = np.linalg.det(twist_jacobian(P, Q, gen))
    best = None
    for a in np.linspace(-4.0, 4.0, 17):
        p = _newton(P, Q, L, ps + offset * (w + a * k))
        sep = float(np.max(np.abs(p - gen)))
        ok = (
            np.max(np.abs(leg_lengths(P, Q, p) - L)) < 1e-14 and sep > 0.1 * offset and np.linalg.det(twist_jacobian(P, Q, p)) * det_gen < 0
        )
        if ok and (best is None or sep < best[1]):
            best = (p, sep)
    if best is None:
        raise RuntimeError(f"no twin assembly found near the singular pose (offset {offset})")
    return gen, best[0], L


def assemblies(P, Q, L, starts: int = 1000, seed: int = 0, tol: float = 1e-12) -> list[np.ndarray]:
    """Distinct assemblies (FreeFlyer ``q``) found by Newton from ``starts`` random poses."""
    P, Q, L = np.asarray(P, float), np.asarray(Q, float), np.asarray(L, float)
    rng = np.random.default_rng(seed)
    reach = float(np.max(np.linalg.norm(P, axis=1)) + np.max(np.linalg.norm(Q, axis=1)) + np.max(L))
    found: list[np.ndarray] = []
    for _ in range(starts):
        axis = rng.normal(size=3)
        w = axis / np.linalg.norm(axis) * rng.uniform(0.0, math.pi)
        p = _newton(P, Q, L, np.r_[w, rng.uniform(-reach, reach, 3)])
        if np.max(np.abs(leg_lengths(P, Q, p) - L)) > tol:
            continue
        q = pose_q(p)
        if all(pose_distance(q, o) > 1e-7 for o in found):
            found.append(q)
    return found
