"""The constant-orientation workspace of a parallel platform (Merlet's classic problem): the
positions its platform frame reaches, held at one orientation, with every leg's length within
its range.

A platform's legs are read off the mechanism's Pinocchio model, never off its name:

* **distance legs** (a Gough-Stewart platform): ``distance`` closures between a point ``A_i``
  fixed to the world and a point of the platform's body;
* **prismatic legs** (a planar 3-RPR): a prismatic joint on a revolute joint fixed to the world
  at ``A_i``, its slider carrying the platform point -- through a joint whose body holds the
  platform frame, or a ``point`` closure with that body -- on the line of the slide, so that the
  distance from ``A_i`` to the platform point is ``s_i + q_i`` (``q_i`` the prismatic joint's
  value, ``s_i`` a constant read from the placements). The revolute joints must turn freely
  (ranges of a full turn) and have parallel axes: the platform moves in their plane.

With the platform at position ``t`` and orientation ``R``, leg ``i``'s length is
``|t + R B_i - A_i|`` (``B_i`` the platform point in the platform frame). Over a box of
positions each squared length is enclosed in interval arithmetic with outward rounding (the
constant ``R B_i - A_i`` carried with a bound on its rounding): a box is **inside** when every
leg's enclosure lies within its squared range, **outside** when one leg's lies wholly beyond it,
else it is split, down to the resolution (**boundary**). The legs' lengths are all the
constraints: the joints of a Gough-Stewart leg are spherical and unlimited, as in the mechanism
model (tests/workspace/test_platform.py).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from ..errors import InputError
from ..interval import down, sqr, up
from ..model.loading import load
from ..model.mechanism import Mechanism
from .paving import BOUNDARY, INSIDE, MAX_BOXES, OUTSIDE, Paving, check_region, check_resolution, pave

#: the platform frame's name (the convention of the platform builders and of the answer's pose)
PLATFORM_FRAME = "platform"
EPS = float(np.finfo(float).eps)


@dataclass
class Legs:
    """The legs of a platform: base points ``A`` (n x 3, world), platform points ``B`` (n x 3,
    platform frame), the lengths' ranges ``lo``/``hi`` (n), the names, and whether the platform
    moves in the world's xy plane (``planar``)."""

    A: np.ndarray
    B: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    names: list[str]
    planar: bool
    given: np.ndarray  # the lengths the mechanism sets (NaN where none)


def _frame_of(mech: Mechanism, joint: int) -> pin.SE3:
    """The platform frame's placement in ``joint``'s frame: the frame named ``platform`` on that
    joint, or the joint's own frame."""
    model = mech.model
    for f in model.frames:
        if f.name == PLATFORM_FRAME and f.parentJoint == joint:
            return pin.SE3(f.placement)
    return pin.SE3.Identity()


def _axis(model: pin.Model, j: int, kind: str) -> np.ndarray | None:
    """The axis of joint ``j`` in its own frame if it is of ``kind`` ("R": revolute, "P":
    prismatic), else None."""
    name = model.joints[j].shortname()
    if name in (f"JointModel{kind}X", f"JointModel{kind}Y", f"JointModel{kind}Z"):
        return np.eye(3)["XYZ".index(name[-1])]
    if name == {"R": "JointModelRevoluteUnaligned", "P": "JointModelPrismaticUnaligned"}[kind]:
        return np.asarray(model.joints[j].extract().axis, dtype=float)
    return None


def _full_turn(model: pin.Model, j: int) -> bool:
    i = model.joints[j].idx_q
    return float(model.upperPositionLimit[i] - model.lowerPositionLimit[i]) >= 2.0 * math.pi - 1e-12


def _distance_legs(mech: Mechanism):
    """``(platform joint, [(name, A, point in the platform joint's frame, length)])`` from the
    ``distance`` closures between the world and one moving body, or None."""
    legs, joints = [], set()
    for c in mech.closures:
        if c.kind != "distance":
            continue
        if c.joint_a == 0 and c.joint_b != 0:
            legs.append((c.name, c.placement_a.translation.copy(), c.placement_b.translation.copy(), float(c.length)))
            joints.add(c.joint_b)
        elif c.joint_b == 0 and c.joint_a != 0:
            legs.append((c.name, c.placement_b.translation.copy(), c.placement_a.translation.copy(), float(c.length)))
            joints.add(c.joint_a)
    if not legs or len(joints) != 1:
        return None
    return joints.pop(), legs


