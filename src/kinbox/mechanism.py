"""Mechanisms: a Pinocchio kinematic tree plus loop closures and locked joints.

A :class:`Mechanism` is what every kinbox problem is made of:

* ``model``: a ``pinocchio.Model`` (the spanning tree; fixed joints are already folded into
  frames by Pinocchio);
* ``closures``: constraints that close loops or pin a frame to a goal, each between a point
  or frame attached to one joint and one attached to another (joint 0 is the world);
* ``locked``: joints held at given values (Pinocchio ``q`` entries of that joint).

:func:`load` makes a Mechanism from a ``pinocchio.Model``, a URDF / MJCF / kinbox mechanism
file (``docs/mechanism-files.md``), a URDF string, a built-in mechanism name
(:func:`builtin_names`) or an example-robot-data robot name. Loading files is Pinocchio's job;
this module only wraps its loaders (kinematic models only: meshes are never loaded).
"""

from __future__ import annotations

import contextlib
import difflib
import json
import math
import os
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np
import pinocchio as pin

from .errors import InputError, ModelError, NameNotFound, read_json

ClosureKind = Literal["weld", "point", "distance"]


@dataclass
class Closure:
    """A loop closure between ``joint_a * placement_a`` and ``joint_b * placement_b``.

    * ``weld``: the two frames coincide (position and orientation);
    * ``point``: the two frame origins coincide (a spherical pair);
    * ``distance``: the two origins are ``length`` apart (a spherical-spherical leg).

    Joint ids are Pinocchio joint indices; ``0`` is the world (universe).
    """

    kind: ClosureKind
    joint_a: int
    placement_a: pin.SE3
    joint_b: int
    placement_b: pin.SE3
    length: float = 0.0
    name: str = ""

    def residual(self, model: pin.Model, data: pin.Data) -> tuple[float, float]:
        """(position error in metres, orientation error in radians) after ``forwardKinematics``.

        Orientation error is 0 for ``point`` and ``distance`` closures.
        """
        Ma = data.oMi[self.joint_a] * self.placement_a
        Mb = data.oMi[self.joint_b] * self.placement_b
        if self.kind == "distance":
            d = float(np.linalg.norm(Ma.translation - Mb.translation))
            return abs(d - self.length), 0.0
        pos = float(np.linalg.norm(Ma.translation - Mb.translation))
        if self.kind == "point":
            return pos, 0.0
        rot = float(np.linalg.norm(pin.log3(Ma.rotation.T @ Mb.rotation)))
        return pos, rot


