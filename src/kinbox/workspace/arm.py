"""Workspaces: where a serial arm can put a frame, as a certified paving of position space.

:func:`kinbox.workspace.serial.reach` paves a region of the frame's position space (with the tool orientation fixed)
into boxes of three kinds, in the manner of Jaulin and Walter's set inversion (SIVIA):

* **outside**: no configuration within the joint limits puts the frame anywhere in the box.
  The arm's IK system (:mod:`kinbox.formulation.arm`) is bound with the goal position as an
  enclosure of the whole box (:meth:`~kinbox.formulation.template.Template.bind` with
  ``prad``: every row then keeps the zeros of every system whose parameters lie in the box),
  and the branch and prune proves that system empty within a small box budget;
* **inside**: every position of the box is reached. A root of the box's centre, certified by
  the ordinary IK, is the centre of a box ``X`` of system variables on which Krawczyk's test
  holds for the enclosure system (:class:`~kinbox.search.certify.Certifier`): ``K(X) ⊂ int X``
  for every system within the enclosures proves that each position of the box has exactly one
  root in ``X`` (the parametric Krawczyk test, Neumaier 1990, Sec. 5.1), and ``X`` inside the
  joint limits (the inequality rows hold on ``X``) puts that root within them. The centre's
  configuration is kept as the box's witness;
* **boundary**: neither was proven and the box is no wider than the resolution.

Every other box is split in two across its widest side (:func:`~kinbox.workspace.paving.pave`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import pinocchio as pin

from ..errors import InputError
from ..formulation.arm import P_T, P_TT, ArmTemplate
from ..pipeline import IK, IK_SIGMA
from ..search import solver
from ..search.certify import Certifier
from ..search.propagate import Propagator
from .paving import BOUNDARY, INSIDE, OUTSIDE

#: boxes the search may process to prove a position box outside before the box is split instead:
#: far from the workspace a few dozen suffice; a box straddling its border would be split
#: down to sigma, which only splitting the position box can settle
OUTSIDE_BOXES = 96
#: epsilon-inflation steps of the inside test (Rump): each widens ``X`` to the hull of ``K(X)``
#: and the last ``X`` times ``INFLATE``
INSIDE_TRIES = 2
INFLATE = 1.5
#: the first ``X`` about a root: this many times the first-order move of the root over the box
FIRST_WIDTH = 1.5
#: ...plus this share of the largest move in every variable: a variable the box does not move
#: still needs room for the others' coupling through the Jacobian's spread
SPREAD = 0.3
#: pieces the inside test may prove one box with (:meth:`Reach._cover`), over all roots tried
COVER_PIECES = 64
#: how boxes are decided: "auto" by the arm's closed form where its geometry has one (else as
#: "search"), "search" by the IK system's search and the parametric Krawczyk test
METHODS = ("auto", "search")
#: boxes the IK of a box's centre may take (far more than any regular pose needs)
CENTRE_BOXES = 4000
#: relative margin on the parameters' enclosures for the rounding of their differences
PARAM_MARGIN = 1e-12


def _unit_quaternion(q: Sequence[float]) -> np.ndarray:
    a = np.asarray(q, dtype=float)
    if a.shape != (4,) or not np.all(np.isfinite(a)):
        raise InputError("the orientation takes four finite numbers: qx qy qz qw")
    n = float(np.linalg.norm(a))
    if not abs(n - 1.0) < 1e-6:
        raise InputError(f"the orientation quaternion must have norm 1 (it has {n:.6g})")
    return np.asarray(a / n, dtype=float)


class Reach:
    """One arm, frame and tool orientation, prepared to decide position boxes (:meth:`decide`):
    a :class:`~kinbox.workspace.paving.Decider`.

    Picklable: worker processes receive it once and decide boxes of a paving."""

    def __init__(self, ik: IK, orientation: Sequence[float], method: str = "auto"):
        if method not in METHODS:
            raise InputError(f"the workspace method is one of {', '.join(METHODS)}, not {method!r}")
        self.method = method
        self.ik = ik
        arm = ik.arm
        if not isinstance(arm, ArmTemplate):
            raise InputError(
                f"frame {ik.frame!r} of {ik.robot.name!r} is not reached by six revolute or prismatic joints "
                "(lock the others with --lock): no workspace paving for it"
            )
        self.arm = arm
        self.quat = _unit_quaternion(orientation)
        self.R = pin.Quaternion(self.quat[3], *self.quat[:3]).toRotationMatrix()
        self.nq = int(ik.robot.model.nq)
        self._cf: Any = None

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_cf"] = None  # compiled closed forms are rebuilt in each worker
        return state

    def closed_form(self):
        """The arm's interval closed form (:class:`~kinbox.search.closed_form.ClosedForm`), or
        None when its geometry is of no closed-form family."""
        if self._cf is None:
            self._cf = (self.method == "auto" and self.ik.closed_form) or False
        return self._cf or None

    def closed_form_verdict(self, lo: np.ndarray, hi: np.ndarray) -> tuple[int, np.ndarray | None] | None:
        """The closed form's verdict on a whole box, or None where it decides nothing.

        The goal's canonical frame ``G = A (R, t) B`` (:meth:`ClosedForm.goal_arrays`) is affine in
        the position ``t``: its translation moves by ``|dG_t/dt| r`` over the box (``r`` its half
        widths). Solved with that enclosure, a branch of the closed form whose pivots and
        discriminants are all proven of one sign over the box is a root of every position of the
        box, within its enclosure (:func:`~kinbox.search.closed_form.solve_branches`; branches not
        decided are skipped). One such root proven within the joint limits: inside, for every
        position (the witness is a root of the centre). Every branch decided, and no root or each
        proven beyond a limit: outside."""
        from ..search.closed_form import MAX_ROOTS, _in_limits, solve_branches

        cf = self.closed_form()
        if cf is None:
            return None
        c = 0.5 * (lo + hi)
        r = np.nextafter(0.5 * (hi - lo), np.inf)
        Rlo, Rhi, tlo, thi = cf.goal_arrays(self.R[None], c[None])
        J = -(cf.A.rotation @ self.R.T) if cf.reversed else cf.A.rotation
        rad = (np.abs(J) @ r) * (1.0 + 1e-12) + 1e-300
        out = np.zeros((MAX_ROOTS, 6, 4))
        n, undecided = solve_branches(
            cf.code, cf.LR, cf.Lt, cf.d, Rlo[0], Rhi[0], tlo[0] - rad, thi[0] + rad, out, np.zeros((4, 3, 4)), True
        )
        verdicts = [int(_in_limits(out[k], cf.limits)) for k in range(n)]
        if 1 in verdicts:
            m, enc, ins = cf.roots(self.R, c)
            k = next((k for k in range(max(m, 0)) if ins[k] == 1), None)
            witness = cf.configuration(enc[k]) if k is not None else cf.configuration(out[verdicts.index(1)])
            return INSIDE, witness
        if not undecided and all(v == 0 for v in verdicts):
            return OUTSIDE, None
        return None

    # -- parameters of a position box --------------------------------------------------------
    def goal(self, t: np.ndarray) -> pin.SE3:
        return pin.SE3(self.R, np.asarray(t, dtype=float))

    def enclosure(self, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(p, pmag, prad)``: the parameters of the box's centre, their magnitudes, and radii
        with ``|p(t) - p| <= prad`` for every position ``t`` of the box. Every parameter is affine
        in ``t`` but ``t . t`` (:meth:`ArmTemplate.params`): the affine ones move by ``|L| r``
        (``L`` their differences over unit steps, ``r`` the box's half widths), the square by
        ``2 |t| . |L_t| r + (|L_t| r)^2``."""
        c = 0.5 * (lo + hi)
        r = np.nextafter(0.5 * (hi - lo), np.inf)
        arm = self.arm
        p, own = arm.params_enclosure(self.goal(c))  # the centre's parameters as given
        pb = arm.params_binary64(self.goal(c))
        L = np.stack([arm.params_binary64(self.goal(c + e)) - pb for e in np.eye(3)], axis=1)  # NPARAMS x 3
        rad = np.abs(L) @ r
        rt = rad[P_T : P_T + 3]
        rad[P_TT] = 2.0 * float(np.abs(p[P_T : P_T + 3]) @ rt) + float(rt @ rt)
        mags = [arm.param_magnitudes(self.goal(np.where(np.array(k), hi, lo))) for k in np.ndindex(2, 2, 2)]
        pmag = np.maximum.reduce(mags) + np.abs(p) + rad
        # the differences L are off by a few ulps of the parameters' magnitudes
        prad = rad * (1.0 + 1e-9) + PARAM_MARGIN * pmag + own
        prad[0] = 0.0
        return p, pmag, prad

    # -- one box ---------------------------------------------------------------------------------
    def decide(self, lo: np.ndarray, hi: np.ndarray, resolution: float) -> tuple[int, np.ndarray | None, dict]:
        """The verdict on one position box: :data:`OUTSIDE`, :data:`INSIDE` (with the witness
        configuration), :data:`BOUNDARY` (no wider than ``resolution``), or -1 (split it).

        The centre's IK comes first: a box whose centre is reached is not outside, and its
        certified roots start the inside test (on the whole box above the resolution, in
        pieces at it); only a box whose centre is not reached gets the outside search."""
        stats = {"searches": 0, "search_boxes": 0, "krawczyk": 0, "closed_form": 0}
        if self.closed_form() is not None:
            # the arm's closed form decides whole boxes; where it cannot, the box is split, and at
            # the resolution it is boundary (the search's tests cost a hundred times more)
            stats["closed_form"] += 1
            got = self.closed_form_verdict(lo, hi)
            if got is not None:
                return got[0], got[1], stats
            if float(np.max(hi - lo)) > resolution:
                return -1, None, stats
            # at the resolution: the box is inside (outside) when each of its eighths is
            stats["closed_form"] += 8
            parts = [self.closed_form_verdict(*_eighth(lo, hi, k)) for k in range(8)]
            kinds = {p[0] if p is not None else BOUNDARY for p in parts}
            if kinds == {INSIDE}:
                return INSIDE, next(p[1] for p in parts if p is not None), stats
            if kinds == {OUTSIDE}:
                return OUTSIDE, None, stats
            return BOUNDARY, None, stats
        goal = self.goal(0.5 * (lo + hi))
        opts = solver.make_options(solver.SolverOptions(sigma=IK_SIGMA), progress=False, policy="quick", max_boxes=CENTRE_BOXES)
        raw = solver.solve_system(self.arm.bind(goal), opts)
        stats["searches"] += 1
        stats["search_boxes"] += int(raw.stats.get("boxes", 0))
        side = float(np.max(hi - lo))
        if raw.boxes or not raw.complete:
            roots = sorted((b.x for b in raw.boxes if b.certified), key=_order)
            # above the resolution one test of the whole box per root; at it, pieces too
            budget = [COVER_PIECES if side <= resolution else len(roots)]
            for x in roots:
                if self._cover(lo, hi, x, stats, budget):
                    return INSIDE, self.arm.decode(x, goal), stats
        else:
            p, pmag, prad = self.enclosure(lo, hi)
            wide = self.arm.template.bind(p, pmag, prad=prad)
            out = solver.solve_system(wide, solver.make_options(opts, max_boxes=OUTSIDE_BOXES))
            stats["searches"] += 1
            stats["search_boxes"] += int(out.stats.get("boxes", 0))
            if out.complete and not out.boxes:
                return OUTSIDE, None, stats
        if side <= resolution:
            return BOUNDARY, None, stats
        return -1, None, stats

    def _cover(self, lo, hi, x, stats, budget: list[int]) -> bool:
        """Is every position of ``[lo, hi]`` proven reached? The box, or each piece of it down
        to a quarter of its widest side (at most :data:`COVER_PIECES` pieces), passes the
        parametric Krawczyk test (:meth:`_proven`) about a root of its centre, which Newton
        finds from the root of the piece it was cut from. ``budget``: pieces left for this box
        (shared by the roots tried)."""
        min_side = 0.25 * float(np.max(hi - lo))
        stack = [(lo, hi, x)]
        while stack:
            blo, bhi, guess = stack.pop()
            budget[0] -= 1
            if budget[0] < 0:
                return False
            p, pmag, prad = self.enclosure(blo, bhi)
            x0 = Certifier(self.arm.template.bind(p, pmag).compile()).newton(guess)
            wide = self.arm.template.bind(p, pmag, prad=prad)
            comp = wide.compile()
            cert = Certifier(comp)
            if np.all(np.isfinite(x0)) and cert.square and self._proven(cert, Propagator(comp), comp, x0, self._limits(wide), stats):
                continue
            side = bhi - blo
            i = int(np.argmax(side))
            if side[i] <= min_side:
                return False
            mid = 0.5 * (blo[i] + bhi[i])
            a_hi, b_lo = bhi.copy(), blo.copy()
            a_hi[i] = mid
            b_lo[i] = mid
            g = x0 if np.all(np.isfinite(x0)) else guess
            stack += [(b_lo, bhi, g), (blo, a_hi, g)]
        return True

    def _limits(self, system) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The variables whose domains are joint limits (displacements; a revolute joint's
        limits are inequality rows, its cosine's and sine's domains their consequences) and
        those domains."""
        lo, hi = system.domain()
        idx = np.array([i for i, t in enumerate(self.arm.template.vars.tags) if t == "disp"], dtype=int)
        return idx, lo[idx], hi[idx]

    @staticmethod
    def _proven(cert: Certifier, prop: Propagator, comp, x: np.ndarray, limits, stats) -> bool:
        """The parametric Krawczyk test about ``x`` (see the module docstring), with
        epsilon-inflation: ``X`` starts at the first-order move of the root over the box."""
        try:
            Y = np.linalg.inv(cert.J(x))
        except np.linalg.LinAlgError:
            return False
        _, eF = cert.F_enclosure(x)
        move = np.abs(Y) @ eF
        if not np.all(np.isfinite(move)):
            return False
        r = FIRST_WIDTH * move + SPREAD * float(move.max()) + 1e-12 * (1.0 + np.abs(x))
        lo, hi = x - r, x + r
        for _ in range(INSIDE_TRIES):
            stats["krawczyk"] += 1
            k = cert.krawczyk(lo, hi, x0=x)
            if k.status == "unique":
                # the root of every position lies in K(X) ∩ X: within the displacements' domains
                # and the inequality rows (the joint limits) there
                klo, khi = np.maximum(k.lo, lo), np.minimum(k.hi, hi)
                idx, dlo, dhi = limits
                if np.any(klo[idx] < dlo) or np.any(khi[idx] > dhi):
                    return False
                if comp.A.shape[0] > comp.n_eq:
                    _, rhi = prop.eval_rows(klo, khi)
                    if np.any(rhi[comp.n_eq :] > 0.0):
                        return False
                return True
            if k.status != "contracted":
                return False
            mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
            lo, hi = mid - INFLATE * half, mid + INFLATE * half
        return False


def _eighth(lo: np.ndarray, hi: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``k``-th of the eight boxes that halve ``[lo, hi]`` along every axis."""
    mid = 0.5 * (lo + hi)
    bits = np.array([(k >> i) & 1 for i in range(3)], dtype=bool)
    return np.where(bits, mid, lo), np.where(bits, hi, mid)


