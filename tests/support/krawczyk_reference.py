"""The Krawczyk test in numpy, as ``Certifier._krawczyk`` computed it before its arithmetic was
compiled (``kinbox.search.certify._krawczyk_full``), with ``Y`` from the kernel's own inverse
(``lu_inverse``): the reference tests/search/test_certify.py compares the kernel with."""

from __future__ import annotations

import numpy as np

from kinbox import interval as iv
from kinbox.search.certify import Certifier, KrawczykResult, lu_inverse


def krawczyk_reference(cert: Certifier, lo, hi, x0=None, exact: bool = False) -> KrawczykResult:
    with np.errstate(over="ignore", invalid="ignore"):
        n = cert.comp.n
        if x0 is None:
            x0 = 0.5 * (lo + hi)
        x0 = np.clip(x0, lo, hi)
        J0 = cert.J(x0)
        # the kernel's inverse (LU with partial pivoting): another inverse is as sound, but its
        # rounding moves K by cond(J0) ulps and a verdict on the edge with it
        Y = np.empty_like(J0)
        if not lu_inverse(J0, Y):
            return KrawczykResult("none", lo, hi)
        absY = np.abs(Y)
        d = np.maximum(iv.up(hi - x0), iv.up(x0 - lo))
        Jmid = cert.jacobian_radius(x0, d, share=0.5)
        F0, eF = cert.F_enclosure(x0)
        YF = Y @ F0
        eYF = absY @ eF + iv.gamma(n + 2) * (absY @ np.abs(F0)) + iv.TINY
        C = np.eye(n) - Y @ J0
        Cerr = iv.gamma(n + 3) * (absY @ np.abs(J0) + 1.0)
        rho = (np.abs(C) + absY @ Jmid + Cerr) @ d
        rho = iv.up(rho * (1 + iv.gamma(n + 2))) + iv.TINY
        cen = x0 - YF
        klo = iv.down(iv.down(cen - eYF) - rho)
        khi = iv.up(iv.up(cen + eYF) + rho)
        if not (np.all(np.isfinite(klo)) and np.all(np.isfinite(khi))):
            return KrawczykResult("none", lo, hi)
        if np.all(klo > lo) and np.all(khi < hi) and at_most_one_reference(cert, lo, hi, x0, d, J0, Y, np.arange(n)):
            return KrawczykResult("unique", klo, khi, eYF)
        if not exact:
            eS = absY @ cert.slack_core
            klo = iv.down(klo - iv.up(eS * (1 + iv.gamma(n + 2))))
            khi = iv.up(khi + iv.up(eS * (1 + iv.gamma(n + 2))))
        nlo, nhi = np.maximum(lo, klo), np.minimum(hi, khi)
        if np.any(nlo > nhi):
            return KrawczykResult("empty", nlo, nhi, eYF)
        if np.any(nlo > lo) or np.any(nhi < hi):
            return KrawczykResult("contracted", nlo, nhi, eYF)
        return KrawczykResult("none", lo, hi, eYF)


def at_most_one_reference(cert: Certifier, blo, bhi, x0, d, J0, Y, V) -> bool:
    """The uniqueness condition (``certify.at_most_one_kernel``) for the zeros of ``Y F`` in
    ``x[V]``: the Jacobian's spread over ``[blo, bhi]``, where ``K`` confined them."""
    m, n = J0.shape
    g, gn = iv.gamma(m + 3), iv.gamma(n + 2)
    absY = np.abs(Y)
    JB = cert.jacobian_radius(x0, np.maximum(iv.up(bhi - x0), iv.up(x0 - blo)))
    JV = J0[:, V]
    C = np.abs(np.eye(len(V)) - Y @ JV) * (1 + g)
    Crad = (absY @ JB[:, V] + g * (absY @ np.abs(JV) + 1.0)) * (1 + g)
    r = iv.up(((C + Crad) @ d[V]) * (1 + gn) * (1 + gn)) + iv.TINY
    return bool(np.all(r < d[V]))


def at_most_one_scaled_reference(cert: Certifier, blo, bhi, x0, d, J0, Y, V) -> bool:
    """``certify.at_most_one_scaled``: the uniqueness condition scaled by the box's radius, else
    by ``v = (I - M)^-1 1`` (``M = |I - Y J_V(x0)| + |Y| Jrad_V``) where ``v`` is positive."""
    if at_most_one_reference(cert, blo, bhi, x0, d, J0, Y, V):
        return True
    JB = cert.jacobian_radius(x0, np.maximum(iv.up(bhi - x0), iv.up(x0 - blo)))
    k = len(V)
    M = np.abs(np.eye(k) - Y @ J0[:, V]) + np.abs(Y) @ JB[:, V]
    try:
        v = np.linalg.solve(np.eye(k) - M, np.ones(k))
    except np.linalg.LinAlgError:
        return False
    if not np.all(v > 0):
        return False
    scaled = np.array(d, dtype=float)
    scaled[V] = v
    return at_most_one_reference(cert, blo, bhi, x0, scaled, J0, Y, V)