@dataclass
class Mechanism:
    """A Pinocchio model with loop closures and locked joints. See the module docstring."""

    model: pin.Model
    closures: list[Closure] = field(default_factory=list)
    locked: dict[str, np.ndarray] = field(default_factory=dict)
    name: str = "mechanism"

    # -- names -----------------------------------------------------------------
    def joint_id(self, name: str) -> int:
        if name in ("universe", "world", ""):
            return 0
        if not self.model.existJointName(name):
            known = ", ".join(self.model.names[1:])
            raise NameNotFound(f"unknown joint {name!r} in {self.name!r}; joints: {known}")
        return self.model.getJointId(name)

    def frame_id(self, name: str) -> int:
        if not self.model.existFrame(name):
            known = ", ".join(f.name for f in self.model.frames)
            raise NameNotFound(f"unknown frame {name!r} in {self.name!r}; frames: {known}")
        return self.model.getFrameId(name)

    def frame_anchor(self, name: str) -> tuple[int, pin.SE3]:
        """(parent joint id, placement in that joint's frame) of a frame or joint name."""
        if name in ("universe", "world", ""):
            return 0, pin.SE3.Identity()
        same = [f for f in self.model.frames if f.name == name]
        if same:
            # a URDF link and a fixed joint may share a name: the link (body frame) is meant
            rank = {pin.FrameType.BODY: 0, pin.FrameType.OP_FRAME: 1, pin.FrameType.FIXED_JOINT: 2,
                    pin.FrameType.JOINT: 3, pin.FrameType.SENSOR: 4}
            best = min(rank.get(f.type, 9) for f in same)
            pick = [f for f in same if rank.get(f.type, 9) == best]
            f = pick[0]
            if any(g.parentJoint != f.parentJoint or not g.placement.isApprox(f.placement) for g in pick[1:]):
                raise NameNotFound(f"frame name {name!r} is ambiguous in {self.name!r}: "
                                   f"{len(pick)} frames of type {f.type} at different places")
            return int(f.parentJoint), pin.SE3(f.placement)
        if self.model.existJointName(name):
            return self.model.getJointId(name), pin.SE3.Identity()
        return self.frame_id(name), pin.SE3.Identity()  # raises NameNotFound

    # -- modifiers -------------------------------------------------------------
    def lock(self, joint: str, value: float | np.ndarray) -> "Mechanism":
        """Hold ``joint`` at ``value`` (its Pinocchio ``q`` entries; a float for 1-dof joints)."""
        jid = self.joint_id(joint)
        j = self.model.joints[jid]
        v = np.atleast_1d(np.asarray(value, dtype=float)).ravel()
        if not np.all(np.isfinite(v)):
            raise InputError(f"lock value of joint {joint!r} is not finite: {v}")
        if v.size == 1 and j.nq == 2 and j.nv == 1:  # continuous joint given as an angle
            v = np.array([np.cos(v[0]), np.sin(v[0])])
        if v.size != j.nq:
            raise InputError(f"joint {joint!r} takes {j.nq} value(s), got {v.size}")
        self.locked[joint] = v
        return self

    def add_goal(self, frame: str, pose: pin.SE3, base: str | None = None, name: str = "goal") -> "Mechanism":
        """Pin ``frame`` to ``pose``, expressed in ``base`` (default: the world)."""
        ja, pa = self.frame_anchor(frame)
        jb, pb = self.frame_anchor(base or "universe")
        self.closures.append(Closure("weld", ja, pa, jb, pb * pose, name=name))
        return self

    def closure_residuals(self, q: np.ndarray) -> list[tuple[str, float, float]]:
        """(name, position error, orientation error) of every closure at ``q`` (Pinocchio FK)."""
        data = self.model.createData()
        pin.forwardKinematics(self.model, data, q)
        return [(c.name or c.kind, *c.residual(self.model, data)) for c in self.closures]


# ======================================================================================
# Loaders
# ======================================================================================
#
# Everything below turns a user's ``source`` into a :class:`Mechanism`. Parsing robot files
# is Pinocchio's job (``buildModelFromUrdf`` / ``buildModelFromXML`` for URDF,
# ``buildModelAndConstraintsFromMJCF`` for MJCF): kinbox never reads URDF itself and never
# builds geometry models, so meshes are never loaded. Kinbox mechanism files (``.json``,
# see ``docs/mechanism-files.md``) are turned into Mechanisms by :mod:`kinbox.builders`.

_PKG_DIR = Path(__file__).resolve().parent
#: where the built-in mechanism files live (repository ``robots/``; a ``robots`` folder next
#: to this module wins, for installed copies). ``KINBOX_ROBOTS`` overrides both.
_BUILTIN_DIRS = (_PKG_DIR / "robots", _PKG_DIR.parents[1] / "robots")

_ROBOT_SUFFIXES = (".json", ".urdf", ".xml", ".mjcf")
#: keys of a kinbox mechanism file that are documentation only
_META_KEYS = {"kind", "name", "description", "source", "note", "notes", "reference", "expected", "set"}


def builtin_dir() -> Path:
    """The folder holding the built-in mechanism files."""
    env = os.environ.get("KINBOX_ROBOTS")
    if env:
        return Path(env)
    for d in _BUILTIN_DIRS:
        if d.is_dir():
            return d
    return _BUILTIN_DIRS[-1]


def _builtin_files() -> dict[str, Path]:
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
    return sorted(_builtin_files())


def _erd_names() -> list[str]:
    try:
        import example_robot_data
    except ImportError:  # pragma: no cover - a declared dependency
        return []
    return sorted(example_robot_data.ROBOTS)


