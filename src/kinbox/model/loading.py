"""Loading: a user's ``source`` (a model, a file, a name) as a :class:`Mechanism`.

:func:`load` makes a Mechanism from a ``pinocchio.Model``, a URDF / MJCF / kinbox mechanism
file (``docs/mechanism-files.md``), a URDF string, a built-in mechanism name
(:func:`builtin_names`) or an example-robot-data robot name. Parsing robot files is
Pinocchio's job (``buildModelFromUrdf`` / ``buildModelFromXML`` for URDF,
``buildModelAndConstraintsFromMJCF`` for MJCF): kinbox never reads URDF itself and never builds
geometry models, so meshes are never loaded. Kinbox mechanism files (``.json``) are turned into
Mechanisms by :mod:`kinbox.model.builders`.
"""

from __future__ import annotations

import contextlib
import difflib
import os
import sys
import tempfile
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import pinocchio as pin

from ..errors import MAX_INPUT_BYTES, InputError, ModelError, NameNotFound, read_bytes, read_json
from . import builders
from .mechanism import Closure, ClosureKind, Mechanism, check_mechanism, finite
from .planar import kind_planar
from .xmlcheck import robot_format

#: where the built-in mechanism files live: package data, so that an installed kinbox has them
#: too. ``KINBOX_ROBOTS`` overrides it.
_BUILTIN_DIR = Path(__file__).resolve().parents[1] / "robots"

_ROBOT_SUFFIXES = (".json", ".urdf", ".xml", ".mjcf")
#: keys of a kinbox mechanism file that are documentation only
_META_KEYS = {"kind", "name", "description", "source", "note", "notes", "reference", "expected", "set"}


def builtin_dir() -> Path:
    """The folder holding the built-in mechanism files."""
    env = os.environ.get("KINBOX_ROBOTS")
    return Path(env) if env else _BUILTIN_DIR


def builtin_files() -> dict[str, Path]:
    """name -> file of every built-in mechanism.

    A ``.json`` file is named by its stem (``robots/four-bar.json`` -> ``four-bar``); another
    file (URDF, MJCF) by its stem too unless a ``.json`` file already has that stem, in which
    case by its file name (``robots/four-bar.xml`` -> ``four-bar.xml``).
    """
    d = builtin_dir()
    if not d.is_dir():
        return {}
    files = sorted(p for p in d.iterdir() if p.is_file() and p.suffix.lower() in _ROBOT_SUFFIXES)
    out: dict[str, Path] = {p.stem: p for p in files if p.suffix.lower() == ".json"}
    for p in files:
        if p.suffix.lower() != ".json":
            out[p.name if p.stem in out else p.stem] = p
    return out


def builtin_names() -> list[str]:
    """Names of the built-in mechanisms, e.g. ``general-6r``, ``dietmeier``, ``four-bar``."""
    return sorted(builtin_files())


def _erd_names() -> list[str]:
    try:
        import example_robot_data
    except ImportError:  # pragma: no cover - a declared dependency
        return []
    return sorted(example_robot_data.ROBOTS)


def normalize_name(name: str) -> str:
    return name.strip().lower().replace("_", "-").replace(" ", "-")


# -- Pinocchio calls -------------------------------------------------------------------------
class CapturedStderr:
    """Capture what C++ code writes to file descriptor 2 (urdfdom prints its errors there)."""

    def __init__(self):
        self.text = ""

    def __enter__(self):
        self._saved = None
        try:
            sys.stderr.flush()
            self._buf = tempfile.TemporaryFile()
            self._saved = os.dup(2)
            os.dup2(self._buf.fileno(), 2)
        except (OSError, ValueError, AttributeError):  # no usable fd 2: do not capture
            self._saved = None
        return self

    def __exit__(self, *exc):
        if self._saved is None:
            return False
        try:
            sys.stderr.flush()
        except (OSError, ValueError, AttributeError):
            pass
        os.dup2(self._saved, 2)
        os.close(self._saved)
        self._buf.seek(0)
        self.text = self._buf.read().decode("utf-8", "replace")
        self._buf.close()
        return False


