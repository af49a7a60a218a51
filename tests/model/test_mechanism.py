"""Mechanism loaders: URDF / MJCF / JSON files, URDF strings, built-in and example-robot-data names."""

import json
import math

import numpy as np
import pinocchio as pin
import pytest

from kinbox.errors import InputError, ModelError, NameNotFound
from kinbox.model.loading import builtin_dir, builtin_names, load
from kinbox.model.mechanism import Closure, Mechanism
from tests.support import paths as PATHS

URDF = """<?xml version="1.0"?>
<robot name="two_link">
  <link name="base"/>
  <link name="l1"/>
  <link name="l2"/>
  <link name="tip"/>
  <joint name="j1" type="revolute">
    <parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.1" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/>
  </joint>
  <joint name="j2" type="revolute">
    <parent link="l1"/><child link="l2"/>
    <origin xyz="0.5 0 0" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/>
  </joint>
  <joint name="tip_joint" type="fixed">
    <parent link="l2"/><child link="tip"/>
    <origin xyz="0.4 0 0"/>
  </joint>
</robot>
"""


def _check_two_link(mech):
    assert isinstance(mech, Mechanism)
    m = mech.model
    assert list(m.names) == ["universe", "j1", "j2"]
    assert m.existFrame("tip")
    data = m.createData()
    pin.framesForwardKinematics(m, data, np.array([0.0, math.pi / 2]))
    assert np.allclose(data.oMf[m.getFrameId("tip")].translation, [0.5, 0.4, 0.1])


def test_urdf_file(tmp_path):
    p = tmp_path / "two_link.urdf"
    p.write_text(URDF)
    mech = load(p)
    _check_two_link(mech)
    assert mech.closures == [] and mech.name == "two_link"
    _check_two_link(load(str(p), name="arm"))
    x = tmp_path / "two_link.xml"  # a URDF with an .xml suffix is recognised by its <robot> root
    x.write_text(URDF)
    _check_two_link(load(x))


def test_urdf_root_joint(tmp_path):
    p = tmp_path / "two_link.urdf"
    p.write_text(URDF)
    mech = load(p, root_joint="freeflyer")
    assert mech.model.nq == 9 and mech.model.joints[1].shortname() == "JointModelFreeFlyer"
    with pytest.raises(InputError, match="root_joint"):
        load(p, root_joint="wobbly")
    with pytest.raises(InputError, match="keyword"):
        load(p, colour="red")


def test_urdf_string():
    _check_two_link(load(URDF))


def test_malformed_urdf_file(tmp_path):
    p = tmp_path / "broken.urdf"
    p.write_text(URDF.replace("</robot>", ""))
    with pytest.raises(ModelError, match="broken.urdf"):
        load(p)
    q = tmp_path / "nan.urdf"
    q.write_text(URDF.replace('xyz="0.5 0 0"', 'xyz="nan 0 0"'))
    with pytest.raises(ModelError, match="nan.urdf") as e:
        load(q)
    assert "nan" in str(e.value).lower()
    with pytest.raises(ModelError, match="URDF string"):
        load("<robot name='x'><link")


def test_missing_file_and_directory(tmp_path):
    with pytest.raises(ModelError, match="no such file"):
        load(tmp_path / "nope.urdf")
    with pytest.raises(ModelError, match="directory"):
        load(tmp_path)


def test_non_finite_model():
    m = pin.Model()
    m.addJoint(0, pin.JointModelRZ(), pin.SE3(np.eye(3), np.array([np.nan, 0, 0])), "j")
    with pytest.raises(ModelError, match="not finite"):
        load(m)
    ok = pin.Model()
    ok.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "j")
    mech = load(ok)
    assert mech.model is ok
    bad = Mechanism(ok, [Closure("point", 1, pin.SE3(np.eye(3), np.array([0, np.inf, 0])), 0, pin.SE3.Identity())])
    with pytest.raises(ModelError, match="not finite"):
        load(bad)
    assert load(mech) is mech


