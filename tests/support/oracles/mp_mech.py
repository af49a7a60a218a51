"""Assemblies of a mechanism at 40 digits: Newton in mpmath on the closures of the model as given.

Independent of kinbox's formulation: forward kinematics of the Pinocchio model's own joints
(revolute about x, y, z or an unaligned axis, prismatic, translation, planar, spherical,
universal, composite, free-flyer) and placements, each read as exact numbers the way ``tests/support/oracles/mp_ik.py``
reads them (a translation as its binary64 value, a rotation as the unit quaternion of its binary64
matrix, an axis normalized at full precision, a locked joint at its binary64 value). The
unknowns are the ``q`` entries of the joints that are not locked; a quaternion (spherical,
free-flyer) or a ``(cos, sin)`` pair (planar) adds its unit-norm equation. The equations are
the closures': ``|pb - pa|^2 = l^2`` for a distance closure, ``pb = pa`` for a point closure.
Newton's step is the least-squares one (``mp.qr_solve``), so a point closure's rows that vanish
identically (a planar mechanism's ``z``) do no harm.

:func:`system_point` gives the exact values of a kinbox system's variables at such a root (by
their names: rotations, positions, displacements, cosines and sines, leg directions), to check
that a certified box holds the root of the model as given.
"""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pinocchio as pin

from .mp_ik import _quat_matrix, _rot, exact_rotation

#: digits the roots are certain to (Newton runs at :data:`WORK` digits)
DPS = 40
WORK = 64

_AXES = {"X": (1, 0, 0), "Y": (0, 1, 0), "Z": (0, 0, 1)}


def _unit(v) -> list:
    v = [mp.mpf(float(x)) for x in v]
    n = mp.sqrt(sum(x * x for x in v))
    return [x / n for x in v]


def _motion(jm, q) -> tuple:
    """``(R, t)`` of a joint's own motion at its ``q`` entries (a list of mpf)."""
    name = jm.shortname().replace("JointModel", "")
    eye, zero = mp.eye(3), mp.matrix([0, 0, 0])
    if name in ("RX", "RY", "RZ", "RevoluteUnaligned"):
        axis = _AXES[name[-1]] if name != "RevoluteUnaligned" else _unit(jm.extract().axis)
        return _rot([mp.mpf(a) for a in axis], q[0]), zero
    if name in ("RUBX", "RUBY", "RUBZ"):
        n = mp.sqrt(q[0] ** 2 + q[1] ** 2)
        return _rot_cs([mp.mpf(a) for a in _AXES[name[-1]]], q[0] / n, q[1] / n), zero
    if name in ("PX", "PY", "PZ", "PrismaticUnaligned"):
        axis = [mp.mpf(a) for a in _AXES[name[-1]]] if name != "PrismaticUnaligned" else _unit(jm.extract().axis)
        return eye, mp.matrix([q[0] * a for a in axis])
    if name == "Translation":
        return eye, mp.matrix(q[:3])
    if name == "Planar":
        n = mp.sqrt(q[2] ** 2 + q[3] ** 2)
        return _rot_cs([mp.mpf(0), mp.mpf(0), mp.mpf(1)], q[2] / n, q[3] / n), mp.matrix([q[0], q[1], 0])
    if name == "Spherical":
        return _quat_matrix(*q[:4]), zero
    if name == "SphericalZYX":
        z, y, x = ([mp.mpf(v) for v in a] for a in ((0, 0, 1), (0, 1, 0), (1, 0, 0)))
        return _rot(z, q[0]) * _rot(y, q[1]) * _rot(x, q[2]), zero
    if name == "Composite":
        ext, R, t, k = jm.extract(), mp.eye(3), mp.matrix([0, 0, 0]), 0
        for sub, P in zip(ext.joints, ext.jointPlacements):
            Rs, ts = _motion(sub, q[k : k + sub.nq])
            Rl, tl = exact_rotation(P.rotation), mp.matrix([mp.mpf(float(v)) for v in P.translation])
            t = t + R * (tl + Rl * ts)
            R = R * Rl * Rs
            k += sub.nq
        return R, t
    if name == "Universal":
        ext = jm.extract()
        return _rot(_unit(ext.axis1), q[0]) * _rot(_unit(ext.axis2), q[1]), zero
    if name == "FreeFlyer":
        return _quat_matrix(*q[3:7]), mp.matrix(q[:3])
    raise ValueError(f"the oracle does not handle {name}")


