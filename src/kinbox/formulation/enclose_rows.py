"""The general formulation's core rows as enclosures of the model and the pose as given.

:func:`kinbox.formulation.build.formulate` writes its rows from the model's binary64 numbers:
each placement's rotation as its binary64 matrix, entries below ``pairs.SNAP`` set to zero, a
joint's axis basis computed in binary64, every coefficient a rounded product of those. The
model as given (:mod:`kinbox.formulation.constants`) is each placement's translation as its
binary64 numbers and its rotation that of the unit quaternion of its binary64 matrix, each
joint's axis its binary64 direction normalized; a goal pose enters as the weld closure
``anchor * goal``, read the same way (the XYZQUAT Pinocchio gives for it).

The formulation is written a second time (*the shadow build*) with every constant an
:class:`~kinbox.formulation.errfloat.EF`: its binary64 value (bit for bit the first build's)
and a bound on its distance to the model's exact value, enclosed in interval arithmetic
(``constants.IFrame``; an entry snapped to zero keeps its value as its error). Every sum and
product of the build carries the bound through (:mod:`~kinbox.formulation.errfloat`), so each
core row's coefficient ends with a bound on its distance to the exact row's. Where the shadow
build's core rows are the first build's (same variables, rows and nonzero coefficients, bit for
bit), :func:`core_errors` gives per core row ``merr`` (a bound on ``|F*(x) - F(x)|`` over the
search domain) and ``mgrad`` (a bound on each partial derivative of that difference): the
:class:`~kinbox.formulation.system.Compiled` rows then carry them and Krawczyk's proofs, and
every contractor's slack, hold for the model and pose as given
(``tests/formulation/test_enclosures.py::test_the_general_formulation_certifies_the_model_as_given``).

What the shadow build covers: revolute and prismatic joints (one axis each), universal joints
(two revolute parts about their two axes), planar pairs (a rotation about the exact ``z`` and
slides along the exact ``x`` and ``y``), translation pairs (slides along the exact coordinate
axes), spherical pairs and free-flyers (a free rotation's rows have the exact constants 1 and
0 only; a free-flyer's translation eliminated in both builds alike), composite joints (their
parts, the first part's placement the enclosed product of the composite's), locked joints
(their motion at the lock values as given: one revolute or prismatic axis, or several, a
quaternion standing for its unit rotation: ``constants._several``,
``tests/formulation/test_enclose_locked.py``), weld, point and distance closures (``l^2`` a
rounded square of the binary64 length, :func:`~kinbox.formulation.errfloat.square`; ``l d``
exact), top frames (``tests/formulation/test_enclose_pairs.py``). A locked joint of another
kind (helical), or a top frame below one, raises :class:`NotEnclosed`: the rows are then taken
as rounded (docs/soundness.md says so).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
from mpmath import iv

from . import constants as K
from .errfloat import EF, err
from .pairs.algebra import mat_mul, mat_vec, transpose, vcross, vdot
from .system import Constraint, System

_GROW = 1.0 + 1e-12


class NotEnclosed(Exception):
    """The shadow build met a constant it does not enclose."""


class NotPlanar(NotEnclosed):
    """The planar formulation's shadow build found the model as given not exactly planar: an
    axis not exactly along the plane's, a slide not exactly across it, a point or weld
    closure's ends not at exactly the same height, a weld not exactly about the plane's axis."""


def ef_array(values, radii) -> np.ndarray:
    """An object array of :class:`EF` (the values bit for bit, ``radii`` their error bounds)."""
    v = np.asarray(values, dtype=float)
    r = np.broadcast_to(np.asarray(radii, dtype=float), v.shape)
    out = np.empty(v.shape, dtype=object)
    for idx in np.ndindex(v.shape):
        out[idx] = EF(float(v[idx]), float(r[idx]))
    return out


def _frame(F: K.IFrame, M: pin.SE3) -> tuple[np.ndarray, np.ndarray]:
    rR, rt = F.radius(M)
    return ef_array(M.rotation, rR), ef_array(M.translation, rt)


def given(M: pin.SE3) -> tuple[np.ndarray, np.ndarray]:
    """A placement of the model as given: its binary64 ``(R, t)`` as :class:`EF` arrays (the
    same numbers give the same arrays: a robot's placements are enclosed once per process)."""
    key = np.concatenate([np.asarray(M.rotation, dtype=float).ravel(), np.asarray(M.translation, dtype=float)]).tobytes()
    hit = _GIVEN.get(key)
    if hit is None:
        with _precision():
            hit = _frame(K.IFrame.given(M), M)
        if len(_GIVEN) > 4096:
            _GIVEN.clear()
        _GIVEN[key] = hit
    return hit[0].copy(), hit[1].copy()


_GIVEN: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}