def test_bad_source_types():
    with pytest.raises(InputError):
        load(42)
    with pytest.raises(InputError):
        load("   ")


# -- example-robot-data ------------------------------------------------------------------------
def test_erd_ur5_without_meshes(monkeypatch):
    import example_robot_data

    def no(*a, **k):
        raise AssertionError("example_robot_data.load (which loads meshes) must not be called for ur5")

    monkeypatch.setattr(example_robot_data, "load", no)
    mech = load("ur5")
    assert mech.model.nq == 6 and mech.name == "ur5"
    assert mech.model.existFrame("tool0")


def test_erd_ur5_matches_example_robot_data():
    import example_robot_data

    ours = load("ur5").model
    theirs = example_robot_data.load("ur5").model
    assert list(ours.names) == list(theirs.names)
    for a, b in zip(ours.jointPlacements, theirs.jointPlacements):
        assert np.allclose(a.homogeneous, b.homogeneous)
    assert np.allclose(ours.lowerPositionLimit, theirs.lowerPositionLimit)


def test_unknown_name_suggests_close_matches():
    with pytest.raises(NameNotFound, match="ur5") as e:
        load("ur55")
    assert "did you mean" in str(e.value)
    with pytest.raises(NameNotFound, match="general-6r"):
        load("general-6")
    with pytest.raises(NameNotFound):
        load("zzzzqqqq")


# -- MJCF ------------------------------------------------------------------------------------------
def test_mjcf_four_bar_has_one_point_closure():
    mech = load(builtin_dir() / "four-bar.xml")
    assert [(c.kind, c.name) for c in mech.closures] == [("point", "ground_pivot")]
    c = mech.closures[0]
    assert (c.joint_a, c.joint_b) == (3, 0)
    assert np.allclose(c.placement_a.translation, [2, 0, 0])
    assert np.allclose(c.placement_b.translation, [3, 0, 0])
    assert load("four-bar.xml").closures[0].kind == "point"


def test_mjcf_and_json_four_bar_are_the_same_linkage():
    a = load("four-bar")
    b = load(builtin_dir() / "four-bar.xml")
    assert list(a.model.names) == list(b.model.names) == ["universe", "crank", "coupler", "rocker"]
    for i in range(1, 4):
        assert a.model.joints[i].shortname() == b.model.joints[i].shortname() == "JointModelRZ"
        assert np.allclose(a.model.jointPlacements[i].homogeneous, b.model.jointPlacements[i].homogeneous)
    ca, cb = a.closures[0], b.closures[0]
    assert ca.joint_a == cb.joint_a and ca.joint_b == cb.joint_b
    assert np.allclose(ca.placement_a.translation, cb.placement_a.translation)
    assert np.allclose(ca.placement_b.translation, cb.placement_b.translation)
    q = np.array([math.pi / 2, -1.2334888453651298, -1.8234765819369754])  # the file's reference pose
    for m in (a, b):
        assert max(p for _, p, _ in m.closure_residuals(q)) < 1e-12
    q2 = q + 0.1
    assert max(p for _, p, _ in a.closure_residuals(q2)) == pytest.approx(max(p for _, p, _ in b.closure_residuals(q2)), abs=1e-12)


