"""A planar mechanism in a plane whose axis is no coordinate axis. Where its joints' axes are
given along the plane's axis and its frames are not turned, the shadow build proves it exactly
planar (exact zeros about the first joint's exact axis) and encloses the plane's basis: its rows
carry their errors and every certified box holds the 40-digit root of the model as given. Where
a test proves it not planar (an interval that excludes zero), it is treated like a model planar
only to ``PARALLEL_TOL`` (``not_planar``: ``"auto"`` writes the general formulation). Where
interval arithmetic cannot decide (a plane turned by a placement's rotation), its rows stay as
rounded (``PlanarFormulation.rounded`` says why) and the answer says that its certificates are
of the planar projection's rows as rounded, not of the model as given."""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pinocchio as pin

import kinbox
from kinbox.formulation.errfloat import EF
from kinbox.formulation.planar import PlanarFormulation, formulate_planar
from kinbox.model.mechanism import Closure, Mechanism
from kinbox.problems.mechanism import choose_formulation
from tests.support.oracles import mp_mech


def _tilted(name: str, **kw):
    """``name`` with every placement on the world turned by one rotation (roll, pitch, yaw
    0.4, -0.3, 0.2): the same mechanism in a tilted plane."""
    mech = kinbox.load(name, **kw)
    model = mech.model
    T = pin.SE3(pin.rpy.rpyToMatrix(np.array([0.4, -0.3, 0.2])), np.zeros(3))
    for j in range(1, model.njoints):
        if model.parents[j] == 0:
            model.jointPlacements[j] = T * model.jointPlacements[j]
    for c in mech.closures:
        if int(c.joint_a) == 0:
            c.placement_a = T * c.placement_a
        if int(c.joint_b) == 0:
            c.placement_b = T * c.placement_b
    return mech


def test_a_tilted_plane_proven_not_planar_goes_to_the_general_formulation():
    """The four-bar at crank 0.7 with its ground placements turned: the turned translations are
    rounded, so its ground pivot's ends are at heights along the exact axis that differ (an
    interval that excludes zero): not planar as given (``not_planar``), and ``"auto"`` writes
    the general formulation; in its own plane (axis z) the rows carry their errors."""
    mech = _tilted("four-bar", set={"crank": 0.7})
    pf = formulate_planar(mech)
    assert pf is not None and pf.system.core_errors is None and pf.not_planar and "height" in pf.not_planar
    assert not isinstance(choose_formulation(mech), PlanarFormulation)
    flat = kinbox.load("four-bar", set={"crank": 0.7})
    pf = formulate_planar(flat)
    assert pf is not None and pf.rounded is None and pf.not_planar is None and pf.system.core_errors is not None
    assert not any("planar" in n for n in kinbox.solve(flat, progress=False).notes)


#: the plane's axis, normalized in binary64 (within an ulp of unit length: the exact axis is
#: this vector normalized exactly)
AXIS = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])


def _unaligned(seed: int = 0, turn: np.ndarray | None = None) -> Mechanism:
    """Two revolute joints in a chain about ``AXIS`` (``JointModelRevoluteUnaligned``, frames not
    turned), each link closed to the ground by a bar whose length is read off a configuration
    (its ends at different heights along the axis): isolated assemblies in the tilted plane.
    ``turn``: the first joint's placement turned by this rotation (the plane turned with it)."""
    rng = np.random.default_rng(seed)
    model = pin.Model()
    T = pin.SE3(np.eye(3) if turn is None else turn, np.zeros(3))

    def add(parent, xyz, name):
        place = pin.SE3(np.eye(3), np.array(xyz, dtype=float))
        return model.addJoint(
            parent, pin.JointModelRevoluteUnaligned(AXIS), place, name, np.ones(1), np.ones(1), np.full(1, -4.0), np.full(1, 4.0)
        )

    j1 = add(0, [0.1, 0.2, -0.1], "j1")
    model.jointPlacements[j1] = T * model.jointPlacements[j1]
    j2 = add(j1, [0.9, 0.3, 0.4], "j2")
    data = model.createData()
    pin.forwardKinematics(model, data, np.array([0.4, -1.1]))
    mech = Mechanism(model, name="tilted-plane")
    for i, jid in enumerate((j2, j1)):
        P = T * pin.SE3(np.eye(3), rng.uniform(-1.5, 1.5, 3))
        Q = pin.SE3(np.eye(3), rng.uniform(-0.6, 0.6, 3))
        length = float(np.linalg.norm((data.oMi[jid] * Q).translation - P.translation))
        mech.closures.append(Closure("distance", 0, P, jid, Q, length=length, name=f"bar{i + 1}"))
    return mech


