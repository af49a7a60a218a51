"""The equations of each pair: round trips q -> system point -> q on small hand-built models.

Each supported Pinocchio joint type is put first, in the middle and last of a three-joint
chain (the other two: RY and RZ), closed either by an IK goal (weld of the last frame) or by
a point closure; for a random ``q`` (seeded) the encoded point satisfies every equation and
inequality, and decoding gives ``q`` back.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from kinbox.errors import FormulationError
from kinbox.formulation import pairs as J
from kinbox.formulation.system import System
from kinbox.interval import cos_range, sin_range
from kinbox.model.mechanism import Closure, Mechanism
from tests.support.formulation_helpers import add_joint, random_placement, random_q, roundtrip

PI = math.pi


def joint_under_test(kind: str, rng):
    """(joint model, lower limits, upper limits) of each kind tested."""
    if kind == "RX":
        return pin.JointModelRX(), [-2.0], [2.5]
    if kind == "RY":
        return pin.JointModelRY(), None, None  # unlimited (+-DBL_MAX)
    if kind == "RZ":
        return pin.JointModelRZ(), [1.0], [5.5]  # limited range across pi
    if kind == "RZ_2pi":
        return pin.JointModelRZ(), [-2 * PI], [2 * PI]  # a range of 4 pi is unlimited
    if kind == "RevoluteUnaligned":
        a = rng.normal(size=3)
        return pin.JointModelRevoluteUnaligned(a / np.linalg.norm(a)), [-3.0], [1.0]
    if kind == "RevoluteUnaligned_negz":
        return pin.JointModelRevoluteUnaligned(np.array([0.0, 0.0, -1.0])), [-1.0], [2.0]
    if kind == "RUBZ":
        return pin.JointModelRUBZ(), None, None
    if kind == "RevoluteUnboundedUnaligned":
        # the Python binding cannot set its axis: take the joint from a URDF continuous joint
        a = rng.normal(size=3)
        a /= np.linalg.norm(a)
        xml = (
            '<robot name="r"><link name="b"/><link name="l"/><joint name="c" type="continuous">'
            f'<parent link="b"/><child link="l"/><axis xyz="{a[0]} {a[1]} {a[2]}"/></joint></robot>'
        )
        jm = pin.buildModelFromXML(xml).joints[1]
        assert jm.shortname() == "JointModelRevoluteUnboundedUnaligned"
        return jm, None, None
    if kind == "PX":
        return pin.JointModelPX(), [-0.3], [0.4]
    if kind == "PrismaticUnaligned":
        a = rng.normal(size=3)
        return pin.JointModelPrismaticUnaligned(a / np.linalg.norm(a)), [-0.2], [0.5]
    if kind == "Spherical":
        return pin.JointModelSpherical(), None, None
    if kind == "SphericalZYX":
        return pin.JointModelSphericalZYX(), None, None
    if kind == "Planar":
        return pin.JointModelPlanar(), [-1, -1, -1.01, -1.01], [1, 1, 1.01, 1.01]
    if kind == "Translation":
        return pin.JointModelTranslation(), [-1, -1, -1], [1, 1, 1]
    if kind == "FreeFlyer":
        lo = [-1, -1, -1] + [-1.01] * 4
        hi = [1, 1, 1] + [1.01] * 4
        return pin.JointModelFreeFlyer(), lo, hi
    if kind == "Composite":
        jm = pin.JointModelComposite()
        jm.addJoint(pin.JointModelRX(), random_placement(rng))
        jm.addJoint(pin.JointModelPY(), random_placement(rng))
        jm.addJoint(pin.JointModelRevoluteUnaligned(np.array([0.6, 0.0, 0.8])), random_placement(rng))
        return jm, [-2.0, -0.5, -PI], [2.0, 0.5, PI]
    raise AssertionError(kind)


KINDS = [
    "RX",
    "RY",
    "RZ",
    "RZ_2pi",
    "RevoluteUnaligned",
    "RevoluteUnaligned_negz",
    "RUBZ",
    "RevoluteUnboundedUnaligned",
    "PX",
    "PrismaticUnaligned",
    "Spherical",
    "SphericalZYX",
    "Planar",
    "Translation",
    "FreeFlyer",
    "Composite",
]


def chain(kind: str, position: int, seed: int):
    """A three-joint chain with the joint under test at ``position`` (0, 1 or 2)."""
    rng = np.random.default_rng(seed)
    model = pin.Model()
    others = [(pin.JointModelRY(), [-PI], [PI]), (pin.JointModelRZ(), [-2.0], [2.0])]
    specs = list(others)
    specs.insert(position, joint_under_test(kind, rng))
    parent = 0
    for k, (jm, lo, hi) in enumerate(specs):
        name = "test" if k == position else f"j{k}"
        parent = add_joint(model, parent, jm, random_placement(rng), name, lo, hi)
    model.addFrame(pin.Frame("tip", parent, random_placement(rng), pin.FrameType.OP_FRAME))
    return model, rng


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("position", [0, 1, 2])
@pytest.mark.parametrize("closure", ["weld", "point"])
def test_joint_roundtrip(kind, position, closure):
    model, rng = chain(kind, position, seed=10 * KINDS.index(kind) + position)
    for _ in range(3):
        q = random_q(model, rng)
        data = model.createData()
        pin.framesForwardKinematics(model, data, q)
        goal = data.oMf[model.getFrameId("tip")]
        mech = Mechanism(model, name=f"{kind}-{position}")
        if closure == "weld":
            mech.add_goal("tip", goal)
        else:
            f = model.frames[model.getFrameId("tip")]
            mech.closures.append(Closure("point", f.parentJoint, f.placement, 0, pin.SE3(np.eye(3), goal.translation), name="pin"))
        form = roundtrip(mech, q)
        assert "test" in form.joint_vars  # every joint that enters, even without variables
        assert form.dropped_joints == []


def test_joint_variable_names_and_tags():
    model, rng = chain("PX", 1, seed=3)
    q = random_q(model, rng)
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    mech = Mechanism(model).add_goal("tip", data.oMf[model.getFrameId("tip")])
    form = roundtrip(mech, q)
    s = form.system
    assert s.tags[s.index("d[test]")] == "disp"
    assert (s.lo[s.index("d[test]")], s.hi[s.index("d[test]")]) == (-0.3, 0.4)
    assert s.tags[s.index("c[j0]")] == "cos" and s.tags[s.index("s[j0]")] == "sin"
    assert set(form.joint_vars["test"]) == {"d[test]"}
    assert all(t in ("cos", "sin", "rot", "disp", "unit", "aux") for t in s.tags)


# ----------------------------------------------------------------------------------------------
# joint limits (Appendix I)
# ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("lo,hi", [(-2.0, 2.5), (1.0, 5.5), (-0.3, 0.2), (3.0, 3.5), (-3.0, -2.9)])
def test_revolute_limits_domains_and_chord(lo, hi):
    s = System()
    c, sv = J.revolute_angle(s, "j", lo, hi)
    assert (s.lo[0], s.hi[0]) == cos_range(lo, hi)
    assert (s.lo[1], s.hi[1]) == sin_range(lo, hi)
    assert s.count("ineq") == 1
    g = s.compile()
    for t in np.linspace(lo, hi, 50):  # inside: the chord inequality holds, domains too
        x = np.array([math.cos(t), math.sin(t)])
        assert g.eval_ineqs(x).max() <= 1e-15
        assert s.lo[0] <= x[0] <= s.hi[0] and s.lo[1] <= x[1] <= s.hi[1]
    for t in np.linspace(hi + 1e-3, lo + 2 * PI - 1e-3, 50):  # outside: violated
        x = np.array([math.cos(t), math.sin(t)])
        assert g.eval_ineqs(x).max() > 0


@pytest.mark.parametrize("lo,hi,unb", [(-PI, PI, False), (-2 * PI, 2 * PI, False), (-1e308, 1e308, False), (-1.0, 1.0, True)])
def test_revolute_unlimited(lo, hi, unb):
    s = System()
    J.revolute_angle(s, "j", lo, hi, unb)
    assert s.lo == [-1.0, -1.0] and s.hi == [1.0, 1.0] and s.count("ineq") == 0


def test_prismatic_infinite_limits_raise_unless_locked():
    model = pin.Model()
    j1 = add_joint(model, 0, pin.JointModelRZ(), pin.SE3.Identity(), "rz", [-1], [1])
    add_joint(model, j1, pin.JointModelPX(), pin.SE3(np.eye(3), np.array([0.3, 0, 0])), "slider")
    mech = Mechanism(model)
    mech.closures.append(Closure("point", 2, pin.SE3.Identity(), 0, pin.SE3(np.eye(3), np.array([0.5, 0.1, 0]))))
    from kinbox.formulation.build import formulate

    with pytest.raises(FormulationError, match="slider"):
        formulate(mech)
    mech.lock("slider", 0.2)
    form = formulate(mech)
    assert form.joint_vars.keys() == {"rz"}


@pytest.mark.parametrize("kind", ["HX", "HelicalUnaligned"])
def test_unsupported_joint_types_raise_naming_joint_and_type(kind):
    from kinbox.formulation.build import formulate

    model = pin.Model()
    # the pitch is given: pin.JointModelHX() leaves it uninitialised (sometimes NaN)
    jm = pin.JointModelHX(0.1) if kind == "HX" else pin.JointModelHelicalUnaligned(np.array([0.6, 0.0, 0.8]), 0.1)
    j = add_joint(model, 0, jm, pin.SE3.Identity(), "odd", [-1.0] * jm.nq, [1.0] * jm.nq)
    add_joint(model, j, pin.JointModelRZ(), pin.SE3(np.eye(3), np.array([0.3, 0, 0])), "rz")
    mech = Mechanism(model).add_goal("rz", pin.SE3.Identity())
    with pytest.raises(FormulationError, match=rf"'odd'.*{kind}"):
        formulate(mech)
    mech.lock("odd", np.zeros(jm.nq))  # locked, it is a constant: fine
    formulate(mech)


# ----------------------------------------------------------------------------------------------
# pair functions on their own
# ----------------------------------------------------------------------------------------------
def test_free_rotation_counts_and_values():
    s = System()
    R = J.free_rotation(s, "f")
    assert s.n == 9 and s.count("core") == 6 and s.count("redundant") == 3
    Q = pin.exp3(np.array([0.3, -1.2, 0.7]))
    x = np.array([Q[r, k] for k in range(3) for r in range(3)])
    assert np.abs(s.residuals(x)).max() < 1e-15
    assert np.allclose(R.value(x), Q)
    x2 = x.copy()
    x2[6:] *= -1  # det = -1 violates w = u x v
    assert np.abs(s.residuals(x2)).max() > 1


def test_revolute_propagation_is_linear_from_a_constant_and_materialized_on_demand():
    s = System()
    c, sv = J.revolute_angle(s, "a")
    B, labels = J.axis_basis(np.array([0.0, 0.0, 1.0]))
    K0 = pin.exp3(np.array([1.0, -0.5, 0.2]))
    R1 = J.revolute_propagate(s, "a", J.Rot.const(K0), np.eye(3), B, labels, c, sv, True, "a")
    assert R1.degree == 1 and s.n == 2
    c2, s2 = J.revolute_angle(s, "b")
    Rp = pin.exp3(np.array([0.4, 0.1, 0.0]))
    R2 = J.revolute_propagate(s, "b", R1, Rp, B, labels, c2, s2, True, "b")
    assert R2.degree == 2 and s.n == 4  # nothing materialized yet
    R2.linear()
    assert R2.degree == 1 and s.n == 10 and s.count("core") == 2 + 6
    t1, t2 = 0.7, -2.1
    x = np.zeros(s.n)
    x[:4] = [math.cos(t1), math.sin(t1), math.cos(t2), math.sin(t2)]
    expected = K0 @ pin.exp3(np.array([0, 0, t1])) @ Rp @ pin.exp3(np.array([0, 0, t2]))
    for i in range(4, s.n):  # materialized columns 0 and 1 of R2
        r, k = s.names[i][len("R[b][") : -1].split(",")
        x[i] = expected[int(r), int(k)]
    assert np.abs(s.residuals(x)).max() < 1e-15
    assert np.allclose(R2.value(x), expected, atol=1e-15)


def test_revolute_closing_equations():
    s = System()
    K = pin.exp3(np.array([0.2, -0.4, 1.0]))
    F = J.free_rotation(s, "p")
    G = J.free_rotation(s, "q")
    c, sv = J.revolute_angle(s, "r", -1.0, 2.0)
    a = np.array([0.0, 0.6, 0.8])
    B, _ = J.axis_basis(a)
    n0 = s.count("core")
    J.revolute_closing(s, "r", F, K, G, B, c, sv)
    assert s.count("core") - n0 == 4 and s.count("ineq") == 2
    Rp = pin.exp3(np.array([1.0, 2.0, -0.5]))
    for t, ok in ((0.5, True), (-0.9, True), (2.5, False)):
        Rc = Rp @ K @ pin.exp3(t * a)
        x = np.concatenate([Rp.T.ravel(), Rc.T.ravel(), [math.cos(t), math.sin(t)]])
        assert np.abs(s.residuals(x)).max() < 1e-14
        assert (s.compile().eval_ineqs(x).max() <= 1e-15) == ok  # 2.5 is beyond the limit
    # the flipped axis satisfies the core but not the sign inequality
    Rc = Rp @ K @ B @ np.diag([1.0, -1.0, -1.0]) @ B.T
    x = np.concatenate([Rp.T.ravel(), Rc.T.ravel(), [1.0, 0.0]])
    core = s.residuals(x)[: s.count("core")]
    assert np.abs(core).max() < 1e-14 and s.compile().eval_ineqs(x).max() > 1


def test_axis_basis():
    for a in (np.eye(3)[0], np.eye(3)[1], np.eye(3)[2], -np.eye(3)[2], np.array([0.6, 0, 0.8])):
        B, labels = J.axis_basis(a)
        assert np.allclose(B.T @ B, np.eye(3)) and np.isclose(np.linalg.det(B), 1.0)
        assert np.allclose(B[:, 2], a)
        std = np.allclose(np.abs(a).max(), 1.0)
        assert (labels != ("b1", "b2")) == std


def test_each_pinocchio_type_has_one_family_and_each_family_the_protocol():
    """The registry: every joint type the round trips cover is claimed by exactly one family,
    whose part has that family's kind; every family answers the protocol's questions."""
    types = {t: fam for fam in J.FAMILIES.values() for t in fam.pinocchio_types}
    claimed = [t for fam in J.FAMILIES.values() for t in fam.pinocchio_types]
    assert len(claimed) == len(set(claimed))
    models = {
        "RX": pin.JointModelRX(),
        "RUBZ": pin.JointModelRUBZ(),
        "PY": pin.JointModelPY(),
        "Spherical": pin.JointModelSpherical(),
        "SphericalZYX": pin.JointModelSphericalZYX(),
        "FreeFlyer": pin.JointModelFreeFlyer(),
        "Planar": pin.JointModelPlanar(),
        "Translation": pin.JointModelTranslation(),
        "RevoluteUnaligned": pin.JointModelRevoluteUnaligned(np.array([0.0, 0.6, 0.8])),
        "PrismaticUnaligned": pin.JointModelPrismaticUnaligned(np.array([0.6, 0.0, 0.8])),
    }
    models = {t: pin.JointModel(jm) for t, jm in models.items()}  # generic, as in model.joints
    for t, jm in models.items():
        (part,) = J.joint_parts(jm, "j")
        assert J.family(part.kind) is types[t]
    for fam in J.FAMILIES.values():
        assert fam.rotation in ("rev", "const", "free")
        assert fam.translation in ("none", "local", "world")
    rx = J.joint_parts(models["RX"], "j")[0]
    assert J.family("revolute").limits_search(rx, np.array([-1.0]), np.array([1.0]))
    assert not J.family("revolute").limits_search(rx, np.array([-4.0]), np.array([4.0]))
    sys = System()
    ((d, a),) = J.family("prismatic").displacements(sys, "p", J.joint_parts(models["PY"], "p")[0], np.array([-0.5]), np.array([0.25]))
    assert sys.names == ["d[p]"] and np.allclose(a, [0.0, 1.0, 0.0])
    assert (sys.lo[0], sys.hi[0]) == (-0.5, 0.25)
