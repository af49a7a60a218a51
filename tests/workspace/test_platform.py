"""Constant-orientation workspaces of parallel platforms (kinbox.workspace.platform): each
verdict checked against the legs' lengths computed independently -- with Pinocchio's forward
kinematics of the mechanism for a Gough-Stewart platform, from the builder's own points for a
3-RPR -- and the interval enclosure of the legs' squared lengths against python-flint's arb."""

from __future__ import annotations

import json
import math

import numpy as np
import pinocchio as pin
import pytest
from flint import arb, ctx

from kinbox.model.builders import stewart, three_rpr
from kinbox.workspace import BOUNDARY, INSIDE, OUTSIDE, Paving, reach_platform
from kinbox.workspace.platform import PlatformReach, legs_of
from tests.support import paths
from tests.support.cli import assert_usage_error, kinbox_cli


def _random_stewart(seed: int):
    """A 6-6 platform with random anchors, its leg lengths set at a home pose (t0, R0)."""
    rng = np.random.default_rng(seed)
    P = rng.uniform(-1.0, 1.0, (6, 3)) * [1, 1, 0.1]
    Q = rng.uniform(-0.5, 0.5, (6, 3)) * [1, 1, 0.1]
    R0 = pin.rpy.rpyToMatrix(*rng.uniform(-0.3, 0.3, 3))
    t0 = np.array([0.1, -0.05, 1.0])
    lengths = np.linalg.norm(t0 + Q @ R0.T - P, axis=1)
    return stewart(P, Q, lengths), t0, R0, lengths


def _leg_lengths_by_pinocchio(mech, t, R) -> np.ndarray:
    """The distance closures' lengths with the platform's free-flyer at (t, R), by Pinocchio FK."""
    model = mech.model
    data = model.createData()
    q = pin.neutral(model)
    q[:7] = pin.SE3ToXYZQUAT(pin.SE3(R, np.asarray(t, float)))
    pin.forwardKinematics(model, data, q)
    out = []
    for c in mech.closures:
        if c.kind == "distance":
            a = (data.oMi[c.joint_a] * c.placement_a).translation
            b = (data.oMi[c.joint_b] * c.placement_b).translation
            out.append(float(np.linalg.norm(a - b)))
    return np.array(out)


def _samples(lo, hi, rng, n=4):
    return lo + rng.uniform(0.02, 0.98, (n, len(lo))) * (hi - lo)


@pytest.mark.parametrize("seed", [0, 1])
def test_stewart_verdicts_hold_at_sampled_positions(seed):
    mech, t0, R0, lengths = _random_stewart(seed)
    quat = pin.Quaternion(R0).coeffs()
    region = np.concatenate([t0 - 0.6, t0 + 0.6])
    pv = reach_platform(mech, quat, legs_scale=(0.8, 1.2), region=region, resolution=0.08)
    assert pv.complete and pv.dims == 3
    c = pv.counts()
    assert c["inside"] > 0 and c["outside"] > 0
    home = np.all((pv.lo <= t0) & (t0 <= pv.hi), axis=1)
    assert np.any(home & (pv.verdict == INSIDE)) or np.any(home & (pv.verdict == BOUNDARY))
    rng = np.random.default_rng(seed)
    lo_len, hi_len = 0.8 * lengths, 1.2 * lengths
    for lo, hi, v in zip(pv.lo, pv.hi, pv.verdict):
        for t in _samples(lo, hi, rng, 2):
            L = _leg_lengths_by_pinocchio(mech, t, R0)
            ok = np.all((lo_len <= L) & (L <= hi_len))
            if v == INSIDE:
                assert ok, (lo, hi, L)
            elif v == OUTSIDE:
                assert not ok, (lo, hi, L)
    vol = pv.volumes()
    assert math.isclose(vol["inside"] + vol["outside"] + vol["boundary"], float(np.prod(region[3:] - region[:3])), rel_tol=1e-9)


def test_stewart_paving_is_the_same_over_worker_processes():
    mech, t0, R0, _ = _random_stewart(3)
    quat = pin.Quaternion(R0).coeffs()
    kw = {"legs_scale": (0.9, 1.1), "region": np.concatenate([t0 - 0.3, t0 + 0.3]), "resolution": 0.1}
    a = reach_platform(mech, quat, **kw)
    b = reach_platform(mech, quat, workers=2, **kw)
    assert np.array_equal(a.lo, b.lo) and np.array_equal(a.hi, b.hi) and np.array_equal(a.verdict, b.verdict)


def test_squared_lengths_enclose_arb_values():
    """The enclosure of every leg's squared length over a box holds its exact value (python-flint
    arb at 200 bits) at the box's corners and at random points, with the anchors and rotation
    entries taken as the exact binary64 numbers the decider was given."""
    mech, t0, R0, _ = _random_stewart(4)
    _, legs = legs_of(mech, scale=(0.8, 1.2))
    dec = PlatformReach(legs, R0)
    rng = np.random.default_rng(4)
    old = ctx.prec
    ctx.prec = 200
    try:
        for _ in range(30):
            lo = t0 + rng.uniform(-0.5, 0.5, 3)
            hi = lo + rng.uniform(1e-9, 0.2, 3)
            s_lo, s_hi = dec.squared_lengths(lo, hi)
            pts = [np.where(np.array(k, bool), hi, lo) for k in np.ndindex(2, 2, 2)] + list(_samples(lo, hi, rng, 4))
            for t in pts:
                for i in range(6):
                    s = arb(0)
                    for k in range(3):
                        x = (
                            arb(float(t[k]))
                            + sum(arb(float(R0[k, j])) * arb(float(legs.B[i, j])) for j in range(3))
                            - arb(float(legs.A[i, k]))
                        )
                        s += x * x
                    assert arb(float(s_lo[i])) <= s <= arb(float(s_hi[i])), (i, t)
    finally:
        ctx.prec = old


