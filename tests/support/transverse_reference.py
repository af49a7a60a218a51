"""The transverse operator in numpy, as ``Transverse._operator`` computed it before its arithmetic
was compiled (``kinbox.search.transverse._operator_kernel``): the reference
tests/search/test_transverse.py compares the kernel with."""

from __future__ import annotations

import numpy as np

from kinbox import interval as iv
from kinbox.search.transverse import Transverse, least_squares_inverse
from tests.support.krawczyk_reference import at_most_one_scaled_reference


def operator_reference(tv: Transverse, lo, hi, P, V, J0=None, unique: bool = True) -> tuple[np.ndarray, np.ndarray, bool] | None:
    """``K`` over ``y = x[V]`` for the box ``[lo, hi]``, parameters ``x[P]`` (outward
    rounded), and whether ``|I - Y J_y(B)|`` maps a positive vector strictly inside itself;
    None where ``K`` is not finite."""
    cert = tv.cert
    n, m = tv.comp.n, tv.comp.n_core
    x0 = 0.5 * (lo + hi)
    if J0 is None:
        J0 = cert.J(x0)
    JV, JP = J0[:, V], J0[:, P]
    # Y is the kernel's own (any Y keeps K sound): what is checked here is the arithmetic after it
    ok, Y = least_squares_inverse(np.ascontiguousarray(JV))
    if not ok:
        return None
    absY = np.abs(Y)
    d = np.maximum(iv.up(hi - x0), iv.up(x0 - lo))
    Jmid = cert.jacobian_radius(x0, d, share=0.5)  # over the midpoints (x + x0) / 2
    F0, eF = cert.F_enclosure(x0)
    eF = iv.up(eF + cert.slack_core)
    g = iv.gamma(m + 3)
    YF = Y @ F0
    eYF = (absY @ eF + g * (absY @ np.abs(F0)) + iv.TINY) * (1 + g)
    C = np.eye(len(V)) - Y @ JV
    Crad = (absY @ Jmid[:, V] + g * (absY @ np.abs(JV) + 1.0)) * (1 + g)
    M = Y @ JP
    Mrad = (absY @ Jmid[:, P] + g * (absY @ np.abs(JP))) * (1 + g)
    gn = iv.gamma(n + 2)
    rho = ((np.abs(C) * (1 + g) + Crad) @ d[V] + (np.abs(M) * (1 + g) + Mrad) @ d[P]) * (1 + gn)
    rho = iv.up(rho * (1 + gn)) + iv.TINY
    cen = x0[V] - YF
    klo = iv.down(iv.down(cen - eYF) - rho)
    khi = iv.up(iv.up(cen + eYF) + rho)
    if not (np.all(np.isfinite(klo)) and np.all(np.isfinite(khi))):
        return None
    if not (unique and np.all(klo > lo[V]) and np.all(khi < hi[V])):
        return klo, khi, False
    # uniqueness of y for each p: the Jacobian over the whole box
    return klo, khi, at_most_one_scaled_reference(cert, lo, hi, x0, d, J0, Y, V)
