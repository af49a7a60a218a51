"""Mechanisms built in code: Pinocchio models plus closures.

Every builder returns a :class:`~kinbox.mechanism.Mechanism` whose ``model`` is a plain
``pinocchio.Model`` (joints, joint frames, a few named operational frames) and whose
``closures`` close the loops. Inputs are checked: a non-finite number, a wrong shape or a
non-positive length raises :class:`~kinbox.errors.InputError` naming the problem.

Names (other modules and the mechanism files rely on them):

============  =================================================================================
builder       joints (in model order) / frames / closures
============  =================================================================================
dh_chain      joints ``joint1..jointN`` (RZ); frames ``joint1..jointN`` and ``tool`` (on jointN);
              closed: weld closure ``loop`` tool <-> world
stewart       joint ``platform`` (FreeFlyer); frames ``platform``, ``base_anchor{i}`` (world),
              ``platform_anchor{i}``; distance closures ``leg1..legN`` (world p_i, platform q_i)
four_bar      joints ``crank``, ``coupler``, ``rocker`` (RZ); frames the joints plus
              ``coupler_point`` (on coupler) and ``rocker_tip``; point closure ``ground_pivot``
three_rpr     joints ``base1, leg1, pivot1, base2, leg2, base3, leg3`` (RZ, PX, RZ, ...);
              frame ``platform`` (the platform frame, on ``pivot1``), ``platform_anchor{i}``;
              point closures ``anchor2``, ``anchor3``; leg lengths = locked ``leg{i}``
delta         joints ``arm1, arm2, arm3`` (revolute, actuated), ``platform`` (Translation);
              frames ``elbow{i}``, ``platform``, ``platform_anchor{i}``, ``tool``;
              distance closures ``leg1..leg3`` (the forearm parallelograms)
============  =================================================================================

Revolute joints get the limits ``[-pi, pi]`` unless told otherwise (kinbox treats a range of
``2 pi`` as unlimited); prismatic and translation joints always get finite limits.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence

import numpy as np
import pinocchio as pin

from ..errors import MAX_CLOSURES, MAX_LENGTH, MAX_MODEL_DOF, InputError
from .mechanism import Closure, Mechanism

PI = math.pi


# ----------------------------------------------------------------------------------------------
# input checks
# ----------------------------------------------------------------------------------------------
def _number(x, what: str, positive: bool = False, nonneg: bool = False) -> float:
    if isinstance(x, bool):
        raise InputError(f"{what} must be a number, not a bool")
    if isinstance(x, (str, bytes)):  # float("3") would take it: tests/cli/test_hostile.py::test_mechanism_file_faults
        raise InputError(f"{what} must be a number, got the string {x!r:.40}")
    try:
        v = float(x)
    except (TypeError, ValueError):
        raise InputError(f"{what} must be a number, got {x!r}") from None
    if not math.isfinite(v):
        raise InputError(f"{what} is not finite: {v}")
    if abs(v) > MAX_LENGTH:  # lengths and angles: tests/cli/test_hostile.py::test_huge_model_numbers
        raise InputError(f"{what} = {v:g} is beyond the limit of {MAX_LENGTH:g}")
    if positive and v <= 0:
        raise InputError(f"{what} must be positive, got {v}")
    if nonneg and v < 0:
        raise InputError(f"{what} must be non-negative, got {v}")
    return v


def _array(x, what: str, shape: tuple) -> np.ndarray:
    """``x`` as a float array of ``shape`` (``-1`` matches any length), finite."""
    try:
        if np.asarray(x).dtype.kind not in "iuf":  # strings or objects, which float() would take
            raise TypeError
        a = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{what} must be numbers, got {x!r:.80}") from None
    ok = a.ndim == len(shape) and all(s == -1 or s == n for s, n in zip(shape, a.shape))
    if not ok:
        want = " x ".join("n" if s == -1 else str(s) for s in shape)
        raise InputError(f"{what} must have shape {want}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise InputError(f"{what} holds non-finite numbers")
    if a.size and float(np.max(np.abs(a))) > MAX_LENGTH:
        raise InputError(f"{what} holds {float(np.max(np.abs(a))):g}, beyond the limit of {MAX_LENGTH:g}")
    return a


def _points(x, what: str, n: int | None = None, dims: tuple = (3,)) -> np.ndarray:
    """An ``n x d`` array of points, ``d`` in ``dims``; 2-D points get ``z = 0``."""
    try:
        a = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{what} must be a list of points, got {x!r}") from None
    if a.ndim != 2 or a.shape[1] not in dims or (n is not None and a.shape[0] != n):
        want = f"{n if n is not None else 'n'} x {'/'.join(map(str, dims))}"
        raise InputError(f"{what} must be {want} coordinates, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise InputError(f"{what} holds non-finite numbers")
    if a.size and float(np.max(np.abs(a))) > MAX_LENGTH:
        raise InputError(f"{what} holds {float(np.max(np.abs(a))):g}, beyond the limit of {MAX_LENGTH:g}")
    if a.shape[1] == 2:
        a = np.hstack([a, np.zeros((a.shape[0], 1))])
    return a


def _limits(x, what: str, default: tuple[float, float]) -> tuple[float, float]:
    if x is None:
        return default
    try:
        lo, hi = x
    except (TypeError, ValueError):
        raise InputError(f"{what} must be a pair (lower, upper), got {x!r}") from None
    lo, hi = _number(lo, f"{what} lower"), _number(hi, f"{what} upper")
    if lo > hi:
        raise InputError(f"{what}: lower {lo} > upper {hi}")
    return lo, hi


def _name(name, what: str = "name") -> str:
    if not isinstance(name, str) or not name:
        raise InputError(f"{what} must be a non-empty string, got {name!r}")
    return name


# ----------------------------------------------------------------------------------------------
# model helpers
# ----------------------------------------------------------------------------------------------
def _T(p) -> pin.SE3:
    return pin.SE3(np.eye(3), np.asarray(p, dtype=float).reshape(3))


def _Rx(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _Rz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _add_joint(model: pin.Model, parent: int, joint, placement: pin.SE3, name: str, lower, upper) -> int:
    """Add a joint with position limits and its JOINT frame; return the joint id."""
    nv = joint.nv
    big = np.full(nv, 1e3)
    lo = np.atleast_1d(np.asarray(lower, dtype=float))
    hi = np.atleast_1d(np.asarray(upper, dtype=float))
    jid = model.addJoint(parent, joint, placement, name, big, big, lo, hi)
    model.addJointFrame(jid)
    return jid


def _add_frame(model: pin.Model, name: str, joint: int, placement: pin.SE3) -> int:
    parent_frame = model.getFrameId(model.names[joint]) if joint > 0 else 0
    return model.addFrame(pin.Frame(name, joint, parent_frame, placement, pin.FrameType.OP_FRAME))


# ----------------------------------------------------------------------------------------------
# DH chains (general 6R loop, Bricard, serial arms)
# ----------------------------------------------------------------------------------------------
_DH_KEYS = {"a", "d", "alpha", "theta", "lower", "upper", "name", "i"}


def _dh_row(row, k: int) -> dict:
    if isinstance(row, Mapping):
        extra = set(row) - _DH_KEYS
        if extra:
            raise InputError(f"DH row {k}: unknown key(s) {sorted(extra)}; keys: a, d, alpha, theta, lower, upper, name")
        missing = {"a", "d", "alpha"} - set(row)
        if missing:
            raise InputError(f"DH row {k}: missing {sorted(missing)}")
        r = dict(row)
    else:
        try:
            vals = list(row)
        except TypeError:
            raise InputError(f"DH row {k} must be a dict {{a, d, alpha}} or a sequence (a, d, alpha[, theta])") from None
        if len(vals) not in (3, 4):
            raise InputError(f"DH row {k} must have 3 or 4 numbers (a, d, alpha[, theta]), got {len(vals)}")
        r = dict(zip(("a", "d", "alpha", "theta"), vals))
    out = {
        "a": _number(r["a"], f"DH row {k} a"),
        "d": _number(r["d"], f"DH row {k} d"),
        "alpha": _number(r["alpha"], f"DH row {k} alpha"),
        "theta": _number(r.get("theta", 0.0), f"DH row {k} theta"),
        "name": _name(r.get("name", f"joint{k}"), f"DH row {k} name"),
    }
    out["lower"], out["upper"] = _limits((r.get("lower", -PI), r.get("upper", PI)), f"DH row {k} limits", (-PI, PI))
    return out


def dh_chain(rows: Sequence, closed: bool = False, name: str = "dh-chain") -> Mechanism:
    """A chain of revolute joints from a table of ``{a, d, alpha}`` rows (``theta`` optional).

    Convention (that of the reference tables, Porta, Ros and Thomas 2009, Sec. V-A): link frame ``F_i`` is
    ``F_{i-1} Rx(alpha_i) Tx(a_i) Rz(theta_i + theta0_i) Tz(d_i)`` with ``F_0`` the world;
    ``theta_i`` is joint ``i``'s value and ``theta0_i`` the row's optional ``theta`` offset.
    A closed chain closes when ``F_n = I``.

    The model: joint ``joint{i}`` (RZ, or the row's ``name``) has placement
    ``Tz(d_{i-1}) Rx(alpha_i) Tx(a_i) Rz(theta0_i)`` in its parent (``d_0 = 0``), so its frame is
    ``F_i Tz(-d_i)``; frame ``tool`` sits on the last joint at ``Tz(d_n)``, i.e. ``tool = F_n``.
    Limits: the row's ``lower``/``upper``, default ``[-pi, pi]``.

    ``closed=True`` adds the weld closure ``loop`` between ``tool`` and the world (the 6R loop
    problem); ``closed=False`` is a serial arm (add an IK goal with ``Mechanism.add_goal``).
    """
    name = _name(name)
    if isinstance(rows, (str, bytes)) or not hasattr(rows, "__len__"):
        raise InputError("dh_chain rows must be a list of {a, d, alpha} rows")
    if len(rows) == 0:
        raise InputError("dh_chain needs at least one row")
    if len(rows) > MAX_MODEL_DOF:
        raise InputError(f"dh_chain: {len(rows)} rows, more than the limit of {MAX_MODEL_DOF} joints")
    table = [_dh_row(r, k) for k, r in enumerate(rows, start=1)]
    names = [r["name"] for r in table]
    if len(set(names)) != len(names) or "tool" in names:
        raise InputError(f"dh_chain joint names must be unique and not 'tool': {names}")
    model = pin.Model()
    model.name = name
    parent, d_prev = 0, 0.0
    for r in table:
        R = _Rx(r["alpha"]) @ _Rz(r["theta"])
        p = np.array([0.0, 0.0, d_prev]) + _Rx(r["alpha"]) @ np.array([r["a"], 0.0, 0.0])
        parent = _add_joint(model, parent, pin.JointModelRZ(), pin.SE3(R, p), r["name"], r["lower"], r["upper"])
        d_prev = r["d"]
    _add_frame(model, "tool", parent, _T([0.0, 0.0, d_prev]))
    mech = Mechanism(model, name=name)
    if closed:
        mech.closures.append(Closure("weld", parent, _T([0.0, 0.0, d_prev]), 0, pin.SE3.Identity(), name="loop"))
    return mech


def dh_matrix(a: float, d: float, alpha: float, theta: float) -> np.ndarray:
    """``Rx(alpha) Tx(a) Rz(theta) Tz(d)`` as a 4x4 matrix (one link of :func:`dh_chain`)."""
    M = np.eye(4)
    M[:3, :3] = _Rx(alpha) @ _Rz(theta)
    M[:3, 3] = _Rx(alpha) @ np.array([a, 0.0, 0.0]) + M[:3, :3] @ np.array([0.0, 0.0, d])
    return M


# ----------------------------------------------------------------------------------------------
# Gough-Stewart platforms
# ----------------------------------------------------------------------------------------------
def stewart(base_points, platform_points, leg_lengths=None, name: str = "stewart") -> Mechanism:
    """A Gough-Stewart platform: base points ``p_i`` (world), platform points ``q_i``.

    Model: one FreeFlyer joint ``platform`` (``q = [t, quaternion xyzw]``, pose of the platform
    frame in the world); frames ``base_anchor{i}`` (on the world) and ``platform_anchor{i}``.
    Closures: ``leg{i}``, ``distance`` between ``world * T(p_i)`` and ``platform * T(q_i)``,
    ``length = l_i``: ``|t + R q_i - p_i| = l_i``.

    ``leg_lengths=None`` leaves every length NaN: set them later with :func:`set_leg_lengths`
    (or ``closure.length``). Any number ``n >= 1`` of legs is accepted (6 for a Stewart
    platform). Translation limits are ``min_i(|p_i| + |q_i| + l_i)`` once lengths are known.
    """
    name = _name(name)
    P = _points(base_points, "base_points")
    n = P.shape[0]
    if n < 1:
        raise InputError("stewart needs at least one leg")
    if n > MAX_CLOSURES:
        raise InputError(f"stewart: {n} legs, more than the limit of {MAX_CLOSURES}")
    Q = _points(platform_points, "platform_points", n=n)
    model = pin.Model()
    model.name = name
    lo = np.full(7, -np.inf)
    hi = np.full(7, np.inf)
    lo[3:], hi[3:] = -1.0, 1.0
    jid = _add_joint(model, 0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "platform", lo, hi)
    mech = Mechanism(model, name=name)
    for i in range(n):
        _add_frame(model, f"base_anchor{i + 1}", 0, _T(P[i]))
        _add_frame(model, f"platform_anchor{i + 1}", jid, _T(Q[i]))
        mech.closures.append(Closure("distance", 0, _T(P[i]), jid, _T(Q[i]), length=math.nan, name=f"leg{i + 1}"))
    if leg_lengths is not None:
        set_leg_lengths(mech, leg_lengths)
    return mech


def set_leg_lengths(mech: Mechanism, lengths) -> Mechanism:
    """Set the lengths of the ``distance`` closures of ``mech`` (in order) and, for a
    :func:`stewart` platform, bound its translation by ``min_i(|p_i| + |q_i| + l_i)``."""
    legs = [c for c in mech.closures if c.kind == "distance"]
    L = _array(lengths, "leg_lengths", (len(legs),))
    if np.any(L <= 0):
        raise InputError(f"leg_lengths must be positive, got {L.tolist()}")
    for c, l in zip(legs, L):
        c.length = float(l)
    model = mech.model
    if model.existJointName("platform"):
        j = model.joints[model.getJointId("platform")]
        if j.shortname() == "JointModelFreeFlyer" and legs:
            bound = min(np.linalg.norm(c.placement_a.translation) + np.linalg.norm(c.placement_b.translation) + c.length for c in legs)
            lo, hi = model.lowerPositionLimit.copy(), model.upperPositionLimit.copy()
            lo[j.idx_q : j.idx_q + 3], hi[j.idx_q : j.idx_q + 3] = -bound, bound
            model.lowerPositionLimit, model.upperPositionLimit = lo, hi
    return mech


# ----------------------------------------------------------------------------------------------
# planar four-bar
# ----------------------------------------------------------------------------------------------
def four_bar(ground: float, crank: float, coupler: float, rocker: float, coupler_point=None, name: str = "four-bar") -> Mechanism:
    """A planar four-bar linkage in the ``z = 0`` plane, as three RZ joints and one pin.

    Joint ``crank`` at the world origin; joint ``coupler`` at ``(crank, 0, 0)`` in the crank
    frame; joint ``rocker`` at ``(coupler, 0, 0)`` in the coupler frame (joint values are
    relative angles, all links along their frame's x). The rocker's far end ``(rocker, 0, 0)``
    (frame ``rocker_tip``) is pinned to the ground pivot ``(ground, 0, 0)`` by the ``point``
    closure ``ground_pivot`` (its z row is identically 0). Frame ``coupler_point`` is the point
    ``coupler_point = (x, y)`` of the coupler frame (default: the coupler's midpoint), whose
    path is the coupler curve. Limits ``[-pi, pi]``.
    """
    name = _name(name)
    g = _number(ground, "ground", positive=True)
    a = _number(crank, "crank", positive=True)
    b = _number(coupler, "coupler", positive=True)
    c = _number(rocker, "rocker", positive=True)
    cp = np.array([b / 2, 0.0]) if coupler_point is None else _array(coupler_point, "coupler_point", (2,))
    model = pin.Model()
    model.name = name
    j1 = _add_joint(model, 0, pin.JointModelRZ(), pin.SE3.Identity(), "crank", -PI, PI)
    j2 = _add_joint(model, j1, pin.JointModelRZ(), _T([a, 0, 0]), "coupler", -PI, PI)
    j3 = _add_joint(model, j2, pin.JointModelRZ(), _T([b, 0, 0]), "rocker", -PI, PI)
    _add_frame(model, "coupler_point", j2, _T([cp[0], cp[1], 0.0]))
    _add_frame(model, "rocker_tip", j3, _T([c, 0, 0]))
    _add_frame(model, "ground_pivot", 0, _T([g, 0, 0]))
    mech = Mechanism(model, name=name)
    mech.closures.append(Closure("point", j3, _T([c, 0, 0]), 0, _T([g, 0, 0]), name="ground_pivot"))
    return mech


# ----------------------------------------------------------------------------------------------
# planar 3-RPR
# ----------------------------------------------------------------------------------------------
def _diameter(P: np.ndarray) -> float:
    return float(max(np.linalg.norm(p - q) for p in P for q in P))


def three_rpr(base_points, platform_points, leg_lengths=None, leg_limits=None, name: str = "3-rpr") -> Mechanism:
    """A planar 3-RPR parallel robot in the ``z = 0`` plane.

    ``base_points`` ``A_i`` (world) and ``platform_points`` ``B_i`` (platform frame): 3 points,
    2-D or 3-D with ``z = 0``. Leg ``i`` is a revolute at ``A_i``, a prismatic joint of
    length ``rho_i`` and a revolute at the platform's ``B_i``.

    Tree: leg 1 is ``base1`` (RZ at ``A_1``) -> ``leg1`` (PX, ``q = rho_1``) -> ``pivot1``
    (RZ at the leg's end, carrying the platform); frame ``platform`` (on ``pivot1`` at
    ``T(-B_1)``) is the platform frame. Legs 2, 3: ``base{i}`` (RZ at ``A_i``) -> ``leg{i}``
    (PX), closed by the ``point`` closures ``anchor{i}`` between the end of ``leg{i}`` and
    the platform point ``B_i``. All axes are along z and all slides in the plane, so the
    platform stays in the plane (the z rows of the closures vanish identically).

    Prismatic limits: ``leg_limits`` (default ``[0, 2 (diam A + diam B) + max rho]``).
    ``leg_lengths`` (optional) locks ``leg1..leg3`` (forward kinematics: the assembly modes).
    """
    name = _name(name)
    A = _points(base_points, "base_points", n=3, dims=(2, 3))
    B = _points(platform_points, "platform_points", n=3, dims=(2, 3))
    if np.any(A[:, 2] != 0) or np.any(B[:, 2] != 0):
        raise InputError("three_rpr is planar: base and platform points must have z = 0")
    rho = None
    if leg_lengths is not None:
        rho = _array(leg_lengths, "leg_lengths", (3,))
        if np.any(rho < 0):
            raise InputError(f"leg_lengths must be non-negative, got {rho.tolist()}")
    hi_default = 2.0 * (_diameter(A) + _diameter(B)) + (float(rho.max()) if rho is not None else 0.0)
    lo, hi = _limits(leg_limits, "leg_limits", (0.0, max(hi_default, 1.0)))
    if rho is not None and (np.any(rho < lo) or np.any(rho > hi)):
        raise InputError(f"leg_lengths {rho.tolist()} outside leg_limits [{lo}, {hi}]")
    model = pin.Model()
    model.name = name
    b1 = _add_joint(model, 0, pin.JointModelRZ(), _T(A[0]), "base1", -PI, PI)
    l1 = _add_joint(model, b1, pin.JointModelPX(), pin.SE3.Identity(), "leg1", lo, hi)
    pv = _add_joint(model, l1, pin.JointModelRZ(), pin.SE3.Identity(), "pivot1", -PI, PI)
    _add_frame(model, "platform", pv, _T(-B[0]))
    for i in range(3):
        _add_frame(model, f"platform_anchor{i + 1}", pv, _T(B[i] - B[0]))
    mech = Mechanism(model, name=name)
    for i in (1, 2):
        bi = _add_joint(model, 0, pin.JointModelRZ(), _T(A[i]), f"base{i + 1}", -PI, PI)
        li = _add_joint(model, bi, pin.JointModelPX(), pin.SE3.Identity(), f"leg{i + 1}", lo, hi)
        mech.closures.append(Closure("point", li, pin.SE3.Identity(), pv, _T(B[i] - B[0]), name=f"anchor{i + 1}"))
    if rho is not None:
        for i in range(3):
            mech.lock(f"leg{i + 1}", float(rho[i]))
    return mech


# ----------------------------------------------------------------------------------------------
# Delta robot
# ----------------------------------------------------------------------------------------------
def delta(
    base_radius: float,
    platform_radius: float,
    arm_length: float,
    forearm_length: float,
    arm_angles=None,
    arm_limits=None,
    name: str = "delta",
) -> Mechanism:
    """A Delta robot (Clavel): three actuated arms and three parallelogram forearms.

    Arm ``i`` (``i = 1, 2, 3``, at azimuth ``phi_i = 2 pi (i-1) / 3``) is a revolute joint
    ``arm{i}`` at the shoulder ``R (cos phi_i, sin phi_i, 0)`` whose axis is tangent to the
    base circle (placement ``Rz(phi_i)``, joint RY: ``q = 0`` is horizontal pointing outward,
    ``q > 0`` points down); frame ``elbow{i}`` is the arm's tip ``(arm_length, 0, 0)``.
    Each forearm parallelogram keeps the platform's orientation fixed, so the platform is a
    ``Translation`` joint ``platform`` (``q = (x, y, z)`` of its centre); its anchor ``i`` is
    ``r (cos phi_i, sin phi_i, 0)`` (frames ``platform_anchor{i}``, and ``tool`` at the centre).
    The forearm of length ``forearm_length`` is the ``distance`` closure ``leg{i}``
    between elbow ``i`` and anchor ``i`` (the parallelogram's midline).

    3 dof. ``arm_angles`` (optional) locks ``arm1..arm3``: forward kinematics, generically two
    assembly modes (platform below or above the elbows). Limits: arms ``arm_limits``
    (default ``[-pi, pi]``); platform ``|x|, |y| <= R + r + arm + forearm``,
    ``|z| <= arm + forearm``.
    """
    name = _name(name)
    R = _number(base_radius, "base_radius", nonneg=True)
    r = _number(platform_radius, "platform_radius", nonneg=True)
    La = _number(arm_length, "arm_length", positive=True)
    Lb = _number(forearm_length, "forearm_length", positive=True)
    lo, hi = _limits(arm_limits, "arm_limits", (-PI, PI))
    angles = None if arm_angles is None else _array(arm_angles, "arm_angles", (3,))
    model = pin.Model()
    model.name = name
    mech = Mechanism(model, name=name)
    arms = []
    for i in range(3):
        phi = 2 * PI * i / 3
        placement = pin.SE3(_Rz(phi), np.array([R * math.cos(phi), R * math.sin(phi), 0.0]))
        j = _add_joint(model, 0, pin.JointModelRY(), placement, f"arm{i + 1}", lo, hi)
        _add_frame(model, f"elbow{i + 1}", j, _T([La, 0, 0]))
        arms.append(j)
    bxy, bz = R + r + La + Lb, La + Lb
    jp = _add_joint(model, 0, pin.JointModelTranslation(), pin.SE3.Identity(), "platform", [-bxy, -bxy, -bz], [bxy, bxy, bz])
    _add_frame(model, "tool", jp, pin.SE3.Identity())
    for i in range(3):
        phi = 2 * PI * i / 3
        anchor = np.array([r * math.cos(phi), r * math.sin(phi), 0.0])
        _add_frame(model, f"platform_anchor{i + 1}", jp, _T(anchor))
        mech.closures.append(Closure("distance", arms[i], _T([La, 0, 0]), jp, _T(anchor), length=Lb, name=f"leg{i + 1}"))
    if angles is not None:
        for i in range(3):
            mech.lock(f"arm{i + 1}", float(angles[i]))
    return mech


# ----------------------------------------------------------------------------------------------
# kinbox mechanism files: kind -> builder (used by kinbox.mechanism.load)
# ----------------------------------------------------------------------------------------------
def take(params: dict, kind: str, required: Sequence[str], optional: Sequence[str] = ()) -> dict:
    missing = [k for k in required if k not in params]
    if missing:
        raise InputError(f"kind {kind!r} needs {', '.join(missing)}")
    extra = [k for k in params if k not in required and k not in optional]
    if extra:
        raise InputError(
            f"kind {kind!r}: unknown parameter(s) {', '.join(extra)}; parameters: {', '.join(list(required) + list(optional))}"
        )
    return {k: params[k] for k in list(required) + list(optional) if k in params}


def _kind_dh(closed: bool):
    def build(params, name, base_dir):
        p = take(params, "dh-loop" if closed else "dh-arm", ["dh"])
        return dh_chain(p["dh"], closed=closed, name=name)

    return build


def _kind_stewart(params, name, base_dir):
    p = take(params, "stewart", ["base_points", "platform_points"], ["leg_lengths"])
    return stewart(p["base_points"], p["platform_points"], p.get("leg_lengths"), name=name)


def _kind_four_bar(params, name, base_dir):
    p = take(params, "four-bar", ["ground", "crank", "coupler", "rocker"], ["coupler_point"])
    return four_bar(p["ground"], p["crank"], p["coupler"], p["rocker"], p.get("coupler_point"), name=name)


def _kind_3rpr(params, name, base_dir):
    p = take(params, "3-rpr", ["base_points", "platform_points"], ["leg_lengths", "leg_limits"])
    return three_rpr(p["base_points"], p["platform_points"], p.get("leg_lengths"), p.get("leg_limits"), name=name)


def _kind_delta(params, name, base_dir):
    p = take(params, "delta", ["base_radius", "platform_radius", "arm_length", "forearm_length"], ["arm_angles", "arm_limits"])
    return delta(
        p["base_radius"], p["platform_radius"], p["arm_length"], p["forearm_length"], p.get("arm_angles"), p.get("arm_limits"), name=name
    )


#: kinds of kinbox mechanism files built here -> ``build(params, name, base_dir) -> Mechanism``
#: (the kinds ``urdf`` and ``mjcf``, which name a robot file, are loaded by :mod:`kinbox.model.loading`)
KINDS: dict[str, Callable[..., Mechanism]] = {
    "dh-loop": _kind_dh(True),
    "dh-arm": _kind_dh(False),
    "stewart": _kind_stewart,
    "four-bar": _kind_four_bar,
    "3-rpr": _kind_3rpr,
    "delta": _kind_delta,
}
