"""Enclosures of an arm's constants: the link matrices of the model as given.

The arm template (:mod:`kinbox.formulation.arm`) writes the chain in canonical frames ``F_i``
computed in binary64 from Pinocchio's joint lines: ``F_{i+1} = F_i L_i Rz(gamma_{i+1})
Tz(d_{i+1})``, the base's frame ``C_0 = F_1`` and the tool's ``E = F_6^-1 T``. Those numbers
are rounded (and entries below :data:`~kinbox.formulation.arm.SNAP` set to zero); the model's
joints are exact lines. This module computes, in interval arithmetic (``mpmath.iv``, 120 bits,
every operation rounded outward), exact frames ``F'_i`` on the model's lines (``z`` the joint's
exact axis, the origin the projection of ``F_i``'s on the line, ``x`` the projection of
``F_i``'s ``x``), and encloses ``L'_i = F'_i^-1 F'_{i+1} Tz(-d_{i+1}) Rz(-gamma_{i+1})``,
``C'_0 = F'_1`` and ``E' = F'_6^-1 T'`` with ``gamma`` and ``d`` the binary64 numbers of the
template. The model's forward kinematics is then exactly ``C'_0 Rz(theta_1) L'_1 Rz(theta_2)
Tz(d_2) ... E'`` (a rotation about joint ``i``'s line is ``F'_i Rz(q) F'_i^-1`` for any frame
``F'_i`` with ``z`` on it), so a template written with constants within the radii of
``L'_i`` (:mod:`kinbox.formulation.errfloat`) and parameters within those of ``C'_0`` and
``E'`` holds, within its error bounds, the equations of the model.

**The model as given** is Pinocchio's (kinbox reads no file itself): each placement's
translation as its binary64 numbers, its rotation the one of the unit quaternion of its
binary64 matrix (``pin.Quaternion``, divided by its norm: exactly orthogonal, within an ulp
of the matrix), each joint's axis its binary64 direction, normalized (exact for the axes
``x``, ``y``, ``z``), a locked joint at its lock values as given (:func:`_several` for a joint
of several axes). ``tests/formulation/test_enclosures.py`` and ``tests/answer/test_curves.py`` check the
certified boxes against 40-digit roots of that model.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
from mpmath import iv

from .pairs.algebra import mat_mul, mat_vec, transpose, vcross, vdot

_PREC = 120


def _quat_matrix(c) -> list:
    """The rotation of the unit quaternion ``c / |c|`` (``c`` = x, y, z, w), enclosed."""
    x, y, z, w = (iv.mpf(float(v)) for v in c)
    s = 2 / (x * x + y * y + z * z + w * w)
    return [
        [1 - s * (y * y + z * z), s * (x * y - z * w), s * (x * z + y * w)],
        [s * (x * y + z * w), 1 - s * (x * x + z * z), s * (y * z - x * w)],
        [s * (x * z - y * w), s * (y * z + x * w), 1 - s * (x * x + y * y)],
    ]


IMat = list  # 3x3 of iv.mpf
IVec = list  # 3 of iv.mpf


def _iv(x: float, r: float = 0.0):
    v = iv.mpf(float(x))
    return v + iv.mpf([-float(r), float(r)]) if r else v


def _vec(t: np.ndarray, r: float = 0.0) -> IVec:
    return [_iv(t[i], r) for i in range(3)]


class IFrame:
    """A rigid motion ``(R, t)`` enclosed in intervals (``R`` holds an orthogonal matrix)."""

    def __init__(self, R: IMat, t: IVec):
        self.R, self.t = R, t

    @staticmethod
    def identity() -> IFrame:
        one, zero = iv.mpf(1), iv.mpf(0)
        return IFrame([[one if i == j else zero for j in range(3)] for i in range(3)], [zero, zero, zero])

    @staticmethod
    def given(M: pin.SE3) -> IFrame:
        """A placement of the model as given (see the module docstring)."""
        t = np.asarray(M.translation, dtype=float)
        return IFrame(_quat_matrix(pin.Quaternion(np.asarray(M.rotation)).coeffs()), _vec(t))

    def __mul__(self, o: IFrame) -> IFrame:
        return IFrame(mat_mul(self.R, o.R), [a + b for a, b in zip(mat_vec(self.R, o.t), self.t)])

    def inverse(self) -> IFrame:
        Rt = transpose(self.R)
        return IFrame(Rt, [-a for a in mat_vec(Rt, self.t)])

    def radius(self, M: pin.SE3 | np.ndarray, t: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Per entry, an upper bound of the distance between this enclosure and binary64
        ``(R, t)`` (``M`` a ``pin.SE3`` or a rotation with ``t``)."""
        if isinstance(M, pin.SE3):
            R, t = np.asarray(M.rotation), np.asarray(M.translation)
        else:
            R = np.asarray(M)
        assert t is not None
        rR = np.array([[_dist(self.R[i][j], R[i, j]) for j in range(3)] for i in range(3)])
        rt = np.array([_dist(self.t[i], t[i]) for i in range(3)])
        return rR, rt


