"""Replays: meshcat scenes, the self-contained HTML page, and what headless Chromium shows of it.

The Chromium tests render real pages (UR5 meshes, a Stewart platform from simple shapes, and
an empty answer as a negative control) and count robot pixels in the screenshot, so they fail
on a blank or robot-less page. Chromium is the Debian package ``chromium``; it is installed if
missing (``apt-get``), and the tests are skipped only if that is impossible.
"""

from __future__ import annotations

import base64
import json
import math
import os
import re
import shutil
import subprocess
import sys

import numpy as np
import pinocchio as pin
import pytest

import kinbox
from kinbox.answer.refine import refine
from kinbox.answer.result import max_residual
from kinbox.cli import main
from kinbox.errors import InputError
from kinbox.model.loading import load
from kinbox.viz import replay
from tests.support.oracles.ur_ik import ur_ik

SHOTS = os.environ.get("KINBOX_TEST_SHOTS")  # keep the pages and screenshots in this folder if set


# -------------------------------------------------------------------------------------------
# results to show
# -------------------------------------------------------------------------------------------
def _ur5_result(q=(0.3, -1.2, 1.5, -0.8, 1.2, 0.4)) -> dict:
    """A UR5 IK result as `kinbox ik --json` writes it, its solutions from the closed-form oracle."""
    model = load("ur5").model
    data = model.createData()
    pin.framesForwardKinematics(model, data, np.asarray(q, dtype=float))
    T = data.oMf[model.getFrameId("tool0")]
    qs = ur_ik("ur5", T.homogeneous)
    assert len(qs) == 8
    return {
        "problem": "ik ur5 tool0",
        "source": {
            "kind": "ik",
            "robot": "ur5",
            "frame": "tool0",
            "base": None,
            "lock": {},
            "pose": [float(v) for v in pin.SE3ToXYZQUAT(T)],
        },
        "joint_names": [f"{n}" for n in model.names[1:]],
        "complete": True,
        "message": "oracle",
        "solutions": [{"q": [float(v) for v in s], "residual": 0.0, "certified": True, "width": 0.0} for s in qs],
        "components": [{"dimension": 0, "boxes": 1, "certified": True} for _ in qs],
        "stats": {},
    }


def _stewart_result() -> dict:
    """Assembly modes of the Dietmeier 6-6 platform found by multi-start Newton (Pinocchio)."""
    mech = load("dietmeier")
    model = mech.model
    rng = np.random.default_rng(1)
    sols = []
    for _ in range(60):
        quat = rng.normal(size=4)
        q = np.concatenate([rng.uniform(-2, 2, 3), quat / np.linalg.norm(quat)])
        for _ in range(8):
            q = refine(mech, q, np.arange(6), iters=10, max_step=np.inf)
        if max_residual(mech, q) < 1e-9 and not any(np.linalg.norm(pin.difference(model, q, s)) < 1e-6 for s in sols):
            sols.append(q)
        if len(sols) == 6:
            break
    assert len(sols) >= 3
    return {
        "problem": "solve dietmeier",
        "source": {"kind": "solve", "mechanism": "dietmeier", "set": {}},
        "joint_names": [],
        "complete": False,
        "message": "multi-start Newton",
        "solutions": [
            {"q": [float(v) for v in s], "residual": float(max_residual(mech, s)), "certified": False, "width": 0.0} for s in sols
        ],
        "components": [{"dimension": 0, "boxes": 1, "certified": False} for _ in sols],
        "stats": {},
    }


def _four_bar_curve(n=60, shuffle=True) -> dict:
    """Samples of one circuit of the built-in four-bar, computed in closed form."""
    qs = []
    for t in np.linspace(-math.pi, math.pi, n, endpoint=False):
        A = np.array([math.cos(t), math.sin(t)])
        G = np.array([3.0, 0.0])
        d = np.linalg.norm(G - A)
        a = (9 - 4 + d * d) / (2 * d)  # |AB| = 3 (coupler), |BG| = 2 (rocker)
        h = math.sqrt(max(9 - a * a, 0.0))
        e = (G - A) / d
        B = A + a * e + h * np.array([-e[1], e[0]])
        coupler = math.atan2(*(B - A)[::-1])
        rocker = math.atan2(*(G - B)[::-1])
        qs.append([t, coupler - t, rocker - coupler])
    mech = load("four-bar")
    assert max(max_residual(mech, np.array(q)) for q in qs) < 1e-9
    order = np.random.default_rng(0).permutation(n) if shuffle else np.arange(n)
    return {
        "problem": "solve four-bar",
        "source": {"kind": "solve", "mechanism": "four-bar", "set": {}},
        "joint_names": ["crank", "coupler", "rocker"],
        "complete": True,
        "message": "closed form",
        "solutions": [],
        "components": [{"dimension": 1, "boxes": n, "certified": False, "samples": [qs[i] for i in order]}],
        "stats": {},
    }