def test_a_plane_along_joint_axes_off_the_coordinate_axes_is_certified_as_given():
    """The plane's axis given by the joints' own axes: proven exactly planar, the rows carry
    ``merr``, every assembly certified and each certified box holding its 40-digit root (Newton
    on the model as given, its cosines and sines of the turning groups)."""
    mech = _unaligned()
    pf = formulate_planar(mech)
    assert pf is not None and pf.rounded is None and pf.not_planar is None and pf.system.core_errors is not None
    assert pf.system.compile().merr.max() > 0
    res = kinbox.solve(mech, progress=False)
    assert isinstance(res.formulated, PlanarFormulation) and not [n for n in res.notes if "planar" in n]
    assert len(res.solutions) > 0 and all(s.certified for s in res.solutions)
    oracle = mp_mech.Mech(mech)
    boxes = [b.enclosure for b in res.raw.boxes if b.certified]
    for sol in res.solutions:
        x = mp_mech.planar_point(res.formulated, oracle.newton(sol.q))
        names = [res.raw.system.names[i] for i in x]
        pt = dict(zip(names, x.values()))
        assert min(mp_mech.box_holds(pt, res.raw.system.names, lo, hi) for lo, hi in boxes) == 0.0


def test_the_plane_basis_holds_the_exact_one():
    """The shadow build's plane basis (``PlanarConstants.project``): each projected point, the
    first build's binary64 value bit for bit, is within its error of the exact projection onto
    the exact basis (``e1`` the coordinate axis least along the exact unit axis, made
    orthogonal to it and normalized; ``e2 = w x e1``), at 60 digits; the binary64 basis differs
    from the exact one, so an error dropped would fail."""
    from kinbox.formulation.enclose_rows import PlanarConstants
    from kinbox.formulation.planar import _analyse

    mech = _unaligned()
    pf = formulate_planar(mech)
    assert pf is not None and pf.impl is not None
    E, w = pf.impl.E, pf.impl.w
    ref = _analyse(mech)[4]
    ef = PlanarConstants(mech, pf.impl.q_ref, ref, w, 1, E)
    mp.mp.dps = 60
    a = [mp.mpf(float(v)) for v in AXIS]
    n = mp.sqrt(sum(v * v for v in a))
    wx = [v / n for v in a]
    e = [mp.mpf(0)] * 3
    e[int(np.argmin(np.abs(w)))] = mp.mpf(1)
    d = sum(x * y for x, y in zip(wx, e))
    e1 = [x - d * y for x, y in zip(e, wx)]
    n1 = mp.sqrt(sum(v * v for v in e1))
    e1 = [v / n1 for v in e1]
    e2 = [wx[1] * e1[2] - wx[2] * e1[1], wx[2] * e1[0] - wx[0] * e1[2], wx[0] * e1[1] - wx[1] * e1[0]]
    exact = [e1, e2]
    assert max(abs(mp.mpf(float(E[r, i])) - exact[r][i]) for r in range(2) for i in range(3)) > 0
    rng = np.random.default_rng(3)
    for _ in range(20):
        p = rng.normal(size=3) * 10.0 ** rng.integers(-2, 3)
        out = ef.project(p)
        assert [float(v) for v in out] == (E @ p).tolist()
        for r in range(2):
            ex = sum(exact[r][i] * mp.mpf(float(p[i])) for i in range(3))
            assert isinstance(out[r], EF) and abs(mp.mpf(float(out[r])) - ex) <= mp.mpf(out[r].err)


def test_a_turned_plane_interval_arithmetic_cannot_decide_keeps_its_rows_as_rounded_and_says_so():
    """The two joints about ``AXIS`` with the first one's placement turned (roll, pitch, yaw
    0.4, -0.3, 0.2; the second joint's frame turned with it): the second axis' cross product
    with the first is an interval about zero, neither zero nor not, and the bars need no equal
    heights. The rows stay as rounded (``rounded`` says why), ``"auto"`` keeps the planar
    formulation (nothing says the model is not planar), and the answer, its assemblies certified
    for the projection, says so in a note."""
    mech = _unaligned(turn=pin.rpy.rpyToMatrix(np.array([0.4, -0.3, 0.2])))
    pf = formulate_planar(mech)
    assert pf is not None and pf.system.core_errors is None and pf.not_planar is None
    assert pf.rounded is not None and "no coordinate axis" in pf.rounded
    auto = choose_formulation(mech)
    assert isinstance(auto, PlanarFormulation) and auto.rounded and auto.system.core_errors is None
    res = kinbox.solve(mech, progress=False)
    assert res.solutions and all(s.certified for s in res.solutions)
    notes = [n for n in res.notes if "no coordinate axis" in n]
    assert notes and "planar projection" in notes[0] and "as given" in notes[0]
    assert any("no coordinate axis" in n for n in res.to_dict().get("notes", []))


def test_an_axis_an_ulp_off_the_plane_is_proven_not_planar():
    """The second joint's binary64 axis one ulp off the first's (frames not turned: the cross
    product is an exact nonzero interval): not planar as given, and ``"auto"`` writes the
    general formulation."""
    mech = _unaligned()
    jm = mech.model.joints[2].extract()
    ax = AXIS.copy()
    ax[0] = np.nextafter(ax[0], 1.0)
    jm.axis = ax
    mech.model.joints[2] = jm
    pf = formulate_planar(mech)
    assert pf is not None and pf.not_planar and "axis" in pf.not_planar and pf.rounded is None
    assert not isinstance(choose_formulation(mech), PlanarFormulation)
