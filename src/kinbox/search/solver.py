"""Branch-and-prune over boxes (Porta, Ros and Thomas 2009, Algorithm 1), with cheap contractors before LPs.

For each box taken from the list:

1. **propagate** (``propagate.py``): interval constraint propagation, vectorised; may prove
   the box empty;
2. **Krawczyk** (``certify.py``, square systems only): may prove the box empty, contract it, or
   prove it holds exactly one solution — then the box is finished at once (polished by Newton,
   certified), however wide it still is;
3. **SHRINK-BOX** (``relaxation.py``): two LPs per variable over the linear relaxation,
   repeated while the box volume drops below ``rho`` of what it was;
4. a box narrower than ``sigma`` that is not certified is returned as an (uncertified) solution
   box; so is a wider *curve box*, where the transverse test (``transverse.py``) proves that
   every zero of the box lies on one graph over a single variable and a corrector finds that
   graph to be a piece of a curve of solutions (``SolverOptions.curve_boxes``); otherwise the box
   is **split**.

Every pruning step is conservative (outward rounding, safe LP bounds), so the union of the
returned boxes holds every solution of the system inside the initial domain. When a budget
(``max_boxes``, ``time_limit``) stops the search the result says so (``complete=False``) and keeps
the unexplored boxes in ``pending``.
"""

from __future__ import annotations

import dataclasses
import math
import os
import sys
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import FloatingPointModeError, InputError
from ..formulation.system import System
from ..interval import flushing_subnormals
from . import bernstein, certify, interrupt, propagate, relaxation, transverse
from .bernstein import BernsteinRelaxation
from .certify import Certifier, gauss_newton, set_newton
from .contractors import Krawczyk, LinearRelaxation, Propagation
from .loading import load_clock
from .policy import POLICIES, T_GAIN, Events, Hint, Policy
from .state import SearchState, fingerprint, tree_options
from .threads import single_threaded
from .transverse import Transverse, correct_on_slice

SPLIT_POINT = 0.4937  # a split slightly off the middle: solutions rarely sit on the cut
RATIO = 0.1  # split candidates are at least this wide relative to the widest: no flat boxes
#: with split ranks, the variables of a rank are split first while one is wider than this
#: share of its domain
RANK_DONE = 0.02
RESOLVED = 1e-9  # equation residual of an approximate solution found in a box
#: derived variables are split once every independent one is narrower than this share of its
#: domain and a derived one is this many times wider (see BoxProcessor._split_variable)
AUX_SPLIT_BELOW = 1e-4
AUX_WIDER = 100.0
#: a curve box (:meth:`BoxProcessor._curve_through`): the corrector's iterations per point,
#: where its end points sit (a share of the parameter's range from each face), how many points
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


@dataclass
class SolutionBox:
    """A box returned by the solver.

    ``lo``/``hi`` is the box the solver finished (for a certified box: the region proven to
    hold exactly one solution); ``enclosure`` is the tightest box known to hold it; ``x`` a
    polished point; ``residual`` the max absolute equation value at ``x``.
    """

    lo: np.ndarray
    hi: np.ndarray
    x: np.ndarray
    certified: bool
    residual: float
    enclosure: tuple[np.ndarray, np.ndarray]
    #: for a box accepted within the core rows' resolution of a root (``_below_floor``): that
    #: root, as Newton reached it; nothing in the box can be told apart from it
    within_resolution_of: np.ndarray | None = None
    #: a curve box (:meth:`BoxProcessor._curve_box`): the search stopped on it because its zeros
    #: looked like a piece of a curve, whatever its width (narrowed after the test, it can end
    #: below sigma, like a box accepted beside a root)
    curve: bool = False

    @property
    def width(self) -> float:
        return float(np.max(self.enclosure[1] - self.enclosure[0], initial=0.0))


@dataclass
class SolveResult:
    """Outcome of :func:`solve_system`, in the style of ``scipy.optimize.OptimizeResult``."""

    success: bool
    complete: bool
    message: str
    boxes: list[SolutionBox]
    pending: list[tuple[np.ndarray, np.ndarray]]
    stats: dict
    system: System
    #: where an incomplete search stopped, to go on with it (``resume=``); None when complete
    state: SearchState | None = None

    @property
    def certified(self) -> list[SolutionBox]:
        return [b for b in self.boxes if b.certified]

    def __repr__(self) -> str:
        return (
            f"SolveResult(success={self.success}, complete={self.complete}, "
            f"boxes={len(self.boxes)}, certified={len(self.certified)}, "
            f"message={self.message!r})"
        )


@dataclass
class SolverOptions:
    sigma: float = 1e-3
    rho: float = 0.95
    max_boxes: int | None = 500_000
    time_limit: float | None = None
    lp: bool = True
    certify: bool = True
    progress: bool | None = None  # None: only when stderr is a terminal
    lp_rounds: int = 20
    #: square systems: a box below sigma that holds a regular-looking root is split further
    #: (until Krawczyk proves it or it is narrower than this), since sigma is meant for
    #: positive-dimensional sets and certification, not width, decides isolated roots
    min_width: float = 1e-11
    #: a box below sigma in which no approximate solution is found is split down to
    #: ``sigma * resolve`` before it is returned (uncertified)
    resolve: float = 1e-3
    #: the ``time.perf_counter()`` the time limit counts from (None: the start of the search),
    #: so that a limit can cover loading and formulation too
    started: float | None = None
    #: bytes the boxes held by the search (pending and solution boxes) may take, estimated from
    #: their number and size (:func:`held_bytes`): the search stops, incomplete, beyond it
    max_memory: float | None = 2e9
    #: the LP contractor: ``"linear"`` (Porta, Ros and Thomas 2009: secants, tangents, McCormick), ``"bernstein"`` (Fünfzig et al. 2010:
    #: the Bernstein polytope of each box's unit box), ``"none"`` (intervals only: propagation
    #: and Krawczyk; the same as ``lp=False``) or ``"auto"``: Bernstein, which was as fast or
    #: faster on every problem measured but one (benchmarks/relaxations.py);
    #: :class:`kinbox.pipeline.Problem` picks linear for that one's kind, mobile platforms with
    #: leg vectors
    relaxation: str = "auto"
    #: a box wider than sigma whose zeros the transverse test proves to lie on one graph over
    #: a single parameter, which a corrector finds to be a piece of a curve of solutions (at
    #: every sample a point where every equation holds to a small multiple of its slack and the Jacobian is
    #: singular to working precision), is returned at once (a *curve box*: the answer stage
    #: follows the curve through it) instead of being split down to sigma; False: every
    #: uncertified box is narrower than sigma. Self-motions take seconds with it and minutes
    #: without. Before the two tests at every sample it took pairs of isolated roots 2e-6 apart
    #: next to a curve (UR5 1e-6 from its shoulder singularity) for a curve piece
    #: (docs/soundness.md, "Curve boxes")
    curve_boxes: bool = True
    #: how the LP policy starts (:data:`kinbox.search.policy.POLICIES`): ``"steady"``, or
    #: ``"quick"`` (a cold round's cost assumed, first rounds replace the priors), which
    #: :class:`kinbox.IK` uses: its searches are short
    policy: str = "steady"


