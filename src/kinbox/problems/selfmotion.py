"""Seven-joint self-motions by a sweep of one end joint (:mod:`kinbox.answer.selfmotion`).

The end joint to sweep is chosen from the geometry: the last free joint of the chain whose
locking leaves six joints of a closed-form family (:func:`kinbox.formulation.families.detect`),
with the same family and the same canonical geometry (link rotations, offsets, zero offsets,
limit rows: exact comparisons) at every lock value, else the first free joint whose six others,
written as the arm rooted at a frame on it (:mod:`kinbox.formulation.swept_goal`: one
template for every value, the goal seen from that frame), are such a family; and a canonical
goal frame that is ``G0 + cos t G1 + sin t G2`` in the locked value ``t`` (checked at a fourth
value). Nothing looks at a robot's name. An arm with no such joint
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
from ..formulation.swept_goal import RootedGoal
from ..search.closed_form import ClosedForm
from ..search.sweep import Anchors, LinearGoal

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


def _locker(ik, name: str):
    """``v -> `` the arm template of ``ik``'s chain with joint ``name`` locked at ``v`` (None
    where there is none)."""

    def locked(v: float):
        rob = copy.copy(ik.robot)
        rob.locked = dict(ik.robot.locked)
        try:
            return type(ik)(rob, ik.frame, ik.base, lock={name: v}).arm
        except Exception:  # a locked chain no arm template covers
            return None

    return locked


def _root_frame(mech, jid: int) -> str | None:
    """The name of a frame on joint ``jid`` that names it alone (its joint frame first), or None."""
    frames = sorted(mech.model.frames, key=lambda f: f.type != pin.FrameType.JOINT)
    for f in frames:
        if f.parentJoint != jid:
            continue
        try:
            if mech.frame_anchor(f.name)[0] == jid:
                return str(f.name)
        except Exception:  # a name shared by frames at different places
            continue
    return None


@dataclass
class Root:
    """The six joints after a swept first joint ``jid`` as the arm from frame ``frame`` on it
    to ``tool``: the frame's placement ``W(v)`` in the seven-joint arm's base ``base`` at each
    lock value (binary64, Pinocchio's forward kinematics; the goal seen from the frame is
    ``W(v)^-1`` times the pose) and the model's configuration ``q`` (locked joints)."""

    frame: str
    tool: str
    base: str | None
    jid: int
    q: np.ndarray
    W: list[pin.SE3]
    #: the exact goal at the anchors' lock values (built once), False where not enclosed
    exact: RootedGoal | None | bool = None


def _rooted(ik, jid: int, values: list[float]) -> tuple[ClosedForm, Root] | None:
    """The closed form of the six joints after ``jid`` rooted at a frame on it, or None."""
    mech = ik.robot
    name = _root_frame(mech, jid)
    if name is None:
        return None
    rob = copy.copy(mech)
    rob.locked = dict(mech.locked)
    try:
        cf = type(ik)(rob, ik.frame, name).closed_form
    except Exception:  # a chain the closed form does not cover
        return None
    if cf is None or len(cf.joints) != 6:
        return None
    model = mech.model
    data = model.createData()
    jb, pb = mech.frame_anchor(ik.base or "universe")
    js, ps = mech.frame_anchor(name)
    Ws = []
    for v in values:
        q = np.array(cf.q_ref, dtype=float)
        q[model.joints[jid].idx_q] = v
        pin.forwardKinematics(model, data, q)
        Ws.append((data.oMi[jb] * pb).inverse() * (data.oMi[js] * ps))
    return cf, Root(name, ik.frame, ik.base, jid, np.array(cf.q_ref, dtype=float), Ws)


#: the anchors' lock values about the first: a third of a turn apart, where the weights of
#: the three are at most 1 in absolute value (:class:`kinbox.search.sweep.Anchors`)
ANCHOR_STEP = 2.0 * math.pi / 3.0


