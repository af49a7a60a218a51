"""The problem protocol: any kind with a system, a sigma and an answer goes through the one
``kinbox.run`` (the clock, the options, the search, the answer, the search again)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pytest

import kinbox
from kinbox.answer.components import analyse
from kinbox.formulation.system import System
from kinbox.search.outcome import Outcome, Stats
from kinbox.search.status import Status


@dataclass(repr=False)
class PointsAnswer(Outcome):
    """A minimal answer: the roots the components hold."""

    status: Status
    message: str
    stats: Stats
    components: list = field(default_factory=list)
    points: list = field(default_factory=list)

    def to_dict(self) -> dict:
        return {"status": self.status.value, "complete": self.complete, "points": [p.tolist() for p in self.points]}

    def table(self) -> str:
        return f"{len(self.points)} point(s); {self.message}"


class CircleAndLine:
    """x^2 + y^2 = 1 and y = x: two isolated roots, (+-1/sqrt 2, +-1/sqrt 2)."""

    sigma = 1e-4
    max_sigma: float | None = 0.5
    built = 0

    def __init__(self):
        s = System()
        x, y = s.add_var("x", -2, 2), s.add_var("y", -2, 2)
        s.add_eq(x * x + y * y - 1)
        s.add_eq(y - x)
        self._system = s

    @property
    def system(self) -> System:
        return self._system

    def relaxation(self) -> str:
        return "auto"

    def answer(self, raw, sigma: float) -> PointsAnswer:
        self.built += 1
        st = analyse(raw.system, raw.boxes, sigma)
        pts = [c.point for c in st.components if c.dimension == 0 and c.point is not None]
        return PointsAnswer(raw.status, raw.message, raw.stats, st.components, pts)


def test_a_new_problem_kind_runs_through_run():
    prob = CircleAndLine()
    res = kinbox.run(prob, progress=False)
    assert isinstance(res, Outcome) and res.complete and res.status is Status.COMPLETE
    got = sorted(float(p[0]) for p in res.points)
    assert np.allclose(got, [-np.sqrt(0.5), np.sqrt(0.5)], atol=1e-9)
    assert prob.built == 1 and res.stats["boxes"] > 0
    stopped = kinbox.run(CircleAndLine(), max_boxes=1, progress=False)
    assert not stopped.complete and stopped.status is Status.BOX_BUDGET


def test_run_refuses_a_sigma_above_the_kind_s_largest():
    with pytest.raises(kinbox.InputError, match="sigma 0.7 is too large: at most 0.5"):
        kinbox.run(CircleAndLine(), sigma=0.7)
