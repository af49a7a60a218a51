"""Collision scenes: verdicts against coal's own checks on the full meshes, planted colliding and
free configurations, curves' free stretches checked by finer sampling, skipped pairs, bad
scene files (kinbox.model.scene, kinbox.answer.collision)."""

from __future__ import annotations

import functools
import json
import math

import numpy as np
import pinocchio as pin
import pytest

import kinbox
from kinbox.answer.collision import Checker, split_branch
from kinbox.answer.resultfile import check_result
from kinbox.errors import InputError
from kinbox.model.loading import erd_files, load
from kinbox.model.scene import build_scene, builtin_scenes, read_scene, scene_from_dict
from tests.support.oracles.ur_ik import ur_ik

POSE = ["0.4", "0.2", "0.3", "0", "1", "0", "0"]
BOX = {"name": "b", "shape": "box", "size": [0.1, 0.1, 0.1], "pose": [1, 0, 0, 0, 0, 0, 1]}


@pytest.fixture(scope="module")
def ur5_cell():
    mech = load("ur5")
    return build_scene(mech, "ur5", read_scene("ur5-cell"))


def coal_contact(scene, q) -> set:
    """The pairs coal's computeCollisions finds in contact on the meshes as loaded."""
    model = scene.model
    data, gdata = model.createData(), pin.GeometryData(scene.geom)
    pin.computeCollisions(model, data, scene.geom, gdata, q, False)
    return {
        (scene.labels[p.first], scene.labels[p.second])
        for k, p in enumerate(scene.geom.collisionPairs)
        if gdata.collisionResults[k].isCollision()
    }


def coal_verdict(scene, q):
    """The independent check: pin.computeCollisions / computeDistances on the meshes as loaded,
    over the scene's active pairs (those kinbox must check)."""
    model = scene.model
    data, gdata = model.createData(), pin.GeometryData(scene.geom)
    pin.computeCollisions(model, data, scene.geom, gdata, q, False)
    contact = set()
    for k, p in enumerate(scene.geom.collisionPairs):
        if gdata.collisionResults[k].isCollision():
            contact.add((scene.labels[p.first], scene.labels[p.second]))
    pin.computeDistances(model, data, scene.geom, gdata, q)
    clearance = min(r.min_distance for r in gdata.distanceResults)
    return contact, clearance


def test_builtin_scenes_listed():
    assert {"ur5-cell", "panda-shelf"} <= set(builtin_scenes())
    for name in builtin_scenes():
        assert read_scene(name).obstacles


def test_pairs_classified(ur5_cell):
    sc = ur5_cell
    c = sc.counts
    n = len(sc.labels)
    assert c["active"] + c["disabled"] + c["allowed"] + c["world_fixed"] + c["out_of_reach"] == n * (n - 1) // 2
    assert c["world_fixed"] > 0  # the base link against the table, the wall, the post
    for a, b in sc.pairs:  # an active pair moves: never two world-fixed geometries
        assert sc.geom.geometryObjects[a].parentJoint or sc.geom.geometryObjects[b].parentJoint
    assert len(sc.geom.collisionPairs) == c["active"]


def test_far_obstacle_skipped_and_never_touched():
    """An obstacle beyond the arm's reach gets no active pair, and no configuration brings any
    link within the reach bound's promise (random configurations, coal's distance)."""
    mech = load("ur5")
    far = dict(BOX, name="far", pose=[3.0, 0, 0.5, 0, 0, 0, 1])
    near = dict(BOX, name="near", pose=[0.5, 0, 0.5, 0, 0, 0, 1])
    sc = build_scene(mech, "ur5", scene_from_dict({"kind": "scene", "obstacles": [far, near]}))
    k_far = sc.labels.index("far")
    assert all(k_far not in p for p in sc.pairs)
    assert sc.counts["out_of_reach"] >= 7
    model, data = sc.model, sc.model.createData()
    gdata = pin.GeometryData(sc.geom)
    rng = np.random.default_rng(3)
    for _ in range(50):
        q = rng.uniform(model.lowerPositionLimit, model.upperPositionLimit)
        pin.updateGeometryPlacements(model, data, sc.geom, gdata, q)
        for i, o in enumerate(sc.geom.geometryObjects):
            if o.parentJoint:
                import coal

                req, res = coal.DistanceRequest(), coal.DistanceResult()
                d = coal.distance(o.geometry, gdata.oMg[i], sc.geom.geometryObjects[k_far].geometry, gdata.oMg[k_far], req, res)
                assert d > 0.5


