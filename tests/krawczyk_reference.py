"""The Krawczyk test in numpy, as ``Certifier._krawczyk`` computed it before its arithmetic was
compiled (``kinbox.search.certify._krawczyk_full``), with ``Y`` from the kernel's own inverse
(``lu_inverse``): the reference tests/test_certify.py compares the kernel with."""

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
        Jrad = cert.jacobian_radius(x0, d)
        Jmid = cert.jacobian_radius(x0, d, share=0.5)
        F0, eF = cert.F_enclosure(x0)
        YF = Y @ F0
        eYF = absY @ eF + iv.gamma(n + 2) * (absY @ np.abs(F0)) + iv.TINY
        C = np.eye(n) - Y @ J0
        Cerr = iv.gamma(n + 3) * (absY @ np.abs(J0) + 1.0)
        rho = (np.abs(C) + absY @ Jmid + Cerr) @ d
        rho = iv.up(rho * (1 + iv.gamma(n + 2))) + iv.TINY
        rfull = (np.abs(C) + absY @ Jrad + Cerr) @ d
        rfull = iv.up(rfull * (1 + iv.gamma(n + 2))) + iv.TINY
        cen = x0 - YF
        klo = iv.down(iv.down(cen - eYF) - rho)
        khi = iv.up(iv.up(cen + eYF) + rho)
        if not (np.all(np.isfinite(klo)) and np.all(np.isfinite(khi))):
            return KrawczykResult("none", lo, hi)
        if np.all(rfull < d) and np.all(klo > lo) and np.all(khi < hi):
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
