"""Planar mechanisms: the ``"planar"`` file kind, the planar formulation and its answers.

Answers are compared with independent references, never with kinbox itself:

* circle intersections for the Watt six-bar (``tests/support/oracles/planar.py`` for the four-bar);
* the 3-RPR sextic of ``tests/support/oracles/planar.py`` on random parameters;
* :func:`multistart`: Gauss-Newton from many random starts on the loop equations written here
  from the mechanism file (one pose ``(x, y, theta)`` per link, numpy only): every assembly it
  finds must be among kinbox's (a root kinbox missed would show here);
* closures measured with Pinocchio forward kinematics (``Mechanism.closure_residuals``).
"""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pinocchio as pin
import pytest
from scipy.optimize import least_squares

import kinbox
from kinbox.errors import ModelError
from kinbox.formulation.planar import PlanarFormulation, formulate_planar, planar_axis
from kinbox.model.planar import planar_mechanism
from kinbox.pipeline import choose_formulation
from tests.support import paths as PATHS
from tests.support.oracles.planar import three_rpr_assemblies

ROBOTS = PATHS.ROBOTS
TOL = 1e-10


def spec(name: str) -> dict:
    return json.loads((ROBOTS / f"{name}.json").read_text())


def rot(t: float) -> np.ndarray:
    return np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]])


def wrap(a: float) -> float:
    return float(np.angle(np.exp(1j * a)))


def assert_closed(res) -> None:
    for k, s in enumerate(res.solutions):
        for name, pos, ang in res.mechanism.closure_residuals(s.q):
            assert pos < TOL and ang < TOL, f"solution {k}: closure {name}: {pos:.2e}"


def link_poses(res, links) -> list[dict[str, tuple[float, float, float]]]:
    """World pose (x, y, theta) of each link frame at each solution, by Pinocchio FK."""
    model = res.mechanism.model
    data = model.createData()
    out = []
    for s in res.solutions:
        pin.framesForwardKinematics(model, data, s.q)
        poses = {}
        for n in links:
            M = data.oMf[model.getFrameId(n, pin.FrameType.OP_FRAME)]
            poses[n] = (float(M.translation[0]), float(M.translation[1]), math.atan2(M.rotation[1, 0], M.rotation[0, 0]))
        out.append(poses)
    return out


# -- an independent solver: one pose per link, Gauss-Newton from random starts ---------------------
def _point(ref, links):
    if isinstance(ref, str):
        link, _, p = ref.rpartition(".")
        return link, np.asarray(links[link][p], float)
    return ref[0], np.asarray(ref[1], float)


def multistart(sp: dict, starts: int, seed: int = 0, locked: dict | None = None) -> list[dict[str, tuple[float, float, float]]]:
    """Assemblies of a planar mechanism file found by Gauss-Newton from ``starts`` random
    starts: unknowns ``(x, y, theta)`` of every link but the ground, residuals per pair (revolute:
    the two points; fixed: the points and the angle; prismatic: B's point on A's line and the
    angle, displacement locked by ``locked``), per bar (the distance)."""
    links = sp["links"]
    ground = sp.get("ground", "ground")
    free = [n for n in links if n != ground]
    locked = locked or {}
    size = sum(float(np.abs(np.asarray(v, float)).sum()) for pts in links.values() for v in pts.values())
    size += sum(b["length"] for b in sp.get("bars", []))

    def world(z, link, p):
        if link == ground:
            return p, 0.0
        k = free.index(link)
        x, y, t = z[3 * k : 3 * k + 3]
        return np.array([x, y]) + rot(t) @ p, t

    def residual(z):
        r = []
        for j in sp["joints"]:
            (a, pa), (b, pb) = (_point(e, links) for e in j["between"])
            wa, ta = world(z, a, pa)
            wb, tb = world(z, b, pb)
            if j["type"] == "revolute":
                r += list(wa - wb)
            elif j["type"] == "fixed":
                r += list(wa - wb) + [wrap(tb - ta - j.get("angle", 0.0))]
            else:
                u = rot(ta) @ np.asarray(j.get("axis", [1, 0]), float)
                d = locked[j["name"]]
                r += list(wa + d * u - wb) + [wrap(tb - ta - j.get("angle", 0.0))]
        for bar in sp.get("bars", []):
            (a, pa), (b, pb) = (_point(e, links) for e in bar["between"])
            wa, _ = world(z, a, pa)
            wb, _ = world(z, b, pb)
            r.append((float(np.sum((wb - wa) ** 2)) - bar["length"] ** 2) / max(bar["length"], 1.0))
        return np.array(r)

    rng = np.random.default_rng(seed)
    found: list[np.ndarray] = []
    for _ in range(starts):
        z0 = np.concatenate([[*rng.uniform(-size, size, 2) * 0.3, rng.uniform(-math.pi, math.pi)] for _ in free])
        sol = least_squares(residual, z0, method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=100 * len(z0))
        if np.max(np.abs(residual(sol.x))) > 1e-9:
            continue
        z = sol.x.copy()
        z[2::3] = [wrap(t) for t in z[2::3]]
        if not any(np.max(np.abs(np.angle(np.exp(1j * (z - f))))) < 1e-6 for f in found):
            found.append(z)
    return [{n: tuple(float(v) for v in z[3 * k : 3 * k + 3]) for k, n in enumerate(free)} for z in found]


