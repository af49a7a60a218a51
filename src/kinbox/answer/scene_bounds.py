"""Lower bounds on the distances of a scene's pairs from their bounding volumes, for many
configurations at once (compiled: :class:`kinbox.answer.collision.Checker` calls it for the
solutions of every answer).

Each geometry has a ball (centre in its joint's frame, radius) and a box about the same centre
(half-widths in its joint's frame, holding the geometry). Placed by the joint's homogeneous
placement ``H`` (Pinocchio's ``data.oMi``), the ball's centre is ``R c + t`` and the box in the
world has half-widths ``|R| h``. The bound of a pair is the larger of the balls' gap
``|c_a - c_b| - r_a - r_b`` and the boxes' signed gap (per axis ``g = |c_a - c_b| - h_a - h_b``;
``|max(g, 0)|`` when apart, ``max g`` -- the boxes' depth along the best axis -- when they
overlap), less ``tol``; both hold in penetration too: a shape inside a ball or box goes no
deeper than it (tests/answer/test_scene.py::test_bounds_below_coal).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np


@nb.njit(cache=True)
def pair_bounds(
    H: np.ndarray,  # (m, J, 4, 4): the placements of the joints carrying geometry, per configuration
    slot: np.ndarray,  # (G,): the row of H of each geometry's joint, -1 for a world-fixed geometry
    centre: np.ndarray,  # (G, 3): ball and box centres, in the joint's frame (world-fixed: in the world)
    half: np.ndarray,  # (G, 3): box half-widths, in the joint's frame (world-fixed: in the world)
    radius: np.ndarray,  # (G,)
    a: np.ndarray,  # (P,) the pairs' first geometries
    b: np.ndarray,  # (P,) and second ones
    tol: float,
) -> np.ndarray:
    m, G, P = H.shape[0], centre.shape[0], a.shape[0]
    out = np.empty((m, P))
    c = np.empty((G, 3))
    h = np.empty((G, 3))
    for r in range(m):
        for g in range(G):
            s = slot[g]
            if s < 0:
                for i in range(3):
                    c[g, i] = centre[g, i]
                    h[g, i] = half[g, i]
                continue
            for i in range(3):
                ci = H[r, s, i, 3]
                hi = 0.0
                for j in range(3):
                    ci += H[r, s, i, j] * centre[g, j]
                    hi += abs(H[r, s, i, j]) * half[g, j]
                c[g, i] = ci
                h[g, i] = hi
        for p in range(P):
            ga, gb = a[p], b[p]
            d2 = 0.0
            o2 = 0.0
            deepest = -math.inf
            for i in range(3):
                x = c[ga, i] - c[gb, i]
                d2 += x * x
                gi = abs(x) - h[ga, i] - h[gb, i]
                if gi > 0.0:
                    o2 += gi * gi
                if gi > deepest:
                    deepest = gi
            ball = math.sqrt(d2) - radius[ga] - radius[gb]
            box = math.sqrt(o2) if deepest > 0.0 else deepest
            out[r, p] = (ball if ball > box else box) - tol
    return out
