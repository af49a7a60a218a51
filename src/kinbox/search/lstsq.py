"""Minimum-norm least squares for the small dense systems of the compiled Newton-type kernels.

Gauss-Newton on tall Jacobians (:mod:`kinbox.search.certify`), the transverse test's slice
corrector (:mod:`kinbox.search.transverse`) and the curve tracer's corrector
(:mod:`kinbox.answer.trace`) solve one least-squares problem per step, from compiled code.
``np.linalg.lstsq`` there is numba's wrapper of LAPACK's ``gelsd`` (an SVD), which copies,
queries and allocates its workspace on every call: for a 45 x 26 Jacobian it took some
160 us, several times the arithmetic. LAPACK's own QR-based driver (``gelsy``) is not reachable
from cached numba code (numba calls LAPACK through its helper library only, and a function that
calls a ctypes pointer cannot be cached), so this module does what ``gelsy`` does, in loops
numba compiles: Householder QR with column pivoting, a rank cut-off on the diagonal of ``R``,
and the minimum-norm solution (the basic solution with its null-space part projected out).

The callers compile this function into their own kernels, and numba's disk cache of a kernel
is keyed on its own file only: after editing this file, touch the callers' files (or delete
the cached ``*.nbi``/``*.nbc``), or they keep running the old code. An installed kinbox gets
all its files anew, so this is a matter for development only.

None of these kernels proves anything (the proofs are Krawczyk's and the LP's): a different
least-squares solution moves where an iteration goes, never what is discarded.
"""

from __future__ import annotations

import math

import numpy as np

from . import jit as nb


@nb.njit(cache=True)
def lstsq(A: np.ndarray, b: np.ndarray, rcond: float = -1.0) -> tuple[np.ndarray, int]:
    """The minimum-norm ``x`` minimising ``|A x - b|``, with the columns of ``A`` whose pivot
    ``|R_kk|`` is at most ``rcond |R_00|`` counted as dependent; and the rank used. A negative
    ``rcond`` (the default) is numpy's cut-off, ``eps * max(m, n)``.

    ``A`` (m x n) and ``b`` are kept. A matrix with an entry that is not finite gives NaN; nothing
    raises.
    """
    m, n = A.shape
    if rcond < 0.0:
        rcond = np.finfo(np.float64).eps * max(m, n)
    # scaled by a power of two to a largest entry in [0.5, 1): the column norms below neither
    # overflow nor underflow, and the scaling is exact
    amax = 0.0
    for i in range(m):
        for j in range(n):
            a = abs(A[i, j])
            if not a < np.inf:  # inf or NaN
                return np.full(n, np.nan), 0
            amax = max(amax, a)
    if amax == 0.0:
        return np.zeros(n), 0
    scale = 2.0 ** -math.frexp(amax)[1]
    C = np.ascontiguousarray(A.T) * scale  # C[j] is column j of A: the loops run along columns
    y = b.copy()
    perm = np.arange(n)
    kmax = min(m, n)
    v = np.empty(m)
    rank = 0
    top = 0.0
    for k in range(kmax):
        # the remaining column of largest norm first (norms recomputed: exact, and cheap here)
        p, best = k, -1.0
        for j in range(k, n):
            s = 0.0
            for i in range(k, m):
                s += C[j, i] * C[j, i]
            if s > best:
                p, best = j, s
        if p != k:
            for i in range(m):
                C[k, i], C[p, i] = C[p, i], C[k, i]
            perm[k], perm[p] = perm[p], perm[k]
        alpha = np.sqrt(best)
        if k == 0:
            top = alpha
        if alpha <= rcond * top or alpha == 0.0:
            break
        if C[k, k] > 0.0:
            alpha = -alpha
        for i in range(k, m):
            v[i] = C[k, i]
        v[k] -= alpha
        vv = 0.0
        for i in range(k, m):
            vv += v[i] * v[i]
        if vv > 0.0:
            for j in range(k + 1, n):
                s = 0.0
                for i in range(k, m):
                    s += v[i] * C[j, i]
                t = 2.0 * s / vv
                for i in range(k, m):
                    C[j, i] -= t * v[i]
            s = 0.0
            for i in range(k, m):
                s += v[i] * y[i]
            t = 2.0 * s / vv
            for i in range(k, m):
                y[i] -= t * v[i]
        C[k, k] = alpha
        rank = k + 1
    r = rank
    # basic solution z (in pivoted order): R11 z1 = y1, z2 = 0
    z = np.zeros(n)
    for i in range(r - 1, -1, -1):
        s = y[i]
        for j in range(i + 1, r):
            s -= C[j, i] * z[j]
        z[i] = s / C[i, i]
    d = n - r
    if d > 0 and r > 0:
        # null space of [R11 R12]: columns [-R11^-1 R12; I]; project z onto its complement
        N = np.zeros((n, d))
        for c in range(d):
            N[r + c, c] = 1.0
            for i in range(r - 1, -1, -1):
                s = -C[r + c, i]
                for j in range(i + 1, r):
                    s -= C[j, i] * N[j, c]
                N[i, c] = s / C[i, i]
        w = _spd_solve(N.T @ N, N.T @ z)  # N^T N >= I: well conditioned
        z = z - N @ w
    x = np.zeros(n)
    for j in range(n):
        x[perm[j]] = z[j] * scale
    return x, r


@nb.njit(cache=True)
def _spd_solve(G: np.ndarray, h: np.ndarray) -> np.ndarray:
    """``G^-1 h`` for a symmetric positive definite ``G`` by Cholesky; NaN where a pivot is not
    positive. Nothing here raises: an exception raised and caught in compiled code once leaked or
    freed its arrays twice (heap corruption, seen as aborts in later allocations)."""
    d = G.shape[0]
    L = np.zeros((d, d))
    for i in range(d):
        for j in range(i + 1):
            s = G[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            if i == j:
                if not s > 0.0:
                    return np.full(d, np.nan)
                L[i, i] = np.sqrt(s)
            else:
                L[i, j] = s / L[j, j]
    w = h.copy()
    for i in range(d):
        for k in range(i):
            w[i] -= L[i, k] * w[k]
        w[i] /= L[i, i]
    for i in range(d - 1, -1, -1):
        for k in range(i + 1, d):
            w[i] -= L[k, i] * w[k]
        w[i] /= L[i, i]
    return w