def same_pose(p, q, tol=1e-7) -> bool:
    return abs(p[0] - q[0]) < tol and abs(p[1] - q[1]) < tol and abs(wrap(p[2] - q[2])) < tol


def assert_multistart_found_nothing_new(res, sp, starts, locked=None):
    poses = link_poses(res, [n for n in sp["links"] if n != sp.get("ground", "ground")])
    ms = multistart(sp, starts, locked=locked)
    assert ms, "the multi-start found no assembly at all"
    for m in ms:
        assert any(all(same_pose(m[n], p[n]) for n in m) for p in poses), f"kinbox missed the assembly {m}"
    return ms


# -- detection ---------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["four-bar", "four-bar.xml", "3-rpr", "watt-six-bar", "planar-3-rpr", "double-butterfly"])
def test_planar_models_get_the_planar_formulation(name):
    mech = kinbox.load(name)
    assert planar_axis(mech) is not None
    assert isinstance(choose_formulation(mech), PlanarFormulation)


@pytest.mark.parametrize("name", ["general-6r", "bricard", "dietmeier", "delta"])
def test_spatial_models_are_not_planar(name):
    assert planar_axis(kinbox.load(name)) is None
    assert not isinstance(choose_formulation(kinbox.load(name), formulation="general"), PlanarFormulation)


def test_parallel_axes_off_z_are_planar():
    """A DH loop whose twists are 0 or pi (all axes parallel, some reversed) is planar: a
    parallelogram four-bar written as a DH loop, with one joint set."""
    rows = [[2.0, 0.0, 0.0], [1.0, 0.0, math.pi], [2.0, 0.0, math.pi], [1.0, 0.0, 0.0]]
    mech = kinbox.load({"kind": "dh-loop", "dh": rows, "set": {"joint1": 0.4}})
    f = formulate_planar(mech)
    assert f is not None and f.system.n == 4  # two turning links (the weld holds the last to the ground)
    res = kinbox.solve(mech, time_limit=60)
    assert res.complete and res.solutions and all(s.certified for s in res.solutions)
    assert_closed(res)


def test_formulation_general_and_planar_agree_on_3rpr():
    a = kinbox.solve("3-rpr", time_limit=60)
    b = kinbox.solve("3-rpr", formulation="general", time_limit=60)
    assert len(a.solutions) == len(b.solutions) == 6
    for s in a.solutions:
        assert min(np.max(np.abs(s.q - t.q)) for t in b.solutions) < 1e-9


def test_planar_formulation_refuses_a_spatial_mechanism():
    with pytest.raises(kinbox.InputError, match="not planar"):
        kinbox.solve("general-6r", formulation="planar")