def length(value: float) -> EF:
    """A distance closure's length as given: its binary64 value, exact (a test widens it to
    stand for an input known only within a radius: ``tests/formulation/test_enclose_pairs.py``)."""
    return EF(float(value), 0.0)


def relative(model: pin.Model, a: int, b: int, q: np.ndarray, M: pin.SE3) -> tuple[np.ndarray, np.ndarray]:
    """Joint ``b``'s frame in joint ``a``'s at ``q`` as computed in binary64 (``M``), with the
    distance to the model's exact frame (:func:`constants.relative`)."""
    with _precision():
        try:
            F = K.relative(model, a, b, q)
        except ValueError as exc:
            raise NotEnclosed(str(exc)) from None
        return _frame(F, M)


#: pair kinds whose parts have no axis and whose motion has no constant of the model: a free
#: rotation's rows hold only the exact constants 1 and 0, a translation's directions are the
#: exact coordinate axes of the frame before its motion
_NO_AXIS = ("translation", "spherical", "spherical_zyx", "free")
_Z = np.array([0.0, 0.0, 1.0])


def part_axes(jm, parts: list) -> list:
    """Per part of a joint (``pairs.joint_parts``), where :func:`basis` takes its axis:
    ``(joint model, raw)`` with ``raw`` None for a revolute or prismatic (sub-)joint (its joint
    model's axis), the binary64 ``axis1`` or ``axis2`` of a universal joint's part (normalized
    exactly there), ``z`` for a planar pair's rotation (exact); ``(joint model, None)`` for a
    part without an axis (translation, spherical, free-flyer). A composite joint's parts are
    those of its sub-joints. :class:`NotEnclosed` for any other pair."""
    from .pairs.family import sub_joint  # noqa: PLC0415

    out: list = []
    seen: dict[tuple, int] = {}
    for p in parts:
        sub = sub_joint(jm, p.path)
        name = sub.shortname()
        k = seen.get(p.path, 0)
        seen[p.path] = k + 1
        if p.kind in ("revolute", "prismatic") and name == "JointModelUniversal":
            ext = sub.extract() if hasattr(sub, "extract") else sub
            out.append((sub, np.array(ext.axis2 if k else ext.axis1, dtype=float)))
        elif p.kind in ("revolute", "prismatic") and name in K._REVOLUTE + K._PRISMATIC:
            out.append((sub, None))
        elif p.kind == "planar":
            out.append((sub, _Z.copy()))
        elif p.kind in _NO_AXIS:
            out.append((sub, None))
        else:
            raise NotEnclosed(f"joint {name!r}: a {p.kind} part")
    return out