def _normalize_name(name: str) -> str:
    return name.strip().lower().replace("_", "-").replace(" ", "-")


# -- numbers -------------------------------------------------------------------------------
def _finite(a) -> bool:
    return bool(np.all(np.isfinite(np.asarray(a, dtype=float))))


def check_model(model: pin.Model, where: str = "model") -> None:
    """Raise :class:`ModelError` if ``model`` holds a non-finite number.

    Joint and frame placements and inertias must be finite. Position limits may be infinite
    (that means "unlimited") but not NaN.
    """
    for i in range(model.njoints):
        M = model.jointPlacements[i]
        if not (_finite(M.translation) and _finite(M.rotation)):
            raise ModelError(f"{where}: placement of joint {model.names[i]!r} is not finite")
        Y = model.inertias[i]
        if not (_finite([Y.mass]) and _finite(Y.lever) and _finite(Y.inertia)):
            raise ModelError(f"{where}: inertia of body of joint {model.names[i]!r} is not finite")
    for f in model.frames:
        if not (_finite(f.placement.translation) and _finite(f.placement.rotation)):
            raise ModelError(f"{where}: placement of frame {f.name!r} is not finite")
    lo = np.asarray(model.lowerPositionLimit, dtype=float)
    hi = np.asarray(model.upperPositionLimit, dtype=float)
    if np.any(np.isnan(lo)) or np.any(np.isnan(hi)):
        raise ModelError(f"{where}: a joint position limit is NaN")


def check_mechanism(mech: Mechanism, where: str | None = None) -> None:
    """:func:`check_model` plus the closures: known joints, finite placements and lengths.

    A ``distance`` closure whose length is NaN is accepted: it means "not set yet"
    (see :func:`kinbox.builders.stewart`).
    """
    where = where or mech.name
    if not isinstance(mech.model, pin.Model):
        raise ModelError(f"{where}: model is not a pinocchio.Model but {type(mech.model).__name__}")
    check_model(mech.model, where)
    for k, c in enumerate(mech.closures):
        label = c.name or f"closure {k}"
        if c.kind not in ("weld", "point", "distance"):
            raise ModelError(f"{where}: {label}: unknown closure kind {c.kind!r}")
        for j in (c.joint_a, c.joint_b):
            if not 0 <= int(j) < mech.model.njoints:
                raise ModelError(f"{where}: {label}: joint index {j} out of range 0..{mech.model.njoints - 1}")
        for M in (c.placement_a, c.placement_b):
            if not (_finite(M.translation) and _finite(M.rotation)):
                raise ModelError(f"{where}: {label}: placement is not finite")
        if c.kind == "distance" and not math.isnan(c.length) and not (math.isfinite(c.length) and c.length >= 0):
            raise ModelError(f"{where}: {label}: length {c.length} is not a finite non-negative number")


# -- Pinocchio calls -------------------------------------------------------------------------
class _CapturedStderr:
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
    cap = _CapturedStderr()
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
        table = {"freeflyer": pin.JointModelFreeFlyer, "free": pin.JointModelFreeFlyer,
                 "floating": pin.JointModelFreeFlyer, "planar": pin.JointModelPlanar,
                 "translation": pin.JointModelTranslation, "spherical": pin.JointModelSpherical}
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
    for kind, label, models in (("point", "connect", point_models), ("weld", "weld", frame_models)):
        for k, cm in enumerate(models, start=1):
            Ma, Mb = pin.SE3(cm.joint1_placement), pin.SE3(cm.joint2_placement)
            for M in (Ma, Mb):
                R = np.asarray(M.rotation)
                if not (_finite(R) and _finite(M.translation) and np.allclose(R.T @ R, np.eye(3), atol=1e-6)):
                    raise ModelError(
                        f"Pinocchio's MJCF parser returned an invalid placement for <{label}> number {k} "
                        "(site-based <connect>/<weld> are not supported by it: use body1/body2 with an anchor)")
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
                    f"Pinocchio's MJCF loader; attach it to bodies (body1/body2 with anchor)")


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
    """'mjcf' or 'urdf' from the root element of an XML file (only its first bytes are read)."""
    try:
        head = path.read_bytes()[:4096].decode("utf-8", "replace").lower()
    except OSError as e:
        raise ModelError(f"cannot read {path.name!r}: {e}") from None
    i, j = head.find("<mujoco"), head.find("<robot")
    if i >= 0 and (j < 0 or i < j):
        return "mjcf"
    if j >= 0:
        return "urdf"
    if path.suffix.lower() == ".urdf":
        return "urdf"
    raise ModelError(f"{path.name!r} is neither URDF (<robot>) nor MJCF (<mujoco>)")


