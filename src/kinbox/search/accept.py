"""Acceptance: when a box is finished rather than split, and what it is reported as.

A box narrower than sigma is finished when no contractor can decide it any further: it holds no
regular-looking root (those are split on until Krawczyk proves them), or it lies within the
resolution of the core rows of a root (:meth:`Acceptance.below_floor`). A finished box is first
settled if it can be: proven empty, or certified beside a regular root (a duplicate the
collector merges); otherwise it is an uncertified solution box. Every constant here shapes the
tree.
"""

from __future__ import annotations

import numpy as np

from .certify import Certifier, gauss_newton, set_newton
from .contract import Box
from .ctc_krawczyk import CtcKrawczyk
from .propagate import Propagator
from .results import BoxOutcome, SolutionBox
from .status import BoxStatus

#: equation residual of an approximate solution found in a box
RESOLVED = 1e-9
#: equation residual below which a Newton iterate is next to a root (then proven or not)
ROOT_RESIDUAL = 1e-10
#: Newton iterations towards a root from a box's centre (near-double roots converge slowly)
NEWTON_ITERS = 25
#: Newton iterations that polish an iterate before a proof is tried around it
POLISH_ITERS = 6
#: iterations of the set-Newton and Gauss-Newton steps that look for a point near a box
NEAR_ITERS = 12
#: the radius (relative to 1 + |x|) of the box a root is proven unique in
PROOF_RADIUS = 1e-8
#: the hull of a box and a root beside it is padded by this share of its width, and this much
#: (relative to 1 + |x|), before Krawczyk is tried on it
HULL_PAD = 1e-3
HULL_PAD_ABS = 1e-12
#: a box lies within the core rows' resolution of a root when it is narrower than this many
#: times the resolution (:meth:`Acceptance.below_floor`)
FLOOR_REACH = 4.0


