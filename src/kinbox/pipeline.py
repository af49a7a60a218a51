"""One pipeline for every problem: model -> formulation -> search -> answer.

:class:`Problem` holds a mechanism and its polynomial system, built once; :meth:`Problem.solve`
runs the search (in this process or over workers) and turns the boxes into checked
joint-space solutions. The two entry points are thin layers over it:

* :func:`ik` / :class:`IK`: every inverse-kinematics solution of a frame of an arm;
* :func:`solve`: every configuration of a mechanism with loops (assembly modes, curves).

Example::

    import kinbox
    res = kinbox.ik("ur5", "tool0", [0.3, 0.2, 0.4, 0, 1, 0, 0])   # x y z qx qy qz qw
    for s in res.solutions:
        print(s.q, s.residual, s.certified)
"""

from __future__ import annotations

import copy
import io
import os
import pickle
import time
from collections.abc import Iterable, Iterator, Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from .answer.refine import free_velocity_indices, refine
from .answer.result import Result, build_result
from .answer.turns import add_turns
from .errors import MAX_LENGTH, FormulationError, InputError
from .formulation.arm import ArmFormulation, ArmTemplate, arm_template
from .formulation.arm_invariants import InvariantsTemplate, invariants_template
from .formulation.build import Formulation, formulate
from .formulation.planar import PlanarFormulation, formulate_planar
from .formulation.system import System
from .model.loading import load
from .model.mechanism import Closure, Mechanism
from .search import solver
from .search.certify import set_newton
from .search.solver import SolveResult, SolverOptions
from .search.state import SearchState
from .search.threads import single_threaded

#: joints held fixed: name -> value (a number, or the joint's ``q`` entries, e.g. a free-flyer's 7)
Locks = Mapping[str, float | Sequence[float]]

if TYPE_CHECKING:  # loaded with a scene only (tests/answer/test_scene.py::test_no_scene_loads_no_geometry)
    from .answer.collision import Checker

#: what the answer stage is given: the system of one problem with its encode and decode
AnyFormulation = Formulation | ArmFormulation | PlanarFormulation
#: ``formulation=`` of :func:`solve`: the planar one for a mechanism whose joint axes are all
#: parallel (:mod:`kinbox.formulation.planar`), else the general one
MECHANISM_FORMULATIONS = ("auto", "planar", "general")

#: box size below which a search stops splitting: IK answers are isolated points (certified
#: by Krawczyk whatever the box size), mechanisms may have curves, drawn at this resolution
IK_SIGMA = 1e-4
MECHANISM_SIGMA = 0.05
#: ``legs="auto"`` looks for this many points of the solution set, from at most this many starts
MOBILITY_SAMPLES = 4
MOBILITY_STARTS = 64
#: singular values of the Jacobian below this share of the largest count as zero
RANK_TOL = 1e-7
#: the largest sigma a problem takes: its variables (cosines, sines, rotation entries, metres)
#: are of unit size, and an answer box wider than this could hold several solutions, which the
#: answer would report as one (the general 6R loop loses half of its 16 at sigma 10)
MAX_SIGMA = 0.5


def solve_system(
    system: System,
    options: SolverOptions | None = None,
    *,
    workers: int | None = None,
    executor=None,
    resume: SearchState | None = None,
    **kw,
) -> SolveResult:
    """Enclose every solution of ``system`` in its domain. Keyword arguments set options.

    ``workers=N`` explores the boxes with N local processes (0: one per core), ``executor=`` a
    ``dask.distributed.Client`` (or scheduler address) on a Dask cluster; see
    :mod:`kinbox.search.parallel`. ``resume``: the ``state`` of an incomplete result of the same
    system (or :meth:`SearchState.load` of a saved one): the search goes on from there.
    """
    opt = solver.make_options(options, **kw)
    if workers is not None or executor is not None:
        from .search.parallel import solve_parallel  # Dask and multiprocessing only when asked

        return solve_parallel(system, opt, workers=workers, executor=executor, resume=resume)
    return solver.solve_system(system, opt, resume=resume)


def local_dimensions(system: System, samples: int = MOBILITY_SAMPLES, starts: int = MOBILITY_STARTS, seed: int = 0) -> list[int]:
    """The local dimension (variables minus the rank of the equations' Jacobian) of the solution
    set of ``system`` at up to ``samples`` of its points, found by Gauss-Newton from seeded random
    starts in the domain (the same points on every run). Empty if none was found."""
    comp = system.compile()
    lo, hi = system.domain()
    rng = np.random.default_rng(seed)
    dims: list[int] = []
    for _ in range(starts):
        x = set_newton(comp, rng.uniform(lo, hi), iters=40)
        if not (np.all(np.isfinite(x)) and np.all(x >= lo) and np.all(x <= hi)):
            continue
        if np.max(np.abs(comp.eval_eqs(x)), initial=0.0) > 1e-10:
            continue
        sv = np.linalg.svd(comp.jacobian(x), compute_uv=False)
        dims.append(comp.n - int(np.sum(sv > RANK_TOL * sv[0])) if len(sv) and sv[0] > 0 else comp.n)
        if len(dims) == samples:
            break
    return dims


def choose_formulation(mechanism: Mechanism, legs: str = "auto", formulation: str = "auto") -> Formulation | PlanarFormulation:
    """The planar formulation of a planar mechanism (``formulation`` ``"auto"`` or ``"planar"``,
    :func:`~kinbox.formulation.planar.formulate_planar`), else ``formulate(mechanism, legs)``;
    for ``legs="auto"``, the leg equations that suit the solution set.

    Squared legs (fewest variables) are fastest on isolated assembly modes; on a curve their
    relaxation is loose and the search neither ends in time nor separates the curves, while
    leg vectors (linear loop equations) give them. Whether the configurations form curves is
    read from the squared system itself: the local dimension at sample points of its solution
    set. Positive at every sample (a mobile mechanism, however its equations count): vectors.
    """
    if formulation not in MECHANISM_FORMULATIONS:
        raise InputError(f"formulation must be one of {', '.join(MECHANISM_FORMULATIONS)}, not {formulation!r}")
    if formulation != "general":
        pf = formulate_planar(mechanism, legs=legs)
        if pf is not None:
            return pf
        if formulation == "planar":
            raise InputError(
                f"{mechanism.name!r} is not planar: its loops need joints whose axes are all parallel (revolute) or across them (prismatic)"
            )
    f = formulate(mechanism, legs=legs)
    if legs != "auto" or not any(c.kind == "distance" for c in mechanism.closures):
        return f
    dims = local_dimensions(f.system)
    if dims and min(dims) >= 1:
        return formulate(mechanism, legs="vector")
    return f