# -- example-robot-data --------------------------------------------------------------------------
def _erd_model(name: str, free_flyer: bool | None = None) -> pin.Model:
    """The kinematic model of an example-robot-data robot, without loading its meshes.

    Robots whose loader is the plain ``RobotLoader`` recipe (URDF + optional free flyer +
    SRDF reference postures) are built here with ``pin.buildModelFromUrdf``; the few with a
    custom loader (e.g. ``talos_legs``, ``cassie``) go through ``example_robot_data.load``.
    """
    import example_robot_data as erd
    from example_robot_data.utils import RobotLoader, getModelPath

    cls = erd.ROBOTS[name]
    if name == "ur3" and getattr(cls, "urdf_filename", "") != "ur3_robot.urdf":
        # example-robot-data 5.0 maps "ur3" to UR5Loader; kinbox's "ur3" is the genuine UR3
        cls = getattr(erd.robots_loader, "UR3Loader", cls)
    ff = bool(cls.free_flyer) if free_flyer is None else bool(free_flyer)
    plain = cls.__init__ is RobotLoader.__init__ or name == "panda_collision"  # only edits collisions
    human = cls.__name__ == "HumanLoader"
    if (plain or human) and getattr(cls, "urdf_filename", "") and not getattr(cls, "sdf_filename", ""):
        try:
            sub = os.path.join(cls.path, cls.urdf_subpath, cls.urdf_filename)
            root = cls.model_path or getModelPath(sub)
        except OSError as e:
            raise ModelError(f"example-robot-data robot {name!r}: {e}") from None
        path = Path(root) / sub
        model = _urdf_file(path, "freeflyer" if ff else None)
        if cls.srdf_filename:
            srdf = Path(root) / cls.path / cls.srdf_subpath / cls.srdf_filename
            if srdf.is_file():
                with contextlib.suppress(Exception):
                    _call_loader(f"SRDF {srdf.name!r}", pin.loadReferenceConfigurations, model, str(srdf), False)
        if human and ff:
            jid = model.getJointId("root_joint")
            model.jointPlacements[jid] = pin.SE3(np.asarray(cls.freeflyer_ori, dtype=float),
                                                 np.array(model.jointPlacements[jid].translation))
        if ff:  # as RobotLoader.addFreeFlyerJointLimits
            lo, hi = model.lowerPositionLimit.copy(), model.upperPositionLimit.copy()
            lo[:7], hi[:7] = -1.0, 1.0
            model.lowerPositionLimit, model.upperPositionLimit = lo, hi
        return model
    if ff != bool(cls.free_flyer):
        raise InputError(f"example-robot-data robot {name!r} has a custom loader: free_flyer cannot be changed")
    cap = _CapturedStderr()
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