def test_encode_decode_round_trip():
    res = kinbox.solve("double-butterfly", time_limit=120)
    f = res.formulated
    for s in res.solutions:
        x = f.encode(s.q)
        assert np.max(np.abs(f.system.residuals(x))) < 1e-9
        assert np.max(np.abs(f.decode(x) - s.q)) < 1e-9


# -- answers against independent solutions -----------------------------------------------------
def _circle(p, r, q, s):
    """Intersections of the circles |x - p| = r and |x - q| = s."""
    d = float(np.hypot(*(q - p)))
    a = (d * d + r * r - s * s) / (2 * d)
    h2 = r * r - a * a
    if h2 < 0:
        return []
    u = (q - p) / d
    n = np.array([-u[1], u[0]])
    return [p + a * u + math.sqrt(h2) * n, p + a * u - math.sqrt(h2) * n]


@pytest.mark.parametrize("crank", [0.7, -2.0, 2.9])
def test_watt_six_bar_matches_circle_intersections(crank):
    sp = spec("watt-six-bar")
    L = {n: {p: np.asarray(v, float) for p, v in pts.items()} for n, pts in sp["links"].items()}
    A, D = L["ground"]["A"], L["ground"]["D"]
    B = A + rot(crank) @ L["crank"]["B"]
    want = []
    for C in _circle(B, np.linalg.norm(L["coupler"]["C"]), D, np.linalg.norm(L["rocker"]["C"])):
        tc = math.atan2(*(C - B)[::-1]) - math.atan2(*L["coupler"]["C"][::-1])
        tr = math.atan2(*(C - D)[::-1]) - math.atan2(*L["rocker"]["C"][::-1])
        E, F = B + rot(tc) @ L["coupler"]["E"], D + rot(tr) @ L["rocker"]["F"]
        for G in _circle(E, np.linalg.norm(L["link5"]["G"]), F, np.linalg.norm(L["link6"]["G"])):
            want.append(np.concatenate([C, G]))
    res = kinbox.solve("watt-six-bar", set={"crank": crank}, time_limit=60)
    assert res.complete and all(s.certified for s in res.solutions)
    assert_closed(res)
    model = res.mechanism.model
    data = model.createData()
    got = []
    for s in res.solutions:
        pin.framesForwardKinematics(model, data, s.q)
        got.append(np.concatenate([data.oMf[model.getFrameId(f)].translation[:2] for f in ("coupler.C", "link5.G")]))
    assert len(got) == len(want) == 4
    for w in want:
        assert sum(np.max(np.abs(w - g)) < 1e-9 for g in got) == 1


def _rpr_spec(A, b, legs) -> dict:
    sp = spec("planar-3-rpr")
    sp["links"]["ground"] = {f"A{i + 1}": list(map(float, A[i])) for i in range(3)}
    sp["links"]["platform"] = {f"B{i + 1}": list(map(float, b[i])) for i in range(3)}
    for j in sp["joints"]:
        if j["type"] == "prismatic":
            j["limits"] = [0.0, 100.0]
    sp["set"] = {f"leg{i + 1}": float(legs[i]) for i in range(3)}
    return sp


@pytest.mark.parametrize("seed", range(4))
def test_3rpr_random_parameters_match_the_sextic(seed):
    """Random base, platform and an assembled pose's leg lengths: kinbox's assembly modes are
    exactly the real roots of the sextic."""
    rng = np.random.default_rng(100 + seed)
    A = rng.uniform(-10, 10, (3, 2))
    b = rng.uniform(-6, 6, (3, 2))
    b -= b[0]  # the platform frame at B1, as the file's
    x, y, phi = *rng.uniform(-5, 5, 2), rng.uniform(-math.pi, math.pi)
    legs = np.linalg.norm(np.array([x, y]) + b @ rot(phi).T - A, axis=1)
    want = three_rpr_assemblies(A, b, legs)
    res = kinbox.solve(_rpr_spec(A, b, legs), time_limit=60)
    assert res.complete and all(s.certified for s in res.solutions)
    assert_closed(res)
    got = [p["platform"] for p in link_poses(res, ["platform"])]
    assert len(got) == len(want), (got, want)
    for w in want:
        assert sum(same_pose(w, g) for g in got) == 1


