"""The ``kinbox`` command line: ``kinbox ik``, ``kinbox solve`` (mechanisms and geometric constraint
systems), ``kinbox check`` (diagnosis), ``kinbox list``, and pictures of a saved result:
``kinbox replay`` (meshcat), ``kinbox plot`` (matplotlib).

Bad input prints one line ``kinbox: error: ...`` on stderr and exits with status 2.
"""

from __future__ import annotations

import argparse
import json
import signal
import sys

import numpy as np


def _assignments(items: list[str] | None, flag: str) -> dict[str, float]:
    out: dict[str, float] = {}
    for it in items or []:
        name, sep, val = it.partition("=")
        if not sep or not name:
            raise _Usage(f"{flag} takes JOINT=VALUE, got {it!r}")
        try:
            out[name] = float(val)
        except ValueError:
            raise _Usage(f"{flag} {it!r}: {val!r} is not a number") from None
    return out


class _Usage(Exception):
    pass


def _floats(text: str, what: str) -> list[float]:
    try:
        return [float(v) for v in text.replace(",", " ").split()]
    except ValueError:
        raise _Usage(f"{what}: {text!r} is not a list of numbers") from None


def read_poses(path: str) -> list[list[float]]:
    """Poses from a text file (``-``: stdin), one ``X Y Z QX QY QZ QW`` per line (spaces or
    commas; blank lines and ``#`` comments skipped). Each is checked as ``--pose`` is."""
    from .errors import InputError
    from .pipeline import parse_pose

    try:
        text = sys.stdin.read() if path == "-" else open(path, encoding="utf-8").read()
    except OSError as e:
        raise InputError(f"cannot read poses file {path!r}: {e.strerror or e}") from None
    poses = []
    for n, line in enumerate(text.splitlines(), 1):
        line = line.split("#", 1)[0].replace(",", " ").strip()
        if not line:
            continue
        try:
            v = [float(t) for t in line.split()]
            parse_pose(v)
        except (ValueError, InputError) as e:
            raise InputError(f"{path}, line {n}: {e}") from None
        poses.append(v)
    if not poses:
        raise InputError(f"no pose in {path!r}")
    return poses


def _solver_options(a) -> dict:
    opts = {}
    if a.sigma is not None:
        if not (a.sigma > 0 and np.isfinite(a.sigma)):
            raise _Usage("--sigma must be a positive number")
        opts["sigma"] = a.sigma
    if a.time_limit is not None:
        opts["time_limit"] = a.time_limit
    if a.max_boxes is not None:
        opts["max_boxes"] = a.max_boxes
    if a.workers is not None:
        if a.workers < 0:
            raise _Usage("--workers must be >= 0 (0: one per core)")
        opts["workers"] = a.workers
    if a.dask is not None:
        if a.workers is not None:
            raise _Usage("--workers and --dask exclude each other")
        opts["executor"] = a.dask
    if a.quiet:
        opts["progress"] = False
    elif a.progress:
        opts["progress"] = True
    return opts


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--sigma", type=float, help="box width below which a box is a solution box")
    p.add_argument("--time-limit", type=float, help="seconds; the answer is marked incomplete if hit")
    p.add_argument("--max-boxes", type=int, help="box budget; the answer is marked incomplete if hit")
    p.add_argument("--workers", type=int, metavar="N", help="explore boxes with N local processes (0: one per core)")
    p.add_argument("--dask", metavar="ADDRESS", help="explore boxes on a Dask cluster, e.g. tcp://host:8786 "
                   "(pip install 'kinbox[dask]')")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")
    p.add_argument("--progress", action="store_true", help="progress on stderr even when not a terminal")


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="kinbox", description="Every configuration of a robot mechanism, certified.")
    p.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")
    sub = p.add_subparsers(dest="cmd", required=True)
    ik = sub.add_parser("ik", help="all inverse-kinematics solutions of an arm")
    ik.add_argument("robot", help="example-robot-data name, URDF file, or built-in mechanism")
    ik.add_argument("--frame", required=True, help="the frame to place")
    g = ik.add_mutually_exclusive_group(required=True)
    g.add_argument("--pose", nargs=7, metavar=("X", "Y", "Z", "QX", "QY", "QZ", "QW"))
    g.add_argument("--from-q", metavar="Q1,...,QN", help="goal = the frame's pose at these joint values")
    g.add_argument("--poses", metavar="FILE",
                   help="many goals, one pose per line (X Y Z QX QY QZ QW; '#' comments; '-' = stdin): "
                        "the arm is prepared once; with --json one result per line (JSON Lines)")
    ik.add_argument("--base", help="frame the pose is expressed in (default: world)")
    ik.add_argument("--lock", action="append", metavar="JOINT=VALUE", help="hold a joint fixed")
    _common(ik)
    so = sub.add_parser("solve", help="all configurations of a mechanism with loops, or all assemblies of a "
                                      "geometric constraint system")
    so.add_argument("mechanism", help="built-in name (kinbox list) or file (.json, .xml, .urdf; a .json with "
                                      "\"kind\": \"constraints\" is a constraint system)")
    so.add_argument("--set", action="append", metavar="NAME=VALUE",
                    help="fix an actuated joint, or set a parameter of a constraint system")
    so.add_argument("--legs", choices=("auto", "squared", "vector"), default="auto",
                    help="equations of legs (distance closures): squared (fastest for isolated assembly "
                         "modes; auto) or vector (a unit vector per leg: for mobile platforms)")
    so.add_argument("--formulation", choices=("auto", "coordinates", "distances"), default="auto",
                    help="constraint systems: coordinates of the entities, or unknown distances under "
                         "Cayley-Menger conditions (points and lines under distances only); auto picks one")
    _common(so)
    ck = sub.add_parser("check", help="degrees of freedom, redundant and inconsistent constraints (constraint "
                                      "systems), mobility (mechanisms)",
                        description="Diagnosis before solving: generic degrees of freedom and at a solution, "
                                    "redundant constraints, a minimal inconsistent set (exit 2 when proven), "
                                    "under-constrained entities; for a mechanism, its mobility by counting and "
                                    "by the closure Jacobian's rank at configurations found.")
    ck.add_argument("target", metavar="FILE", help="constraint system or mechanism (file or built-in name)")
    ck.add_argument("--set", action="append", metavar="NAME=VALUE", help="parameter (or locked joint) value")
    ck.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    sub.add_parser("list", help="built-in mechanisms and example-robot-data robots")
    _pictures(sub)
    return p