class Problem:
    """A mechanism formulated once, solved on demand."""

    def __init__(
        self,
        mechanism: Mechanism,
        label: str,
        sigma: float,
        source: dict | None = None,
        legs: str = "auto",
        formulation: AnyFormulation | None = None,
    ):
        self.mechanism = mechanism
        self.label = label
        self.sigma = sigma
        self.source = source or {}
        self.formulation: AnyFormulation = formulation if formulation is not None else choose_formulation(mechanism, legs)
        self._free_v = free_velocity_indices(mechanism.model, self.formulation.joint_vars.keys())
        self._data: pin.Data | None = None

    def polish(self, q: np.ndarray) -> np.ndarray:
        """Newton on the closures with Pinocchio, moving only the joints of the system."""
        if self._data is None:  # scratch for Pinocchio, one per problem (not per solution)
            self._data = self.mechanism.model.createData()
        return refine(self.mechanism, q, self._free_v, data=self._data)

    def relaxation(self) -> str:
        """The LP contractor for ``relaxation="auto"``: the linear relaxation (Porta, Ros and Thomas 2009) when the legs are
        unit vectors (a mobile platform, see :func:`choose_formulation`), where it ran 1.16x
        faster than the Bernstein polytope; Bernstein elsewhere, where it was as fast (general
        6R, the four-bar) or faster (UR5 0.93x, Dietmeier 0.83x) (``benchmarks/relaxations.py``;
        tests/search/test_relaxations.py checks that every relaxation gives the same answers)."""
        legs = getattr(self.formulation, "closure_vars", None) or {}
        return "linear" if any(legs.values()) else "bernstein"

    @single_threaded
    def solve(
        self, workers: int | None = None, executor=None, resume: SearchState | None = None, all_turns: bool = False, **solver_options
    ) -> Result:
        """Search and check. ``resume``: a stopped search of this problem (``result.raw.state``,
        or :meth:`SearchState.load`) to go on with; ``started``: the ``time.perf_counter()`` a
        ``time_limit`` counts from (default: now); ``all_turns``: list every copy ``q + 2 pi k``
        within the limits of a joint whose range is wider than a turn (:mod:`kinbox.answer.turns`)."""
        _start_clock(solver_options)
        if solver_options.get("relaxation", "auto") == "auto":
            solver_options["relaxation"] = self.relaxation()
        opts = solver.make_options(SolverOptions(sigma=self.sigma), **solver_options)
        if opts.sigma > MAX_SIGMA:
            raise InputError(
                f"sigma {opts.sigma:g} is too large: at most {MAX_SIGMA} (an answer box wider than that could hold several solutions)"
            )
        raw = solve_system(self.formulation.system, opts, workers=workers, executor=executor, resume=resume)
        res = build_result(self.label, raw, self.formulation, opts.sigma, polish=self.polish, source=self.source)
        while redo := unconfirmed_curve_boxes(raw, res.components):
            raw = solver.search_again(self.formulation.system, raw, redo, opts)
            res = build_result(self.label, raw, self.formulation, opts.sigma, polish=self.polish, source=self.source)
        add_turns(res, all_turns)
        return res


def unconfirmed_curve_boxes(raw: SolveResult, components) -> list[int]:
    """The curve boxes of a complete search that the answer put on no curve (``components``:
    dimension 1):
    :func:`kinbox.search.solver.search_again` resolves them like any other box. The answer
    stage is the second judge of a curve box, after the solver's samples along it: its
    continuation must leave the box's point along a curve, else the box may hold isolated roots
    next to a curve that its one point would stand for (docs/soundness.md, "Curve boxes")."""
    if not raw.complete:
        return []  # an incomplete answer says so; resuming it ends with this check
    curve = [i for i, b in enumerate(raw.boxes) if b.curve]
    if not curve:
        return []
    on_curve = {i for c in components if c.dimension >= 1 for i in c.boxes}
    return [i for i in curve if i not in on_curve]


# ----------------------------------------------------------------------------------------------
# inverse kinematics
# ----------------------------------------------------------------------------------------------
def parse_pose(pose) -> pin.SE3:
    """A ``pin.SE3`` or a 7-vector ``x y z qx qy qz qw`` (Pinocchio's XYZQUAT), validated."""
    if isinstance(pose, pin.SE3):
        if not (np.all(np.isfinite(pose.translation)) and np.all(np.isfinite(pose.rotation))):
            raise InputError("pose has non-finite numbers")
        R = pose.rotation
        if np.max(np.abs(R.T @ R - np.eye(3))) > 1e-9 or np.linalg.det(R) < 0:
            raise InputError("pose rotation is not a rotation matrix")
        return pin.SE3(pose)
    try:
        v = np.asarray(pose, dtype=float).ravel()
    except (TypeError, ValueError):
        raise InputError(f"pose must be a pinocchio.SE3 or 7 numbers (x y z qx qy qz qw), got {pose!r:.80}") from None
    if v.size != 7:
        raise InputError(f"pose needs 7 numbers (x y z qx qy qz qw), got {v.size}")
    if not np.all(np.isfinite(v)):
        raise InputError(f"pose has non-finite numbers: {v.tolist()}")
    nq = float(np.linalg.norm(v[3:]))
    if abs(nq - 1.0) > 1e-6:
        raise InputError(f"quaternion (qx qy qz qw) = {v[3:].tolist()} is not unit (norm {nq:.6g})")
    v[3:] /= nq
    return pin.XYZQUATToSE3(v)


#: how :class:`IK` formulates: ``"auto"`` (for six revolute joints with no wrist or shoulder
#: centre, Raghavan and Roth's invariants; for other chains of six revolute or prismatic joints
#: the arm template; else the general formulation), ``"invariants"`` or ``"arm"`` (that
#: template, or an error) or ``"general"`` (:func:`~kinbox.formulation.build.formulate` for
#: every pose)
ARM_FORMULATIONS = ("auto", "invariants", "arm", "general")