class Acceptance:
    """The acceptance rules of one search (``opt``: its options)."""

    def __init__(self, comp, cert: Certifier, prop: Propagator, krawczyk: CtcKrawczyk | None, lo0, hi0, opt):
        self.comp, self.cert, self.prop, self.krawczyk = comp, cert, prop, krawczyk
        self.lo0, self.hi0 = lo0, hi0
        self.opt = opt

    def certified(self, vlo, vhi, klo, khi) -> BoxOutcome:
        """``[vlo, vhi]`` holds exactly one zero of the core, inside ``[klo, khi]``.

        Every zero of the box being processed lies in ``[vlo, vhi]`` (contractors are
        conservative), so that zero is the box's only candidate.
        """
        comp, cert = self.comp, self.cert
        elo, ehi = cert.tighten(klo, khi)
        if np.any(ehi < self.lo0) or np.any(elo > self.hi0):
            return BoxOutcome("empty")  # the only zero lies outside the search domain
        x = cert.newton(0.5 * (elo + ehi), elo, ehi)
        ok = True
        if comp.A.shape[0] > comp.n_eq:  # inequality rows (none in most arm systems)
            rlo, rhi = self.prop.eval_rows(elo, ehi)
            ineq_lo, ineq_hi = rlo[comp.n_eq :], rhi[comp.n_eq :]
            tol = comp.slack[comp.n_eq :]
            if np.any(ineq_lo > tol):
                return BoxOutcome("empty")  # the core's zero violates an inequality
            ok = bool(np.all(ineq_hi <= tol))
        ok = ok and bool(np.all(elo >= self.lo0) and np.all(ehi <= self.hi0))
        res = float(np.max(np.abs(comp.eval_eqs(x)), initial=0.0))
        status = BoxStatus.CERTIFIED if ok else BoxStatus.UNCERTIFIED
        return BoxOutcome("solution", SolutionBox(vlo, vhi, x, status, res, (elo, ehi)))

    def next_to_root(self, lo, hi) -> BoxOutcome | None:
        """Settle a small box lying next to a regular root, where the relaxations are too weak to
        separate the two (near-singular roots leave such clusters of boxes).

        Newton from the box centre finds a root ``x`` within sigma of the box; if Krawczyk proves
        that the hull of the box and ``x`` holds exactly one zero, the box holds that zero or
        none: it is then certified (a duplicate the collector merges) or proven empty.
        """
        cert = self.cert
        if not (cert.square and self.opt.certify):
            return None
        x = cert.newton(0.5 * (lo + hi), iters=NEWTON_ITERS)
        if not np.all(np.isfinite(x)) or np.max(np.abs(cert.F(x)), initial=0.0) > ROOT_RESIDUAL:
            return None
        d = self.opt.sigma
        if np.any(x < lo - d) or np.any(x > hi + d):
            return None
        vlo, vhi = np.minimum(lo, x), np.maximum(hi, x)
        pad = HULL_PAD * (vhi - vlo) + HULL_PAD_ABS * (1.0 + np.abs(x))
        vlo, vhi = vlo - pad, vhi + pad
        k = cert.krawczyk(vlo, vhi, x)
        if k.status == "unique":
            zlo, zhi = k.lo, k.hi
        elif self.krawczyk is not None:
            # the hull thinner than K's floor (a root of a near-double pair 1e-8 away, condition
            # 1e7): the contractor's epsilon-inflation tries a wider box around it, and returns
            # the enclosure of the one zero of its proof box
            c = self.krawczyk.contract(Box(vlo, vhi))
            if c.status != "unique" or c.proof is None:
                return None
            (vlo, vhi), zlo, zhi = c.proof, c.lo, c.hi
        else:
            return None
        klo, khi = np.maximum(zlo, vlo), np.minimum(zhi, vhi)
        if np.any(khi < lo) or np.any(klo > hi):
            return BoxOutcome("empty")  # the hull's only zero lies outside the box
        return self.certified(vlo, vhi, klo, khi)

    def accepted(self, lo, hi, root: np.ndarray | None = None) -> BoxOutcome:
        """A box below sigma that the search stops on. An approximate solution lies in it or
        near it; if that is a regular root just outside, a proof settles the box (empty, or a
        certified duplicate) instead of reporting it: a box accepted next to a near-singular
        assembly mode could hide its twin (as one did on Dietmeier's platform).

        Krawczyk on the box itself comes first: the box may have been narrowed since the
        contractors last ran on it (LP rounds, propagation), and a box 1e-7 beside a certified
        root of a near-double pair was reported as a singular root of its own, which the
        same test, run on the narrowed box, proves empty."""
        if self.krawczyk is not None:
            k = self.krawczyk.contract(Box(lo, hi))
            if k.empty:
                return BoxOutcome("empty")
            if k.status == "unique" and k.proof is not None:
                return self.certified(k.proof[0], k.proof[1], k.lo, k.hi)
        return self.next_to_root(lo, hi) or self.uncertified(lo, hi, root)

    def uncertified(self, lo, hi, root: np.ndarray | None = None) -> BoxOutcome:
        comp = self.comp
        x0 = 0.5 * (lo + hi)
        x = gauss_newton(comp, x0, lo, hi)  # least squares: robust where J is singular
        r0 = float(np.max(np.abs(comp.eval_eqs(x0)), initial=0.0))
        res = float(np.max(np.abs(comp.eval_eqs(x)), initial=0.0))
        if res > r0:
            x, res = x0, r0
        if res > RESOLVED:
            # clipping can stall on a face next to a near-singular root inside the box (a
            # Dietmeier assembly mode was reported as an unresolved box): the free iteration
            # counts if it ends in the box
            x1 = gauss_newton(comp, x0)
            r1 = float(np.max(np.abs(comp.eval_eqs(x1)), initial=0.0))
            if r1 < res and np.all(x1 >= lo) and np.all(x1 <= hi):
                x, res = x1, r1
        status = BoxStatus.UNCERTIFIED if root is None else BoxStatus.WITHIN_RESOLUTION
        return BoxOutcome("solution", SolutionBox(lo, hi, x, status, res, (lo.copy(), hi.copy()), root))

    def accept_small(self, lo, hi) -> tuple[bool, np.ndarray | None]:
        """Is a box narrower than sigma finished (returned as an uncertified solution box)?

        Not yet if it holds a regular-looking root (Krawczyk will decide it once smaller), nor
        if no approximate solution can be found in it at all (it is probably empty, like the
        "box traces" near singular configurations): such boxes are split down to
        ``sigma * resolve`` first. With the verdict, the root the box lies within the resolution
        of, if that is why it is finished (:meth:`below_floor`).
        """
        opt = self.opt
        w = np.max(hi - lo)
        if w > opt.sigma:
            return False, None
        if looks_regular(self.cert, lo, hi, max(opt.min_width, 1e-3 * opt.sigma * opt.resolve), opt.sigma):
            root = self.below_floor(lo, hi)
            return root is not None, root
        if w > opt.sigma * opt.resolve:
            x = self.near_point(lo, hi)
            if x is None:
                return False, None
            if self.cert.square and regular_root(self.cert, x):
                # an isolated root next to the box or in it, not a curve through it: split until
                # Krawczyk settles it (a box holding a near-singular pair of roots, from whose
                # centre Newton stalls between them, was reported as one point)
                return False, None
        return True, None

    def below_floor(self, lo, hi) -> np.ndarray | None:
        """Is the box, already below ``sigma * resolve``, narrower in every coordinate than four
        times the resolution of the core rows at its centre (the radius Krawczyk's operator has
        there even for a point box: the rounding of ``F(x0)`` and the rows' slack, the
        uncertainty of their coefficients, through ``|J^-1|``), and does it lie within that
        resolution, measured at the root, of the root Newton reaches from it? If it is merely
        narrower, no contractor can empty a sub-box, nor prove one to hold a unique root: any
        point of the box is a zero of the core rows moved within their slack. Between the two
        roots of a near-double pair (a UR5 1e-6 from its elbow singularity: 2e-6 apart,
        ``|J^-1|`` 6e6, the slack's reach 5e-7) such boxes were split to 1e-10 by the tens of
        thousands, and the search never ended. The box is accepted instead: reported, never
        discarded (:meth:`accepted` still tries to prove it empty or to settle it beside a
        regular root). Returns the root, or None (the box is split on)."""
        if np.max(hi - lo) > self.opt.sigma * self.opt.resolve:
            return None
        cert = self.cert
        k = cert.krawczyk(lo, hi)
        if k.floor is None:
            return None
        x0 = 0.5 * (lo + hi)
        try:
            Y = np.linalg.inv(cert.J(x0))
        except np.linalg.LinAlgError:
            return None
        reach = k.floor + np.abs(Y) @ cert.slack_core
        if not (np.all(np.isfinite(reach)) and np.all(hi - lo <= FLOOR_REACH * reach)):
            return None
        # and the box lies within the same resolution of the root Newton goes to from it, so
        # nothing in it can be told apart from that root; a box farther out, or right next to
        # the root (within its own width: Krawczyk's proofs there reach further than this
        # estimate), is split on
        x = cert.newton(x0, iters=NEWTON_ITERS)
        if not np.all(np.isfinite(x)):
            return None
        try:
            Yx = np.linalg.inv(cert.J(x))
        except np.linalg.LinAlgError:
            return None
        gap = float(np.max(np.maximum(lo - x, x - hi)))
        return x if float(np.max(hi - lo)) < gap <= FLOOR_REACH * float(np.max(np.abs(Yx) @ cert.slack_core)) else None

    def near_point(self, lo, hi) -> np.ndarray | None:
        """An approximate solution in the box or within sigma of it, or None. Unclipped: a curve
        may leave the box where the iteration heads. The truncated step (:func:`set_newton`)
        reaches a curve from beside it, where a full step runs along it; it stalls where ``J``
        is ill-conditioned on the set itself (Bricard), where plain Gauss-Newton then does."""
        x0 = 0.5 * (lo + hi)
        for step in (set_newton, gauss_newton):
            x = step(self.comp, x0, iters=NEAR_ITERS)
            near = np.all(x >= lo - self.opt.sigma) and np.all(x <= hi + self.opt.sigma)
            if near and np.max(np.abs(self.comp.eval_eqs(x)), initial=0.0) <= RESOLVED:
                return x
        return None