def _loader_message(exc: BaseException, captured: str) -> str:
    """The exception's message plus the useful lines the C++ loader printed."""
    lines = [ln.strip() for ln in captured.splitlines()]
    lines = [ln[6:].strip() if ln.startswith("Error:") else ln for ln in lines if ln and not ln.startswith("at line ")]
    msg = str(exc).strip() or type(exc).__name__
    if lines:
        msg += " (" + "; ".join(dict.fromkeys(lines)) + ")"
    return msg


def _call_loader(what: str, fn, *args):
    """Run a Pinocchio loader; any failure becomes a ModelError naming ``what``."""
    cap = CapturedStderr()
    try:
        with cap:
            out = fn(*args)
    except Exception as e:  # noqa: BLE001 - Pinocchio raises ValueError, RuntimeError, ...
        raise ModelError(f"cannot load {what}: {_loader_message(e, cap.text)}") from None
    if cap.text.strip():  # warnings of a successful load: pass them on
        sys.stderr.write(cap.text)
    return out


def _root_joint(root_joint):
    """``None`` | ``"freeflyer"`` | ``"planar"`` | a ``pin.JointModel*`` -> JointModel or None."""
    if root_joint is None or root_joint is False:
        return None
    if isinstance(root_joint, str):
        key = root_joint.strip().lower().replace("-", "").replace("_", "")
        table = {
            "freeflyer": pin.JointModelFreeFlyer,
            "free": pin.JointModelFreeFlyer,
            "floating": pin.JointModelFreeFlyer,
            "planar": pin.JointModelPlanar,
            "translation": pin.JointModelTranslation,
            "spherical": pin.JointModelSpherical,
        }
        if key not in table:
            raise InputError(f"unknown root_joint {root_joint!r}; use one of freeflyer, planar, translation, spherical")
        return table[key]()
    if type(root_joint).__name__.startswith("JointModel"):
        return root_joint
    raise InputError(f"root_joint must be None, a name or a pinocchio JointModel, not {type(root_joint).__name__}")


def _urdf_file(path: Path, root_joint=None) -> pin.Model:
    rj = _root_joint(root_joint)
    args = (str(path),) if rj is None else (str(path), rj)
    return _call_loader(f"URDF file {path.name!r}", pin.buildModelFromUrdf, *args)


def _urdf_string(xml: str, root_joint=None) -> pin.Model:
    rj = _root_joint(root_joint)
    args = (xml,) if rj is None else (xml, rj)
    return _call_loader("URDF string", pin.buildModelFromXML, *args)


def closures_from_mjcf(point_models, frame_models) -> list[Closure]:
    """Closures from the constraint models of ``pin.buildModelAndConstraintsFromMJCF``.

    ``<connect>`` (a ``PointAnchorConstraintModel``) -> ``point``; ``<weld>``
    (a ``FrameAnchorConstraintModel``) -> ``weld``. Pinocchio computes the second body's
    anchor from the file's reference configuration ``qpos0`` (MuJoCo's semantics), and does
    not keep the constraint names: closures are named ``connect1, connect2, ..., weld1, ...``.
    """
    out: list[Closure] = []
    kinds: tuple[tuple[ClosureKind, str, Any], ...] = (("point", "connect", point_models), ("weld", "weld", frame_models))
    for kind, label, models in kinds:
        for k, cm in enumerate(models, start=1):
            Ma, Mb = pin.SE3(cm.joint1_placement), pin.SE3(cm.joint2_placement)
            for M in (Ma, Mb):
                R = np.asarray(M.rotation)
                if not (finite(R) and finite(M.translation) and np.allclose(R.T @ R, np.eye(3), atol=1e-6)):
                    raise ModelError(
                        f"Pinocchio's MJCF parser returned an invalid placement for <{label}> number {k} "
                        "(site-based <connect>/<weld> are not supported by it: use body1/body2 with an anchor)"
                    )
            if kind == "point":  # only the anchor points matter; Pinocchio may leave R unset
                Ma = pin.SE3(np.eye(3), np.array(Ma.translation))
                Mb = pin.SE3(np.eye(3), np.array(Mb.translation))
            name = getattr(cm, "name", "") or f"{label}{k}"
            out.append(Closure(kind, int(cm.joint1_id), Ma, int(cm.joint2_id), Mb, name=name))
    return out


