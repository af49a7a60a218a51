"""The ``kinbox`` command line: ``kinbox ik``, ``kinbox solve`` (mechanisms and geometric constraint
systems), ``kinbox check`` (diagnosis), ``kinbox info``, ``kinbox list``, and pictures of a saved
result: ``kinbox replay`` (meshcat), ``kinbox plot`` (matplotlib).

Bad input prints one line ``kinbox: error: ...`` on stderr and exits with status 2; the other
exit statuses are in :data:`EXIT_STATUS` (and ``kinbox --help``).
"""

from __future__ import annotations

import argparse
import errno
import gc
import json
import math
import os
import re
import signal
import sys
import threading
import time
from typing import Any

from .problems.choices import MECHANISM_FORMULATIONS

EXIT_OK = 0
EXIT_INPUT = 2
EXIT_INTERNAL = 3
EXIT_INCOMPLETE = 4
EXIT_BATCH = 5
EXIT_SIGNAL: dict[int, int] = {int(signal.SIGINT): 130, int(signal.SIGTERM): 143}
EXIT_BROKEN_PIPE = 141  # as a command killed by SIGPIPE: its output was closed
EXIT_OUTPUT = 74  # sysexits' EX_IOERR: the output could not be written
#: errors of writing the output (stdout) that are the output's, not kinbox's
_OUTPUT_ERRNOS = {errno.ENOSPC, errno.EDQUOT, errno.EIO, errno.EFBIG, errno.EROFS, errno.EBADF, errno.EPIPE}
#: the program's full collections: one per this many collections of the middle generation
#: (Python's default is 10)
FULL_GC_EVERY = 1000
#: --delay and --sweep of a replay, seconds (a day; the page's animation counts in integers)
MAX_DELAY = 86400.0

EXIT_STATUS = """exit status:
  0    a complete answer
  4    an incomplete answer (a time, box or memory budget was hit, or worker processes were
       lost): printed in full, JSON included, marked incomplete, with one line on stderr
  5    --poses: some lines were bad input (an error record each, {"line": N, "error": ...});
       every other line was answered
  2    bad input: one line on stderr, kinbox: error: ...
  3    internal error: a bug in kinbox (--debug shows the traceback)
  74   the output could not be written (a full disk): one line on stderr
  130  interrupted by Ctrl-C (SIGINT), 143 by SIGTERM: what was found so far is printed,
       marked incomplete; with --save FILE the search goes on later with --resume FILE"""


_NUMBER = r"((\d+\.?\d*|\.\d+)([eE][-+]?\d+)?|inf|nan)"


class _Parser(argparse.ArgumentParser):
    """argparse, with usage errors on one line, like every other error of kinbox, and negative
    numbers in every notation (``-1e-3``, ``-inf``) taken as values, not options, also a list
    of numbers that starts with one (``--from-q -1.72,0.3,...``; test_negative_values_after_options)."""

    def __init__(self, *args, **kw):
        super().__init__(*args, **kw)
        # argparse's own pattern knows -1 and -.5 only (a private attribute, stable since 3.2)
        self._negative_number_matcher = re.compile(rf"^-{_NUMBER}([,\s]+[-+]?{_NUMBER})*[,\s]*$", re.I)

    def error(self, message):
        self.exit(EXIT_INPUT, f"kinbox: error: {message} (see `{self.prog} --help`)\n")


def _assignments(items: list[str] | None, flag: str, vectors: bool = False) -> dict:
    """``NAME=VALUE`` items as ``{name: value}``; with ``vectors``, ``NAME=V1,V2,...`` too (a
    joint of several ``q`` entries, such as a free-flyer's seven; test_lock_takes_vectors)."""
    out: dict = {}
    for it in items or []:
        name, sep, val = it.partition("=")
        if not sep or not name:
            raise _Usage(f"{flag} takes {'JOINT=VALUE[,VALUE...]' if vectors else 'JOINT=VALUE'}, got {it!r}")
        if name in out:  # tests/cli/test_hostile.py::test_cli_numbers
            raise _Usage(f"{flag} {name} is given twice")
        try:
            if vectors and "," in val:
                out[name] = [_number(v) for v in val.split(",")]
            else:
                out[name] = _number(val)
        except ValueError:
            raise _Usage(f"{flag} {it!r}: {val!r} is not a number{' or a list of numbers' if vectors else ''}") from None
    return out