def _order(x: np.ndarray) -> tuple[float, ...]:
    """The order roots are tried in: their coordinates, rounded (the same on every run)."""
    return tuple(float(v) for v in np.round(x, 9))


def default_region(ik: IK) -> np.ndarray:
    """A cube about the base that holds every point the frame can reach: centred on the first
    joint of the chain, half side the sum of the distances between consecutive joints and the
    frame (each link turns about its joint), rounded up to a centimetre."""
    arm = ik.arm
    if not isinstance(arm, ArmTemplate):
        raise InputError("no workspace paving for this chain")
    model = ik.robot.model
    data = model.createData()
    q = pin.neutral(model)
    pin.forwardKinematics(model, data, q)
    pin.updateFramePlacements(model, data)
    pts = [data.oMi[j].translation for j in ik.chain]
    pts.append(ik.pose_at(q[: model.nq]).translation if ik.base is None else data.oMf[model.getFrameId(ik.frame)].translation)
    reach_len = sum(float(np.linalg.norm(b - a)) for a, b in zip(pts, pts[1:]))
    prismatic = sum(
        max(abs(float(model.lowerPositionLimit[model.joints[j].idx_q])), abs(float(model.upperPositionLimit[model.joints[j].idx_q])))
        for j in ik.chain
        if model.joints[j].shortname().startswith("JointModelP")
    )
    half = math.ceil((reach_len + prismatic) * 100.0 + 1.0) / 100.0
    c = np.asarray(pts[0], dtype=float)
    return np.array([c - half, c + half])


__all__ = ["Reach", "default_region"]