class Progress:
    """Progress of a search on stderr, drawn by tqdm: boxes so far and their rate, pending boxes,
    solutions, and the share of the domain's volume still to explore (the boxes ``done..`` of
    the wave and the next wave so far). Refreshed at most every ``INTERVAL`` seconds; what is
    shown never feeds back into the search."""

    INTERVAL = 0.25

    def __init__(self, enabled: bool, root_logvol: np.ndarray):
        self.enabled = enabled
        self.last = time.perf_counter()
        self.root_w = root_logvol
        self.bar: Any = None
        if enabled:
            from tqdm import tqdm

            # smoothing=0: the rate is boxes over the whole run, not a noisy recent average.
            # A terminal that reports a size of 0 x 0 (a bare pty) would get no line at all
            # from tqdm: no width limit there, and room for the line.
            size = {"ncols": 0, "nrows": 20} if _columns(sys.stderr) == 0 else {}
            self.bar = tqdm(
                desc="kinbox",
                unit=" boxes",
                file=sys.stderr,
                leave=True,
                mininterval=0,
                smoothing=0,
                bar_format="{desc}: {n_fmt}{unit}{postfix} [{elapsed}, {rate_fmt}]",
                **size,
            )

    def report(self, stats, wave, done: int, nxt, force=False):
        """Update the line (``force``: now, and the final time: the line is closed)."""
        if self.bar is None:
            return
        now = time.perf_counter()
        if not force and now - self.last < self.INTERVAL:
            return
        self.last = now
        todo = list(wave[done:]) + list(nxt)
        vol = sum(float(np.prod(np.clip((b[1] - b[0]) / self.root_w, 0, 1))) for b in todo)
        self.bar.set_postfix_str(
            f"{len(todo)} pending, {stats['solutions']} solutions ({stats['certified']} certified), volume left {vol:.3e}", refresh=False
        )
        self.bar.n = stats["boxes"]
        if force:
            self.bar.close()  # draws the final state once more and ends the line
            self.bar = None
        else:
            self.bar.refresh()


def _columns(stream: Any) -> int | None:
    """The width of the terminal ``stream`` writes to, or None if it is not a terminal."""
    try:
        return os.get_terminal_size(stream.fileno()).columns
    except (AttributeError, OSError, ValueError):
        return None


@dataclass
class BoxOutcome:
    """What processing one box gave: ``kind`` is "empty", "solution", "split" or "unfinished"
    (a deadline passed inside the box: ``children`` holds the box, to be explored later).
    ``children`` are ``(lo, hi, hint)``."""

    kind: str
    solution: SolutionBox | None = None
    children: list = field(default_factory=list)
    lps: int = 0
    krawczyk: int = 0
    events: Events = field(default_factory=Events)


#: Krawczyk tests again on a box its last test (and propagation after it) narrowed by at least
#: 0.1 of log-volume, at most this many times: the contraction of a box next to a root is
#: quadratic while it pays, and a box split instead came back a wave later for the same
#: test. UR5, 100 poses: 3,172 -> 2,792 boxes, worst pose 0.5x (benchmarks/ur_poses.py per-pose)
K_REPEATS = 3


