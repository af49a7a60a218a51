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

import numba as nb
import numpy as np
import pinocchio as pin

from ..errors import InputError
from ..formulation.arm import P_T, P_TT, ArmTemplate
from ..pipeline import IK, IK_SIGMA
from ..search import solver
from ..search.certify import Certifier
from ..search.closed_form import MAX_ROOTS, _in_limits, solve_branches
from ..search.propagate import Propagator
from .centred import CENTRED_FAMILIES, box_translation, centred_verdicts, relaxed_outside, verdict_of
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
#: a box at the resolution the closed form does not decide whole is tried in pieces: eighths,
#: and eighths of those left undecided, down to this many halvings of its sides...
PIECE_DEPTH = 3
#: ...and at most this many pieces (a cell the workspace's border crosses ends sooner: as soon
#: as one piece is proven inside and another outside)
PIECE_BUDGET = 200
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
        cf = self.closed_form()
        if cf is None:
            return None
        v = int(self.closed_form_batch(lo[None], hi[None])[0])
        if v == 1:
            return INSIDE, self._centre_witness(cf, 0.5 * (lo + hi), lo, hi)
        if v == 0:
            return OUTSIDE, None
        return None

    def closed_form_batch(self, lo: np.ndarray, hi: np.ndarray, centred: bool = True) -> np.ndarray:
        """:meth:`closed_form_verdict` of boxes ``lo``/``hi`` (N x 3) at once, without witnesses:
        1 inside, 0 outside, -1 undecided, per box. ``centred``: the boxes the plain interval
        closed form leaves undecided are tried again in centred form (:meth:`centred_retry`)."""
        cf = self.closed_form()
        c = 0.5 * (lo + hi)
        r = np.nextafter(0.5 * (hi - lo), np.inf)
        Rlo, Rhi, tlo, thi = cf.goal_arrays(np.broadcast_to(self.R, (len(c), 3, 3)), c)
        J = -(cf.A.rotation @ self.R.T) if cf.reversed else cf.A.rotation
        out = np.zeros(len(c), dtype=np.int8)
        _verdicts(cf.code, cf.LR, cf.Lt, cf.d, cf.limits, Rlo, Rhi, tlo, thi, np.ascontiguousarray(np.abs(J)), r, out)
        if centred:
            self.centred_retry(lo, hi, out)
        return out

    def centred_retry(self, lo: np.ndarray, hi: np.ndarray, out: np.ndarray) -> None:
        """The boxes with ``out < 0`` decided again by the closed form in centred form, where the
        arm's family has one (:mod:`kinbox.workspace.centred`: the same branches, each quantity
        enclosed by its mean-value form about the box's centre, with its gradient by the
        position); their verdicts written into ``out``."""
        cf = self.closed_form()
        left = out < 0
        if cf.code not in CENTRED_FAMILIES or cf.LR.ndim != 3 or not np.any(left):
            return  # the centred form takes binary64 links only (not cf_delta.kernel_links' enclosures)
        c = 0.5 * (lo[left] + hi[left])
        # [c - r, c + r] holds the box: the rounding of c and of the half widths covered
        r = np.nextafter(0.5 * (hi[left] - lo[left]), np.inf) * (1.0 + 1e-12) + 2.0 * np.spacing(np.abs(c)) + 1e-300
        Rlo, Rhi, tlo, thi = cf.goal_arrays(np.broadcast_to(self.R, (len(c), 3, 3)), c)
        J = -(cf.A.rotation @ self.R.T) if cf.reversed else cf.A.rotation
        # J's entries as intervals covering the rounding of the product that formed them
        pad = 1e-12 * float(np.abs(J).max()) + 1e-300
        Ji = np.ascontiguousarray(np.stack([J - pad, J + pad], axis=-1))
        got = np.full(len(c), -1, dtype=np.int8)
        centred_verdicts(cf.code, cf.LR, cf.Lt, cf.d, cf.limits, Rlo, Rhi, tlo, thi, Ji, r, np.ones(len(c), dtype=np.bool_), got)
        # where two borders meet: the relaxed closed form proves outside what no branch decided over the box can
        relaxed_outside(cf.code, cf.LR, cf.Lt, cf.d, cf.limits, Rlo, Rhi, tlo, thi, np.ascontiguousarray(np.abs(J)), r, got)
        out[left] = got

    def _centre_witness(self, cf, c: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """A root of the centre ``c`` within the limits, or else the configuration of a root
        proven over the box ``lo``/``hi`` proven inside (its enclosure's midpoint)."""
        m, enc, ins = cf.roots(self.R, c)
        k = next((k for k in range(max(m, 0)) if ins[k] == 1), None)
        if k is not None:
            return cf.configuration(enc[k])
        return cf.configuration(_inside_root(self, cf, lo, hi))

    def closed_form_pieces(self, lo: np.ndarray, hi: np.ndarray, stats: dict) -> tuple[int, np.ndarray | None]:
        """The verdict on a box at the resolution that the closed form does not decide whole:
        :data:`INSIDE` when pieces of it, each proven inside, cover it, :data:`OUTSIDE` when
        pieces each proven outside cover it, else :data:`BOUNDARY`.

        The pieces are its eighths, and the eighths of each piece left undecided, down to
        :data:`PIECE_DEPTH` halvings, within :data:`PIECE_BUDGET` closed-form verdicts; a piece
        proven inside and another proven outside end the search (the workspace's border crosses
        the box), and so do two positions of the box, one proven reached and one proven not (the
        closed form at a point: the box's corners, and the centres of the pieces of each depth
        before the pieces are tried). The witness: a root of the box's centre within the limits."""
        plo, phi = _eighths(lo[None], hi[None])
        seen = 0  # bit 1: a piece (or position) proven outside, bit 2: one proven inside
        first = None  # the first piece proven inside
        calls = 0
        corners = np.array([np.where(np.array(k, dtype=bool), hi, lo) for k in np.ndindex(2, 2, 2)])
        for depth in range(1, PIECE_DEPTH + 1):
            pts = 0.5 * (plo + phi)
            if depth == 1:
                pts = np.concatenate([corners, pts])
            v = self.closed_form_batch(pts, pts, centred=False)
            stats["closed_form"] += len(pts)
            seen |= (1 if np.any(v == 0) else 0) | (2 if np.any(v == 1) else 0)
            if seen == 3:
                stats["closed_form"] += calls
                return BOUNDARY, None
            calls += len(plo)
            if calls > PIECE_BUDGET:
                stats["closed_form"] += calls - len(plo)
                return BOUNDARY, None
            v = self.closed_form_batch(plo, phi, centred=False)
            seen |= (1 if np.any(v == 0) else 0) | (2 if np.any(v == 1) else 0)
            if seen != 3:  # the centred form only where the plain one has not shown the border crossing
                self.centred_retry(plo, phi, v)
                seen |= (1 if np.any(v == 0) else 0) | (2 if np.any(v == 1) else 0)
            if first is None and np.any(v == 1):
                k = int(np.argmax(v == 1))
                first = (plo[k], phi[k])
            left = v < 0
            if seen == 3 or (depth == PIECE_DEPTH and np.any(left)):
                stats["closed_form"] += calls
                return BOUNDARY, None
            if not np.any(left):
                break
            plo, phi = _eighths(plo[left], phi[left])
        stats["closed_form"] += calls
        if seen == 1:
            return OUTSIDE, None
        assert first is not None
        return INSIDE, self._centre_witness(self.closed_form(), 0.5 * (lo + hi), *first)

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
            v, w = self.closed_form_pieces(lo, hi, stats)
            return v, w, stats
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


def _eighths(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The eight halves-along-every-axis of each box ``lo``/``hi`` (N x 3): 8 N boxes, box by box."""
    mid = 0.5 * (lo + hi)
    bits = np.array([[(k >> i) & 1 for i in range(3)] for k in range(8)], dtype=bool)  # 8 x 3
    plo = np.where(bits[None], mid[:, None], lo[:, None]).reshape(-1, 3)
    phi = np.where(bits[None], hi[:, None], mid[:, None]).reshape(-1, 3)
    return plo, phi


@nb.njit(cache=True)
def _verdicts(code, LR, Lt, d, limits, Rlo, Rhi, tlo, thi, absJ, r, out):
    """The closed form over each box ``k`` (its canonical goal's translation enclosed by
    ``[tlo, thi] +- |J| r_k``, the move of the goal over the box): ``out[k]`` 1 when a branch
    proven over the whole box has a root proven within the limits (inside), 0 when every branch
    is decided and each root is proven beyond a limit or there is none (outside), else -1."""
    enc = np.zeros((MAX_ROOTS, 6, 4))
    scratch = np.zeros((4, 3, 4))
    for k in range(out.shape[0]):
        lo = np.empty(3)
        hi = np.empty(3)
        box_translation(tlo, thi, absJ, r, k, lo, hi)
        scratch[:] = 0.0
        n, undecided = solve_branches(code, LR, Lt, d, Rlo[k], Rhi[k], lo, hi, enc, scratch, True)
        out[k] = verdict_of(enc, n, undecided, limits)


def _inside_root(reach_: Reach, cf, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The enclosure of a root proven over the whole box and within the limits (for a box
    :meth:`Reach.closed_form_batch` calls inside)."""
    c = 0.5 * (lo + hi)
    r = np.nextafter(0.5 * (hi - lo), np.inf)
    Rlo, Rhi, tlo, thi = cf.goal_arrays(reach_.R[None], c[None])
    J = -(cf.A.rotation @ reach_.R.T) if cf.reversed else cf.A.rotation
    rad = (np.abs(J) @ r) * (1.0 + 1e-12) + 1e-300
    out = np.zeros((MAX_ROOTS, 6, 4))
    n, _ = solve_branches(cf.code, cf.LR, cf.Lt, cf.d, Rlo[0], Rhi[0], tlo[0] - rad, thi[0] + rad, out, np.zeros((4, 3, 4)), True)
    return next(out[k] for k in range(max(n, 0)) if _in_limits(out[k], cf.limits) == 1)


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