def test_mjcf_string_and_errors(tmp_path):
    text = (builtin_dir() / "four-bar.xml").read_text()
    assert len(load(text).closures) == 1
    bad = tmp_path / "bad.xml"
    bad.write_text(text.replace('body1="rocker"', 'body1="nobody"'))
    with pytest.raises(ModelError, match="bad.xml"):
        load(bad)
    # Pinocchio 3.x/4.x leaves the placement of a <connect> to a site of the world body unset
    # (zero rotation, zero translation): kinbox refuses it rather than pinning to the origin.
    site = tmp_path / "site.xml"
    site.write_text(
        text.replace('<connect name="ground_pivot" body1="rocker" anchor="2 0 0"/>', '<connect site1="a" site2="b"/>')
        .replace(
            '<joint name="rocker" type="hinge" axis="0 0 1" ref="-1.8234765819369754"/>',
            '<joint name="rocker" type="hinge" axis="0 0 1" ref="-1.8234765819369754"/><site name="a" pos="2 0 0"/>',
        )
        .replace("<worldbody>", '<worldbody><site name="b" pos="3 0 0"/>')
    )
    with pytest.raises(ModelError, match="site.xml.*between sites"):
        load(site)
    neither = tmp_path / "neither.xml"
    neither.write_text("<sdf/>")
    with pytest.raises(ModelError, match="neither"):
        load(neither)


# -- built-ins and kinbox mechanism files --------------------------------------------------------
def test_builtin_names_all_load():
    names = builtin_names()
    for n in ["general-6r", "bricard", "dietmeier", "griffis-duffy", "four-bar", "3-rpr", "delta"]:
        assert n in names
    for n in names:
        mech = load(n)
        assert isinstance(mech, Mechanism) and mech.closures, n
        lo, hi = mech.model.lowerPositionLimit, mech.model.upperPositionLimit
        assert not np.any(np.isnan(lo)) and not np.any(np.isnan(hi))
    assert load("general_6r").name == "general-6r"  # underscores are accepted


def test_builtin_contents():
    g = load("general-6r")
    assert g.model.nq == 6 and [c.name for c in g.closures] == ["loop"]
    gd = load("griffis-duffy")
    spec = json.loads((builtin_dir() / "griffis-duffy.json").read_text())
    assert [c.length for c in gd.closures] == spec["leg_lengths"]
    assert "leg_lengths_consistent" in spec["note"]
    ref = PATHS.DATA / "reference" / "griffis_duffy.json"
    if ref.is_file():
        r = json.loads(ref.read_text())
        assert spec["leg_lengths"] == r["leg_lengths_consistent"]
        pose = r["pose_rotvec_t"]
        q = np.concatenate([pose[3:], pin.Quaternion(pin.exp3(np.array(pose[:3]))).coeffs()])
        assert max(p for _, p, _ in gd.closure_residuals(q)) < 1e-7
    assert set(load("3-rpr").locked) == {"leg1", "leg2", "leg3"}
    assert set(load("delta").locked) == {"arm1", "arm2", "arm3"}
    d = load("dietmeier", leg_lengths=[1, 1, 1, 1, 1, 2])  # keywords override the file
    assert d.closures[5].length == 2


def test_json_file(tmp_path):
    p = tmp_path / "fb.json"
    p.write_text(
        json.dumps({"kind": "four-bar", "description": "x", "ground": 3, "crank": 1, "coupler": 3, "rocker": 2, "set": {"crank": 0.5}})
    )
    mech = load(p)
    assert mech.name == "fb" and set(mech.locked) == {"crank"}
    assert np.allclose(mech.locked["crank"], [0.5])
    u = tmp_path / "two_link.urdf"
    u.write_text(URDF)
    w = tmp_path / "wrap.json"
    w.write_text(json.dumps({"kind": "urdf", "file": "two_link.urdf", "set": {"j1": 0.1}}))
    wrapped = load(w)
    _check_two_link(wrapped)
    assert set(wrapped.locked) == {"j1"}
    assert load({"kind": "dh-arm", "dh": [[1, 0, 0], [1, 0, 0]]}).model.nq == 2


