"""The planar formulation's rows as enclosures of the model as given: a weld's angle enclosed
from the placements' exact values (``enclose_rows.PlanarConstants.weld``), and a model planar
only to ``PARALLEL_TOL`` sent to the general formulation (docs/soundness.md).

The 40-digit roots: Newton in mpmath on the model as given (its placements' rotations those of
their unit quaternions, translations their binary64 numbers, the goal its XYZQUAT:
``tests/support/oracles/mp_ik.py``), mapped to the planar system's variables (the cosine and
sine of each turning group's angle, the sum of its revolute joints' angles)."""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pinocchio as pin
import pytest

import kinbox
from kinbox.formulation import enclose_rows, planar
from kinbox.formulation.planar import PlanarFormulation, formulate_planar
from kinbox.problems.mechanism import choose_formulation
from tests.support.oracles import mp_ik, mp_mech

ARM = {"kind": "dh-arm", "dh": [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.8, 0.0, 0.0]]}


def _planar_root(chain: mp_ik.Chain, goal: pin.SE3, q0: np.ndarray) -> list:
    """The planar arm's root near ``q0`` at 40 digits: the tool's x, y and the sine of its
    angle to the goal's vanish (the arm turns about z exactly: its other rows vanish too)."""
    mp.mp.dps = mp_ik.WORK
    Rg, tg = mp_ik.exact_pose(goal)

    def f(*q):
        R, p, _, _ = chain.fk(q)
        D = Rg.T * R
        return [p[0] - tg[0], p[1] - tg[1], D[1, 0]]

    r = mp.findroot(f, [mp.mpf(float(v)) for v in q0], tol=mp.mpf(10) ** (-2 * mp_ik.DPS))
    q = [r[i] for i in range(len(q0))]
    R, p, _, _ = chain.fk(q)
    assert max(abs(p[k] - tg[k]) for k in range(3)) < mp.mpf(10) ** -mp_ik.DPS
    assert mp.mnorm(Rg.T * R - mp.eye(3)) < mp.mpf(10) ** -mp_ik.DPS
    return q


def _arm():
    """A planar 3R arm with a tip off its last joint's axis, turned by 0.7 rad: the weld's angle
    then moves the tip (the goal's rotation and the tip's placement both enter it)."""
    mech = kinbox.load(ARM)
    model = mech.model
    tool = model.getFrameId("tool")
    tip = pin.SE3(pin.exp3(np.array([0.0, 0.0, 0.7])), np.array([0.6, 0.25, 0.0]))
    model.addFrame(pin.Frame("tip", model.frames[tool].parentJoint, tool, tip, pin.FrameType.OP_FRAME))
    return mech


def _ik_case(q0=(0.3, 0.9, -0.4)):
    ik = kinbox.IK(_arm(), "tip")
    q0 = np.array(q0)
    goal = ik.pose_at(q0)
    res = ik.solve(goal, time_limit=60)
    assert isinstance(res.formulated, PlanarFormulation)
    chain = mp_ik.Chain(ik.robot.model, "tip")
    roots = [_planar_root(chain, goal, s.q) for s in res.solutions]
    return res, roots


def _welded_pair():
    """Two planar arms welded at their tips: a 2R arm (``j2``, ``j3``) and a 1R arm (``j5``)
    from the ground, the weld between the two moving tips (its angle turns one moving group
    into another), the weld's placement read off a configuration: a rigid loop, isolated
    assemblies. Returns the mechanism and that configuration."""
    from kinbox.model.mechanism import Closure, Mechanism

    model = pin.Model()

    def add(parent, xyz, name):
        place = pin.SE3(np.eye(3), np.array(xyz, dtype=float))
        return model.addJoint(parent, pin.JointModelRZ(), place, name, np.ones(1), np.ones(1), np.full(1, -4.0), np.full(1, 4.0))

    j2 = add(0, (0.0, 0.0, 0.0), "j2")
    j3 = add(j2, (1.0, 0.0, 0.0), "j3")
    j5 = add(0, (2.0, 0.3, 0.0), "j5")
    Pa = pin.SE3(pin.exp3(np.array([0.0, 0.0, 0.4])), np.array([0.9, 0.2, 0.0]))
    model.addFrame(pin.Frame("C", j3, 0, Pa, pin.FrameType.OP_FRAME))
    q = np.array([0.5, 1.1, 2.2])
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    Pb = data.oMi[j5].inverse() * data.oMi[j3] * Pa
    model.addFrame(pin.Frame("E", j5, 0, Pb, pin.FrameType.OP_FRAME))
    return Mechanism(model, [Closure("weld", j3, Pa, j5, Pb, name="weld")], name="welded-pair"), q