class IK:
    """An arm prepared once for many inverse-kinematics queries of one frame.

    A six-joint serial chain (revolute or prismatic joints, locked joints folded in) is
    formulated once (:mod:`kinbox.formulation.arm`, or :mod:`kinbox.formulation.arm_invariants`
    for a general 6R arm): each pose only binds numbers into it.
    """

    def __init__(
        self,
        robot,
        frame: str,
        base: str | None = None,
        lock: Locks | None = None,
        formulation: str = "auto",
        scene=None,
        srdf: str | None = None,
    ):
        if formulation not in ARM_FORMULATIONS:
            raise InputError(f"formulation must be one of {', '.join(ARM_FORMULATIONS)}, not {formulation!r}")
        self.formulation = formulation
        self._arm: ArmTemplate | InvariantsTemplate | None = None
        self._arm_tried = False
        self.robot = load(robot)
        self.source = {
            "kind": "ik",
            "robot": robot if isinstance(robot, str) else None,
            "frame": frame,
            "base": base,
            "lock": dict(lock or {}),
        }
        self.frame = frame
        self.base = base
        if not isinstance(frame, str) or not frame.strip():
            raise InputError(
                f"the frame to place is empty: name a frame of {self.robot.name!r} (`kinbox info {self.robot.name}` lists them)"
            )
        if base is not None and (not isinstance(base, str) or not base.strip()):
            raise InputError("the base frame is empty: name a frame, or leave it out for the world")
        self.robot.frame_anchor(frame)  # validates the names now, not at the first solve
        if base is not None:
            self.robot.frame_anchor(base)
        for name, value in (lock or {}).items():
            self.robot.lock(name, value)
        #: the joints between the base and the frame, in model order
        self.chain = self.robot.joints_between(frame, base)
        names = self.robot.model.names
        where = f"{frame!r} relative to {base!r}" if base else f"{frame!r} relative to the world"
        if not self.chain:
            raise InputError(
                f"no joint moves frame {where} in {self.robot.name!r}: "
                f"choose a frame on the arm (`kinbox info {self.robot.name}` lists them)"
            )
        if all(names[j] in self.robot.locked for j in self.chain):
            raise InputError(f"every joint that moves frame {where} is locked: nothing to solve")
        _refuse_floating_base(self.robot, self.chain, frame, where)
        #: degrees of freedom of the unlocked joints of the chain (6 for a pose to isolate them)
        self.dof = sum(self.robot.model.joints[j].nv for j in self.chain if names[j] not in self.robot.locked)
        #: the collision scene every answer is checked against (kinbox.answer.collision), or None
        self.scene = Scene(self.robot, robot, scene, srdf) if scene is not None else None
        if self.scene is not None:
            self.source["scene"] = self.scene.name

    def pose_at(self, q: Sequence[float]) -> pin.SE3:
        """The goal frame's pose (in ``base``) at configuration ``q``: Pinocchio's ``q``, one
        value per degree of freedom (angles for continuous joints), or values of the joints
        between the base and the frame alone (:attr:`chain`, in model order; the others, such
        as gripper fingers, do not move the frame), or values of its unlocked joints alone, the
        locked ones at their locks (test_lock_takes_vectors)."""
        model = self.robot.model
        data = model.createData()
        free = [j for j in self.chain if model.names[j] not in self.robot.locked]
        sizes = {model.nq, model.nv, *(sum(getattr(model.joints[j], k) for j in self.chain) for k in ("nq", "nv"))}
        n = np.size(q) if isinstance(q, (list, tuple, np.ndarray)) else -1
        if free != self.chain and n not in sizes and n in (sum(model.joints[j].nq for j in free), sum(model.joints[j].nv for j in free)):
            qa = _as_configuration(model, q, free, self.frame)
            for jid, v in self.robot.locked_q().items():
                qa[model.joints[jid].idx_q : model.joints[jid].idx_q + model.joints[jid].nq] = v
        else:
            qa = _as_configuration(model, q, self.chain, self.frame)
        pin.framesForwardKinematics(model, data, qa)
        ja, pa = self.robot.frame_anchor(self.frame)
        jb, pb = self.robot.frame_anchor(self.base or "universe")
        return (data.oMi[jb] * pb).inverse() * (data.oMi[ja] * pa)

    @property
    def arm(self) -> ArmTemplate | InvariantsTemplate | None:
        """The arm template of this frame (built at the first use), or None where the chain is
        not one it covers (or ``formulation="general"``)."""
        if not self._arm_tried and self.formulation != "general":
            self._arm_tried = True
            if self.formulation in ("auto", "invariants"):
                self._arm = invariants_template(self.robot, self.frame, self.base)
                if self._arm is None and self.formulation == "invariants":
                    raise FormulationError(
                        f"frame {self.frame!r} of {self.robot.name!r} is not reached by six revolute joints without a wrist or "
                        "shoulder centre and without three parallel axes in a row: no invariants formulation"
                    )
            if self._arm is None and self.formulation != "invariants":
                self._arm = arm_template(self.robot, self.frame, self.base)
            if self._arm is None and self.formulation == "arm":
                raise FormulationError(
                    f"frame {self.frame!r} of {self.robot.name!r} is not reached by six revolute or prismatic joints: no arm formulation"
                )
        return self._arm

    def problem(self, pose, arm: ArmTemplate | InvariantsTemplate | None = None) -> Problem:
        """The problem of one goal pose (formulated, not solved; ``arm``: with that template
        instead of :attr:`arm`)."""
        goal = parse_pose(pose)
        source = dict(self.source, pose=[float(v) for v in pin.SE3ToXYZQUAT(goal)])
        goal = self._within_scale(goal)
        mech = copy.copy(self.robot)
        mech.closures = list(self.robot.closures)
        mech.locked = dict(self.robot.locked)
        mech.add_goal(self.frame, goal, self.base)
        arm = self.arm if arm is None else arm
        form: AnyFormulation | None = arm.formulation(mech, goal) if arm is not None else None
        if form is None and self.formulation == "general":
            form = choose_formulation(mech, formulation="general")
        return Problem(mech, f"ik {mech.name} {self.frame}", IK_SIGMA, source, formulation=form)

    def _within_scale(self, goal: pin.SE3) -> pin.SE3:
        """``goal``, or, for a goal beyond the frame's reach (:meth:`Mechanism.reach`), an equally
        unreachable goal of the same orientation at twice that distance, whose search proves the
        answer empty quickly and without overflow (a coordinate of 1e308 squared is infinite).
        A goal farther than :data:`~kinbox.errors.MAX_LENGTH` that no reach bound rules out is
        refused (tests/cli/test_hostile.py::test_far_pose_is_proven_empty)."""
        t = np.asarray(goal.translation, dtype=float)
        far = float(np.max(np.abs(t)))  # |t| >= far: no square, no overflow
        reach = self.robot.reach(self.frame) + self.robot.reach(self.base or "universe")
        if far > reach:
            return pin.SE3(goal.rotation, t / far * (2.0 * reach + 1.0))
        if far > MAX_LENGTH:
            raise InputError(f"pose position {far:g} is beyond the limit of {MAX_LENGTH:g} (the unit of the model's lengths)")
        return goal

    def solve(self, pose, **solver_options) -> Result:
        """Every configuration that puts the frame at ``pose``; a ``time_limit`` covers the
        formulation of the pose's problem too."""
        _start_clock(solver_options)
        solver_options.setdefault("policy", "quick")  # short searches (kinbox.search.policy.QUICK)
        collision_free = bool(solver_options.pop("collision_free", False))
        if self.scene is None and not collision_free:
            quick = self._closed_form_fast(pose, solver_options)
            if quick is not None:
                return quick
        fast = self._eigen6r_answer(pose, solver_options)
        if fast is None:
            prob = self.problem(pose)
            res = self._closed_form_or_search(prob, solver_options)
        else:
            res, prob = fast
        if self.scene is not None:
            self.scene.annotate(res, collision_free, prob.polish)
        elif collision_free:
            raise InputError("collision_free needs a scene (scene=..., --scene FILE)")
        if self.dof < 6:
            res.notes.append(_few_joints_note(self.dof, self.frame))
        return res

    def _closed_form_or_search(self, prob: Problem, solver_options: dict) -> Result:
        """The closed form's answer where it decides (:mod:`kinbox.answer.closed_form`), else
        the branch and prune's; ``closed_form=False`` asks for the latter."""
        use_closed_form = solver_options.pop("closed_form", True)
        all_turns = bool(solver_options.pop("all_turns", False))
        plain = not any(k in solver_options for k in ("workers", "executor", "resume"))
        if use_closed_form and plain and self.closed_form is not None:
            # the options are checked as the search would check them, then not needed
            check = {k: v for k, v in solver_options.items() if not (k == "relaxation" and v == "auto")}
            if solver.make_options(SolverOptions(sigma=prob.sigma), **check).sigma > MAX_SIGMA:
                return prob.solve(**solver_options)  # which refuses it
            from .answer.closed_form import closed_form_result

            fast = closed_form_result(
                self.closed_form, prob.formulation, prob.label, prob.sigma, prob.polish, prob.source, all_turns=all_turns
            )
            if fast is not None:
                return fast
        res = prob.solve(all_turns=all_turns, **solver_options)
        res.stats.setdefault("method", "branch-and-prune")
        return res

    def _closed_form_fast(self, pose, solver_options: dict, batch=None, k: int = 0) -> Result | None:
        """The closed form's answer of one pose certified in the joint angles, with what every
        pose shares computed once (:func:`kinbox.answer.closed_form.fast_result`), or None
        (no closed form, options it does not take, a pose it does not decide: the closed form
        with the system's certificate, then the branch and prune, as :meth:`_closed_form_or_search`)."""
        if not solver_options.get("closed_form", True) or any(k in solver_options for k in ("workers", "executor", "resume")):
            return None
        cf = self.closed_form
        if cf is None or cf.joint_certifier is None:
            return None
        check = {
            k: v for k, v in solver_options.items() if k not in ("closed_form", "all_turns") and not (k == "relaxation" and v == "auto")
        }
        if solver.make_options(SolverOptions(sigma=IK_SIGMA), **check).sigma > MAX_SIGMA:
            return None  # the search refuses it
        from .answer.closed_form import fast_result

        goal = parse_pose(pose)
        if float(np.max(np.abs(goal.translation))) > self._reach():
            return None  # beyond the reach: the search proves it empty
        V = pin.SE3ToXYZQUAT(goal)
        facts = self._facts()
        mech = copy.copy(self.robot)
        mech.closures = list(self.robot.closures)
        mech.locked = dict(self.robot.locked)
        ja, pa, jb, pb = self._anchors()
        mech.closures.append(Closure("weld", ja, pa, jb, pb * goal, name="goal"))
        source = dict(self.source, pose=[float(v) for v in V])
        all_turns = bool(solver_options.get("all_turns", False))
        return fast_result(cf, self.arm, facts, mech, goal, np.asarray(V, dtype=float), source, all_turns, batch, k)

    def _reach(self) -> float:
        if not hasattr(self, "_reach_value"):
            self._reach_value = self.robot.reach(self.frame) + self.robot.reach(self.base or "universe")
        return self._reach_value

    def _anchors(self):
        """The goal closure's anchors (:meth:`Mechanism.add_goal`), once."""
        if not hasattr(self, "_anchor_value"):
            self._anchor_value = (*self.robot.frame_anchor(self.frame), *self.robot.frame_anchor(self.base or "universe"))
        return self._anchor_value

    def _facts(self):
        """What every closed-form answer of this IK shares (:class:`~kinbox.answer.closed_form.ArmFacts`)."""
        if not hasattr(self, "_facts_value"):
            from .answer.closed_form import ArmFacts
            from .answer.result import applied_limits, q_names

            form = self.problem(pin.SE3.Identity()).formulation  # any pose: the same rows, joints and limits
            self._facts_value = ArmFacts(
                f"ik {self.robot.name} {self.frame}", q_names(self.robot.model), applied_limits(form), form.system.summary(), form.system.n
            )
        return self._facts_value

    @property
    def closed_form(self):
        """The closed form of this arm's family (:mod:`kinbox.formulation.families`), or None."""
        if not hasattr(self, "_closed_form"):
            from .formulation.families import detect
            from .search.closed_form import ClosedForm

            fam = detect(self.arm.geometry) if isinstance(self.arm, ArmTemplate) else None
            self._closed_form = ClosedForm(fam, self.arm) if fam is not None else None
        return self._closed_form

    @property
    def eigen6r(self):
        """The eigenvalue path of a general 6R arm (:mod:`kinbox.search.eigen6r`: six revolute
        joints of no closed-form family), on the arm formulation's system, or None."""
        if not hasattr(self, "_eigen6r_solver"):
            from .search.eigen6r import eigen_solver_of

            self._eigen6r_solver = None
            # a formulation asked for by name ("invariants", "general") is the one that answers
            if self.formulation in ("auto", "arm") and self.arm is not None and self.closed_form is None:
                arm = self.arm if isinstance(self.arm, ArmTemplate) else arm_template(self.robot, self.frame, self.base)
                self._eigen6r_solver = eigen_solver_of(arm) if arm is not None else None
        return self._eigen6r_solver

    def _eigen6r_answer(self, pose, solver_options: dict) -> tuple[Result, Problem] | None:
        """The eigenvalue path's answer of a pose where it decides (:mod:`kinbox.answer.eigen6r`),
        else None; ``closed_form=False`` (as for the closed form) asks for the search alone."""
        if not solver_options.get("closed_form", True) or any(k in solver_options for k in ("workers", "executor", "resume")):
            return None
        es = self.eigen6r
        if es is None:
            return None
        prob = self.problem(pose, es.arm)
        check = {
            k: v for k, v in solver_options.items() if k not in ("closed_form", "all_turns") and not (k == "relaxation" and v == "auto")
        }
        if solver.make_options(SolverOptions(sigma=prob.sigma), **check).sigma > MAX_SIGMA:
            return None  # the search refuses it
        from .answer.eigen6r import eigen_result

        all_turns = bool(solver_options.get("all_turns", False))
        res = eigen_result(es, prob.formulation, prob.label, prob.sigma, prob.polish, prob.source, all_turns=all_turns)
        return None if res is None else (res, prob)

    def solve_many(self, poses: Iterable, **solver_options) -> list[Result]:
        """Every solution of each pose, in order (the arm is formulated once for all of them).

        ``workers=N`` spreads the *poses* over N processes (0: one per core); each pose is
        then solved in one process, with the same answer as alone.
        """
        return list(self.solve_iter(poses, **solver_options))

    def solve_iter(self, poses: Iterable, workers: int | None = None, **solver_options) -> Iterator[Result]:
        """:meth:`solve_many`, one result at a time, in the order of ``poses``, each as soon as
        it is ready (with ``workers``, the poses after it may be solved already)."""
        goals = [parse_pose(p) for p in poses]
        if workers is None or len(goals) < 2:
            batch = solver_options.get("closed_form", True) and solver_options.get("resume") is None
            batch = batch and self.scene is None and not solver_options.get("collision_free")  # scenes: per pose
            if len(goals) > 1 and batch and self.closed_form:
                yield from self._solve_closed_form_batch(goals, **solver_options)
                return
            for g in goals:
                yield self.solve(g, **solver_options)
            return
        from .search.parallel import imap_tasks

        self.prepare()
        for blob in imap_tasks(_solve_one, [(g, solver_options) for g in goals], workers, initializer=_set_worker_ik, initargs=(self,)):
            yield _Unpickler(io.BytesIO(blob), self._shared()).load()

    def _solve_closed_form_batch(self, goals: list[pin.SE3], **solver_options) -> Iterator[Result]:
        """:meth:`solve_iter` through the compiled closed form
        (:func:`kinbox.search.closed_form.run_batch`, all poses at once, each root certified in
        the joint angles); a pose it does not decide is solved as :meth:`solve` solves it alone."""
        from .search.closed_form import run_batch

        cf = self.closed_form
        solver_options.pop("closed_form", None)
        R = np.array([g.rotation for g in goals])
        t = np.array([g.translation for g in goals])
        V = np.array([pin.SE3ToXYZQUAT(g) for g in goals]).reshape(len(goals), 7)
        batch = run_batch(cf, cf.certifier, R, t, V=V, certificate="joint")
        for k, g in enumerate(goals):
            fast = self._closed_form_fast(g, dict(solver_options), batch, k)
            yield fast if fast is not None else self.solve(g, **solver_options)

    def solve_array(self, poses, certify: bool | str = True, **solver_options):
        """Every solution of an (N, 7) array of poses (``x y z qx qy qz qw``) as flat arrays
        (:class:`kinbox.answer.closed_form.BatchAnswer`): compiled, no Python per pose, for an
        arm of a closed-form family (:mod:`kinbox.formulation.families`); the poses the closed
        form does not decide, and every pose of other arms, by the branch and prune.
        ``certify``: each closed-form root also by Krawczyk in the joint angles (True; or on the
        kinbox system: ``"system"``; False: the interval closed form is the proof)."""
        from .answer.closed_form import poses_array, solve_array

        R, t, V = poses_array(poses, parse_pose)
        cf = self.closed_form
        if cf is None:
            raise FormulationError(f"frame {self.frame!r} of {self.robot.name!r} is of no closed-form family: use solve_many")

        def fallback(k: int) -> Result:
            return self.solve(pin.SE3(R[k], t[k]), closed_form=False, **solver_options)

        return solve_array(cf, R, t, fallback, certify=certify, V=V)

    def _shared(self) -> dict[str, object]:
        """What every result of this IK refers to: sent by name between processes."""
        return {"arm": self._arm, "model": self.robot.model}

    def prepare(self) -> IK:
        """Build now what every pose needs (the arm template, the compiled kernels loaded), so
        that worker processes forked from this one find them ready; returns ``self``."""
        _ = self.arm
        load_kernels()
        return self


