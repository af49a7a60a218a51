"""Which contractor a box gets: decisions from counters, the same on every run.

Interval propagation is cheap and runs on every box; an LP round costs as much as several
boxes, and Krawczyk pays only near isolated roots. Whether they are worth it is learnt as the
search goes, from **counts** of the rounds and tests that paid, never from a clock.

The search runs in **waves** (:mod:`kinbox.search.solver`): every box of a wave is processed
with the same :class:`Policy`, and the policy for the next wave is made from the wave's counts
(sums, which do not depend on the order the boxes were processed in, or on which process
processed them). So the tree, its counts and its answer are the same on every run, in one
process or spread over many, whatever the machine's load.

Where the policy says "not worth it", a box is still probed now and then, to notice when the
contractor starts paying again. Which boxes probe is decided by a hash of their place in the
tree (:func:`child_id`), so probes are spread evenly over the tree and are the same on every run.
Probes are rarer when an LP round costs more boxes and after a wave of probes that did not
pay, except while the boxes without LPs are hardly ever closed (:data:`CLOSE_LOW`): the tree
then doubles with every wave, LPs that did not pay on the large boxes of the first waves may
pay a few waves later, and rare probes learnt that too late (a random general 6R arm grew to
1,700 boxes in one wave before its LPs were turned on; ``benchmarks/arm_classes.py``).
tests/search/test_policy.py checks each rule on counted waves.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields, replace

from . import steps
from .contract import Gate

#: LP rounds run while at least this share of the recent ones paid...
LP_RATE = 0.5
#: ...and on one box in this many otherwise (or more, when an LP round costs more boxes, and
#: twice as rare after a wave of probes that did not pay)
LP_PROBE = 8
#: an LP round pays if it proves the box empty or removes this much log-volume per box of work
#: it costs
LP_GAIN = 0.05
#: the work of one LP round in boxes: simplex iterations counted (deterministic) over this many
#: per box, since an iteration costs a few hundredths of a millisecond and a box a few tenths
ITERATIONS_PER_BOX = 10.0
#: while fewer than this share of the boxes without LPs are closed, the tree grows by nearly
#: a factor of 2 per wave whatever else is done: LPs are probed on one box in LP_PROBE then
CLOSE_LOW = 0.25
#: the weight, in LP rounds, of the quick start's prior "LP rounds do not pay" against the
#: first measured ones: one paid probe leaves the rate at 1/3, two paid of two turn LPs on.
#: Lighter, a UR-like arm turned LPs on after a lucky probe and spent more on them than the
#: boxes they saved; heavier, general 6R arms, whose LPs do pay, waited too long for them
#: (benchmarks/arm_classes.py; tests/search/test_policy.py, first LP rounds replace the priors)
RATE_PRIOR = 2.0
#: Krawczyk runs on every box while this share of the recent tests paid (else on probes)
K_RATE = 0.15
K_PROBE = 8
#: the transverse Krawczyk test (:mod:`kinbox.search.transverse`) runs on every box while this
#: share of the recent tests paid (else on probes); a test pays if it proves the box empty or
#: removes :data:`T_GAIN` of log-volume
T_RATE = 0.15
T_PROBE = 8
T_GAIN = 0.5
#: LP rounds on a box whose transverse test paid (a box around a piece of a curve) run while
#: this share of the recent such rounds proved their box empty, else on probes. Across the
#: curve the test has done an LP round's work already, and along it nothing can be cut while
#: the curve runs through the box, so such a round pays only by showing the curve is not there.
#: Skipping them took the four-bar from 1229 to 2361 boxes but 1.41 to 0.98 s, Bricard from
#: 27 to 21 s (benchmarks/mobile.py; tests/search/test_policy.py, LP rounds on curve pieces)
C_RATE = 0.25
C_PROBE = 8
#: weight of one event in a running share (events of a wave count as that many events)
DECAY = 0.1

_MASK = (1 << 64) - 1


def child_id(parent: int, j: int) -> int:
    """A 64-bit identifier of child ``j`` of box ``parent`` (splitmix64 of the two): the same on
    every run, and spread evenly, so ``id % k == k - 1`` picks one box in ``k`` anywhere."""
    z = (parent * 0x9E3779B97F4A7C15 + j + 1) & _MASK
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & _MASK
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & _MASK
    return z ^ (z >> 31)


@dataclass(frozen=True, slots=True, eq=False)
class Hint:
    """What a box inherits from its parent: its identifier in the tree and the LP basis its
    nearest ancestor with LPs ended on (a warm start, picklable)."""

    id: int = 0
    basis: tuple | None = None

    def child(self, j: int, basis: tuple | None = None) -> Hint:
        return Hint(child_id(self.id, j), basis if basis is not None else self.basis)


#: LP rounds: off at the start (the root's round is a probe: most IK poses need ~100 boxes,
#: which cold LPs would dominate), probed at a spacing that follows their cost
LP = Gate("lp", LP_RATE, LP_PROBE, 0, start=0.0, adaptive=True, prior=RATE_PRIOR)
#: Krawczyk: on at the start
KRAWCZYK = Gate("krawczyk", K_RATE, K_PROBE, 0, start=1.0)
#: the transverse test: off at the start (on isolated roots, most IK poses, the square test
#: settles the boxes); probes on other boxes than Krawczyk's
TRANSVERSE = Gate("transverse", T_RATE, T_PROBE, 16, start=0.0)
#: LP rounds on a box the transverse test narrowed around a curve piece: on until they are seen
#: not to pay (a round pays there only by proving the box empty)
LP_ON_CURVE = Gate("lp_on_curve", C_RATE, C_PROBE, 32, start=1.0)
GATES = (LP, KRAWCZYK, TRANSVERSE, LP_ON_CURVE)
#: every gate by name: :data:`GATES` and those a contractor's module adds (:func:`register_gate`)
_REGISTERED: dict[str, Gate] = {g.name: g for g in GATES}


def register_gate(gate: Gate) -> Gate:
    """Make ``gate`` known to every :class:`Policy` (its rate starts at ``gate.start`` and is
    learnt from the counts of its tests like the others'); returns it."""
    old = _REGISTERED.get(gate.name)
    if old is not None and old != gate:
        raise ValueError(f"another gate is named {gate.name!r}")
    _REGISTERED[gate.name] = gate
    return gate


def gates() -> tuple[Gate, ...]:
    """Every gate a policy keeps a rate for: those of every step of the sequence (their modules
    loaded first), so a process that only gathers the counts of its workers learns the same
    rates as one that processed the boxes itself (``tests/search/test_ctc_shave.py``)."""
    steps.steps()
    return tuple(_REGISTERED.values())


def _start_rates() -> dict[str, float]:
    # the gates of this module; a rate missing is its gate's start (:meth:`Policy.rate`), and
    # :meth:`Policy.next` adds the rates of the gates registered since
    return {g.name: g.start for g in GATES}


@dataclass
class Events:
    """Counts of one wave (or one box): summed, so the order of the boxes does not matter.
    ``tests`` and ``paid``: per gate name, the tests run and those that paid."""

    tests: dict[str, int] = field(default_factory=dict)
    paid: dict[str, int] = field(default_factory=dict)
    #: simplex iterations of the LP rounds (their cost)
    lp_iterations: int = 0
    #: boxes processed without an LP round, and how many of them were closed (proven empty or
    #: settled as a solution) rather than split
    plain: int = 0
    plain_closed: int = 0

    def count(self, name: str, paid: bool) -> None:
        """One test of gate ``name``, which paid or not."""
        self.tests[name] = self.tests.get(name, 0) + 1
        self.paid[name] = self.paid.get(name, 0) + int(paid)

    def add(self, other: Events) -> None:
        for mine, theirs in ((self.tests, other.tests), (self.paid, other.paid)):
            for k, v in theirs.items():
                mine[k] = mine.get(k, 0) + v
        self.lp_iterations += other.lp_iterations
        self.plain += other.plain
        self.plain_closed += other.plain_closed

    @classmethod
    def from_dict(cls, d: dict) -> Events:
        """Events saved by :func:`dataclasses.asdict` (or, from states saved before the gates were
        one rule, by their counters per contractor)."""
        d = dict(d)
        tests, paid = dict(d.pop("tests", {})), dict(d.pop("paid", {}))
        for old, name in _LEGACY_COUNTS:
            if f"{old}_tests" in d or f"{old}_rounds" in d:
                tests[name] = int(d.pop(f"{old}_tests", d.pop(f"{old}_rounds", 0)))
                paid[name] = int(d.pop(f"{old}_paid", 0))
        known = {f.name for f in fields(cls)}
        return cls(tests=tests, paid=paid, **{k: v for k, v in d.items() if k in known})


#: the per-contractor counters and rates of states saved before the gates were one rule
_LEGACY_COUNTS = (("lp", "lp"), ("k", "krawczyk"), ("t", "transverse"), ("c", "lp_on_curve"))


def _ema(value: float, count: int, total: float, seen: int | None = None, prior: float = 1.0) -> float:
    """A running mean of weight :data:`DECAY` per event after ``count`` more events summing to
    ``total`` (the wave's events taken at their mean). With ``seen``, the number of events
    before these, the starting value weighs as ``prior`` events only: the first measurements
    replace a prior instead of nudging it."""
    if count == 0:
        return value
    keep = (1.0 - DECAY) ** count
    if seen is not None:
        keep = min(keep, (seen + prior) / (seen + prior + count))
    return keep * value + (1.0 - keep) * total / count


@dataclass(frozen=True)
class Policy:
    """The decisions of one wave: for each gate (:func:`gates`) the share of its recent tests
    that paid (``rates``), and the LP rounds' cost model."""

    rates: dict[str, float] = field(default_factory=_start_rates)
    lp_misses: int = 0
    #: simplex iterations per LP round, running mean (the cost of a round)
    lp_iterations: float = 50.0
    #: LP rounds so far
    lp_seen: int = 0
    #: the first LP rounds replace the priors of the LP rate and ``lp_iterations`` instead of
    #: nudging them (:data:`QUICK`)
    quick: bool = False
    #: share of the boxes without an LP round that were closed, running mean
    close_rate: float = 1.0
    #: the transverse test also runs on a box whose Krawczyk test has just paid. Off in the
    #: quick start (IK): there such a box lies by an isolated root, where the transverse test
    #: only repeats Krawczyk's narrowing and then looks for a curve that is not there. On
    #: elsewhere: on Bricard's curve the test after a paying Krawczyk is what finishes its curve
    #: boxes (benchmarks/mobile.py; tests/search/test_policy.py, the quick start skips the transverse test)
    transverse_after_krawczyk: bool = True

    def __hash__(self) -> int:
        return hash((tuple(sorted(self.rates.items())), self.lp_misses, self.lp_iterations, self.lp_seen, self.quick, self.close_rate))

    def with_rates(self, **rates: float) -> Policy:
        """This policy with the rates of the gates named set."""
        for k in rates:
            if k not in _REGISTERED:
                raise KeyError(f"no gate named {k!r}")
        return replace(self, rates={**self.rates, **rates})

    def rate(self, gate: Gate) -> float:
        """The share of the recent tests of ``gate`` that paid (its start before any, also for a
        gate registered after this policy was made)."""
        return self.rates.get(gate.name, gate.start)

    @property
    def lp_cost(self) -> float:
        """An LP round's work, in boxes."""
        return max(1.0, self.lp_iterations / ITERATIONS_PER_BOX)

    def probe_every(self, gate: Gate) -> int:
        """One box in how many probes ``gate`` while it is closed. An adaptive gate (LP rounds)
        probes rarer when a round costs more boxes and twice as rarely after a wave of probes
        that did not pay, except while the boxes without LPs are hardly ever closed."""
        if not gate.adaptive or self.close_rate < CLOSE_LOW:
            return gate.probe
        return max(gate.probe, int(2 * self.lp_cost)) << min(self.lp_misses, 1)

    def opens(self, gate: Gate, hint: Hint) -> bool:
        """Does the box of ``hint`` pass ``gate``? (The one rule every gate follows.)"""
        if self.rate(gate) >= gate.rate:
            return True
        every = self.probe_every(gate)
        return (hint.id >> gate.bits) % every == every - 1

    def lp_paid(self, gain: float, iterations: int) -> bool:
        """Did an LP round that removed ``gain`` of log-volume (inf: proved the box empty) in
        ``iterations`` simplex iterations pay for itself?"""
        cost = max(1.0, iterations / ITERATIONS_PER_BOX)
        return gain >= LP_GAIN * cost

    def runs_after_paid(self, step: str, before: str) -> bool:
        """Does step ``step`` run on a box whose first test of step ``before`` has just paid?"""
        return self.transverse_after_krawczyk or (step, before) != ("transverse", "krawczyk")

    def next(self, ev: Events) -> Policy:
        """The policy of the next wave, after a wave with events ``ev``."""
        rounds = ev.tests.get(LP.name, 0)
        misses = self.lp_misses
        if rounds:
            misses = 0 if ev.paid.get(LP.name, 0) else misses + 1
        seen = self.lp_seen if self.quick else None
        rates = {
            g.name: _ema(
                self.rate(g),
                ev.tests.get(g.name, 0),
                ev.paid.get(g.name, 0),
                seen if g.prior is not None else None,
                g.prior if g.prior is not None else 1.0,
            )
            for g in gates()
        }
        return replace(
            self,
            rates=rates,
            lp_misses=misses,
            lp_iterations=_ema(self.lp_iterations, rounds, ev.lp_iterations, seen),
            lp_seen=self.lp_seen + rounds,
            close_rate=_ema(self.close_rate, ev.plain, ev.plain_closed),
        )

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> Policy:
        """A policy saved by :meth:`to_dict` (or, from states saved before the gates were one
        rule, with a rate field per contractor; fields since removed are left out)."""
        d = dict(d)
        rates = _start_rates()
        rates.update({k: float(v) for k, v in dict(d.pop("rates", {})).items()})
        for old, name in _LEGACY_COUNTS:
            if f"{old}_rate" in d:
                rates[name] = float(d.pop(f"{old}_rate"))
        known = {f.name for f in fields(cls)}
        return cls(rates=rates, **{k: v for k, v in d.items() if k in known})


#: The policy an IK search starts from (``SolverOptions.policy="quick"``): most poses need a
#: few dozen boxes around isolated roots, too few for running means that move by DECAY per
#: round to learn anything. The prior cost is a cold round (no ancestor's basis), as the first
#: probes are, several times the steady start's: with that one, arms with cheap boxes probed
#: often at a cost far above the one assumed. And the first measured rounds replace both
#: priors, so an arm whose LPs pay (a general 6R) turns them on after a few paid probes. Closed
#: mechanisms run thousands of boxes, where the steady start has time to learn; the quick one
#: bought them nothing, and on the general 6R loop it turned LPs on for a wave in which they
#: did not pay (benchmarks/arm_classes.py; tests/search/test_policy.py, IK searches start quick)
QUICK = Policy(lp_iterations=200.0, quick=True, transverse_after_krawczyk=False)
#: The policy of a search whose LP rounds are expected to pay from the root on (a system whose
#: rows are linear but for unit circles: the relaxation is exact on every other row): the LP gate
#: starts open and closes, like the others, once fewer than LP_RATE of its rounds pay
#: (:meth:`kinbox.problems.mechanism.Problem.search_defaults`; tests/search/test_policy.py)
EAGER = Policy(rates={**_start_rates(), LP.name: 1.0})
POLICIES = {"steady": Policy(), "quick": QUICK, "eager": EAGER}
