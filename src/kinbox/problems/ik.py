"""Inverse kinematics: every configuration of an arm that puts a frame at a pose.

:class:`IK` prepares an arm once for many poses of one frame (the arm template, the closed
form of its family); each pose is one joint-space :class:`~kinbox.problems.mechanism.Problem`.
:func:`ik` is one pose; :meth:`IK.solve_iter` many (:mod:`kinbox.problems.batch`, the one pose-batch
path of the API and ``kinbox ik --poses``).
"""

from __future__ import annotations

import copy
import time
from collections.abc import Iterable, Iterator, Sequence
from types import SimpleNamespace
from typing import Any

import numpy as np
import pinocchio as pin

from ..answer.result import Result
from ..errors import MAX_LENGTH, FormulationError, InputError
from ..formulation.arm import ArmTemplate, arm_template
from ..formulation.arm_invariants import InvariantsTemplate, invariants_template
from ..model.loading import load
from .choices import ARM_FORMULATIONS
from .mechanism import AnyFormulation, Locks, Problem, choose_formulation
from .run import load_kernels, options_of, start_clock
from .scene import Scene

#: box size below which a search stops splitting: IK answers are isolated points (certified
#: by Krawczyk whatever the box size)
IK_SIGMA = 1e-4


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
        v = np.array(pose, dtype=float).ravel()  # a copy: the quaternion is normalised below, not the caller's
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
        start_clock(solver_options)
        solver_options.setdefault("policy", "quick")  # short searches (kinbox.search.policy.QUICK)
        collision_free = bool(solver_options.pop("collision_free", False))
        prune_opt = solver_options.pop("prune_scene", None)  # on by default where it can run (docs/scenes.md)
        prune = bool(collision_free and self.scene is not None) if prune_opt is None else bool(prune_opt)
        if prune and (self.scene is None or not collision_free):
            raise InputError("prune_scene needs a scene and collision_free (--scene FILE --collision-free)")
        if collision_free and self.scene is None:
            raise InputError("collision_free needs a scene (scene=..., --scene FILE)")
        quick = self._closed_form_fast(pose, solver_options)
        if quick is None:
            quick = self._eigen6r_answer(pose, solver_options)
        if quick is not None:  # isolated roots only: the scene's verdicts need no polishing
            if self.scene is not None:
                self.scene.annotate(quick, collision_free, None)
            return quick
        prob = self.problem(pose)
        if prune and self.scene is not None:  # boxes in no free configuration discarded in the search (docs/scenes.md)
            prob.formulation.system.exclude = self.scene.pruner(prob.formulation)  # this pose's own system
        res = self._closed_form_or_search(prob, solver_options)
        if self.scene is not None:
            self.scene.annotate(res, collision_free, prob.polish)
            exclude = getattr(getattr(prob.formulation, "system", None), "exclude", None)
            if exclude is not None:  # counted in this process (a parallel search's workers count their own)
                res.stats["collision"]["pruning"] = {"tested": exclude.calls, "discarded": exclude.pruned}
        if self.dof < 6:
            res.notes.append(_few_joints_note(self.dof, self.frame))
        return res

    def _closed_form_or_search(self, prob: Problem, solver_options: dict) -> Result:
        """The closed form's answer where it decides (:mod:`kinbox.answer.closed_form`), else
        the branch and prune's; ``closed_form=False`` asks for the latter, and with
        ``within_enclosures`` for the search inside the closed form's enclosures alone (where
        they bound the roots: the sound part of its answers, cheaper than the seeded count of
        :meth:`_seeded` with its one-root check), else of the whole domain."""
        use_closed_form = solver_options.pop("closed_form", True)
        within_enclosures = bool(solver_options.pop("within_enclosures", False))
        all_turns = bool(solver_options.pop("all_turns", False))
        plain = not any(k in solver_options for k in ("workers", "executor", "resume"))
        if use_closed_form and plain and self.dof == 7 and self.sweeper is not None:
            fast = self.sweeper.solve(prob, self._within_scale(parse_pose(prob.source["pose"])))
            if fast is not None:
                return fast
        if use_closed_form and plain and self.closed_form is not None:
            options_of(prob, dict(solver_options))  # checked as a search checks them (a sigma too large refused), then not needed
            from ..answer.closed_form import closed_form_result

            fast = closed_form_result(
                self.closed_form, prob.formulation, prob.label, prob.sigma, prob.polish, prob.source, all_turns=all_turns
            )
            if fast is None:
                fast = self._seeded(prob, all_turns)
            if fast is not None:
                return fast
        if use_closed_form and plain:
            curve = self._wrist_curve(prob, all_turns, solver_options)
            if curve is not None:
                return curve
        within = self._enclosures(prob) if (use_closed_form or within_enclosures) and plain else None
        # the copies q + 2 pi k listed after a near-double pair is separated (one per root)
        if within is not None:
            res = prob.solve(all_turns=False, within=within, **solver_options)
            res.stats["searched"] = {"closed-form enclosures": len(within)}
        else:
            res = prob.solve(all_turns=False, **solver_options)
        res.stats.setdefault("method", "branch-and-prune")
        res = self._separated(res, prob)
        res = self._in_angles(res, prob)
        if all_turns or res.stats.get("separated") or res.stats.get("proven_in_angles"):
            from ..answer.separate import turns_again

            turns_again(res, all_turns)
        return res

    def _separated(self, res: Result, prob: Problem) -> Result:
        """``res`` with each near-double pair it reports as one point separated into two
        certified roots where the joint angles prove them (:mod:`kinbox.answer.separate`)."""
        from ..formulation.arm import ArmFormulation

        if self.dof != 6 or not isinstance(prob.formulation, ArmFormulation) or prob.formulation.arm is not self.arm:
            return res
        cf = self.closed_form
        if cf is None or cf.joint_certifier is None:
            return res
        if not any(not s.certified and s.multiplicity == 2 for s in res.solutions):
            return res
        from ..answer.separate import separate_clusters

        if not hasattr(self, "_exact_constants"):  # the model's exact links and frames, once per arm
            from ..formulation.constants import enclose_links

            self._exact_constants = enclose_links(self.arm.geometry, self.arm.mechanism, self.frame, self.base, keep_exact=True)
        return separate_clusters(res, self.arm, cf.joint_certifier, np.asarray(prob.source["pose"], dtype=float), self._exact_constants)

    def _in_angles(self, res: Result, prob: Problem) -> Result:
        """``res`` through the general formulation with its uncertified roots proven in the
        joint angles where a six-revolute arm's can be (:mod:`kinbox.answer.angle_proof`)."""
        if self.dof != 6 or self.formulation != "general" or res.formulation != "general":
            return res
        if not any(not s.certified for s in res.solutions) and not res.undecided:
            return res
        if not hasattr(self, "_angle_arm"):  # the arm and its exact links and frames, once per IK
            from ..formulation.constants import enclose_links

            arm = arm_template(self.robot, self.frame, self.base)
            exact = enclose_links(arm.geometry, arm.mechanism, self.frame, self.base, keep_exact=True) if arm is not None else None
            self._angle_arm = (arm, exact)
        arm, exact = self._angle_arm
        if arm is None:
            return res
        from ..answer.angle_proof import certify_in_angles

        return certify_in_angles(res, arm, np.asarray(prob.source["pose"], dtype=float), exact)

    def _closed_form_goal(self, prob: Problem) -> tuple[Any, ArmTemplate, pin.SE3] | None:
        """The six-joint closed form, the arm template it solves and ``prob``'s goal in the
        arm's scale, where ``prob`` is formulated on that template; else None."""
        cf, arm = self.closed_form, self.arm
        if cf is None or self.dof != 6 or not isinstance(arm, ArmTemplate):
            return None
        from ..formulation.arm import ArmFormulation

        if not isinstance(prob.formulation, ArmFormulation):
            return None
        return cf, arm, self._within_scale(parse_pose(prob.source["pose"]))

    def _seeded(self, prob: Problem, all_turns: bool) -> Result | None:
        """The closed form's answer of a pose whose roots it counts but its certificates do not
        prove (next to a singularity), each root certified on the pose's system from Newton's
        point (:mod:`kinbox.search.cf_seeded`), or None."""
        given = self._closed_form_goal(prob)
        if given is None:
            return None
        cf, arm, goal = given
        from ..answer.closed_form import closed_form_result
        from ..search.certify import Certifier
        from ..search.cf_seeded import relaxed_roots, seeded_roots

        bound = relaxed_roots(cf, goal.rotation, goal.translation)
        if bound is None:  # no bound on the roots (a wrist singularity): nothing to certify
            return None
        lo0, hi0 = prob.system.search_domain()
        pose = np.asarray(prob.source["pose"], dtype=float)
        batch = seeded_roots(cf, Certifier(prob.system.compile()), goal.rotation, goal.translation, lo0, hi0, bound, pose)
        if batch is None:
            return None
        res = closed_form_result(cf, prob.formulation, prob.label, prob.sigma, prob.polish, prob.source, batch=batch, all_turns=all_turns)
        if res is not None:
            res.stats["certificate"] = "system, from Newton's point"
        return res

    def _wrist_curve(self, prob: Problem, all_turns: bool, solver_options: dict) -> Result | None:
        """The curves of a pose at a wrist singularity of an arm of three parallel axes, in closed
        form (:mod:`kinbox.search.cf_curve`, :mod:`kinbox.answer.cf_curve`), with the isolated
        roots of a joint-1 branch whose wrist is not singular from the branch and prune of its
        enclosures; None where that does not apply (the pose is then searched as before)."""
        given = self._closed_form_goal(prob)
        if given is None or given[0].code != 3:
            return None
        t0, c0 = time.perf_counter(), time.process_time()
        cf, arm, goal = given
        from ..answer.cf_curve import curve_points, wrist_curve_result
        from ..search.cf_curve import wrist_curves

        comp = prob.system.compile()
        wc = wrist_curves(cf, goal.rotation, goal.translation, lambda th: curve_points(cf, [th], goal, comp) is not None)
        if wc is None or not wc.curves:
            return None
        points = curve_points(cf, [c.theta for c in wc.curves], goal, comp)
        if points is None:  # not the singular arm's curve (a pose next to the singularity)
            return None
        lo0, hi0 = prob.system.search_domain()
        p, rad = arm.params_enclosure(goal)
        params = (p - 2.0 * rad, p + 2.0 * rad)
        rest = None
        if wc.others:
            from ..search.cf_fallback import MAX_BOXES, system_boxes

            boxes = system_boxes(cf, wc.others, lo0, hi0, params, wc.other_pairs)
            if boxes is None or len(boxes) > MAX_BOXES:
                return None
            if boxes:
                rest = prob.solve(all_turns=all_turns, within=boxes, **solver_options)
                if rest.curves or not rest.complete:  # a curve there too, or a budget hit: searched as before
                    return None
                rest.stats["searched"] = {"closed-form enclosures": len(boxes)}
        from ..search.cf_curve import curve_boxes

        def arcs(encs: list, x: np.ndarray) -> list:
            return curve_boxes(cf, encs, lo0, hi0, params, x, comp)

        return wrist_curve_result(cf, wc, points, prob.formulation, prob.label, prob.source, rest, (t0, c0), all_turns, arcs)

    def _enclosures(self, prob: Problem) -> list | None:
        """Boxes of ``prob``'s system holding every root of its pose, from the closed form with
        its undecided steps relaxed (:mod:`kinbox.search.cf_fallback`), or None (no closed
        form, or it decides nothing: the whole domain is searched)."""
        given = self._closed_form_goal(prob)
        if given is None:
            return None
        cf, arm, goal = given
        from ..search.cf_fallback import MAX_BOXES, folded_enclosures, system_boxes

        got = folded_enclosures(cf, goal.rotation, goal.translation)
        if got is None:
            return None
        encs, pairs = got
        lo0, hi0 = prob.system.search_domain()
        p, rad = arm.params_enclosure(goal)
        boxes = system_boxes(cf, encs, lo0, hi0, (p - 2.0 * rad, p + 2.0 * rad), pairs)
        return boxes if boxes is not None and len(boxes) <= MAX_BOXES else None

    @property
    def sweeper(self):
        """For seven joints: the sweep of an end joint through the closed form of the other
        six (:class:`kinbox.problems.selfmotion.Sweeper`), or None where no end joint gives a family."""
        if not hasattr(self, "_sweeper"):
            from .selfmotion import Sweeper

            self._sweeper = Sweeper.of(self) if self.dof == 7 and self.formulation == "auto" else None
        return self._sweeper

    def _closed_form_fast(self, pose, solver_options: dict, batch=None, k: int = 0) -> Result | None:
        """The closed form's answer of one pose certified in the joint angles (pose ``k`` of
        ``batch`` if given), with what every pose shares computed once
        (:func:`kinbox.answer.closed_form.fast_result`), or None (no closed form, options it
        does not take, a pose it does not decide: then the other paths, as before)."""
        if not self._fast_allowed(solver_options):
            return None
        cf = self.closed_form
        if cf is None or cf.joint_certifier is None:
            return None
        given = self._fast_inputs(pose, solver_options)
        if given is None:
            return None
        from ..answer.closed_form import fast_result

        goal, V, mech, source, all_turns = given
        if batch is not None:
            return fast_result(cf, self.arm, self._facts(), mech, goal, V, source, all_turns, batch, k)
        # the pose through the one-pose path (kinbox.answer.cf_pose), its kernel's time and, the
        # first time, its loading counted in the answer's stats as fast_result counts its own
        from ..search.loading import load_clock

        plan = self._one_pose("joint")
        one, load = None, 0.0
        if plan is not None:
            t0, c0 = time.perf_counter(), time.process_time()
            if plan.bound:
                one = plan.batch(V, goal.rotation)
            else:
                with load_clock() as clock:
                    one = plan.batch(V, goal.rotation)
                load = clock.seconds
        if one is None:  # a pose the closed form leaves to the other paths (or not taken): as before
            return fast_result(cf, self.arm, self._facts(), mech, goal, V, source, all_turns)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        res = fast_result(cf, self.arm, self._facts(), mech, goal, V, source, all_turns, one, 0)
        if res is not None:
            res.stats["seconds"] += wall
            res.stats["cpu_seconds"] += cpu
            res.stats["load_seconds"] = load
        return res

    @staticmethod
    def _fast_allowed(solver_options: dict) -> bool:
        """Whether the options leave a pose to a fast path (the closed form, the eigenvalue path):
        not where they ask for the search (``closed_form=False``, workers, a resume) or for a
        resolution the search refuses."""
        if not solver_options.get("closed_form", True) or any(k in solver_options for k in ("workers", "executor", "resume")):
            return False
        # the verdict of options seen before, the start of the clock aside (a number that only
        # a time limit reads): the options of every pose of a loop are checked once
        key = None
        if isinstance(solver_options.get("started", 0.0), float):
            try:
                key = frozenset((k, type(v), v) for k, v in solver_options.items() if k != "started")
                hit = _FAST_ALLOWED.get(key)
            except TypeError:  # an option's value that is not hashable: checked each time
                key, hit = None, None
            if hit is not None:
                return hit
        verdict = IK._check_fast(solver_options)
        if key is not None and len(_FAST_ALLOWED) < 256:
            _FAST_ALLOWED[key] = verdict
        return verdict

    @staticmethod
    def _check_fast(solver_options: dict) -> bool:
        from ..search import solver
        from ..search.solver import SolverOptions
        from .run import MAX_SIGMA

        check = {
            k: v for k, v in solver_options.items() if k not in ("closed_form", "all_turns") and not (k == "relaxation" and v == "auto")
        }
        return solver.make_options(SolverOptions(sigma=IK_SIGMA), **check).sigma <= MAX_SIGMA

    def _fast_inputs(self, pose, solver_options: dict):
        """What a fast path needs of one pose: the goal, its XYZQUAT, the mechanism with the goal's
        closure, the answer's source and ``all_turns``; or None where the pose lies beyond the
        reach (the search proves it empty)."""
        from ..model.mechanism import Closure

        goal = parse_pose(pose)
        if float(np.max(np.abs(goal.translation))) > self._reach():
            return None
        V = np.asarray(pin.SE3ToXYZQUAT(goal), dtype=float)
        mech = copy.copy(self.robot)
        mech.closures = list(self.robot.closures)
        mech.locked = dict(self.robot.locked)
        ja, pa, jb, pb = self._anchors()
        mech.closures.append(Closure("weld", ja, pa, jb, pb * goal, name="goal"))
        source = dict(self.source, pose=[float(v) for v in V])
        return goal, V, mech, source, bool(solver_options.get("all_turns", False))

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
            from ..answer.closed_form import ArmFacts
            from ..answer.result import applied_limits, q_names
            from ..answer.turns import wrapping_joints

            form = self.problem(pin.SE3.Identity()).formulation  # any pose: the same rows, joints, limits and mechanism
            self._facts_value = ArmFacts(
                f"ik {self.robot.name} {self.frame}", q_names(self.robot.model), applied_limits(form), form.system.summary(), form.system.n,
                wrapping_joints(SimpleNamespace(formulated=form)),
            )  # fmt: skip
        return self._facts_value

    @property
    def closed_form(self):
        """The closed form of this arm's family (:mod:`kinbox.formulation.families`), or None."""
        if not hasattr(self, "_closed_form"):
            from ..formulation.families import detect
            from ..search.cf_batch import closed_form

            fam = detect(self.arm.geometry) if isinstance(self.arm, ArmTemplate) else None
            self._closed_form = closed_form(fam, self.arm) if fam is not None else None
        return self._closed_form

    @property
    def eigen6r(self):
        """The eigenvalue path of a general 6R arm (:mod:`kinbox.search.eigen6r`: six revolute
        joints of no closed-form family), on the arm formulation's system, or None."""
        if not hasattr(self, "_eigen6r_solver"):
            from ..search.eigen6r import eigen_solver_of

            self._eigen6r_solver = None
            # a formulation asked for by name ("invariants", "general") is the one that answers
            if self.formulation in ("auto", "arm") and self.arm is not None and self.closed_form is None:
                arm = self.arm if isinstance(self.arm, ArmTemplate) else arm_template(self.robot, self.frame, self.base)
                self._eigen6r_solver = eigen_solver_of(arm) if arm is not None else None
        return self._eigen6r_solver

    def _eigen6r_answer(self, pose, solver_options: dict) -> Result | None:
        """The eigenvalue path's answer of a pose where it decides
        (:func:`kinbox.answer.eigen6r.fast_result`), else None; ``closed_form=False`` (as for
        the closed form) asks for the search alone."""
        if not self._fast_allowed(solver_options):
            return None
        es = self.eigen6r
        if es is None:
            return None
        given = self._fast_inputs(pose, solver_options)
        if given is None:
            return None
        from ..answer.eigen6r import fast_result

        goal, V, mech, source, all_turns = given
        return fast_result(es, self._eigen_facts(es), mech, goal, V, source, all_turns)

    def _eigen_facts(self, es):
        """What every eigenvalue answer of this IK shares (as :meth:`_facts`, on the arm
        formulation of the eigenvalue path)."""
        if not hasattr(self, "_eigen_facts_value"):
            from ..answer.closed_form import ArmFacts
            from ..answer.result import applied_limits, q_names

            form = self.problem(pin.SE3.Identity(), es.arm).formulation
            self._eigen_facts_value = ArmFacts(
                f"ik {self.robot.name} {self.frame}", q_names(self.robot.model), applied_limits(form), form.system.summary(), form.system.n
            )
        return self._eigen_facts_value

    def solve_many(self, poses: Iterable, **solver_options) -> list[Result]:
        """Every solution of each pose, in order (the arm is formulated once for all of them).

        ``workers=N`` spreads the *poses* over N processes (0: one per core); each pose is
        then solved in one process, with the same answer as alone.
        """
        return list(self.solve_iter(poses, **solver_options))

    def solve_iter(self, poses: Iterable, workers: int | None = None, **solver_options) -> Iterator[Result]:
        """:meth:`solve_many`, one result at a time, in the order of ``poses``, each as soon as
        it is ready (with ``workers``, the poses after it may be solved already)."""
        from .batch import answers

        goals = [parse_pose(p) for p in poses]
        for a in answers(self, goals, workers, **solver_options):
            assert a.result is not None
            yield a.result

    def solve_array(self, poses, certify: bool | str = True, **solver_options):
        """Every solution of an (N, 7) array of poses (``x y z qx qy qz qw``) as flat arrays
        (:class:`kinbox.answer.closed_form.BatchAnswer`): compiled, no Python per pose, for an
        arm of a closed-form family (:mod:`kinbox.formulation.families`); the poses the closed
        form does not decide (next to a singularity) by the branch and prune inside its
        enclosures where they bound the roots (``within_enclosures``: a few milliseconds, not
        the whole domain's search), and every pose of other arms by the branch and prune.
        ``certify``: each closed-form root also by Krawczyk in the joint angles (True; or on the
        kinbox system: ``"system"``; False: the interval closed form is the proof). One pose (a
        (1, 7) array) goes through the kernels with their buffers made once for the arm
        (:class:`kinbox.answer.cf_pose.OnePose`): the same answer, without the batch's per-call costs."""
        mode = "joint" if certify is True else (certify or "none")
        if isinstance(poses, np.ndarray) and poses.shape == (1, 7) and poses.dtype.kind == "f" and not solver_options:
            one = self._one_pose(mode)
            ans = one.solve(poses) if one is not None else None
            if ans is not None:
                return ans
        from ..answer.closed_form import poses_array, solve_array

        R, t, V = poses_array(poses, parse_pose)
        cf = self.closed_form
        if cf is None:
            raise FormulationError(f"frame {self.frame!r} of {self.robot.name!r} is of no closed-form family: use solve_many")

        def fallback(k: int) -> Result:
            return self.solve(pin.SE3(R[k], t[k]), closed_form=False, within_enclosures=True, **solver_options)

        return solve_array(cf, R, t, fallback, certify=certify, V=V)

    def _one_pose(self, mode: str):
        """The closed form of one pose with what every call shares built once
        (:class:`kinbox.answer.cf_pose.OnePose`) for certificate ``mode``, or None (no closed
        form, or a certificate it does not take)."""
        plans = self.__dict__.setdefault("_one_pose_plans", {})
        if mode not in plans:
            from ..answer.cf_pose import MODES, OnePose

            cf = self.closed_form
            ok = cf is not None and mode in MODES and (mode != "joint" or cf.joint_certifier is not None)
            plans[mode] = OnePose(cf, mode) if ok else None
        return plans[mode]

    def _shared(self) -> dict[str, object]:
        """What every result of this IK refers to: sent by name between processes."""
        return {"arm": self._arm, "model": self.robot.model}

    def prepare(self) -> IK:
        """Build now what every pose needs (the arm template, the compiled kernels loaded), so
        that worker processes forked from this one find them ready; returns ``self``."""
        _ = self.arm
        load_kernels()
        return self


#: :meth:`IK._fast_allowed`'s verdicts by options (the clock's start left out)
_FAST_ALLOWED: dict[frozenset, bool] = {}


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
    start_clock(solver_options)  # the limit covers loading too
    return IK(robot, frame, base, lock, scene=scene, srdf=srdf).solve(pose, **solver_options)


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
