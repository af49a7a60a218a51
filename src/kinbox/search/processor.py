"""Processing one box: the per-box sequence of :mod:`kinbox.search.steps`, then acceptance
(:mod:`kinbox.search.accept`) or bisection (:mod:`kinbox.search.bisector`)."""

from __future__ import annotations

import math
import time

import numpy as np

from ..errors import FloatingPointModeError, InputError
from ..formulation.system import System
from ..interval import flushing_subnormals
from .accept import Acceptance
from .bisector import Bisector
from .certify import Certifier
from .contract import Box, Context, Contraction, Contractor, ContractStatus, Step
from .ctc_bernstein import CtcBernstein
from .ctc_krawczyk import CtcKrawczyk
from .ctc_linear import LP_VAR_PAYS, CtcLinear, CtcLP
from .ctc_propagation import CtcPropagation
from .curvebox import CurveBoxRule
from .options import RELAXATIONS, SolverOptions
from .policy import LP, LP_ON_CURVE, Events, Hint, Policy
from .results import BoxOutcome, SolutionBox
from .status import BoxStatus
from .steps import steps


def _lp_built_apart(proc) -> None:
    return None


#: the LP round that ends a round of the sequence (:mod:`kinbox.search.steps`): it pays by the
#: log-volume it removes per box of work (:meth:`~kinbox.search.policy.Policy.lp_paid`); on a
#: box around a piece of a curve it also passes :data:`~kinbox.search.policy.LP_ON_CURVE`. Its
#: contractor is :attr:`BoxProcessor.lp`, built at the first LP round.
LP_STEP = Step("lp", _lp_built_apart, LP, 0.0)
LP_CURVE_GATE = LP_ON_CURVE


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
        self.exclude = system.exclude  # boxes holding no wanted solution (None: none)
        # the domain widened by the slack of derived rows: a root on a bound (an angle of 0, a
        # rotation entry of 1, a joint at its limit) is inside it, however its proof box lies
        self.lo0, self.hi0 = system.search_domain()
        self.root_w = np.maximum(self.hi0 - self.lo0, 1e-300)
        self.split_mask = system.independent()
        self.ranks = system.split_ranks()
        self.cert = Certifier(comp)
        self.hc4 = CtcPropagation(comp)
        self.krawczyk: CtcKrawczyk | None = CtcKrawczyk(self.cert) if self.cert.square and options.certify else None
        # built at the first LP round: most IK poses have none, and a relaxation's model and
        # HiGHS instance cost a few percent of such a pose
        self.has_lp = lp_kind(options, comp) is not None
        self._lp: CtcLP | None = None
        self.deadline: float | None = None
        self.bisector = Bisector(self.cert, self.root_w, self.split_mask, self.ranks, options.bisection)
        self.accept = Acceptance(comp, self.cert, self.hc4.prop, self.krawczyk, self.lo0, self.hi0, options)
        self.curves = CurveBoxRule(comp)
        # the steps of the sequence this search runs (:mod:`kinbox.search.steps`) and their
        # contractors, built once per system (None: the step is skipped)
        extra = set(filter(None, options.extra_steps.split(",")))
        self.steps: tuple[Step, ...] = tuple(s for s in steps() if not s.optional or s.name in extra)
        self.ctc: dict[str, Contractor | None] = {s.name: s.build(self) for s in self.steps}

    @property
    def prop(self):
        """The interval propagator (evaluations of rows over boxes)."""
        return self.hc4.prop

    @property
    def lp(self) -> CtcLP | None:
        """The LP contractor (None: no LPs), built when first asked for."""
        if self._lp is None and self.has_lp:
            self._lp = lp_contractor(self.opt, self.comp, self.split_mask, self.root_w)
            if self._lp is not None:
                self._lp.deadline = self.deadline
        return self._lp

    def set_deadline(self, deadline: float | None) -> None:
        """Stop inside a box (between LPs) once ``time.perf_counter()`` passes ``deadline``."""
        self.deadline = deadline
        if self._lp is not None:
            self._lp.deadline = deadline

    def _logvol(self, lo, hi):
        return float(np.sum(np.log(np.maximum((hi - lo) / self.root_w, 1e-30))))

    def _propagate(self, lo, hi, ctx: Context) -> Contraction:
        c = self.hc4.contract(Box(lo, hi), ctx)
        ctx.mlo, ctx.mhi = c.mlo, c.mhi
        return c

    def process(self, lo: np.ndarray, hi: np.ndarray, hint: Hint | None = None, policy: Policy | None = None) -> BoxOutcome:
        """Process the box ``[lo, hi]`` (the root box when ``hint`` is None) under ``policy``."""
        check_floating_point()  # a library loaded since could have switched the mode
        hint = hint or Hint()
        policy = policy or Policy()
        ev = Events()
        work = [0]  # LPs solved

        def out(o: BoxOutcome) -> BoxOutcome:
            if ev.tests.get(LP_STEP.gate.name, 0) == 0 and o.kind != "unfinished":
                ev.plain += 1
                ev.plain_closed += int(o.kind in ("empty", "solution"))
            o.krawczyk, o.lps, o.events = ev.tests.get("krawczyk", 0), work[0], ev
            return o

        if self.comp.n == 0:  # no unknown (every joint locked): the rows are constants
            if self.hc4.contract(Box(lo, hi)).empty:
                return out(BoxOutcome("empty"))
            res = float(np.max(np.abs(self.comp.eval_eqs(lo)), initial=0.0))
            return out(BoxOutcome("solution", SolutionBox(lo, hi, lo.copy(), BoxStatus.UNCERTIFIED, res, (lo.copy(), hi.copy()))))
        return out(self._rounds(lo, hi, hint, policy, ev, work))

    def _gates(self, hint: Hint, policy: Policy) -> dict[str, bool]:
        """Which steps the box's gates let run (decided once per box, from the policy)."""
        opened = {}
        for step in (*self.steps, LP_STEP):
            ctc = self.has_lp if step is LP_STEP else self.ctc[step.name] is not None
            ungated = step.without_lp and not self.has_lp
            opened[step.name] = bool(ctc) and (ungated or policy.opens(step.gate, hint))
        return opened

    def _rounds(self, lo, hi, hint: Hint, policy: Policy, ev: Events, work: list) -> BoxOutcome:
        """The rounds of :mod:`kinbox.search.steps` on one box, then acceptance or a split."""
        opt = self.opt
        box0 = (lo, hi)
        ctx = Context(basis=hint.basis)
        opened = self._gates(hint, policy)
        curve = False  # a step narrowed the box around a curve piece
        exclude = self.exclude
        for _ in range(opt.lp_rounds):
            c = self._propagate(lo, hi, ctx)
            if c.empty:
                return BoxOutcome("empty")
            lo, hi = c.lo, c.hi
            if exclude is not None and exclude(lo, hi):
                return BoxOutcome("empty")  # no configuration of the box is wanted (System.exclude)
            exclude = None  # once per box, after its first propagation
            for step in self.steps:
                if not (opened[step.name] or self._below(step, lo, hi)):
                    continue
                done, lo, hi, paid = self._step(step, lo, hi, ctx, ev, policy, opened)
                curve = curve or paid
                if done is not None:
                    return done
            accept, root = self.accept.accept_small(lo, hi)
            if accept:
                return self.accept.accepted(lo, hi, root)
            if not opened[LP_STEP.name] or (curve and not policy.opens(LP_CURVE_GATE, hint)):
                break
            if self.deadline is not None and time.perf_counter() > self.deadline:
                return BoxOutcome("unfinished", children=[(box0[0], box0[1], hint)])
            v0 = self._logvol(lo, hi)
            lp = self.lp
            assert lp is not None
            s = lp.contract(Box(lo, hi), ctx)
            work[0] += s.work
            paid = policy.lp_paid(math.inf if s.empty else v0 - self._logvol(s.lo, s.hi), s.iterations)
            ev.count(LP_STEP.gate.name, paid)
            ev.lp_iterations += s.iterations
            if curve:
                ev.count(LP_CURVE_GATE.name, s.empty)
            if s.empty:
                return BoxOutcome("empty")
            ctx.basis = s.basis
            lo, hi = s.lo, s.hi
            if np.max(hi - lo) <= opt.sigma:
                continue  # back to the top: propagate, certify or accept
            if not paid or self._logvol(lo, hi) - v0 > math.log(opt.rho):
                break
        accept, root = self.accept.accept_small(lo, hi)
        if accept:
            return self.accept.accepted(lo, hi, root)
        if np.max(hi - lo) <= opt.sigma:
            o = self.accept.next_to_root(lo, hi)
            if o is not None:
                return o
        return BoxOutcome("split", children=self.bisector.split(lo, hi, hint, ctx.basis))

    def _below(self, step: Step, lo, hi) -> bool:
        """Does ``step`` run on the box, gate closed, because the box is narrow?"""
        if not step.always_below or self.ctc[step.name] is None:
            return False
        return bool(np.max(hi - lo) <= step.always_below * self.opt.sigma)

    def _step(self, step: Step, lo, hi, ctx: Context, ev: Events, policy: Policy, opened: dict):
        """Run ``step`` on the box (again on the box it narrowed, while it pays, at most
        ``step.repeats`` more times). Returns ``(outcome or None, lo, hi, curve)``: an outcome
        finishes the box; ``curve``: a test of a curve step paid."""
        ctc = self.ctc[step.name]
        assert ctc is not None
        curve = False
        for rep in range(1 + step.repeats):
            ctx.graph = step.curve and self.opt.curve_boxes and bool(np.max(hi - lo) > self.opt.sigma)
            r = ctc.contract(Box(lo, hi), ctx)
            if r.status is ContractStatus.NARROWED:
                nlo, nhi = np.maximum(r.lo, lo), np.minimum(r.hi, hi)
                gain = self._logvol(lo, hi) - self._logvol(nlo, nhi)
            else:  # nothing learnt removes nothing; a box proven empty or unique pays
                gain = 0.0 if r.status is ContractStatus.NONE else math.inf
            paid = gain >= step.gain
            ev.count(step.gate.name, paid)
            if rep == 0:
                for other in self.steps:  # a step this one closes once its first test paid
                    if other.not_after == step.name and paid and not policy.runs_after_paid(other.name, step.name):
                        opened[other.name] = False
            curve = curve or (step.curve and paid)
            if r.empty:
                return BoxOutcome("empty"), lo, hi, curve
            if r.status is ContractStatus.UNIQUE and r.proof is not None:
                return self.accept.certified(r.proof[0], r.proof[1], r.lo, r.hi), lo, hi, curve
            if r.status is ContractStatus.NARROWED:
                c = self._propagate(nlo, nhi, ctx)
                if c.empty:
                    return BoxOutcome("empty"), lo, hi, curve
                lo, hi = c.lo, c.hi
            if step.curve and r.graph_box is not None and r.params is not None and len(r.params) == 1:
                x = self.curves.through(lo, hi, int(r.params[0]), *r.graph_box)
                if x is not None:
                    if not paid:  # a finished box pays
                        ev.paid[step.gate.name] += 1
                    return self.curves.box(lo, hi, x), lo, hi, curve
            if r.status is not ContractStatus.NARROWED or not paid:
                break
        return None, lo, hi, curve