@pytest.mark.parametrize(
    "spec, msg",
    [
        ('{"kind": "fourbar"}', "did you mean four-bar"),
        ('{"ground": 1}', "kind"),
        ('{"kind": "four-bar", "ground": 1, "crank": 1, "coupler": 1}', "rocker"),
        ('{"kind": "four-bar", "ground": 1, "crank": 1, "coupler": 1, "rocker": 1, "colour": 2}', "colour"),
        ('{"kind": "four-bar", "ground": 1, "crank": 1, "coupler": 1, "rocker": 1, "set": {"crunk": 1}}', "crunk"),
        ('{"kind": "stewart", "base_points": [[0, 0, NaN]], "platform_points": [[0, 0, 0]]}', "non-finite"),
        ('{"kind": "stewart", "base_points": [[0, 0, 1e999]], "platform_points": [[0, 0, 0]]}', "non-finite"),
        ('{"kind": "four-bar", ', "not valid JSON"),
        ("[1, 2]", "JSON object"),
    ],
)
def test_bad_json_files(tmp_path, spec, msg):
    p = tmp_path / "bad.json"
    p.write_text(spec)
    with pytest.raises(ModelError, match=msg) as e:
        load(p)
    assert "bad.json" in str(e.value)


def test_erd_ur3_is_the_genuine_ur3():
    # example-robot-data 5.0's ROBOTS maps "ur3" to UR5Loader; kinbox loads the real UR3
    m = load("ur3").model
    assert m.nq == 6
    assert np.isclose(m.jointPlacements[1].translation[2], 0.1519)  # UR3 d1 (UR5: 0.089159)


def test_lock_values_are_checked_in_one_place():
    """Mechanism.lock_value normalises a lock for lock(), the formulation and decode.check alike."""
    from kinbox.formulation.build import formulate
    from kinbox.formulation.decode import check

    mech = load("four-bar")
    jid, v = mech.lock_value("crank", 0.7)
    assert jid == mech.joint_id("crank") and v.tolist() == [0.7]
    for bad, msg in ((float("nan"), "not finite"), ([0.1, 0.2], "takes 1 value")):
        with pytest.raises(InputError, match=msg):
            mech.lock("crank", bad)
    with pytest.raises(InputError, match="cannot lock the universe"):
        mech.lock("universe", 0.0)
    mech.locked["crank"] = [0.1, 0.2]  # filled directly: refused where it is used
    with pytest.raises(InputError, match="takes 1 value"):
        formulate(mech)
    with pytest.raises(InputError, match="takes 1 value"):
        check(mech, np.zeros(mech.model.nq))
    mech.locked["crank"] = 0.7
    q = np.zeros(mech.model.nq)
    q[mech.model.joints[jid].idx_q] = 0.7
    assert check(mech, q)["locked"] == 0.0 and math.isclose(check(mech, 0 * q)["locked"], 0.7)


def test_auto_legs_follow_the_local_dimension():
    # leg vectors where the configurations form curves (Griffis-Duffy: mobile although its
    # squared system is square), squared legs where they are isolated (Dietmeier)
    from kinbox.model.loading import load
    from kinbox.pipeline import choose_formulation, local_dimensions

    gd, dm = load("griffis-duffy"), load("dietmeier")
    assert local_dimensions(choose_formulation(gd, "squared").system) == [1, 1, 1, 1]
    assert local_dimensions(choose_formulation(dm, "squared").system) == [0, 0, 0, 0]
    assert "dir" in " ".join(choose_formulation(gd).system.names)
    assert "dir" not in " ".join(choose_formulation(dm).system.names)
    assert "dir" not in " ".join(choose_formulation(gd, "squared").system.names)


def test_auto_relaxation_follows_the_measured_rule():
    """relaxation="auto": the linear relaxation for mobile platforms with leg vectors, the
    Bernstein polytope elsewhere, squared legs of a mobile platform included (docs/benchmarks.md)."""
    from kinbox.model.loading import load
    from kinbox.pipeline import Problem

    picks = {n: Problem(load(n), n, 0.05).relaxation() for n in ("griffis-duffy", "dietmeier", "four-bar")}
    assert picks == {"griffis-duffy": "linear", "dietmeier": "bernstein", "four-bar": "bernstein"}
    assert Problem(load("griffis-duffy"), "gd", 0.05, legs="squared").relaxation() == "bernstein"