def test_double_butterfly_six_assemblies_and_multistart():
    """CuikSuite's rigid Double Butterfly: 6 isolated assemblies (its documentation's 6
    solution boxes), all certified; 60 Gauss-Newton starts find none other."""
    res = kinbox.solve("double-butterfly", time_limit=120)
    assert res.complete and len(res.solutions) == 6 and all(s.certified for s in res.solutions)
    assert not res.components or all(c.dimension == 0 for c in res.components)
    assert_closed(res)
    assert_multistart_found_nothing_new(res, spec("double-butterfly"), 60)


@pytest.mark.slow
def test_watt_baranov_76_assemblies():
    """CuikSuite's Watt-Baranov truss: 76 isolated assemblies (its documentation's 76 solution
    boxes), all certified; 1500 Gauss-Newton starts find none other."""
    res = kinbox.solve("watt-baranov", time_limit=600)
    assert res.complete and len(res.solutions) == 76 and all(s.certified for s in res.solutions)
    assert_closed(res)
    assert_multistart_found_nothing_new(res, spec("watt-baranov"), 1500)


def test_revolute_limits_cut_assemblies():
    """A limit on the rocker's relative angle keeps exactly the assemblies inside it."""
    free = kinbox.solve("watt-six-bar", set={"crank": 0.7}, time_limit=60)
    sp = spec("watt-six-bar")
    for j in sp["joints"]:
        if j["name"] == "rocker":
            j["limits"] = [0.0, 2.0]
    sp["set"] = {"crank": 0.7}
    res = kinbox.solve(sp, time_limit=60)
    k = res.mechanism.model.getJointId("rocker")
    iq = res.mechanism.model.joints[k].idx_q
    want = [s.q for s in free.solutions if 0.0 <= s.q[iq] <= 2.0]
    assert 0 < len(want) < len(free.solutions)
    assert len(res.solutions) == len(want)
    for s in res.solutions:
        assert min(np.max(np.abs(s.q - w)) for w in want) < 1e-9


def test_pairs_written_child_first():
    """Revolute pairs listed with the link nearer the ground second: the same assemblies, each
    such joint's q the opposite (q is the angle of the pair's second link to its first)."""
    sp = spec("planar-3-rpr")
    flipped = json.loads(json.dumps(sp))
    for j in flipped["joints"]:
        if j["name"] in ("base2", "pivot1"):
            j["between"] = j["between"][::-1]
    a = kinbox.solve(sp, time_limit=60)
    b = kinbox.solve(flipped, time_limit=60)
    assert len(a.solutions) == len(b.solutions) == 6
    names = list(a.mechanism.model.names)
    for s in a.solutions:
        qa = {n: s.q[a.mechanism.model.joints[k].idx_q] for k, n in enumerate(names) if k}
        sign = {n: -1.0 if n in ("base2", "pivot1") else 1.0 for n in qa}
        assert any(
            all(abs(wrap(sign[n] * qa[n] - t.q[b.mechanism.model.joints[b.mechanism.model.getJointId(n)].idx_q])) < 1e-9 for n in qa)
            for t in b.solutions
        )


def test_prismatic_pair_written_child_first():
    """A slider whose pair lists the slider first: the leg length is still its q."""
    sp = spec("planar-3-rpr")
    for j in sp["joints"]:
        if j["name"] == "leg1":
            j["between"] = j["between"][::-1]
            j["axis"] = [-1, 0]  # rod1's axis seen from the slider (turned by angle 0)
    res = kinbox.solve(sp, time_limit=60)
    assert len(res.solutions) == 6
    assert_closed(res)