def _rot_cs(axis, c, s):
    x, y, z = axis
    C = 1 - c
    return mp.matrix(
        [
            [c + x * x * C, x * y * C - z * s, x * z * C + y * s],
            [y * x * C + z * s, c + y * y * C, y * z * C - x * s],
            [z * x * C - y * s, z * y * C + x * s, c + z * z * C],
        ]
    )


def _norm_rows(jm) -> list[tuple[int, int]]:
    """The ``q`` slices (offset, length) of a joint that must be unit vectors."""
    name = jm.shortname().replace("JointModel", "")
    return _NORMS.get(name, [])


_NORMS = {"Spherical": [(0, 4)], "FreeFlyer": [(3, 4)], "Planar": [(2, 2)], "RUBX": [(0, 2)], "RUBY": [(0, 2)], "RUBZ": [(0, 2)]}


class Mech:
    """A mechanism's closures at 40 digits (the module docstring). ``lengths``: a distance
    closure's length other than the model's (by closure name), e.g. an input perturbed on purpose."""

    def __init__(self, mech, lengths: dict | None = None):
        self.mech, self.model = mech, mech.model
        model = self.model
        mp.mp.dps = WORK
        self.place = [(exact_rotation(M.rotation), mp.matrix([mp.mpf(float(v)) for v in M.translation])) for M in model.jointPlacements]
        self.locked = {j: [mp.mpf(float(v)) for v in np.atleast_1d(val)] for j, val in mech.locked_q().items()}
        self.free = [j for j in range(1, model.njoints) if j not in self.locked]
        self.lengths = {c.name: mp.mpf(float((lengths or {}).get(c.name, c.length))) for c in mech.closures if c.kind == "distance"}
        self.ends = [(c, self._point(c.placement_a), self._point(c.placement_b)) for c in mech.closures]

    @staticmethod
    def _point(P: pin.SE3):
        return mp.matrix([mp.mpf(float(v)) for v in P.translation])

    def unpack(self, x) -> dict[int, list]:
        """Joint id -> its ``q`` entries (mpf) from the unknowns ``x`` (the free joints' ``q`` in order)."""
        out, k = dict(self.locked), 0
        for j in self.free:
            nq = self.model.joints[j].nq
            out[j] = list(x[k : k + nq])
            k += nq
        return out

    def pack(self, q: np.ndarray) -> list:
        """The unknowns of a Pinocchio ``q`` (binary64), as mpf."""
        x = []
        for j in self.free:
            jm = self.model.joints[j]
            x += [mp.mpf(float(v)) for v in q[jm.idx_q : jm.idx_q + jm.nq]]
        return x

    def frames(self, x) -> list:
        """World ``(R, o)`` of every joint's frame at the unknowns ``x``."""
        qs, model = self.unpack(x), self.model
        out = [(mp.eye(3), mp.matrix([0, 0, 0]))]
        for j in range(1, model.njoints):
            Rp, op = out[model.parents[j]]
            Rl, tl = self.place[j]
            Rm, tm = _motion(model.joints[j], qs[j])
            R0 = Rp * Rl
            out.append((R0 * Rm, op + Rp * tl + R0 * tm))
        return out

    def residual(self, x) -> list:
        F = self.frames(x)
        rows = []
        for c, Pa, Pb in self.ends:
            Ra, oa = F[int(c.joint_a)]
            Rb, ob = F[int(c.joint_b)]
            d = (ob + Rb * Pb) - (oa + Ra * Pa)
            if c.kind == "distance":
                rows.append(sum(v * v for v in d) - self.lengths[c.name] ** 2)
            else:
                rows += list(d)
        qs = self.unpack(x)
        for j in self.free:
            for off, n in _norm_rows(self.model.joints[j]):
                rows.append(sum(v * v for v in qs[j][off : off + n]) - 1)
        return rows

    def newton(self, q0: np.ndarray, iters: int = 12) -> list:
        """The root of the closures next to the binary64 configuration ``q0`` (its unknowns)."""
        mp.mp.dps = WORK
        x = self.pack(q0)
        h = mp.mpf(10) ** (-WORK // 2)
        for _ in range(iters):
            f = self.residual(x)
            J = mp.matrix(len(f), len(x))
            for i in range(len(x)):
                xp, xm = list(x), list(x)
                xp[i] += h
                xm[i] -= h
                fp, fm = self.residual(xp), self.residual(xm)
                for r in range(len(f)):
                    J[r, i] = (fp[r] - fm[r]) / (2 * h)
            dx = mp.qr_solve(J, mp.matrix([-v for v in f]))[0]
            x = [a + b for a, b in zip(x, dx)]
            if mp.norm(dx) < mp.mpf(10) ** (-DPS - 5):
                break
        if max(abs(v) for v in self.residual(x)) > mp.mpf(10) ** (-DPS):
            raise ArithmeticError("Newton did not converge at 40 digits")
        return x

    def system_point(self, x, names: list[str]) -> dict[str, object]:
        """The exact values of the variables ``names`` of a kinbox system (general formulation of a
        mechanism whose top frame is the world) at the unknowns ``x``: ``R[joint][r,k]`` (its
        frame's rotation), ``t[joint][k]`` (its frame's position), ``d[joint]`` and
        ``d[joint][k]`` (its displacements), ``c[joint]``, ``s[joint]``, ``dir[closure][k]``
        (a leg's unit vector); names of other kinds are left out."""
        F, qs, model = self.frames(x), self.unpack(x), self.model
        ids = {model.names[j]: j for j in range(1, model.njoints)}
        legs = {c.name: (c, Pa, Pb) for c, Pa, Pb in self.ends}
        out: dict[str, object] = {}
        for nm in names:
            kind, rest = nm.split("[", 1)
            owner, _, idx = rest.partition("]")
            idx = idx.strip("[]")
            if kind in ("c", "s") and "/" in owner:  # part k of a composite of one-angle joints
                jn, k = owner.rsplit("/", 1)
                if jn in ids and model.joints[ids[jn]].nq == model.joints[ids[jn]].nv:
                    out[nm] = (mp.cos if kind == "c" else mp.sin)(qs[ids[jn]][int(k)])
                continue
            if kind == "R" and owner in ids and "," in idx and "b" not in idx:
                r, k = (int(v) for v in idx.split(","))
                out[nm] = F[ids[owner]][0][r, k]
            elif kind == "t" and owner in ids:
                out[nm] = F[ids[owner]][1][int(idx)]
            elif kind == "d" and owner in ids:
                out[nm] = qs[ids[owner]][int(idx) if idx else 0]
            elif kind in ("c", "s") and owner in ids and model.joints[ids[owner]].nq == 1:
                out[nm] = (mp.cos if kind == "c" else mp.sin)(qs[ids[owner]][0])
            elif kind in ("c", "s") and owner in ids:  # (cos, sin) in q: a continuous joint's, a planar one's last two
                cs = qs[ids[owner]][-2:]
                out[nm] = cs[0 if kind == "c" else 1] / mp.sqrt(cs[0] ** 2 + cs[1] ** 2)
            elif kind == "dir" and owner in legs:
                c, Pa, Pb = legs[owner]
                Ra, oa = F[int(c.joint_a)]
                Rb, ob = F[int(c.joint_b)]
                out[nm] = ((ob + Rb * Pb) - (oa + Ra * Pa))[int(idx)] / self.lengths[owner]
        return out


def box_holds(point: dict, names: list[str], lo: np.ndarray, hi: np.ndarray) -> float:
    """How far the exact ``point`` (by variable name) is outside the box ``[lo, hi]`` (0: inside)."""
    gap = mp.mpf(0)
    for i, nm in enumerate(names):
        if nm in point:
            v = point[nm]
            gap = max(gap, mp.mpf(float(lo[i])) - v, v - mp.mpf(float(hi[i])))
    return float(gap)


def certified_gaps(oracle: Mech, res) -> list[float]:
    """Per solution of a kinbox answer ``res``, the distance from the 40-digit root of
    ``oracle``'s mechanism next to it (Newton from its ``q``) to the nearest certified box (0:
    inside), in the system's variables."""
    names = res.raw.system.names
    boxes = [b.enclosure for b in res.raw.boxes if b.certified]
    out = []
    for s in res.solutions:
        pt = oracle.system_point(oracle.newton(s.q), names)
        assert len(pt) >= 2
        out.append(min(box_holds(pt, names, lo, hi) for lo, hi in boxes))
    return out


def planar_point(pf, q: list) -> dict[int, object]:
    """The planar formulation's cosine/sine variables (by index) at the joint values ``q``
    (mpmath): each turning group's angle, the sum of its revolute joints' angles from the
    reference down its chain, each with its sign along the plane's axis."""
    impl = pf.impl
    assert impl is not None

    def theta(n: int):
        t = mp.mpf(0)
        while n in impl.joints:
            j = impl.joints[n]
            if j.kind == "revolute":
                t += j.sign * (q[j.idx_q] - mp.mpf(float(impl.q_ref[j.idx_q])))
            n = j.parent
        return t

    out = {}
    for g, (ic, is_) in impl.gvars.items():
        t = theta(impl.gnode[g])
        out[ic], out[is_] = mp.cos(t), mp.sin(t)
    return out
