"""The closed form's roots next to a singularity, certified on the kinbox system from Newton's point.

Where the interval closed form (:mod:`kinbox.search.closed_form`) proves a pose's count of roots
(every discriminant and pivot away from zero, every root's joint limits decided) but its
certificates fail -- a near-double root, 1e-6 from the elbow singularity of a UR5: the closed
form's root (the midpoint of its enclosure) is 1e-7 off the root, and the Jacobian's condition
number is 1e7 -- each root kept is certified here by Krawczyk on the pose's own kinbox system
(:meth:`kinbox.search.certify.Certifier.krawczyk`, the search's test):

1. Newton on the system's core from the closed form's root (a float iterate: no proof);
2. Krawczyk on boxes about that point whose half-widths are :data:`GROWTH` times the
   radius ``K`` has for a point box there (its *floor*: the error of ``F`` and the rows'
   uncertainty through ``|J^-1|``), until one holds exactly one root (``K(X) ⊂ int X`` and
   ``|I - Y J(X)| d < d``); the count of boxes tried is fixed (counters, never time);
3. the proof box is checked inside the search domain, apart from every other root's
   enclosure (some joint's ``cos`` or ``sin`` disjoint from that root's, turned to the
   system's angles) and from the other proof boxes.

The closed form's roots are all the roots, each in its own enclosure; a proof box apart from
every other enclosure holds one root, which is therefore the root of its own enclosure. With
every root kept certified so, the answer is complete, as on the closed form's fast path
(:func:`kinbox.answer.closed_form.closed_form_result`). Otherwise None: the pose goes to the
branch and prune (:mod:`kinbox.search.cf_fallback`). ``tests/search/test_cf_seeded.py``
compares the answers with the search of the whole domain on planted near-singular poses.
"""

from __future__ import annotations

import math

import numpy as np

from .certify import Certifier
from .closed_form import (
    MAX_ROOTS,
    POSE_CLOSED_FORM,
    Batch,
    ClosedForm,
    encode_rows,
    iadd,
    iscale,
    isub,
    root_angles,
)

#: half-widths of the boxes tried, in units of Krawczyk's floor at Newton's point (the window
#: between the floor and a box whose Jacobian spread ``|Y| |T| d`` reaches 1 is about a decade
#: and a half wide 1e-6 from a UR5's elbow singularity: 3 to 64 floors)
GROWTH = (4.0, 16.0, 64.0)
#: Newton steps from the closed form's root
NEWTON_STEPS = 20
#: the enclosures turned to the system's angles are widened by this (``math.cos``, ``math.sin``
#: of the shift within an ulp, times entries at most 1)
TURN_ERR = 1e-15


def _turned(enc: np.ndarray, shift: np.ndarray, i: int) -> tuple[tuple[float, float], tuple[float, float]]:
    """Joint ``i``'s ``(cos, sin)`` enclosure of a root (family angles) in the system's angle
    (``theta + shift[i]``), widened by :data:`TURN_ERR`."""
    cs, sn = math.cos(shift[i]), math.sin(shift[i])
    c, s = (enc[i, 0], enc[i, 1]), (enc[i, 2], enc[i, 3])
    c2 = isub(iscale(cs, c), iscale(sn, s))
    s2 = iadd(iscale(cs, s), iscale(sn, c))
    return (c2[0] - TURN_ERR, c2[1] + TURN_ERR), (s2[0] - TURN_ERR, s2[1] + TURN_ERR)


def apart(klo: np.ndarray, khi: np.ndarray, enc: np.ndarray, tc) -> bool:
    """Is the system box ``[klo, khi]`` proven apart from a root's enclosure ``enc`` ((6, 4),
    family angles): some joint's ``cos`` or ``sin`` variable over the box disjoint from the
    root's?"""
    for i in range(6):
        c2, s2 = _turned(enc, tc.shift, i)
        for var, iv in ((tc.cvar[i], c2), (tc.svar[i], s2)):
            if var >= 0 and (khi[var] < iv[0] or klo[var] > iv[1]):
                return True
    return False


def seeded_roots(cf: ClosedForm, cert: Certifier, goal_R: np.ndarray, goal_t: np.ndarray, lo0: np.ndarray, hi0: np.ndarray) -> Batch | None:
    """The roots of the goal ``(goal_R, goal_t)`` certified on its kinbox system (``cert``, its
    search domain ``lo0``, ``hi0``) from Newton's point (see the module's text), as a one-pose
    :class:`~kinbox.search.closed_form.Batch` with the system certificate, or None (the closed
    form does not decide the pose, or a root is not certified so)."""
    tc = cf.certifier
    if tc is None or not cert.square or tc.n != cert.comp.n:
        return None
    n_roots, enc, inside = cf.roots(goal_R, goal_t)
    if n_roots < 0 or n_roots > MAX_ROOTS or np.any(inside[:n_roots] < 0):
        return None
    keep = [r for r in range(n_roots) if inside[r] == 1]
    theta = np.zeros((len(keep), 6))
    for m, r in enumerate(keep):
        root_angles(enc[r], theta[m])
    P, _ = tc.params(goal_R[None], goal_t[None])
    X = np.zeros((len(keep), tc.n))
    encode_rows(theta, P[0], tc.fixed, tc.cvar, tc.svar, tc.shift, tc.def_target, tc.def_start, tc.def_param, tc.def_coef,
                tc.def_a, tc.def_b, X)  # fmt: skip
    xs, los, his, res = [], [], [], []
    for m, r in enumerate(keep):
        x = cert.newton(X[m], iters=NEWTON_STEPS)
        if not np.all(np.isfinite(x)):
            return None
        floor = cert.krawczyk(x, x, x).floor
        if floor is None or not np.all(np.isfinite(floor)):
            return None
        proof = None
        for g in GROWTH:
            d = g * float(np.max(floor)) + 1e-15 * (1.0 + np.abs(x))
            k = cert.krawczyk(x - d, x + d, x)
            if k.status == "unique":
                proof = (k.lo, k.hi)
                break
        if proof is None:
            return None
        klo, khi = proof
        if np.any(klo < lo0) or np.any(khi > hi0):
            return None
        if not all(apart(klo, khi, enc[j], tc) for j in range(n_roots) if j != r):
            return None
        if not all(np.any(khi < plo) or np.any(klo > phi) for plo, phi in zip(los, his)):
            return None
        theta[m] = _angles(x, tc, theta[m])
        xs.append(x)
        los.append(klo)
        his.append(khi)
        res.append(float(np.max(np.abs(cert.comp.eval_eqs(x)), initial=0.0)))
    m = len(keep)
    e = np.zeros((m, tc.n))
    return Batch(
        np.array([POSE_CLOSED_FORM]),
        np.array([0]),
        np.array([m]),
        theta,
        np.array(xs).reshape(m, tc.n),
        np.array(los).reshape(m, tc.n) if m else e,
        np.array(his).reshape(m, tc.n) if m else e,
        np.array(res),
        True,
        "system",
    )


def _angles(x: np.ndarray, tc, theta: np.ndarray) -> np.ndarray:
    """The family's angles at the system point ``x`` (where both of a joint's variables are
    there; else ``theta``'s)."""
    out = theta.copy()
    for i in range(6):
        if tc.cvar[i] >= 0 and tc.svar[i] >= 0:
            out[i] = math.atan2(x[tc.svar[i]], x[tc.cvar[i]]) - tc.shift[i]
    return out
