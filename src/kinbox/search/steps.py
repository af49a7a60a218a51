"""The per-box sequence, written once as data (in the manner of Ibex's ``CtcCompo``).

Every box is first narrowed by propagation. Then, in rounds (at most ``SolverOptions.lp_rounds``),
the :data:`STEPS` run in order, each where its gate lets it (:meth:`kinbox.search.policy.Policy.opens`):
a step's contractor either proves the box empty, proves it holds one root (the box is finished,
certified), or narrows it (propagation follows, and the step runs again on the narrowed box
while it pays, at most ``repeats`` more times). After them, a box below sigma may be finished
(:mod:`kinbox.search.accept`); otherwise the :data:`LP_STEP` runs where its gate lets it, and
another round follows while it pays and the box shrinks below ``rho`` of its volume. A box
still unfinished is bisected (:mod:`kinbox.search.bisector`). The runner is
:meth:`kinbox.search.processor.BoxProcessor.process`.

Adding a contractor is a module with a ``contract(box, ctx)`` method and one :class:`Step` line
(and a :class:`~kinbox.search.policy.Gate` when it is not to run on every box).
"""

from __future__ import annotations

from dataclasses import dataclass

from .policy import KRAWCZYK, LP, LP_ON_CURVE, T_GAIN, TRANSVERSE, Gate

#: Krawczyk tests again on a box its last test (and propagation after it) narrowed by at least
#: :data:`K_GAIN` of log-volume, at most this many times: the contraction of a box next to a
#: root is quadratic while it pays, and a box split instead came back a wave later for the same
#: test (benchmarks/ur_poses.py: fewer boxes over 100 UR5 poses than without the repeats)
K_REPEATS = 3
#: a Krawczyk test pays when it removes this much log-volume (or proves the box empty or unique)
K_GAIN = 0.1
#: Krawczyk runs on every box narrower than this many sigma, whatever its gate says: isolated
#: roots get certified there
K_ALWAYS_BELOW = 2.0


@dataclass(frozen=True)
class Step:
    """One contractor of the per-box sequence.

    ``contractor``: the name of the :class:`~kinbox.search.processor.BoxProcessor` attribute
    that holds it (None there: the step is skipped); ``gate``: when it runs; ``gain``: the
    log-volume a test must remove to pay; ``repeats``: more runs on the box it narrowed, while
    they pay; ``always_below``: it also runs, gate closed, on boxes narrower than this many
    sigma; ``curve``: a test that pays marks the box as lying around a piece of a curve (LP
    rounds there follow their own gate) and a graph it proves is tried as a curve box;
    ``not_after``: the step of this name, when its first test on the box paid, closes this
    one under a policy that says so (:meth:`~kinbox.search.policy.Policy.runs_after_paid`);
    ``without_lp``: where the search has no LP rounds, the step runs on every box, gate open
    (it is then the only test that settles a box)."""

    name: str
    contractor: str
    gate: Gate
    gain: float
    repeats: int = 0
    always_below: float = 0.0
    curve: bool = False
    not_after: str | None = None
    without_lp: bool = False


STEPS: tuple[Step, ...] = (
    Step("krawczyk", "krawczyk", KRAWCZYK, K_GAIN, repeats=K_REPEATS, always_below=K_ALWAYS_BELOW, without_lp=True),
    Step("transverse", "transverse", TRANSVERSE, T_GAIN, curve=True, not_after="krawczyk"),
)

#: the LP round that ends a round of the sequence: it pays by the log-volume it removes per box
#: of work (:meth:`~kinbox.search.policy.Policy.lp_paid`); on a box around a piece of a curve it
#: also passes :data:`~kinbox.search.policy.LP_ON_CURVE`
LP_STEP = Step("lp", "lp", LP, 0.0)
LP_CURVE_GATE = LP_ON_CURVE
