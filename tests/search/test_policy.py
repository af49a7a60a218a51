"""The LP probes of the search policy (kinbox.search.policy): decisions from counts only."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import kinbox
from kinbox.search.policy import C_PROBE, C_RATE, CLOSE_LOW, LP, LP_ON_CURVE, LP_PROBE, Events, Hint, Policy, child_id


def _share(policy: Policy, n: int = 4000) -> float:
    return sum(policy.opens(LP, Hint(child_id(7, j))) for j in range(n)) / n


def test_probes_are_rare_when_lps_cost_much_and_boxes_close():
    p = Policy(lp_misses=3, lp_iterations=300.0, close_rate=0.9).with_rates(lp=0.0)
    every = int(2 * p.lp_cost) << 1
    assert every > 4 * LP_PROBE
    assert abs(_share(p) - 1.0 / every) < 0.5 / every


def test_probes_one_box_in_lp_probe_while_the_tree_grows():
    # the same costs and misses, but the boxes without LPs are hardly ever closed
    p = Policy(lp_misses=3, lp_iterations=300.0, close_rate=0.5 * CLOSE_LOW).with_rates(lp=0.0)
    assert abs(_share(p) - 1.0 / LP_PROBE) < 0.3 / LP_PROBE


def test_lps_on_every_box_when_they_pay():
    assert _share(Policy(close_rate=0.0).with_rates(lp=0.9)) == 1.0
    assert _share(Policy(close_rate=1.0).with_rates(lp=0.9)) == 1.0


def test_close_rate_follows_the_waves_counts():
    p = Policy()
    assert p.close_rate == 1.0
    for _ in range(6):  # waves where no box without LPs was closed
        p = p.next(Events(plain=8, plain_closed=0))
    assert p.close_rate < CLOSE_LOW
    q = p.next(Events())  # a wave without such boxes leaves it as it was
    assert q.close_rate == p.close_rate
    for _ in range(6):
        p = p.next(Events(plain=8, plain_closed=8))
    assert p.close_rate > 0.9


def test_events_add_sums_the_plain_counts():
    a = Events(tests={"lp": 2}, plain=3, plain_closed=1)
    a.add(Events(tests={"lp": 1}, plain=4, plain_closed=4))
    assert (a.plain, a.plain_closed, a.tests["lp"]) == (7, 5, 3)


def test_boxes_without_lps_are_counted():
    from kinbox.formulation.system import System
    from kinbox.search.solver import BoxProcessor, SolverOptions

    s = System()
    x = s.add_var("x", -2.0, 2.0)
    y = s.add_var("y", -2.0, 2.0)
    s.add_eq(x * x + y * y - 1.0)
    s.add_eq(x - y)
    proc = BoxProcessor(s, SolverOptions())
    lo, hi = s.search_domain()
    off = Policy(close_rate=1.0).with_rates(lp=0.0)
    o = proc.process(lo, hi, Hint(0), off)  # the root: no probe (id 0), split
    assert o.kind == "split" and o.lps == 0
    assert (o.events.plain, o.events.plain_closed) == (1, 0)
    o = proc.process(np.array([1.5, -2.0]), np.array([2.0, -1.5]), Hint(0), off)  # no root there
    assert o.kind == "empty" and (o.events.plain, o.events.plain_closed) == (1, 1)
    on = Policy().with_rates(lp=1.0)
    o = proc.process(lo, hi, Hint(0), on)
    assert o.lps > 0 and o.events.plain == 0


def _hints(n: int = 4000) -> list[Hint]:
    return [Hint(child_id(7, j)) for j in range(n)]


def test_lp_rounds_on_curve_pieces_follow_their_own_counts():
    """LP rounds on boxes the transverse test narrowed around a curve run while they prove boxes
    empty; once they stop doing so, only probes (about one box in C_PROBE) get them, and they
    come back when the probes prove boxes empty again. The other LP rounds are not affected."""
    p = Policy().with_rates(lp=1.0)
    hints = _hints()
    assert all(p.opens(LP_ON_CURVE, h) for h in hints)  # on at the start
    off = p.next(Events(tests={"lp": 50, "lp_on_curve": 50}, paid={"lp": 50, "lp_on_curve": 0}))
    assert off.rates["lp_on_curve"] < C_RATE
    share = sum(off.opens(LP_ON_CURVE, h) for h in hints) / len(hints)
    assert abs(share - 1.0 / C_PROBE) < 0.03, share
    assert all(off.opens(LP, h) for h in hints)  # LP rounds elsewhere still on every box
    # the same counts give the same policy, whatever order the boxes came in
    wave = {"tests": {"lp_on_curve": 3}, "paid": {"lp_on_curve": 1}}
    assert off.next(Events(**wave)) == off.next(Events(**wave))
    back = off
    for _ in range(5):
        back = back.next(Events(tests={"lp_on_curve": 20}, paid={"lp_on_curve": 20}))
    assert back.rates["lp_on_curve"] >= C_RATE and all(back.opens(LP_ON_CURVE, h) for h in hints)


def test_events_add_the_curve_counts():
    a = Events(tests={"lp_on_curve": 2, "lp": 3}, paid={"lp_on_curve": 1})
    a.add(Events(tests={"lp_on_curve": 5, "lp": 1}, paid={"lp_on_curve": 4}))
    assert (a.tests["lp_on_curve"], a.paid["lp_on_curve"], a.tests["lp"]) == (7, 5, 4)


def test_first_lp_rounds_replace_the_priors():
    """Before any LP round the policy assumes a cold round's cost and probes rarely; the first
    measured rounds then replace both priors (the cost's prior weighs as one round, the pay
    rate's as RATE_PRIOR rounds), and later waves only nudge the running means."""
    from kinbox.search.policy import LP_RATE, QUICK, RATE_PRIOR

    p = QUICK
    assert abs(_share(p) - 1.0 / int(2 * p.lp_cost)) < 0.5 / int(2 * p.lp_cost)
    paid = p.next(Events(tests={"lp": 3}, paid={"lp": 3}, lp_iterations=180))
    assert paid.lp_seen == 3
    assert paid.rates["lp"] == 3 / (3 + RATE_PRIOR) >= LP_RATE  # 3 paid rounds of 3 turn LPs on
    assert abs(paid.lp_iterations - (p.lp_iterations + 180) / 4) < 1e-9
    assert _share(paid) == 1.0
    missed = p.next(Events(tests={"lp": 2}, paid={"lp": 0}, lp_iterations=400))
    assert missed.rates["lp"] == 0.0 and abs(missed.lp_iterations - (p.lp_iterations + 400) / 3) < 1e-9
    # once many rounds are known, a wave moves the means by DECAY per round, not more
    late = replace(paid, lp_seen=1000)
    after = late.next(Events(tests={"lp": 1}, paid={"lp": 0}, lp_iterations=int(late.lp_iterations)))
    assert abs(after.rates["lp"] - 0.9 * late.rates["lp"]) < 1e-12
    # the steady start (every search but IK's) nudges from the first round on
    steady = Policy().next(Events(tests={"lp": 3}, paid={"lp": 3}, lp_iterations=180))
    assert abs(steady.rates["lp"] - (1 - 0.9**3)) < 1e-12 < LP_RATE - steady.rates["lp"]


def test_ik_searches_start_quick_and_others_steady():
    import kinbox
    from kinbox.errors import InputError
    from kinbox.search.policy import POLICIES, QUICK
    from kinbox.search.solver import SolverOptions, make_options

    assert POLICIES["steady"] == Policy() and POLICIES["quick"] == QUICK
    assert SolverOptions().policy == "steady"
    with pytest.raises(InputError, match="policy must be one of steady, quick"):
        make_options(policy="fast")
    ik = kinbox.IK("ur5", "tool0")
    goal = ik.pose_at(np.array([0.3, -1.2, 1.5, -0.8, 1.2, 0.4]))
    quick, steady = ik.solve(goal, closed_form=False), ik.solve(goal, policy="steady", closed_form=False)  # the searches
    assert sorted(map(tuple, np.round([s.q for s in quick.solutions], 9))) == sorted(
        map(tuple, np.round([s.q for s in steady.solutions], 9))
    )
    assert quick.stats["lps"] < steady.stats["lps"]  # the probes a cold round's cost makes rarer


def test_the_quick_start_skips_the_transverse_test_where_krawczyk_paid(monkeypatch):
    """Under the quick start (IK) a box whose first Krawczyk test paid gets no transverse test;
    under the steady start it does (counted per box: the tests Krawczyk repeats on a box it
    narrowed come between)."""
    from kinbox.search import contractors, solver

    log: list[str] = []
    real_k, real_t, real_p = contractors.CtcKrawczyk.contract, contractors.CtcTransverse.contract, solver.BoxProcessor.process

    def k_spy(self, box, ctx=None):
        lo, hi = box
        r = real_k(self, box, ctx)
        gain = np.sum(np.log(np.maximum(hi - lo, 1e-300))) - np.sum(np.log(np.maximum(np.minimum(r.hi, hi) - np.maximum(r.lo, lo), 1e-300)))
        log.append("k:paid" if r.status == "narrowed" and gain >= 0.1 else "k:" + r.status)
        return r

    def t_spy(self, box, ctx=None):
        log.append("t")
        return real_t(self, box, ctx)

    def p_spy(self, lo, hi, hint=None, policy=None):
        log.append("box")
        return real_p(self, lo, hi, hint, policy)

    monkeypatch.setattr(contractors.CtcKrawczyk, "contract", k_spy)
    monkeypatch.setattr(contractors.CtcTransverse, "contract", t_spy)
    monkeypatch.setattr(solver.BoxProcessor, "process", p_spy)

    def after_paid() -> int:
        boxes = " ".join(log).split("box")
        return sum(1 for b in boxes if b.split()[:1] == ["k:paid"] and "t" in b.split())

    ik = kinbox.IK("ur5", "tool0")
    after = {"quick": 0, "steady": 0}
    for q in np.random.default_rng(0).uniform(-3, 3, (4, 6)):
        goal = ik.pose_at(q)
        found = []
        for name in ("quick", "steady"):
            log.clear()
            res = ik.solve(goal, policy=name, closed_form=False)
            assert res.complete and all(s.certified for s in res.solutions)
            found.append(len(res.solutions))
            after[name] += after_paid()
        assert found[0] == found[1] >= 1
    assert after["quick"] == 0 and after["steady"] > 0