# -------------------------------------------------------------------------------------------
# what is shown
# -------------------------------------------------------------------------------------------
def test_ur5_uses_its_meshes_and_every_solution():
    d = _ur5_result()
    show = replay.prepare(d)
    assert show.meshes
    names = [go.name for go in show.visual.geometryObjects]
    assert any(n.startswith("base_link") for n in names) and any(n.startswith("wrist_3") for n in names)
    assert "kinbox_goal" in names  # the IK goal as a red ball
    assert len(show.qs) == 8 and show.labels[0] == "solution 1 of 8"
    for q, s in zip(show.qs, d["solutions"]):
        assert np.allclose(q, s["q"])


def test_mechanism_without_meshes_gets_shapes_and_legs_follow_q():
    import coal

    d = _stewart_result()
    show = replay.prepare(d)
    assert not show.meshes and show.note == ""
    kinds = {type(go.geometry).__name__ for go in show.visual.geometryObjects}
    assert {"Cylinder", "Sphere"} <= kinds
    mech = load("dietmeier")
    legs = {c.name: c for c in mech.closures}
    assert len(show.segments) == 6  # one cylinder per leg (distance closure)
    for q in show.qs[:2]:
        show.place(q)
        for seg in show.segments:
            go = show.visual.geometryObjects[seg.gid]
            assert isinstance(go.geometry, coal.Cylinder) and go.parentJoint == 0
            a = show.data.oMi[seg.joint_a].act(seg.point_a)
            b = show.data.oMi[seg.joint_b].act(seg.point_b)
            M = go.placement
            assert np.allclose(M.translation, 0.5 * (a + b))
            axis = M.rotation[:, 2] * go.meshScale[2] * 2 * go.geometry.halfLength
            assert np.allclose(axis, b - a, atol=1e-9)
            leg = legs[go.name.rsplit("_", 1)[0]]
            assert abs(np.linalg.norm(b - a) - leg.length) < 1e-8  # assembled: legs at their lengths


@pytest.mark.parametrize("name", ["four-bar", "3-rpr", "delta", "general-6r", "four-bar.xml"])
def test_builtin_mechanisms_get_simple_shapes(name):
    mech = load(name)
    geom, segs = replay.simple_model(mech, [pin.neutral(mech.model)])
    assert geom.ngeoms >= mech.model.njoints
    n_distance = sum(c.kind == "distance" for c in mech.closures)
    n_prismatic = sum(j.shortname() in ("JointModelPX", "JointModelPY", "JointModelPZ") for j in mech.model.joints)
    assert len(segs) == n_distance + n_prismatic


def test_curve_samples_are_shown_in_order_along_the_curve():
    d = _four_bar_curve(60)
    show = replay.prepare(d)
    assert len(show.qs) == 60
    assert show.labels[0] == "component 1 of 1 (dimension 1), point 1 of 60"
    # consecutive configurations are neighbours on the circuit: crank steps of 2 pi / 60
    steps = [abs(math.remainder(b[0] - a[0], 2 * math.pi)) for a, b in zip(show.qs, show.qs[1:])]
    assert max(steps) < 1.5 * 2 * math.pi / 60


def test_a_polyline_is_shown_in_its_own_order():
    d = _four_bar_curve(40, shuffle=False)
    comp = d["components"][0]
    line = comp["samples"][17:] + comp["samples"][:17]  # a closed curve, started elsewhere
    comp["polyline"] = line
    comp["samples"] = [line[i] for i in np.random.default_rng(5).permutation(40)]
    show = replay.prepare(d)
    assert len(show.qs) == 40 and all(np.array_equal(q, p) for q, p in zip(show.qs, line))
    d["components"][0]["polyline"] = [[0.0, 1.0]]  # checked like every other q
    with pytest.raises(InputError, match="3 finite numbers"):
        replay.prepare(d)