def _refuse_floating_base(robot, chain: Sequence[int], frame: str, where: str) -> None:
    """A free-flyer or planar joint (a floating base) in the chain of an IK, not locked, would
    move the whole robot to the goal: six more unknowns, a pose reached by a family of
    dimension six more. Refused, with the two ways out (test_floating_base_in_the_chain_is_refused)."""
    model = robot.model
    for j in chain:
        name = model.names[j]
        shortname = model.joints[j].shortname()
        if name in robot.locked or shortname not in ("JointModelFreeFlyer", "JointModelPlanar"):
            continue
        kind = "free-flyer" if shortname == "JointModelFreeFlyer" else "planar"
        held = ",".join(f"{v:g}" for v in pin.neutral(model)[model.joints[j].idx_q : model.joints[j].idx_q + model.joints[j].nq])
        child = next((f.name for f in model.frames if f.parentJoint == j and f.type == pin.FrameType.BODY), None)
        base = f", or place it relative to the floating body (--base {child})" if child else ""
        raise InputError(
            f"joint {name!r} of {robot.name!r} is a floating base ({kind}, {model.joints[j].nv} dof) that moves frame {where}: "
            f"lock it (--lock {name}={held}){base}"
        )


def _few_joints_note(dof: int, frame: str) -> str:
    """What an answer for a chain of fewer than six degrees of freedom means."""
    return (
        f"{dof} degree(s) of freedom move {frame!r}, fewer than the 6 of a pose: the goal over-determines them "
        f"(6 conditions on {dof} unknowns), so a reachable pose has isolated solutions and most poses none; kinbox "
        "certifies square systems only, so each solution is checked by Pinocchio forward kinematics (its residual), "
        "not certified"
    )


