"""Curves of solutions followed by continuation: ordered points, ends, bifurcations.

The solver's boxes enclose a curve at resolution sigma, but whether two boxes belong to one
curve cannot be read off the boxes alone: pieces of one curve may not touch (a box shrunk away
from its neighbour), and two separate curves that come close share boxes. A curve is therefore
*followed*: pseudo-arclength continuation (Allgower and Georg, *Introduction to Numerical
Continuation Methods*, ch. 2) from a point of it, on all equations of the system:

* **predictor**: a step ``h`` along the unit tangent ``t`` (the null vector of ``J``);
* **corrector**: Gauss-Newton on ``F(x) = 0, t . (x - x_pred) = 0`` (least squares: the
  system may have more equations than unknowns). A step is taken only if the corrector converges
  and contracts, lands within a fraction of ``h`` of the prediction, the tangent turns by less
  than :data:`MAX_TURN` and the chord follows the tangents (no jump to a nearby curve); else
  ``h`` is halved, down to ``h_min``.

A curve ends where it leaves the search domain or violates an inequality (a joint limit): the
end point is located by bisection. A trace stops when it comes back to its start (a closed
curve) or runs onto another trace with the same tangent (the same curve, followed before).
Passing a vertex of another trace with a different tangent is a *crossing*: the two traces are
one connected set.

**Bifurcations**: along a curve ``J`` has rank ``n - 1``; where branches cross it drops to
``n - 2``. The test function ``tau = sigma_{n-1}(J) / sigma_1(J)`` has a V-shaped zero there; a
local minimum of ``tau`` over three consecutive points is refined by golden-section search along
the chord, and reported when ``tau`` falls below :data:`BIFURCATION_TAU`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..formulation.system import Compiled
from ..search import jit as nb
from ..search.lstsq import lstsq
from .local import Quadratic

if TYPE_CHECKING:
    from scipy.spatial import cKDTree

#: relative residual of a point of the solution set (see :meth:`Quadratic.residual`): not much
#: below, since the equations themselves may hold only to ~1e-12 (a Griffis-Duffy platform whose
#: leg lengths are given to 12 decimals: exactly, it would not move at all)
ON_SET = 1e-10
#: the corrector lands within this share of ``h`` of the prediction
MAX_CORRECTION = 0.25
#: and the tangent turns by at most this (radians) over a step
MAX_TURN = 0.35
#: tau below this at a local minimum: a bifurcation point
BIFURCATION_TAU = 1e-6
#: a trace stops after this many steps (it then says so)
MAX_STEPS = 20_000


@dataclass
class Trace:
    """One followed curve: ``points`` in order (``closed``: the last joins the first)."""

    points: list[np.ndarray]
    closed: bool = False
    #: how each end stopped: "closed", "joined", "boundary", "stuck" or "steps"
    ends: list[str] = field(default_factory=list)
    #: indices into ``points`` of the bifurcation points found on it
    bifurcations: list[int] = field(default_factory=list)
    #: other traces it ran onto or crossed (same connected set)
    touches: set[int] = field(default_factory=set)
    tangents: list[np.ndarray] = field(default_factory=list)

    @property
    def complete(self) -> bool:
        return all(e in ("closed", "joined", "boundary") for e in self.ends)


class Tracer:
    """Follows curves of the solution set of a compiled system inside ``[lo, hi]``."""

    def __init__(self, comp: Compiled, lo: np.ndarray, hi: np.ndarray, h_max: float, h_min: float | None = None):
        load_kernel()  # here, not at start-up: an answer of certified roots alone follows no curve
        self.q = Quadratic(comp)
        self.comp = comp
        # the equations as plain arrays for the compiled corrector
        self._rows = comp.rows(comp.n_eq)
        self._abs_data = np.abs(self._rows.data)
        self._slack = np.ascontiguousarray(self.q.slack, dtype=float)
        self.lo, self.hi = lo, hi
        # below ~1e-3 of the step a point near a double root passes the corrector too (the
        # equations there are only ~h^2 from 0)
        self.h_max, self.h_min = h_max, 1e-3 * h_max if h_min is None else h_min
        self.n = comp.n
        A = comp.A[comp.n_eq :].tocsr()
        self.ineq_A, self.ineq_c = A, comp.c[comp.n_eq :]
        self.ineq_abs = abs(A)
        self.ineq_slack = comp.slack[comp.n_eq :] if len(comp.slack) else np.zeros(A.shape[0])
        self.traces: list[Trace] = []
        self._tree: cKDTree | None = None
        self._owner: np.ndarray = np.zeros(0, dtype=int)
        self._pts: np.ndarray = np.zeros((0, self.n))
        self._tan: np.ndarray = np.zeros((0, self.n))
        self.corrections = 0  # corrector runs (a measure of the work)

    # -- pieces ------------------------------------------------------------------------------
    def feasible(self, x: np.ndarray) -> bool:
        """Inside the search domain and every inequality holds (up to its slack and rounding)."""
        if np.any(x < self.lo) or np.any(x > self.hi):
            return False
        if self.ineq_A.shape[0] == 0:
            return True
        z = self.comp.z(x)
        g = self.ineq_A @ z + self.ineq_c
        tol = self.ineq_slack + 1e-12 * (1.0 + self.ineq_abs @ np.abs(z) + np.abs(self.ineq_c))
        return bool(np.all(g <= tol))

    def tangent(self, x: np.ndarray, like: np.ndarray | None = None) -> tuple[np.ndarray, float, int]:
        """The unit tangent at ``x`` (oriented along ``like``), the test function ``tau``, and the
        number of (numerically) zero singular values of ``J``."""
        J = self.q.J(x)
        _, s, Vt = np.linalg.svd(J, full_matrices=True)
        sv = np.zeros(self.n)
        sv[: len(s)] = s
        t = Vt[-1]
        if like is not None and float(t @ like) < 0:
            t = -t
        top = max(float(sv[0]), 1e-300)
        tau = float(sv[self.n - 2] / top) if self.n >= 2 else 1.0
        zero = int(np.sum(sv <= 1e-9 * max(top, 1.0)))
        return t, tau, zero

    def correct(self, xp: np.ndarray, t: np.ndarray, iters: int = 10, strict: bool = True) -> np.ndarray | None:
        """The point of the solution set on the hyperplane through ``xp`` normal to ``t`` that
        Gauss-Newton reaches from ``xp`` (None if it does not converge, or with ``strict`` if it
        does not contract: near a bifurcation point it converges only linearly)."""
        self.corrections += 1
        R = self._rows
        ok, x = _correct_kernel(
            np.asarray(xp, dtype=float), np.asarray(t, dtype=float), int(iters), bool(strict), ON_SET, R.n, R.mi, R.mj,
            R.indptr, R.indices, R.data, self._abs_data, R.c, self._slack, R.Ax, R.t_flat, R.t_var, R.t_coef,
        )  # fmt: skip
        return x if ok else None

    def on_set(self, x: np.ndarray) -> bool:
        return self.q.residual(x) <= ON_SET

    # -- one step ----------------------------------------------------------------------------
    def _step(self, x, t, h):
        """Try a step of ``h``; returns (point, tangent, tau) or None."""
        y = self.correct(x + h * t, t)
        if y is None:
            return None
        d = y - x
        dist = float(np.linalg.norm(d))
        if dist <= 0.5 * h or float(np.linalg.norm(y - (x + h * t))) > MAX_CORRECTION * h:
            return None
        ty, tau, _ = self.tangent(y, t)
        turn = math.acos(min(1.0, abs(float(t @ ty))))
        if float(t @ ty) < 0 or turn > MAX_TURN:
            return None
        # the chord of an arc runs along the mean of its end tangents; a jump to another curve
        # nearby does not
        mid = t + ty
        mid /= np.linalg.norm(mid)
        if math.acos(min(1.0, float(mid @ d) / dist)) > 0.25 * turn + 0.05:
            return None
        return y, ty, tau

    def _boundary(self, x, t, h):
        """The last feasible point between ``x`` (feasible) and a step of ``h`` (not)."""
        a, b = 0.0, h
        best = x
        for _ in range(40):
            m = 0.5 * (a + b)
            y = self.correct(x + m * t, t)
            if y is not None and self.feasible(y):
                a, best = m, y
            else:
                b = m
            if b - a <= 1e-12 * (1.0 + h):
                break
        return best

    def _refine_bifurcation(self, a: np.ndarray, b: np.ndarray):
        """Golden-section search of ``tau`` along the chord ``a -> b``: (point, tau) at its
        minimum."""
        u = b - a
        L = float(np.linalg.norm(u))
        u = u / L

        def f(lam):
            y = self.correct(a + lam * L * u, u, iters=60, strict=False)
            if y is None:
                return math.inf, None
            return self.tangent(y)[1], y

        g = (math.sqrt(5) - 1) / 2
        lo_, hi_ = 0.0, 1.0
        c1, c2 = hi_ - g * (hi_ - lo_), lo_ + g * (hi_ - lo_)
        f1, f2 = f(c1), f(c2)
        for _ in range(60):
            if f1[0] <= f2[0]:
                hi_, c2, f2 = c2, c1, f1
                c1 = hi_ - g * (hi_ - lo_)
                f1 = f(c1)
            else:
                lo_, c1, f1 = c1, c2, f2
                c2 = lo_ + g * (hi_ - lo_)
                f2 = f(c2)
            if (hi_ - lo_) * L <= 1e-12:
                break
        return f1[1], f1[0]

    def _meets(self, x, t, y, me: int, start: np.ndarray | None):
        """Does the step ``x -> y`` pass the start point (closed) or a vertex of another trace?
        Returns ("closed", None), ("joined", k), ("crossed", k) or None."""
        step = float(np.linalg.norm(y - x))

        def through(v) -> bool:
            s = float(t @ (v - x))
            if not (0.0 < s <= 1.5 * step):
                return False
            if float(np.linalg.norm(v - (x + s * t))) > MAX_CORRECTION * s + 1e-9:
                return False
            z = self.correct(x + s * t, t)
            return z is not None and float(np.linalg.norm(z - v)) <= 1e-7 * (1.0 + float(np.max(np.abs(v))))

        if start is not None and through(start):
            return ("closed", None)
        if self._tree is None:
            return None
        found = None
        for i in sorted(self._tree.query_ball_point(y, 1.5 * step + 1e-12)):
            k = int(self._owner[i])
            if k == me or (found is not None and found[1] == k):
                continue
            v = self._pts[i]
            if through(v):
                same = abs(float(self._tan[i] @ self.tangent(v)[0])) >= 0.9
                if same:
                    return ("joined", k)
                found = ("crossed", k)
        return found

    # -- a whole curve -------------------------------------------------------------------------
    def _walk(self, x0, t0, me: int, close_at: np.ndarray | None):
        """Points from ``x0`` (excluded) along ``t0`` until an end; returns (points, tangents,
        taus, end, touches, bifurcation points)."""
        pts, tans, taus = [], [], []
        touches: set[int] = set()
        x, t = x0, t0
        h = self.h_max
        end = "steps"
        prev = [(x0, self.tangent(x0, t0)[1])]
        bifs: list[np.ndarray] = []
        for _ in range(MAX_STEPS):
            r = self._step(x, t, h)
            if r is None:
                h *= 0.5
                if h < self.h_min:
                    end = "stuck"
                    break
                continue
            y, ty, tau = r
            if not self.feasible(y):
                b = self._boundary(x, t, h)
                if b is not x:
                    pts.append(b)
                    tans.append(self.tangent(b, t)[0])
                    taus.append(self.tangent(b)[1])
                end = "boundary"
                break
            meet = self._meets(x, t, y, me, close_at if len(pts) >= 2 else None)
            if meet is not None and meet[0] in ("closed", "joined"):
                end = meet[0]
                if meet[1] is not None:
                    touches.add(meet[1])
                break
            if meet is not None:
                touches.add(meet[1])
            pts.append(y)
            tans.append(ty)
            taus.append(tau)
            prev.append((y, tau))
            if len(prev) >= 3:
                (a, ta), (m, tm), (b, tb) = prev[-3:]
                if tm <= min(ta, tb) and tm <= 0.5 * max(ta, tb):
                    p, tp = self._refine_bifurcation(a, b)
                    if p is not None and tp <= BIFURCATION_TAU:
                        bifs.append(p)
            x, t = y, ty
            h = min(1.5 * h, self.h_max)
        return pts, tans, taus, end, touches, bifs

    def trace(self, x0: np.ndarray) -> Trace | None:
        """Follow the curve through ``x0`` (a point of the solution set) both ways. None if no
        step of at least ``h_min`` leaves ``x0`` along a kernel direction of ``J``: ``x0`` is then
        not a point of a curve (an isolated singular point)."""
        me = len(self.traces)
        J = self.q.J(x0)
        _, s, Vt = np.linalg.svd(J, full_matrices=True)
        sv = np.zeros(self.n)
        sv[: len(s)] = s
        zero = max(1, int(np.sum(sv <= 1e-6 * max(float(sv[0]), 1.0))))
        t0 = None
        for k in range(self.n - 1, self.n - 1 - zero, -1):
            for sign in (1.0, -1.0):
                d = sign * Vt[k]
                h = self.h_max
                while h >= self.h_min:
                    if self._step(x0, d, h) is not None:
                        t0 = d
                        break
                    h *= 0.5
                if t0 is not None:
                    break
            if t0 is not None:
                break
        if t0 is None:
            return None
        # the start is a Newton limit on the square rows, which stalls next to a curve (its
        # Jacobian singular along it) up to 5e-12 off: the corrector, regular on a curve, puts it
        # on the set like every other point of the trace
        # (tests/answer/test_trace.py::test_the_start_of_a_trace_is_corrected_onto_the_curve)
        x1 = self.correct(x0, t0)
        if x1 is not None and float(np.max(np.abs(x1 - x0))) <= self.h_min:
            x0 = x1
        tr = Trace([x0])
        fwd = self._walk(x0, t0, me, x0)
        tau0 = self.tangent(x0)[1]
        if fwd[3] == "closed":
            pts, tans = [x0] + fwd[0], [t0] + fwd[1]
            tr.closed = True
            tr.ends = ["closed"]
            touches, bifs = fwd[4], fwd[5]
            # a bifurcation at the start point itself: the three points around it
            taus = [tau0] + fwd[2]
            if len(pts) >= 3 and taus[0] <= min(taus[1], taus[-1]) and taus[0] <= 0.5 * max(taus[1], taus[-1]):
                p, tp = self._refine_bifurcation(pts[-1], pts[1])
                if p is not None and tp <= BIFURCATION_TAU:
                    bifs = bifs + [p]
        else:
            bwd = self._walk(x0, -t0, me, None)
            pts = [p for p in reversed(bwd[0])] + [x0] + fwd[0]
            tans = [-v for v in reversed(bwd[1])] + [t0] + fwd[1]
            tr.ends = [bwd[3], fwd[3]]
            touches, bifs = fwd[4] | bwd[4], fwd[5] + bwd[5]
            taus = list(reversed(bwd[2])) + [tau0] + fwd[2]
            i = len(bwd[0])
            if 0 < i < len(pts) - 1 and taus[i] <= min(taus[i - 1], taus[i + 1]) and taus[i] <= 0.5 * max(taus[i - 1], taus[i + 1]):
                p, tp = self._refine_bifurcation(pts[i - 1], pts[i + 1])
                if p is not None and tp <= BIFURCATION_TAU:
                    bifs = bifs + [p]
        if all(e == "stuck" for e in tr.ends) and sum(float(np.linalg.norm(b - a)) for a, b in zip(pts, pts[1:])) < 0.1 * self.h_max:
            return None  # a few tiny steps and stuck both ways: not a curve at this resolution
        tr.points, tr.tangents, tr.touches = pts, tans, touches
        # the bifurcation points go into the polyline where they lie
        for p in bifs:
            k = _insert_at(tr.points, p, tr.closed)
            tr.points.insert(k, p)
            tr.tangents.insert(k, self.tangent(p, tr.tangents[min(k, len(tr.tangents) - 1)])[0])
            tr.bifurcations = [b + (b >= k) for b in tr.bifurcations] + [k]
        self.traces.append(tr)
        self._index()
        return tr

    def owner_of(self, p: np.ndarray) -> int:
        """The trace ``p`` lies on (a corrector from its nearest vertices lands on ``p``), or -1."""
        if self._tree is None:
            return -1
        d, idx = self._tree.query(p, k=min(4, len(self._pts)))
        for dist, i in zip(np.atleast_1d(d), np.atleast_1d(idx)):
            if not np.isfinite(dist) or dist > 2.0 * self.h_max:
                continue
            v, t = self._pts[i], self._tan[i]
            if dist <= 1e-12 * (1.0 + float(np.max(np.abs(p)))):
                return int(self._owner[i])
            s = float(t @ (p - v))
            z = self.correct(v + s * t, t)
            if z is not None and float(np.linalg.norm(z - p)) <= 1e-7 * (1.0 + float(np.max(np.abs(p)))):
                return int(self._owner[i])
        return -1

    def _index(self) -> None:
        pts = [p for tr in self.traces for p in tr.points]
        self._owner = np.array([k for k, tr in enumerate(self.traces) for _ in tr.points], dtype=int)
        self._pts = np.array(pts)
        self._tan = np.array([v for tr in self.traces for v in tr.tangents])
        from scipy.spatial import cKDTree  # loaded when a curve is followed, not at start-up

        self._tree = cKDTree(self._pts)


def _insert_at(points: list[np.ndarray], p: np.ndarray, closed: bool) -> int:
    """Where ``p`` (a point near the polyline) goes: after the nearest vertex or before it,
    whichever segment it is nearer to."""
    P = np.array(points)
    i = int(np.argmin(np.linalg.norm(P - p, axis=1)))
    if i + 1 < len(points):
        nxt = P[i + 1] - P[i]
        if float(nxt @ (p - P[i])) > 0:
            return i + 1
        return i
    return i + 1 if not closed or float((P[0] - P[i]) @ (p - P[i])) > 0 else i


def segments_meet_box(a: np.ndarray, b: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """For segments ``a_k -> b_k`` (rows), does the segment meet the box ``[lo, hi]`` (slab
    test)?"""
    d = b - a
    tmin = np.zeros(len(a))
    tmax = np.ones(len(a))
    with np.errstate(divide="ignore", invalid="ignore"):
        for j in range(a.shape[1]):
            flat = np.abs(d[:, j]) < 1e-300
            t1 = np.where(flat, -np.inf, (lo[j] - a[:, j]) / d[:, j])
            t2 = np.where(flat, np.inf, (hi[j] - a[:, j]) / d[:, j])
            inside = (a[:, j] >= lo[j]) & (a[:, j] <= hi[j])
            tmin = np.maximum(tmin, np.where(flat, np.where(inside, 0.0, 2.0), np.minimum(t1, t2)))
            tmax = np.minimum(tmax, np.where(flat, np.where(inside, 1.0, -1.0), np.maximum(t1, t2)))
    return tmin <= tmax


def load_kernel() -> None:
    """Load (on the first run: compile and cache) the corrector's kernel; after the first call
    in a process, nothing."""
    global _KERNEL_LOADED
    if not _KERNEL_LOADED:
        one, i0 = np.ones(1), np.zeros(1, dtype=np.int64)
        _correct_kernel(one, one, 1, True, ON_SET, 1, i0, i0, np.array([0, 1]), i0, one, one, -one, 0 * one, one[:, None], i0, i0, 0 * one)
        _KERNEL_LOADED = True


_KERNEL_LOADED = False


# -- the corrector, compiled -------------------------------------------------------------------
# Tracing a curve is thousands of corrector runs of a few Gauss-Newton steps on small matrices;
# as numpy calls they were half of the answer stage (benchmarks/mobile.py measures it). The
# same iteration as one compiled call; a heuristic like every Newton run (what it returns is a
# point where the equations hold to ON_SET, checked here; tests/search/test_transverse.py checks that
# the corrector lands on the curve).


@nb.njit(cache=True)
def _residual(x, n, mi, mj, indptr, indices, data, abs_data, c, slack):
    """:meth:`Quadratic.residual` (inf where it is not finite)."""
    worst = 0.0
    for r in range(c.shape[0]):
        f = 0.0
        sc = 0.0
        for q in range(indptr[r], indptr[r + 1]):
            k = indices[q]
            z = x[k] if k < n else x[mi[k - n]] * x[mj[k - n]]
            f += data[q] * z
            sc += abs_data[q] * abs(z)
        f += c[r]
        v = max(abs(f) - slack[r], 0.0) / (1.0 + sc + abs(c[r]))
        if not v == v:
            return np.inf
        if v > worst:
            worst = v
    return worst


@nb.njit(cache=True)
def _correct_kernel(xp, t, iters, strict, on_set, n, mi, mj, indptr, indices, data, abs_data, c, slack, Ax, t_flat, t_var, t_coef):
    """:meth:`Tracer.correct`: (converged, point)."""
    m = c.shape[0]
    x = xp.copy()
    A = np.empty((m + 1, n))
    rhs = np.empty(m + 1)
    prev = np.inf
    for _ in range(iters):
        for i in range(m):  # not A[:m, :] = Ax: a slice copy compiles numba's shape-error message
            for j in range(n):
                A[i, j] = Ax[i, j]
        Af = A.reshape(-1)  # row-major: the flat places of the m x n Jacobian are the same
        for q in range(t_flat.shape[0]):
            Af[t_flat[q]] += t_coef[q] * x[t_var[q]]
        for r in range(m):
            f = 0.0
            for q in range(indptr[r], indptr[r + 1]):
                k = indices[q]
                f += data[q] * (x[k] if k < n else x[mi[k - n]] * x[mj[k - n]])
            rhs[r] = -(f + c[r])
        s = 0.0
        for j in range(n):
            A[m, j] = t[j]
            s += t[j] * (x[j] - xp[j])
        rhs[m] = -s
        for r in range(m + 1):
            if not np.isfinite(rhs[r]):
                return False, x
            for j in range(n):
                if not np.isfinite(A[r, j]):
                    return False, x
        # numpy's cut-off (a smaller one, numba's default, moved the point Gauss-Newton reaches
        # near a bifurcation point)
        dx = lstsq(A, rhs)[0]
        step = 0.0
        for j in range(n):
            step += dx[j] * dx[j]
        step = np.sqrt(step)
        if not np.isfinite(step):
            return False, x
        big = 0.0
        for j in range(n):
            x[j] += dx[j]
            big = max(big, abs(x[j]))
        # a step this small leaves an error of its square: converged (the residual may stay at
        # the level the equations are consistent to, e.g. rounded leg lengths)
        if step <= 1e-8 * (1.0 + big) and _residual(x, n, mi, mj, indptr, indices, data, abs_data, c, slack) <= on_set:
            return True, x
        if strict and step > 0.5 * prev:
            return False, x  # not contracting
        prev = step
    return _residual(x, n, mi, mj, indptr, indices, data, abs_data, c, slack) <= on_set, x