def _dist(x, v: float) -> float:
    """An upper bound (a float) of ``|y - v|`` for ``y`` in the interval ``x``."""
    d = abs(x - iv.mpf(float(v)))
    return _up(d.b)


def _up(x) -> float:
    """``x`` (an mpf) rounded up to a float."""
    f = float(x)
    return f if f >= x else float(np.nextafter(f, np.inf))


def _rot(axis: IVec, c, s) -> IMat:
    """Rodrigues: the rotation by (c, s) about a unit axis."""
    x, y, z = axis
    C = 1 - c
    return [
        [c + x * x * C, x * y * C - z * s, x * z * C + y * s],
        [y * x * C + z * s, c + y * y * C, y * z * C - x * s],
        [z * x * C - y * s, z * y * C + x * s, c + z * z * C],
    ]


_REVOLUTE: tuple[str, ...] = ("JointModelRX", "JointModelRY", "JointModelRZ", "JointModelRUBX", "JointModelRUBY", "JointModelRUBZ")
_REVOLUTE += ("JointModelRevoluteUnaligned", "JointModelRevoluteUnboundedUnaligned")
_PRISMATIC = ("JointModelPX", "JointModelPY", "JointModelPZ", "JointModelPrismaticUnaligned")


def _joint_axis(jm) -> IVec:
    """The joint's unit axis: its binary64 axis (:func:`_raw_axis`) normalized exactly."""
    v = _raw_axis(jm)
    n = iv.sqrt(vdot(v, v))
    return [x / n for x in v]


def _raw_axis(jm) -> IVec:
    """The joint's binary64 axis as given (not normalized), as exact intervals."""
    name = jm.shortname()
    last = name[-1]
    if last in "XYZ" and "Unaligned" not in name:
        a = np.zeros(3)
        a["XYZ".index(last)] = 1.0
    else:  # the model's binary64 axis, normalized here exactly (not first in binary64)
        ext = jm.extract()
        if hasattr(type(ext), "axis"):
            a = np.asarray(ext.axis, dtype=float)
        else:  # a binding without the axis (RevoluteUnboundedUnaligned): measured
            from .pairs.family import joint_axis  # noqa: PLC0415

            a = np.asarray(joint_axis(jm, name in _REVOLUTE), dtype=float)
    return [iv.mpf(float(x)) for x in a]


def _motion(model: pin.Model, jid: int, q: np.ndarray) -> IFrame:
    """The motion of joint ``jid`` at ``q`` (revolute, continuous or prismatic about one axis;
    a joint of several axes: :func:`_several`)."""
    jm = model.joints[jid]
    return _joint_motion(jm, q[jm.idx_q : jm.idx_q + jm.nq], model.names[jid])


def _joint_motion(jm, v: np.ndarray, label: str) -> IFrame:
    """The motion of joint model ``jm`` at its ``q`` entries ``v`` (``label``: its name in errors)."""
    name = jm.shortname()
    if name in _SEVERAL:
        return _several(jm, v, label)
    if name not in _REVOLUTE + _PRISMATIC:
        raise ValueError(f"joint {label} is not one revolute or prismatic axis")
    a = _joint_axis(jm)
    if name in _PRISMATIC:
        d = iv.mpf(float(v[0]))
        return IFrame(IFrame.identity().R, [x * d for x in a])
    if jm.nq == 2:  # continuous: (cos, sin), normalized
        c, s = iv.mpf(float(v[0])), iv.mpf(float(v[1]))
        n = iv.sqrt(c * c + s * s)
        c, s = c / n, s / n
    elif float(v[0]) == 0.0:
        return IFrame.identity()
    else:
        c, s = iv.cos(iv.mpf(float(v[0]))), iv.sin(iv.mpf(float(v[0])))
    return IFrame(_rot(a, c, s), [iv.mpf(0)] * 3)