def test_order_along_curve_open_and_closed():
    t = np.linspace(0, 1, 40)
    pts = [np.array([x, x * x]) for x in t]
    perm = np.random.default_rng(3).permutation(40)
    order = replay.order_along_curve([pts[i] for i in perm])
    walked = [perm[i] for i in order]
    assert walked in (list(range(40)), list(range(39, -1, -1)))
    assert replay.order_along_curve([]) == [] and replay.order_along_curve([np.zeros(2)]) == [0]


def test_bad_results_are_input_errors(tmp_path):
    d = _ur5_result()
    d["solutions"][0]["q"] = d["solutions"][0]["q"][:5]
    with pytest.raises(InputError, match="6 finite numbers"):
        replay.prepare(d)
    d = _ur5_result()
    d["source"] = {"kind": "ik", "robot": None}
    with pytest.raises(InputError, match="rebuild"):
        replay.prepare(d)
    p = tmp_path / "x.json"
    p.write_text("{not json")
    with pytest.raises(InputError, match="not valid JSON"):
        replay.load_result(p)
    p.write_text("[1, 2]")
    with pytest.raises(InputError, match="not a kinbox result"):
        replay.load_result(p)
    with pytest.raises(InputError, match="delay"):
        replay.html(_ur5_result(), delay=0)


# -------------------------------------------------------------------------------------------
# the HTML page
# -------------------------------------------------------------------------------------------
def _commands(page: str) -> list[dict]:
    import umsgpack

    blobs = re.findall(r'fetch\("data:application/octet-binary;base64,([A-Za-z0-9+/=]+)"\)', page)
    return [umsgpack.unpackb(base64.b64decode(b)) for b in blobs]


def test_html_is_self_contained_with_an_animation(tmp_path):
    out = replay.to_html(_ur5_result(), tmp_path / "ur5.html", delay=0.5)
    page = out.read_text()
    assert "<script src" not in page.lower() and not re.search(r"""src=["']?https?:""", page)
    fetches = re.findall(r'fetch\("([a-z]+):', page)
    assert fetches and set(fetches) == {"data"}  # the scene comes from data: URLs only
    assert "MeshCat.Viewer" in page and "kinbox-label" in page
    cmds = _commands(page)
    objects = [c["path"] for c in cmds if c["type"] == "set_object"]
    assert sum("/kinbox/visuals/" in p for p in objects) == 8  # 7 links + the goal
    anim = [c for c in cmds if c["type"] == "set_animation"]
    assert len(anim) == 1
    clips = anim[0]["animations"]
    fps = clips[0]["clip"]["fps"]
    times = sorted({k["time"] for c in clips for t in c["clip"]["tracks"] for k in t["keys"]})
    # each of the 8 solutions is held for 0.5 s: key frames at the start and end of each hold
    assert len(times) == 16 and times[-1] == 8 * 15 - 1 and fps == 30


def test_html_sweeps_a_curve_as_one_motion(tmp_path):
    page = replay.to_html(_four_bar_curve(60), tmp_path / "fb.html", delay=1.0, sweep=4.0).read_text()
    anim = [c for c in _commands(page) if c["type"] == "set_animation"]
    assert len(anim) == 1
    clip = anim[0]["animations"][0]["clip"]
    times = sorted({k["time"] for t in clip["tracks"] for k in t["keys"]})
    # one key frame per configuration along the curve (no hold): the animation interpolates
    assert len(times) == 60 and times[0] == 0 and abs(times[-1] - 59 * 4 * 30 / 60) <= 1
    assert 'max="59"' in page and "point 60 of 60" in page  # the slider and the labels


def test_recorded_page_matches_meshcat_server_export():
    """The in-process export gives the scene the meshcat server's static_html() gives."""
    d = _stewart_result()
    d["solutions"] = d["solutions"][:1]
    page = replay.html(d)
    viewer = replay.start_viewer()
    try:
        replay.replay(d, viewer=viewer, delay=0.01, cycles=1, log=False)
        served = viewer.static_html()
    finally:
        replay.stop_viewer(viewer)
    assert viewer.window.server_proc.poll() is not None  # the server is down

    def scene(p):
        return sorted(
            (c["type"], c.get("path", ""), json.dumps(c.get("matrix") or c.get("value"), default=str))
            for c in _commands(p)
            if c["type"] in ("set_object", "set_transform", "set_property")
        )

    ours = {(t, p) for t, p, _ in scene(page)}
    theirs = {(t, p) for t, p, _ in scene(served)}
    assert ours == theirs
    tf_ours = {p: v for t, p, v in scene(page) if t == "set_transform"}
    tf_theirs = {p: v for t, p, v in scene(served) if t == "set_transform"}
    assert tf_ours == tf_theirs  # one configuration: the same placements