def _pair_root(model, q0) -> list:
    """The welded pair's assembly near ``q0`` at 40 digits: the tips' x, y and the sine of the
    angle between their frames vanish (every axis is exactly z: the other rows vanish too)."""
    mp.mp.dps = mp_ik.WORK
    C, E = mp_ik.Chain(model, "C"), mp_ik.Chain(model, "E")

    def f(q2, q3, q5):
        Rc, pc, _, _ = C.fk([q2, q3])
        Re, pe, _, _ = E.fk([q5])
        return [pc[0] - pe[0], pc[1] - pe[1], (Re.T * Rc)[1, 0]]

    r = mp.findroot(f, [mp.mpf(float(v)) for v in q0], tol=mp.mpf(10) ** (-2 * mp_ik.DPS))
    q = [r[i] for i in range(3)]
    assert max(abs(v) for v in f(*q)) < mp.mpf(10) ** -mp_ik.DPS
    return q


def _pair_case():
    mech, _ = _welded_pair()
    res = kinbox.solve(mech, time_limit=60)
    assert isinstance(res.formulated, PlanarFormulation)
    return res, [_pair_root(mech.model, s.q) for s in res.solutions]


def _held(res, roots) -> list[float]:
    """Per 40-digit root, its distance to the nearest certified box (0: inside)."""
    pf = res.formulated
    mp.mp.dps = 60
    gaps = []
    for q in roots:
        x = mp_mech.planar_point(pf, q)
        gap = np.inf
        for b in res.raw.boxes:
            if not b.certified:
                continue
            lo, hi = b.enclosure
            d = max(max(mp.mpf(float(lo[i])) - v, v - mp.mpf(float(hi[i]))) for i, v in x.items())
            gap = min(gap, max(float(d), 0.0))
        gaps.append(gap)
    return gaps


def test_a_welds_angle_is_enclosed_and_its_roots_certified_as_given():
    """A planar 3R arm's IK: the goal is a weld closure, its angle an ``atan2`` of the goal's
    rotation in binary64. Its cosine and sine are enclosed from the goal's and placements'
    exact values, so the rows carry ``merr`` (the shadow build covers the model) and every
    certified box holds the 40-digit root of the arm and pose as given."""
    res, roots = _ik_case()
    comp = res.formulated.system.compile()
    assert res.formulated.system.core_errors is not None and res.formulated.not_planar is None
    loops = [i for i, c in enumerate(c for c in res.formulated.system.constraints if c.kind == "core") if c.name.startswith("loop:")]
    assert loops and np.all(comp.merr[loops] > 0) and np.all(comp.merr[: comp.n_core] <= comp.slack[: comp.n_core])
    assert len(res.solutions) == 2 and all(s.certified for s in res.solutions)
    assert _held(res, roots) == [0.0, 0.0]


def test_a_weld_between_two_moving_bodies_is_certified_as_given():
    """A weld between two moving bodies (two arms welded at their tips) merges two turning
    groups: the enclosed offset is composed from both. Its rows carry ``merr`` and each
    assembly's certified box holds its 40-digit root of the model as given (the arm's
    configuration that placed the weld among them)."""
    res, roots = _pair_case()
    assert res.formulated.system.core_errors is not None and res.formulated.system.compile().merr.max() > 0
    assert res.complete and len(res.solutions) >= 2 and all(s.certified for s in res.solutions)
    _, q = _welded_pair()
    assert min(max(abs(float(r[i]) - q[i]) for i in range(3)) for r in roots) < 1e-9
    assert _held(res, roots) == [0.0] * len(roots)


def test_the_welds_constants_hold_their_exact_values():
    """Each weld-turned constant (a group's cosine and sine offset by the weld's angle) lies
    within its error of the exact value at 60 digits, for goals all around the circle (each
    ``atan2`` quadrant and the quaternion's branches)."""
    ik = kinbox.IK(_arm(), "tip")
    rng = np.random.default_rng(5)
    for q in rng.uniform(-np.pi, np.pi, (12, 3)):
        goal = ik.pose_at(q)
        mech = ik.problem(goal).mechanism
        ef = enclose_rows.PlanarConstants(mech, *planar._analyse(mech)[3:5], np.array([0.0, 0.0, 1.0]))
        weld = next(c for c in mech.closures if c.kind == "weld")
        z = ef.weld(int(weld.joint_a), weld.placement_a, int(weld.joint_b), weld.placement_b, "goal")
        mp.mp.dps = 60
        Rg, _ = mp_ik.exact_pose(goal)
        Rt = mp_ik.Chain(mech.model, "tip").fk([0, 0, 0])[0]  # the tip's frame at the reference
        Mx = Rg * Rt.T
        phi = mp.atan2(Mx[1, 0], Mx[0, 0])
        assert all(z[k].a <= v <= z[k].b for k, v in enumerate((mp.cos(phi), mp.sin(phi))))
        t = float(phi)
        ct, st = ef.turn(z, t)
        assert abs(mp.mpf(float(ct)) - mp.cos(phi)) <= ct.err and abs(mp.mpf(float(st)) - mp.sin(phi)) <= st.err
        assert ct.err < 1e-15 and st.err < 1e-15


