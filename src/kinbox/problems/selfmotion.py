"""Seven-joint self-motions by a sweep of one end joint (:mod:`kinbox.answer.selfmotion`).

The end joint to sweep is chosen from the geometry: the first or the last free joint of the
chain whose locking leaves six joints of a closed-form family
(:func:`kinbox.formulation.families.detect`), with the same family and the same canonical
geometry (link rotations, offsets, zero offsets, limit rows: exact comparisons) at every lock
value, and a canonical goal frame that is ``G0 + cos t G1 + sin t G2`` in the locked value
``t`` (checked at a fourth value). Nothing looks at a robot's name. An arm with no such joint
(or a swept joint without finite limits narrower than a turn) is answered by the branch and
prune, as is a pose the sweep does not decide.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..answer.result import Result, max_residual
from ..answer.selfmotion import sweep_result
from ..search.closed_form import ClosedForm
from ..search.sweep import LinearGoal

#: the linear form of the goal frame must reproduce a fourth lock value to this (absolute)
LINEAR_CHECK = 1e-12


@dataclass
class SweptJoint:
    name: str
    idx_q: int
    lo: float
    hi: float


def _same(a: ClosedForm, b: ClosedForm) -> bool:
    return (
        a.code == b.code
        and [j.name for j in a.joints] == [j.name for j in b.joints]
        and all(np.array_equal(getattr(a, k), getattr(b, k)) for k in ("LR", "Lt", "d", "gamma", "limits", "lo", "hi"))
    )


def _frame(cf: ClosedForm, goal: pin.SE3) -> tuple[np.ndarray, np.ndarray]:
    Rlo, Rhi, tlo, thi = cf.goal_arrays(goal.rotation[None], goal.translation[None])
    return 0.5 * (Rlo[0] + Rhi[0]), 0.5 * (tlo[0] + thi[0])


def linear_goal(values: list[float], frames: list[tuple[np.ndarray, np.ndarray]]) -> LinearGoal:
    """``G0, G1, G2`` of ``G(t) = G0 + cos t G1 + sin t G2`` from the frames at three values."""
    A = np.array([[1.0, math.cos(v), math.sin(v)] for v in values])
    R = np.linalg.solve(A, np.array([f[0].ravel() for f in frames]))
    p = np.linalg.solve(A, np.array([f[1] for f in frames]))
    return LinearGoal((R[0].reshape(3, 3), R[1].reshape(3, 3), R[2].reshape(3, 3)), (p[0], p[1], p[2]))


class Sweeper:
    """The closed forms of one seven-joint arm with an end joint locked at three values."""

    def __init__(self, swept: SweptJoint, values: list[float], forms: list[ClosedForm]):
        self.swept, self.values, self.forms = swept, values, forms

    @classmethod
    def of(cls, ik) -> Sweeper | None:
        robot = ik.robot
        model = robot.model
        free = [j for j in ik.chain if model.names[j] not in robot.locked]
        if len(free) != 7 or any(model.joints[j].nq != 1 or model.joints[j].nv != 1 for j in free):
            return None
        for end in (free[-1], free[0]):
            name = model.names[end]
            iq = model.joints[end].idx_q
            lo, hi = float(model.lowerPositionLimit[iq]), float(model.upperPositionLimit[iq])
            if not (math.isfinite(lo) and math.isfinite(hi) and 0.0 < hi - lo < 2.0 * math.pi):
                continue
            mid, a = 0.5 * (lo + hi), min(1.0, 0.25 * (hi - lo))
            values = [mid, mid + a, mid - a, mid + 0.5 * a]
            forms: list[ClosedForm] = []
            for v in values:
                rob = copy.copy(robot)
                rob.locked = dict(robot.locked)
                try:
                    sub = type(ik)(rob, ik.frame, ik.base, lock={name: v})
                    cf = sub.closed_form
                except Exception:  # a locked chain the closed form does not cover
                    cf = None
                if cf is None or (forms and not _same(forms[0], cf)):
                    forms = []
                    break
                forms.append(cf)
            # a joint of the six with a range wider than a turn has copies q + 2 pi k that the
            # closed form's wrapped angles do not list: the branch and prune answers that arm
            if not forms or any((not j.unbounded) and j.hi - j.lo >= 2.0 * math.pi for j in forms[0].joints):
                continue
            sw = cls(SweptJoint(name, iq, lo, hi), values, forms)
            rng = np.random.default_rng(0)  # two goals: the frame's map must be linear in (cos t, sin t)
            if all(sw._linear_ok(pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(size=3))) for _ in range(2)):
                return sw
        return None

    def _linear_ok(self, goal: pin.SE3) -> bool:
        frames = [_frame(cf, goal) for cf in self.forms]
        lin = linear_goal(self.values[:3], frames[:3])
        R4, p4 = lin.at(self.values[3])
        return bool(np.abs(R4 - frames[3][0]).max() <= LINEAR_CHECK and np.abs(p4 - frames[3][1]).max() <= LINEAR_CHECK)

    def solve(self, prob, goal: pin.SE3) -> Result | None:
        """The self-motion of ``goal`` (:func:`kinbox.answer.selfmotion.sweep_result`), or None."""
        if not self._linear_ok(goal):
            return None
        lin = linear_goal(self.values[:3], [_frame(cf, goal) for cf in self.forms[:3]])
        mech = prob.formulation.mechanism
        data = mech.model.createData()
        return sweep_result(
            self.forms[0],
            lin,
            self.swept,
            prob.formulation,
            prob.label,
            prob.sigma,
            prob.source,
            lambda q: max_residual(mech, q, data),
            prob.polish,
        )