# -- replay / plot: pictures of a saved result (kinbox.replay, kinbox.plot) ------------------------
def _pictures(sub) -> None:
    rp = sub.add_parser("replay", help="show every configuration of a result on the robot (meshcat)",
                        description="Show every configuration of a result (kinbox ik/solve --json) on the robot. "
                                    "Live: a meshcat server on localhost (its URL is printed); --html: one "
                                    "self-contained page that steps through the configurations.")
    rp.add_argument("result", metavar="RESULT.json", help="output of `kinbox ik ... --json` or `kinbox solve ... --json`")
    rp.add_argument("--html", metavar="OUT.html", help="write a self-contained HTML page instead of serving live")
    rp.add_argument("--delay", type=float, default=1.0, metavar="S", help="seconds per isolated configuration (default 1)")
    rp.add_argument("--sweep", type=float, metavar="S",
                    help="seconds to move along one curve component (default: 5 x --delay)")
    rp.add_argument("--cycles", type=int, default=0, metavar="N",
                    help="live mode: passes through the configurations, 0 = until Ctrl-C (default)")
    rp.add_argument("--host", default="127.0.0.1",
                    help="live mode: address the viewer page is served on (default 127.0.0.1, this machine only; "
                         "another address lets other hosts see it: a warning is printed)")
    pl = sub.add_parser("plot", help="projection of the solution boxes onto 2 or 3 variables or joints",
                        description="Projection of the solution boxes of a result onto two or three system "
                                    "variables (boxes) or joints (angles; one point per box), one colour per component.")
    pl.add_argument("result", metavar="RESULT.json", help="output of `kinbox ik ... --json` or `kinbox solve ... --json`")
    pl.add_argument("--vars", required=True, metavar="A,B[,C]", help="system variable or joint names")
    pl.add_argument("-o", "--output", required=True, metavar="OUT.png", help="image file (png, pdf, svg)")


def _run_pictures(a) -> int:
    import math

    from .viz.entities import is_constraints_result

    if is_constraints_result(a.result):
        if a.cmd == "plot":
            raise _Usage(f"{a.result!r} is the answer of a constraint system: it has no solution boxes to plot; "
                         "`kinbox replay` draws its points, lines and planes")
        return _replay_entities(a)
    if a.cmd == "plot":
        from .answer.resultfile import load_result
        from .viz.plot import parse_vars, plot_boxes

        out = plot_boxes(load_result(a.result), parse_vars(a.vars), a.output)
        print(f"kinbox: wrote {out}", file=sys.stderr)
        return 0
    from .viz import replay

    for flag, v in (("--delay", a.delay), ("--sweep", a.sweep)):
        if v is not None and not (math.isfinite(v) and v > 0):
            raise _Usage(f"{flag} must be a positive number of seconds")
    if a.cycles < 0:
        raise _Usage("--cycles must be >= 0")
    data = replay.load_result(a.result)
    if a.html:
        out = replay.to_html(data, a.html, delay=a.delay, sweep=a.sweep)
        print(f"kinbox: wrote {out}", file=sys.stderr)
        return 0
    show = replay.prepare(data)  # errors before a server is started
    viewer = replay.start_viewer(a.host)
    # SIGTERM unwinds like Ctrl-C, so that the server is stopped below (it would end with this
    # process anyway: it watches a pipe from it)
    signal.signal(signal.SIGTERM, _terminated)
    try:
        print(f"kinbox: meshcat viewer at {viewer.url()} (Ctrl-C to stop)", flush=True)
        replay.replay(show, viewer=viewer, delay=a.delay, cycles=a.cycles, sweep=a.sweep)
    finally:
        replay.stop_viewer(viewer)
    return 0


