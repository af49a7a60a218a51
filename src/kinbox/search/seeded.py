"""Krawczyk proofs about Newton's point: a root next to a singularity, where no box the search
splits down to is proven, certified in boxes grown about a converged Newton iterate.

Two callers share this loop: the closed form's roots next to a singularity
(:mod:`kinbox.search.cf_seeded`: cube boxes, :func:`cube_proof`) and the points the search left
uncertified, proven from the answer stage (:func:`kinbox.search.point.seeded_certifier`:
:func:`prove_about`, cube boxes first, then shaped ones).

*Cube boxes.* Half-widths :data:`GROWTH` times the largest radius ``K`` has for a point box at
``x`` (its *floor*: the error of ``F(x)`` and the rows' uncertainty ``merr`` through ``|J^-1|``),
the same in every variable.

*Shaped boxes.* Next to a wrist singularity of an arm written in the general formulation (28
variables for a UR5, many of them frame entries) the floor is some 1e-16 in the variables the
near-null direction of ``J`` leaves alone and 5e-8 in the others (1e-8 from the singularity): a
cube wide enough for the largest is far too wide for the Jacobian's spread of the others, and
none was proven. The box's radius ``d`` is instead the fixed point of ``d <- MARGIN * r_K(d)``,
where ``r_K(d) = |Y F(x)| + floor + (|I - Y J(x)| + |Y| Jmid(d)) d`` is the radius ``K`` of the
box ``x +- d`` has (:func:`kinbox.search.certify.box_jacobian_radius` for ``Jmid``), iterated
from the floor a fixed number of times (:data:`SHAPE_STEPS`); Krawczyk itself decides each box.
Newton's iterate is first refined with the residual evaluated as in twice the working precision
(:meth:`~kinbox.search.certify.Certifier.F_enclosure`): with the residual in binary64, Newton
stops some ``|J^-1|`` ulps (3e-9 there) from the root, which the box then has to cover.

Nothing here is a proof but Krawczyk's verdict; the number of boxes tried is fixed (counters,
never time). ``tests/answer/test_newton_proof.py`` checks the proofs on a UR5 1e-7 and 1e-8 from
its wrist singularity in the general formulation against the 40-digit roots.
"""

from __future__ import annotations

import numpy as np

from .. import interval as iv
from .certify import Certifier, box_jacobian_radius

#: half-widths of the cube boxes tried, in units of Krawczyk's floor at Newton's point (the window
#: between the floor and a box whose Jacobian spread ``|Y| |T| d`` reaches 1 is about a decade
#: and a half wide 1e-6 from a UR5's elbow singularity: 3 to 64 floors)
GROWTH = (4.0, 16.0, 64.0)
#: steps of the shaped boxes' fixed-point iteration (each one Krawczyk test)
SHAPE_STEPS = 24
#: each shaped box is this much wider than the radius ``K`` has for the box before it
SHAPE_MARGIN = 1.002
#: a shaped box wider than this (in any variable) is not tried: the iteration diverges
SHAPE_LARGEST = 1e-2
#: Newton steps with the residual in twice the working precision
REFINE_STEPS = 4

#: ``(lo, hi, klo, khi)``: the box proven to hold exactly one zero of the core, and ``K``'s
#: enclosure of it
Proof = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]


def cube_proof(cert: Certifier, x: np.ndarray, growth: tuple[float, ...] = GROWTH) -> Proof | None:
    """The first cube box about ``x`` (half-widths ``growth`` times the largest floor) that
    Krawczyk proves to hold exactly one zero, or None."""
    floor = cert.krawczyk(x, x, x).floor
    if floor is None or not np.all(np.isfinite(floor)):
        return None
    for g in growth:
        d = g * float(np.max(floor)) + 1e-15 * (1.0 + np.abs(x))
        k = cert.krawczyk(x - d, x + d, x)
        if k.status == "unique":
            return x - d, x + d, k.lo, k.hi
    return None


def refine(cert: Certifier, x: np.ndarray, steps: int = REFINE_STEPS) -> np.ndarray:
    """Newton steps from ``x`` with the residual evaluated as in twice the working precision,
    while they shrink (a heuristic: the proof is Krawczyk's)."""
    last = np.inf
    for _ in range(steps):
        F, _ = cert.F_enclosure(x, model=False)
        try:
            dx = np.linalg.solve(cert.J(x), F)
        except np.linalg.LinAlgError:
            break
        step = float(np.max(np.abs(dx), initial=0.0))
        if not (np.all(np.isfinite(dx)) and step < last):
            break
        x, last = x - dx, step
    return x


def shaped_proof(cert: Certifier, x: np.ndarray) -> Proof | None:
    """The first shaped box about ``x`` (see the module's text) that Krawczyk proves to hold
    exactly one zero, or None."""
    floor = cert.krawczyk(x, x, x).floor
    if floor is None or not np.all(np.isfinite(floor)):
        return None
    J0 = cert.J(x)
    try:
        Y = np.linalg.inv(J0)
    except np.linalg.LinAlgError:
        return None
    F0, _ = cert.F_enclosure(x)
    base = np.abs(Y @ F0) + floor
    A = np.abs(np.eye(len(x)) - Y @ J0)
    absY = np.abs(Y)
    tiny = 1e-15 * (1.0 + np.abs(x))
    d = SHAPE_MARGIN * base + tiny
    R = cert.R
    for _ in range(SHAPE_STEPS):
        if not (np.all(np.isfinite(d)) and float(np.max(d)) <= SHAPE_LARGEST):
            return None
        lo, hi = x - d, x + d
        k = cert.krawczyk(lo, hi, x)
        if k.status == "unique":
            return lo, hi, k.lo, k.hi
        dd, _, Jmid = box_jacobian_radius(lo, hi, x, R.Ax, R.t_var, R.t_flat, cert.t_abs, cert.g_slope, iv.TINY, cert.mgrad_core)
        d = SHAPE_MARGIN * (base + (A + absY @ Jmid) @ dd) + tiny
    return None


def prove_about(cert: Certifier, x: np.ndarray) -> tuple[np.ndarray, Proof] | None:
    """Newton's point refined from ``x`` (:func:`refine`) and a proof about it: cube boxes,
    then shaped ones; None where neither is proven."""
    x = refine(cert, np.asarray(x, dtype=float))
    if not np.all(np.isfinite(x)):
        return None
    proof = cube_proof(cert, x) or shaped_proof(cert, x)
    return None if proof is None else (x, proof)