def test_no_srdf_disables_joined_links():
    """Without an SRDF, links joined by a joint are not checked against each other."""
    files = erd_files("ur5")
    mech = load(str(files.urdf))
    sc = build_scene(mech, str(files.urdf), scene_from_dict({"kind": "scene", "obstacles": [BOX]}))
    model = sc.model
    assert sc.srdf is None
    for a, b in sc.pairs:
        ja, jb = sc.geom.geometryObjects[a].parentJoint, sc.geom.geometryObjects[b].parentJoint
        assert ja != jb and model.parents[ja] != jb and model.parents[jb] != ja
    # with the SRDF, fewer robot pairs stay active than joints alone would leave
    with_srdf = build_scene(mech, str(files.urdf), scene_from_dict({"kind": "scene", "obstacles": [BOX]}), srdf=files.srdf)
    assert with_srdf.counts["active"] < sc.counts["active"]


def _same_mod_2pi(a, b, tol=1e-6):
    d = np.angle(np.exp(1j * (np.asarray(a) - np.asarray(b))))
    return bool(np.max(np.abs(d)) < tol)


@pytest.mark.parametrize("seed", range(6))
def test_verdicts_agree_with_coal_and_closed_form(ur5_cell, seed):
    """For a random pose: every solution's verdict and clearance are coal's on the full meshes,
    and the free solutions are the closed-form UR5 solutions (tests/support/oracles/ur_ik.py) that
    coal finds free."""
    rng = np.random.default_rng(seed)
    ik = kinbox.IK("ur5", "tool0", scene="ur5-cell")
    q0 = rng.uniform(-math.pi, math.pi, 6)
    q0[1] = rng.uniform(-math.pi, 0)  # mostly above the table
    pose = ik.pose_at(q0)
    res = ik.solve(pose)
    assert res.complete
    for s in res.solutions:
        contact, clearance = coal_verdict(ur5_cell, s.q)
        assert s.collision["free"] == (not contact)
        assert {tuple(p) for p in s.collision["pairs"]} == contact
        assert abs(s.collision["clearance"] - clearance) < 1e-6
    oracle = ur_ik("ur5", pose.homogeneous)
    free_oracle = [q for q in oracle if not coal_verdict(ur5_cell, np.asarray(q))[0]]
    free_kinbox = [s.q for s in res.solutions if s.collision["free"]]
    assert len(free_oracle) == len(free_kinbox)
    for q in free_oracle:
        assert any(_same_mod_2pi(q, p) for p in free_kinbox)


def test_planted_colliding_and_free(ur5_cell):
    """A configuration with the forearm through the table and one clear of everything: both
    come back as solutions of their poses with those verdicts; --collision-free keeps only the
    free one."""
    down = np.array([0.3, 0.6, 0.9, -1.2, 1.4, 0.2])  # the upper arm and forearm below z = 0
    up = np.array([0.3, -1.7, 1.0, -1.2, -1.4, 0.2])
    assert coal_verdict(ur5_cell, down)[0] and not coal_verdict(ur5_cell, up)[0]
    ik = kinbox.IK("ur5", "tool0", scene="ur5-cell")
    for q, free in ((down, False), (up, True)):
        res = ik.solve(ik.pose_at(q))
        match = [s for s in res.solutions if _same_mod_2pi(s.q, q)]
        assert len(match) == 1 and match[0].collision["free"] is free
        kept = ik.solve(ik.pose_at(q), collision_free=True)
        assert all(s.collision["free"] for s in kept.solutions)
        assert any(_same_mod_2pi(s.q, q) for s in kept.solutions) is free
        assert kept.stats["collision"]["dropped"] == sum(not s.collision["free"] for s in res.solutions)


def test_result_json_carries_verdicts(tmp_path):
    res = kinbox.ik("ur5", "tool0", [0.4, 0.2, 0.3, 0, 1, 0, 0], scene="ur5-cell")
    d = json.loads(res.to_json())
    check_result(d)
    assert all(set(s["collision"]) == {"free", "clearance", "pairs", "nearest"} for s in d["solutions"])
    assert d["scene"]["obstacles"] and d["source"]["scene"] == "ur5-cell"
    assert "collision" in res.table()
    old = {k: v for k, v in d.items() if k != "scene"}
    for s in old["solutions"]:
        s.pop("collision")
    check_result(old)  # a result without a scene still loads


