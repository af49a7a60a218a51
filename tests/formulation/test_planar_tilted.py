"""A planar mechanism in a plane whose axis is no coordinate axis: the planar formulation's
shadow build cannot prove the model as given exactly planar there, so its rows stay as rounded
(``PlanarFormulation.rounded`` says why) and the answer says that its certificates are of the
planar projection's rows as rounded, not of the model as given."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

import kinbox
from kinbox.formulation.planar import PlanarFormulation, formulate_planar
from kinbox.problems.mechanism import choose_formulation


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


def test_a_tilted_plane_keeps_its_rows_as_rounded_and_says_so():
    """The four-bar at crank 0.7 in a tilted plane: planar (its axes parallel), its rows not
    claimed to be the model's (``core_errors`` None, ``rounded`` naming the axis), and the
    answer (both assemblies certified, of the projection) carries the note; in its own plane
    (axis z) the rows carry their errors and the answer has no such note."""
    mech = _tilted("four-bar", set={"crank": 0.7})
    pf = formulate_planar(mech)
    assert pf is not None and pf.system.core_errors is None and pf.not_planar is None
    assert pf.rounded is not None and "no coordinate axis" in pf.rounded
    auto = choose_formulation(mech)  # "auto" keeps the planar formulation (the model may well be exactly planar)
    assert isinstance(auto, PlanarFormulation) and auto.rounded and auto.system.core_errors is None
    res = kinbox.solve(mech, progress=False)
    assert res.stats["certified"] == 2
    notes = [n for n in res.notes if "no coordinate axis" in n]
    assert notes and "planar projection" in notes[0] and "as given" in notes[0]
    assert any("no coordinate axis" in n for n in res.to_dict().get("notes", []))
    flat = kinbox.load("four-bar", set={"crank": 0.7})
    pf = formulate_planar(flat)
    assert pf is not None and pf.rounded is None and pf.system.core_errors is not None
    assert not any("coordinate axis" in n for n in kinbox.solve(flat, progress=False).notes)
