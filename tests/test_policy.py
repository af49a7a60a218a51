"""The search policy (kinbox.search.policy): decisions from counts, the same on every run."""

from __future__ import annotations

from kinbox.search.policy import C_PROBE, C_RATE, Events, Hint, Policy, child_id


def _hints(n: int = 4000) -> list[Hint]:
    return [Hint(child_id(7, j)) for j in range(n)]


def test_lp_rounds_on_curve_pieces_follow_their_own_counts():
    """LP rounds on boxes the transverse test narrowed around a curve run while they prove boxes
    empty; once they stop doing so, only probes (about one box in C_PROBE) get them, and they
    come back when the probes prove boxes empty again. The other LP rounds are not affected."""
    p = Policy(lp_rate=1.0)
    hints = _hints()
    assert all(p.wants_lp_on_curve(h) for h in hints)  # on at the start
    off = p.next(Events(lp_rounds=50, lp_paid=50, c_rounds=50, c_paid=0))
    assert off.c_rate < C_RATE
    share = sum(off.wants_lp_on_curve(h) for h in hints) / len(hints)
    assert abs(share - 1.0 / C_PROBE) < 0.03, share
    assert all(off.wants_lp(h) for h in hints)  # LP rounds elsewhere still on every box
    # the same counts give the same policy, whatever order the boxes came in
    assert off.next(Events(c_rounds=3, c_paid=1)) == off.next(Events(c_rounds=3, c_paid=1))
    back = off
    for _ in range(5):
        back = back.next(Events(c_rounds=20, c_paid=20))
    assert back.c_rate >= C_RATE and all(back.wants_lp_on_curve(h) for h in hints)


def test_events_add_the_curve_counts():
    a = Events(c_rounds=2, c_paid=1, lp_rounds=3)
    a.add(Events(c_rounds=5, c_paid=4, lp_rounds=1))
    assert (a.c_rounds, a.c_paid, a.lp_rounds) == (7, 5, 4)