def _name_mjcf_closures(path: Path, closures: list[Closure]) -> None:
    """Give the closures the names of the file's ``<connect>`` / ``<weld>`` elements.

    Pinocchio drops these names; they are read back from ``<equality>`` (names only, in file
    order) and applied only when the counts match what Pinocchio returned.
    """
    import xml.etree.ElementTree as ET

    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError):
        return
    for tag, kind in (("connect", "point"), ("weld", "weld")):
        names = [el.get("name") for eq in root.iter("equality") for el in eq if el.tag == tag]
        mine = [c for c in closures if c.kind == kind]
        if len(names) == len(mine):
            for c, n in zip(mine, names):
                if n:
                    c.name = n


def _refuse_site_constraints(path: Path) -> None:
    """Pinocchio's MJCF loader reads uninitialised memory for ``<connect>``/``<weld>`` between
    sites (a wrong anchor, sometimes a crash): refuse them before Pinocchio sees the file."""
    import xml.etree.ElementTree as ET

    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError):
        return  # Pinocchio reports malformed files itself
    for eq in root.iter("equality"):
        for el in eq:
            if el.tag in ("connect", "weld") and (el.get("site1") or el.get("site2")):
                raise ModelError(
                    f"MJCF file {path.name!r}: <{el.tag}> between sites is not supported by "
                    f"Pinocchio's MJCF loader; attach it to bodies (body1/body2 with anchor)"
                )


def _mjcf_file(path: Path, root_joint=None, name: str | None = None) -> Mechanism:
    _refuse_site_constraints(path)
    rj = _root_joint(root_joint)
    args = (str(path),) if rj is None else (str(path), rj)
    model, pts, frs = _call_loader(f"MJCF file {path.name!r}", pin.buildModelAndConstraintsFromMJCF, *args)
    try:
        closures = closures_from_mjcf(pts, frs)
    except ModelError as e:
        raise ModelError(f"MJCF file {path.name!r}: {e}") from None
    _name_mjcf_closures(path, closures)
    mech = Mechanism(model, closures, name=name or model.name or path.stem)
    check_mechanism(mech, f"MJCF file {path.name!r}")
    return mech


def _sniff_xml(path: Path) -> str:
    """'mjcf' or 'urdf' from the root element of the robot file ``path``, read with the input
    budget and checked for its limits (:mod:`kinbox.model.xmlcheck`)."""
    return robot_format(read_bytes(path, ModelError, "robot file"), repr(path.name))


# -- example-robot-data --------------------------------------------------------------------------
def erd_loader(name: str) -> Any:
    """The example-robot-data loader class of the robot ``name`` (a key of ``ROBOTS``)."""
    import example_robot_data as erd

    cls = erd.ROBOTS[name]
    if name == "ur3" and getattr(cls, "urdf_filename", "") != "ur3_robot.urdf":
        # example-robot-data 5.0 maps "ur3" to UR5Loader; kinbox's "ur3" is the genuine UR3
        cls = getattr(erd.robots_loader, "UR3Loader", cls)
    return cls


class ErdFiles(NamedTuple):
    """The files of an example-robot-data robot described by URDF."""

    urdf: Path
    srdf: Path | None  # reference postures, if the robot has them
    package_dir: Path  # where the ``package://`` URIs of its meshes resolve


def erd_files(name: str) -> ErdFiles | None:
    """The files of the example-robot-data robot ``name``; ``None`` if its loader builds the
    model another way (SDF, no URDF)."""
    from example_robot_data.utils import getModelPath

    cls = erd_loader(name)
    urdf, sdf = getattr(cls, "urdf_filename", None), getattr(cls, "sdf_filename", None)
    if not urdf or sdf:
        return None
    sub = os.path.join(cls.path, cls.urdf_subpath, urdf)
    try:
        root = Path(cls.model_path or getModelPath(sub))
    except OSError as e:
        raise ModelError(f"example-robot-data robot {name!r}: {e}") from None
    srdf = root / cls.path / cls.srdf_subpath / cls.srdf_filename if cls.srdf_filename else None
    # the URIs read package://example-robot-data/robots/...: two levels above the robots folder
    return ErdFiles(root / sub, srdf, root.parent.parent)