class BoxProcessor:
    """Processes one box at a time: contract, certify, shrink, then accept or split.

    It holds no search state (what a box needs from the search so far comes with it, as a
    :class:`~kinbox.search.policy.Hint`), so serial and parallel searches share it and give the
    same tree; each process builds its own.
    """

    def __init__(self, system: System, options: SolverOptions):
        self.opt = options
        check_floating_point()
        self.comp = comp = system.compile()
        # each compiled kernel loads at its first call (after an install: compiles, then caches):
        # a UR5 pose uses three of the eleven, and loading the others showed in the start-up of
        # a whole `kinbox ik` run (benchmarks/ur_poses.py startup); :func:`load_kernels` loads all of them
        # ahead, where a time limit is to leave the first compilation out
        # the domain widened by the slack of derived rows: a root on a bound (an angle of 0, a
        # rotation entry of 1, a joint at its limit) is inside it, however its proof box lies
        self.lo0, self.hi0 = system.search_domain()
        self.root_w = np.maximum(self.hi0 - self.lo0, 1e-300)
        self.split_mask = system.independent()
        self.ranks = system.split_ranks()
        #: the independent variables of each rank, lowest rank first
        self.rank_masks = (
            [] if self.ranks is None else [self.split_mask & (self.ranks == r) for r in np.unique(self.ranks[self.split_mask])]
        )
        self.cert = Certifier(comp)
        self.hc4 = Propagation(comp)
        self.krawczyk = Krawczyk(self.cert) if self.cert.square and options.certify else None
        self.transverse = Transverse(self.cert) if comp.n_core > 0 else None
        # built at the first LP round: most IK poses have none, and a relaxation's model and
        # HiGHS instance cost a few percent of such a pose
        self.has_lp = lp_kind(options, comp) is not None
        self._lp = None
        # a point of a curve closes every equation row within a multiple of its slack (no slack: never)
        self.eq_slack = comp.slack[: comp.n_eq] if len(comp.slack) else np.zeros(comp.n_eq)
        self.deadline: float | None = None

    @property
    def prop(self):
        """The interval propagator (evaluations of rows over boxes)."""
        return self.hc4.prop

    @property
    def lp(self):
        """The LP contractor (None: no LPs), built when first asked for."""
        if self._lp is None and self.has_lp:
            self._lp = lp_contractor(self.opt, self.comp, self.split_mask, self.root_w)
            self._lp.deadline = self._lp.relax.deadline = self.deadline
        return self._lp

    def set_deadline(self, deadline: float | None) -> None:
        """Stop inside a box (between LPs) once ``time.perf_counter()`` passes ``deadline``."""
        self.deadline = deadline
        if self._lp is not None:
            self._lp.deadline = self._lp.relax.deadline = deadline

    def _split_variable(self, lo, hi) -> int:
        """The independent variable of largest *smear*: sum_r |dF_r/dx_j| * width_j.

        The smear (|J| at the box centre times the width) measures how much the equations vary along ``x_j``;
        cutting there reduces the linearization error most. Derived (``aux``) variables are
        not cut while an independent one is wider than :data:`AUX_SPLIT_BELOW` of its domain;
        past that, the widest derived variable is, if it is :data:`AUX_WIDER` times wider (a
        derived variable that the independent ones leave free: an arm whose joint 4 lines up
        with joint 1 turns about that line, and splitting the pinned independents again and
        again never ended). Falls back to the widest relative width when the Jacobian is not
        at hand.
        """
        w = hi - lo
        rel = w / self.root_w
        mask = self.split_mask
        if not mask.all():
            ind, aux = float(rel[mask].max()), float(rel[~mask].max())
            if ind < AUX_SPLIT_BELOW and aux > AUX_WIDER * ind:
                return int(np.argmax(np.where(mask, -1.0, rel)))
        if self.ranks is not None:  # the lowest rank that is not narrow yet
            for m in self.rank_masks:
                if rel[m].max() > RANK_DONE:
                    mask = m
                    break
        if self.comp.n_core:
            smear = np.abs(self.cert.J(0.5 * (lo + hi))).sum(axis=0) * w
        else:
            smear = w / self.root_w
        # ignore variables already much narrower than the others: the Jacobian at the centre
        # may vanish along a wide one (then the widest is cut, below)
        smear = np.where(mask & (rel >= RATIO * rel[mask].max()), smear, -1.0)
        i = int(np.argmax(smear))
        if smear[i] <= 0:
            i = int(np.argmax(np.where(mask, w / self.root_w, -1.0)))
        return i

    def _logvol(self, lo, hi):
        return float(np.sum(np.log(np.maximum((hi - lo) / self.root_w, 1e-30))))

    def _certified(self, vlo, vhi, klo, khi) -> BoxOutcome:
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
        return BoxOutcome("solution", SolutionBox(vlo, vhi, x, ok, res, (elo, ehi)))

    def _next_to_root(self, lo, hi) -> BoxOutcome | None:
        """Settle a small box lying next to a regular root, where the relaxations are too weak to
        separate the two (near-singular roots leave such clusters of boxes).

        Newton from the box centre finds a root ``x`` within sigma of the box; if Krawczyk proves
        that the hull of the box and ``x`` holds exactly one zero, the box holds that zero or
        none: it is then certified (a duplicate the collector merges) or proven empty.
        """
        cert = self.cert
        if not (cert.square and self.opt.certify):
            return None
        x = cert.newton(0.5 * (lo + hi), iters=25)
        if not np.all(np.isfinite(x)) or np.max(np.abs(cert.F(x)), initial=0.0) > 1e-10:
            return None
        d = self.opt.sigma
        if np.any(x < lo - d) or np.any(x > hi + d):
            return None
        vlo, vhi = np.minimum(lo, x), np.maximum(hi, x)
        pad = 1e-3 * (vhi - vlo) + 1e-12 * (1.0 + np.abs(x))
        vlo, vhi = vlo - pad, vhi + pad
        k = cert.krawczyk(vlo, vhi, x)
        if k.status == "unique":
            zlo, zhi = k.lo, k.hi
        elif self.krawczyk is not None:
            # the hull thinner than K's floor (a root of a near-double pair 1e-8 away, condition
            # 1e7): the contractor's epsilon-inflation tries a wider box around it, and returns
            # the enclosure of the one zero of its proof box
            c = self.krawczyk.contract(vlo, vhi)
            if c.status != "unique" or c.proof is None:
                return None
            (vlo, vhi), zlo, zhi = c.proof, c.lo, c.hi
        else:
            return None
        klo, khi = np.maximum(zlo, vlo), np.minimum(zhi, vhi)
        if np.any(khi < lo) or np.any(klo > hi):
            return BoxOutcome("empty")  # the hull's only zero lies outside the box
        return self._certified(vlo, vhi, klo, khi)

    def _accepted(self, lo, hi, root: np.ndarray | None = None) -> BoxOutcome:
        """A box below sigma that the search stops on. An approximate solution lies in it or
        near it; if that is a regular root just outside, a proof settles the box (empty, or a
        certified duplicate) instead of reporting it: a box accepted next to a near-singular
        assembly mode could hide its twin (as one did on Dietmeier's platform).

        Krawczyk on the box itself comes first: the box may have been narrowed since the
        contractors last ran on it (LP rounds, propagation), and a box 1e-7 beside a certified
        root of a near-double pair was reported as a singular root of its own, which the
        same test, run on the narrowed box, proves empty."""
        if self.krawczyk is not None:
            k = self.krawczyk.contract(lo, hi)
            if k.empty:
                return BoxOutcome("empty")
            if k.status == "unique" and k.proof is not None:
                return self._certified(k.proof[0], k.proof[1], k.lo, k.hi)
        return self._next_to_root(lo, hi) or self._uncertified(lo, hi, root)

    def _uncertified(self, lo, hi, root: np.ndarray | None = None) -> BoxOutcome:
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
        return BoxOutcome("solution", SolutionBox(lo, hi, x, False, res, (lo.copy(), hi.copy()), root))

    def _accept_small(self, lo, hi) -> tuple[bool, np.ndarray | None]:
        """Is a box narrower than sigma finished (returned as an uncertified solution box)?

        Not yet if it holds a regular-looking root (Krawczyk will decide it once smaller), nor
        if no approximate solution can be found in it at all (it is probably empty, like the
        "box traces" near singular configurations): such boxes are split down to
        ``sigma * resolve`` first. With the verdict, the root the box lies within the resolution
        of, if that is why it is finished (:meth:`_below_floor`).
        """
        w = np.max(hi - lo)
        if w > self.opt.sigma:
            return False, None
        if _looks_regular(self.cert, self.comp, lo, hi, max(self.opt.min_width, 1e-3 * self.opt.sigma * self.opt.resolve), self.opt.sigma):
            root = self._below_floor(lo, hi)
            return root is not None, root
        if w > self.opt.sigma * self.opt.resolve:
            x = self._near_point(lo, hi)
            if x is None:
                return False, None
            if self.cert.square and _regular_root(self.cert, x):
                # an isolated root next to the box or in it, not a curve through it: split until
                # Krawczyk settles it (a box holding a near-singular pair of roots, from whose
                # centre Newton stalls between them, was reported as one point)
                return False, None
        return True, None

    def _below_floor(self, lo, hi) -> np.ndarray | None:
        """Is the box, already below ``sigma * resolve``, narrower in every coordinate than four
        times the resolution of the core rows at its centre (the radius Krawczyk's operator has
        there even for a point box: the rounding of ``F(x0)`` and the rows' slack, the
        uncertainty of their coefficients, through ``|J^-1|``), and does it lie within that
        resolution, measured at the root, of the root Newton reaches from it? If it is merely
        narrower, no contractor can empty a
        sub-box, nor prove one to hold a unique root: any point of the box is a zero of the core
        rows moved within their slack. Between the two roots of a near-double pair (a UR5 1e-6
        from its elbow singularity: 2e-6 apart, ``|J^-1|`` 6e6, the slack's reach 5e-7) such
        boxes were split to 1e-10 by the tens of thousands, and the search never ended. The box
        is accepted instead: reported, never discarded (:meth:`_accepted` still tries to prove
        it empty or to settle it beside a regular root). Returns the root, or None (the box is
        split on)."""
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
        if not (np.all(np.isfinite(reach)) and np.all(hi - lo <= 4.0 * reach)):
            return None
        # and the box lies within the same resolution of the root Newton goes to from it, so
        # nothing in it can be told apart from that root; a box farther out, or right next to
        # the root (within its own width: Krawczyk's proofs there reach further than this
        # estimate), is split on
        x = cert.newton(x0, iters=25)
        if not np.all(np.isfinite(x)):
            return None
        try:
            Yx = np.linalg.inv(cert.J(x))
        except np.linalg.LinAlgError:
            return None
        gap = float(np.max(np.maximum(lo - x, x - hi)))
        return x if float(np.max(hi - lo)) < gap <= 4.0 * float(np.max(np.abs(Yx) @ cert.slack_core)) else None

    def _curve_through(self, lo, hi, j: int, glo, ghi) -> np.ndarray | None:
        """A box whose zeros all lie on one graph over the parameter ``x_j`` in the box
        ``[glo, ghi]`` (the transverse test proved it: for each ``x_j`` exactly one zero of
        ``Y F`` there): is that graph a piece of a curve of solutions? The zeros of ``F`` on the
        graph are the zeros of ``F(x_j, y(x_j))``, an analytic function of ``x_j``: either the
        whole graph or isolated points. The graph is taken for a curve when a corrector
        (Gauss-Newton on the other variables, ``x_j`` held) lands, at each of
        :data:`CURVE_SAMPLES` values of ``x_j`` across the box, inside ``[glo, ghi]`` on a point
        next to those the search keeps (every equation row within :data:`CURVE_SLACK` times its
        slack: :meth:`_on_curve`) where the
        Jacobian is singular to working precision (:data:`CURVE_RANK`), and at least one of those
        points lies in the box; then the box is finished (the answer stage's continuation follows
        the curve through it) instead of split down to sigma. Returns the point in the box
        nearest its middle, or None (the box is split as usual, so isolated roots stay
        resolved).

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
                if not (np.all(y >= glo) and np.all(y <= ghi) and self._on_curve(y)):
                    return None
                if np.all(y >= lo) and np.all(y <= hi):
                    d = float(np.max(np.abs(y - centre) / np.maximum(hi - lo, 1e-300)))
                    if d < dist:
                        best, dist = y.copy(), d
        return best

    def _on_curve(self, y: np.ndarray) -> bool:
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

    def _curve_box(self, lo, hi, x) -> BoxOutcome:
        res = float(np.max(np.abs(self.comp.eval_eqs(x)), initial=0.0))
        return BoxOutcome("solution", SolutionBox(lo, hi, x, False, res, (lo.copy(), hi.copy()), curve=True))

    def _near_point(self, lo, hi) -> np.ndarray | None:
        """An approximate solution in the box or within sigma of it, or None. Unclipped: a curve
        may leave the box where the iteration heads. The truncated step (:func:`set_newton`)
        reaches a curve from beside it, where a full step runs along it; it stalls where ``J``
        is ill-conditioned on the set itself (Bricard), where plain Gauss-Newton then does."""
        x0 = 0.5 * (lo + hi)
        for step in (set_newton, gauss_newton):
            x = step(self.comp, x0, iters=12)
            near = np.all(x >= lo - self.opt.sigma) and np.all(x <= hi + self.opt.sigma)
            if near and np.max(np.abs(self.comp.eval_eqs(x)), initial=0.0) <= RESOLVED:
                return x
        return None

    def process(self, lo: np.ndarray, hi: np.ndarray, hint: Hint | None = None, policy: Policy | None = None) -> BoxOutcome:
        """Process the box ``[lo, hi]`` (the root box when ``hint`` is None) under ``policy``."""
        check_floating_point()  # a library loaded since could have switched the mode
        hint = hint or Hint()
        policy = policy or Policy()
        opt, hc4, kraw, has_lp = self.opt, self.hc4, self.krawczyk, self.has_lp
        ev = Events()
        nl = 0
        basis = hint.basis
        box = (lo, hi)

        def out(o: BoxOutcome) -> BoxOutcome:
            if ev.lp_rounds == 0 and o.kind != "unfinished":
                ev.plain += 1
                ev.plain_closed += int(o.kind in ("empty", "solution"))
            o.krawczyk, o.lps, o.events = ev.k_tests, nl, ev
            return o

        if self.comp.n == 0:  # no unknown (every joint locked): the rows are constants
            if hc4.contract(lo, hi).empty:
                return out(BoxOutcome("empty"))
            res = float(np.max(np.abs(self.comp.eval_eqs(lo)), initial=0.0))
            return out(BoxOutcome("solution", SolutionBox(lo, hi, lo.copy(), False, res, (lo.copy(), hi.copy()))))
        wants_lp = has_lp and policy.wants_lp(hint)
        wants_k = kraw is not None and (not has_lp or policy.wants_krawczyk(hint))
        tv = self.transverse
        wants_t = tv is not None and policy.wants_transverse(hint)
        curve = False  # the transverse test narrowed the box around a curve piece
        for _ in range(opt.lp_rounds):
            c = hc4.contract(lo, hi)
            if c.empty:
                return out(BoxOutcome("empty"))
            lo, hi = c.lo, c.hi
            if kraw is not None and (wants_k or np.max(hi - lo) <= 2.0 * opt.sigma):
                # Krawczyk on every box while its tests pay, and always below twice sigma,
                # where isolated roots get certified; again on the box it narrowed (and
                # propagation after it), while that pays
                for rep in range(1 + K_REPEATS):
                    k = kraw.contract(lo, hi)
                    ev.k_tests += 1
                    k_paid = k.status in ("empty", "unique") or (
                        k.status == "narrowed" and self._logvol(lo, hi) - self._logvol(np.maximum(k.lo, lo), np.minimum(k.hi, hi)) >= 0.1
                    )
                    ev.k_paid += int(k_paid)
                    if rep == 0:
                        wants_t = wants_t and (policy.transverse_after_krawczyk or not k_paid)
                    if k.empty:
                        return out(BoxOutcome("empty"))
                    if k.status == "unique" and k.proof is not None:
                        return out(self._certified(k.proof[0], k.proof[1], k.lo, k.hi))
                    if k.status != "narrowed":
                        break
                    c = hc4.contract(np.maximum(k.lo, lo), np.minimum(k.hi, hi))
                    if c.empty:
                        return out(BoxOutcome("empty"))
                    lo, hi = c.lo, c.hi
                    if not k_paid:
                        break
            if tv is not None and wants_t:
                t = tv.contract(lo, hi, graph=opt.curve_boxes and bool(np.max(hi - lo) > opt.sigma))
                ev.t_tests += 1
                gain = math.inf if t.status == "empty" else self._logvol(lo, hi) - self._logvol(t.lo, t.hi)
                ev.t_paid += int(gain >= T_GAIN)
                curve = curve or gain >= T_GAIN
                if t.status == "empty":
                    return out(BoxOutcome("empty"))
                if t.status == "narrowed":
                    c = hc4.contract(t.lo, t.hi)
                    if c.empty:
                        return out(BoxOutcome("empty"))
                    lo, hi = c.lo, c.hi
                if t.graph_box is not None and t.params is not None and len(t.params) == 1:
                    x = self._curve_through(lo, hi, int(t.params[0]), *t.graph_box)
                    if x is not None:
                        ev.t_paid += int(gain < T_GAIN)  # a finished box pays
                        return out(self._curve_box(lo, hi, x))
            accept, root = self._accept_small(lo, hi)
            if accept:
                return out(self._accepted(lo, hi, root))
            if not wants_lp or (curve and not policy.wants_lp_on_curve(hint)):
                break
            if self.deadline is not None and time.perf_counter() > self.deadline:
                return out(BoxOutcome("unfinished", children=[(box[0], box[1], hint)]))
            v0 = self._logvol(lo, hi)
            lp = self.lp
            its0 = lp.relax.iterations
            s = lp.contract(lo, hi, c.mlo, c.mhi, basis)
            its = lp.relax.iterations - its0
            nl += s.work
            paid = policy.lp_paid(math.inf if s.empty else v0 - self._logvol(s.lo, s.hi), its)
            ev.lp_rounds += 1
            ev.lp_paid += int(paid)
            ev.lp_iterations += its
            ev.c_rounds += int(curve)
            ev.c_paid += int(curve and s.empty)
            if s.empty:
                return out(BoxOutcome("empty"))
            basis = lp.relax.basis()
            lo, hi = s.lo, s.hi
            if np.max(hi - lo) <= opt.sigma:
                continue  # back to the top: propagate, certify or accept
            if not paid or self._logvol(lo, hi) - v0 > math.log(opt.rho):
                break
        accept, root = self._accept_small(lo, hi)
        if accept:
            return out(self._accepted(lo, hi, root))
        if np.max(hi - lo) <= opt.sigma:
            o = self._next_to_root(lo, hi)
            if o is not None:
                return out(o)
        i = self._split_variable(lo, hi)
        cut = lo[i] + SPLIT_POINT * (hi[i] - lo[i])
        hi1 = hi.copy()
        hi1[i] = cut
        lo2 = lo.copy()
        lo2[i] = cut
        return out(BoxOutcome("split", children=[(lo2, hi, hint.child(0, basis)), (lo, hi1, hint.child(1, basis))]))


RELAXATIONS = ("auto", "linear", "bernstein", "none")


def lp_kind(options: SolverOptions, comp) -> str | None:
    """The relaxation the LP rounds of a search of ``comp`` use, or None: no LP rounds."""
    kind = options.relaxation
    if kind not in RELAXATIONS:
        raise InputError(f"relaxation must be one of {', '.join(RELAXATIONS)}, got {kind!r}")
    if not options.lp or kind == "none" or comp.n == 0:
        return None
    return kind


def lp_contractor(options: SolverOptions, comp, mask: np.ndarray, root_w: np.ndarray):
    """The LP contractor ``options.relaxation`` names (None: no LPs)."""
    kind = lp_kind(options, comp)
    if kind is None:
        return None
    comp = comp.for_lp()
    if kind in ("bernstein", "auto"):
        return BernsteinRelaxation(comp, mask, root_w)
    return LinearRelaxation(comp, mask, root_w)


class Collector:
    """Gathers outcomes: solution boxes (with de-duplication) and statistics.

    Two certified boxes hold the same solution when one's enclosure lies in the other's
    uniqueness box, or (a root on the face between two sibling boxes, certified in both) when
    Krawczyk proves a single zero in the small hull of both enclosures.
    """

    def __init__(self, certifier: Certifier | None = None):
        self.cert = certifier
        self.boxes: list[SolutionBox] = []
        self.stats: dict[str, Any] = dict(
            boxes=0, empty=0, split=0, solutions=0, certified=0, lps=0, krawczyk=0, seconds=0.0, cpu_seconds=0.0, max_pending=1
        )

    def add(self, o: BoxOutcome) -> None:
        st = self.stats
        st["boxes"] += 1
        st["lps"] += o.lps
        st["krawczyk"] += o.krawczyk
        if o.kind == "empty":
            st["empty"] += 1
        elif o.kind == "split":
            st["split"] += 1
        elif o.kind == "unfinished":
            st["boxes"] -= 1  # handed back: it will be processed (and counted) again
        elif o.solution is not None:
            self.record(o.solution)

    def record(self, sol: SolutionBox) -> None:
        if sol.certified:
            for o in self.boxes:
                if o.certified and self._same(sol, o):
                    return
        self.boxes.append(sol)
        self.stats["solutions"] += 1
        self.stats["certified"] += int(sol.certified)

    def _same(self, a: SolutionBox, b: SolutionBox) -> bool:
        if _inside(a.enclosure, (b.lo, b.hi)) or _inside(b.enclosure, (a.lo, a.hi)):
            return True  # a's root lies in b's uniqueness box: it is b's root
        if self.cert is None:
            return False
        hlo = np.minimum(a.enclosure[0], b.enclosure[0])
        hhi = np.maximum(a.enclosure[1], b.enclosure[1])
        if np.max(hhi - hlo) > 1e-6 * (1.0 + np.max(np.abs(hlo))):
            return False
        c = 0.5 * (hlo + hhi)
        r = np.maximum(hhi - hlo, 1e-12 * (1.0 + np.abs(c)))
        # both roots lie in [c - r, c + r]; a unique zero there makes them one
        return self.cert.krawczyk(c - r, c + r).status == "unique"


def make_options(options: SolverOptions | None = None, **kw) -> SolverOptions:
    """``options`` (default: the defaults) with the keyword arguments set, as a new object."""
    opt = options or SolverOptions()
    fields = {f.name for f in dataclasses.fields(SolverOptions)}
    for k in kw:
        if k not in fields:
            raise TypeError(f"unknown solver option {k!r}")
    opt = dataclasses.replace(opt, **kw)
    check_options(opt)
    if opt.relaxation not in RELAXATIONS:
        raise InputError(f"relaxation must be one of {', '.join(RELAXATIONS)}, got {opt.relaxation!r}")
    if opt.policy not in POLICIES:
        raise InputError(f"policy must be one of {', '.join(POLICIES)}, got {opt.policy!r}")
    return opt


_KERNELS_LOADED = False


def load_kernels() -> None:
    """Load (the first time after an install: compile and cache) every compiled kernel of the
    search; after the first call in a process, nothing."""
    global _KERNELS_LOADED
    if not _KERNELS_LOADED:
        for mod in (propagate, certify, relaxation, bernstein, transverse):
            mod.load_kernel()
        _KERNELS_LOADED = True


def check_floating_point() -> None:
    """Raise :class:`FloatingPointModeError` if subnormals are flushed to zero in this thread:
    every outward rounding of the search assumes IEEE gradual underflow."""
    mode = flushing_subnormals()
    if mode is not None:
        raise FloatingPointModeError(
            f"the processor runs with {mode} (set by a library built with -ffast-math?): interval bounds would not be sound"
        )


def _positive(v, integer: bool = False) -> bool:
    if isinstance(v, bool):
        return False
    if integer:
        return bool(isinstance(v, (int, np.integer)) and v >= 1)
    return bool(isinstance(v, (int, float, np.integer, np.floating)) and math.isfinite(v) and v > 0)


def check_options(opt: SolverOptions) -> None:
    """Raise :class:`~kinbox.errors.InputError` for an option out of its range: sizes and
    budgets are positive and finite (a budget of None: no budget)."""
    checks = [
        ("sigma", opt.sigma, False, False),
        ("rho", opt.rho, False, False),
        ("lp_rounds", opt.lp_rounds, True, False),
        ("min_width", opt.min_width, False, False),
        ("resolve", opt.resolve, False, False),
        ("max_boxes", opt.max_boxes, True, True),
        ("time_limit", opt.time_limit, False, True),
        ("max_memory", opt.max_memory, False, True),
    ]
    for name, v, integer, optional in checks:
        if optional and v is None:
            continue
        if not _positive(v, integer):
            what = "a positive integer" if integer else "a positive finite number"
            raise InputError(f"solver option {name} must be {what}{' or None' if optional else ''}, got {v!r}")
    if opt.rho > 1:
        raise InputError(f"solver option rho must be at most 1, got {opt.rho!r}")
    if opt.started is not None and not (isinstance(opt.started, (int, float)) and math.isfinite(opt.started)):
        raise InputError(f"solver option started must be a time.perf_counter() value, got {opt.started!r}")


def finish(
    system: System,
    col: Collector,
    complete: bool,
    message: str,
    state: SearchState | None,
    t0,
    c0,
    before: dict | None = None,
    load_seconds: float = 0.0,
) -> SolveResult:
    """The result of a search that ran from ``t0`` (``perf_counter``) / ``c0`` (``process_time``);
    ``before``: the stats of the run it resumed (its times are added). ``load_seconds``: the part
    of the search's seconds spent loading compiled kernels (:mod:`kinbox.search.loading`)."""
    st = col.stats
    before = before or {}
    st["seconds"] = time.perf_counter() - t0 + float(before.get("seconds", 0.0))
    st["load_seconds"] = load_seconds + float(before.get("load_seconds", 0.0))
    st["cpu_seconds"] = time.process_time() - c0 + float(before.get("cpu_seconds", 0.0))
    st.update(system.summary())
    if complete and not col.boxes:
        message = "search complete: no solution (proven)"
    if state is not None:
        state.stats = dict(st)
    return SolveResult(
        success=complete,
        complete=complete,
        message=message,
        boxes=col.boxes,
        pending=[] if complete or state is None else state.pending,
        stats=st,
        system=system,
        state=None if complete else state,
    )