def _prismatic_legs(mech: Mechanism):
    """``(platform joint, [(name, A, point in the platform joint's frame, s, qlo, qhi, q set)])``
    from revolute-prismatic legs (see the module docstring), or None."""
    model = mech.model
    legs, axes = [], []
    for j in range(1, model.njoints):
        pax = _axis(model, j, "P")
        r = int(model.parents[j])
        if pax is None or r == 0 or model.parents[r] != 0:
            continue
        rax = _axis(model, r, "R")
        if rax is None:
            continue
        # the slider's point that carries the platform: a child joint, or a point closure
        attach, pj, pt = None, None, None
        for k in range(1, model.njoints):
            if model.parents[k] == j and _axis(model, k, "R") is not None:
                attach, pj, pt = model.jointPlacements[k].translation.copy(), k, np.zeros(3)
                axes.append(model.jointPlacements[k].rotation @ _axis(model, k, "R"))
        for c in mech.closures:
            if c.kind == "point" and c.joint_a == j and c.joint_b != 0:
                attach, pj, pt = c.placement_a.translation.copy(), c.joint_b, c.placement_b.translation.copy()
            elif c.kind == "point" and c.joint_b == j and c.joint_a != 0:
                attach, pj, pt = c.placement_b.translation.copy(), c.joint_a, c.placement_a.translation.copy()
        if attach is None:
            continue
        M = model.jointPlacements[j]
        axis = M.rotation @ pax  # the slide's direction in the revolute joint's frame
        p0 = M.translation + M.rotation @ attach  # the platform point at q = 0, same frame
        s = float(axis @ p0)
        if np.linalg.norm(p0 - s * axis) > 1e-12 * (1.0 + np.linalg.norm(p0)) or abs(float(rax @ axis)) > 1e-12:
            raise InputError(f"leg {model.names[j]!r}: the platform point is off the line of the slide; no workspace for this leg")
        if not (_full_turn(model, r) and (pj is None or _full_turn(model, pj) or pj == j)):
            raise InputError(f"leg {model.names[j]!r}: its revolute joints have limits; only freely turning legs are paved")
        axes.append(model.jointPlacements[r].rotation @ rax)
        i = model.joints[j].idx_q
        qset = mech.locked.get(model.names[j])
        legs.append(
            (
                model.names[j],
                model.jointPlacements[r].translation.copy(),
                pt,
                s,
                float(model.lowerPositionLimit[i]),
                float(model.upperPositionLimit[i]),
                float(np.asarray(qset).reshape(-1)[0]) if qset is not None else math.nan,
                pj,
            )
        )
    if not legs:
        return None
    carriers = {leg[7] for leg in legs}
    return carriers, legs, axes


