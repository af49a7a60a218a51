"""Structure of an answer: connected components of solution boxes and their dimension.

Boxes that share a point are adjacent (a curve of solutions crosses the face two neighbouring
boxes were cut from, and conservative shrinking keeps that crossing point in both). Each
connected component gets a dimension estimated two ways, which must agree for a confident
answer:

* from the Jacobian at the polished points of its boxes: ``dim = n - rank J`` (the tangent
  space of a smooth solution set; a rank drop beyond that marks a singular point);
* from the boxes: one certified box is an isolated point; many boxes spread far beyond
  ``sigma`` are a set of dimension >= 1; a component no wider than ``sigma`` is a point at
  that resolution (a singular root has a rank-deficient Jacobian too).

A box of a curve component from which three or more branches leave (connected groups among
its neighbours), or whose Jacobian drops rank further than its component's, is flagged as a
possible bifurcation.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..formulation.system import System


@dataclass
class Component:
    dimension: int
    boxes: list[int]
    certified: bool
    bifurcations: list[int] = field(default_factory=list)

    def to_dict(self) -> dict:
        return {"dimension": self.dimension, "boxes": len(self.boxes), "box_indices": self.boxes,
                "certified": self.certified, "bifurcations": self.bifurcations}


def adjacency(los: np.ndarray, his: np.ndarray, tol: float = 1e-9) -> list[list[int]]:
    """Neighbour lists of boxes that intersect or touch (within ``tol`` relative width)."""
    n = len(los)
    nbrs: list[list[int]] = [[] for _ in range(n)]
    if n == 0:
        return nbrs
    pad = tol * (1.0 + np.abs(los) + np.abs(his))
    lo, hi = los - pad, his + pad
    order = np.argsort(lo[:, 0])
    lo_s, hi_s = lo[order], hi[order]
    for a in range(n):
        # sweep along the first coordinate: candidates start before this box ends
        b_end = np.searchsorted(lo_s[:, 0], hi_s[a, 0], side="right")
        cand = np.arange(a + 1, b_end)
        if len(cand) == 0:
            continue
        ok = np.all((lo_s[cand] <= hi_s[a]) & (lo_s[a] <= hi_s[cand]), axis=1)
        for b in cand[ok]:
            i, j = int(order[a]), int(order[b])
            nbrs[i].append(j)
            nbrs[j].append(i)
    return nbrs


def _branches(nbrs: list[list[int]], i: int) -> int:
    """Number of branches leaving box ``i``: connected groups among its neighbours.

    A box on a smooth curve has two (one at an end); where branches of the solution set
    meet there are three or more.
    """
    near = set(nbrs[i])
    seen: set[int] = set()
    groups = 0
    for s in near:
        if s in seen:
            continue
        groups += 1
        stack = [s]
        seen.add(s)
        while stack:
            a = stack.pop()
            for b in nbrs[a]:
                if b in near and b not in seen:
                    seen.add(b)
                    stack.append(b)
    return groups


def _on_set(system: System, box) -> np.ndarray:
    """A point of the solution set near the box: its own point if that solves the equations,
    else an unclipped Gauss-Newton projection from it (the tangent space is measured there)."""
    comp = system.compile()
    if np.max(np.abs(comp.eval_eqs(box.x)), initial=0.0) <= 1e-9:
        return box.x
    from ..search.certify import gauss_newton

    y = gauss_newton(comp, box.x, iters=20)
    return y if np.max(np.abs(comp.eval_eqs(y)), initial=0.0) <= 1e-9 else box.x


def _rank_deficiency(system: System, x: np.ndarray) -> int:
    comp = system.compile()
    if comp.n == 0:
        return 0
    J = comp.jacobian(x)
    if J.size == 0:
        return comp.n
    sv = np.linalg.svd(J, compute_uv=False)
    tol = max(J.shape) * np.finfo(float).eps * max(sv[0], 1.0) * 1e4
    return comp.n - int(np.sum(sv > tol))


def components(system: System, boxes, sigma: float) -> list[Component]:
    """Group solution boxes (``SolutionBox``-like: ``lo``, ``hi``, ``x``, ``certified``)."""
    if not boxes:
        return []
    los = np.array([b.lo for b in boxes])
    his = np.array([b.hi for b in boxes])
    nbrs = adjacency(los, his)
    n = len(boxes)
    parent = list(range(n))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i in range(n):
        for j in nbrs[i]:
            parent[find(i)] = find(j)
    # a box that holds no solution itself (it only lies within sigma of the set) belongs with
    # the box that holds the solution its projection reaches: no one-box "components" beside a
    # curve or a certified root
    on_set = [_on_set(system, b) for b in boxes]
    pad = 1e-9 * (1.0 + np.abs(los) + np.abs(his))
    for i in range(n):
        y = on_set[i]
        if y is boxes[i].x or _rank_deficiency(system, y) == 0:
            continue  # (near an isolated root, boxes of distinct roots must stay apart)
        holders = np.nonzero(np.all((los - pad <= y) & (y <= his + pad), axis=1))[0]
        for h in holders:
            parent[find(i)] = find(int(h))
    groups: dict[int, list[int]] = {}
    for i in range(n):
        groups.setdefault(find(i), []).append(i)
    out: list[Component] = []
    for members in sorted(groups.values()):
        defic = [_rank_deficiency(system, on_set[i]) for i in members]
        extent = float(np.max(his[members].max(axis=0) - los[members].min(axis=0)))
        all_cert = all(boxes[i].certified for i in members)
        if all_cert and len(members) == 1:
            dim = 0
        else:
            dim = int(np.median(defic))
            if dim == 0 and extent > 4 * sigma and len(members) > 3:
                dim = 1  # spread far beyond sigma: not a point, whatever the rank says
            elif dim >= 1 and extent <= sigma:
                # no wider than sigma, the resolution asked for: a point, whatever the rank says
                # (a double root, e.g. a UR5 at its elbow singularity, has a rank-deficient J;
                # depending on the search path it was reported as a curve and not as a solution)
                dim = 0
        bif = []
        if dim >= 1:
            for i, d in zip(members, defic):
                if d > dim or _branches(nbrs, i) >= 3:
                    bif.append(i)
        out.append(Component(dim, members, all_cert, bif))
    return out