def load_kernels() -> None:
    """Load the search's compiled kernels (compiled and cached on disk after an install); the
    answer's curve tracer loads its own when it first follows a curve."""
    solver.load_kernels()


def load_all_kernels() -> None:
    """Load every compiled kernel of kinbox: the search's (:func:`load_kernels`), the curve
    tracer's and the answer's least squares. After an install the first call compiles and
    caches them all (``make setup`` does it once), so that no first solve of any kind compiles."""
    from .answer import trace
    from .search.lstsq import lstsq

    load_kernels()
    trace.load_kernel()
    A, b = np.ones((2, 1)), np.ones(2)
    lstsq(A, b)
    lstsq(A, b, 1e-12)


def _start_clock(solver_options: dict) -> None:
    """Set ``started`` (what a ``time_limit`` counts from) to now, unless given, once the
    compiled kernels are loaded: the limit covers loading the model and solving, not compiling
    the kernels, which the first solve after an install does (tens of seconds)."""
    if "started" not in solver_options:
        load_kernels()
        solver_options["started"] = time.perf_counter()


_WORKER_IK: IK | None = None  # the arm of a pose worker, formulated once per process


def _set_worker_ik(ik_: IK) -> None:
    global _WORKER_IK
    _WORKER_IK = ik_


def _solve_one(task) -> bytes:
    """A pose solved in a worker, pickled without what the master holds already (the arm
    template, the robot's model: most of a result's bytes), see :class:`_Pickler`."""
    goal, options = task
    ik_ = _WORKER_IK
    assert ik_ is not None
    out = io.BytesIO()
    _Pickler(out, ik_._shared()).dump(ik_.solve(goal, **options))
    return out.getvalue()


