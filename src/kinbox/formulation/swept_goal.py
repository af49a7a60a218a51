"""The exact goal of a six-joint arm rooted on a swept joint, enclosed at given values of it.

A seven-joint arm whose first joint ``j0`` is swept (:mod:`kinbox.problems.selfmotion`) is
written as the six-joint arm of the other joints *rooted at a frame ``S`` on ``j0``*: its
template, canonical frames and exact constants (:mod:`kinbox.formulation.constants`) do not
depend on ``j0``'s value. With the arm's base frame ``b``, the pose ``P`` of the tool in ``b``
is reached with ``j0 = t`` exactly where the tool's pose in ``S`` is ``W(t)^-1 P``, ``W(t) =
Pb^-1 relative(b, j0, t) Ps`` the frame ``S`` in ``b`` (the placements on the path between
them and ``j0``'s rotation about its exact axis, the only factor that depends on ``t``). The
template's goal is then ``G(t) = A' W(t)^-1 P B'`` (for a reversed chain ``A' P^-1 W(t) B'``),
``A'`` and ``B'`` the exact frames the template composes the goal with; each of its entries
is ``a + b cos t + c sin t`` with exact coefficients. :class:`RootedGoal` encloses ``G`` at
given values of ``t`` in interval arithmetic (``mpmath.iv``, 120 bits, outward rounding), the
pose read from its XYZQUAT as :mod:`kinbox.formulation.enclose` reads it;
:class:`kinbox.search.sweep.Anchors` takes them. ``tests/search/test_sweep_goal.py`` checks
them against the arm template's enclosure on the seven-joint arm locked at ``t``.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
from mpmath import iv

from .constants import _PREC, IFrame, _dist, _quat_matrix, enclose_links, relative


class RootedGoal:
    """The exact goal of the arm template ``arm`` (the chain from frame ``root``, on joint
    ``swept``, to ``frame``) for a pose in the frame ``base`` (None: the world) of the
    seven-joint arm, at the values ``values`` of ``swept``; ``q`` the model's configuration
    for the joints above ``swept`` (locked ones). Built once per arm: the exact frames ``A'``,
    ``B'`` and ``W(v)^-1`` at each value."""

    def __init__(self, arm, frame: str, root: str, base: str | None, swept: int, q: np.ndarray, values):
        g = arm.geometry
        mech = arm.mechanism
        model = mech.model
        self.reversed = bool(g.chain.reversed)
        self.values = [float(v) for v in values]
        old = iv.prec
        iv.prec = _PREC
        try:
            ex = enclose_links(g, mech, frame, root, keep_exact=True)
            jb, pb = mech.frame_anchor(base or "universe")
            js, ps = mech.frame_anchor(root)
            if ex is None or js != swept:
                raise ValueError("no exact frames")
            self.A, self.B = ex["A"], ex["B"]
            iq = model.joints[swept].idx_q
            self.W: list[IFrame] = []
            for v in self.values:
                qk = np.array(q, dtype=float)
                qk[iq] = v
                self.W.append(IFrame.given(pb).inverse() * relative(model, jb, swept, qk) * IFrame.given(ps))
            self.Winv = [W.inverse() for W in self.W]
        finally:
            iv.prec = old

    @classmethod
    def of(cls, arm, frame: str, root: str, base: str | None, swept: int, q: np.ndarray, values) -> RootedGoal | None:
        """As the constructor; None where the exact frames are not enclosed (a joint on the
        way that is not one revolute or prismatic axis, or ``root`` not on ``swept``)."""
        try:
            return cls(arm, frame, root, base, swept, q, values)
        except (ValueError, ZeroDivisionError):
            return None

    def goals(self, goal: pin.SE3) -> tuple[np.ndarray, np.ndarray]:
        """The template's goal (rotation row by row, then translation: 12 entries) at each
        value: binary64 midpoints and radii ``(len(values), 12)``, every radius an upper
        bound of the distance to the exact goal of the pose ``goal`` as given."""
        old = iv.prec
        iv.prec = _PREC
        try:
            v = pin.SE3ToXYZQUAT(goal)
            P = IFrame(_quat_matrix(v[3:]), [iv.mpf(float(x)) for x in v[:3]])
            Pinv = P.inverse() if self.reversed else None
            mid = np.empty((len(self.values), 12))
            rad = np.empty((len(self.values), 12))
            for k, (W, Wi) in enumerate(zip(self.W, self.Winv)):
                G = self.A * (Wi * P) * self.B if Pinv is None else self.A * (Pinv * W) * self.B
                ent = [G.R[i][j] for i in range(3) for j in range(3)] + list(G.t)
                mid[k] = [float(x.mid) for x in ent]
                rad[k] = [_dist(x, float(m)) for x, m in zip(ent, mid[k])]
            return mid, rad
        finally:
            iv.prec = old