#: estimated bytes of a box held by the search: per variable (two float64 bounds) and fixed
#: (two NumPy arrays, a tuple and a Hint); a solution box holds five arrays
BOX_BYTES_PER_VAR, BOX_BYTES = 16, 400
SOLUTION_BYTES_PER_VAR, SOLUTION_BYTES = 40, 800


def held_bytes(n: int, pending: int, solutions: int) -> float:
    """Estimated memory of ``pending`` boxes and ``solutions`` solution boxes of ``n`` variables."""
    return pending * (BOX_BYTES_PER_VAR * n + BOX_BYTES) + solutions * (SOLUTION_BYTES_PER_VAR * n + SOLUTION_BYTES)


def pending_state(system: System, state: SearchState, rest: list, nxt: list, policy: Policy, ev: Events, col: Collector) -> SearchState:
    """What is left of a search that stops (or pauses): the boxes not processed yet, the policy
    and its counters, the solutions so far, for :func:`finish` and ``--save``."""
    return SearchState(
        rest=rest,
        nxt=nxt,
        policy=policy,
        events=ev,
        boxes=col.boxes,
        stats={},
        fingerprint=state.fingerprint or fingerprint(system),
        options=state.options,
        names=state.names,
    )


def start_state(system: System, opt: SolverOptions, col: Collector, resume: SearchState | None, within: list | None = None) -> SearchState:
    """The state a search starts from: the root box (or the boxes ``within``), or ``resume``
    (checked against the system and the options, its solutions and counts put in ``col``)."""
    fp = fingerprint(system) if resume is not None else ""
    if resume is None:
        lo0, hi0 = system.search_domain()
        return SearchState(
            rest=[(lo0, hi0, Hint())] if within is None else [(lo, hi, Hint()) for lo, hi in within],
            nxt=[],
            policy=POLICIES[opt.policy],
            events=Events(),
            boxes=[],
            stats={},
            fingerprint=fp,
            options=tree_options(opt),
            names=list(system.names),
        )
    resume.check(system, opt)
    col.boxes = list(resume.boxes)
    for k, v in resume.stats.items():
        if k in col.stats or k == "waves":
            col.stats[k] = v
    return SearchState(
        rest=list(resume.rest),
        nxt=list(resume.nxt),
        policy=resume.policy,
        events=dataclasses.replace(resume.events),
        boxes=[],
        stats={},
        fingerprint=fp,
        options=tree_options(opt),
        names=list(system.names),
    )