def erd_package_dir() -> Path | None:
    """The folder ``package://example-robot-data/...`` URIs resolve in (for URDF files of users
    that use its meshes), or None."""
    from example_robot_data.utils import getModelPath

    try:
        return Path(getModelPath("ur_description")).parent.parent
    except OSError:
        return None


def erd_name(text: str) -> str | None:
    """The example-robot-data name ``text`` stands for (case and ``-``/``_`` ignored), or None."""
    table = {n.lower(): n for n in _erd_names()}
    for cand in (text.lower(), text.lower().replace("-", "_")):
        if cand in table:
            return table[cand]
    return None


def _erd_model(name: str, free_flyer: bool | None = None) -> pin.Model:
    """The kinematic model of an example-robot-data robot, without loading its meshes.

    Robots whose loader is the plain ``RobotLoader`` recipe (URDF + optional free flyer +
    SRDF reference postures) are built here with ``pin.buildModelFromUrdf``; the few with a
    custom loader (e.g. ``talos_legs``, ``cassie``) go through ``example_robot_data.load``.
    """
    import example_robot_data as erd
    from example_robot_data.utils import RobotLoader

    cls = erd_loader(name)
    ff = bool(cls.free_flyer) if free_flyer is None else bool(free_flyer)
    plain = cls.__init__ is RobotLoader.__init__ or name == "panda_collision"  # only edits collisions
    human = cls.__name__ == "HumanLoader"
    files = erd_files(name) if plain or human else None
    if files is not None:
        model = _urdf_file(files.urdf, "freeflyer" if ff else None)
        if files.srdf is not None and files.srdf.is_file():
            with contextlib.suppress(Exception):
                _call_loader(f"SRDF {files.srdf.name!r}", pin.loadReferenceConfigurations, model, str(files.srdf), False)
        if human and ff:
            jid = model.getJointId("root_joint")
            model.jointPlacements[jid] = pin.SE3(
                np.asarray(cls.freeflyer_ori, dtype=float), np.array(model.jointPlacements[jid].translation)
            )
        if ff:  # as RobotLoader.addFreeFlyerJointLimits
            lo, hi = model.lowerPositionLimit.copy(), model.upperPositionLimit.copy()
            lo[:7], hi[:7] = -1.0, 1.0
            model.lowerPositionLimit, model.upperPositionLimit = lo, hi
        return model
    if ff != bool(cls.free_flyer):
        raise InputError(f"example-robot-data robot {name!r} has a custom loader: free_flyer cannot be changed")
    cap = CapturedStderr()
    try:
        with cap:
            return erd.load(name).model
    except Exception as e:  # noqa: BLE001
        raise ModelError(f"cannot load example-robot-data robot {name!r}: {_loader_message(e, cap.text)}") from None


# -- kinbox mechanism files ------------------------------------------------------------------------
def _reject_constant(c: str):
    raise ModelError(f"non-finite number {c} in a mechanism file")


def read_mechanism_file(path: str | os.PathLike) -> dict:
    """The parsed JSON of a kinbox mechanism file (no NaN/Infinity allowed)."""
    path = Path(path)
    try:
        spec = read_json(path, ModelError, "mechanism file", parse_constant=_reject_constant)
    except ModelError as e:
        if str(path) in str(e):
            raise
        raise ModelError(f"{path.name!r}: {e}") from None
    if not isinstance(spec, dict):
        raise ModelError(f"{path.name!r}: a mechanism file holds a JSON object, not {type(spec).__name__}")
    return spec


