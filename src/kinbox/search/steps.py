"""The per-box sequence, written once as data (in the manner of Ibex's ``CtcCompo``).

Every box is first narrowed by propagation. Then, in rounds (at most ``SolverOptions.lp_rounds``),
the steps of :data:`SEQUENCE` run in order, each where its gate lets it
(:meth:`kinbox.search.policy.Policy.opens`): a step's contractor either proves the box empty,
proves it holds one root (the box is finished, certified), or narrows it (propagation follows,
and the step runs again on the narrowed box while it pays, at most ``repeats`` more times).
After them, a box below sigma may be finished (:mod:`kinbox.search.accept`); otherwise the
LP round (:data:`kinbox.search.processor.LP_STEP`) runs where its gate lets it, and another round follows while it pays and the box
shrinks below ``rho`` of its volume. A box still unfinished is bisected
(:mod:`kinbox.search.bisector`). The runner is :meth:`kinbox.search.processor.BoxProcessor.process`.

Adding a contractor is one module ``ctc_<name>.py`` that defines the contractor (a
``contract(box, ctx)`` method) and its :class:`~kinbox.search.contract.Step` as ``STEP`` (with a
:class:`~kinbox.search.contract.Gate` made by :func:`~kinbox.search.policy.register_gate` when it
is not to run on every box), and its name in :data:`SEQUENCE`: one line
(``tests/search/test_contractors.py``, the sequence is data and names contractors and gates that exist).
"""

from __future__ import annotations

import functools
import importlib

from .contract import Step

#: the contractors of the per-box sequence, in the order they run: the module ``ctc_<name>``
#: of each defines its ``STEP`` (a step with ``optional=True`` runs only where
#: ``SolverOptions.extra_steps`` names it)
SEQUENCE: tuple[str, ...] = ("krawczyk", "transverse", "shave")


@functools.cache
def steps() -> tuple[Step, ...]:
    """The :class:`~kinbox.search.contract.Step` of every name in :data:`SEQUENCE`, in order
    (their modules are imported at the first call: each registers its gate with the policy)."""
    out = []
    for name in SEQUENCE:
        step = importlib.import_module(f"{__package__}.ctc_{name}").STEP
        if step.name != name:
            raise RuntimeError(f"module ctc_{name} defines the step {step.name!r}")
        out.append(step)
    return tuple(out)