_SEVERAL: tuple[str, ...] = ("JointModelSpherical", "JointModelSphericalZYX", "JointModelFreeFlyer", "JointModelTranslation")
_SEVERAL += ("JointModelPlanar", "JointModelUniversal", "JointModelComposite")


def _axis_rot(k: int, x) -> IMat:
    """The rotation by the angle ``x`` (binary64, exact) about coordinate axis ``k``."""
    c, s = iv.cos(iv.mpf(float(x))), iv.sin(iv.mpf(float(x)))
    return _rot([iv.mpf(1) if i == k else iv.mpf(0) for i in range(3)], c, s)


def _unit(a) -> IVec:
    v = [iv.mpf(float(x)) for x in a]
    n = iv.sqrt(vdot(v, v))
    return [x / n for x in v]


def _several(jm, v: np.ndarray, label: str) -> IFrame:
    """The motion of a joint of several axes at its ``q`` entries ``v`` (a locked joint's
    values, exact as given): a quaternion (spherical, free-flyer: ``x y z w``) stands for the
    rotation of its unit quaternion ``v / |v|``, like a placement's; a planar joint's
    ``(cos, sin)`` for its normalized pair, like a continuous joint's; a spherical ZYX joint's
    angles for ``Rz Ry Rx``, a universal joint's for the rotations about its two axes (each
    normalized exactly); translations are the values themselves; a composite joint is its
    parts' placements (as given) and motions in turn
    (``tests/formulation/test_enclose_locked.py`` checks each against Pinocchio's motion)."""
    name = jm.shortname()
    zero = [iv.mpf(0)] * 3
    if name == "JointModelComposite":
        ext, F, k = jm.extract(), IFrame.identity(), 0
        for sub, P in zip(ext.joints, ext.jointPlacements):
            F = F * IFrame.given(pin.SE3(P)) * _joint_motion(sub, v[k : k + sub.nq], label)
            k += sub.nq
        return F
    if name == "JointModelUniversal":
        ext = jm.extract()
        rots = [_rot(_unit(ax), iv.cos(iv.mpf(float(x))), iv.sin(iv.mpf(float(x)))) for ax, x in zip((ext.axis1, ext.axis2), v)]
        return IFrame(mat_mul(rots[0], rots[1]), zero)
    if name == "JointModelSpherical":
        return IFrame(_quat_matrix(v[:4]), zero)
    if name == "JointModelFreeFlyer":
        return IFrame(_quat_matrix(v[3:7]), _vec(v[:3]))
    if name == "JointModelTranslation":
        return IFrame(IFrame.identity().R, _vec(v[:3]))
    if name == "JointModelPlanar":
        c, s = iv.mpf(float(v[2])), iv.mpf(float(v[3]))
        n = iv.sqrt(c * c + s * s)
        R = _rot([iv.mpf(0), iv.mpf(0), iv.mpf(1)], c / n, s / n)
        return IFrame(R, [iv.mpf(float(v[0])), iv.mpf(float(v[1])), iv.mpf(0)])
    # spherical ZYX: Rz(v0) Ry(v1) Rx(v2)
    return IFrame(mat_mul(mat_mul(_axis_rot(2, v[0]), _axis_rot(1, v[1])), _axis_rot(0, v[2])), zero)


def _path(model: pin.Model, j: int) -> list[int]:
    out = []
    while j != 0:
        out.append(j)
        j = model.parents[j]
    return out[::-1]


def relative(model: pin.Model, a: int, b: int, q: np.ndarray) -> IFrame:
    """Joint ``b``'s frame in joint ``a``'s at ``q`` (both after their motion), enclosed: the
    placements on the path between them only (an enclosure through the world would add up
    the errors of every placement above them)."""
    pa, pb = _path(model, a), _path(model, b)
    k = 0
    while k < min(len(pa), len(pb)) and pa[k] == pb[k]:
        k += 1

    def down(js):
        F = IFrame.identity()
        for j in js:
            F = F * IFrame.given(model.jointPlacements[j]) * _motion(model, j, q)
        return F

    return down(pa[k:]).inverse() * down(pb[k:])


def _local_frame(axis: IVec, hint: pin.SE3) -> IFrame:
    """An exact frame on the joint's line (through the joint's origin along ``axis``, in the
    joint's coordinates): ``z = axis``, ``x`` the normalized projection of ``hint``'s, the
    origin the projection of ``hint``'s on the line."""
    xf = _vec(hint.rotation[:, 0])
    x = [u - vdot(xf, axis) * v for u, v in zip(xf, axis)]
    nx = iv.sqrt(vdot(x, x))
    x = [u / nx for u in x]
    y = vcross(axis, x)
    s = vdot(_vec(hint.translation), axis)
    return IFrame([[x[i], y[i], axis[i]] for i in range(3)], [s * v for v in axis])