class _Pickler(pickle.Pickler):
    """Pickles the objects of ``shared`` (name -> object) by name: the master puts its own in
    their place (:class:`_Unpickler`), the same objects (its IK is the one the worker has)."""

    def __init__(self, file, shared: dict[str, object]):
        super().__init__(file, protocol=pickle.HIGHEST_PROTOCOL)
        self.names = {id(v): k for k, v in shared.items() if v is not None}

    def persistent_id(self, obj):
        return self.names.get(id(obj))


class _Unpickler(pickle.Unpickler):
    def __init__(self, file, shared: dict[str, object]):
        super().__init__(file)
        self.shared = shared

    def persistent_load(self, pid):
        return self.shared[pid]


def ik(
    robot,
    frame: str,
    pose,
    base: str | None = None,
    lock: Locks | None = None,
    scene=None,
    srdf: str | None = None,
    **solver_options,
) -> Result:
    """Every configuration of ``robot`` that puts ``frame`` at ``pose`` (within joint limits).

    ``robot``: a ``pinocchio.Model``, a URDF path, or an example-robot-data name;
    ``pose``: a ``pinocchio.SE3`` or ``[x, y, z, qx, qy, qz, qw]``, in ``base`` (default: world);
    ``lock``: joints held fixed, ``{name: value}``. Solver options: ``sigma``, ``time_limit``,
    ``max_boxes``, ``progress``, ``workers``. An unreachable pose gives no solution and
    ``complete=True``. ``scene``: a scene file, built-in scene name or dict
    (:mod:`kinbox.model.scene`): every solution gets its collision verdict;
    ``collision_free=True`` keeps the free ones; ``srdf``: the robot's disabled pairs.
    """
    _start_clock(solver_options)  # the limit covers loading too
    return IK(robot, frame, base, lock, scene=scene, srdf=srdf).solve(pose, **solver_options)


class Scene:
    """A collision scene of a loaded robot, its geometry built at once (and again in each
    worker process that receives it pickled: the geometry is not pickled)."""

    def __init__(self, mechanism: Mechanism, robot, scene, srdf: str | None = None):
        from .model.scene import read_scene

        self.spec = read_scene(scene)
        self.name = self.spec.source or self.spec.name
        self.mechanism = mechanism
        self.robot = robot if isinstance(robot, str) else None
        if srdf is not None and not os.path.isfile(srdf):
            raise InputError(f"no SRDF file {srdf!r}")
        self._robot = robot
        self.srdf = srdf
        self._built = None
        self._checker: Checker | None = None
        _ = self.collision  # a bad mesh or name is reported now, not after the first search

    def __getstate__(self):
        return {**self.__dict__, "_built": None, "_checker": None}

    @property
    def collision(self):
        """The :class:`~kinbox.model.scene.CollisionScene` (built at the first use)."""
        if self._built is None:
            from .model.scene import build_scene

            self._built = build_scene(self.mechanism, self._robot, self.spec, self.srdf)
        return self._built

    def annotate(self, res: Result, collision_free: bool = False, polish=None) -> Result:
        from .answer.collision import Checker, annotate

        if self._checker is None or self._checker.scene is not self.collision:
            self._checker = Checker(self.collision)  # its Pinocchio and coal data, made once
        return annotate(res, self.collision, collision_free=collision_free, polish=polish, checker=self._checker)