# -------------------------------------------------------------------------------------------
# headless Chromium
# -------------------------------------------------------------------------------------------
@pytest.fixture(scope="session")
def chromium():
    exe = replay.find_chromium()
    if exe is None and shutil.which("apt-get") and hasattr(os, "geteuid") and os.geteuid() == 0:
        try:
            subprocess.run(
                "apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium",
                shell=True,
                check=False,
                timeout=900,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
            )
        except subprocess.TimeoutExpired:
            pass
        exe = replay.find_chromium()
    if exe is None:
        pytest.skip("Chromium is not installed and `apt-get install -y chromium` was not possible here")
    return exe


def _shot(chromium, page_or_result, tmp_path, name, delay=1.0):
    folder = SHOTS or str(tmp_path)
    os.makedirs(folder, exist_ok=True)
    html = os.path.join(folder, name + ".html")
    if isinstance(page_or_result, str):
        with open(html, "w") as f:
            f.write(page_or_result)
    else:
        replay.to_html(page_or_result, html, delay=delay)
    return replay.screenshot(html, os.path.join(folder, name + ".png"), size=(800, 600), budget_ms=600, timeout=25, browser=chromium)


def robot_pixels(png) -> tuple[float, int]:
    """(fraction, distinct colours) of pixels in the central region that are not sky:
    meshcat's background is a blue gradient, the robot is grey, orange, green, red."""
    from PIL import Image

    a = np.asarray(Image.open(png).convert("RGB")).astype(int)
    h, w, _ = a.shape
    c = a[int(0.1 * h) : int(0.9 * h), int(0.1 * w) : int(0.9 * w)]
    mask = (c[..., 2] - np.maximum(c[..., 0], c[..., 1])) < 30
    colours = len({tuple(p) for p in c[mask].reshape(-1, 3)})
    return float(mask.mean()), colours


@pytest.mark.slow
def test_chromium_shows_the_ur5(chromium, tmp_path):
    d = _ur5_result()
    full, full_colours = robot_pixels(_shot(chromium, d, tmp_path, "ur5"))
    empty = dict(d, solutions=[], components=[])  # negative control: the same page, no robot
    none, _ = robot_pixels(_shot(chromium, empty, tmp_path, "ur5_empty"))
    assert full > 0.015 and full > 3 * none, (full, none)
    assert full_colours > 200  # shaded meshes, not a flat patch


@pytest.mark.slow
def test_chromium_shows_the_stewart_platform(chromium, tmp_path):
    frac, colours = robot_pixels(_shot(chromium, _stewart_result(), tmp_path, "stewart"))
    assert frac > 0.008 and colours > 100, (frac, colours)


@pytest.mark.slow
def test_chromium_shows_the_four_bar_moving_along_its_curve(chromium, tmp_path):
    """The mobile-mechanism replay: the page renders the linkage, and it moves."""
    from PIL import Image

    folder = SHOTS or str(tmp_path)
    page = replay.to_html(_four_bar_curve(60), os.path.join(folder, "four_bar.html"), sweep=6.0)
    shots = [
        replay.screenshot(page, os.path.join(folder, f"four_bar_{t}.png"), size=(800, 600), budget_ms=t, timeout=25, browser=chromium)
        for t in (400, 3400)
    ]
    for png in shots:
        frac, colours = robot_pixels(png)
        assert frac > 0.004 and colours > 20, (png, frac, colours)
    a, b = (np.asarray(Image.open(p).convert("RGB")).astype(int) for p in shots)
    moved = float((np.abs(a - b).max(axis=2) > 40).mean())
    assert moved > 0.002, moved  # half a sweep later the crank and coupler are elsewhere