def part_placements(jm, placement: pin.SE3, parts: list) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per part of a joint, its placement (``Part.placement``, binary64) as :class:`EF` arrays:
    the joint's placement as given, or, for the first part of a composite's sub-joint, the
    product of the placements that ``pairs.joint_parts`` multiplied in binary64 (the joint's and
    the composite's first ones, enclosed as a product); a later part of one sub-joint (a
    universal joint's second rotation) is at the identity, exact."""
    out = []
    seen: set[tuple] = set()
    for p in parts:
        if p.path in seen:
            out.append(given(p.placement))
            continue
        seen.add(p.path)
        factors = [placement]
        cur = jm
        for k in p.path:
            comp = cur.extract()
            P = pin.SE3(comp.jointPlacements[k])
            factors = factors + [P] if k == 0 else [P]
            cur = comp.joints[k]
        if len(factors) == 1:
            out.append(given(p.placement))
            continue
        with _precision():
            F = K.IFrame.given(factors[0])
            for f in factors[1:]:
                F = F * K.IFrame.given(f)
            out.append(_frame(F, p.placement))
    return out


def basis(jm, B: np.ndarray, raw: np.ndarray | None = None) -> np.ndarray:
    """The axis basis ``B = [b1 b2 a]`` of a revolute or prismatic part (``pairs.axis_basis``)
    as :class:`EF`: the exact orthonormal basis whose ``z`` is the model's unit axis (the joint
    model's, or ``raw`` normalized exactly: a universal joint's part) and whose ``x`` is ``b1``
    made orthogonal to it (any such basis gives the same rotation about the axis,
    ``B Rz(q) B^T``; a slide uses ``z`` alone), each entry's distance to ``B``'s."""
    name = jm.shortname()
    axis = b"" if raw is None else np.asarray(raw, dtype=float).tobytes()
    if raw is None and "Unaligned" in name:  # the model's own axis (a coordinate axis for the others)
        from .pairs.family import joint_axis  # noqa: PLC0415

        axis = np.asarray(joint_axis(jm, "Revolute" in name), dtype=float).tobytes()
    key = (name, axis, np.asarray(B, dtype=float).tobytes())
    hit = _BASIS.get(key)
    if hit is None:
        hit = _basis(jm, B, raw)
        if len(_BASIS) > 4096:
            _BASIS.clear()
        _BASIS[key] = hit
    return hit.copy()


_BASIS: dict[tuple, np.ndarray] = {}


def _basis(jm, B: np.ndarray, raw: np.ndarray | None) -> np.ndarray:
    with _precision():
        if raw is None:
            a = K._joint_axis(jm)
        else:
            v = [iv.mpf(float(x)) for x in raw]
            n = iv.sqrt(vdot(v, v))
            a = [x / n for x in v]
        x0 = [iv.mpf(float(v)) for v in B[:, 0]]
        d = vdot(x0, a)
        x = [u - d * w for u, w in zip(x0, a)]
        n = iv.sqrt(vdot(x, x))
        x = [u / n for u in x]
        y = vcross(a, x)
        cols = (x, y, a)
        rad = np.array([[K._dist(cols[j][i], float(B[i, j])) for j in range(3)] for i in range(3)])
    return ef_array(B, rad)


class _precision:
    def __enter__(self):
        self.old = iv.prec
        iv.prec = K._PREC

    def __exit__(self, *exc):
        iv.prec = self.old


def _same_rows(a: System, b: System) -> bool:
    """Are the variables and core rows of ``a`` (the first build) those of ``b`` (the shadow),
    the shadow's nonzero coefficients bit for bit the first's?"""
    if a.names != b.names or a.lo != b.lo or a.hi != b.hi:
        return False
    ca = [c for c in a.constraints if c.kind == "core"]
    cb = [c for c in b.constraints if c.kind == "core"]
    if len(ca) != len(cb):
        return False
    for x, y in zip(ca, cb):
        if x.name != y.name:
            return False
        ty = {k: float(v) for k, v in y.expr.terms.items() if float(v) != 0.0}
        tx = {k: float(v) for k, v in x.expr.terms.items()}
        if tx != ty:
            return False
    return True


def _row_error(con: Constraint, mag: list[float]) -> tuple[float, float]:
    """``(merr, mgrad)`` of one row: per term, its coefficient's error times the bound of its
    monomial over the domain, and times the bound of each partial derivative of the monomial."""
    e = g = 0.0
    for k, v in con.expr.terms.items():
        r = err(v)
        if r == 0.0:
            continue
        m = r
        for i in k:
            m *= mag[i]
        e += m
        if k:
            d = 0.0
            for i in set(k):
                p = r * k.count(i)
                for j, kk in enumerate(k):
                    if kk != i or j != k.index(i):
                        p *= mag[kk]
                d = max(d, p)
            g += d
    return e, g


def core_errors(first: System, shadow: System) -> tuple[np.ndarray, np.ndarray] | None:
    """Per core row of ``first``, ``(merr, mgrad)`` from the shadow build's :class:`EF`
    coefficients over ``first``'s search domain (rounded up), or None where the two builds'
    core rows differ (the rows are then taken as rounded)."""
    if not _same_rows(first, shadow):
        return None
    lo, hi = first.search_domain()
    mag = np.maximum(np.abs(lo), np.abs(hi)).tolist()
    cons = [c for c in shadow.constraints if c.kind == "core"]
    merr = np.empty(len(cons))
    mgrad = np.empty(len(cons))
    for r, c in enumerate(cons):
        e, g = _row_error(c, mag)
        # each product and sum above rounded: a relative 1e-12 covers them (at most a few
        # dozen roundings of 2^-53 each), the smallest normal number an underflow
        merr[r], mgrad[r] = e, g
    tiny = 2.2250738585072014e-308
    merr = np.where(merr > 0, np.nextafter(merr * _GROW, np.inf) + tiny, 0.0)
    mgrad = np.where(mgrad > 0, np.nextafter(mgrad * _GROW, np.inf) + tiny, 0.0)
    return merr, mgrad


def _joint_key(model: pin.Model, j: int, q: np.ndarray) -> tuple:
    """What ``constants.relative`` reads of joint ``j``: its kind, its binary64 axis (an
    unaligned one), its placement and its ``q``."""
    jm = model.joints[j]
    name = jm.shortname()
    axis = b""
    if "Unaligned" in name:
        ext = jm.extract()
        if hasattr(type(ext), "axis"):
            axis = np.asarray(ext.axis, dtype=float).tobytes()
        else:
            from .pairs.family import joint_axis  # noqa: PLC0415

            axis = np.asarray(joint_axis(jm, "Revolute" in name), dtype=float).tobytes()
    M = model.jointPlacements[j]
    v = np.asarray(q[jm.idx_q : jm.idx_q + jm.nq], dtype=float)
    return name, axis, np.asarray(M.homogeneous, dtype=float).tobytes(), v.tobytes()


def _path_key(model: pin.Model, j: int, q: np.ndarray) -> tuple:
    return tuple(_joint_key(model, jj, q) for jj in K._path(model, j))


def _world_frame(model: pin.Model, j: int, q: np.ndarray, key: tuple | None = None) -> K.IFrame:
    """Joint ``j``'s frame in the world at ``q``, enclosed (``constants.relative``), computed
    once per process for the same numbers along its path (``key``: :func:`_path_key`; an
    arm's IK formulates a planar system per pose: its frames at the reference are the same for
    every pose)."""
    key = _path_key(model, j, q) if key is None else key
    hit = _FRAMES.get(key)
    if hit is None:
        hit = K.relative(model, 0, j, q)
        if len(_FRAMES) > 4096:
            _FRAMES.clear()
        _FRAMES[key] = hit
    return hit


def _given_frame(M: pin.SE3) -> K.IFrame:
    """``constants.IFrame.given(M)``, once per process for the same numbers."""
    key = np.asarray(M.homogeneous, dtype=float).tobytes()
    hit = _GIVEN_FRAMES.get(key)
    if hit is None:
        hit = K.IFrame.given(M)
        if len(_GIVEN_FRAMES) > 4096:
            _GIVEN_FRAMES.clear()
        _GIVEN_FRAMES[key] = hit
    return hit


_FRAMES: dict[tuple, K.IFrame] = {}
_GIVEN_FRAMES: dict[bytes, K.IFrame] = {}
_PLANAR: dict[tuple, tuple] = {}  # PlanarConstants.axis and .point for the same numbers


def _remember(key: tuple, value: tuple) -> tuple:
    if len(_PLANAR) > 4096:
        _PLANAR.clear()
    _PLANAR[key] = value
    return value


class PlanarConstants:
    """The planar formulation's constants (:mod:`kinbox.formulation.planar`) as :class:`EF`,
    for its shadow build: the reference points of the joints' axes and of the closures' ends
    in the plane, the slides' directions and the bars' lengths in the plane, each with its
    distance to the exact value of the model as given (its frames at the reference
    configuration enclosed by :func:`constants.relative`).

    The plane's exact axis is ``A``: the coordinate axis ``w`` is (the first build snaps a
    coordinate axis to it), else the world direction of joint ``wj``'s axis (the revolute joint
    the first build took ``w`` from) as its frame's exact rotation times its binary64 axis, not
    normalized; every test of exact planarity is an exact zero of an interval computed from
    ``A`` (an axis' cross product with it, a slide's or a height difference's dot product, a
    weld's ``M A - A``), so it holds where the model's frames at the reference are exact (a
    plane turned off the coordinate axes by joint axes given along it, frames not turned) and
    fails, leaving the rows as rounded, where the interval arithmetic cannot tell. The plane's
    basis ``E`` (binary64, the first build's) is enclosed as the exact basis built the same way
    from ``A`` (:meth:`project`).

    A weld's angle (``atan2`` in binary64) is enclosed as the exact cosine and sine of the
    relative rotation of its two frames (:meth:`weld`).

    Raises :class:`NotPlanar` where the model as given is not exactly planar about a coordinate
    axis ``w``: a revolute axis not exactly along ``w``, a slide not exactly across it, a point
    or weld closure whose ends are not at exactly the same height, a weld that does not turn
    exactly about ``w`` (:func:`kinbox.problems.mechanism.choose_formulation` then writes the
    general formulation), and about another axis where such a test proves it (an interval that
    excludes zero); a test that interval arithmetic cannot decide about another axis is kept in
    :attr:`unproven` (the rows then stay as rounded)."""

    def __init__(self, mech, q_ref: np.ndarray, ref: list, w: np.ndarray, wj: int | None = None, E: np.ndarray | None = None):
        self.mech, self.model, self.q_ref, self.ref = mech, mech.model, q_ref, ref
        self._frames: dict[int, K.IFrame] = {}
        self._keys: dict[int, tuple] = {}
        #: tests of exact planarity interval arithmetic could not decide (:meth:`_require`)
        self.unproven: list[str] = []
        k = int(np.argmax(np.abs(w)))
        self.k: int | None = k if (w[k] == 1.0 and np.count_nonzero(w) == 1) else None
        with _precision():
            if self.k is not None:
                self.A = [iv.mpf(1) if i == k else iv.mpf(0) for i in range(3)]
            else:
                if wj is None:
                    raise NotEnclosed(f"the plane's axis {np.round(w, 6).tolist()} is no coordinate axis")
                self.A = mat_vec(self._frame(wj).R, K._raw_axis(self.model.joints[wj]))
            self.nA = iv.sqrt(vdot(self.A, self.A))
            self.w = [x / self.nA for x in self.A]
            self._ie = int(np.argmin(np.abs(w)))  # the first build's e: the coordinate axis least along w
            if E is not None:
                if self.k is not None:  # e1 = e_{k+1}, e2 = w x e1 = e_{k+2}: exact
                    rows = [[iv.mpf(1) if i == (k + r) % 3 else iv.mpf(0) for i in range(3)] for r in (1, 2)]
                else:
                    e1 = self._e1()
                    rows = [e1, vcross(self.w, e1)]
                self.E = ef_array(E, [[K._dist(rows[r][i], float(E[r, i])) for i in range(3)] for r in range(2)])

    def _require(self, zeros: list, msg: str) -> bool:
        """Are the intervals ``zeros`` exactly zero? If not: :class:`NotPlanar` about a
        coordinate axis, or where one of them excludes zero (the model as given is not planar);
        else ``msg`` is kept in :attr:`unproven` (the model may be planar, interval arithmetic
        cannot tell: the rows are then left as rounded) and False is returned."""
        if all(self._exact_zero(x) for x in zeros):
            return True
        if self.k is not None or any(x.a > 0 or x.b < 0 for x in zeros):
            raise NotPlanar(msg)
        self.unproven.append(f"{msg} (not proven about the plane's axis, no coordinate axis)")
        return False

    def project(self, p) -> np.ndarray:
        """``E p`` (the first build's values, bit for bit) with ``E``'s and ``p``'s errors."""
        from .errfloat import matmul  # noqa: PLC0415

        p = np.asarray(p)
        if p.dtype != object:
            p = ef_array(p, 0.0)
        return matmul(self.E, p)

    def _key(self, j: int) -> tuple:
        """What joint ``j``'s frame at the reference is computed from (:func:`_path_key`)."""
        if j not in self._keys:
            self._keys[j] = _path_key(self.model, j, self.q_ref)
        return self._keys[j]

    def _frame(self, j: int) -> K.IFrame:
        if j not in self._frames:
            with _precision():
                try:
                    self._frames[j] = _world_frame(self.model, j, self.q_ref, self._key(j)) if j else K.IFrame.identity()
                except ValueError as exc:
                    raise NotEnclosed(str(exc)) from None
        return self._frames[j]

    def _exact_zero(self, x) -> bool:
        return bool(x.a == 0 and x.b == 0)

    def axis(self, j: int, kind: str, a: np.ndarray) -> np.ndarray:
        """The world direction of joint ``j``'s axis (``a``, binary64) as ``EF``; checks that
        the exact one is along ``A`` (revolute) or across it (prismatic)."""
        key = ("axis", self._key(j), kind, self._plane_key(), np.asarray(a, dtype=float).tobytes())
        hit = _PLANAR.get(key)
        if hit is not None:
            return hit[0].copy()
        with _precision():
            F = self._frame(j)
            ax = K._joint_axis(self.model.joints[j])
            v = mat_vec(F.R, ax)
            raw = mat_vec(F.R, K._raw_axis(self.model.joints[j]))
            if kind == "revolute":
                ok = self._require(vcross(raw, self.A), f"joint {self.model.names[j]!r}: its axis is not exactly along the plane's")
            else:
                ok = self._require([vdot(raw, self.A)], f"joint {self.model.names[j]!r}: its slide is not exactly across the plane's axis")
            rad = np.array([K._dist(v[i], float(a[i])) for i in range(3)])
        out = ef_array(a, rad)
        return (_remember(key, (out,))[0] if ok else out).copy()  # an undecided test is not remembered

    def _plane_key(self) -> tuple:
        return (self.k,) if self.k is not None else tuple((float(x.a), float(x.b)) for x in self.A)

    def point(self, j: int, M: pin.SE3 | None, t: np.ndarray) -> tuple[np.ndarray, object]:
        """The world point ``t`` (binary64) of joint ``j``'s frame (times ``M``) at the
        reference, as ``EF``, and its exact height along ``A`` (an interval, times ``|A|``)."""
        placed = None if M is None else np.asarray(M.homogeneous, dtype=float).tobytes()
        key = ("point", self._key(j), placed, np.asarray(t, dtype=float).tobytes(), self._plane_key())
        hit = _PLANAR.get(key)
        if hit is None:
            with _precision():
                F = self._frame(j)
                if M is not None:
                    F = F * _given_frame(M)
                rad = np.array([K._dist(F.t[i], float(t[i])) for i in range(3)])
                hit = _remember(key, (ef_array(t, rad), F.t[self.k] if self.k is not None else vdot(self.A, F.t)))
        return hit[0].copy(), hit[1]

    def same_height(self, ha, hb, name: str) -> None:
        with _precision():
            self._require([ha - hb], f"closure {name!r}: its ends are not at exactly the same height")

    def weld(self, na: int, Pa: pin.SE3, nb: int, Pb: pin.SE3, name: str) -> tuple:
        """The exact ``(cos phi, sin phi)`` (intervals) of a weld's angle ``phi = theta_a -
        theta_b``: the rotation ``R_b R_a^T`` of its two frames at the reference (joint ``na``'s
        frame times ``Pa``, ``nb``'s times ``Pb``), which must turn exactly about ``w``."""
        with _precision():
            Ra = (self._frame(na) * _given_frame(Pa)).R
            Rb = (self._frame(nb) * _given_frame(Pb)).R
            M = mat_mul(Rb, transpose(Ra))
            k = self.k
            if k is not None:
                if not all(self._exact_zero(M[i][k]) and self._exact_zero(M[k][i]) for i in range(3) if i != k):
                    raise NotPlanar(f"closure {name!r}: the weld does not turn exactly about the plane's axis")
                i1, i2 = (k + 1) % 3, (k + 2) % 3  # e1 = e_{k+1}, e2 = w x e1 = e_{k+2}
                c, s = M[i1][i1], M[i2][i1]
            else:
                msg = f"closure {name!r}: the weld does not turn exactly about the plane's axis"
                self._require([x - y for x, y in zip(mat_vec(M, self.A), self.A)], msg)
                e1 = self._e1()
                Me1 = mat_vec(M, e1)
                c, s = vdot(e1, Me1), vdot(vcross(self.w, e1), Me1)
            n = iv.sqrt(c * c + s * s)
            return c / n, s / n

    def turn(self, z: tuple, t: float) -> tuple[EF, EF]:
        """``cos t``, ``sin t`` (binary64, ``t`` the first build's angle) as :class:`EF`, their
        errors the distance to the exact ``z = (cos, sin)`` (intervals)."""
        with _precision():
            ct, st = math.cos(t), math.sin(t)
            return EF(ct, K._dist(z[0], ct)), EF(st, K._dist(z[1], st))

    @staticmethod
    def compose(a: tuple, b: tuple, conj_b: bool = False) -> tuple:
        """The exact ``(cos, sin)`` of ``alpha + beta`` (``alpha - beta`` with ``conj_b``)."""
        with _precision():
            bc, bs = b[0], (-b[1] if conj_b else b[1])
            return a[0] * bc - a[1] * bs, a[0] * bs + a[1] * bc

    @staticmethod
    def zero_turn() -> tuple:
        return iv.mpf(1), iv.mpf(0)

    def _e1(self) -> list:
        """The exact ``e1`` of the plane's basis (a unit vector across ``A``)."""
        e = [iv.mpf(0)] * 3
        e[self._ie] = iv.mpf(1)
        d = vdot(self.w, e)
        e1 = [a - d * b for a, b in zip(e, self.w)]
        n1 = iv.sqrt(vdot(e1, e1))
        return [a / n1 for a in e1]

    def length(self, L: float, ha, hb, value: float):
        """A bar's length in the plane, ``sqrt(L^2 - (ha - hb)^2)`` (``value``: binary64), as ``EF``."""
        with _precision():
            h = (ha - hb) / self.nA
            x = iv.mpf(float(L)) ** 2 - h * h
            if x.a < 0:
                raise NotEnclosed("a bar shorter than the height between its ends")
            return EF(value, K._dist(iv.sqrt(x), value))