def from_spec(spec: dict, name: str | None = None, base_dir: str | os.PathLike | None = None,
              where: str = "mechanism spec") -> Mechanism:
    """A Mechanism from a kinbox mechanism-file dict (see ``docs/mechanism-files.md``).

    Kinds: ``dh-loop``, ``dh-arm``, ``stewart``, ``four-bar``, ``3-rpr``, ``delta``, ``urdf``,
    ``mjcf``. ``"set": {joint: value}`` locks joints after building.
    """
    from . import builders

    if not isinstance(spec, dict):
        raise ModelError(f"{where}: expected a JSON object, got {type(spec).__name__}")
    kind = spec.get("kind")
    if not isinstance(kind, str):
        raise ModelError(f"{where}: missing \"kind\" (one of {', '.join(builders.KINDS)})")
    key = _normalize_name(kind)
    if key not in builders.KINDS:
        close = difflib.get_close_matches(key, list(builders.KINDS), n=3, cutoff=0.4)
        hint = f"; did you mean {', '.join(close)}?" if close else ""
        raise ModelError(f"{where}: unknown kind {kind!r}; kinds: {', '.join(builders.KINDS)}{hint}")
    params = {k: v for k, v in spec.items() if k not in _META_KEYS}
    mname = name or spec.get("name") or key
    try:
        mech = builders.KINDS[key](params, name=str(mname), base_dir=Path(base_dir) if base_dir else Path.cwd())
        sets = spec.get("set") or {}
        if not isinstance(sets, dict):
            raise InputError(f"\"set\" must map joint names to values, not {type(sets).__name__}")
        for joint, value in sets.items():
            mech.lock(joint, value)
    except (InputError, NameNotFound, ModelError) as e:
        raise ModelError(f"{where}: {e}") from None
    check_mechanism(mech, where)
    return mech


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
    fmt = "mjcf" if suffix == ".mjcf" else _sniff_xml(path)
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
            "load() takes a Mechanism, a pinocchio.Model, a file path, an XML string or a robot name, "
            f"not {type(source).__name__}")

    text = source.strip()
    if not text:
        raise InputError("load() got an empty string")
    if text.startswith("<"):  # an XML string
        root_joint = kw.pop("root_joint", None)
        if kw:
            raise InputError(f"unknown keyword(s) for an XML string: {', '.join(kw)}")
        head = text[:4096].lower()
        if "<mujoco" in head and ("<robot" not in head or head.find("<mujoco") < head.find("<robot")):
            with tempfile.TemporaryDirectory() as d:
                p = Path(d) / "model.xml"
                p.write_text(text, encoding="utf-8")
                return _mjcf_file(p, root_joint, name or "mjcf")
        model = _urdf_string(text, root_joint)
        mech = Mechanism(model, name=name or model.name or "urdf")
        check_mechanism(mech, "URDF string")
        return mech

    path = Path(os.path.expanduser(text))
    if path.is_file():
        return _file(path, kw, name)
    looks_like_path = os.sep in text or "/" in text or path.suffix.lower() in _ROBOT_SUFFIXES

    builtins = _builtin_files()
    key = _normalize_name(text)
    for cand in (text, key):
        if cand in builtins:
            return _file(builtins[cand], kw, name or Path(cand).stem)

    erd = _erd_names()
    erd_key = {n.lower(): n for n in erd}
    for cand in (text.lower(), text.lower().replace("-", "_")):
        if cand in erd_key:
            free_flyer = kw.pop("free_flyer", None)
            if kw:
                raise InputError(f"unknown keyword(s) for an example-robot-data robot: {', '.join(kw)}")
            model = _erd_model(erd_key[cand], free_flyer)
            mech = Mechanism(model, name=name or erd_key[cand])
            check_mechanism(mech, f"example-robot-data robot {erd_key[cand]!r}")
            return mech

    if path.is_dir():
        raise ModelError(f"{text!r} is a directory, not a robot or mechanism file")
    if looks_like_path:
        raise ModelError(f"no such file: {text!r}")
    candidates = list(builtins) + erd
    close = difflib.get_close_matches(key, candidates, n=5, cutoff=0.5)
    close += [c for c in difflib.get_close_matches(text.lower(), candidates, n=5, cutoff=0.5) if c not in close]
    hint = f"did you mean {', '.join(close[:5])}?" if close else (
        f"built-in mechanisms: {', '.join(sorted(builtins))}; example-robot-data robots include "
        f"{', '.join(erd[:8])}, ...")
    raise NameNotFound(f"unknown robot or mechanism {text!r}: not a file, a built-in mechanism or an "
                       f"example-robot-data robot; {hint}")
