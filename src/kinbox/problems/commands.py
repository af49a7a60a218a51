"""The commands the library offers a command line, declared once as data: each command's name,
help, arguments and their choices. ``kinbox.cli`` builds its parser by iterating
:data:`COMMANDS` and adds nothing of its own; the choices are the library's tuples
(:mod:`kinbox.problems.choices`, :func:`kinbox.search.options.choices`), so the command line
cannot offer a name the library refuses (tests/cli/test_cli.py::test_cli_choices_are_the_library_s,
test_cli_commands_are_the_library_s).

This module loads nothing heavy (no numpy): ``kinbox --help`` reads it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from ..search.options import choices as solver_choices
from .choices import ARM_FORMULATIONS, LEGS, SOLVE_FORMULATIONS


@dataclass(frozen=True)
class Arg:
    """One argument of a command: its flags (a positional name, or ``--option`` strings) and
    argparse's keywords (``type``, ``choices``, ``default``, ``help``, ...). ``negatable``: an
    on/off option that also takes ``--no-OPTION``. ``group``: the name of a group of options
    of which exactly one must be given."""

    flags: tuple[str, ...]
    options: dict[str, Any] = field(default_factory=dict)
    negatable: bool = False
    group: str | None = None


def arg(*flags: str, negatable: bool = False, group: str | None = None, **options: Any) -> Arg:
    return Arg(flags, options, negatable, group)


@dataclass(frozen=True)
class Command:
    """A command: ``kinbox NAME ARGS...``. ``exit_status``: its help ends with the exit
    statuses (the commands that search)."""

    name: str
    help: str
    args: tuple[Arg, ...] = ()
    description: str | None = None
    exit_status: bool = False


#: the options of a search (:class:`kinbox.search.options.SolverOptions` and the budgets of a
#: run), taken by every command that searches
SEARCH_ARGS: tuple[Arg, ...] = (
    arg("--sigma", type=float, help="box width below which a box is a solution box"),
    arg(
        "--time-limit",
        type=float,
        help="wall-clock seconds (elapsed time, not CPU: on a busy machine a search gets less CPU "
        "than that) for the whole run, loading and formulating included, compiling kernels not; "
        "the answer is marked incomplete if hit",
    ),
    arg(
        "--cpu-limit",
        type=float,
        metavar="SECONDS",
        help="CPU seconds of this process (not of --workers processes) for the whole run, "
        "compiling kernels not included; the answer is marked incomplete if hit",
    ),
    arg("--max-boxes", type=int, help="box budget; the answer is marked incomplete if hit"),
    arg(
        "--curve-boxes",
        negatable=True,
        default=None,
        help="return a box proven to hold one piece of a curve at once instead of splitting it "
        "down to sigma (on by default: self-motions in seconds); --no-curve-boxes splits every "
        "uncertified box down to sigma",
    ),
    arg(
        "--workers",
        type=int,
        metavar="N",
        help="explore boxes with N local processes (0: one per core); with --poses, solve N poses at a time, one per process",
    ),
    arg("--dask", metavar="ADDRESS", help="explore boxes on a Dask cluster, e.g. tcp://host:8786 (pip install 'kinbox[dask]')"),
    arg(
        "--relaxation",
        choices=solver_choices("relaxation"),
        help="the LP contractor: linear (Porta, Ros and Thomas 2009: secants, tangents, McCormick), "
        "bernstein (Fünfzig et al. 2010: the Bernstein polytope of each box), none (interval propagation and Krawczyk only) or auto "
        "(default: linear for mobile platforms with leg vectors, bernstein otherwise)",
    ),
    arg(
        "--extra-steps",
        metavar="NAMES",
        help="optional contractors to run on every box too, comma-separated: shave (3BCID shaving over propagation; "
        "fewer boxes on most problems, not less CPU on all: benchmarks/shaving.py)",
    ),
    arg(
        "--all-turns",
        action="store_true",
        help="a joint whose range is wider than a turn (+-400 deg, +-2 pi): list every copy q + 2 pi k "
        "within its limits, each a solution (by default one per solution, the answer says how many)",
    ),
    arg("--json", action="store_true", help="print one JSON object on stdout"),
    arg("--quiet", action="store_true", help="no progress on stderr"),
    arg("--progress", action="store_true", help="progress on stderr even when not a terminal"),
    arg(
        "--save",
        metavar="FILE",
        help="if the search stops unfinished (a budget, Ctrl-C, SIGTERM), write where it stood to FILE, to go on later with --resume FILE",
    ),
    arg(
        "--resume",
        metavar="FILE",
        help="go on with a search saved by --save (same problem and solver options); the budgets count from now",
    ),
)

#: a collision scene (:mod:`kinbox.problems.scene`) for the solutions of a search
SCENE_ARGS: tuple[Arg, ...] = (
    arg(
        "--scene",
        metavar="FILE|NAME",
        help="check every solution against a collision scene (a scene file or a built-in scene, kinbox list)",
    ),
    arg("--srdf", metavar="FILE", help="with --scene: the robot's disabled collision pairs (default: its own SRDF, if any)"),
    arg("--collision-free", action="store_true", help="with --scene: keep only the collision-free solutions"),
)

_JSON = arg("--json", action="store_true", help="print one JSON object on stdout")

IK_COMMAND = Command(
    "ik",
    "all inverse-kinematics solutions of an arm",
    (
        arg("robot", help="example-robot-data name, URDF file, or built-in mechanism"),
        arg(
            "--frame",
            required=True,
            help="the frame to place: NAME, or NAME:TYPE (body, joint, fixed_joint, op_frame) "
            "where frames of one name are at different places",
        ),
        arg("--pose", group="goal", nargs=7, metavar=("X", "Y", "Z", "QX", "QY", "QZ", "QW")),
        arg(
            "--from-q",
            group="goal",
            metavar="Q1,...,QN",
            help="goal = the frame's pose at these joint values: every joint of the robot, or the "
            "joints between the base and the frame alone (kinbox info ROBOT lists them in order)",
        ),
        arg(
            "--poses",
            group="goal",
            metavar="FILE",
            help="many goals, one pose per line (X Y Z QX QY QZ QW; '#' comments; '-' = stdin): "
            "the arm is prepared once; with --json one result per line (JSON Lines, each with "
            'its "line"); a bad line gets an error record {"line": N, "error": ...}',
        ),
        arg(
            "--formulation",
            choices=ARM_FORMULATIONS,
            default="auto",
            help="auto (default): built once for a frame reached by six revolute or prismatic joints "
            "(others locked): Raghavan and Roth's invariants for six revolute joints with no wrist or "
            "shoulder centre, else the arm formulation; else the general one; invariants, arm: that "
            "or an error; general: the general formulation for every pose",
        ),
        arg("--base", help="frame the pose is expressed in (default: world)"),
        arg(
            "--lock",
            action="append",
            metavar="JOINT=VALUE",
            help="hold a joint fixed; a joint of several q entries takes them all, e.g. a free-flyer "
            "root_joint=0,0,0,0,0,0,1 (x y z qx qy qz qw)",
        ),
        *SCENE_ARGS,
        *SEARCH_ARGS,
    ),
    exit_status=True,
)

SOLVE_COMMAND = Command(
    "solve",
    "all configurations of a mechanism with loops, or all assemblies of a geometric constraint system",
    (
        arg(
            "mechanism",
            help='built-in name (kinbox list) or file (.json, .xml, .urdf; a .json with "kind": "constraints" is a constraint system)',
        ),
        arg("--set", action="append", metavar="NAME=VALUE", help="fix an actuated joint, or set a parameter of a constraint system"),
        arg(
            "--legs",
            choices=LEGS,
            default="auto",
            help="equations of legs (distance closures): squared (fastest for isolated assembly "
            "modes) or vector (a unit vector per leg: for mobile platforms); auto picks "
            "vector when the configurations form curves",
        ),
        arg(
            "--formulation",
            choices=SOLVE_FORMULATIONS,
            default="auto",
            help="constraint systems: coordinates of the entities, or unknown distances under "
            "Cayley-Menger conditions (points and lines under distances only); mechanisms: "
            "planar (every loop joint about parallel axes) or general; auto picks one",
        ),
        *SCENE_ARGS,
        *SEARCH_ARGS,
    ),
    exit_status=True,
)

CHECK_COMMAND = Command(
    "check",
    "degrees of freedom, redundant and inconsistent constraints (constraint systems), mobility (mechanisms)",
    (
        arg("target", metavar="FILE", help="constraint system or mechanism (file or built-in name)"),
        arg("--set", action="append", metavar="NAME=VALUE", help="parameter (or locked joint) value"),
        _JSON,
    ),
    description="Diagnosis before solving: generic degrees of freedom and at a solution, "
    "redundant constraints, a minimal inconsistent set (exit 2 when proven), "
    "under-constrained entities; for a mechanism, its mobility by counting and "
    "by the closure Jacobian's rank at configurations found.",
)

LIST_COMMAND = Command("list", "built-in mechanisms and example-robot-data robots")

INFO_COMMAND = Command(
    "info",
    "the joints (types, limits), frames and loop closures of a robot or mechanism",
    (
        arg("robot", help="example-robot-data name, URDF/MJCF file, built-in mechanism or mechanism file"),
        _JSON,
    ),
)

REPLAY_COMMAND = Command(
    "replay",
    "show every configuration of a result on the robot (meshcat)",
    (
        arg("result", metavar="RESULT.json", help="output of `kinbox ik ... --json` or `kinbox solve ... --json`"),
        arg("--html", metavar="OUT.html", help="write a self-contained HTML page instead of serving live"),
        arg("--delay", type=float, default=1.0, metavar="S", help="seconds per isolated configuration (default 1)"),
        arg("--sweep", type=float, metavar="S", help="seconds to move along one curve component (default: 5 x --delay)"),
        arg(
            "--cycles",
            type=int,
            default=0,
            metavar="N",
            help="live mode: passes through the configurations, 0 = until Ctrl-C (default)",
        ),
        arg(
            "--host",
            default="127.0.0.1",
            help="live mode: address the viewer page is served on (default 127.0.0.1, this machine only; "
            "another address lets other hosts see it: a warning is printed)",
        ),
    ),
    description="Show every configuration of a result (kinbox ik/solve --json) on the robot. "
    "Live: a meshcat server on localhost (its URL is printed); --html: one "
    "self-contained page that steps through the configurations.",
)

PLOT_COMMAND = Command(
    "plot",
    "projection of the solution boxes onto 2 or 3 variables or joints",
    (
        arg(
            "result",
            metavar="RESULT.json",
            help="output of `kinbox ik/solve ... --json`, or a workspace paving (.npz, `kinbox reach --out`)",
        ),
        arg(
            "--vars",
            metavar="A,B[,C]",
            help="system variables or joints (a workspace paving, map.npz: the axis x, y or z to slice across)",
        ),
        arg("-o", "--output", required=True, metavar="OUT.png", help="image file (png, pdf, svg)"),
    ),
    description="Projection of the solution boxes of a result onto two or three system "
    "variables (boxes) or joints (angles; one point per box), one colour per component.",
)

REACH_COMMAND = Command(
    "reach",
    "the workspace of a frame or a platform: a paving of position space into boxes proven inside, proven outside, and boundary",
    (
        arg("robot", help="example-robot-data name, URDF file, or built-in mechanism (a platform without --frame)"),
        arg("--frame", help="the frame to place (an arm); without it ROBOT is a parallel platform"),
        arg(
            "--orientation",
            nargs=4,
            metavar=("QX", "QY", "QZ", "QW"),
            default=None,
            help="the tool's or platform's orientation (default: 0 0 0 1)",
        ),
        arg(
            "--cone",
            nargs=4,
            metavar=("AX", "AY", "AZ", "ANGLE"),
            help="an arm's tool held with its z axis within ANGLE radians of the direction AX AY AZ",
        ),
        arg("--any-orientation", action="store_true", help="an arm's tool at any orientation (the position workspace)"),
        arg("--angle", metavar="PHI", help="a planar platform's orientation: its angle about z in radians (default 0)"),
        arg("--legs", nargs=2, metavar=("MIN", "MAX"), help="a platform's legs: every length within [MIN, MAX]"),
        arg(
            "--legs-scale",
            nargs=2,
            metavar=("A", "B"),
            help="a platform's legs: from A to B times the lengths the mechanism sets (0.8 1.2: +-20 %%)",
        ),
        arg(
            "--region",
            nargs="+",
            metavar="X",
            help="the region XMIN YMIN ZMIN XMAX YMAX ZMAX (XMIN YMIN XMAX YMAX for a planar platform; "
            "default: a box that bounds the reach)",
        ),
        arg("--resolution", type=float, default=0.05, metavar="R", help="boxes are not split below this side, in metres (default 0.05)"),
        arg("--base", help="frame the positions are expressed in (default: world)"),
        arg("--lock", action="append", metavar="JOINT=VALUE", help="hold a joint fixed"),
        arg("--workers", type=int, metavar="N", help="decide boxes over N local processes (0: one per core); the paving is the same"),
        arg("--dask", metavar="ADDRESS", help="decide boxes on a Dask cluster (scheduler address); the paving is the same"),
        arg("--max-boxes", type=int, default=2_000_000, metavar="N", help="stop, incomplete, after deciding this many boxes"),
        arg("--out", metavar="FILE", help="write the paving (.npz, or JSON otherwise), with its pending boxes if a budget stops it"),
        arg("--resume", metavar="FILE", help="go on with a paving of the same problem stopped by --max-boxes (written by --out)"),
        arg("--json", action="store_true", help="print the paving as JSON on stdout"),
        arg("--quiet", action="store_true", help="no progress line on stderr"),
    ),
    description="The positions a frame reaches with its tool held at one orientation, at any orientation, or with "
    "its axis within a cone, within the joint limits (ROBOT --frame F), or the positions a parallel platform's "
    "frame reaches at a constant orientation with every leg's length in its range (ROBOT a platform, no --frame): "
    "boxes proven reached (inside, with a witness at the centre), proven unreached (outside), and boxes at the "
    "resolution that are neither (boundary). Set inversion (Jaulin and Walter) with the IK system's parameters as "
    "enclosures of each box, or the legs' lengths in interval arithmetic (docs/workspace.md).",
    exit_status=True,
)

#: every command, in the order ``kinbox --help`` lists them
COMMANDS: tuple[Command, ...] = (
    IK_COMMAND,
    SOLVE_COMMAND,
    CHECK_COMMAND,
    LIST_COMMAND,
    INFO_COMMAND,
    REPLAY_COMMAND,
    PLOT_COMMAND,
    REACH_COMMAND,
)

__all__ = ["COMMANDS", "SCENE_ARGS", "SEARCH_ARGS", "Arg", "Command", "arg"]