@single_threaded
def solve_system(
    system: System, options: SolverOptions | None = None, *, resume: SearchState | None = None, within: list | None = None, **kw
) -> SolveResult:
    """Enclose every solution of ``system`` in its domain, in this process. Keyword arguments
    set options. (:func:`kinbox.solve_system` also spreads the search over workers.)

    The search runs in waves: the boxes of one wave (the children of the previous one, in
    order) are processed under one :class:`~kinbox.search.policy.Policy`, and the next wave's
    policy is made from the wave's counts, so the tree does not depend on the order in which a
    wave's boxes are processed (:mod:`kinbox.search.parallel` processes them in parallel).

    A search stopped by a budget or by :func:`kinbox.search.interrupt.request` returns its
    :class:`~kinbox.search.state.SearchState` in ``state``; ``resume=state`` goes on from there
    and ends as the search would have ended had it not stopped. ``within``: boxes ``(lo, hi)``
    of the search domain to search instead of the whole domain (:func:`search_again`).
    """
    opt = make_options(options, **kw)
    c0 = time.process_time()
    t0 = time.perf_counter()
    clock = opt.started if opt.started is not None else t0
    # loading the compiled kernels (at their first call in this process) is reported apart
    with load_clock() as loads:
        proc = BoxProcessor(system, opt)
        if opt.time_limit is not None:
            proc.set_deadline(clock + opt.time_limit)
        col = Collector(proc.cert)
        state = start_state(system, opt, col, resume, within)
        before = dict(col.stats) if resume is not None else {}
        boxes0 = col.stats["boxes"]
        show = opt.progress if opt.progress is not None else sys.stderr.isatty()
        progress = Progress(bool(show), proc.root_w)
        message, complete = "search complete", True
        wave, k, nxt, ev, policy = state.rest, 0, state.nxt, state.events, state.policy
        n = system.n
        with interrupt.searching():
            while True:
                if k == len(wave):  # the wave is done: the next one, under a policy made from its counts
                    col.stats["waves"] = col.stats.get("waves", 0) + 1
                    policy = policy.next(ev)
                    wave, k, nxt, ev = nxt, 0, [], Events()
                    if not wave:
                        break
                    col.stats["max_pending"] = max(col.stats["max_pending"], len(wave))
                stop = budget_hit(opt, col.stats["boxes"] - boxes0, clock, held_bytes(n, len(wave) - k + len(nxt), len(col.boxes)))
                if stop:
                    complete, message = False, stop
                    break
                lo, hi, hint = wave[k]
                o = proc.process(lo, hi, hint, policy)
                if o.kind == "unfinished":  # the time limit passed inside the box: it stays pending
                    complete, message = False, f"time limit of {opt.time_limit:g} s reached"
                    break
                col.add(o)
                ev.add(o.events)
                nxt.extend(o.children)
                k += 1
                progress.report(col.stats, wave, k, nxt)
        progress.report(col.stats, wave, k, nxt, force=True)
        state = pending_state(system, state, wave[k:], nxt, policy, ev, col)
    return finish(system, col, complete, message, state, t0, c0, before, loads.seconds)


