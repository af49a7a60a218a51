"""Closed-form / polynomial assembly modes of planar linkages (independent oracle).

Four-bar linkage
----------------
Ground pivots ``A = (0, 0)`` and ``D = (ground, 0)``; crank ``AB`` (length ``crank``) at absolute
angle ``crank_angle`` (from the ground line ``AD``, counter-clockwise); coupler ``BC``; rocker
``DC``.  :func:`four_bar_assemblies` intersects the circles ``|C - B| = coupler`` and
``|C - D| = rocker``: 0, 1 (tangent, the two modes coincide) or 2 solutions, each a
:class:`FourBarAssembly` ``(theta_coupler, theta_rocker, C)`` where

* ``theta_coupler`` = absolute angle of the vector ``B -> C``,
* ``theta_rocker``  = absolute angle of the vector ``D -> C``,

both measured from the x axis (= ``A -> D``), wrapped to ``(-pi, pi]``.  The first solution has
``C`` on the left of ``B -> D`` (``cross(D - B, C - B) > 0``), the second on the right.
:func:`four_bar_relative_angles` converts to the relative joint angles of the open chain
``A -> B -> C`` closed at ``C``.

3-RPR parallel manipulator
--------------------------
Base pivots ``A_i`` (world), platform pivots ``b_i`` (platform frame), leg lengths ``rho_i``:
find the platform poses ``(x, y, phi)`` (platform-frame origin and orientation in the world)
with ``|(x, y) + R(phi) b_i - A_i| = rho_i``.  :func:`three_rpr_assemblies` moves to
``A_1 = 0``, ``b_1 = 0``; the two differences ``eq_i - eq_1`` are linear in ``p = B_1`` with
coefficients linear in ``(cos phi, sin phi)``; Cramer's rule gives ``p = (Dx, Dy) / D`` and
``Dx^2 + Dy^2 - rho_1^2 D^2 = 0``.  With ``t = tan((phi - phi0) / 2)`` this is a degree-8
polynomial which always has the factor ``1 + t^2`` (the circular points); after dividing it out
a polynomial of degree <= 6 remains (Gosselin's sextic).  Real roots (``numpy.roots``) are
back-substituted, polished by at most a few Newton steps on the three original equations (to
reach 1e-12), verified (residual of every leg <= ``verify_tol``) and de-duplicated.  Up to 6
real solutions.  ``phi = phi0 + pi`` (``t`` infinite) is checked separately.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

__all__ = [
    "FourBarAssembly",
    "four_bar_assemblies",
    "four_bar_relative_angles",
    "three_rpr_residuals",
    "three_rpr_assemblies",
    "three_rpr_sextic",
]


def _wrap(a: float) -> float:
    return float(math.pi - (math.pi - a) % (2 * math.pi))


class FourBarAssembly(NamedTuple):
    theta_coupler: float  # absolute angle of B -> C
    theta_rocker: float  # absolute angle of D -> C
    C: tuple[float, float]


def four_bar_assemblies(
    ground: float, crank: float, coupler: float, rocker: float, crank_angle: float, tol: float = 1e-12
) -> list[FourBarAssembly]:
    """The assembly modes of a four-bar at a given crank angle (see module docstring)."""
    B = np.array([crank * math.cos(crank_angle), crank * math.sin(crank_angle)])
    D = np.array([float(ground), 0.0])
    v = D - B
    dist = float(np.hypot(*v))
    if dist < 1e-15:
        if abs(coupler - rocker) <= tol:
            raise ValueError("B coincides with D and coupler == rocker: a continuum of assemblies")
        return []
    # distance from B, along B->D, of the chord midpoint; half-chord h
    a = (dist * dist + coupler * coupler - rocker * rocker) / (2.0 * dist)
    h2 = coupler * coupler - a * a
    scale = max(coupler, rocker, dist) ** 2
    if h2 < -tol * scale:
        return []
    u = v / dist
    n = np.array([-u[1], u[0]])  # left normal of B -> D
    mid = B + a * u
    if h2 <= tol * scale:
        Cs = [mid]
    else:
        h = math.sqrt(h2)
        Cs = [mid + h * n, mid - h * n]
    out = []
    for C in Cs:
        tc = _wrap(math.atan2(C[1] - B[1], C[0] - B[0]))
        tr = _wrap(math.atan2(C[1] - D[1], C[0] - D[0]))
        out.append(FourBarAssembly(tc, tr, (float(C[0]), float(C[1]))))
    return out


def four_bar_relative_angles(crank_angle: float, asm: FourBarAssembly) -> tuple[float, float, float]:
    """Relative joint angles ``(q_A, q_B, q_C)`` of the chain A -> B -> C -> D:
    ``q_A = crank_angle``, ``q_B = theta_coupler - crank_angle`` (coupler w.r.t. crank) and
    ``q_C = (theta_rocker + pi) - theta_coupler`` (link C -> D w.r.t. the coupler); also the rocker
    pivot angle at D is ``theta_rocker`` itself.  All wrapped to (-pi, pi]."""
    return (
        _wrap(crank_angle),
        _wrap(asm.theta_coupler - crank_angle),
        _wrap(asm.theta_rocker + math.pi - asm.theta_coupler),
    )


# ----------------------------------------------------------------------------------- 3-RPR


def _rot(phi: float) -> np.ndarray:
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[c, -s], [s, c]])


def three_rpr_residuals(base_pts, platform_pts, leg_lengths, pose) -> np.ndarray:
    """``|p + R(phi) b_i - A_i| - rho_i`` for the pose ``(x, y, phi)``."""
    A = np.asarray(base_pts, float)
    b = np.asarray(platform_pts, float)
    rho = np.asarray(leg_lengths, float)
    x, y, phi = pose
    B = np.array([x, y]) + b @ _rot(phi).T
    return np.linalg.norm(B - A, axis=1) - rho


# polynomials in t (numpy.polynomial convention: increasing degree), scaled by (1 + t^2):
#   cos(phi0 + psi) * (1+t^2)   and   sin(phi0 + psi) * (1+t^2),  t = tan(psi/2)
def _trig_polys(phi0: float):
    c0, s0 = math.cos(phi0), math.sin(phi0)
    C = np.array([1.0, 0.0, -1.0])  # cos psi (1+t^2)
    S = np.array([0.0, 2.0, 0.0])  # sin psi (1+t^2)
    W = np.array([1.0, 0.0, 1.0])  # 1 (1+t^2)
    return c0 * C - s0 * S, s0 * C + c0 * S, W


P = np.polynomial.polynomial


def three_rpr_sextic(base_pts, platform_pts, leg_lengths, phi0: float = 0.0):
    """The univariate polynomial (increasing-degree coefficients, numpy.polynomial convention) in
    ``t = tan((phi - phi0)/2)`` whose real roots are the assembly orientations, after removing
    the ``1 + t^2`` factor; also returns the removed-factor remainder (should be ~0) and the
    helper data used for back-substitution."""
    A = np.asarray(base_pts, float)
    b = np.asarray(platform_pts, float)
    rho = np.asarray(leg_lengths, float)
    A0 = A - A[0]
    b0 = b - b[0]
    cw, sw, W = _trig_polys(phi0)
    # R b_i - A_i (scaled by (1+t^2)), components as polynomials
    u = []
    rhs = []
    for i in (1, 2):
        bx, by = b0[i]
        ax, ay = A0[i]
        ux = bx * cw - by * sw - ax * W
        uy = bx * sw + by * cw - ay * W
        u.append((ux, uy))
        k = rho[i] ** 2 - rho[0] ** 2 - bx * bx - by * by - ax * ax - ay * ay
        # 2 (R b_i) . A_i
        rb_dot_a = ax * (bx * cw - by * sw) + ay * (bx * sw + by * cw)
        rhs.append(k * W + 2.0 * rb_dot_a)
    # system: 2 u_i . p = rhs_i (both sides scaled by (1+t^2))
    (u2x, u2y), (u3x, u3y) = u
    r2, r3 = rhs
    D = 4.0 * P.polysub(P.polymul(u2x, u3y), P.polymul(u2y, u3x))  # * (1+t^2)^2
    Dx = 2.0 * P.polysub(P.polymul(r2, u3y), P.polymul(u2y, r3))  # * (1+t^2)^2
    Dy = 2.0 * P.polysub(P.polymul(u2x, r3), P.polymul(r2, u3x))  # * (1+t^2)^2
    F = P.polysub(P.polyadd(P.polymul(Dx, Dx), P.polymul(Dy, Dy)), rho[0] ** 2 * P.polymul(D, D))
    q, r = P.polydiv(F, W)
    scale = max(np.abs(F).max(), 1e-300)
    return P.polytrim(q, tol=0.0), float(np.abs(r).max() / scale), (A0, b0, D, Dx, Dy)


def _newton_polish(A, b, rho, pose, iters: int = 4):
    x = np.array(pose, float)
    for _ in range(iters):
        R = _rot(x[2])
        dR = np.array([[-math.sin(x[2]), -math.cos(x[2])], [math.cos(x[2]), -math.sin(x[2])]])
        Bp = x[:2] + b @ R.T
        d = Bp - A
        f = np.einsum("ij,ij->i", d, d) - rho**2
        J = np.column_stack([2 * d[:, 0], 2 * d[:, 1], 2 * np.einsum("ij,ij->i", d, b @ dR.T)])
        try:
            step = np.linalg.solve(J, -f)
        except np.linalg.LinAlgError:
            break
        x = x + step
        if np.abs(step).max() < 1e-15:
            break
    return x


def three_rpr_assemblies(
    base_pts,
    platform_pts,
    leg_lengths,
    verify_tol: float = 1e-9,
    phi0: float = 0.3718,
    imag_tol: float = 1e-6,
    polish: bool = True,
) -> list[tuple[float, float, float]]:
    """All real assembly modes ``(x, y, phi)`` of a 3-RPR (see module docstring), ``phi`` in
    (-pi, pi], sorted by ``phi``.  Each returned pose satisfies every leg length to ``verify_tol``."""
    A = np.asarray(base_pts, float)
    b = np.asarray(platform_pts, float)
    rho = np.asarray(leg_lengths, float)
    sextic, rem, (A0, b0, D, Dx, Dy) = three_rpr_sextic(A, b, rho, phi0)
    if np.abs(sextic).max() == 0.0:
        raise ValueError("the sextic vanishes identically (architecturally singular design?)")
    cands = []
    roots = np.roots(sextic[::-1]) if len(sextic) > 1 else np.array([])
    for t in roots:
        if abs(t.imag) > imag_tol * max(1.0, abs(t)):
            continue
        cands.append(phi0 + 2.0 * math.atan(t.real))
    cands.append(phi0 + math.pi)  # t = infinity
    out: list[np.ndarray] = []
    for phi in cands:
        t = math.tan((phi - phi0) / 2.0) if abs(math.cos((phi - phi0) / 2.0)) > 1e-12 else None
        R = _rot(phi)
        if t is not None:
            den = P.polyval(t, D)
            if abs(den) < 1e-14 * max(1.0, np.abs(D).max()):
                # degenerate elimination: solve legs 1-2 by circle intersection instead
                p_list = _p_from_circles(A0, b0, rho, R)
            else:
                p_list = [np.array([P.polyval(t, Dx), P.polyval(t, Dy)]) / den]
        else:
            M = 2.0 * np.array([R @ b0[1] - A0[1], R @ b0[2] - A0[2]])
            rhs = np.array([rho[i] ** 2 - rho[0] ** 2 - b0[i] @ b0[i] - A0[i] @ A0[i] + 2.0 * (R @ b0[i]) @ A0[i] for i in (1, 2)])
            if abs(np.linalg.det(M)) < 1e-14:
                p_list = _p_from_circles(A0, b0, rho, R)
            else:
                p_list = [np.linalg.solve(M, rhs)]
        for p in p_list:
            # p = B_1 - A_1 ; platform origin = B_1 - R b_1
            pose = np.array([*(p + A[0] - R @ b[0]), phi])
            if polish:
                pose = _newton_polish(A, b, rho, pose)
            res = three_rpr_residuals(A, b, rho, pose)
            if np.abs(res).max() <= verify_tol:
                pose[2] = _wrap(pose[2])
                if not any(abs(_wrap(pose[2] - q[2])) < 1e-8 and np.abs(pose[:2] - q[:2]).max() < 1e-8 for q in out):
                    out.append(pose)
    out.sort(key=lambda q: q[2])
    return [tuple(float(v) for v in q) for q in out]


def _p_from_circles(A0, b0, rho, R):
    """Fallback: B_1 on the circle |p| = rho_1 with leg 2 a circle: intersect (then legs are verified)."""
    c2 = A0[1] - R @ b0[1]  # |p - c2| = rho_2
    d = float(np.hypot(*c2))
    if d < 1e-15:
        return []
    a = (d * d + rho[0] ** 2 - rho[1] ** 2) / (2 * d)
    h2 = rho[0] ** 2 - a * a
    if h2 < 0:
        return []
    u = c2 / d
    n = np.array([-u[1], u[0]])
    h = math.sqrt(max(h2, 0.0))
    return [a * u + h * n, a * u - h * n]
