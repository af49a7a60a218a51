"""Structure of an answer: which solution boxes hold which root or curve.

The solver returns boxes: certified boxes (each proven to hold exactly one root) and boxes it
stopped splitting at resolution sigma without a proof. How they group must not depend on how
boxes happen to touch, so the grouping is done on the **solution set**, not on the boxes:

1. every box gets a point of the solution set: its own polished point, else the limit of
   Gauss-Newton from it, within sigma of the box (:func:`_on_set`); a box with none is
   *undecided* (it could not be ruled out, and no solution was found in or near it);
2. at that point the rank of the constraint Jacobian (all equations) decides what it is:

   * rank ``n`` (regular): an isolated root. Certified boxes are distinct roots; an uncertified
     box's point is the root of a certified box if it lies in that box's uniqueness region, else
     it is proven where it is (Krawczyk on a tiny box) or kept as an uncertified root;
   * rank ``< n``: either a point of a curve or a **singular isolated root**. Continuation
     (:mod:`kinbox.answer.trace`) decides: if a step leaves the point along a kernel direction of
     ``J``, the curve is followed until it closes, ends (domain, inequality) or runs onto a curve
     followed before; boxes whose point lies on a followed curve belong to it (checked by a
     corrector from the curve, so a close but separate curve is told apart). If no step leaves
     it, the point is a singular root: nearby boxes (within sigma) that converge to it are one
     answer, with its multiplicity estimated (:mod:`kinbox.answer.local`).

3. curves that cross (a bifurcation point, where the rank drops once more) or that continue
   each other are one component, found with ``scipy.sparse.csgraph.connected_components``.

Every component reports its **dimension**, the **rank** of the constraint Jacobian at its points
and the degrees of freedom ``dof = n - rank`` that follow (a singular root has ``dof > 0`` but
dimension 0), and for curves the ordered **polylines** of the branches and the bifurcation points.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..formulation.system import System
from ..search.boxes import SolutionBox
from ..search.certify import gauss_newton
from .local import Multiplicity, Quadratic, multiplicity, rank, refine
from .trace import ON_SET, Trace, Tracer, segments_meet_box

#: the longest step along a curve, relative to the typical width of the domain (the polyline's
#: resolution; the step is shorter where the curve turns)
STEP = 0.025
#: at most this many points of a curve get the Jacobian's rank measured for the report
RANK_SAMPLES = 24
#: two points of one root (Newton limits from different boxes) are this close, relative
SAME_ROOT = 1e-8
#: a singular point this close (relative) to a bifurcation point of a followed curve is that
#: point: Newton converges only linearly there and stops short of it, and would leave a stray
#: singular point beside the curve (tests/answer/test_answer.py, bifurcation point met first)
SAME_SINGULAR = 1e-6
#: a followed curve is a curve only if its points, polished, close every equation row within
#: this many times the row's slack (which is at least the bound on the input rows' distance from
#: the rounded ones, ``Compiled.merr``): the tube the search's own curve-box test uses
#: (``search.solver.CURVE_SLACK``; a Griffis-Duffy platform's curves need 0.07 at the lengths of
#: its reference assembly, 36 with those lengths given to 12 decimals). A UR5
#: 1e-10 from its wrist singularity has a valley of near-solutions, 6e-11 off the pose, through
#: two pairs of isolated roots: followed as a curve, it hid them
#: (tests/answer/test_curves.py::test_no_curve_where_the_roots_are_isolated)
CURVE_CLOSURE = 100.0
#: points of a followed curve checked against :data:`CURVE_CLOSURE`
CLOSURE_SAMPLES = 16
#: ...each by itself or by Gauss-Newton's limit from it, if that lies this close (relative)
CLOSURE_SLIDE = 1e-6
#: a followed trace whose points close the equations this many times better in one place
#: than in another, the worst at least :data:`VALLEY_FLOOR` (relative, :meth:`Quadratic.residual`),
#: is a valley of near-solutions through isolated roots, not a curve (:meth:`_Closure.valley`,
#: at :data:`VALLEY_SAMPLES` points): 1e-12 from their wrist singularity, a UR5's valley
#: 5e-15 to 6e-13 (a gain of 120), a UR10's 8.6e-15 to 7.4e-13 (86)
#: (tests/answer/test_curves.py::test_wrist_sweep); on curves, rounding (1e-16..1e-15)
VALLEY_GAIN = 10.0
VALLEY_FLOOR = 1e-13
VALLEY_SAMPLES = 48


@dataclass
class Component:
    """A connected piece of the solution set and the boxes whose points lie on it.

    ``dimension``: 0 for an isolated root, 1 for a curve. ``rank``: the rank of the constraint
    Jacobian at its points (for a curve the largest seen at sample points along it; it drops at
    bifurcation points); ``dof = n - rank``. A root: ``point`` (system variables), ``certified``
    (a Krawczyk proof), ``singular`` (``dof > 0``) with its estimated ``multiplicity`` (None if
    not finite: a real point of a curve of complex solutions). A curve: ``polylines`` (ordered
    points of each branch, system variables; ``closed[k]``: the last point joins the first),
    ``bifurcations`` (points where branches cross), ``complete`` (every branch was followed to an
    end)."""

    dimension: int
    boxes: list[int]
    certified: bool
    rank: int = 0
    dof: int = 0
    point: np.ndarray | None = None
    singular: bool = False
    multiplicity: int | None = 1
    complex_dimension: int | None = None
    polylines: list[np.ndarray] = field(default_factory=list)
    closed: list[bool] = field(default_factory=list)
    bifurcations: list[np.ndarray] = field(default_factory=list)
    complete: bool = True
    #: dimension 0: width of the box known to hold the root (proven, or the hull of its boxes)
    width: float = 0.0
    #: an uncertified root: whether the number of roots within ``width`` is known (its
    #: multiplicity); False where Newton from its boxes ends at several points the precision
    #: does not separate ("roots within d, how many not known")
    count_known: bool = True

    def to_dict(self) -> dict:
        d: dict = {
            "dimension": self.dimension,
            "boxes": len(self.boxes),
            "box_indices": self.boxes,
            "certified": self.certified,
            "rank": self.rank,
            "dof": self.dof,
        }
        if self.dimension == 0:
            d.update(singular=self.singular, multiplicity=self.multiplicity)
            if not self.count_known:
                d["count_known"] = False
        else:
            d.update(bifurcations=len(self.bifurcations), branches=len(self.polylines), complete=self.complete)
        return d


@dataclass
class Structure:
    """The components of an answer and the boxes that belong to none."""

    components: list[Component]
    #: boxes that could not be ruled out but hold no solution found in or near them
    undecided: list[int]
    #: work done: corrector runs along curves
    corrections: int = 0


def components(system: System, boxes, sigma: float) -> list[Component]:
    """Group solution boxes (``SolutionBox``-like: ``lo``, ``hi``, ``x``, ``certified``)."""
    return analyse(system, boxes, sigma).components


def _on_set(q: Quadratic, comp, box, sigma: float) -> np.ndarray | None:
    """A point of the solution set in the box or within sigma of it, or None."""
    # the box's own point first, Gauss-Newton from it only if that is not on the set (the
    # search's corrector has usually put it there: 1300 of 2250 Bricard boxes)
    if q.residual(box.x) <= ON_SET and _near(box, box.x, sigma):
        return np.asarray(box.x, dtype=float)
    x = gauss_newton(comp, box.x, iters=30)
    if q.residual(x) <= ON_SET and _near(box, x, sigma):
        return np.asarray(x, dtype=float)
    # near a singular root Gauss-Newton converges only linearly (and the compiled one gives up)
    y, r = refine(q, x if np.all(np.isfinite(x)) else box.x)
    if r <= ON_SET and _near(box, y, sigma):
        return y
    return None


def _near(box, y, d: float) -> bool:
    return bool(np.all(np.isfinite(y)) and np.all(y >= box.lo - d) and np.all(y <= box.hi + d))


class _Union:
    def __init__(self):
        self.edges: list[tuple[int, int]] = []

    def add(self, a: int, b: int) -> None:
        self.edges.append((a, b))

    def labels(self, n: int) -> np.ndarray:
        if n == 0:
            return np.zeros(0, dtype=int)
        if not self.edges:
            return np.arange(n)
        from scipy.sparse import coo_matrix  # scipy's graphs and trees load when needed: not at start-up
        from scipy.sparse.csgraph import connected_components

        a, b = np.array(self.edges).T
        g = coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n))
        return connected_components(g, directed=False)[1]


def analyse(system: System, boxes, sigma: float, prover=None, seeded=None) -> Structure:
    """The structure of the answer given by ``boxes`` (see the module docstring).

    ``prover(x)`` optionally returns a certified solution box around a regular root ``x`` that
    the solver left uncertified (a Krawczyk proof on a tiny box), or None. ``seeded``: a
    :class:`kinbox.search.point.SeededCertifier` that proves the isolated roots still
    uncertified at the end from Newton's point (:mod:`kinbox.answer.newton_proof`).
    """
    n_box = len(boxes)
    if n_box == 0:
        return Structure([], [])
    comp = system.compile()
    n = comp.n
    if all(b.certified for b in boxes):
        # every box a proven root (distinct by the solver's de-duplication): what steps 1-3 and
        # _roots below make of them, without the machinery for curves and singular roots
        return Structure(
            [Component(0, [i], True, rank=n, dof=0, point=np.asarray(b.x, dtype=float), width=b.width) for i, b in enumerate(boxes)], []
        )
    q = Quadratic(comp)
    lo0, hi0 = system.search_domain()
    width = float(np.median(np.minimum(hi0 - lo0, 1e3))) if n else 1.0
    h_max = STEP * max(width, 1e-6)
    tracer = Tracer(comp, lo0, hi0, h_max=h_max, h_min=1e-3 * h_max)

    # -- 1. a point of the solution set per box ------------------------------------------------
    pts: list[np.ndarray | None] = [np.asarray(b.x, dtype=float) if b.certified else None for b in boxes]
    for i, b in enumerate(boxes):
        if not b.certified:
            pts[i] = _on_set(q, comp, b, sigma)

    # -- 2. roots, curves, singular roots ------------------------------------------------------
    kind = ["undecided"] * n_box  # "root", "curve", "singular"
    on_trace = [-1] * n_box
    # traces that are no curve (:func:`_is_a_curve`): their boxes stay undecided
    false_traces: set[int] = set()
    closure = _Closure(comp)
    roots = [(np.asarray(b.x, dtype=float), b.width) for b in boxes if b.certified]
    ranks = [n] * n_box
    sing: list[int] = []
    for i, b in enumerate(boxes):
        p = pts[i]
        if b.certified:
            kind[i] = "root"
            continue
        near = getattr(b, "within_resolution_of", None)
        home = next((j for j, c in enumerate(boxes) if c.certified and _close(pts[j], near)), -1) if near is not None else -1
        if home >= 0:
            # the solver accepted the box because nothing in it can be told apart from this
            # certified root at the rows' resolution (search/solver.py, _below_floor): it is that
            # root, and _roots puts it there (its point now in that root's box)
            kind[i], pts[i] = "root", pts[home]
            continue
        if p is None:
            continue
        k = tracer.owner_of(p)
        if k >= 0:
            if k not in false_traces:
                kind[i], on_trace[i] = "curve", k
                ranks[i] = n - 1
            continue
        r, _ = rank(q.J(p))
        ranks[i] = r
        if r == n:
            # a regular root: the box belongs to it if it holds it; a box that only lies next to
            # one is undecided (Krawczyk settles such boxes, and the solver splits them until it
            # does, so a twin root nearby cannot hide in them)
            pad = 1e-9 * (1.0 + np.abs(p))
            if np.all(p >= b.lo - pad) and np.all(p <= b.hi + pad):
                kind[i] = "root"
            continue
        if any(_same_singular(pts[j], p, sigma) for j in sing):
            kind[i] = "singular"
            sing.append(i)
            continue
        tr = tracer.trace(p)
        if tr is None:
            kind[i] = "singular"
            sing.append(i)
        elif not _is_a_curve(closure, tracer, len(tracer.traces) - 1, roots, q):
            false_traces.add(len(tracer.traces) - 1)
        else:
            kind[i], on_trace[i] = "curve", len(tracer.traces) - 1
            ranks[i] = n - 1

    # -- 2b. singular points that lie on a curve followed after them ---------------------------
    # No single direction leaves a bifurcation point (the kernel of J is two-dimensional
    # there), so a box that reached one before any curve through it was followed was filed as a
    # singular root, and which box comes first depends on the tree's last bits. With every
    # curve followed, such a point is the curve's: a trace passes through it, or it is one of
    # the bifurcation points the traces found (to the precision of a singular point)
    if sing and tracer.traces:
        for i in list(sing):
            p = pts[i]
            k = _curve_at(tracer, p) if p is not None else -1
            if k >= 0 and k not in false_traces:
                kind[i], on_trace[i], ranks[i] = "curve", k, n - 1
                sing.remove(i)

    # -- 3. boxes with no point of their own, within sigma of a curve or a singular root -------
    # (they are part of the enclosure of the set at resolution sigma; near a regular root a box
    # stays undecided: there certification, not sigma, is the resolution)
    _near_curves(tracer, boxes, kind, on_trace, sigma, false_traces)
    if sing:
        S = np.array([pts[i] for i in sing])
        for i, b in enumerate(boxes):
            if kind[i] == "undecided" and np.any(np.all((S >= b.lo - sigma) & (S <= b.hi + sigma), axis=1)):
                kind[i] = "singular"
                pts[i] = S[int(np.argmax(np.all((S >= b.lo - sigma) & (S <= b.hi + sigma), axis=1)))]
                sing.append(i)

    out: list[Component] = []
    out += _roots(q, boxes, pts, kind, prover, sing, sigma)
    found_sing, no_root = _singular_roots(q, boxes, pts, sing, sigma, [c for c in out if c.certified])
    out += found_sing
    for i in no_root:
        kind[i] = "undecided"
    out += _curves(q, tracer, on_trace, n, false_traces)
    # a box the solver returned whose point lies on nothing: undecided, unless Newton on the
    # square core reaches a regular root from the boxes of its cluster
    undecided = [i for i in range(n_box) if kind[i] == "undecided"]
    found, undecided = _roots_in_undecided(q, comp, boxes, undecided, sigma, out, prover)
    out += found
    if seeded is not None:
        from .newton_proof import certify_from_newton

        out, undecided = certify_from_newton(out, undecided, boxes, seeded)
    out.sort(key=lambda c: min(c.boxes, default=n_box))
    return Structure(out, undecided, tracer.corrections)


#: Newton runs per cluster of undecided boxes (:func:`_roots_in_undecided`), from boxes spread
#: over the cluster
UNDECIDED_STARTS = 64


def _clusters(boxes, idx: list[int], sigma: float) -> list[list[int]]:
    """The boxes ``idx`` grouped by overlap (widened by sigma)."""
    if not idx:
        return []
    from scipy.spatial import cKDTree

    lo = np.array([boxes[i].lo for i in idx]) - sigma
    hi = np.array([boxes[i].hi for i in idx]) + sigma
    c = 0.5 * (lo + hi)
    half = float(np.max(0.5 * (hi - lo)))
    u = _Union()
    for a, nb in enumerate(cKDTree(c).query_ball_point(c, 2.0 * half, p=np.inf)):
        for b in nb:
            if b > a and np.all(lo[a] <= hi[b]) and np.all(lo[b] <= hi[a]):
                u.add(a, b)
    lab = u.labels(len(idx))
    out: dict[int, list[int]] = {}
    for a, k in enumerate(lab):
        out.setdefault(int(k), []).append(idx[a])
    return list(out.values())


def _roots_in_undecided(q: Quadratic, comp, boxes, undecided: list[int], sigma: float, comps: list[Component], prover=None):
    """Roots among undecided boxes: per cluster of them that holds no root reported already,
    Newton on the square core from the :data:`UNDECIDED_STARTS` boxes whose points close the
    equations best. A limit that closes every row within its slack and lies in the cluster
    (within sigma) is a root of the cluster: where ``prover`` proves it, a certified root of
    its own (with the boxes whose limit it is). The limits left unproven are one uncertified
    point whose width is the hull of the cluster's other boxes (the roots of the cluster lie in
    its boxes: the search kept them): if every unproven limit is one point, a root of the
    multiplicity found there; if they are several points, or the one point is singular (``J``
    drops rank there: its multiplicity is not 1, and is not estimated here), the precision does
    not tell how many roots the hull holds, and the point says so (``count_known`` False: "roots
    within d, how many not known"; two double roots 0.05 apart were one such point that stated
    one root, tests/answer/test_singular_count.py). A UR5 1e-6 from its elbow and 1e-9 from its wrist singularity has a
    valley of limits 1e-2 long that close every row, through a real pair 7.5e-4 apart: one
    limit, reported as one root, stood for both
    (tests/answer/test_curves.py::test_a_valley_of_limits_says_its_count_is_not_known). Next to
    a wrist singularity (a UR5 1e-11 from it) the roots are regular but lie in a valley of
    near-solutions that Gauss-Newton on all rows slides along: they were left in undecided
    boxes (tests/answer/test_curves.py). The other clusters stay undecided."""
    if not undecided or comp.n_core != comp.n:
        return [], undecided
    from ..search.certify import Certifier

    cert = Certifier(comp)
    n = comp.n
    known = [c.point for c in comps if c.dimension == 0 and c.point is not None]
    known_w = [c.width for c in comps if c.dimension == 0 and c.point is not None]
    found: list[Component] = []
    left: list[int] = []
    for cl in _clusters(boxes, undecided, sigma):
        lo = np.min([boxes[i].lo for i in cl], axis=0) - sigma
        hi = np.max([boxes[i].hi for i in cl], axis=0) + sigma
        if any(np.all(k >= lo) and np.all(k <= hi) for k in known):
            left += cl  # next to a root reported already: no second answer for it
            continue
        # the boxes whose points close the equations best first: next to the roots of a valley
        order = sorted(cl, key=lambda i: q.residual(np.asarray(boxes[i].x, dtype=float)))
        # a root closes every row within its slack (the points the search keeps): a limit on a
        # valley's floor 0.11 rad from a certified root closed them only to 3e-14 beyond it, and
        # the cluster held no root (tests/answer/test_curves.py::test_wrist_sweep, UR10 1e-12)
        limits: list[tuple[int, np.ndarray]] = []
        for i in order[:UNDECIDED_STARTS]:
            x = cert.newton(np.asarray(boxes[i].x, dtype=float), iters=30)
            if np.all(np.isfinite(x)) and np.all(x >= lo) and np.all(x <= hi) and q.residual(x) <= 0.0:
                limits.append((i, x))
        # distinct limits (the last of each kept: the one reported before when all are one)
        distinct: list[np.ndarray] = []
        for _, x in reversed(limits):
            if not any(_close(d, x) for d in distinct):
                distinct.append(x)
        proofs: list[SolutionBox] = []
        for x in distinct:
            # Krawczyk proves no root where the Jacobian drops rank: no proof asked there
            proof = prover(x) if prover is not None and rank(q.J(x))[0] == n else None
            if proof is not None and not any(_near(p, proof.x, 0.0) for p in proofs):
                proofs.append(proof)
        unproven = [x for x in distinct if not any(_near(p, x, 0.0) for p in proofs)]
        rest = set(cl)
        for p in proofs:
            members = sorted(i for i, x in limits if _near(p, x, 0.0))
            rest -= set(members)
            if any(float(np.max(np.abs(p.x - k))) <= p.width + w for k, w in zip(known, known_w)):
                left += members  # a root reported already
                continue
            found.append(Component(0, members, True, rank=n, dof=0, point=np.asarray(p.x, dtype=float), width=p.width))
            known.append(np.asarray(p.x, dtype=float))
            known_w.append(p.width)
        if not unproven:
            left += sorted(rest)  # no root found in them beyond the proven ones
            continue
        best = unproven[0]
        rlo = np.min([boxes[i].lo for i in rest], axis=0) - sigma
        rhi = np.max([boxes[i].hi for i in rest], axis=0) + sigma
        width = float(np.max(rhi - rlo))
        if any(float(np.max(np.abs(best - k))) <= width + w for k, w in zip(known, known_w)):
            left += sorted(rest)  # a root reported already that this precision does not tell from it
            continue
        rk, _ = rank(q.J(best))
        found.append(
            Component(0, sorted(rest), False, rank=rk, dof=n - rk, point=best, width=width, count_known=len(unproven) == 1 and rk == n)
        )
        known.append(best)
        known_w.append(width)
    return found, left


def _one_root_between(q: Quadratic, a: np.ndarray, b: np.ndarray) -> bool:
    """Two Newton limits no equation tells apart: every point between them closes the rows
    to :data:`ON_SET` (two roots would have rows that grow between them)."""
    ts = np.linspace(0.0, 1.0, BLUR_SAMPLES + 1)
    return all(q.residual(a + t * (b - a)) <= ON_SET for t in ts)


def _near_curves(tracer: Tracer, boxes, kind: list[str], on_trace: list[int], sigma: float, false_traces: set[int]) -> None:
    """Undecided boxes that a followed curve passes through or within sigma of go to it."""
    if not tracer.traces:
        return
    a, b, owner = [], [], []
    for k, tr in enumerate(tracer.traces):
        if k in false_traces:
            continue
        P = np.array(tr.points)
        if len(P) < 2:
            continue
        Q = np.vstack([P[1:], P[:1]]) if tr.closed else P[1:]
        a.append(P[: len(Q)])
        b.append(Q)
        owner += [k] * len(Q)
    if not a:
        return
    A, B = np.vstack(a), np.vstack(b)
    own = np.array(owner)
    mid = 0.5 * (A + B)
    half = 0.5 * np.max(np.abs(B - A), axis=1)
    from scipy.spatial import cKDTree

    tree = cKDTree(mid)
    reach = float(np.max(half))
    for i, bx in enumerate(boxes):
        if kind[i] != "undecided":
            continue
        c = 0.5 * (bx.lo + bx.hi)
        r = 0.5 * float(np.max(bx.hi - bx.lo)) + sigma + reach
        cand = np.array(sorted(tree.query_ball_point(c, r, p=np.inf)), dtype=int)
        if len(cand) == 0:
            continue
        hit = segments_meet_box(A[cand], B[cand], bx.lo - sigma, bx.hi + sigma)
        if np.any(hit):
            kind[i], on_trace[i] = "curve", int(own[cand[int(np.argmax(hit))]])


def _curve_at(tracer: Tracer, p: np.ndarray) -> int:
    """The followed curve through ``p`` (a point where ``J`` drops rank), or -1."""
    k = tracer.owner_of(p)
    if k >= 0:
        return k
    tol = SAME_SINGULAR * (1.0 + float(np.max(np.abs(p))))
    for k, tr in enumerate(tracer.traces):
        if any(float(np.max(np.abs(tr.points[j] - p))) <= tol for j in tr.bifurcations):
            return k
    return -1


def _same_singular(a, b, sigma: float) -> bool:
    return a is not None and b is not None and float(np.max(np.abs(a - b))) <= sigma


def _roots(q: Quadratic, boxes, pts, kind, prover, sing: list[int], sigma: float) -> list[Component]:
    """One component per regular root: certified boxes first (distinct by the solver's
    de-duplication), then uncertified boxes whose points are regular roots.

    An uncertified point that no proof settles and that cannot be told apart from a singular
    root at working precision (:func:`_blurred_into`) joins that root (its box moves to ``sing``,
    its point to the root's): near a double root the equations are flat along the kernel, so
    points up to ~1e-5 away close every equation to 1e-12, and Newton from them stops there
    (the UR5 at its elbow singularity was reported as a double root plus a "regular" one
    2e-5 away)."""
    comps: list[Component] = []
    n = q.n
    for i, b in enumerate(boxes):
        if b.certified:
            comps.append(Component(0, [i], True, rank=n, dof=0, point=pts[i], width=b.width))
    cert = list(comps)
    tree = None  # built at the first uncertified root (most answers have none)
    for i, b in enumerate(boxes):
        if b.certified or kind[i] != "root":
            continue
        p = pts[i]
        home = None
        if tree is None and cert:
            from scipy.spatial import cKDTree

            tree = cKDTree(np.array([c.point for c in cert]))
        if tree is not None:
            for j in tree.query_ball_point(p, 1e-6 * (1.0 + float(np.max(np.abs(p)))) + 1e-300, p=np.inf):
                cb = boxes[cert[j].boxes[0]]
                if _near(cb, p, 0.0):
                    home = cert[j]  # in the certified box's uniqueness region: that root
                    break
        if home is None:
            home = next((c for c in comps[len(cert) :] if _close(c.point, p)), None)
        if home is None:
            proof = prover(p) if prover is not None else None
            if proof is not None:
                # proven where it is: the same root as a certified box if that box holds it
                home = next((c for c in cert if _close(c.point, proof.x)), None)
                if home is None:
                    home = Component(0, [], True, rank=n, dof=0, point=np.asarray(proof.x, dtype=float), width=proof.width)
                    comps.append(home)
            else:
                j = _blurred_into(q, p, [pts[k] for k in sing], sigma)
                if j >= 0:
                    kind[i], pts[i] = "singular", pts[sing[j]]
                    sing.append(i)
                    continue
                home = Component(0, [], False, rank=n, dof=0, point=p, width=float(np.max(b.hi - b.lo)))
                comps.append(home)
        home.boxes.append(i)
    return [c for c in comps if c.boxes]


#: points sampled on the segment between a point and a singular root by :func:`_blurred_into`
BLUR_SAMPLES = 16


def _blurred_into(q: Quadratic, p: np.ndarray, roots: list, sigma: float) -> int:
    """The index of a singular root in ``roots`` that ``p`` cannot be told apart from, or -1:
    within sigma, and every point of the segment between them is on the solution set to
    :data:`ON_SET` (two distinct roots would have equations that grow between them). Only
    uncertified points are asked: a root with a proof is never merged."""
    for j, s in enumerate(roots):
        if s is None or float(np.max(np.abs(s - p))) > sigma:
            continue
        ts = np.linspace(0.0, 1.0, BLUR_SAMPLES + 1)
        if all(q.residual(s + t * (p - s)) <= ON_SET for t in ts):
            return j
    return -1


def _close(a, b) -> bool:
    return float(np.max(np.abs(a - b))) <= SAME_ROOT * (1.0 + float(np.max(np.abs(a))))


def _singular_roots(q: Quadratic, boxes, pts, sing: list[int], sigma: float, cert: list[Component]) -> tuple[list[Component], list[int]]:
    """Boxes whose points converge to a singular isolated root: one component per root (points
    within sigma of each other, the resolution asked for, are one root).

    A group whose root, refined, lies in the uniqueness region of a certified root (``cert``)
    is that root: its boxes join it. Between the two roots of a near-double pair (a Dietmeier
    pose 1e-5 from a singular one: roots 7e-6 apart, both certified) the equations are flat,
    a box there looks singular, and Newton from it ends on one of the two: it was reported a
    third time, as a double root.

    The group's points are within sigma of each other in a chain, so its hull can hold more
    roots than the one its point refines to: the multiplicity found there is stated as the
    hull's count only where Newton from the group's boxes reaches no other root
    (:func:`_one_singular_root`), else the count is not known (``count_known`` False).

    A group whose multiplicity is estimated 0 (its refined point closes no root at the
    estimate's tolerance: a near-solution on a valley, 1e-9 from a UR5's wrist singularity in
    the general formulation) is no root: its boxes are returned apart, and stay undecided (not
    ruled out) instead of standing for "0 roots within d"."""
    if not sing:
        return [], []
    from scipy.spatial import cKDTree

    P = np.array([pts[i] for i in sing])
    pairs = cKDTree(P).query_pairs(sigma, p=np.inf, output_type="ndarray")
    u = _Union()
    for a, b in pairs:
        u.add(int(a), int(b))
    lab = u.labels(len(sing))
    out = []
    none: list[int] = []
    for g in sorted(set(lab.tolist()), key=lambda g: int(np.argmax(lab == g))):
        members = [sing[k] for k in np.nonzero(lab == g)[0]]
        best = min(members, key=lambda i: q.residual(pts[i]))
        x, _ = refine(q, pts[best])
        home = next((c for c in cert if _near(boxes[c.boxes[0]], x, 0.0)), None)
        if home is not None:
            home.boxes.extend(members)
            home.boxes.sort()
            continue
        m: Multiplicity = multiplicity(q, x)
        if m.value == 0:
            none += members
            continue
        r, _ = rank(q.J(x))
        hlo = np.min([boxes[i].lo for i in members], axis=0)
        hhi = np.max([boxes[i].hi for i in members], axis=0)
        hull = np.max(hhi - hlo)
        out.append(
            Component(
                0,
                sorted(members),
                False,
                rank=r,
                dof=q.n - r,
                point=x,
                singular=True,
                multiplicity=m.value,
                complex_dimension=m.complex_dimension,
                width=float(hull),
                count_known=_one_singular_root(q, boxes, pts, members, x, hlo - sigma, hhi + sigma),
            )
        )
    return out, none


#: refinements per group of singular boxes (:func:`_one_singular_root`), from boxes spread over it
SINGULAR_STARTS = 32


def _one_singular_root(q: Quadratic, boxes, pts, members: list[int], x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> bool:
    """Whether the singular root ``x`` is the only root the group's boxes ``members`` lead to,
    so that its multiplicity counts the roots of the group's hull (``lo``, ``hi``: the hull
    widened by sigma). The points of a group are within sigma of each other in a chain, and its
    hull may hold other roots than ``x``: two double roots 0.1 apart with sigma 0.1 were one
    group, reported as one root of multiplicity 3 whose hull held four
    (tests/answer/test_singular_count.py). From up to :data:`SINGULAR_STARTS` members (their
    points and their boxes' points, spread over the group) least-squares Newton
    (:func:`kinbox.answer.local.refine`) runs; a limit that closes the equations (to
    :data:`ON_SET`) inside the hull and cannot be told from ``x`` (within :data:`SAME_SINGULAR`,
    or on the solution set all the way to it, as :func:`_blurred_into` asks) is ``x``; any other
    such limit is a second root, and the count is not known ("roots within d, how many not
    known"). A limit that closes nothing or leaves the hull is no root of it. A heuristic that
    can only take a count away: a root no start reaches keeps the count stated."""
    step = max(1, len(members) // SINGULAR_STARTS)
    tol = SAME_SINGULAR * (1.0 + float(np.max(np.abs(x))))
    ts = np.linspace(0.0, 1.0, BLUR_SAMPLES + 1)
    for i in members[::step][:SINGULAR_STARTS]:
        for start in (pts[i], boxes[i].x):
            if start is None:
                continue
            y, r = refine(q, np.asarray(start, dtype=float))
            if not (r <= ON_SET and np.all(y >= lo) and np.all(y <= hi)):
                continue
            if float(np.max(np.abs(y - x))) <= tol or all(q.residual(x + t * (y - x)) <= ON_SET for t in ts):
                continue
            return False
    return True


class _Closure:
    """Whether a point, polished by Gauss-Newton on all equations, closes every equation row
    within :data:`CURVE_CLOSURE` times its slack."""

    def __init__(self, comp):
        self.comp = comp
        self.cert = None
        self.tol = CURVE_CLOSURE * (comp.slack[: comp.n_eq] if len(comp.slack) else np.zeros(comp.n_eq))

    def closes(self, x: np.ndarray) -> bool:
        """Does ``x``, or Gauss-Newton's limit from it within :data:`CLOSURE_SLIDE` of it, close
        every row within the tube? A limit farther away closes the rows somewhere else: next to a
        UR5's wrist singularity in the general formulation (1e-7 from it), Gauss-Newton slid every
        point of a valley of near-solutions 1e-3 along it onto the isolated root at its end, and the
        valley was reported as a curve in place of four roots
        (tests/answer/test_newton_proof.py::test_a_valley_is_no_curve_in_the_general_formulation)."""
        far = CLOSURE_SLIDE * (1.0 + float(np.max(np.abs(x), initial=0.0)))
        for y in (x, gauss_newton(self.comp, x, iters=30)):
            if not (np.all(np.isfinite(y)) and float(np.max(np.abs(y - x), initial=0.0)) <= far):
                continue
            if bool(np.all(np.abs(self.comp.eval_eqs(y)) <= self.tol)):
                return True
        return False

    def valley(self, q: Quadratic, pts) -> bool:
        """Do the points of a followed trace (polished by Gauss-Newton) close the equations
        unevenly, the worst above :data:`VALLEY_FLOOR` and :data:`VALLEY_GAIN` times the best?
        On a curve every point closes them to rounding, as well as any other; a valley of
        near-solutions through isolated roots closes them best next to the roots (square
        systems only: a mechanism's rows given to a few decimals close unevenly on its curves)."""
        if self.comp.n_core != self.comp.n or len(pts) < 2:
            return False
        r = []
        for x in pts:
            y = gauss_newton(self.comp, np.asarray(x, dtype=float), iters=30)
            r.append(q.residual(y) if np.all(np.isfinite(y)) else np.inf)
        worst, best = max(r), min(r)
        return worst >= VALLEY_FLOOR and best * VALLEY_GAIN <= worst


def _is_a_curve(closure: _Closure, tracer: Tracer, k: int, roots: list[tuple[np.ndarray, float]], q: Quadratic | None = None) -> bool:
    """Is trace ``k`` a curve of the solution set at the working precision? Its points must close
    every equation to the rounding the rows carry (:class:`_Closure`, at
    :data:`CLOSURE_SAMPLES` points along it), and no certified root may lie on it: a certified
    root is proven the only zero of its box, so a curve through it is not one of the input's
    (the same configuration would be reported twice, as a root and as a point of a curve).
    Nor may its points close them unevenly (:meth:`_Closure.valley`): a UR5 1e-12 from its
    wrist singularity has a valley of near-solutions, 6e-13 off and within the tube, that
    closes them to 5e-15 next to its isolated roots."""
    pts = tracer.traces[k].points
    step = max(1, len(pts) // CLOSURE_SAMPLES)
    if not all(closure.closes(np.asarray(p, dtype=float)) for p in pts[::step]):
        return False
    if q is not None and closure.valley(q, pts[:: max(1, len(pts) // VALLEY_SAMPLES)]):
        return False
    return not any(_on_trace(tracer, k, r, w) for r, w in roots)


def _on_trace(tracer: Tracer, k: int, r: np.ndarray, w: float) -> bool:
    """Does trace ``k`` pass through the certified root ``r`` (enclosure width ``w``)? The
    corrector from the trace's nearest vertex, on the hyperplane through ``r`` normal to the
    tangent there, lands within the root's enclosure (or ``owner_of`` finds it on the trace):
    near a wrist 1e-12 from singular the enclosure is 6e-4 wide, and the corrector lands on the
    valley's floor beside the root, not on it."""
    if tracer.owner_of(r) == k:
        return True
    tr = tracer.traces[k]
    P = np.array(tr.points)
    if len(P) == 0 or len(tr.tangents) != len(P):
        return False
    j = int(np.argmin(np.max(np.abs(P - r), axis=1)))
    if float(np.max(np.abs(P[j] - r))) > 2.0 * tracer.h_max:
        return False
    t = tr.tangents[j]
    z = tracer.correct(P[j] + float(t @ (r - P[j])) * t, t, strict=False)
    return z is not None and float(np.max(np.abs(z - r))) <= w + 1e-7 * (1.0 + float(np.max(np.abs(r))))


def _curves(q: Quadratic, tracer: Tracer, on_trace: list[int], n: int, false_traces: set[int] = frozenset()) -> list[Component]:  # type: ignore[assignment]
    """Traces joined into components: traces that ran onto each other, crossed, or share a
    bifurcation point (traces that are no curve left out)."""
    traces = tracer.traces
    if not traces:
        return []
    u = _Union()
    for k, tr in enumerate(traces):
        for o in tr.touches:
            u.add(k, o)
    bif = [(k, tr.points[i]) for k, tr in enumerate(traces) for i in tr.bifurcations]
    for a in range(len(bif)):
        for b in range(a):
            if float(np.max(np.abs(bif[a][1] - bif[b][1]))) <= 1e-6:
                u.add(bif[a][0], bif[b][0])
    lab = u.labels(len(traces))
    out = []
    for g in sorted(set(lab.tolist()), key=lambda g: int(np.argmax(lab == g))):
        ks = [k for k in range(len(traces)) if lab[k] == g and k not in false_traces]
        members = sorted(i for i, k in enumerate(on_trace) if k >= 0 and lab[k] == g)
        if not members:
            continue
        branches: list[Trace] = [traces[k] for k in ks if len(traces[k].points) >= 2]
        points: list[np.ndarray] = []
        for k in ks:
            for i in traces[k].bifurcations:
                p = traces[k].points[i]
                if not any(float(np.max(np.abs(p - o))) <= 1e-6 for o in points):
                    points.append(p)
        sample = [p for tr in branches for p in tr.points]
        step = max(1, len(sample) // RANK_SAMPLES)
        r = max((rank(q.J(p))[0] for p in sample[::step]), default=n - 1)
        out.append(
            Component(
                1,
                members,
                False,
                rank=r,
                dof=n - r,
                polylines=[np.array(tr.points) for tr in branches],
                closed=[tr.closed for tr in branches],
                bifurcations=points,
                complete=all(traces[k].complete for k in ks),
            )
        )
    return out