def _as_configuration(model: pin.Model, q, chain: Sequence[int] = (), frame: str = "") -> np.ndarray:
    """Accept Pinocchio ``q`` (size nq) or one value per degree of freedom (size nv): from the
    neutral configuration, integrating ``v`` by the angles gives those angles for revolute
    (bounded or continuous) and prismatic joints. With ``chain`` (joint ids), values of those
    joints alone are accepted too (``q`` entries or angles), the others left neutral."""
    try:
        v = np.asarray(q, dtype=float).ravel()
    except (TypeError, ValueError):
        raise InputError(f"joint values must be numbers, got {q!r}") from None
    if not np.all(np.isfinite(v)):
        raise InputError(f"joint values are not finite: {v.tolist()}")
    if v.size == model.nq:
        return v
    if v.size == model.nv:
        return pin.integrate(model, pin.neutral(model), v)
    joints = [model.joints[j] for j in chain]
    cq, cv = sum(j.nq for j in joints), sum(j.nv for j in joints)
    if chain and v.size == cq:
        out = pin.neutral(model)
        k = 0
        for j in joints:
            out[j.idx_q : j.idx_q + j.nq] = v[k : k + j.nq]
            k += j.nq
        return out
    if chain and v.size == cv:
        dv = np.zeros(model.nv)
        k = 0
        for j in joints:
            dv[j.idx_v : j.idx_v + j.nv] = v[k : k + j.nv]
            k += j.nv
        return pin.integrate(model, pin.neutral(model), dv)
    also = ""
    if chain and (cq, cv) != (model.nq, model.nv):
        names = [model.names[j] for j in chain]
        also = f", or {cv} for the joints that move {frame!r} ({names[0]} .. {names[-1]})" if frame else ""
    raise InputError(f"{model.name or 'robot'} takes {model.nq} joint values (or {model.nv} angles){also}, got {v.size}")


# ----------------------------------------------------------------------------------------------
# mechanisms with loops
# ----------------------------------------------------------------------------------------------
def solve(
    mechanism,
    set: Mapping[str, float] | None = None,
    legs: str = "auto",  # noqa: A002
    formulation: str = "auto",
    scene=None,
    srdf: str | None = None,
    **solver_options,
) -> Result:
    """All configurations of ``mechanism`` (a built-in name, a file, or a Mechanism).

    ``set``: joints held at given values (leg lengths, input angles). ``legs``: equations of
    distance closures (legs of platforms): ``"squared"`` (fastest for isolated assembly modes) or
    ``"vector"`` (a unit vector per leg: tighter, for mobile platforms whose configurations form
    curves, see :func:`kinbox.formulation.build.formulate`); ``"auto"`` picks by the local
    dimension of the solution set (:func:`choose_formulation`). ``formulation``: ``"auto"`` (the
    planar formulation when every loop joint turns about parallel axes), ``"planar"`` or
    ``"general"``. Solver options:
    ``sigma`` (box size for positive-dimensional sets), ``time_limit``, ``max_boxes``,
    ``progress``, ``workers``. ``scene``: a scene (file, built-in name or dict) for a
    mechanism loaded from a URDF or MJCF file with collision shapes: every configuration gets
    its collision verdict, every curve its free stretches (``collision_free=True`` keeps the
    free isolated ones).
    """
    collision_free = bool(solver_options.pop("collision_free", False))
    mech = copy.copy(load(mechanism))
    mech.closures = list(mech.closures)
    mech.locked = dict(mech.locked)
    for name, value in (set or {}).items():
        mech.lock(name, value)
    if not mech.closures:
        raise FormulationError(f"{mech.name!r} has no loop closure and no goal: nothing to solve (for a serial arm use `kinbox ik`)")
    source = {
        "kind": "solve",
        "mechanism": mechanism if isinstance(mechanism, str) else None,
        "set": {k: float(v) for k, v in (set or {}).items()},
    }
    checker = Scene(mech, mechanism, scene, srdf) if scene is not None else None
    if checker is not None:
        source["scene"] = checker.name
    elif collision_free:
        raise InputError("collision_free needs a scene (scene=..., --scene FILE)")
    _start_clock(solver_options)  # the limit covers loading too
    prob = Problem(mech, f"solve {mech.name}", MECHANISM_SIGMA, source, formulation=choose_formulation(mech, legs, formulation))
    res = prob.solve(**solver_options)
    if checker is not None:
        checker.annotate(res, collision_free, prob.polish)
    vectors = any(prob.formulation.closure_vars.values())  # legs="auto" may have chosen them
    if (
        not res.complete
        and not vectors
        and any(c.kind == "distance" for c in mech.closures)
        and _on_a_curve(res.raw, prob.formulation.system)
    ):
        res.message += "; the configurations seem to form curves (a mobile platform): try legs='vector' (--legs vector)"
    return res


def _on_a_curve(raw: SolveResult, system: System, tries: int = 32) -> bool:
    """Signs that the solutions of a stopped search form curves: an uncertified solution box, or
    a solution point (Levenberg-Marquardt from the centres of the first pending boxes) at which
    the equations' Jacobian is rank-deficient. Isolated regular solutions show neither."""
    from scipy.optimize import least_squares

    if any(not b.certified for b in raw.boxes):
        return True
    comp = system.compile()
    if comp.n == 0:
        return False
    lo0, hi0 = system.search_domain()

    def jac(x):
        return comp.jacobian(x, slice(0, comp.n_eq))

    for lo, hi in raw.pending[:tries]:
        x = least_squares(comp.eval_eqs, 0.5 * (lo + hi), jac=jac, method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=200).x
        if not (np.all(np.isfinite(x)) and np.all(x >= lo0) and np.all(x <= hi0)):
            continue
        if np.max(np.abs(comp.eval_eqs(x)), initial=0.0) > 1e-9:
            continue
        sv = np.linalg.svd(jac(x), compute_uv=False)
        if len(sv) < comp.n or sv[-1] <= 1e-8 * sv[0]:
            return True
    return False


# ----------------------------------------------------------------------------------------------
# geometric constraint systems
# ----------------------------------------------------------------------------------------------
#: box size below which the search stops splitting on a constraint system (positive-dimensional
#: sets are drawn at this resolution; isolated assemblies are certified whatever the size)
CONSTRAINTS_SIGMA = 0.05
CONSTRAINT_FORMULATIONS = ("auto", "coordinates", "distances")


