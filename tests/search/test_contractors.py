"""Every contractor behind the one interface (``contract(box, ctx) -> Contraction``, one status
enum), the per-box sequence as data, and the one gate rule of the policy."""

from __future__ import annotations

import numpy as np
import pytest

from kinbox.formulation.system import System
from kinbox.search import contractors as C
from kinbox.search.certify import Certifier
from kinbox.search.policy import Hint, Policy, child_id, gates
from kinbox.search.processor import LP_STEP
from kinbox.search.steps import SEQUENCE, steps

ROOTS = [np.array([s, s]) / np.sqrt(2.0) for s in (1.0, -1.0)]


def circle_and_line() -> System:
    s = System()
    x, y = s.add_var("x", -2.0, 2.0), s.add_var("y", -2.0, 2.0)
    s.add_eq(x * x + y * y - 1.0)
    s.add_eq(x - y)
    return s


def contractors_of(s: System):
    comp = s.compile()
    cert = Certifier(comp)
    lo, hi = s.search_domain()
    root_w = np.maximum(hi - lo, 1e-300)
    mask = s.independent()
    lp = comp.for_lp()
    return {
        "propagation": C.CtcPropagation(comp),
        "krawczyk": C.CtcKrawczyk(cert),
        "transverse": C.CtcTransverse(cert),
        "linear": C.CtcLinear(lp, mask, root_w),
        "bernstein": C.CtcBernstein(lp, mask, root_w),
    }


@pytest.mark.parametrize("name", ["propagation", "krawczyk", "transverse", "linear", "bernstein"])
def test_each_contractor_keeps_the_roots_and_says_what_it_did_with_one_enum(name):
    s = circle_and_line()
    ctcs = contractors_of(s)
    ctc = ctcs[name]
    boxes = [
        (np.array([0.5, 0.5]), np.array([1.0, 1.0])),
        (np.array([-1.2, -1.1]), np.array([0.2, 0.1])),
        (np.array([1.5, -2.0]), np.array([2.0, -1.5])),
    ]
    for lo, hi in boxes:
        ctx = C.Context()
        if name in ("linear", "bernstein"):  # an LP round is built on propagation's monomial bounds
            p = ctcs["propagation"].contract(C.Box(lo, hi), ctx)
            if p.empty:
                continue
            ctx.mlo, ctx.mhi = p.mlo, p.mhi
        r = ctc.contract(C.Box(lo, hi), ctx)
        assert isinstance(r, C.Contraction) and isinstance(r.status, C.ContractStatus)
        for x in ROOTS:
            if np.all(lo <= x) and np.all(x <= hi):
                assert not r.empty, (name, lo, hi)
                keep = (r.proof[0], r.proof[1]) if r.status is C.ContractStatus.UNIQUE else (r.lo, r.hi)
                assert np.all(keep[0] <= x + 1e-15) and np.all(x - 1e-15 <= keep[1]), (name, r)


def test_no_root_box_is_emptied_by_the_sequence_and_a_root_box_is_proven():
    ctcs = contractors_of(circle_and_line())
    empty = ctcs["propagation"].contract(C.Box(np.array([1.5, -2.0]), np.array([2.0, -1.5])))
    assert empty.status is C.ContractStatus.EMPTY and empty.status == "empty"
    k = ctcs["krawczyk"].contract(C.Box(np.array([0.6, 0.6]), np.array([0.8, 0.8])))
    assert k.status is C.ContractStatus.UNIQUE and k.proof is not None


def test_the_sequence_is_data_and_names_contractors_and_gates_that_exist():
    from kinbox.search.processor import BoxProcessor
    from kinbox.search.solver import SolverOptions

    everything = ",".join(s.name for s in steps() if s.optional)
    proc = BoxProcessor(circle_and_line(), SolverOptions(extra_steps=everything))
    names = {g.name for g in gates()}
    assert [s.name for s in steps()] == list(SEQUENCE) == [s.name for s in proc.steps]
    for step in (*steps(), LP_STEP):
        assert step.gate.name in names
        assert step.not_after is None or step.not_after in SEQUENCE
    assert set(proc.ctc) == set(SEQUENCE)
    assert [s.name for s in BoxProcessor(circle_and_line(), SolverOptions()).steps] == [s.name for s in steps() if not s.optional]


@pytest.mark.parametrize("gate", gates(), ids=lambda g: g.name)
def test_every_gate_follows_one_rule(gate):
    """Open on every box while the share of its tests that paid reaches its rate; else on one box
    in ``probe_every`` (fixed, or adaptive for the LP rounds), chosen by its bits of the box id."""
    hints = [Hint(child_id(7, j)) for j in range(4000)]
    on = Policy().with_rates(**{gate.name: gate.rate})
    assert all(on.opens(gate, h) for h in hints)
    off = Policy(close_rate=0.0).with_rates(**{gate.name: 0.0})
    every = off.probe_every(gate)
    assert every == gate.probe  # the boxes without LPs close at no rate: the plain spacing
    chosen = [h for h in hints if off.opens(gate, h)]
    assert all((h.id >> gate.bits) % every == every - 1 for h in chosen)
    assert abs(len(chosen) / len(hints) - 1.0 / every) < 0.3 / every
    with pytest.raises(KeyError):
        Policy().with_rates(no_such_gate=1.0)


def test_a_policy_saved_with_a_rate_per_contractor_loads_into_the_gates():
    from kinbox.search.policy import Events

    old = {"lp_rate": 0.7, "k_rate": 0.2, "t_rate": 0.3, "c_rate": 0.4, "lp_misses": 1, "close_rate": 0.5}
    p = Policy.from_dict(old)
    assert p.rates == {"lp": 0.7, "krawczyk": 0.2, "transverse": 0.3, "lp_on_curve": 0.4}
    assert (p.lp_misses, p.close_rate) == (1, 0.5)
    assert Policy.from_dict(p.to_dict()) == p
    ev = Events.from_dict({"lp_rounds": 3, "lp_paid": 1, "k_tests": 4, "k_paid": 2, "c_rounds": 1, "c_paid": 0, "plain": 5})
    assert ev.tests == {"lp": 3, "krawczyk": 4, "lp_on_curve": 1} and ev.paid == {"lp": 1, "krawczyk": 2, "lp_on_curve": 0}
    assert ev.plain == 5
