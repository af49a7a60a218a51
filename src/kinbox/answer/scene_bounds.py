"""Lower bounds on the distances of a scene's pairs from their bounding volumes, for many
configurations at once (compiled: :class:`kinbox.answer.collision.Checker` calls it for the
solutions of every answer).

Each geometry has a ball (centre in its joint's frame, radius) and a box about the same centre:
coal's local AABB of the geometry, turned by the geometry's placement (its axes ``rot`` in the
joint's frame, half-widths ``h`` along them), so that it holds the geometry. Placed by the
joint's homogeneous placement ``H`` (Pinocchio's ``data.oMi``), the ball's centre is ``R c + t``
and the box's axes ``R rot``. The bound of a pair is the largest of

* the balls' gap ``|c_a - c_b| - r_a - r_b``;
* the signed gap of the boxes' world AABBs (half-widths ``|R rot| h``; per axis
  ``g = |c_a - c_b| - h_a - h_b``; ``|max(g, 0)|`` when apart, ``max g`` when they overlap);
* the boxes' gap along each of their separating axes (each box's three axes and the nine cross
  products of one's with the other's): ``|d . u| - r_a(u) - r_b(u)`` for a unit ``u``, where
  ``r(u) = sum_k h_k |axis_k . u|`` is the box's half-extent along ``u``;

less ``tol``. Each holds in penetration too: along any direction a shape inside a box overlaps
the other no more than the box does, and its penetration depth is its smallest overlap over
the directions; a mesh's distance (coal's smallest over its triangles) is no smaller than that
of the box holding them all (tests/answer/test_scene.py::test_bounds_below_coal).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

#: a cross product of two box axes shorter than this (nearly parallel axes) is no axis tested
MIN_AXIS = 1e-6


@nb.njit(cache=True, inline="always")
def _gap(u0: float, u1: float, u2: float, d: np.ndarray, Ra: np.ndarray, ha: np.ndarray, Rb: np.ndarray, hb: np.ndarray) -> float:
    """The gap of two boxes (axes ``Ra``, ``Rb`` as columns, half-widths ``ha``, ``hb``,
    centres ``d`` apart) along the direction ``u`` (not normalised: the gap is divided by
    ``|u|``)."""
    ra = 0.0
    rb = 0.0
    for k in range(3):
        ra += ha[k] * abs(Ra[0, k] * u0 + Ra[1, k] * u1 + Ra[2, k] * u2)
        rb += hb[k] * abs(Rb[0, k] * u0 + Rb[1, k] * u1 + Rb[2, k] * u2)
    return (abs(d[0] * u0 + d[1] * u1 + d[2] * u2) - ra - rb) / math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)


@nb.njit(cache=True)
def pair_bounds(
    H: np.ndarray,  # (m, J, 4, 4): the placements of the joints carrying geometry, per configuration
    slot: np.ndarray,  # (G,): the row of H of each geometry's joint, -1 for a world-fixed geometry
    centre: np.ndarray,  # (G, 3): ball and box centres, in the joint's frame (world-fixed: in the world)
    rot: np.ndarray,  # (G, 3, 3): the box's axes (columns), in the joint's frame (world-fixed: in the world)
    half: np.ndarray,  # (G, 3): box half-widths along its axes
    radius: np.ndarray,  # (G,)
    a: np.ndarray,  # (P,) the pairs' first geometries
    b: np.ndarray,  # (P,) and second ones
    tol: float,
) -> np.ndarray:
    m, G, P = H.shape[0], centre.shape[0], a.shape[0]
    out = np.empty((m, P))
    c = np.empty((G, 3))
    R = np.empty((G, 3, 3))
    w = np.empty((G, 3))
    d = np.empty(3)
    for r in range(m):
        for g in range(G):
            s = slot[g]
            for i in range(3):
                if s < 0:
                    c[g, i] = centre[g, i]
                    for k in range(3):
                        R[g, i, k] = rot[g, i, k]
                else:
                    ci = H[r, s, i, 3]
                    for j in range(3):
                        ci += H[r, s, i, j] * centre[g, j]
                    c[g, i] = ci
                    for k in range(3):
                        v = 0.0
                        for j in range(3):
                            v += H[r, s, i, j] * rot[g, j, k]
                        R[g, i, k] = v
            for i in range(3):
                wi = 0.0
                for k in range(3):
                    wi += abs(R[g, i, k]) * half[g, k]
                w[g, i] = wi
        for p in range(P):
            ga, gb = a[p], b[p]
            d2 = 0.0
            o2 = 0.0
            deepest = -math.inf
            for i in range(3):
                x = c[ga, i] - c[gb, i]
                d[i] = x
                d2 += x * x
                gi = abs(x) - w[ga, i] - w[gb, i]
                if gi > 0.0:
                    o2 += gi * gi
                if gi > deepest:
                    deepest = gi
            ball = math.sqrt(d2) - radius[ga] - radius[gb]
            best = math.sqrt(o2) if deepest > 0.0 else deepest
            if ball > best:
                best = ball
            Ra, Rb, ha, hb = R[ga], R[gb], half[ga], half[gb]
            for i in range(3):
                g1 = _gap(Ra[0, i], Ra[1, i], Ra[2, i], d, Ra, ha, Rb, hb)
                g2 = _gap(Rb[0, i], Rb[1, i], Rb[2, i], d, Ra, ha, Rb, hb)
                if g1 > best:
                    best = g1
                if g2 > best:
                    best = g2
                for j in range(3):
                    u0 = Ra[1, i] * Rb[2, j] - Ra[2, i] * Rb[1, j]
                    u1 = Ra[2, i] * Rb[0, j] - Ra[0, i] * Rb[2, j]
                    u2 = Ra[0, i] * Rb[1, j] - Ra[1, i] * Rb[0, j]
                    if u0 * u0 + u1 * u1 + u2 * u2 > MIN_AXIS * MIN_AXIS:
                        gx = _gap(u0, u1, u2, d, Ra, ha, Rb, hb)
                        if gx > best:
                            best = gx
            out[r, p] = best - tol
    return out