def search_again(system: System, raw: SolveResult, redo: list[int], options: SolverOptions) -> SolveResult:
    """``raw`` (a complete search) with its solution boxes ``redo`` searched again without curve
    boxes: the answer stage found no curve through those curve boxes (their points are isolated
    or singular roots, or lie on nothing), so what they hold is resolved like any other box,
    down to certified roots and boxes below sigma. The union of the boxes returned still
    encloses every solution: the boxes searched again are replaced by what their search
    returns. Certified boxes found twice (a root on a face of a curve box) are merged as in a
    search. The budgets are those of ``options`` (the time limit counts from the same start);
    a search again that stops leaves the answer incomplete, with no state to resume."""
    opt = dataclasses.replace(options, curve_boxes=False)
    sub = solve_system(system, opt, within=[(raw.boxes[i].lo, raw.boxes[i].hi) for i in redo])
    col = Collector(Certifier(system.compile()))
    gone = set(redo)
    for i, b in enumerate(raw.boxes):
        if i not in gone:
            col.record(b)
    for b in sub.boxes:
        col.record(b)
    st = dict(raw.stats)
    for k in ("boxes", "empty", "split", "lps", "krawczyk", "seconds", "cpu_seconds", "load_seconds"):
        st[k] = st.get(k, 0) + sub.stats[k]
    st["solutions"], st["certified"] = col.stats["solutions"], col.stats["certified"]
    st["curve_boxes_searched_again"] = st.get("curve_boxes_searched_again", 0) + len(redo)
    complete = raw.complete and sub.complete
    message = raw.message if sub.complete else f"{sub.message} (searching curve boxes again)"
    return SolveResult(complete, complete, message, col.boxes, list(raw.pending) + list(sub.pending), st, system, raw.state)