def test_planar_mechanism_model():
    mech = planar_mechanism(
        {"ground": {"A": [0, 0], "D": [3, 0]}, "crank": {"B": [1, 0]}, "coupler": {"C": [3, 0]}},
        [
            {"name": "crank", "type": "revolute", "between": ["ground.A", ["crank", [0, 0]]]},
            {"name": "coupler", "type": "revolute", "between": ["crank.B", ["coupler", [0, 0]]]},
        ],
        bars=[{"name": "rocker", "between": ["coupler.C", "ground.D"], "length": 2.0}],
    )
    assert [mech.model.names[k] for k in range(1, mech.model.njoints)] == ["crank", "coupler"]
    assert [c.kind for c in mech.closures] == ["distance"]
    assert all(mech.model.existFrame(n) for n in ("ground", "crank.B", "coupler.C"))
    res = kinbox.solve(mech, set={"crank": 0.7}, time_limit=60)
    assert len(res.solutions) == 2
    assert_closed(res)


@pytest.mark.parametrize(
    "edit,message",
    [
        (lambda s: s["joints"][0].update(between=["ground.A1", "nowhere.O"]), "not 'link.point'"),
        (lambda s: s["joints"][0].update(type="ball"), "revolute, prismatic or fixed"),
        (lambda s: s["joints"][3].pop("limits"), "needs limits"),
        (lambda s: s.update(joints=s["joints"][:6]), "not joined to the ground"),
        (lambda s: s["links"]["rod1"].update(O=[0, float("nan")]), "not finite"),
        (lambda s: s.update(ground="sky"), "ground link 'sky'"),
    ],
)
def test_bad_planar_files(edit, message):
    sp = spec("planar-3-rpr")
    edit(sp)
    with pytest.raises(ModelError, match=message):
        kinbox.load(sp)


def test_bad_planar_file_cli(tmp_path):
    sp = spec("planar-3-rpr")
    sp["joints"][0]["between"] = ["ground.A9", "rod1.O"]
    p = tmp_path / "bad.json"
    p.write_text(json.dumps(sp))
    out = subprocess.run([sys.executable, "-m", "kinbox.cli", "solve", str(p)], capture_output=True, text=True)
    assert out.returncode == 2 and out.stderr.startswith("kinbox: error:") and "A9" in out.stderr
    assert "Traceback" not in out.stderr


@pytest.mark.parametrize(
    "args,words",
    [
        (["general-6r", "--formulation", "planar"], ["not planar"]),
        (["four-bar", "--formulation", "coordinates"], ["constraint systems"]),
    ],
)
def test_cli_formulation_of_a_mechanism(args, words):
    from tests.support.cli import assert_usage_error, kinbox_cli

    assert_usage_error(kinbox_cli("solve", *args), *words)


def test_cli_general_formulation_of_a_planar_mechanism():
    from tests.support.cli import kinbox_cli

    out = kinbox_cli("solve", "planar-3-rpr", "--formulation", "general", "--json")
    assert out.returncode == 0, out.stderr
    d = json.loads(out.stdout)
    assert len(d["solutions"]) == 6 and d["stats"]["variables"] == 8


def test_planar_arm_ik():
    """A planar 3R arm (DH twists 0): the IK of a pose in its plane goes through the planar
    formulation; its two solutions (elbow up and down) put the tool at the pose (Pinocchio FK).
    A pose out of the plane has no solution (a proven empty answer)."""
    arm = {"kind": "dh-arm", "dh": [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.8, 0.0, 0.0]]}
    ik = kinbox.IK(kinbox.load(arm), "tool")
    q0 = np.array([0.3, 0.9, -0.4])
    pose = ik.pose_at(q0)
    res = ik.solve(pose, time_limit=60)
    assert isinstance(res.formulated, PlanarFormulation) and res.formulation == "planar"
    assert res.complete and len(res.solutions) == 2 and all(s.certified for s in res.solutions)
    assert min(np.max(np.abs(s.q - q0)) for s in res.solutions) < 1e-9
    for s in res.solutions:
        assert ik.pose_at(s.q).isApprox(pose, 1e-9)
    lifted = pin.SE3(pose.rotation, pose.translation + np.array([0.0, 0.0, 0.1]))
    empty = ik.solve(lifted, time_limit=60)
    assert empty.complete and empty.solutions == [] and empty.components == []