@pytest.mark.slow
@pytest.mark.parametrize("name,options", [("four-bar", {}), ("bricard", {}), ("griffis-duffy", {"sigma": 0.25})])
def test_chromium_replays_the_solved_mobile_mechanism(chromium, tmp_path, name, options):
    """The whole path for a mobile mechanism: kinbox.solve -> to_html -> Chromium, moving
    (the four-bar's circuits, Bricard's self-motion, Griffis-Duffy's curves)."""
    from PIL import Image

    res = kinbox.solve(name, **options)
    assert any(c.dimension == 1 for c in res.components)
    folder = SHOTS or str(tmp_path)
    page = kinbox.to_html(res, os.path.join(folder, f"{name}_solved.html"), sweep=4.0)
    shots = [
        replay.screenshot(page, os.path.join(folder, f"{name}_solved_{t}.png"), budget_ms=t, timeout=25, browser=chromium)
        for t in (400, 2400)
    ]
    for png in shots:
        frac, colours = robot_pixels(png)
        assert frac > 0.004 and colours > 20, (png, frac, colours)
    a, b = (np.asarray(Image.open(p).convert("RGB")).astype(int) for p in shots)
    assert float((np.abs(a - b).max(axis=2) > 40).mean()) > 0.002


def test_blank_page_fails_the_pixel_check(chromium, tmp_path):
    page = "<!DOCTYPE html><html><body style='background:#87cefa'></body></html>"
    frac, _ = robot_pixels(_shot(chromium, page, tmp_path, "blank"))
    assert frac < 0.001


def test_real_ik_result_replays(chromium, tmp_path):
    """The whole path: kinbox.ik -> Result.to_html -> Chromium."""
    res = kinbox.ik("ur5", "tool0", kinbox.IK("ur5", "tool0").pose_at([1.0, -0.7, 1.1, -1.9, -1.3, 2.0]))
    assert res.solutions and res.source["robot"] == "ur5"
    folder = SHOTS or str(tmp_path)
    html = kinbox.to_html(res, os.path.join(folder, "ur5_ik.html"), delay=0.5)
    frac, colours = robot_pixels(replay.screenshot(html, os.path.join(folder, "ur5_ik.png"), budget_ms=600, timeout=25, browser=chromium))
    assert frac > 0.015 and colours > 200, (frac, colours)
    # the JSON round trip gives the same page content
    d = json.loads(res.to_json())
    assert replay.prepare(d).meshes and len(replay.prepare(d).qs) == len(res.solutions)


# -------------------------------------------------------------------------------------------
# live viewer and command line
# -------------------------------------------------------------------------------------------
def test_result_replay_in_a_live_viewer():
    res = kinbox.solve("four-bar", set={"crank": 0.7})
    viewer = replay.start_viewer()
    try:
        assert viewer.url().startswith("http://127.0.0.1:")
        viz = kinbox.replay(res, viewer=viewer, delay=0.01)
        assert viz.viewer is viewer
        page = viewer.static_html()
    finally:
        replay.stop_viewer(viewer)
    paths = [c["path"] for c in _commands(page) if c["type"] == "set_object"]
    assert any("/kinbox/visuals/hinge" in p for p in paths)


def test_cli_replay_html(tmp_path, capsys):
    src = tmp_path / "ur5.json"
    src.write_text(json.dumps(_ur5_result()))
    out = tmp_path / "page.html"
    assert main(["replay", str(src), "--html", str(out), "--delay", "0.3"]) == 0
    assert out.stat().st_size > 100_000 and "MeshCat.Viewer" in out.read_text()


def test_cli_replay_errors(tmp_path, capsys):
    assert main(["replay", str(tmp_path / "missing.json"), "--html", str(tmp_path / "x.html")]) == 2
    assert "kinbox: error: cannot read result file" in capsys.readouterr().err
    src = tmp_path / "ur5.json"
    src.write_text(json.dumps(_ur5_result()))
    assert main(["replay", str(src), "--html", str(tmp_path / "x.html"), "--delay", "nan"]) == 2
    assert "--delay" in capsys.readouterr().err


