"""No curve where the roots are isolated, no configuration twice, every root found: UR arms
near their wrist and elbow singularities against roots computed at 40 digits
(tests/support/oracles/mp_ik.py, complex Newton on the pose as given)."""

from __future__ import annotations

import numpy as np
import pytest

import kinbox
from tests.support.enclosures import oracle_check


def _angle_gap(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(np.angle(np.exp(1j * (np.asarray(a)[:6] - np.asarray(b)[:6]))))))


def check_against_oracle(robot: str, q: list[float]) -> tuple:
    """Solve the pose of ``q`` and check the answer against the 40-digit roots: every real root
    is in a certified box or within the width of a reported uncertified point (a cluster the
    precision cannot separate, with that many roots); no certified box misses the root it
    claims; no configuration is reported twice; no curve where every root is isolated."""
    ik = kinbox.IK(robot, "tool0")
    goal = ik.pose_at(q)
    res = ik.solve(goal)
    # starting points independent of kinbox: the closed form of the published UR geometry (off
    # from the URDF's by ~1e-11, and at a wrist below 1e-12 it takes theta6 = 0): Newton at 40
    # digits from each
    from tests.support.oracles.ur_ik import ur_ik

    seeds = [q, *ur_ik(robot, goal.homogeneous, tol=1e-6, singular="zero")]
    rep = oracle_check(ik, goal, res, seeds)
    sols = res.solutions
    # no configuration twice: distinct reported points, none inside another's certified box
    for i in range(len(sols)):
        for j in range(i):
            assert _angle_gap(sols[i].q, sols[j].q) > max(sols[i].width, sols[j].width, 1e-12), (sols[i].q, sols[j].q)
    # every certified solution holds a root of the pose as given
    for s in sols:
        if s.certified:
            assert any(r["in_certified_box"] and r["distance"] <= s.width + 1e-12 for r in rep["roots"]), s.q
    # every real root is reported: in a certified box, or within an uncertified point's width,
    # and a point standing for several roots says so (its multiplicity)
    for r in rep["roots"]:
        if r["in_certified_box"]:
            continue
        near = [s for s in sols if not s.certified and _angle_gap(s.q, r["q"]) <= max(s.width, 1e-9)]
        assert near, f"root {r['q']} not reported"
        k = sum(1 for o in rep["roots"] if _angle_gap(o["q"], near[0].q) <= max(near[0].width, 1e-9))
        assert near[0].multiplicity is None or near[0].multiplicity >= k
    # isolated roots only (the oracle's roots are regular): no curve
    assert not any(c.dimension >= 1 for c in res.components), "a curve where the roots are isolated"
    return res, rep


@pytest.mark.parametrize(
    "robot",
    [
        "ur5",
        pytest.param(
            "ur10",
            marks=[
                pytest.mark.slow,
                # the arm's constants are taken as exact (template.TEMPLATE_COEF_ERR): the oracle's
                # arm (Pinocchio's placements, each rotation read through its quaternion) is ulps
                # away, and one regular root's box, 1.9e-15 wide, misses its root by 1.4e-16
                pytest.mark.xfail(reason="the arm's constants are not enclosed"),
            ],
        ),
    ],
)
def test_no_curve_where_the_roots_are_isolated(robot):
    """1e-10 from the wrist singularity: 8 isolated roots (two pairs along the singular arm's
    self-motion, 1e-10 from it). They were reported as a curve whose points miss the pose by
    6e-11..9e-11, hiding two of them; now all 8 are certified in boxes holding the 40-digit
    roots, and no curve."""
    res, rep = check_against_oracle(robot, [0.3, -1.2, 1.5, -0.8, 1e-10, 0.4])
    assert rep["real"] == 8
    assert sum(1 for s in res.solutions if s.certified) == 8


def test_a_pair_the_precision_cannot_separate_is_reported_as_one():
    """1e-8 from the elbow singularity the two real roots (q3 = +-2.09e-8) are closer than the
    enclosures of the pose's rows can separate: one point, multiplicity 2, with the width
    that holds both (and the JSON says so)."""
    res, rep = check_against_oracle("ur5", [0.3, -1.2, 1e-8, -0.8, 1.2, 0.4])
    assert rep["real"] == 2
    (s,) = res.solutions
    assert not s.certified and s.singular and s.multiplicity == 2
    assert res.to_dict()["solutions"][0]["not_separated_within"] == s.width


WRIST = [10.0**-k for k in range(1, 13)]
ELBOW = [10.0**-k for k in range(3, 13)]
#: at and below this the wrist's valley of near-solutions hides roots: at 1e-11 two stay in undecided boxes,
#: at 1e-12 the valley is shallower than the tube a curve must close to and is reported as one
VALLEY = 1e-11
#: the arm's constants are taken as exact (template.TEMPLATE_COEF_ERR): at 1e-7 two certified
#: boxes, 2.2e-9 wide, miss the 40-digit roots of Pinocchio's placements by 1.1e-17
CONSTANTS = "the arm's constants are not enclosed"
CONSTANTS_MISS = (1e-7,)


@pytest.mark.slow
@pytest.mark.parametrize(
    "q5",
    [
        pytest.param(v, marks=pytest.mark.xfail(reason="roots in a valley the curve test cannot tell from a curve"))
        if v <= VALLEY
        else pytest.param(v, marks=pytest.mark.xfail(reason=CONSTANTS))
        if v in CONSTANTS_MISS
        else v
        for v in WRIST
    ],
)
def test_wrist_sweep(q5):
    check_against_oracle("ur5", [0.3, -1.2, 1.5, -0.8, q5, 0.4])


@pytest.mark.slow
@pytest.mark.parametrize("q3", ELBOW)
def test_elbow_sweep(q3):
    check_against_oracle("ur5", [0.3, -1.2, q3, -0.8, 1.2, 0.4])