def lp_kind(options: SolverOptions, comp) -> str | None:
    """The relaxation the LP rounds of a search of ``comp`` use, or None: no LP rounds."""
    kind = options.relaxation
    if kind not in RELAXATIONS:
        raise InputError(f"relaxation must be one of {', '.join(RELAXATIONS)}, got {kind!r}")
    if not options.lp or kind == "none" or comp.n == 0:
        return None
    return kind


def lp_contractor(options: SolverOptions, comp, mask: np.ndarray, root_w: np.ndarray) -> CtcLP | None:
    """The LP contractor ``options.relaxation`` names (None: no LPs)."""
    kind = lp_kind(options, comp)
    if kind is None:
        return None
    comp = comp.for_lp()
    pay = 0.0 if options.lp_sweep else LP_VAR_PAYS  # a sweep bounds every variable each round
    if kind in ("bernstein", "auto"):
        return CtcBernstein(comp, mask, root_w, pay)
    return CtcLinear(comp, mask, root_w, pay)


def check_floating_point() -> None:
    """Raise :class:`FloatingPointModeError` if subnormals are flushed to zero in this thread:
    every outward rounding of the search assumes IEEE gradual underflow."""
    mode = flushing_subnormals()
    if mode is not None:
        raise FloatingPointModeError(
            f"the processor runs with {mode} (set by a library built with -ffast-math?): interval bounds would not be sound"
        )