def legs_of(mech: Mechanism, lengths: Sequence[float] | None = None, scale: Sequence[float] | None = None) -> tuple[int, Legs]:
    """The platform joint and legs of ``mech`` with their length ranges: ``lengths`` (``lo hi``,
    the same for every leg), or ``scale`` (``a b``: from ``a`` to ``b`` times the length the
    mechanism sets), or else the prismatic joints' limits."""
    found = _distance_legs(mech)
    if found is not None:
        pj, raw = found
        F = _frame_of(mech, pj)
        names = [n or f"leg{i + 1}" for i, (n, *_r) in enumerate(raw)]
        A = np.array([a for _, a, _, _ in raw])
        B = np.array([F.actInv(pin.SE3(np.eye(3), b)).translation for _, _, b, _ in raw])
        given = np.array([ln for *_r, ln in raw])
        lo = hi = None
        planar = False
    else:
        found2 = _prismatic_legs(mech)
        if found2 is None:
            raise InputError(
                f"{mech.name!r} has no legs kinbox can pave: distance closures between the world and a platform, "
                "or revolute-prismatic legs carrying a platform point (docs/workspace.md)"
            )
        carriers, raw, axes = found2
        # the platform's joint: the carrier that holds the platform frame, else the only one
        frames = {f.parentJoint for f in mech.model.frames if f.name == PLATFORM_FRAME}
        pj = next(iter(carriers & frames)) if carriers & frames else (next(iter(carriers)) if len(carriers) == 1 else -1)
        if pj < 0:
            raise InputError(f"{mech.name!r}: its legs reach different bodies and none holds a frame named 'platform'")
        F = _frame_of(mech, pj)
        names = [n for n, *_r in raw]
        A = np.array([a for _, a, *_r in raw])
        B = np.array([F.actInv(pin.SE3(np.eye(3), leg[2])).translation for leg in raw])
        if any(leg[7] != pj for leg in raw):
            raise InputError(f"{mech.name!r}: its legs reach different bodies; no workspace for it")
        s = np.array([leg[3] for leg in raw])
        qlo = np.array([leg[4] for leg in raw])
        qhi = np.array([leg[5] for leg in raw])
        given = np.array([leg[6] for leg in raw]) + s
        n0 = axes[0] / np.linalg.norm(axes[0])
        if any(np.linalg.norm(np.cross(n0, a / np.linalg.norm(a))) > 1e-12 for a in axes) or abs(abs(float(n0[2])) - 1.0) > 1e-12:
            raise InputError(f"{mech.name!r}: its legs' revolute axes are not all along the world's z axis; no planar workspace")
        if np.any(s + qlo < 0.0):
            raise InputError(f"{mech.name!r}: a leg's slide passes through its base point; no workspace for it")
        lo, hi = s + qlo, s + qhi
        planar = True
    if lengths is not None:
        a, b = (float(v) for v in lengths)
        if not (math.isfinite(a) and math.isfinite(b) and 0.0 <= a < b):
            raise InputError(f"the legs' range takes two finite lengths 0 <= MIN < MAX, not {a:g} {b:g}")
        lo, hi = np.full(len(A), a), np.full(len(A), b)
    elif scale is not None:
        a, b = (float(v) for v in scale)
        if not (math.isfinite(a) and math.isfinite(b) and 0.0 <= a < b):
            raise InputError(f"the legs' scale takes two finite factors 0 <= A < B, not {a:g} {b:g}")
        if not np.all(np.isfinite(given)):
            raise InputError(f"{mech.name!r} does not set every leg's length: give the range itself (--legs MIN MAX)")
        lo, hi = a * given, b * given
    if lo is None or hi is None:
        raise InputError(f"{mech.name!r}: give the legs' range (--legs MIN MAX) or a scale of their lengths (--legs-scale A B)")
    return pj, Legs(A, B, np.asarray(lo, float), np.asarray(hi, float), names, planar, given)


