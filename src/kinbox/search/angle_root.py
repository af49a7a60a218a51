"""One root of a six-revolute arm proven in its joint angles, next to a singularity where the
search's variables cannot prove it.

Next to a UR5's wrist singularity the general formulation's 28 variables (cosines, sines and
frame entries) leave a root within 1e-9 of singular unproven: Krawczyk's floor there, the rows'
uncertainty through ``|J^-1|``, is wider than any axis-aligned box whose Jacobian spread it can
bear (:mod:`kinbox.search.seeded`). In the six joint angles the same root is proven: the Taylor
model of :mod:`kinbox.search.separate` (``F``, ``J``, ``H`` at a centre in 128-bit intervals on
the model's exact constants, a Lagrange remainder for the rest), in the variables ``z`` of
``theta = c + B z`` with ``B`` the right singular vectors of ``J(c)``, so that the near-null
direction is one variable. :func:`prove_root` moves the centre to Newton's point on that model
(:data:`RECENTRE` times: the remainder grows with the distance from the centre), takes Newton's
point once more in ``z`` (below the spacing of binary64 angles at the centre), then tries
Krawczyk (:func:`kinbox.search.separate.krawczyk`) on boxes :data:`GROWTH` times the radius
``|Y| |F(m)|`` Newton's point leaves. A fixed number of steps (counters, never time); nothing
but Krawczyk's verdict is a proof. ``tests/answer/test_angle_proof.py`` checks the proofs
against the 40-digit roots.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import separate as sep

#: Newton steps on the Taylor model about each centre
NEWTON_STEPS = 20
#: times the centre is moved to Newton's point before the proof
RECENTRE = 3
#: half-widths of the boxes tried, in units of ``|Y| |F(m)|`` at Newton's point
GROWTH = (2.0, 8.0, 64.0)
#: the smallest half-width tried, relative to ``1 + |theta|`` in each angle
RAD_FLOOR = 2.0**-60
#: a centre farther than this from the given point (radians, any angle) is not this point's
#: root: no proof is tried
MOVE_LARGEST = 1e-2


@dataclass
class AngleRoot:
    """A root proven alone: Newton's point ``theta`` (geometry angles), Krawczyk's enclosure
    ``lo``/``hi`` of it (inside the proof box ``plo``/``phi``, which holds exactly one root)."""

    theta: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    plo: np.ndarray
    phi: np.ndarray


def _newton(model: sep.Model) -> np.ndarray | None:
    """Newton on the model's midpoint Taylor polynomial from ``z = 0``."""
    return sep.newton_on_model(model, np.zeros(6), NEWTON_STEPS)


def _rotated(cs: sep.Constants, V: np.ndarray, c: np.ndarray) -> sep.Model:
    model = sep.taylor_model(cs, V, c)
    _, _, Vt = np.linalg.svd(0.5 * (model.J[0] + model.J[1]))
    return model.rotated(np.ascontiguousarray(Vt.T))


def prove_root(cs: sep.Constants, V: np.ndarray, c: np.ndarray) -> AngleRoot | None:
    """The root next to the angles ``c`` (geometry angles) of the arm ``cs`` at the goal ``V``
    (XYZQUAT as given), proven alone in a box (module docstring), or None."""
    c0 = np.asarray(c, dtype=float)
    c = c0.copy()
    for _ in range(RECENTRE):
        model = _rotated(cs, V, c)
        z = _newton(model)
        if z is None:
            return None
        c = c + model.B @ z
        if not (np.all(np.isfinite(c)) and float(np.max(np.abs(c - c0))) <= MOVE_LARGEST):
            return None
    model = _rotated(cs, V, c)
    if not model.trace > 0.5:  # a half turn from the goal: zeros of F that are no roots
        return None
    # Newton's point in ``z``, which resolves the root below the angles' binary64 spacing at
    # ``c``: ``F`` there is the 128-bit model's rounding, not ``J`` times half an ulp of ``c``
    m = _newton(model)
    if m is None:
        return None
    F = sep.f_at(model, m[None])
    Jm = 0.5 * (model.J[0] + model.J[1]) + np.einsum("qji,i->qj", 0.5 * (model.H[0] + model.H[1]), m)
    try:
        Y = np.linalg.inv(Jm)
    except np.linalg.LinAlgError:
        return None
    base = np.abs(Y) @ np.maximum(np.abs(F[0][0]), np.abs(F[1][0]))
    floor = RAD_FLOOR * (1.0 + float(np.max(np.abs(c))))
    for g in GROWTH:
        rad = g * base + floor
        k = sep.krawczyk(model, m, rad)
        if k is None:
            continue
        lo, hi = model.theta(k[0][None], k[1][None])
        plo, phi = model.theta((m - rad)[None], (m + rad)[None])
        return AngleRoot(c, lo[0], hi[0], plo[0], phi[0])
    return None