class Assemble:
    """A constraint system prepared once: diagnosed (degrees of freedom, redundant and
    inconsistent constraints), formulated, solved on demand.

    ``formulation``: ``"coordinates"`` (:mod:`kinbox.formulation.geometry`), ``"distances"``
    (:mod:`kinbox.formulation.distance`, systems of points and lines under distances only) or
    ``"auto"`` (see :func:`choose_constraint_formulation`). An inconsistent system raises
    :class:`~kinbox.errors.InconsistentError` naming a minimal set of inconsistent constraints
    (proven by a complete search on that set) unless ``check=False``.
    """

    def __init__(
        self,
        system,
        set: Mapping[str, float] | None = None,
        formulation: str = "auto",  # noqa: A002
        check: bool = True,
    ):
        from .answer.diagnosis import diagnose, refuse_if_inconsistent
        from .model.constraints import load_constraints

        if formulation not in CONSTRAINT_FORMULATIONS:
            raise InputError(f"formulation must be one of {', '.join(CONSTRAINT_FORMULATIONS)}, got {formulation!r}")
        self.model = load_constraints(system).with_parameters(set)
        self.source = {
            "kind": "constraints",
            "system": system if isinstance(system, str) else None,
            "set": {k: float(v) for k, v in (set or {}).items()},
        }
        self.diagnosis = diagnose(self.model) if check else None
        if self.diagnosis is not None:
            refuse_if_inconsistent(self.model, self.diagnosis)
        self.formulation = choose_constraint_formulation(self.model, self.diagnosis) if formulation == "auto" else formulation
        pin = self.diagnosis.pin if self.diagnosis is not None else None
        from .formulation.geometry import formulate as formulate_geometry

        self.geometry = formulate_geometry(self.model, pin=pin)
        if self.diagnosis is not None:  # after the formulation's own refusals (an unbounded entity)
            refuse_if_underconstrained(self.model, self.diagnosis)
        if self.diagnosis is not None and self.diagnosis.solution is not None:
            # redundant constraints: a square core of full rank at the solution found, for Krawczyk
            from .answer.diagnosis import in_frame
            from .formulation.geometry import square_core

            places, poses = in_frame(self.model, self.geometry, *self.diagnosis.solution)
            square_core(self.geometry.system, self.geometry.encode(places, poses))
        self.distances = None
        if self.formulation == "distances":
            from .formulation.distance import formulate as formulate_distances

            at = self.diagnosis.solution[0] if self.diagnosis is not None and self.diagnosis.solution else None
            try:
                self.distances = formulate_distances(self.model, self.geometry, at=at)
            except FormulationError:
                # auto never picks a formulation that refuses the system (four points with six
                # distances: test_auto_formulation_never_refuses); an explicit choice is refused
                if formulation != "auto":
                    raise
                self.formulation = "coordinates"

    @property
    def system(self) -> System:
        return self.distances.system if self.distances is not None else self.geometry.system

    @single_threaded
    def solve(self, workers: int | None = None, executor=None, resume: SearchState | None = None, **solver_options):
        """Search and decode. ``resume``: a stopped search of this system (``result.raw.state``,
        or :meth:`SearchState.load`); ``started``: the ``time.perf_counter()`` a ``time_limit``
        counts from (default: now)."""
        import functools

        from .answer.assembly import build_assembly_result, distance_assemblies

        _start_clock(solver_options)
        opts = solver.make_options(SolverOptions(sigma=CONSTRAINTS_SIGMA), **solver_options)
        raw = solve_system(self.system, opts, workers=workers, executor=executor, resume=resume)
        diag = self.diagnosis.to_dict() if self.diagnosis is not None else {}
        decode = None
        if self.distances is not None:
            decode = functools.partial(distance_assemblies, self.distances)

        def build(raw: SolveResult):
            return build_assembly_result(
                f"assemble {self.model.name}",
                raw,
                self.geometry,
                opts.sigma,
                decode=decode,
                formulation=self.formulation,
                source=self.source,
                diagnosis=diag,
            )

        res = build(raw)
        while redo := unconfirmed_curve_boxes(raw, res.components):
            raw = solver.search_again(self.system, raw, redo, opts)
            res = build(raw)
        return res


#: a system whose assemblies form families of this dimension or more is refused before the
#: search: boxes cannot sample a surface to sigma in reasonable time, and the answer would
#: say nothing the diagnosis does not (test_underconstrained_system_is_refused_at_once)
MAX_FAMILY_DIMENSION = 1


def refuse_if_underconstrained(model, diagnosis) -> None:
    """Refuse (:class:`InputError`, one line) a system the diagnosis found under-constrained
    both generically and at its solution by more than :data:`MAX_FAMILY_DIMENSION` degrees of
    freedom (rigid motions of a system with nothing fixed taken out): its degrees of freedom,
    the entities or bodies left free, and what to do. Curves (one degree of freedom) and
    isolated assemblies are solved."""
    d = diagnosis
    if d.dof is None or d.generic_dof is None or min(d.dof, d.generic_dof) <= MAX_FAMILY_DIMENSION:
        return
    dof = min(d.dof, d.generic_dof)
    free = ", ".join(f"{n} ({k} dof)" for n, k in d.underconstrained.items()) or "?"
    raise InputError(
        f"{model.name} is under-constrained: {dof} degrees of freedom (`kinbox check` shows them), so its assemblies "
        f"form families of dimension {dof}, not isolated assemblies or curves; free: {free}; fix entities or bodies "
        f'("fixed") or add constraints to take away {dof - MAX_FAMILY_DIMENSION} or more (all {dof} for isolated assemblies)'
    )


def choose_constraint_formulation(model, diagnosis=None) -> str:
    """The formulation ``"auto"`` picks: ``"distances"`` for the pure distance problems of
    Porta et al. 2005 -- free points only (nothing fixed, no body, no line) under point-point distances,
    with isolated assemblies expected (the diagnosis found no degree of freedom at its
    solution) -- else ``"coordinates"`` (tests/answer/test_assemble.py, automatic choice of
    formulation). Measured by ``benchmarks/constraints.py``: the distance
    formulation took fewer boxes on the octahedral manipulators, more on the tangent lines,
    the cyclohexane's curve and the Stewart platform."""
    from .formulation.distance import supports

    if supports(model) is not None or model.has_fixed or model.bodies:
        return "coordinates"
    if any(e.type != "point" for e in model.entities.values()):
        return "coordinates"
    if diagnosis is None or diagnosis.dof != 0:
        return "coordinates"
    return "distances"


def assemble(
    system,
    set: Mapping[str, float] | None = None,
    formulation: str = "auto",  # noqa: A002
    check: bool = True,
    **solver_options,
):
    """Every assembly of a geometric constraint system (a file, a built-in name or a dict).

    ``set``: parameter values; ``formulation``: ``"auto"``, ``"coordinates"`` or
    ``"distances"``. Solver options: ``sigma``, ``time_limit``, ``max_boxes``, ``progress``,
    ``workers``; ``resume``: a stopped search of this system. Returns an
    :class:`~kinbox.answer.assembly.AssemblyResult`.
    """
    _start_clock(solver_options)  # the limit covers diagnosis too
    return Assemble(system, set, formulation, check).solve(**solver_options)