def _number(text: str) -> float:
    """``float(text)`` without Python's digit separators (``0_4`` is not 4)."""
    if "_" in text:
        raise ValueError(text)
    return float(text)


class _Usage(Exception):
    pass


def _floats(text: str, what: str) -> list[float]:
    """Numbers separated by commas (each field one number: ``0.1,,0.2`` is refused) or spaces."""
    fields = text.split(",") if "," in text else text.split()
    try:
        return [_number(v.strip()) for v in fields]
    except ValueError:
        raise _Usage(f"{what}: {text!r} is not a list of numbers") from None


def pose_lines(path: str) -> list[tuple[int, list[float] | None, str | None]]:
    """The lines of a poses file (``-``: stdin) that hold a pose, one ``X Y Z QX QY QZ QW`` per
    line (spaces or commas; blank lines and ``#`` comments skipped): ``(line number, pose,
    None)``, or ``(line number, None, what is wrong)`` for a line that is not a valid pose
    (checked as ``--pose`` is). An unreadable file, or one without any pose line, raises."""
    from .errors import MAX_INPUT_BYTES, InputError, read_text
    from .pipeline import parse_pose

    if path == "-":
        raw = sys.stdin.buffer.read(MAX_INPUT_BYTES + 1) if hasattr(sys.stdin, "buffer") else sys.stdin.read(MAX_INPUT_BYTES + 1).encode()
        if len(raw) > MAX_INPUT_BYTES:
            raise InputError(f"poses on stdin: more than {MAX_INPUT_BYTES} bytes")
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError as e:
            raise InputError(f"poses on stdin are not UTF-8 text (byte {e.start})") from None
    else:
        text = read_text(path, InputError, "poses file")
    out: list[tuple[int, list[float] | None, str | None]] = []
    for n, line in enumerate(text.splitlines(), 1):
        line = line.split("#", 1)[0].replace(",", " ").strip()
        if not line:
            continue
        try:
            v = [_number(t) for t in line.split()]
            parse_pose(v)
        except ValueError:
            out.append((n, None, f"{line[:60]!r} is not a list of numbers"))
            continue
        except InputError as e:
            out.append((n, None, str(e)))
            continue
        out.append((n, v, None))
    if not out:
        raise InputError(f"no pose in {path!r}")
    return out


def read_poses(path: str) -> list[list[float]]:
    """The poses of a poses file (see :func:`pose_lines`); the first bad line raises."""
    from .errors import InputError

    poses = []
    for n, pose, err in pose_lines(path):
        if err is not None:
            raise InputError(f"{path}, line {n}: {err}")
        assert pose is not None
        poses.append(pose)
    return poses


def _solver_options(a) -> dict:
    opts = {}
    if a.sigma is not None:
        if not (a.sigma > 0 and math.isfinite(a.sigma)):
            raise _Usage(f"--sigma must be a positive number, got {a.sigma:g}")
        opts["sigma"] = a.sigma
    if a.time_limit is not None:
        if not (a.time_limit > 0 and math.isfinite(a.time_limit)):
            raise _Usage(f"--time-limit must be a positive number of seconds, got {a.time_limit:g}")
        opts["time_limit"] = a.time_limit
    if a.cpu_limit is not None:
        if not (a.cpu_limit > 0 and math.isfinite(a.cpu_limit)):
            raise _Usage(f"--cpu-limit must be a positive number of seconds, got {a.cpu_limit:g}")
        if a.workers is not None or a.dask is not None:
            raise _Usage("--cpu-limit counts the CPU of this process only: not with --workers or --dask (use --time-limit)")
    if getattr(a, "curve_boxes", None) is not None:
        opts["curve_boxes"] = a.curve_boxes
    if a.max_boxes is not None:
        if a.max_boxes < 1:
            raise _Usage(f"--max-boxes must be a positive number of boxes, got {a.max_boxes}")
        opts["max_boxes"] = a.max_boxes
    if a.workers is not None:
        if a.workers < 0:
            raise _Usage("--workers must be >= 0 (0: one per core)")
        opts["workers"] = a.workers
    if a.dask is not None:
        if a.workers is not None:
            raise _Usage("--workers and --dask exclude each other")
        _check_dask_address(a.dask)
        opts["executor"] = a.dask
    if a.relaxation is not None:
        opts["relaxation"] = a.relaxation
    if a.extra_steps is not None:
        opts["extra_steps"] = a.extra_steps
    if getattr(a, "all_turns", False):
        opts["all_turns"] = True
    if a.quiet:
        opts["progress"] = False
    elif a.progress:
        opts["progress"] = True
    return opts


