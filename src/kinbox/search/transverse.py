"""Krawczyk across a solution set of positive dimension: narrowing orthogonal to a curve.

On a curve (a mobile mechanism, the self-motion of a redundant arm, a singular pose) the core
Jacobian ``J`` has rank ``k < n`` at every solution, so the Krawczyk operator of
:mod:`kinbox.search.certify` (which inverts ``J``) learns nothing there, and every box near the
curve is narrowed only by propagation and LPs. But the curve is a graph over ``d = n - k`` of
the variables (the *parameters* ``p``, chosen along the null space of ``J`` at the box centre),
and the other ``k`` (``y``) are functions of them. With any ``k x m`` matrix ``Y`` (here the
pseudo-inverse of ``J_y(x0)``) every zero of ``F`` in the box ``B = B_p x B_y`` satisfies

    y in K = y0 - Y F(x0) + (I - Y J_y(B)) (B_y - y0) - Y J_p(B) (B_p - p0)

(the mean-value form of ``0 = Y F(x)``: ``F`` is quadratic, so ``F(x) - F(x0) = J(ξ) (x - x0)``
exactly, with ``ξ = (x + x0) / 2`` the midpoint, within half the box's radius of ``x0``: ``J``
is taken over that half-size box, as in :mod:`kinbox.search.certify`). ``K`` is evaluated in
outward-rounded arithmetic
like the square operator (``F(x0)`` as if in twice the working precision, widened by the rows' slack), so
``B_y ∩ K`` keeps every solution: it narrows ``y`` to about ``|dy/dp| w_p`` (the width the curve
itself sweeps over ``B_p``) plus ``O(w^2)``, and ``B_y ∩ K = ∅`` proves the box empty. The
parameters are not narrowed.

It pays on boxes small against the curve's curvature (a few sigma): there it does what an LP
round does, for the price of two small dense factorizations.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba as nb
import numpy as np

from .. import interval as iv
from ..formulation.system import Rows
from .certify import Certifier, at_most_one_scaled, box_jacobian_radius
from .lstsq import lstsq

#: singular values of J(x0) below this share of the largest count as zero (the null space of
#: the curve's tangent directions; a wrong guess only weakens the narrowing, never its soundness)
RANK_TOL = 1e-6


@dataclass
class TransverseResult:
    status: str  # "empty", "narrowed" or "none"
    lo: np.ndarray
    hi: np.ndarray
    params: np.ndarray | None = None
    #: ``K`` lies in the interior of ``B_y``: for every value of the parameters ``Y F = 0`` has
    #: exactly one solution ``y`` in the box (Krawczyk's existence and uniqueness test on the
    #: ``k`` equations ``Y F``), so every zero of ``F`` in the box lies on that one graph
    graph: bool = False
    #: the box ``B*`` that graph lies in (a superset of the box's zeros), when ``graph``
    graph_box: tuple[np.ndarray, np.ndarray] | None = None


class Transverse:
    """The operator above, on the core rows of a :class:`~kinbox.search.certify.Certifier`."""

    def __init__(self, cert: Certifier):
        self.cert = cert
        self.comp = cert.comp

    def contract(self, lo: np.ndarray, hi: np.ndarray, graph: bool = False) -> TransverseResult:
        """Narrow ``y`` (see the module docstring). ``graph``: when the box is not proven empty
        and one free variable is left as parameter, also try to prove that every zero in the
        box lies on one graph over it (:meth:`graph_test`)."""
        cert = self.cert
        n = self.comp.n
        m = self.comp.n_core
        if m == 0 or n == 0:
            return TransverseResult("none", lo, hi)
        x0 = 0.5 * (lo + hi)
        J0 = cert.J(x0)
        if not np.all(np.isfinite(J0)):
            return TransverseResult("none", lo, hi)
        # variables fixed in the box (a point interval) are constants here, not unknowns: no
        # interval can lie in the interior of a point
        free = np.flatnonzero(hi > lo)
        nf = len(free)
        if nf < 2:
            return TransverseResult("none", lo, hi)
        try:
            _, S, Vt = np.linalg.svd(J0[:, free])
        except np.linalg.LinAlgError:
            return TransverseResult("none", lo, hi)
        if len(S) == 0 or not S[0] > 0:
            return TransverseResult("none", lo, hi)
        # rank k of J on the solution set: at most nf - 1 (on a curve), and the count of the
        # singular values that are not negligible; off the set a square J is regular-looking,
        # its smallest singular direction is then the best guess of the curve's tangent
        k = min(int(np.sum(S > RANK_TOL * S[0])), nf - 1)
        N = Vt[k:]  # (d, nf): the null space of J(x0) over the free variables
        # parameters: the d variables along which the null space moves most (a column-pivoted
        # QR of N picks the best-conditioned set greedily), and the fixed ones
        Pf = free[_pivots(N, nf - k)]
        isp = np.ones(n, dtype=bool)
        isp[free] = False
        isp[Pf] = True
        P = np.flatnonzero(isp)
        V = np.flatnonzero(~isp)
        K = self._operator(lo, hi, P, V, J0, unique=False)
        if K is None:
            return TransverseResult("none", lo, hi)
        klo, khi, _ = K
        nlo, nhi = lo.copy(), hi.copy()
        nlo[V] = np.maximum(lo[V], klo)
        nhi[V] = np.minimum(hi[V], khi)
        if np.any(nlo > nhi):
            return TransverseResult("empty", nlo, nhi, Pf)
        status = "narrowed" if (np.any(nlo > lo) or np.any(nhi < hi)) else "none"
        out = TransverseResult(status, nlo if status == "narrowed" else lo, nhi if status == "narrowed" else hi, Pf)
        if graph and len(Pf) == 1:
            out.graph_box = self.graph_test(nlo, nhi, P, V, klo, khi)
            out.graph = out.graph_box is not None
        return out

    def _operator(self, lo, hi, P, V, J0=None, unique: bool = True) -> tuple[np.ndarray, np.ndarray, bool] | None:
        """``K`` over ``y = x[V]`` for the box ``[lo, hi]``, parameters ``x[P]`` (outward
        rounded), and whether ``K`` lies inside the box's ``y`` while ``|I - Y J_y(B)|`` maps a
        positive vector strictly inside itself (:func:`~kinbox.search.certify.at_most_one_scaled`:
        each ``p`` then has exactly one zero of ``Y F``
        in the box; only tested with ``unique``, else False); None where ``K`` is not finite."""
        cert = self.cert
        n, m = self.comp.n, self.comp.n_core
        x0 = 0.5 * (lo + hi)
        if J0 is None:
            J0 = cert.J(x0)
        ok, Y = least_squares_inverse(np.ascontiguousarray(J0[:, V]))
        if not ok:
            return None
        F0, eF = cert.F_enclosure(x0)
        ok, klo, khi, contracts = _operator_kernel(
            np.ascontiguousarray(lo, dtype=float),
            np.ascontiguousarray(hi, dtype=float),
            x0,
            np.ascontiguousarray(J0),
            np.ascontiguousarray(Y),
            P,
            V,
            F0,
            eF,
            cert.Ax,
            cert.t_var,
            cert.t_flat,
            cert.t_abs,
            cert.g_slope,
            cert.slack_core,
            cert.mgrad_core,
            float(iv.gamma(m + 3)),
            float(iv.gamma(n + 2)),
            iv.TINY,
            unique,
        )
        return (klo, khi, contracts) if ok else None

    def graph_test(self, lo, hi, P, V, klo, khi) -> tuple[np.ndarray, np.ndarray] | None:
        """Every zero of ``F`` in ``[lo, hi]`` (a box whose ``y`` were just narrowed to ``K``)
        lies on one graph ``y(p)`` over the single free parameter: Krawczyk's existence and
        uniqueness test for the ``k`` equations ``Y F = 0`` in ``y``, ``p`` held, on a box ``B*``
        with the same ``p`` and ``y`` in ``K`` widened (epsilon-inflation: ``K`` itself, as wide as
        the box it came from, cannot lie in its own interior). ``B*`` holds every zero of the
        box. ``K(B*)`` inside the interior of ``B*_y`` proves, for each ``p``, a zero of ``Y F``
        in ``B*_y`` (``y - Y F(p, y)`` maps ``B*_y`` into ``K``), and ``|I - Y J_y(B*)|``
        mapping a positive vector strictly inside itself (the radius of ``B*_y``, or the
        candidate of :func:`~kinbox.search.certify.at_most_one_scaled`) proves it the only one (two zeros
        ``y, y'`` would give ``y - y' = (I - Y J_y(m)) (y - y')``, ``m`` their midpoint in
        ``B*``): ``Y F`` square in ``y`` with ``Y J_y`` regular over ``B*``, so the zeros form a
        real-analytic function of ``p`` by the implicit function theorem. Returns ``B*``, or
        None if the test fails."""
        ylo, yhi = klo, khi
        for attempt in range(GRAPH_TRIES):
            mid, rad = 0.5 * (ylo + yhi), 0.5 * (yhi - ylo)
            rad = iv.up(rad * (1.0 + GRAPH_EPS) + GRAPH_ABS * (1.0 + np.abs(mid)))
            blo, bhi = lo.copy(), hi.copy()
            blo[V] = np.minimum(iv.down(mid - rad), lo[V])
            bhi[V] = np.maximum(iv.up(mid + rad), hi[V])
            K = self._operator(blo, bhi, P, V)
            if K is None:
                return None
            if K[2] and np.all(K[0] > blo[V]) and np.all(K[1] < bhi[V]):
                return blo, bhi
            if attempt == 0 and np.any(K[1] - K[0] > GRAPH_GIVE_UP * (bhi[V] - blo[V])):
                return None  # far from contracting: a wider B* only widens K
            ylo, yhi = np.minimum(K[0], lo[V]), np.maximum(K[1], hi[V])
        return None


#: epsilon-inflation of :meth:`Transverse.graph_test`: relative and absolute widening, tries
GRAPH_EPS = 0.1
GRAPH_ABS = 1e-12
GRAPH_TRIES = 3
#: a first try whose ``K`` is this many times as wide as ``B*`` in some ``y`` ends the test: the
#: next ``B*`` is at least as wide as that ``K``, and its Jacobian's spread with it (every test
#: that passed on the four-bar, Bricard and Griffis-Duffy had ``K`` at most 1.83 times as wide at
#: its first try; 20-70 % of their tests start above 4)
GRAPH_GIVE_UP = 4.0


def _pivots(N: np.ndarray, d: int) -> np.ndarray:
    """The first ``d`` pivot columns of a column-pivoted QR of ``N`` (greedy: the column of
    largest remaining norm, then the residual against it)."""
    A = N.copy()
    piv: list[int] = []
    for _ in range(d):
        norms = np.einsum("ij,ij->j", A, A)
        if piv:
            norms[piv] = -1.0
        j = int(np.argmax(norms))
        piv.append(j)
        v = A[:, j] / np.sqrt(max(norms[j], 1e-300))
        A = A - np.outer(v, v @ A)
    return np.array(piv, dtype=np.int64)


def load_kernel() -> None:
    """Load (on the first run: compile and cache) the compiled operator; a solve does it when it
    first needs it."""
    one, idx = np.ones(1), np.zeros(1, dtype=np.int64)
    eye = np.ones((1, 1))
    _operator_kernel(
        -one, one, 0 * one, eye, eye, idx, idx, 0 * one, 0 * one, eye, idx, idx, one, 0.0, 0 * one, 0 * one, 0.0, 0.0, iv.TINY, True
    )
    least_squares_inverse(eye)
    i1 = np.ones(1, dtype=np.int64)
    _slice_kernel(np.zeros(2), 0, one, 1, 0.5, 2, idx, idx, np.array([0, 1]), i1, one, -one, np.ones((1, 2)), i1, i1, 0 * one)


# -- compiled operator -------------------------------------------------------------------------
# The operator was some forty numpy calls on small arrays (UR5: 24 x 23), most of a transverse
# test's time next to the pseudo-inverse; the same formulas and error terms here, element by
# element (sums in any order are covered by the gamma factors; nextafter moves a result one ulp
# outward, as in :mod:`kinbox.interval`). tests/search/test_transverse.py compares it with the numpy
# code (tests/support/transverse_reference.py).


@nb.njit(cache=True)
def _operator_kernel(lo, hi, x0, J0, Y, P, V, F0, eF, Ax, t_var, t_flat, t_abs, g_slope, slack, mgrad, g, gn, tiny, unique):
    """``K`` of :meth:`Transverse._operator` over ``y = x[V]``: (finite, klo, khi, unique),
    ``unique`` (tested only when asked for: the narrowing does not use it) when ``K`` lies in
    the interior of the box's ``y`` and ``Y F`` has at most one zero ``y`` in the box for each
    ``p``."""
    inf = np.inf
    m = Ax.shape[0]
    k = V.shape[0]
    # J(x) in J0 +- Jrad over the box, and in J0 +- Jmid over its points' midpoints with x0
    d, Jrad, Jmid = box_jacobian_radius(lo, hi, x0, Ax, t_var, t_flat, t_abs, g_slope, tiny, mgrad)
    absY = np.abs(Y)
    JV = np.ascontiguousarray(J0[:, V])
    JP = np.ascontiguousarray(J0[:, P])
    YJV = Y @ JV
    YJP = Y @ JP
    RV = absY @ np.ascontiguousarray(Jmid[:, V])
    RP = absY @ np.ascontiguousarray(Jmid[:, P])
    AV = absY @ np.abs(JV)
    AP = absY @ np.abs(JP)
    klo = np.empty(k)
    khi = np.empty(k)
    for i in range(k):
        yf = 0.0
        e1 = 0.0
        e2 = 0.0
        for r in range(m):
            yf += Y[i, r] * F0[r]
            e1 += absY[i, r] * np.nextafter(eF[r] + slack[r], inf)
            e2 += absY[i, r] * abs(F0[r])
        eyf = (e1 + g * e2 + tiny) * (1 + g)
        rho = 0.0
        for jj in range(k):
            c = (1.0 if i == jj else 0.0) - YJV[i, jj]
            crad = (RV[i, jj] + g * (AV[i, jj] + 1.0)) * (1 + g)
            rho += (abs(c) * (1 + g) + crad) * d[V[jj]]
        for jj in range(P.shape[0]):
            mrad = (RP[i, jj] + g * AP[i, jj]) * (1 + g)
            rho += (abs(YJP[i, jj]) * (1 + g) + mrad) * d[P[jj]]
        rho = np.nextafter(rho * (1 + gn) * (1 + gn), inf) + tiny
        cen = x0[V[i]] - yf
        klo[i] = np.nextafter(np.nextafter(cen - eyf, -inf) - rho, -inf)
        khi[i] = np.nextafter(np.nextafter(cen + eyf, inf) + rho, inf)
        if not (np.isfinite(klo[i]) and np.isfinite(khi[i])):
            return False, klo, khi, False
    if not unique:
        return True, klo, khi, False
    for i in range(k):
        if not (klo[i] > lo[V[i]] and khi[i] < hi[V[i]]):
            return True, klo, khi, False
    # two zeros y, y' of Y F(p, .) in the box: none if the uniqueness condition holds over it
    if not at_most_one_scaled(d, J0, Y, V, Jrad, m, tiny):
        return True, klo, khi, False
    return True, klo, khi, True


# -- the curve-box corrector -------------------------------------------------------------------
# Every sample of a curve box (solver.BoxProcessor._curve_through) is a few Gauss-Newton steps on
# small matrices; as numpy calls (lstsq, the Jacobian, the rows) they were the largest part of
# the four-bar's search. The same iteration as one compiled call: a heuristic like every Newton
# run here (the caller checks the point it ends on).


def correct_on_slice(R: Rows, y: np.ndarray, j: int, close: np.ndarray, iters: int, stall: float) -> bool:
    """Gauss-Newton on the rows ``R`` with ``x_j`` held, from ``y`` (changed in place): at most
    ``iters`` steps, stopping once every row ``r`` is within ``close[r]``, or once a step left the
    largest row above ``stall`` times what it was (the point is then judged where it is). False
    if a step is not finite."""
    args = (R.n, R.mi, R.mj, R.indptr, R.indices, R.data, R.c, R.Ax, R.t_flat, R.t_var, R.t_coef)
    return bool(_slice_kernel(y, int(j), close, int(iters), float(stall), *args))


@nb.njit(cache=True)
def _rows_into(x, n, mi, mj, indptr, indices, data, c, out):
    for r in range(c.shape[0]):
        s = 0.0
        for q in range(indptr[r], indptr[r + 1]):
            k = indices[q]
            s += data[q] * (x[k] if k < n else x[mi[k - n]] * x[mj[k - n]])
        out[r] = s + c[r]


@nb.njit(cache=True)
def _slice_kernel(y, j, close, iters, stall, n, mi, mj, indptr, indices, data, c, Ax, t_flat, t_var, t_coef):
    m = c.shape[0]
    F = np.empty(m)
    J = np.empty((m, n))
    JV = np.empty((m, n - 1))
    rhs = np.empty(m)
    prev = np.inf
    for _ in range(iters):
        _rows_into(y, n, mi, mj, indptr, indices, data, c, F)
        done = True
        worst = 0.0
        for r in range(m):
            if not np.isfinite(F[r]):
                return False
            if not abs(F[r]) <= close[r]:
                done = False
            worst = max(worst, abs(F[r]))
        if done:
            return True
        if not worst <= stall * prev:
            return True  # stalled
        prev = worst
        for ra in range(Ax.shape[0]):  # not J[:, :] = Ax: a slice copy compiles numba's shape-error message
            for ca in range(Ax.shape[1]):
                J[ra, ca] = Ax[ra, ca]
        Jf = J.reshape(-1)
        for q in range(t_flat.shape[0]):
            Jf[t_flat[q]] += t_coef[q] * y[t_var[q]]
        for r in range(m):
            rhs[r] = -F[r]
            a = 0
            for i in range(n):
                if not np.isfinite(J[r, i]):
                    return False
                if i != j:
                    JV[r, a] = J[r, i]
                    a += 1
        # numpy's cut-off
        dy = lstsq(JV, rhs)[0]
        for a in range(n - 1):
            if not np.isfinite(dy[a]):
                return False
        a = 0
        for i in range(n):
            if i != j:
                y[i] += dy[a]
                a += 1
    return True


@nb.njit(cache=True)
def least_squares_inverse(JV):
    """``Y = JV^+ = R^-1 Q^T`` from a QR factorization of the ``m x k`` matrix ``JV`` (``k <= m``):
    (finite, Y). The parameters are chosen so that ``JV`` has full column rank, where this is
    the pseudo-inverse at a third of the cost of numpy's SVD; where it is (numerically)
    rank-deficient, ``Y`` is huge or not finite and the operator proves nothing. Any finite
    ``Y`` is sound (docs/soundness.md, "The transverse test")."""
    m, k = JV.shape
    Y = np.empty((k, m))
    if k > m:
        return False, Y
    for r in range(m):
        for a in range(k):
            if not np.isfinite(JV[r, a]):
                return False, Y  # numba's qr raises on it
    Q, R = np.linalg.qr(JV)
    for a in range(k - 1, -1, -1):
        if not R[a, a] != 0.0:
            return False, Y
        for r in range(m):
            s = Q[r, a]
            for b in range(a + 1, k):
                s -= R[a, b] * Y[b, r]
            Y[a, r] = s / R[a, a]
            if not np.isfinite(Y[a, r]):
                return False, Y
    return True, Y