def test_planar_answer_replays(tmp_path):
    """A planar answer is a result like any other: its JSON replays (meshcat scene, bars drawn
    as segments at their lengths) and writes an HTML page."""
    from kinbox.viz import replay

    sp = {
        "kind": "planar",
        "links": {"ground": {"A": [0, 0], "D": [3, 0]}, "crank": {"B": [1, 0]}, "coupler": {"C": [3, 0]}},
        "joints": [
            {"name": "crank", "type": "revolute", "between": ["ground.A", ["crank", [0, 0]]]},
            {"name": "coupler", "type": "revolute", "between": ["crank.B", ["coupler", [0, 0]]]},
        ],
        "bars": [{"name": "rocker", "between": ["coupler.C", "ground.D"], "length": 2.0}],
    }
    path = tmp_path / "bar.json"
    path.write_text(json.dumps(sp))
    res = kinbox.solve(str(path), set={"crank": 0.7}, time_limit=60)
    d = json.loads(json.dumps(res.to_dict()))
    show = replay.prepare(d)
    assert len(show.qs) == 2 and len(show.segments) == 1
    for q in show.qs:
        show.place(q)
        seg = show.segments[0]
        a = show.data.oMi[seg.joint_a].act(seg.point_a)
        b = show.data.oMi[seg.joint_b].act(seg.point_b)
        assert abs(np.linalg.norm(b - a) - 2.0) < 1e-9
    page = replay.to_html(d, tmp_path / "bar.html")
    assert "MeshCat.Viewer" in page.read_text()


@pytest.mark.parametrize("name,mobility", [("four-bar", 1), ("watt-six-bar", 1), ("planar-3-rpr", 0)])
def test_planar_mobility_by_counting(name, mobility):
    """Grubler's count in the plane (two conditions per pin closure, one per bar) agrees with
    the rank of the closure Jacobian at configurations found."""
    from kinbox.problems.diagnosis import diagnose_mechanism

    diag = diagnose_mechanism(kinbox.load(name))
    assert diag.counted_mobility == mobility and set(diag.at_solutions) == {mobility}


def test_circles_and_lines_class():
    """Square planar systems whose rows are linear but for the unit circles (revolute joints,
    no bars) get CuikSuite's search (full LP sweeps on every box, error-based splits); bars add
    direction unknowns, and a curve's system is not square."""
    from kinbox.formulation.planar import circles_and_lines
    from kinbox.pipeline import Problem

    def system(name):
        return choose_formulation(kinbox.load(name)).system

    assert circles_and_lines(system("double-butterfly")) and circles_and_lines(system("planar-3-rpr"))
    assert not circles_and_lines(system("watt-baranov"))  # bars: direction unknowns
    assert not circles_and_lines(system("rhombus"))  # a curve: 5 equations in 6 unknowns
    prob = Problem(kinbox.load("double-butterfly"), "db", 0.05)
    assert prob.search_defaults() == {"relaxation": "linear", "lp_sweep": True, "policy": "eager", "bisection": "error"}
    assert Problem(kinbox.load("rhombus"), "rh", 0.05).search_defaults() == {}


def test_sweep_search_gives_the_same_assemblies_in_fewer_boxes():
    """The Double Butterfly by its default search (full LP sweeps, error-based splits) and by
    the steady one: the same six certified assemblies; the sweeps settle it in fewer boxes."""
    fast = kinbox.solve("double-butterfly")
    steady = kinbox.solve("double-butterfly", relaxation="bernstein", lp_sweep=False, policy="steady", bisection="smear")
    assert fast.complete and steady.complete
    assert len(fast.solutions) == len(steady.solutions) == 6 and all(s.certified for s in fast.solutions)
    for s in fast.solutions:
        assert sum(np.allclose(s.q, t.q, atol=1e-8) for t in steady.solutions) == 1
    assert fast.raw.stats["boxes"] < steady.raw.stats["boxes"]