def _exact_links(g, model: pin.Model, local: list) -> list:
    """The exact links ``L'_i`` (:class:`IFrame`) between the exact frames ``local`` on the
    joints' lines (module docstring)."""
    chain, q = g.chain, g.chain.q_ref
    out = []
    zero, one = iv.mpf(0), iv.mpf(1)
    for i in range(len(g.links)):
        gam = iv.mpf(float(g.gamma[i + 1]))
        c, s = iv.cos(gam), iv.sin(gam)
        RzInv = IFrame([[c, s, zero], [-s, c, zero], [zero, zero, one]], [zero, zero, zero])
        TzInv = IFrame(IFrame.identity().R, [zero, zero, iv.mpf(-float(g.d[i + 1]))])
        ji, jn = chain.joints[i].jid, chain.joints[i + 1].jid
        out.append(local[i].inverse() * relative(model, ji, jn, q) * local[i + 1] * TzInv * RzInv)
    return out


def enclose_links(arm_geometry, mechanism, frame: str, base: str | None, keep_exact: bool = False) -> dict | None:
    """The radii of the template's constants (see the module docstring): ``links`` (per link
    ``(rR, rt)``: bounds on ``|L'_i - L_i|`` entry by entry), ``A`` and ``B`` (the same for
    ``C_0^-1 base`` and ``E^-1``, the frames the goal is composed with), or None where a joint
    on the way is not one revolute or prismatic axis (no enclosure: the constants are taken
    as computed). ``keep_exact`` (tests): instead ``exact_links``, ``A`` and ``B``, the
    enclosures of ``L'_i``, ``A'`` and ``B'`` themselves (:class:`IFrame`, 120 bits)."""
    g = arm_geometry
    chain = g.chain
    if g.frames is None:
        return None
    old = iv.prec
    iv.prec = _PREC
    try:
        model = mechanism.model
        q = chain.q_ref
        data = model.createData()
        pin.forwardKinematics(model, data, q)
        ja, pa = mechanism.frame_anchor(frame)
        jb, pb = mechanism.frame_anchor(base or "universe")
        Mbinv = (data.oMi[jb] * pb).inverse()
        local = []
        for cj, F in zip(chain.joints, g.frames):
            a = _joint_axis(model.joints[cj.jid])
            W = Mbinv * data.oMi[cj.jid]  # the joint's frame (binary64), base coordinates
            hint = W.inverse() * F
            if float(np.dot(W.rotation @ np.array([float(x.mid) for x in a]), cj.axis)) < 0:
                a = [-x for x in a]
            local.append(_local_frame(a, hint))
        exact = _exact_links(g, model, local)
        links = [Lx.radius(L.R, L.t) for Lx, L in zip(exact, g.links)]
        j1, j6 = chain.joints[0].jid, chain.joints[5].jid
        Pa, Pb = IFrame.given(pa), IFrame.given(pb)
        if not chain.reversed:  # A = C_0^-1, B = E^-1 = tool^-1 F_6
            A = local[0].inverse() * relative(model, j1, jb, q) * Pb
            B = Pa.inverse() * relative(model, ja, j6, q) * local[5]
        else:  # A = C_0^-1 tool, B = F_6
            A = local[0].inverse() * relative(model, j1, ja, q) * Pa
            B = Pb.inverse() * relative(model, jb, j6, q) * local[5]
        if keep_exact:
            return dict(exact_links=exact, A=A, B=B)
        out: dict = dict(links=links)
        # against the binary64 frames params_enclosure composes (the rotation of an SE3's
        # inverse is the transpose, exact; its translation is rounded: a few ulps of the
        # translations summed)
        Afloat = g.C0.inverse() * chain.base
        Bfloat = g.E.inverse()
        for key, X, Xf, mags in (
            ("A", A, Afloat, float(np.linalg.norm(g.C0.translation) + np.linalg.norm(chain.base.translation))),
            ("B", B, Bfloat, float(np.linalg.norm(g.E.translation))),
        ):
            rR, rt = X.radius(Xf)
            out[key] = (rR, rt + 8 * 2.0**-53 * (mags + 1e-300))
        return out
    except (ValueError, ZeroDivisionError):
        return None
    finally:
        iv.prec = old