def budget_hit(opt: SolverOptions, boxes: int, clock: float, held: float = 0.0) -> str | None:
    """Why the search must stop now, or None: a stop request (:mod:`kinbox.search.interrupt`) or a
    budget spent (``boxes`` processed in this run, time since ``clock``, ``held`` bytes)."""
    why = interrupt.requested()
    if why is not None:
        return why
    if opt.max_boxes is not None and boxes >= opt.max_boxes:
        return f"box budget of {opt.max_boxes} reached"
    if opt.time_limit is not None and time.perf_counter() - clock > opt.time_limit:
        return f"time limit of {opt.time_limit:g} s reached"
    if opt.max_memory is not None and held > opt.max_memory:
        return f"memory budget of {opt.max_memory / 1e9:g} GB for boxes reached"
    return None


def _looks_regular(cert: Certifier, comp, lo, hi, min_width: float, near: float = 0.0) -> bool:
    """True if Newton from the box centre converges to a well-conditioned root in the box or
    within the box's width (or ``near``) of it (a root next to the box: the box is then split
    until it is settled by :meth:`BoxProcessor._next_to_root`, or pruned).

    Newton may run off to a regular root outside the box while the box holds one of its own (a
    near-double root's twin): then Newton kept inside the box is tried too.
    """
    if not cert.square or np.max(hi - lo) <= min_width:
        return False
    w = max(float(np.max(hi - lo)), near)
    x = cert.newton(0.5 * (lo + hi), iters=25)  # near-double roots converge slowly
    if _regular_root(cert, x) and not (np.any(x < lo - w) or np.any(x > hi + w)):
        return True
    x = cert.newton(0.5 * (lo + hi), lo, hi, iters=25)
    return _regular_root(cert, x)


def _regular_root(cert: Certifier, x) -> bool:
    """Is ``x`` (a Newton iterate) next to a regular root? Proven, not guessed from a
    condition number: a small residual and a moderate condition number also hold a little
    off a double root, where no root is, and boxes there were split down to the minimum width.

    ``x`` is polished by Newton first: an iterate stopped at a residual of 1e-9 can lie 1e-7
    from a root of condition 1e2..1e5, outside the small box the proof is tried on, and a box
    was then accepted as a singular cluster beside a regular root it did not hold, while a
    regular root of its own (Newton from its centre did not converge) went unreported."""
    if not np.all(np.isfinite(x)):
        return False
    x = cert.newton(x, iters=6)  # quadratic near a regular root; harmless elsewhere
    if not np.all(np.isfinite(x)) or np.max(np.abs(cert.F(x)), initial=0.0) > 1e-10:
        return False
    r = 1e-8 * (1.0 + np.abs(x))
    return cert.krawczyk(x - r, x + r, x).status == "unique"


def _inside(inner, outer) -> bool:
    return bool(np.all(inner[0] >= outer[0]) and np.all(inner[1] <= outer[1]))