def test_a_dropped_weld_enclosure_misses_the_root(monkeypatch):
    """The weld's angle off by 1e-11 in binary64 (an artificial error in the constant): the
    enclosure carries it (the rows' ``merr`` grows to it, the certified boxes still hold the
    40-digit roots); with the weld's errors dropped (its cosine and sine taken as exact) the
    certified boxes are of the perturbed rows and miss the roots."""
    angle = planar._weld_angle
    monkeypatch.setattr(planar, "_weld_angle", lambda v: angle(v) + 1e-11)
    res, roots = _ik_case()
    assert res.formulated.system.compile().merr.max() > 1e-12
    assert res.solutions and all(s.certified for s in res.solutions)
    assert _held(res, roots) == [0.0] * len(roots)
    turn = enclose_rows.PlanarConstants.turn

    def dropped(self, z, t):
        ct, st = turn(self, z, t)
        return enclose_rows.EF(float(ct), 0.0), enclose_rows.EF(float(st), 0.0)

    monkeypatch.setattr(enclose_rows.PlanarConstants, "turn", dropped)
    res0, roots0 = _ik_case()
    assert res0.solutions and all(s.certified for s in res0.solutions)
    assert min(_held(res0, roots0)) > 1e-12
    monkeypatch.setattr(enclose_rows.PlanarConstants, "turn", turn)  # the same, two moving bodies
    res, roots = _pair_case()
    assert res.solutions and all(s.certified for s in res.solutions) and _held(res, roots) == [0.0] * len(roots)
    monkeypatch.setattr(enclose_rows.PlanarConstants, "turn", dropped)
    res0, roots0 = _pair_case()
    assert res0.solutions and all(s.certified for s in res0.solutions)
    assert min(_held(res0, roots0)) > 1e-12


def _tilted(name: str, how: str):
    """``name`` with one revolute axis turned by 1e-13 rad out of the plane (``axis``), or one
    point closure's end lifted by 1e-13 out of it (``height``)."""
    mech = kinbox.load(name)
    model = mech.model
    if how == "axis":
        j = next(j for j in range(1, model.njoints) if model.joints[j].shortname().endswith("RZ"))
        M = model.jointPlacements[j]
        model.jointPlacements[j] = pin.SE3(pin.exp3(np.array([1e-13, 0.0, 0.0])) @ M.rotation, M.translation)
    else:
        c = next(c for c in mech.closures if c.kind == "point")
        c.placement_a = pin.SE3(c.placement_a.rotation, c.placement_a.translation + np.array([0.0, 0.0, 1e-13]))
    return mech


@pytest.mark.parametrize("name, how", [("four-bar", "axis"), ("four-bar", "height"), ("double-butterfly", "axis")])
def test_a_nearly_planar_model_goes_to_the_general_formulation(name, how):
    """A model planar only to ``PARALLEL_TOL`` is not planar as given: ``formulation="auto"``
    writes the general formulation (its own shadow build: revolute joints and point
    closures are covered); the planar formulation, asked for, says why it is not the model
    (``not_planar``) and keeps its rows as rounded. The model as given is exactly planar."""
    assert isinstance(choose_formulation(kinbox.load(name)), PlanarFormulation)
    mech = _tilted(name, how)
    pf = formulate_planar(mech)
    assert pf is not None and pf.system.core_errors is None
    assert pf.not_planar and ("axis" if how == "axis" else "height") in pf.not_planar
    f = choose_formulation(mech)
    assert not isinstance(f, PlanarFormulation) and f.system.core_errors is not None
    assert isinstance(choose_formulation(mech, formulation="planar"), PlanarFormulation)


def test_a_nearly_planar_rigid_model_is_solved_as_given():
    """The Double Butterfly (six assembly modes) with one axis 1e-13 rad out of the plane: in
    space its loops cannot close (their heights are one more row each), and the general
    formulation proves it: no assembly, a complete answer; its planar projection, asked for,
    has the six, and the answer says whose they are (a note)."""
    mech = _tilted("double-butterfly", "axis")
    res = kinbox.solve(mech, time_limit=120)
    assert res.complete and res.solutions == [] and res.components == []
    assert not res.notes
    proj = kinbox.solve(_tilted("double-butterfly", "axis"), formulation="planar", time_limit=120)
    assert proj.complete and len(proj.solutions) == 6
    assert any("planar projection" in n and "not exactly along" in n for n in proj.notes), proj.notes
    assert any("planar projection" in n for n in proj.to_dict().get("notes", [])) and "planar projection" in proj.table()