def test_curve_stretches_sound(ur5_cell):
    """A sweep of the shoulder through the post: the stretches found free are free when sampled
    10x finer (coal on the meshes), and the sweep's colliding part is in no stretch."""
    ch = Checker(ur5_cell)
    q0 = np.array([-2.0, -0.5, 0.3, -1.0, 1.0, 0.0])
    qs = [q0 + np.array([t, 0, 0, 0, 0, 0]) for t in np.linspace(0, 2.6, 27)]
    out = split_branch(ch, qs, closed=False)
    assert out["colliding_samples"] > 0 and out["stretches"]
    model = ur5_cell.model
    for st in out["stretches"]:
        pl = [np.array(q) for q in st["polyline"]]
        assert st["clearance"] is not None and st["clearance"] > 0
        for a, b in zip(pl, pl[1:]):
            for t in np.linspace(0, 1, 11):
                assert not coal_contact(ur5_cell, pin.interpolate(model, a, b, t))
        mid = pin.interpolate(model, pl[0], pl[-1], 0.5) if len(pl) == 2 else pl[len(pl) // 2]
        assert coal_verdict(ur5_cell, mid)[1] >= st["clearance"] - 1e-6
    in_contact = [q for q in qs if coal_contact(ur5_cell, q)]
    for q in in_contact:
        assert not any(np.allclose(q, p) for st in out["stretches"] for p in st["polyline"])


def test_mesh_obstacle_uses_hull_proofs():
    mech = load("ur5")
    mesh = str(erd_files("ur5").urdf.parent.parent / "meshes" / "ur5" / "collision" / "base.stl")
    spec = scene_from_dict(
        {"kind": "scene", "obstacles": [{"name": "part", "shape": "mesh", "file": mesh, "scale": 1.5, "pose": [0.5, 0.2, 0.3, 0, 0, 0, 1]}]}
    )
    sc = build_scene(mech, "ur5", spec)
    ch = Checker(sc)
    rng = np.random.default_rng(0)
    for _ in range(20):
        q = rng.uniform(-math.pi, math.pi, 6)
        v = ch.verdict(q)
        contact, clearance = coal_verdict(sc, q)
        assert v.free == (not contact)
        assert abs(v.clearance - clearance) < 1e-6
    assert ch.stats["hull_proofs"] > 0


@pytest.mark.slow
def test_four_bar_curve_split(tmp_path):
    """`kinbox solve` of an MJCF linkage with bodies: its curve comes back split by an obstacle."""
    from tests.support.scene_data import FOUR_BAR_BODIES

    f = tmp_path / "fb.xml"
    f.write_text(FOUR_BAR_BODIES)
    scene = {"kind": "scene", "obstacles": [{"name": "ball", "shape": "sphere", "radius": 0.3, "pose": [-0.9, 0.3, 0.0, 0, 0, 0, 1]}]}
    res = kinbox.solve(str(f), scene=scene)
    curves = [c for c in res.curves.values()]
    assert curves and all(c.collision is not None for c in curves)
    branches = [b for c in curves for b in c.collision]
    assert any(b["colliding_samples"] for b in branches) and any(b["stretches"] for b in branches)
    check_result(json.loads(res.to_json()))
    sc = build_scene(load(str(f)), str(f), scene_from_dict(scene))
    for b in branches:  # every stretch free when sampled 10x finer, through a closed curve's start too
        for st in b["stretches"]:
            pl = [np.array(q) for q in st["polyline"]]
            for a, c in zip(pl, pl[1:]):
                for t in np.linspace(0, 1, 11):
                    assert not coal_contact(sc, pin.interpolate(sc.model, a, c, t))


BAD = [
    ({"kind": "mechanism"}, '"kind" must be "scene"'),
    ({"kind": "scene", "obstacles": {}}, '"obstacles" must be a list'),
    ({"kind": "scene", "obstacle": []}, "unknown key"),
    ({"kind": "scene", "obstacles": [dict(BOX, shape="cone")]}, "shape"),
    ({"kind": "scene", "obstacles": [dict(BOX, size=[1, 0, 1])]}, "must be positive"),
    ({"kind": "scene", "obstacles": [dict(BOX, size=[1, 1])]}, "3 numbers"),
    ({"kind": "scene", "obstacles": [dict(BOX, pose=[0, 0, 0, 0, 0, 0, 2])]}, "not unit"),
    ({"kind": "scene", "obstacles": [dict(BOX, pose=[0, 0, "x", 0, 0, 0, 1])]}, "must be a number"),
    ({"kind": "scene", "obstacles": [{"name": "s", "shape": "sphere", "pose": [0, 0, 0, 0, 0, 0, 1]}]}, "needs radius"),
    ({"kind": "scene", "obstacles": [dict(BOX, radius=1)]}, "unknown key"),
    ({"kind": "scene", "obstacles": [BOX, BOX]}, "two obstacles"),
    ({"kind": "scene", "obstacles": [{"name": "m", "shape": "mesh", "file": "nope.stl", "pose": [0, 0, 0, 0, 0, 0, 1]}]}, "no such file"),
    ({"kind": "scene", "margin": -1}, "must not be negative"),
    ({"kind": "scene", "allow": [["a"]]}, "pairs"),
]


@pytest.mark.parametrize("spec,message", BAD)
def test_bad_scene(spec, message):
    with pytest.raises(InputError, match=message):
        scene_from_dict(spec)


def test_bad_scene_names():
    mech = load("ur5")
    with pytest.raises(InputError, match="neither a link"):
        build_scene(mech, "ur5", scene_from_dict({"kind": "scene", "obstacles": [BOX], "allow": [["base_link", "tabel"]]}))
    with pytest.raises(InputError, match="name of a link"):
        build_scene(mech, "ur5", scene_from_dict({"kind": "scene", "obstacles": [dict(BOX, name="forearm_link")]}))
    with pytest.raises(InputError, match="no scene file"):
        read_scene("ur5-cel")


def test_cli_scene(tmp_path, capsys):
    from kinbox.cli import main

    bad = tmp_path / "bad.json"
    bad.write_text('{"kind": "scene", "obstacles": [{"name": "a", "shape": "box", "size": [1, -1, 1], "pose": [0,0,0,0,0,0,1]}]}')
    assert main(["ik", "ur5", "--frame", "tool0", "--pose", *POSE, "--scene", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "size[1] must be positive" in err
    assert main(["ik", "ur5", "--frame", "tool0", "--pose", *POSE, "--collision-free"]) == 2
    capsys.readouterr()
    code = main(["ik", "ur5", "--frame", "tool0", "--pose", *POSE, "--scene", "ur5-cell", "--collision-free", "--json"])
    assert code == 0
    d = json.loads(capsys.readouterr().out)
    assert d["solutions"] and all(s["collision"]["free"] for s in d["solutions"])
    assert d["stats"]["collision"]["dropped"] > 0


def test_replay_draws_scene(tmp_path):
    """The replay of a result with a scene holds the obstacles, and red copies of the links in
    contact shown (full scale) exactly at the configurations where coal finds them in contact."""
    from kinbox.viz import replay

    res = kinbox.ik("ur5", "tool0", [0.4, 0.2, 0.3, 0, 1, 0, 0], scene="ur5-cell")
    f = tmp_path / "r.json"
    f.write_text(res.to_json())
    show = replay.prepare(replay.load_result(f))
    names = [g.name for g in show.visual.geometryObjects]
    assert {"kinbox_obstacle/table", "kinbox_obstacle/wall", "kinbox_obstacle/post"} <= set(names)
    assert show.ghosts
    for s, label in zip(res.solutions, show.labels):
        show.place(s.q)
        shown = {link for gid, link, scale in show.ghosts if show.visual.geometryObjects[gid].meshScale[0] > 0.5}
        assert shown == {n for p in s.collision["pairs"] for n in p} - {"table", "wall", "post"}
        assert ("IN CONTACT" in label) == (not s.collision["free"])


def test_cli_poses_with_scene(tmp_path, capsys):
    """--poses: every line answered with its verdicts, as one pose alone."""
    from kinbox.cli import main

    f = tmp_path / "poses.txt"
    f.write_text(" ".join(POSE) + "\nnot a pose\n")
    assert main(["ik", "ur5", "--frame", "tool0", "--poses", str(f), "--scene", "ur5-cell", "--json", "--quiet"]) == 5
    first, bad = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    alone = kinbox.ik("ur5", "tool0", [float(v) for v in POSE], scene="ur5-cell")
    assert [s["collision"] for s in first["solutions"]] == [s.collision for s in alone.solutions]
    assert bad["line"] == 2 and "error" in bad


def test_bad_mesh_one_line(tmp_path, capsys):
    from kinbox.cli import main

    (tmp_path / "bad.stl").write_text("solid x\nfacet garbage\n")
    f = tmp_path / "s.json"
    f.write_text(
        json.dumps({"kind": "scene", "obstacles": [{"name": "m", "shape": "mesh", "file": "bad.stl", "pose": [0, 0, 1, 0, 0, 0, 1]}]})
    )
    assert main(["ik", "ur5", "--frame", "tool0", "--pose", *POSE, "--scene", str(f)]) == 2
    out = capsys.readouterr()
    assert out.out == "" and out.err.count("\n") == 1 and "cannot load mesh 'bad.stl'" in out.err


def test_robot_without_geometry_refused():
    with pytest.raises(InputError, match="no body geometry"):
        kinbox.solve("four-bar", scene={"kind": "scene", "obstacles": [BOX]})
    with pytest.raises(InputError, match="not loaded from a file"):
        kinbox.IK(load("ur5").model, "tool0", scene={"kind": "scene", "obstacles": [BOX]})
    with pytest.raises(InputError, match="needs a scene"):
        kinbox.ik("ur5", "tool0", [float(v) for v in POSE], collision_free=True)


def test_margin_environment_and_capsule(tmp_path):
    """With a margin, a pair closer than it is in contact (coal's security margin); obstacles
    from an environment URDF and capsules are checked like the others."""
    (tmp_path / "env.urdf").write_text(
        '<robot name="cell"><link name="pillar"><collision><origin xyz="0.45 0.3 0.4"/>'
        '<geometry><box size="0.1 0.1 0.8"/></geometry></collision></link></robot>'
    )
    spec = {
        "kind": "scene",
        "obstacles": [{"name": "rod", "shape": "capsule", "radius": 0.03, "length": 0.6, "pose": [0.4, -0.3, 0.4, 0, 0, 0, 1]}],
        "environment": [{"urdf": "env.urdf"}],
        "margin": 0.01,
    }
    sc = build_scene(load("ur5"), "ur5", scene_from_dict(spec, tmp_path))
    assert "pillar" in sc.labels and "rod" in sc.labels
    ch = Checker(sc)
    rng = np.random.default_rng(5)
    seen = set()
    for _ in range(40):
        q = rng.uniform(-math.pi, math.pi, 6)
        v = ch.verdict(q)
        _, clearance = coal_verdict(sc, q)
        assert abs(v.clearance - clearance) < 1e-6
        if abs(clearance - 0.01) > 1e-5:
            assert v.free == (clearance > 0.01)
        seen.add(v.free)
    assert seen == {True, False}


def test_no_scene_loads_no_geometry():
    """Without a scene, neither the scene modules nor any collision geometry are loaded."""
    import subprocess
    import sys

    code = (
        "import sys, kinbox; kinbox.IK('ur5', 'tool0').problem([0.4, 0.2, 0.3, 0, 1, 0, 0]); "
        "print(sorted(m for m in sys.modules if m in ('kinbox.model.scene', 'kinbox.answer.collision', 'kinbox.viz.obstacles')))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_robot_without_collision_shapes(tmp_path):
    f = tmp_path / "arm.urdf"
    f.write_text(
        '<robot name="arm"><link name="a"/><link name="b"/>'
        '<joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>'
    )
    with pytest.raises(InputError, match="no collision geometry"):
        build_scene(load(str(f)), str(f), scene_from_dict({"kind": "scene", "obstacles": [BOX]}))


def test_closed_curve_stretch_through_start(ur5_cell):
    """A closed sweep of the shoulder once round, blocked in places (not at its start): as many
    stretches as blocked runs, one running on through the sweep's start, each free when
    sampled 10x finer."""
    ch = Checker(ur5_cell)
    q0 = np.array([-2.0, -0.5, 0.3, -1.0, 1.0, 0.0])
    qs = [q0 + np.array([t, 0, 0, 0, 0, 0]) for t in np.linspace(0, 2 * math.pi, 40, endpoint=False)]
    hit = [bool(coal_contact(ur5_cell, q)) for q in qs]
    start = next(i for i in range(len(qs)) if not (hit[i - 1] or hit[i] or hit[(i + 1) % len(qs)]))
    qs = qs[start:] + qs[:start]  # the sweep starts inside a free run
    blocked = [i for i, q in enumerate(qs) if coal_contact(ur5_cell, q)]
    assert blocked and 0 not in blocked and len(qs) - 1 not in blocked
    runs = 1 + sum(1 for a, b in zip(blocked, blocked[1:]) if b != a + 1)
    out = split_branch(ch, qs, closed=True)
    assert len(out["stretches"]) == runs
    through = [st for st in out["stretches"] if any(np.allclose(q, qs[0]) for q in st["polyline"][1:-1])]
    assert len(through) == 1
    for st in out["stretches"]:
        pl = [np.array(q) for q in st["polyline"]]
        for a, b in zip(pl, pl[1:]):
            for t in np.linspace(0, 1, 11):
                assert not coal_contact(ur5_cell, pin.interpolate(ur5_cell.model, a, b, t))


@pytest.mark.slow
def test_panda_selfmotion_in_shelf():
    """The Panda's self-motion through a configuration with the hand in the shelf comes back in
    collision-free stretches, free when sampled 10x finer (benchmarks/scenes.py measures it)."""
    from benchmarks.scenes import PANDA_IN_SHELF

    ik = kinbox.IK("panda", "panda_hand", scene="panda-shelf")
    res = ik.solve(ik.pose_at(PANDA_IN_SHELF), progress=False)
    sc = ik.scene.collision
    stretches = [st for cv in res.curves.values() for b in cv.collision for st in b["stretches"]]
    assert stretches
    for st in stretches:
        pl = [np.array(q) for q in st["polyline"]]
        for a, b in zip(pl, pl[1:]):
            for t in np.linspace(0, 1, 11):
                assert not coal_contact(sc, pin.interpolate(sc.model, a, b, t))


def test_replay_marks_curve_stretches(ur5_cell, tmp_path):
    """A curve's points are labelled with their stretch or as not free, and the links in contact
    at a point in contact are shown red there."""
    from kinbox.viz import replay

    res = kinbox.ik("ur5", "tool0", [0.4, 0.2, 0.3, 0, 1, 0, 0], scene="ur5-cell")
    d = json.loads(res.to_json())
    q0 = np.array([-2.0, -0.5, 0.3, -1.0, 1.0, 0.0])
    qs = [q0 + np.array([t, 0, 0, 0, 0, 0]) for t in np.linspace(0, 2.6, 27)]
    col = split_branch(Checker(ur5_cell), qs, closed=False)
    pl = [[float(v) for v in q] for q in qs]
    d["components"].append({"dimension": 1, "polyline": pl, "branches": [{"polyline": pl, "closed": False}], "collision": [col]})
    check_result(d)
    show = replay.prepare(d)
    labels = show.labels[len(res.solutions) :]
    assert len(labels) == len(qs)
    for q, label in zip(qs, labels):
        names = coal_contact(ur5_cell, q)
        assert ("NOT collision-free" in label) == (not any(np.allclose(q, p) for st in col["stretches"] for p in st["polyline"]))
        show.place(q)
        red = {link for gid, link, scale in show.ghosts if show.visual.geometryObjects[gid].meshScale[0] > 0.5}
        assert red == {n for p in names for n in p} - {"table", "wall", "post"}


@pytest.mark.parametrize("margin", [0.0, 0.02])
def test_verdict_same_as_sample_path(margin):
    """Checker.verdict (one configuration, plain numbers) gives what sample + decide +
    verdict_of give (the path curves use): verdict, clearance, pairs, nearest pair and the
    check counts, at random configurations of the UR5 cell (with no margin some of them free,
    with a margin all in contact: the margin makes neighbouring links touch)."""
    spec = read_scene("ur5-cell")
    spec.margin = margin
    sc = build_scene(load("ur5"), "ur5", spec)
    fast, slow = Checker(sc), Checker(sc)
    rng = np.random.default_rng(11)
    seen = set()
    for _ in range(60):
        q = rng.uniform(-math.pi, math.pi, 6)
        a = fast.verdict(q)
        b = slow.verdict_of(slow.sample(q))
        assert a.to_dict() == b.to_dict()
        seen.add(a.free)
    assert seen == ({True, False} if margin == 0 else {False})
    assert fast.stats == slow.stats and fast.stats["mesh_distances"] > 0


def _stateless_reference(scene, q):
    """coal's checks on the meshes as loaded over the scene's active pairs, on a fresh
    GeometryData without a carried GJK guess: (pairs in contact, clearance, every pair's
    distance)."""
    from kinbox.answer.collision import stateless

    model = scene.model
    data, gdata = model.createData(), pin.GeometryData(scene.geom)
    if scene.margin > 0:
        n = len(scene.labels)
        gdata.setSecurityMargins(scene.geom, np.full((n, n), scene.margin), True, True)
    stateless(gdata)
    pin.computeCollisions(model, data, scene.geom, gdata, q, False)
    contact = {scene.pair_names(k) for k in range(len(scene.pairs)) if gdata.collisionResults[k].isCollision()}
    pin.computeDistances(model, data, scene.geom, gdata, q)
    dist = [r.min_distance for r in gdata.distanceResults]
    return contact, min(dist), dist


def _cluttered(margin=0.0):
    mesh = str(erd_files("ur5").urdf.parent.parent / "meshes" / "ur5" / "collision" / "forearm.stl")
    q = [0.2, 0.3, 0.1, 0.92736185]
    obstacles = [
        {"name": "part", "shape": "mesh", "file": mesh, "scale": 1.2, "pose": [0.45, 0.2, 0.3, *q]},
        {"name": "tilted", "shape": "box", "size": [0.3, 0.1, 0.5], "pose": [0.2, -0.4, 0.3, *q]},
        {"name": "ball", "shape": "sphere", "radius": 0.15, "pose": [-0.3, 0.3, 0.4, 0, 0, 0, 1]},
        {"name": "rod", "shape": "capsule", "radius": 0.03, "length": 0.6, "pose": [0.0, -0.5, 0.4, 0, 0, 0, 1]},
        {"name": "post", "shape": "cylinder", "radius": 0.04, "length": 0.8, "pose": [-0.4, -0.2, 0.4, *q]},
    ]
    return scene_from_dict({"kind": "scene", "obstacles": obstacles, "margin": margin})


@pytest.mark.parametrize("margin", [0.0, 0.02])
def test_verdict_matches_reference(margin):
    """Every verdict is coal's own at its configuration: the pairs in contact are those
    computeCollisions finds, the clearance is bit for bit the smallest of computeDistances over
    the active pairs, the nearest pair is one at that distance -- although most pairs are
    settled by their bounds and never reach coal (random configurations, the UR5 cell and a
    cluttered scene of every shape)."""
    rng = np.random.default_rng(23)
    for spec in (read_scene("ur5-cell"), _cluttered(margin)):
        spec.margin = margin
        sc = build_scene(load("ur5"), "ur5", spec)
        ch = Checker(sc)
        qs = [rng.uniform(-math.pi, math.pi, 6) for _ in range(24)]
        seen = set()
        for q, v in zip(qs, ch.verdicts(qs)):
            contact, clearance, dist = _stateless_reference(sc, q)
            assert {tuple(p) for p in v.pairs} == contact
            assert v.free == (not contact)
            assert v.clearance == clearance
            assert dist[sc.pairs.index(tuple(sc.labels.index(n) for n in v.nearest))] == clearance
            seen.add(v.free)
        if margin == 0:
            assert seen == {True, False}
        assert ch.stats["sphere_skipped"] > ch.stats["mesh_distances"] > 0


def test_no_configurations(ur5_cell):
    """An answer without isolated solutions (a curve alone) has no verdicts to give and no
    bounds to compute: empty, with a row per pair."""
    ch = Checker(ur5_cell)
    assert ch.verdicts([]) == []
    assert ch.bounds([]).shape == (0, len(ur5_cell.pairs))
    assert ch.stats["configurations"] == 0


def test_verdicts_history_free(ur5_cell):
    """A verdict depends on its configuration alone: a batch checked at once, the same
    configurations one at a time in reverse order by another checker, and a checker that saw
    other configurations first all agree bit for bit."""
    rng = np.random.default_rng(29)
    qs = [rng.uniform(-math.pi, math.pi, 6) for _ in range(24)]
    batch = [v.to_dict() for v in Checker(ur5_cell).verdicts(qs)]
    other = Checker(ur5_cell)
    other.verdicts([rng.uniform(-math.pi, math.pi, 6) for _ in range(24)])
    alone = [other.verdict(q).to_dict() for q in reversed(qs)][::-1]
    assert batch == alone


def test_bounds_below_coal():
    """The bounding-volume bounds are below coal's mesh distance of every pair, in penetration
    too (random configurations, a cluttered scene of every shape, tilted obstacles)."""
    sc = build_scene(load("ur5"), "ur5", _cluttered())
    ch = Checker(sc)
    rng = np.random.default_rng(31)
    qs = [rng.uniform(-math.pi, math.pi, 6) for _ in range(30)]
    lbs = ch.bounds(qs)
    deep = 0
    for q, lb in zip(qs, lbs):
        _, _, dist = _stateless_reference(sc, q)
        assert np.all(lb <= np.array(dist))
        deep += sum(d < -0.01 for d in dist)
    assert deep > 0  # some pairs penetrate: the bound holds there too


@pytest.mark.parametrize("margin", [0.0, 0.05])
def test_sorted_bounds_as_numpy(ur5_cell, margin):
    """The verdicts' one compiled call gives the bounds of Checker.bounds, each row's pairs in
    NumPy's stable order and how many of them do not clear the margin; its sort keeps tied
    bounds in pair order, as NumPy's stable sort does."""
    from kinbox.answer.collision import TOL
    from kinbox.answer.scene_bounds import stable_order

    ch = Checker(ur5_cell)
    rng = np.random.default_rng(47)
    qs = [rng.uniform(-math.pi, math.pi, 6) for _ in range(12)]
    args = (ch._slot, ch.centre, ch.rot, ch.half, ch.radius, ch.a, ch.b, TOL, margin)
    lb, order = ch._sorted_bounds(ch._placements(qs), *args)
    assert np.array_equal(lb, ch.bounds(qs))
    assert np.array_equal(order[:, :-1], np.argsort(lb, axis=1, kind="stable"))
    assert np.array_equal(order[:, -1], np.count_nonzero(lb <= margin, axis=1))
    tied = np.round(lb, 1)  # many equal bounds in a row
    assert any(len(set(row)) < len(row) for row in tied.tolist())
    for row in tied:
        assert np.array_equal(stable_order(row), np.argsort(row, kind="stable"))


@functools.cache
def _three_scenes():
    """The UR5 cell and a cluttered scene (every shape, a mesh obstacle), without and with a margin."""
    return [build_scene(load("ur5"), "ur5", spec) for spec in (read_scene("ur5-cell"), _cluttered(0.0), _cluttered(0.02))]


def _placed_checkers(seed, n=30):
    """A checker of each of :func:`_three_scenes`, with random configurations to place."""
    rng = np.random.default_rng(seed)
    qs = [rng.uniform(-math.pi, math.pi, 6) for _ in range(n)]
    return [(Checker(sc), qs) for sc in _three_scenes()]


def test_mesh_pairs_never_negative():
    """coal's distance between two meshes is never negative, also where they intersect: the
    rule by which a pair of two meshes skips the clearance search once the clearance is zero or
    less (Checker._judge), applied to exactly those pairs."""
    import coal

    for ch, qs in _placed_checkers(37, n=16)[:2]:
        sc = ch.scene
        objs = sc.geom.geometryObjects
        meshes = [k for k, (a, b) in enumerate(sc.pairs) if all(isinstance(objs[i].geometry, coal.BVHModelBase) for i in (a, b))]
        assert meshes and [k for k, f in enumerate(ch._floor) if f == 0.0] == meshes
        touching = 0
        for q in qs:
            ch._placed = None
            ch._place(q)
            for k in meshes:
                assert pin.computeDistance(sc.geom, ch.gdata, k).min_distance >= 0.0
                touching += bool(pin.computeCollision(sc.geom, ch.gdata, k))
        assert touching > 0  # some of them intersect


def test_penetration_is_contact():
    """A pair whose coal distance on the meshes is a penetration deeper than TOL is in contact by
    coal's collision test (the rule by which Checker._judge skips that test), with and without
    a margin."""
    from kinbox.answer.collision import TOL

    for ch, qs in _placed_checkers(41, n=16):
        sc = ch.scene
        deep = 0
        for q in qs:
            ch._placed = None
            ch._place(q)
            for k in range(len(sc.pairs)):
                if pin.computeDistance(sc.geom, ch.gdata, k).min_distance < -TOL:
                    deep += 1
                    assert pin.computeCollision(sc.geom, ch.gdata, k)
        assert deep > 0


def test_bounded_distance_is_coal():
    """Checker._below(k, best), coal's traversal started from ``best``: bit for bit the distance
    ``pin.computeDistance`` gives where that is below ``best``, ``best`` or more where not."""
    below = above = 0
    for ch, qs in _placed_checkers(43, n=8)[:2]:
        sc = ch.scene
        for q in qs:
            ch._placed = None
            ch._place(q)
            for k in range(len(sc.pairs)):
                d = pin.computeDistance(sc.geom, ch.gdata, k).min_distance
                for best in (d + 1e-9, d + 1e-3, 2.0 * abs(d) + 0.01, 0.5 * d, 0.99 * d):
                    if best <= 0.0:
                        continue
                    e = ch._below(k, best)
                    if d < best:
                        assert e == d
                        below += 1
                    else:
                        assert e >= best
                        above += 1
    assert below > 0 and above > 0
