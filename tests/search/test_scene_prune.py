"""Pruning search boxes with a collision scene (kinbox.search.scene_prune): a box is discarded only
when coal finds its configurations in contact, and a planted collision-free root just outside an
obstacle is never lost."""

from __future__ import annotations

import math

import coal
import numpy as np
import pinocchio as pin
import pytest

import kinbox
from kinbox.model.scene import build_scene, read_scene, scene_from_dict
from kinbox.search.scene_prune import scene_pruner

Q0 = np.array([2.07, -1.394, -1.698, -1.973, -0.89, 3.048, -2.446, 0.01, 0.01])


def test_pruned_boxes_hold_only_contact():
    """Boxes of the Panda's general formulation around random configurations (each joint's
    cosine and sine within w): where the test discards one, every configuration sampled in it is
    in contact by coal's computeCollisions on the meshes; and it does discard some."""
    ik = kinbox.IK("panda", "panda_hand")
    model = ik.robot.model
    form = ik.problem(ik.pose_at(Q0[:7])).formulation
    sc = build_scene(ik.robot, "panda", read_scene("panda-clutter"))
    prune = scene_pruner(model, form.system, sc, form.impl.locked)
    assert prune is not None
    names = form.system.names
    idx = [(names.index(f"c[panda_joint{j + 1}]"), names.index(f"s[panda_joint{j + 1}]")) for j in range(7)]
    data, gdata = model.createData(), pin.GeometryData(sc.geom)
    lo0, hi0 = form.system.search_domain()
    rng = np.random.default_rng(1)
    discarded = 0
    for trial in range(160):
        q = Q0.copy()
        q[:7] = rng.uniform(model.lowerPositionLimit[:7], model.upperPositionLimit[:7])
        w = (1e-3, 1e-2, 0.05, 0.2)[trial % 4]
        lo, hi = lo0.copy(), hi0.copy()
        for j, (ic, is_) in enumerate(idx):
            lo[ic], hi[ic] = math.cos(q[j]) - w, math.cos(q[j]) + w
            lo[is_], hi[is_] = math.sin(q[j]) - w, math.sin(q[j]) + w
        if not prune(lo, hi):
            continue
        discarded += 1
        for _ in range(8):  # angles within w of q: their cosines and sines are in the box
            q2 = q.copy()
            q2[:7] += rng.uniform(-w, w, 7) * 0.999
            pin.computeCollisions(model, data, sc.geom, gdata, q2, True)
            assert any(r.isCollision() for r in gdata.collisionResults)
    assert discarded >= 10
    assert prune.pruned == discarded and prune.calls == 160


@pytest.mark.parametrize("gap", [1e-3, 1e-5])
def test_planted_free_root_just_outside_an_obstacle_is_kept(gap):
    """A sphere placed ``gap`` metres from the UR5's nearest link at a planted configuration: the
    configuration is free, and the search with pruning (the general formulation, not the closed
    form) returns it, with the same free solutions as the search without pruning."""
    ik0 = kinbox.IK("ur5", "tool0")
    model = ik0.robot.model
    q = np.array([0.3, -1.7, 1.0, -1.2, -1.4, 0.2])
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    centre = data.oMi[model.getJointId("elbow_joint")].act(np.array([0.35, 0.0, 0.3]))
    spec = {"kind": "scene", "obstacles": [{"name": "ball", "shape": "sphere", "radius": 0.2, "pose": [*centre, 0, 0, 0, 1]}]}
    sc = build_scene(ik0.robot, "ur5", scene_from_dict(spec))
    gdata = pin.GeometryData(sc.geom)
    pin.updateGeometryPlacements(model, data, sc.geom, gdata, q)
    k = sc.labels.index("ball")
    ball = sc.geom.geometryObjects[k]
    d = min(
        coal.distance(o.geometry, gdata.oMg[i], ball.geometry, gdata.oMg[k], coal.DistanceRequest(), coal.DistanceResult())
        for i, o in enumerate(sc.geom.geometryObjects)
        if not sc.obstacle[i]
    )
    spec["obstacles"][0]["radius"] = 0.2 + d - gap  # the nearest link now gap from the sphere
    ik = kinbox.IK("ur5", "tool0", formulation="general", scene=spec)
    goal = ik.pose_at(q)
    plain = ik.solve(goal, closed_form=False, collision_free=True, prune_scene=False, progress=False)
    pruned = ik.solve(goal, closed_form=False, collision_free=True, progress=False)  # pruning is on by default
    assert pruned.complete and plain.complete
    assert pruned.stats["collision"]["pruning"]["discarded"] > 0  # boxes were discarded in this search
    near = [s for s in pruned.solutions if np.max(np.abs(np.angle(np.exp(1j * (s.q - q))))) < 1e-6]
    assert len(near) == 1 and near[0].collision["free"]
    assert 0 < near[0].collision["clearance"] < 2 * gap
    key = sorted(tuple(np.round(s.q, 9)) for s in plain.solutions)
    assert sorted(tuple(np.round(s.q, 9)) for s in pruned.solutions) == key


def test_prune_needs_collision_free():
    ik = kinbox.IK("ur5", "tool0", scene="ur5-cell")
    with pytest.raises(kinbox.InputError, match="prune_scene needs"):
        ik.solve([0.4, 0.2, 0.3, 0, 1, 0, 0], prune_scene=True)