def test_cli_replay_live_once(tmp_path):
    src = tmp_path / "fb.json"
    src.write_text(json.dumps(_four_bar_curve(6, shuffle=False)))
    p = subprocess.run(
        [sys.executable, "-m", "kinbox.cli", "replay", str(src), "--delay", "0.01", "--cycles", "1"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert p.returncode == 0, p.stderr
    assert re.search(r"meshcat viewer at http://127\.0\.0\.1:\d+/static/", p.stdout)
    assert p.stderr.count("kinbox: component 1 of 1 (dimension 1): a motion through 6 configurations") == 1


# -------------------------------------------------------------------------------------------
# the server: loopback only, stopped with the command whatever ends it
# -------------------------------------------------------------------------------------------
def _listening(pids: set[int]) -> list[tuple[str, int]]:
    """(address, port) of every TCP socket of ``pids`` in the LISTEN state."""
    import psutil

    return [(c.laddr.ip, c.laddr.port) for c in psutil.net_connections(kind="tcp") if c.status == psutil.CONN_LISTEN and c.pid in pids]


def _alive(pid: int) -> bool:
    import psutil

    try:
        return psutil.Process(pid).status() != psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return False


@pytest.mark.parametrize("how", ["SIGTERM", "SIGINT", "exit"])
@pytest.mark.slow
def test_cli_replay_server_on_loopback_and_stopped(tmp_path, how):
    import signal
    import time

    import psutil

    src = tmp_path / "fb.json"
    src.write_text(json.dumps(_four_bar_curve(6, shuffle=False)))
    cycles = "1" if how == "exit" else "0"
    delay = "0.8" if how == "exit" else "0.05"
    proc = subprocess.Popen(
        [sys.executable, "-m", "kinbox.cli", "replay", str(src), "--delay", delay, "--cycles", cycles],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        line = proc.stdout.readline()
        assert "meshcat viewer at http://127.0.0.1:" in line, (line, proc.stderr.read() if proc.poll() else "")
        children = {c.pid for c in psutil.Process(proc.pid).children(recursive=True)}
        assert children  # the server
        sockets = _listening(children)
        assert len(sockets) >= 1  # the page (the command socket is a Unix socket)
        assert all(ip == "127.0.0.1" for ip, _ in sockets), sockets  # never 0.0.0.0 or ::
        if how != "exit":
            proc.send_signal(getattr(signal, how))
        code = proc.wait(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert code == {"SIGTERM": 128 + signal.SIGTERM, "SIGINT": 130, "exit": 0}[how], proc.stderr.read()
    deadline = time.monotonic() + 10
    while any(_alive(c) for c in children) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not any(_alive(c) for c in children)
    ports = {port for _, port in sockets}
    assert not [s for s in _listening_any() if s[1] in ports and s[2] in children]


def _listening_any() -> list[tuple[str, int, int | None]]:
    import psutil

    return [(c.laddr.ip, c.laddr.port, c.pid) for c in psutil.net_connections(kind="tcp") if c.status == psutil.CONN_LISTEN]


@pytest.mark.slow
def test_server_child_dies_with_a_killed_parent(tmp_path):
    """SIGKILL leaves no time to clean up: the server sees its stdin pipe close and exits."""
    import time

    import psutil

    code = (
        "import sys, time; from kinbox.viz import replay; v = replay.start_viewer(); "
        "print(v.window.server_proc.pid, flush=True); time.sleep(600)"
    )
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    try:
        child = int(proc.stdout.readline())
        assert _alive(child) and _listening({child})
        proc.kill()
        proc.wait()
        deadline = time.monotonic() + 10
        while _alive(child) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not _alive(child)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        if _alive(child):
            psutil.Process(child).kill()


def test_other_host_warns_and_a_bad_host_is_an_input_error(tmp_path, capsys):
    viewer = replay.start_viewer("0.0.0.0")
    try:
        assert viewer.url().startswith("http://127.0.0.1:")
        ports = {p for ip, p in _listening({viewer.window.server_proc.pid}) if ip == "0.0.0.0"}
        assert len(ports) == 1  # the page only: the command socket stays on loopback
    finally:
        replay.stop_viewer(viewer)
    assert "warning: the viewer is served on '0.0.0.0'" in capsys.readouterr().err
    src = tmp_path / "fb.json"
    src.write_text(json.dumps(_four_bar_curve(6, shuffle=False)))
    assert main(["replay", str(src), "--host", "192.0.2.1"]) == 2  # TEST-NET: not this machine
    err = capsys.readouterr().err.strip()
    assert err.startswith("kinbox: error: cannot serve on host '192.0.2.1'") and "\n" not in err