def _check_dask_address(address: str) -> None:
    """A scheduler address as Dask reads it (``tcp://host:port``, ``host:port``, ...), checked
    by Dask's own parser before anything runs (tests/cli/test_hostile.py::test_cli_numbers)."""
    try:
        from distributed.comm.addressing import parse_address, parse_host_port
    except ImportError:  # reported where the cluster is used, with the install hint
        return
    try:
        scheme, loc = parse_address(address)
        if scheme not in ("tcp", "tls", "ws", "wss", "ucx"):
            raise ValueError(f"scheme {scheme!r} is not one of tcp, tls, ws, wss, ucx")
        parse_host_port(loc)
    except (ValueError, TypeError) as e:
        raise _Usage(f"--dask {address!r} is not a scheduler address such as tcp://host:8786 ({e})") from None


def _scene_options(a) -> dict:
    """The scene keywords of ``kinbox ik``/``kinbox solve`` (kinbox.model.scene)."""
    if a.scene is None:
        if a.srdf is not None or a.collision_free:
            raise _Usage("--srdf and --collision-free take a --scene")
        return {}
    return {"scene": a.scene, "srdf": a.srdf, "collision_free": a.collision_free}


def _parser() -> argparse.ArgumentParser:
    """The parser of every command the library declares (:data:`kinbox.problems.commands.COMMANDS`)."""
    from .problems.commands import COMMANDS

    p = _Parser(
        prog="kinbox",
        description="Every configuration of a robot mechanism, certified.",
        epilog=EXIT_STATUS,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")
    sub = p.add_subparsers(dest="cmd", required=True)
    for c in COMMANDS:
        kw: dict[str, Any] = {"epilog": EXIT_STATUS, "formatter_class": argparse.RawDescriptionHelpFormatter} if c.exit_status else {}
        cp = sub.add_parser(c.name, help=c.help, description=c.description, **kw)
        groups: dict = {}
        for a in c.args:
            target = cp
            if a.group is not None:
                target = groups.get(a.group) or groups.setdefault(a.group, cp.add_mutually_exclusive_group(required=True))
            extra: dict[str, Any] = {"action": argparse.BooleanOptionalAction} if a.negatable else {}
            target.add_argument(*a.flags, **a.options, **extra)
    return p


def _reach(a) -> int:
    from .workspace import reach, reach_platform

    quat = _floats(" ".join(a.orientation), "--orientation") if a.orientation else None
    region = _floats(" ".join(a.region), "--region") if a.region else None
    show = not a.quiet and sys.stderr.isatty()

    def progress(d: dict) -> None:
        if show:
            v = d["volume"]
            print(
                f"\rkinbox reach: {d['decided']} boxes decided ({v['inside']:.4f} inside, {v['outside']:.4f} outside, "
                f"{v['boundary']:.4f} boundary), {d['pending']} pending",
                end="",
                file=sys.stderr,
                flush=True,
            )

    common = {"region": region, "resolution": a.resolution, "workers": a.workers, "executor": a.dask, "max_boxes": a.max_boxes}
    common["progress"] = progress
    if a.resume:
        from .workspace import Paving

        common["resume"] = Paving.load(a.resume)
    if a.frame is None:
        for flag, given in (("--base", a.base), ("--lock", a.lock), ("--cone", a.cone), ("--any-orientation", a.any_orientation)):
            if given:
                raise _Usage(f"{flag} applies to an arm (with --frame), not to a platform")
        if a.angle is not None and quat is not None:
            raise _Usage("give a platform's orientation once: --orientation (in space) or --angle (in the plane)")
        orient = [_floats(a.angle, "--angle")[0]] if a.angle is not None else (quat or [0.0, 0.0, 0.0, 1.0])
        legs = _floats(" ".join(a.legs), "--legs") if a.legs else None
        scale = _floats(" ".join(a.legs_scale), "--legs-scale") if a.legs_scale else None
        if legs is not None and scale is not None:
            raise _Usage("give the legs' range once: --legs MIN MAX or --legs-scale A B")
        paving = reach_platform(a.robot, orient, legs=legs, legs_scale=scale, **common)
    else:
        for flag, given in (("--angle", a.angle), ("--legs", a.legs), ("--legs-scale", a.legs_scale)):
            if given:
                raise _Usage(f"{flag} applies to a platform (no --frame), not to an arm")
        if sum(x is not None and x is not False for x in (quat, a.cone, a.any_orientation or None)) > 1:
            raise _Usage("give the tool's orientation once: --orientation, --cone or --any-orientation")
        cone = _floats(" ".join(a.cone), "--cone") if a.cone else None
        arm_orient: str | list[float] | None = "any" if a.any_orientation else quat
        paving = reach(a.robot, a.frame, arm_orient, cone=cone, base=a.base, lock=_assignments(a.lock, "--lock"), **common)
    if show:
        print(file=sys.stderr)
    if a.out:
        paving.save(a.out)
    print(paving.to_json() if a.json else paving.table(), flush=True)
    if paving.complete:
        return EXIT_OK
    print(f"kinbox: incomplete paving ({paving.message}); exit status {EXIT_INCOMPLETE}", file=sys.stderr)
    return EXIT_INCOMPLETE


# -- replay / plot: pictures of a saved result (kinbox.replay, kinbox.plot) ------------------------
def _is_paving(path: str) -> bool:
    return str(path).endswith(".npz")


def _replay_paving(a) -> int:
    """A workspace paving in 3-D with the robot: one HTML page (meshcat's static export)."""
    from .workspace import Paving
    from .workspace.view3d import to_html

    if not a.html:
        raise _Usage("a workspace paving is shown as one page: give --html OUT.html")
    out = to_html(Paving.load(a.result), a.html)
    print(f"kinbox: wrote {out}", file=sys.stderr)
    return 0


def _plot_paving(a) -> int:
    from .viz.paving import AXES, plot_slices
    from .workspace import Paving

    axis = a.vars or "z"
    if axis not in AXES:
        raise _Usage(f"--vars for a workspace paving names the axis across which it is sliced: x, y or z, not {axis!r}")
    pv = Paving.load(a.result)
    if pv.dims == 2:
        from .viz.paving import plot_plane

        plot_plane(pv.lo, pv.hi, pv.verdict, pv.region, a.output, title=f"{pv.meta.get('robot')} {pv.meta.get('frame')}")
        print(f"wrote {a.output}: the plane of the platform")
        return EXIT_OK
    levels = plot_slices(pv.lo, pv.hi, pv.verdict, pv.region, a.output, axis=axis, title=f"{pv.meta.get('robot')} {pv.meta.get('frame')}")
    print(f"wrote {a.output}: slices across {axis} at {', '.join(f'{v:.3f}' for v in levels)} m")
    return EXIT_OK


def _run_pictures(a) -> int:
    import math

    from .viz.entities import is_constraints_result

    if is_constraints_result(a.result):
        if a.cmd == "plot":
            raise _Usage(
                f"{a.result!r} is the answer of a constraint system: it has no solution boxes to plot; "
                "`kinbox replay` draws its points, lines and planes"
            )
        return _replay_entities(a)
    if a.cmd == "plot":
        from .answer.resultfile import load_result
        from .viz.plot import parse_vars, plot_boxes

        if not a.vars:
            raise _Usage("plot needs --vars A,B[,C]: the system variables or joints to project the solution boxes onto")
        out = plot_boxes(load_result(a.result), parse_vars(a.vars), a.output)
        print(f"kinbox: wrote {out}", file=sys.stderr)
        return 0
    from .viz import replay

    for flag, v in (("--delay", a.delay), ("--sweep", a.sweep)):
        if v is not None and not (math.isfinite(v) and 0 < v <= MAX_DELAY):
            raise _Usage(f"{flag} must be a positive number of seconds, at most {MAX_DELAY:g}")
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

    if not (math.isfinite(a.delay) and 0 < a.delay <= MAX_DELAY):
        raise _Usage(f"--delay must be a positive number of seconds, at most {MAX_DELAY:g}")
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
    from .problems.constraints import check

    c = check(a.target, set=_assignments(a.set, "--set"))
    print(json.dumps(c.to_dict()) if a.json else c.table())
    if c.inconsistent:
        print(f"kinbox: error: {c.inconsistent}", file=sys.stderr)
        return EXIT_INPUT
    return EXIT_OK


def _one_line(text: str) -> str:
    """``text`` with newlines, terminal escapes and other unprintable characters written as
    Python escapes: an error names what the user gave, and stays one line
    (tests/cli/test_hostile.py::test_control_characters_escaped)."""
    return text if text.isprintable() else "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def _terminated(signum: int, frame: object) -> None:
    raise SystemExit(128 + signum)


class _Stopped(BaseException):
    """A signal arrived outside a search (or a second time): stop at once."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


class _Signals:
    """SIGINT (Ctrl-C) and SIGTERM. During a solve the first one asks the search to stop at its
    next box (:mod:`kinbox.search.interrupt`): the answer so far is printed, marked
    incomplete. Outside a solve, or a second time, the command stops at once."""

    def __init__(self):
        self.received: int | None = None
        self._old: dict = {}
        self.budget = None  # a CpuBudget of the run (--cpu-limit), stopped on exit

    def __enter__(self):
        from .search import interrupt

        interrupt.clear()
        if threading.current_thread() is threading.main_thread():
            for s in EXIT_SIGNAL:
                self._old[s] = signal.signal(s, self._handle)
        return self

    def __exit__(self, *exc):
        from .search import interrupt

        if self.budget is not None:
            self.budget.stop()
        for s, h in self._old.items():
            signal.signal(s, h)
        interrupt.clear()
        return False

    def _handle(self, signum, frame):
        from .search import interrupt

        first = self.received is None
        if first:
            self.received = signum
        if first and interrupt.running():
            interrupt.request(f"interrupted by {signal.Signals(signum).name}")
            return
        raise _Stopped(signum)


def command() -> int:
    """The ``kinbox`` program: :func:`main` on ``sys.argv``, then a quick shutdown.

    Python's shutdown walks every object the process made, and numba and Pinocchio make many:
    that walk took longer than the IK solve itself (``benchmarks/ur_poses.py startup``). They are moved out of
    the collector's reach once the work is done, so the shutdown skips them; it still flushes
    files and runs ``atexit`` handlers. Only the program does this: a process that calls
    :func:`main` (the tests) keeps its collector as it was.

    The program also starts OpenBLAS with one thread, unless ``OPENBLAS_NUM_THREADS`` says
    otherwise. Its solves run at one BLAS thread anyway (:mod:`kinbox.search.threads`), and its
    workers are processes; but numpy's and scipy's OpenBLAS each start a thread per core as they
    load, and those threads spin, a large share of the CPU of a short ``kinbox`` run. The
    variable must be set before numpy loads, which is why this module and the package's
    ``__init__`` do not import numpy.

    And the collector's full passes are made rare: as numpy, scipy, Pinocchio and numba load,
    the heap grows by some hundred thousand objects that live as long as the process, and each
    full pass walks them all (two passes, some 5% of a small problem's CPU,
    ``benchmarks/startup.py``); the young generations, where short-lived cycles die, are
    collected as usual."""
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    young, middle, _ = gc.get_threshold()
    gc.set_threshold(young, middle, FULL_GC_EVERY)
    code = main()
    gc.freeze()
    return code


def main(argv: list[str] | None = None) -> int:
    started = time.perf_counter()
    args = sys.argv[1:] if argv is None else list(argv)
    parser = _parser()
    try:
        a = parser.parse_args(args)
    except SystemExit as e:  # --help, or a usage error (printed on one line by _Parser.error)
        return int(e.code or 0) if not isinstance(e.code, str) else EXIT_INPUT
    from .errors import KinboxError

    with _Signals() as sig:
        try:
            code = _run(a, sig, started)
            sys.stdout.flush()  # a full disk is seen here, not at exit
            return code
        except (KinboxError, _Usage) as e:
            print(f"kinbox: error: {_one_line(str(e))}", file=sys.stderr)
            return EXIT_INPUT
        except BrokenPipeError:  # the reader of our output went away (`kinbox ... | head`)
            try:
                sys.stdout = open(os.devnull, "w")  # so that the flush at exit does not fail again
            except OSError:
                pass
            return EXIT_BROKEN_PIPE
        except OSError as e:
            if e.errno not in _OUTPUT_ERRNOS:
                if a.debug:
                    raise
                print(f"kinbox: internal error: {type(e).__name__}: {e} (run with --debug for details)", file=sys.stderr)
                return EXIT_INTERNAL
            # the output could not be written (a full disk, a closed output):
            # tests/cli/test_hostile.py::test_output_errors
            print(f"kinbox: error: cannot write the output: {e.strerror or e}", file=sys.stderr)
            try:
                sys.stdout = open(os.devnull, "w")  # what is left unwritten is dropped at exit
            except OSError:
                pass
            return EXIT_OUTPUT
        except (KeyboardInterrupt, _Stopped) as e:
            signum = e.signum if isinstance(e, _Stopped) else int(signal.SIGINT)
            print(f"kinbox: interrupted by {signal.Signals(signum).name}", file=sys.stderr)
            return EXIT_SIGNAL[signum]
        except Exception as e:  # an internal error, not the user's input
            if a.debug:
                raise
            print(f"kinbox: internal error: {type(e).__name__}: {e} (run with --debug for details)", file=sys.stderr)
            return EXIT_INTERNAL


def _list(a) -> int:
    from .model.constraints import builtin_constraint_files
    from .model.loading import builtin_names

    print("built-in mechanisms:", " ".join(builtin_names()))
    print("built-in constraint systems:", " ".join(builtin_constraint_files()))
    from .model.scene import builtin_scenes

    print("built-in scenes:", " ".join(builtin_scenes()))
    import example_robot_data as erd

    print("example-robot-data robots:", " ".join(sorted(erd.ROBOTS)))
    return EXIT_OK


def _info(a) -> int:
    from .model.describe import describe, info_table
    from .model.loading import load

    d = describe(load(a.robot))
    print(json.dumps(d) if a.json else info_table(d))
    return EXIT_OK


def _plot(a) -> int:
    return _plot_paving(a) if _is_paving(a.result) else _run_pictures(a)


def _replay(a) -> int:
    return _replay_paving(a) if _is_paving(a.result) else _run_pictures(a)


#: the handler of each command that does not search (:data:`SEARCHES` go to :func:`_search`);
#: together they cover every command the library declares (tests/cli/test_cli.py::test_cli_commands_are_the_library_s)
_HANDLERS = {"list": _list, "info": _info, "reach": _reach, "replay": _replay, "plot": _plot, "check": _check}
SEARCHES = ("ik", "solve")


def _run(a, sig: _Signals, started: float) -> int:
    """Run command ``a.cmd``: its handler, or, for the commands that search, :func:`_search`."""
    return _search(a, sig, started) if a.cmd in SEARCHES else _HANDLERS[a.cmd](a)


def _search(a, sig: _Signals, started: float) -> int:
    """``kinbox ik`` and ``kinbox solve``: options -> the library's problem -> the answer printed."""
    from .search import interrupt
    from .search.state import SearchState

    opts = _solver_options(a)
    if not a.quiet and sys.stderr.isatty():
        from .search.loading import kernels_cached

        if not kernels_cached():
            print(
                "kinbox: compiling the numba kernels once (the first run after an install: about a minute of CPU; "
                "`make setup` does it ahead)",
                file=sys.stderr,
                flush=True,
            )
    if a.cmd == "ik" and a.poses is not None:
        if a.save or a.resume:
            raise _Usage("--save and --resume take one problem, not a --poses batch")
        if a.cpu_limit is not None:
            raise _Usage("--cpu-limit takes one problem, not a --poses batch (--time-limit is per pose)")
        return _run_poses(a, opts, sig)
    if a.save:  # checked before the search, not after it has run for hours
        folder = os.path.dirname(os.path.abspath(a.save))
        if os.path.isdir(a.save) or not os.path.isdir(folder) or not os.access(folder, os.W_OK):
            raise _Usage(f"--save {a.save!r}: cannot write a file there")
    if a.resume:
        opts["resume"] = SearchState.load(a.resume)
    if "time_limit" in opts or a.cpu_limit is not None:
        # the limit covers loading the model and formulating, not compiling the kernels (the
        # first run after an install): with a limit, a cold cache is filled before its clock
        # starts; cached, each kernel loads at its first call (a UR5 pose uses three of them)
        from .pipeline import compile_kernels

        compile_kernels()
        started = time.perf_counter()
    opts["started"] = started
    if a.cpu_limit is not None:  # stopped when the command ends (_Signals.__exit__)
        from .search.cpu_budget import CpuBudget

        sig.budget = CpuBudget(a.cpu_limit)
    if a.cmd == "ik":
        from .pipeline import IK

        lock = _assignments(a.lock, "--lock", vectors=True)
        scene = _scene_options(a)
        if scene:
            opts["collision_free"] = scene.pop("collision_free")
        prob = IK(a.robot, a.frame, a.base, lock, formulation=a.formulation, **scene)
        if a.pose is not None:
            pose = _floats(" ".join(a.pose), "--pose")
        else:
            pose = prob.pose_at(_floats(a.from_q, "--from-q"))
        with interrupt.searching():
            res = prob.solve(pose, **opts)
    else:
        from .model.constraints import is_constraints_source

        with interrupt.searching():
            if is_constraints_source(a.mechanism):
                from .pipeline import assemble

                opts.pop("all_turns", None)  # entities, no joints
                if a.scene is not None:
                    raise _Usage("--scene takes a mechanism with body geometry (URDF, MJCF), not a constraint system")
                res = assemble(a.mechanism, set=_assignments(a.set, "--set"), formulation=a.formulation, **opts)
            else:
                from .pipeline import solve

                if a.formulation not in MECHANISM_FORMULATIONS:
                    take = " or ".join(MECHANISM_FORMULATIONS[1:])
                    raise _Usage(f"--formulation {a.formulation} is for constraint systems; mechanisms take {take}")
                res = solve(
                    a.mechanism, set=_assignments(a.set, "--set"), legs=a.legs, formulation=a.formulation, **_scene_options(a), **opts
                )
    print(json.dumps(res.to_dict()) if a.json else res.table(), flush=True)
    if res.complete and sig.received is None:
        return EXIT_OK
    note = f"kinbox: incomplete answer ({res.message})"
    state = getattr(res.raw, "state", None)
    if a.save and state is not None:
        from .errors import KinboxError

        try:  # a failed save keeps the answer's status: tests/cli/test_hostile.py::test_save_is_safe
            state.save(a.save)
            note += f"; search state saved to {a.save} (add --resume {a.save} to go on)"
        except KinboxError as e:
            note += f"; the search state was NOT saved ({e})"
    code = EXIT_SIGNAL[sig.received] if sig.received is not None else EXIT_INCOMPLETE
    print(f"{note}; exit status {code}", file=sys.stderr, flush=True)
    return code


def _run_poses(a, opts: dict, sig: _Signals) -> int:
    """``kinbox ik --poses FILE``: every good line answered, an error record for each bad one.

    The arm is prepared once and the poses answered by the library's one batch path
    (:func:`kinbox.problems.batch.answers`: with ``--workers N`` over N processes, each pose
    solved in one of them, the answer that of the pose alone), printed in the order of the
    file as they come. One progress bar counts the poses."""
    from .pipeline import IK, parse_pose
    from .problems.batch import answers
    from .search import interrupt

    workers = opts.pop("workers", None)
    show = opts.pop("progress", None)
    show = sys.stderr.isatty() if show is None else show
    opts["progress"] = False  # one bar for the batch, not one per pose
    scene = _scene_options(a)
    if scene:
        opts["collision_free"] = scene.pop("collision_free")
    prob = IK(a.robot, a.frame, a.base, _assignments(a.lock, "--lock", vectors=True), formulation=a.formulation, **scene)
    lines = pose_lines(a.poses)
    goals = [parse_pose(pose) if err is None else None for _, pose, err in lines]
    records = answers(prob, goals, workers, catch=True, debug=a.debug, **opts)
    bar = _poses_bar(len(lines)) if show else None
    bad = incomplete = internal = done = 0
    first: tuple[int, str | None] | None = None  # the first bad line, named on stderr
    try:
        with interrupt.searching():
            for ans in records:
                n, pose, err = lines[ans.index]
                err = err or ans.error
                if bar is not None:
                    bar.update(1)
                _print_whole(_pose_text(ans.index, len(lines), n, pose, ans.result, err, a.json))
                if err is not None:
                    bad += 1
                    internal += ans.internal
                    first = first or (n, err)
                else:
                    assert ans.result is not None
                    done += 1
                    incomplete += not ans.result.complete
                if sig.received is not None:
                    break
    finally:
        records.close()  # workers still busy are stopped
        if bar is not None:
            bar.close()
    parts = []
    if first is not None:
        parts.append(
            f"error: {bad} of {len(lines)} lines of {a.poses} rejected (line {first[0]}: {first[1]}"
            f"{'; ...' if bad > 1 else ''}), an error record each in the output"
        )
    if incomplete:
        parts.append(f"{incomplete} of {done} answers incomplete")
    if sig.received is not None:
        parts.append(f"interrupted by {signal.Signals(sig.received).name} after {done + bad} of {len(lines)} lines")
        code = EXIT_SIGNAL[sig.received]
    else:
        code = EXIT_INTERNAL if internal else EXIT_BATCH if bad else EXIT_INCOMPLETE if incomplete else EXIT_OK
    if parts:
        print(f"kinbox: {'; '.join(parts)}; exit status {code}", file=sys.stderr, flush=True)
    return code


def _pose_text(k: int, total: int, n: int, pose, res, err: str | None, as_json: bool) -> str:
    """The output of one line of a poses file: its answer, or its error record."""
    if err is not None:
        return json.dumps({"line": n, "error": err}) if as_json else f"pose {k + 1} of {total} (line {n}): error: {err}"
    if as_json:
        return json.dumps({"line": n, **res.to_dict()})
    return f"pose {k + 1} of {total} (line {n}): {' '.join(f'{v:g}' for v in pose or [])}\n{res.table()}"


def _print_whole(text: str) -> None:
    """Print a line of the output, all of it, also when a signal handler runs while the write
    is blocked on a full pipe. With ``print``, Ctrl-C to ``kinbox ik --poses ... --workers 2``
    under load (the first one only asks the searches to stop: its handler returns) now and then
    left the last line cut short, half a JSON record; where in the io stack the rest went was
    not found. ``os.write`` on the file descriptor reports what it wrote, and the rest is
    written again: a record is whole or absent (tests/cli/test_cli.py, a poses line written whole
    through signals on a full pipe)."""
    try:
        fd = sys.stdout.fileno()
    except (AttributeError, OSError, ValueError):  # not a file (captured, redirected in Python)
        print(text, flush=True)
        return
    sys.stdout.flush()
    data = memoryview((text + "\n").encode(sys.stdout.encoding or "utf-8", sys.stdout.errors or "strict"))
    while data:
        data = data[os.write(fd, data) :]


def _poses_bar(total: int):
    from tqdm import tqdm

    class _Bar(tqdm):
        monitor_interval = 0  # no monitor thread: worker processes may be forked after it starts

    return _Bar(total=total, desc="kinbox", unit=" poses", file=sys.stderr, smoothing=0, mininterval=0.25)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(command())