def looks_regular(cert: Certifier, lo, hi, min_width: float, near: float = 0.0) -> bool:
    """True if Newton from the box centre converges to a well-conditioned root in the box or
    within the box's width (or ``near``) of it (a root next to the box: the box is then split
    until it is settled by :meth:`Acceptance.next_to_root`, or pruned).

    Newton may run off to a regular root outside the box while the box holds one of its own (a
    near-double root's twin): then Newton kept inside the box is tried too.
    """
    if not cert.square or np.max(hi - lo) <= min_width:
        return False
    w = max(float(np.max(hi - lo)), near)
    x = cert.newton(0.5 * (lo + hi), iters=NEWTON_ITERS)  # near-double roots converge slowly
    if regular_root(cert, x) and not (np.any(x < lo - w) or np.any(x > hi + w)):
        return True
    x = cert.newton(0.5 * (lo + hi), lo, hi, iters=NEWTON_ITERS)
    return regular_root(cert, x)


def regular_root(cert: Certifier, x) -> bool:
    """Is ``x`` (a Newton iterate) next to a regular root? Proven, not guessed from a
    condition number: a small residual and a moderate condition number also hold a little
    off a double root, where no root is, and boxes there were split down to the minimum width.

    ``x`` is polished by Newton first: an iterate stopped at a residual of 1e-9 can lie 1e-7
    from a root of condition 1e2..1e5, outside the small box the proof is tried on, and a box
    was then accepted as a singular cluster beside a regular root it did not hold, while a
    regular root of its own (Newton from its centre did not converge) went unreported."""
    if not np.all(np.isfinite(x)):
        return False
    x = cert.newton(x, iters=POLISH_ITERS)  # quadratic near a regular root; harmless elsewhere
    if not np.all(np.isfinite(x)) or np.max(np.abs(cert.F(x)), initial=0.0) > ROOT_RESIDUAL:
        return False
    r = PROOF_RADIUS * (1.0 + np.abs(x))
    return cert.krawczyk(x - r, x + r, x).status == "unique"