class Sweeper:
    """The closed forms of one seven-joint arm with an end joint locked at three values."""

    def __init__(self, swept: SweptJoint, values: list[float], forms: list[ClosedForm], locked=None, root: Root | None = None):
        self.swept, self.values, self.forms = swept, values, forms
        #: a swept first joint: the six others rooted at a frame on it (one closed form)
        self.root = root
        #: the arm locked at a value (``locked(v)``: its arm template, or None), for the anchors
        self._locked = locked
        self._anchor_arms: tuple[list[float], list] | None = None

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
            root = None
            if end == free[0]:  # the six others rooted on it: their frames do not move with it
                rooted = _rooted(ik, end, values)
                if rooted is not None:
                    forms, root = [rooted[0]] * len(values), rooted[1]
            for v in values if end != free[0] else []:
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
            sw = cls(SweptJoint(name, iq, lo, hi), values, forms, _locker(ik, name), root)
            rng = np.random.default_rng(0)  # two goals: the frame's map must be linear in (cos t, sin t)
            if all(sw._linear_ok(pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(size=3))) for _ in range(2)):
                return sw
        return None

    def frames(self, goal: pin.SE3) -> list[tuple[np.ndarray, np.ndarray]]:
        """The canonical goal frame at each lock value (binary64): the pose in each locked
        arm's frames, or seen from the root frame at that value (:class:`Root`)."""
        if self.root is None:
            return [_frame(cf, goal) for cf in self.forms]
        return [_frame(cf, W.inverse() * goal) for cf, W in zip(self.forms, self.root.W)]

    def _linear_ok(self, goal: pin.SE3) -> bool:
        frames = self.frames(goal)
        lin = linear_goal(self.values[:3], frames[:3])
        R4, p4 = lin.at(self.values[3])
        return bool(np.abs(R4 - frames[3][0]).max() <= LINEAR_CHECK and np.abs(p4 - frames[3][1]).max() <= LINEAR_CHECK)

    def _arms(self) -> tuple[list[float], list]:
        """The anchors' lock values and arm templates (built once): the first lock value and a
        third of a turn either side, else the first three lock values."""
        if self._anchor_arms is None:
            arm0 = self.forms[0].certifier.arm if self.forms[0].certifier is not None else None
            v0 = self.values[0]
            values = [v0, v0 + ANCHOR_STEP, v0 - ANCHOR_STEP]
            arms = [arm0] + ([self._locked(v) for v in values[1:]] if self._locked is not None else [None, None])
            if any(a is None for a in arms):
                values = list(self.values[:3])
                arms = [cf.certifier.arm if cf.certifier is not None else None for cf in self.forms[:3]]
            self._anchor_arms = (values, arms)
        return self._anchor_arms

    def anchors(self, goal: pin.SE3) -> Anchors | None:
        """The exact goal of the pose as given at three lock values
        (:class:`kinbox.search.sweep.Anchors`), where the six joints' canonical frames are the
        same at each (bit for bit: their exact frames are then the same, and the exact goal is
        ``a + b cos t + c sin t`` entry by entry) and the constants are enclosed; for a swept
        first joint, the exact goal of the arm rooted on it at three lock values
        (:class:`kinbox.formulation.swept_goal.RootedGoal`); else None."""
        if self.root is not None:
            return self._rooted_anchors(goal)
        values, arms = self._arms()
        if any(a is None or a.constants is None or a.geometry.frames is None for a in arms):
            return None
        f0 = arms[0].geometry.frames
        for a in arms[1:]:
            f = a.geometry.frames
            if len(f) != len(f0) or not all(np.array_equal(x.homogeneous, y.homogeneous) for x, y in zip(f, f0)):
                return None
        encs = [a.params_enclosure(goal) for a in arms]
        return Anchors.of(values, [p[1:13] for p, _ in encs], [r[1:13] for _, r in encs])

    def _rooted_anchors(self, goal: pin.SE3) -> Anchors | None:
        root = self.root
        assert root is not None
        if root.exact is None:
            tc = self.forms[0].certifier
            v0 = self.values[0]
            values = [v0, v0 + ANCHOR_STEP, v0 - ANCHOR_STEP]
            ex = None
            if tc is not None and tc.arm.constants is not None:
                ex = RootedGoal.of(tc.arm, root.tool, root.frame, root.base, root.jid, root.q, values)
            root.exact = ex if ex is not None else False
        if root.exact is False:
            return None
        assert isinstance(root.exact, RootedGoal)
        G, Gr = root.exact.goals(goal)
        return Anchors.of(root.exact.values, G, Gr)

    def solve(self, prob, goal: pin.SE3) -> Result | None:
        """The self-motion of ``goal`` (:func:`kinbox.answer.selfmotion.sweep_result`), or None."""
        if not self._linear_ok(goal):
            return None
        lin = linear_goal(self.values[:3], self.frames(goal)[:3])
        lin.anchors = self.anchors(goal)
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