def from_spec(spec: dict, name: str | None = None, base_dir: str | os.PathLike | None = None, where: str = "mechanism spec") -> Mechanism:
    """A Mechanism from a kinbox mechanism-file dict (see ``docs/mechanism-files.md``).

    Kinds: ``dh-loop``, ``dh-arm``, ``stewart``, ``four-bar``, ``3-rpr``, ``delta``, ``planar``,
    ``urdf``, ``mjcf``. ``"set": {joint: value}`` locks joints after building.
    """
    if not isinstance(spec, dict):
        raise ModelError(f"{where}: expected a JSON object, got {type(spec).__name__}")
    kinds = {**builders.KINDS, **FILE_KINDS}
    kind = spec.get("kind")
    if not isinstance(kind, str):
        raise ModelError(f'{where}: missing "kind" (one of {", ".join(kinds)})')
    key = normalize_name(kind)
    if key not in kinds:
        close = difflib.get_close_matches(key, list(kinds), n=3, cutoff=0.4)
        hint = f"; did you mean {', '.join(close)}?" if close else ""
        raise ModelError(f"{where}: unknown kind {kind!r}; kinds: {', '.join(kinds)}{hint}")
    params = {k: v for k, v in spec.items() if k not in _META_KEYS}
    mname = name or spec.get("name") or key
    try:
        mech = kinds[key](params, name=str(mname), base_dir=Path(base_dir) if base_dir else Path.cwd())
        sets = spec.get("set") or {}
        if not isinstance(sets, dict):
            raise InputError(f'"set" must map joint names to values, not {type(sets).__name__}')
        for joint, value in sets.items():
            mech.lock(joint, value)
    except (InputError, NameNotFound, ModelError) as e:
        raise ModelError(f"{where}: {e}") from None
    check_mechanism(mech, where)
    return mech


def _kind_file(kind: str):
    """Kinds ``urdf``/``mjcf`` of a mechanism file: a robot file, relative to the mechanism file."""

    def build(params, name, base_dir):
        p = builders.take(params, kind, ["file"], ["root_joint"])
        f = p["file"]
        if not isinstance(f, str):
            raise InputError(f'kind {kind!r}: "file" must be a path string')
        path = Path(f) if Path(f).is_absolute() else Path(base_dir) / f
        if not path.exists():
            raise InputError(f"kind {kind!r}: no such file {str(path)!r}")
        if path.suffix.lower() == ".json":  # a mechanism file naming itself would recurse forever
            raise InputError(f"kind {kind!r}: {f!r} is a kinbox mechanism file, not a robot file (URDF or MJCF)")
        return load(path, name=name, **({"root_joint": p["root_joint"]} if "root_joint" in p else {}))

    return build


FILE_KINDS = {"urdf": _kind_file("urdf"), "mjcf": _kind_file("mjcf"), "planar": kind_planar}


def _json_file(path: Path, name: str | None = None, overrides: dict | None = None) -> Mechanism:
    spec = read_mechanism_file(path)
    if overrides:
        spec = {**spec, **overrides}
    return from_spec(spec, name=name or spec.get("name") or path.stem, base_dir=path.parent, where=repr(path.name))


# -- the entry point ------------------------------------------------------------------------------
def _file(path: Path, kw: dict, name: str | None) -> Mechanism:
    suffix = path.suffix.lower()
    if suffix == ".json":
        return _json_file(path, name, kw)
    root_joint = kw.pop("root_joint", None)
    if kw:
        raise InputError(f"unknown keyword(s) for a robot file: {', '.join(kw)}")
    # read with the input budget (a device or FIFO is refused) and checked before Pinocchio
    # reads it: tests/cli/test_hostile.py::test_robot_file_limits
    fmt = _sniff_xml(path)
    if fmt == "mjcf":
        return _mjcf_file(path, root_joint, name)
    model = _urdf_file(path, root_joint)
    mech = Mechanism(model, name=name or model.name or path.stem)
    check_mechanism(mech, f"URDF file {path.name!r}")
    return mech