def _rpr_points(name: str):
    """Base and platform points as the built-in file gives them (independent of the legs' extraction)."""
    d = json.loads((paths.ROBOTS / f"{name}.json").read_text())
    if d["kind"] == "planar":
        g, p = d["links"]["ground"], d["links"]["platform"]
        return np.array([g[f"A{i}"] for i in (1, 2, 3)], float), np.array([p[f"B{i}"] for i in (1, 2, 3)], float)
    return np.array(d["base_points"], float), np.array(d["platform_points"], float)


@pytest.mark.parametrize("name", ["3-rpr", "planar-3-rpr"])
def test_three_rpr_verdicts_hold_at_sampled_positions(name):
    A, B = _rpr_points(name)
    phi = 0.4
    pv = reach_platform(name, phi, legs=(10.0, 22.0), region=(-15, -15, 35, 35), resolution=1.0)
    assert pv.complete and pv.dims == 2 and pv.counts()["inside"] > 0
    R = np.array([[math.cos(phi), -math.sin(phi)], [math.sin(phi), math.cos(phi)]])
    rng = np.random.default_rng(0)
    for lo, hi, v in zip(pv.lo, pv.hi, pv.verdict):
        for t in _samples(lo, hi, rng, 2):
            L = np.linalg.norm(t + B[:, :2] @ R.T - A[:, :2], axis=1)
            ok = np.all((10.0 <= L) & (L <= 22.0))
            if v == INSIDE:
                assert ok
                assert np.allclose(pv.witness[pv.verdict == INSIDE][:, 2], phi)
            elif v == OUTSIDE:
                assert not ok


def test_three_rpr_legs_default_to_the_prismatic_limits():
    mech = three_rpr([[0, 0], [10, 0], [0, 8]], [[0, 0], [6, 0], [2, 5]], leg_limits=(2.0, 9.0))
    _, legs = legs_of(mech)
    assert legs.planar and np.allclose(legs.lo, 2.0) and np.allclose(legs.hi, 9.0)
    assert np.allclose(legs.A[:, :2], [[0, 0], [10, 0], [0, 8]]) and np.allclose(legs.B[:, :2], [[0, 0], [6, 0], [2, 5]])


def test_cli_platform_paving_json_and_plot(tmp_path):
    out = tmp_path / "rpr.npz"
    p = kinbox_cli(
        "reach",
        "3-rpr",
        "--angle",
        "0.4",
        "--legs",
        "10",
        "22",
        "--region",
        "-15",
        "-15",
        "35",
        "35",
        "--resolution",
        "2",
        "--json",
        "--out",
        out,
    )
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["kind"] == "workspace" and d["complete"] and len(d["region"]["lo"]) == 2
    assert {b["verdict"] for b in d["boxes"]} <= {"inside", "outside", "boundary"}
    png = tmp_path / "rpr.png"
    q = kinbox_cli("plot", out, "-o", png)
    assert q.returncode == 0, q.stderr
    assert png.read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize(
    "args,words",
    [
        (("reach", "ur5", "--legs", "1", "2"), ["no legs"]),
        (("reach", "ur5", "--frame", "tool0", "--legs", "1", "2"), ["--legs", "platform"]),
        (("reach", "3-rpr", "--orientation", "1", "0", "0", "0"), ["about z"]),
        (("reach", "3-rpr", "--legs", "5", "1"), ["MIN < MAX"]),
        (("reach", "3-rpr", "--region", "0", "0", "1"), ["region"]),
        (("reach", "dietmeier", "--legs", "1", "2", "--legs-scale", "0.9", "1.1"), ["once"]),
    ],
)
def test_cli_platform_errors_are_one_line(args, words):
    assert_usage_error(kinbox_cli(*args), *words)


@pytest.mark.parametrize("suffix", [".npz", ".json"])
def test_a_paving_stopped_by_its_budget_resumes_to_the_same_paving(tmp_path, suffix):
    kw = {"legs": (10.0, 22.0), "region": (-15, -15, 35, 35), "resolution": 1.0}
    whole = reach_platform("3-rpr", 0.4, **kw)
    part = reach_platform("3-rpr", 0.4, max_boxes=300, **kw)
    assert not part.complete and len(part.pending) > 0
    f = tmp_path / f"part{suffix}"
    part.save(str(f))
    done = reach_platform("3-rpr", 0.4, resume=Paving.load(str(f)), **kw)
    assert done.complete
    key = np.lexsort(np.hstack([whole.lo, whole.hi]).T)
    key2 = np.lexsort(np.hstack([done.lo, done.hi]).T)
    assert np.array_equal(whole.lo[key], done.lo[key2]) and np.array_equal(whole.verdict[key], done.verdict[key2])


def test_resume_refuses_another_problem_and_a_file_that_is_no_paving(tmp_path):
    kw = {"legs": (10.0, 22.0), "region": (-15, -15, 35, 35), "resolution": 1.0}
    part = reach_platform("3-rpr", 0.4, max_boxes=50, **kw)
    f = tmp_path / "part.npz"
    part.save(str(f))
    assert_usage_error(kinbox_cli("reach", "3-rpr", "--angle", "0.5", "--legs", "10", "22", "--resume", f), "another problem")
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"not a zip")
    assert_usage_error(kinbox_cli("reach", "3-rpr", "--legs", "10", "22", "--resume", bad), "not a workspace paving")
