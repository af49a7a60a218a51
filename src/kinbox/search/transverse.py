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
exactly, with ``ξ`` the midpoint, in ``B``). ``K`` is evaluated in outward-rounded arithmetic
like the square operator (``F(x0)`` in extended precision, widened by the rows' slack), so
``B_y ∩ K`` keeps every solution: it narrows ``y`` to about ``|dy/dp| w_p`` (the width the curve
itself sweeps over ``B_p``) plus ``O(w^2)``, and ``B_y ∩ K = ∅`` proves the box empty. The
parameters are not narrowed.

It pays on boxes small against the curve's curvature (a few sigma): there it does what an LP
round does, for the price of two small dense factorizations.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import interval as iv
from .certify import Certifier

#: singular values of J(x0) below this share of the largest count as zero (the null space of
#: the curve's tangent directions; a wrong guess only weakens the narrowing, never its soundness)
RANK_TOL = 1e-6


@dataclass
class TransverseResult:
    status: str  # "empty", "narrowed" or "none"
    lo: np.ndarray
    hi: np.ndarray
    params: np.ndarray | None = None


class Transverse:
    """The operator above, on the core rows of a :class:`~kinbox.search.certify.Certifier`."""

    def __init__(self, cert: Certifier):
        self.cert = cert
        self.comp = cert.comp

    def contract(self, lo: np.ndarray, hi: np.ndarray) -> TransverseResult:
        cert = self.cert
        n = self.comp.n
        m = self.comp.n_core
        if m == 0 or n == 0:
            return TransverseResult("none", lo, hi)
        x0 = 0.5 * (lo + hi)
        J0 = cert.J(x0)
        if not np.all(np.isfinite(J0)):
            return TransverseResult("none", lo, hi)
        try:
            _, S, Vt = np.linalg.svd(J0)
        except np.linalg.LinAlgError:
            return TransverseResult("none", lo, hi)
        if len(S) == 0 or not S[0] > 0:
            return TransverseResult("none", lo, hi)
        # rank k of J on the solution set: at most n - 1 (on a curve), and the count of the
        # singular values that are not negligible; off the set a square J is regular-looking,
        # its smallest singular direction is then the best guess of the curve's tangent
        k = min(int(np.sum(S > RANK_TOL * S[0])), n - 1)
        N = Vt[k:]  # (d, n): the null space of J(x0)
        # parameters: the d variables along which the null space moves most (a column-pivoted
        # QR of N picks the best-conditioned set greedily)
        P = _pivots(N, n - k)
        isp = np.zeros(n, dtype=bool)
        isp[P] = True
        V = np.flatnonzero(~isp)
        JV, JP = J0[:, V], J0[:, P]
        try:
            Y = np.linalg.pinv(JV)  # (k, m)
        except np.linalg.LinAlgError:
            return TransverseResult("none", lo, hi)
        if not np.all(np.isfinite(Y)):
            return TransverseResult("none", lo, hi)
        absY = np.abs(Y)
        d = np.maximum(iv.up(hi - x0), iv.up(x0 - lo))
        Jrad = cert.jacobian_radius(x0, d)  # J(B) in J0 +- Jrad, as in Certifier.krawczyk
        F0, eF = cert.F_enclosure(x0)
        eF = iv.up(eF + cert.slack_core)
        g = iv.gamma(m + 3)
        YF = Y @ F0
        eYF = (absY @ eF + g * (absY @ np.abs(F0)) + iv.TINY) * (1 + g)
        C = np.eye(len(V)) - Y @ JV
        Crad = (absY @ Jrad[:, V] + g * (absY @ np.abs(JV) + 1.0)) * (1 + g)
        M = Y @ JP
        Mrad = (absY @ Jrad[:, P] + g * (absY @ np.abs(JP))) * (1 + g)
        gn = iv.gamma(n + 2)
        rho = ((np.abs(C) * (1 + g) + Crad) @ d[V] + (np.abs(M) * (1 + g) + Mrad) @ d[P]) * (1 + gn)
        rho = iv.up(rho * (1 + gn)) + iv.TINY
        cen = x0[V] - YF
        klo = iv.down(iv.down(cen - eYF) - rho)
        khi = iv.up(iv.up(cen + eYF) + rho)
        if not (np.all(np.isfinite(klo)) and np.all(np.isfinite(khi))):
            return TransverseResult("none", lo, hi)
        nlo, nhi = lo.copy(), hi.copy()
        nlo[V] = np.maximum(lo[V], klo)
        nhi[V] = np.minimum(hi[V], khi)
        if np.any(nlo > nhi):
            return TransverseResult("empty", nlo, nhi, P)
        if np.any(nlo > lo) or np.any(nhi < hi):
            return TransverseResult("narrowed", nlo, nhi, P)
        return TransverseResult("none", lo, hi, P)


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
