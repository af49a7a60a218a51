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
* the boxes' gap along each box's own three axes: ``|d . u| - r_a(u) - r_b(u)`` for the unit
  axis ``u``, where ``r(u) = sum_k h_k |axis_k . u|`` is a box's half-extent along ``u``;

less ``tol``. Each holds in penetration too: along any direction a shape inside a box overlaps
the other no more than the box does, and its penetration depth is its smallest overlap over
the directions; a mesh's distance (coal's smallest over its triangles) is no smaller than that
of the box holding them all (tests/answer/test_scene.py::test_bounds_below_coal).
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
    t = np.empty(3)
    C = np.empty((3, 3))
    A = np.empty((3, 3))
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
            # the gaps along each box's own axes, in box a's frame: C = Ra^T Rb, t = Ra^T d
            for i in range(3):
                t[i] = R[ga, 0, i] * d[0] + R[ga, 1, i] * d[1] + R[ga, 2, i] * d[2]
                for j in range(3):
                    x = R[ga, 0, i] * R[gb, 0, j] + R[ga, 1, i] * R[gb, 1, j] + R[ga, 2, i] * R[gb, 2, j]
                    C[i, j] = x
                    A[i, j] = abs(x)
            ha, hb = half[ga], half[gb]
            for i in range(3):
                gi = abs(t[i]) - ha[i] - (hb[0] * A[i, 0] + hb[1] * A[i, 1] + hb[2] * A[i, 2])
                if gi > best:
                    best = gi
            for j in range(3):
                sj = C[0, j] * t[0] + C[1, j] * t[1] + C[2, j] * t[2]
                gj = abs(sj) - (ha[0] * A[0, j] + ha[1] * A[1, j] + ha[2] * A[2, j]) - hb[j]
                if gj > best:
                    best = gj
            out[r, p] = best - tol
    return out


@nb.njit(cache=True)
def stable_order(row: np.ndarray) -> np.ndarray:
    """The indices of ``row`` by increasing value, equal values in index order: NumPy's
    ``argsort(kind="stable")`` (tests/answer/test_scene.py::test_sorted_bounds_as_numpy)."""
    return np.argsort(row, kind="mergesort")


@nb.njit(cache=True)
def sorted_pair_bounds(
    H: np.ndarray,
    slot: np.ndarray,
    centre: np.ndarray,
    rot: np.ndarray,
    half: np.ndarray,
    radius: np.ndarray,
    a: np.ndarray,
    b: np.ndarray,
    tol: float,
    margin: float,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`pair_bounds`, with per configuration the pairs by increasing bound (a stable
    sort, as ``np.argsort(kind="stable")``) in ``order[:, :-1]`` and, in ``order[:, -1]``, how
    many of them do not clear ``margin`` (bound <= margin): all an answer's verdicts need
    from its bounds in one call."""
    lb = pair_bounds(H, slot, centre, rot, half, radius, a, b, tol)
    m, P = lb.shape
    order = np.empty((m, P + 1), dtype=np.int64)
    for r in range(m):
        row = lb[r]
        order[r, :P] = stable_order(row)
        low = 0
        for p in range(P):
            if row[p] <= margin:
                low += 1
        order[r, P] = low
    return lb, order