def load(source, **kw) -> Mechanism:
    """A :class:`Mechanism` from almost anything.

    ``source`` may be:

    * a :class:`Mechanism` (returned as is, after checking it) or a ``pinocchio.Model``;
    * a path (``str`` or ``Path``) to a URDF (``.urdf``, or ``.xml`` with a ``<robot>`` root),
      an MJCF file (``.xml`` with a ``<mujoco>`` root, or ``.mjcf``; ``<connect>`` and ``<weld>``
      equality constraints become ``point`` and ``weld`` closures), or a kinbox mechanism
      file (``.json``, see ``docs/mechanism-files.md``);
    * a URDF (or MJCF) XML string;
    * a built-in mechanism name (:func:`builtin_names`: ``general-6r``, ``bricard``,
      ``dietmeier``, ``griffis-duffy``, ``four-bar``, ``3-rpr``, ``delta``, ...);
    * an example-robot-data robot name (``ur5``, ``panda``, ``talos_arm``, ...).

    Keywords: ``name`` (the Mechanism's name); for URDF/MJCF sources ``root_joint``
    (``None``, ``"freeflyer"``, ``"planar"`` or a ``pin.JointModel``); for example-robot-data
    names ``free_flyer`` (override the loader's choice); for mechanism files and built-in
    names any parameter of the file (``leg_lengths=...``, ``set={...}``), which replaces the
    file's value.

    Raises :class:`ModelError` for a file that cannot be loaded (its name and the loader's
    message) or non-finite numbers, :class:`NameNotFound` for an unknown name (with close
    matches), :class:`InputError` for bad keywords. Meshes are never loaded.
    """
    kw = dict(kw)
    name = kw.pop("name", None)
    if name is not None and not isinstance(name, str):
        raise InputError(f"name must be a string, not {type(name).__name__}")

    if isinstance(source, Mechanism):
        if kw:
            raise InputError(f"unknown keyword(s) for a Mechanism: {', '.join(kw)}")
        check_mechanism(source)
        if name:
            source.name = name
        return source
    if isinstance(source, pin.Model):
        if kw:
            raise InputError(f"unknown keyword(s) for a pinocchio.Model: {', '.join(kw)}")
        mech = Mechanism(source, name=name or source.name or "model")
        check_mechanism(mech)
        return mech
    if isinstance(source, dict):
        return from_spec({**source, **kw}, name=name)
    if isinstance(source, os.PathLike):
        source = os.fspath(source)
    if isinstance(source, bytes):
        source = source.decode("utf-8", "replace")
    if not isinstance(source, str):
        raise InputError(
            f"load() takes a Mechanism, a pinocchio.Model, a file path, an XML string or a robot name, not {type(source).__name__}"
        )

    text = source.strip()
    if not text:
        raise InputError("load() got an empty string")
    if len(text) > MAX_INPUT_BYTES:
        raise InputError(f"load() got a string of {len(text)} characters, more than the limit of {MAX_INPUT_BYTES}")
    if text.startswith("<"):  # an XML string
        root_joint = kw.pop("root_joint", None)
        if kw:
            raise InputError(f"unknown keyword(s) for an XML string: {', '.join(kw)}")
        if robot_format(text.encode("utf-8", "surrogatepass"), "URDF string") == "mjcf":
            with tempfile.TemporaryDirectory() as d:
                p = Path(d) / "model.xml"
                p.write_text(text, encoding="utf-8")
                return _mjcf_file(p, root_joint, name or "mjcf")
        model = _urdf_string(text, root_joint)
        mech = Mechanism(model, name=name or model.name or "urdf")
        check_mechanism(mech, "URDF string")
        return mech

    path = Path(os.path.expanduser(text))
    if path.exists() and not path.is_dir():  # a device or FIFO is refused by the reader, naming it
        return _file(path, kw, name)
    looks_like_path = os.sep in text or "/" in text or path.suffix.lower() in _ROBOT_SUFFIXES

    builtins = builtin_files()
    key = normalize_name(text)
    for cand in (text, key):
        if cand in builtins:
            return _file(builtins[cand], kw, name or Path(cand).stem)

    robot = erd_name(text)
    if robot is not None:
        free_flyer = kw.pop("free_flyer", None)
        if kw:
            raise InputError(f"unknown keyword(s) for an example-robot-data robot: {', '.join(kw)}")
        model = _erd_model(robot, free_flyer)
        mech = Mechanism(model, name=name or robot)
        check_mechanism(mech, f"example-robot-data robot {robot!r}")
        return mech
    erd = _erd_names()

    if path.is_dir():
        raise ModelError(f"{text!r} is a directory, not a robot or mechanism file")
    if looks_like_path:
        raise ModelError(f"no such file: {text!r}")
    candidates = list(builtins) + erd
    close = difflib.get_close_matches(key, candidates, n=5, cutoff=0.5)
    close += [c for c in difflib.get_close_matches(text.lower(), candidates, n=5, cutoff=0.5) if c not in close]
    hint = (
        f"did you mean {', '.join(close[:5])}?"
        if close
        else (f"built-in mechanisms: {', '.join(sorted(builtins))}; example-robot-data robots include {', '.join(erd[:8])}, ...")
    )
    raise NameNotFound(f"unknown robot or mechanism {text!r}: not a file, a built-in mechanism or an example-robot-data robot; {hint}")
