"""Curve boxes: a box wider than sigma finished at once because its zeros form a piece of a curve.

The transverse test (:mod:`kinbox.search.transverse`) proves that every zero of a box lies on
one graph over a single variable; :class:`CurveBoxRule` decides whether that graph is a piece
of a curve of solutions (then the box is finished: the answer stage follows the curve through
it) or holds isolated roots (then the box is split as usual). Every constant here shapes the
tree.
"""

from __future__ import annotations

import math

import numpy as np

from .results import BoxOutcome, SolutionBox
from .status import BoxStatus
from .transverse import correct_on_slice

#: the corrector's iterations per point, where its end points sit (a share of the parameter's
#: range from each face), how many points
CURVE_ITERS = 12
CURVE_END = 0.02
CURVE_SAMPLES = 7
#: the corrector stops once every equation row is within this share of its slack
CURVE_CLOSE = 0.5
#: ...and stops early when a step did not shrink the largest residual by this factor: on a
#: curve Gauss-Newton converges quadratically (measured: 1e12, 1e9, 1e4, 1e-1 slacks on the
#: four-bar and a Panda self-motion), next to an isolated root it sits on the least-squares
#: point from the second step on (UR5: 34 of 34 graph boxes), where the other ten steps did
#: nothing but cost about a twentieth of the pose
CURVE_STALL = 0.5
#: the Jacobian at a point of a curve: smallest singular value at most this share of the largest
#: (a few ulps on a curve, measured 1e-17..1e-15; 2e-7 at isolated roots 2e-6 apart next to one)
CURVE_RANK = 1e-10
#: ...and every equation row within this many times its slack there. The rounded rows of a
#: mechanism whose mobility rests on exact geometry have no curve, only a tube of near-solutions:
#: on Griffis-Duffy's platform the best point of a slice leaves a unit row 36 times its slack
#: off (all core rows together are inconsistent there by some 1e-13), so no sample passed a test
#: at the slack itself and every curve box was split down to sigma. The isolated root pairs the
#: test must not take for a curve leave a row 1e4 times its slack off (docs/soundness.md)
CURVE_SLACK = 100.0


class CurveBoxRule:
    """The curve-box test of one compiled system ``comp``."""

    def __init__(self, comp):
        self.comp = comp
        # a point of a curve closes every equation row within a multiple of its slack (no slack: never)
        self.eq_slack = comp.slack[: comp.n_eq] if len(comp.slack) else np.zeros(comp.n_eq)

    def through(self, lo, hi, j: int, glo, ghi) -> np.ndarray | None:
        """A box whose zeros all lie on one graph over the parameter ``x_j`` in the box
        ``[glo, ghi]`` (the transverse test proved it: for each ``x_j`` exactly one zero of
        ``Y F`` there): is that graph a piece of a curve of solutions? The zeros of ``F`` on the
        graph are the zeros of ``F(x_j, y(x_j))``, an analytic function of ``x_j``: either the
        whole graph or isolated points. The graph is taken for a curve when a corrector
        (Gauss-Newton on the other variables, ``x_j`` held) lands, at each of
        :data:`CURVE_SAMPLES` values of ``x_j`` across the box, inside ``[glo, ghi]`` on a point
        next to those the search keeps (every equation row within :data:`CURVE_SLACK` times its
        slack: :meth:`on_curve`) where the Jacobian is singular to working precision
        (:data:`CURVE_RANK`), and at least one of those points lies in the box; then the box is
        finished (the answer stage's continuation follows the curve through it) instead of split
        down to sigma. Returns the point in the box nearest its middle, or None (the box is split
        as usual, so isolated roots stay resolved).

        The two tests at every sample are what tells a curve from isolated roots near one (a UR5
        1e-6 from its shoulder singularity has pairs of roots 2e-6 apart within 1e-6 of the
        singular arm's curve): there the dropped equation stays ~1e-10 along the graph, 10^4
        times its slack, and the smallest singular value of ``J`` is 2e-7 of the largest; on a
        curve they are a few ulps (docs/soundness.md, "Curve boxes")."""
        comp = self.comp
        R = comp.rows(comp.n_eq)
        close = CURVE_CLOSE * self.eq_slack
        shares = np.linspace(CURVE_END, 1.0 - CURVE_END, CURVE_SAMPLES)
        half = len(shares) // 2
        centre = 0.5 * (lo + hi)
        best, dist = None, math.inf
        for order in (shares[half:], shares[:half][::-1]):  # from the middle out, warm started
            y = centre.copy()
            for share in order:
                y[j] = lo[j] + share * (hi[j] - lo[j])
                if not correct_on_slice(R, y, j, close, CURVE_ITERS, CURVE_STALL):
                    return None
                if not (np.all(y >= glo) and np.all(y <= ghi) and self.on_curve(y)):
                    return None
                if np.all(y >= lo) and np.all(y <= hi):
                    d = float(np.max(np.abs(y - centre) / np.maximum(hi - lo, 1e-300)))
                    if d < dist:
                        best, dist = y.copy(), d
        return best

    def on_curve(self, y: np.ndarray) -> bool:
        """Is ``y`` a point of a curve of solutions, as far as working precision can tell? Every
        equation row holds within :data:`CURVE_SLACK` times its slack there, and the Jacobian of
        all equations has a null direction: its smallest singular value is at most
        :data:`CURVE_RANK` of its largest."""
        comp = self.comp
        if not np.all(np.abs(comp.eval_eqs(y)) <= CURVE_SLACK * self.eq_slack):
            return False
        if comp.n_eq < comp.n:
            return True  # fewer equations than unknowns: J has a null space wherever it is
        s = np.linalg.svd(comp.jacobian(y, slice(0, comp.n_eq)), compute_uv=False)
        return bool(len(s) >= comp.n and s[comp.n - 1] <= CURVE_RANK * max(float(s[0]), 1.0))

    def box(self, lo, hi, x) -> BoxOutcome:
        """The curve box ``[lo, hi]`` through the point ``x``, finished."""
        res = float(np.max(np.abs(self.comp.eval_eqs(x)), initial=0.0))
        return BoxOutcome("solution", SolutionBox(lo, hi, x, BoxStatus.CURVE, res, (lo.copy(), hi.copy())))