class PlatformReach:
    """One platform, its legs' ranges and a fixed orientation, prepared to decide boxes of the
    platform frame's positions: a :class:`~kinbox.workspace.paving.Decider`. Its witnesses are
    the platform's pose at a box's centre, ``x y z qx qy qz qw`` (``x y phi`` in the plane)."""

    def __init__(self, legs: Legs, R: np.ndarray):
        self.legs = legs
        self.R = np.asarray(R, dtype=float)
        d = 2 if legs.planar else 3
        self.dims = d
        self.nq = 3 if legs.planar else 7
        C = legs.B @ self.R.T - legs.A  # R B_i - A_i
        # rounding of R (from a quaternion or an angle: a few ulps per entry) and of the product
        err = 16.0 * EPS * (np.abs(legs.B) @ np.abs(self.R).T + np.abs(legs.A) + np.abs(C)) + 1e-300
        self.c_lo, self.c_hi = down(C - err)[:, :d], up(C + err)[:, :d]
        # the ranges squared, enclosed: inside needs lo^2 <= L^2 <= hi^2 for the exact squares
        self.lo2_up, self.lo2_down = up(legs.lo * legs.lo), down(legs.lo * legs.lo)
        self.hi2_up, self.hi2_down = up(legs.hi * legs.hi), down(legs.hi * legs.hi)
        self.quat = pin.Quaternion(self.R).coeffs() if not legs.planar else None
        self.angle = math.atan2(float(self.R[1, 0]), float(self.R[0, 0])) if legs.planar else None

    def squared_lengths(self, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Enclosures of every leg's squared length over the box ``[lo, hi]`` (outward rounded)."""
        vlo = down(lo[None, :] + self.c_lo)
        vhi = up(hi[None, :] + self.c_hi)
        slo, shi = sqr(vlo, vhi)
        s_lo, s_hi = slo[:, 0], shi[:, 0]
        for k in range(1, self.dims):
            s_lo, s_hi = down(s_lo + slo[:, k]), up(s_hi + shi[:, k])
        return np.maximum(s_lo, 0.0), s_hi

    def decide(self, lo: np.ndarray, hi: np.ndarray, resolution: float) -> tuple[int, np.ndarray | None, dict]:
        s_lo, s_hi = self.squared_lengths(np.asarray(lo, float), np.asarray(hi, float))
        stats = {"legs_checked": len(s_lo)}
        if np.any(s_hi < self.lo2_down) or np.any(s_lo > self.hi2_up):
            return OUTSIDE, None, stats
        if np.all(s_lo >= self.lo2_up) and np.all(s_hi <= self.hi2_down):
            c = 0.5 * (np.asarray(lo, float) + np.asarray(hi, float))
            w = np.array([c[0], c[1], self.angle]) if self.legs.planar else np.concatenate([c, self.quat])
            return INSIDE, w, stats
        if float(np.max(np.asarray(hi) - np.asarray(lo))) <= resolution:
            return BOUNDARY, None, stats
        return -1, None, stats


def default_platform_region(legs: Legs) -> np.ndarray:
    """A box about the base points holding every position the platform frame can take: each
    leg keeps its platform point within ``hi_i`` of ``A_i``, so the frame lies within
    ``hi_i + |B_i|`` of ``A_i`` for every leg: the intersection of those boxes, rounded out to a
    centimetre."""
    d = 2 if legs.planar else 3
    r = legs.hi + np.linalg.norm(legs.B, axis=1)
    lo = np.max(legs.A[:, :d] - r[:, None], axis=0)
    hi = np.min(legs.A[:, :d] + r[:, None], axis=0)
    lo, hi = np.floor(lo * 100.0 - 1.0) / 100.0, np.ceil(hi * 100.0 + 1.0) / 100.0
    if np.any(hi <= lo):
        raise InputError("the legs' ranges leave no position for the platform")
    return np.array([lo, hi])


def _rotation(orientation, planar: bool) -> np.ndarray:
    """The platform's rotation: from ``qx qy qz qw``, or for a planar platform from one angle about
    z (a quaternion then must turn about z alone)."""
    from .arm import _unit_quaternion

    a = np.asarray(orientation, dtype=float).reshape(-1)
    if planar and a.shape == (1,):
        if not math.isfinite(float(a[0])):
            raise InputError("a planar platform's angle must be a finite number of radians")
        c, s = math.cos(float(a[0])), math.sin(float(a[0]))
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    q = _unit_quaternion(a.tolist())
    R = pin.Quaternion(q[3], *q[:3]).toRotationMatrix()
    if planar and (abs(q[0]) > 1e-12 or abs(q[1]) > 1e-12):
        raise InputError("a planar platform turns about z only: give its angle (--angle PHI) or a quaternion 0 0 qz qw")
    return np.asarray(R)


def reach_platform(
    mechanism,
    orientation: Sequence[float] | float = (0.0, 0.0, 0.0, 1.0),
    *,
    legs: Sequence[float] | None = None,
    legs_scale: Sequence[float] | None = None,
    region: Sequence[float] | None = None,
    resolution: float = 0.05,
    workers: int | None = None,
    executor=None,
    max_boxes: int = MAX_BOXES,
    progress: Callable[[dict], None] | None = None,
    resume: Paving | None = None,
) -> Paving:
    """The constant-orientation workspace of a parallel platform (a built-in name, a mechanism
    file or a :class:`~kinbox.model.mechanism.Mechanism`) as a :class:`Paving` of its platform
    frame's positions: ``orientation`` is ``qx qy qz qw`` (an angle about z for a planar
    platform), the legs' lengths range over ``legs`` (``MIN MAX``) or ``legs_scale`` (``A B``
    times the lengths the mechanism sets), else over the prismatic joints' limits. ``region``
    (``xmin ymin zmin xmax ymax zmax``, or ``xmin ymin xmax ymax`` in the plane) defaults to a box
    that bounds the reach. ``resume``: a paving of the same problem stopped by its budget,
    continued."""
    resolution = check_resolution(resolution)
    mech = mechanism if isinstance(mechanism, Mechanism) else load(mechanism)
    _, lg = legs_of(mech, legs, legs_scale)
    orient = [orientation] if isinstance(orientation, (int, float)) else orientation
    R = _rotation(orient, lg.planar)
    dec = PlatformReach(lg, R)
    reg = default_platform_region(lg) if region is None else check_region(region, dec.dims)
    meta: dict[str, Any] = {
        "robot": mechanism if isinstance(mechanism, str) else mech.name,
        "frame": PLATFORM_FRAME,
        "legs": {"names": lg.names, "lo": lg.lo.tolist(), "hi": lg.hi.tolist()},
    }
    if lg.planar:
        meta["angle"] = dec.angle
    else:
        meta["orientation"] = [float(v) for v in np.asarray(dec.quat)]
    return pave(dec, reg, resolution, meta, workers=workers, executor=executor, max_boxes=max_boxes, progress=progress, resume=resume)


__all__ = ["Legs", "PlatformReach", "legs_of", "reach_platform", "default_platform_region"]