def _replay_entities(a) -> int:
    import math

    from .viz import entities

    if not (math.isfinite(a.delay) and a.delay > 0):
        raise _Usage("--delay must be a positive number of seconds")
    if a.cycles < 0:
        raise _Usage("--cycles must be >= 0")
    data = entities.load_result(a.result)
    if a.html:
        out = entities.to_html(data, a.html, delay=a.delay)
        print(f"kinbox: wrote {out}", file=sys.stderr)
        return 0
    signal.signal(signal.SIGTERM, _terminated)  # unwinds like Ctrl-C: the server is stopped
    entities.serve(data, delay=a.delay, cycles=a.cycles, host=a.host)
    return 0


def _check(a) -> int:
    from .model.constraints import is_constraints_source

    values = _assignments(a.set, "--set")
    if is_constraints_source(a.target):
        from .answer.diagnosis import diagnose, refuse_if_inconsistent
        from .errors import InconsistentError
        from .model.constraints import load_constraints

        model = load_constraints(a.target).with_parameters(values)
        d = diagnose(model)
        try:
            refuse_if_inconsistent(model, d)
            err = None
        except InconsistentError as e:
            err = str(e)
        print(json.dumps({"problem": model.name, **d.to_dict()}) if a.json else d.report(model.name))
        if err:
            print(f"kinbox: error: {err}", file=sys.stderr)
            return 2
        return 0
    from .answer.diagnosis import diagnose_mechanism
    from .model.loading import load

    mech = load(a.target)
    for name, value in values.items():
        mech.lock(name, value)
    md = diagnose_mechanism(mech)
    print(json.dumps({"problem": mech.name, **md.to_dict()}) if a.json else md.report(mech.name))
    return 0


def _terminated(signum: int, frame: object) -> None:
    raise SystemExit(128 + signum)


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else list(argv)
    parser = _parser()
    a = parser.parse_args(args)
    from .errors import KinboxError

    try:
        return _run(a)
    except (KinboxError, _Usage) as e:
        print(f"kinbox: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("kinbox: interrupted", file=sys.stderr)
        return 130
    except Exception as e:  # an internal error, not the user's input
        if a.debug:
            raise
        print(f"kinbox: internal error: {type(e).__name__}: {e} (run with --debug for details)", file=sys.stderr)
        return 3


def _run(a) -> int:
    if a.cmd == "list":
        from .model.constraints import builtin_constraint_files
        from .model.loading import builtin_names

        print("built-in mechanisms:", " ".join(builtin_names()))
        print("built-in constraint systems:", " ".join(builtin_constraint_files()))
        import example_robot_data as erd

        print("example-robot-data robots:", " ".join(sorted(erd.ROBOTS)))
        return 0
    if a.cmd in ("replay", "plot"):
        return _run_pictures(a)
    if a.cmd == "check":
        return _check(a)
    opts = _solver_options(a)
    if a.cmd == "ik":
        from .pipeline import IK

        lock = _assignments(a.lock, "--lock")
        prob = IK(a.robot, a.frame, a.base, lock)
        if a.poses is not None:
            poses = read_poses(a.poses)
            for k, pose in enumerate(poses):
                res = prob.solve(pose, **opts)
                if a.json:
                    print(json.dumps(res.to_dict()), flush=True)
                else:
                    print(f"pose {k + 1} of {len(poses)}: {' '.join(f'{v:g}' for v in pose)}")
                    print(res.table(), flush=True)
            return 0
        if a.pose is not None:
            pose = _floats(" ".join(a.pose), "--pose")
        else:
            pose = prob.pose_at(_floats(a.from_q, "--from-q"))
        res = prob.solve(pose, **opts)
    else:
        from .model.constraints import is_constraints_source

        if is_constraints_source(a.mechanism):
            from .pipeline import assemble

            res = assemble(a.mechanism, set=_assignments(a.set, "--set"), formulation=a.formulation, **opts)
        else:
            from .pipeline import solve

            res = solve(a.mechanism, set=_assignments(a.set, "--set"), legs=a.legs, **opts)
    if a.json:
        print(json.dumps(res.to_dict()))
    else:
        print(res.table())
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
