"""The planar formulation: a mechanism whose joint axes are all parallel, written in its plane.

:func:`planar_axis` recognises a planar mechanism from its Pinocchio model: every joint that
moves on a loop is a revolute or a prismatic pair, the revolute axes are parallel to one world
direction ``w`` and the prismatic axes perpendicular to it (to :data:`PARALLEL_TOL`). Then every
body only turns about ``w`` and translates across it, and :func:`formulate_planar` writes
(Porta, Ros, Creemers, Thomas 2007; Porta, Ros and Thomas 2009, Sec. IV):

* one cosine/sine pair ``(c_g, s_g)`` per rigid group of bodies (bodies joined by prismatic
  or locked joints and welds turn together), with ``c_g^2 + s_g^2 = 1``: the angle of the
  group about ``w`` from the reference configuration (``q`` neutral, locked values held);
* a displacement per prismatic joint (its ``q``, within its limits);
* each body's origin as a sum down the tree: across a revolute joint at ``J``,
  ``o_child = o_parent + (R_parent - R_child) J``; across a prismatic joint along ``u``,
  ``o_child = o_parent + (q - q_ref) R_parent u`` -- linear in the cosines and sines,
  bilinear in a displacement and a cosine;
* closures as loop equations in the plane: a point (or weld) closure ``p_a = p_b`` (two
  rows); a distance closure (a bar) ``p_a + l d = p_b`` with a unit vector ``d`` and ``l`` the
  length in the plane (``l^2 = L^2 - h^2``, ``h`` the constant offset of its ends along
  ``w``; ``d`` is derived: not split, its loop rows give it from the links' angles), or
  ``|p_b - p_a|^2 = l^2`` (``legs="squared"``); a weld also ties the two groups' angles
  (linear rows);
* revolute limits narrower than ``2 pi``: ``cos(t - mid) >= cos(half)`` on the relative
  angle ``t`` (bilinear), which cuts exactly the allowed arc.

All equations are of degree two, so the search, relaxations and Krawczyk apply unchanged.
The shadow build (``enclose=True``, :class:`~kinbox.formulation.enclose_rows.PlanarConstants`)
encloses every constant from the model as given, welds' angles included, and proves the model
exactly planar; one planar only to :data:`PARALLEL_TOL` gets ``not_planar`` (its reason), and
``formulation="auto"`` the general formulation (tests/formulation/test_planar_enclosures.py).
:class:`PlanarFormulation` has the interface of :class:`~kinbox.formulation.build.Formulation`
that the answer stage uses (``encode``/``decode`` through Pinocchio's forward kinematics).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from ..errors import FormulationError, InputError, finite_vector
from ..model.mechanism import Mechanism, check_mechanism
from .build import reference_configuration, tree_path
from .errfloat import keep, num
from .pairs import joint_parts, part_limits
from .pairs.family import Part
from .pairs.revolute import revolute_is_limited, wrap_angle
from .system import Expr, System

#: joint axes count as parallel (or perpendicular) when the cross (or dot) product of the unit
#: axes is below this: axes from DH parameters such as alpha = pi are parallel to 1.2e-16
PARALLEL_TOL = 1e-12
#: leg equations of a distance closure
PLANAR_LEGS = ("auto", "vector", "squared")

Vec = list  # two entries, each an Expr or a float


def _lin(*terms) -> Expr | float:
    """``sum a_k * e_k`` (floats ``a_k``; ``e_k`` Expr or float), a float when constant."""
    out: Expr | float = 0.0
    for a, e in terms:
        if not keep(a) or (not isinstance(e, Expr) and not keep(e)):  # keep: a zero with an error (EF)
            continue
        out = out + a * e
    if isinstance(out, Expr) and out.is_constant():
        return out.constant
    return out


def _rotate(cs: tuple, p: np.ndarray) -> Vec:
    """``R(c, s) p`` for a constant 2-vector ``p``."""
    c, s = cs
    return [_lin((p[0], c), (-p[1], s)), _lin((p[1], c), (p[0], s))]


def _vadd(a: Vec, b: Vec, sign: float = 1.0) -> Vec:
    return [_lin((1.0, a[k]), (sign, b[k])) for k in range(2)]


def _val(e, x: np.ndarray) -> float:
    return e.value(x) if isinstance(e, Expr) else float(e)


@dataclass
class _Joint:
    jid: int
    name: str
    kind: str  # "revolute", "prismatic" or "locked"
    parent: int  # node (joint id) of the parent frame
    sign: float = 1.0  # revolute: axis along +w or -w
    J: np.ndarray | None = None  # revolute: the axis' point in the plane at the reference
    u: np.ndarray | None = None  # prismatic: the direction in the plane at the reference
    idx_q: int = 0
    nq: int = 1
    unbounded: bool = False
    lo: float = -math.inf
    hi: float = math.inf


@dataclass(eq=False)
class _Impl:
    w: np.ndarray
    E: np.ndarray  # 2 x 3: the plane's basis e1, e2 (rows), e1 x e2 = w
    q_ref: np.ndarray
    ref: list  # data.oMi at q_ref
    top: dict[int, int]  # node -> the top frame of its piece (its pose is held at the reference)
    joints: dict[int, _Joint]  # node -> the joint into it (nodes on a loop path)
    group: dict[int, int]  # node -> its rotation group (0: held)
    offset: dict[int, float]  # node -> angle of the node from its group's angle
    gvars: dict[int, tuple[int, int]]  # group -> indices of (c, s)
    gnode: dict[int, int]  # group -> a node of it with offset 0 (where encode reads its angle)
    dvars: dict[int, int]  # prismatic node -> index of its displacement
    bars: list  # (closure index, plane length, (c index, s index))
    locked: dict[int, np.ndarray]


@dataclass
class PlanarFormulation:
    """A planar mechanism, its system, and the maps between ``q`` and system points."""

    mechanism: Mechanism
    system: System
    dropped_joints: list[str]
    joint_vars: dict[str, list[str]]
    closure_vars: dict[str, list[str]] = field(default_factory=dict)
    impl: _Impl | None = field(default=None, repr=False)
    kind: str = "planar"
    #: why the model as given is not exactly planar (an axis parallel to the plane's only to
    #: :data:`PARALLEL_TOL`, ...; ``enclose_rows.NotPlanar``), None where it is or where the
    #: shadow build does not reach the test: the rows are then those of a planar model near it
    #: (``formulation="auto"`` writes the general formulation instead:
    #: :func:`kinbox.problems.mechanism.choose_formulation`)
    not_planar: str | None = None
    #: why the core rows are taken as rounded where the shadow build does not cover the model
    #: (``enclose_rows.NotEnclosed``: a plane whose axis is no coordinate axis, whose exact
    #: planarity it cannot prove), None where they carry their errors or are not planar as given:
    #: the answer says its certificates are of the planar rows as rounded
    rounded: str | None = None

    def _poses(self, q: np.ndarray) -> dict[int, pin.SE3]:
        impl = self.impl
        assert impl is not None
        model = self.mechanism.model
        data = model.createData()
        pin.forwardKinematics(model, data, q)
        out: dict[int, pin.SE3] = {}
        for n, t in impl.top.items():  # each piece moved so that its top frame is at the reference
            out[n] = impl.ref[t] * data.oMi[t].inverse() * data.oMi[n]
        return out

    def _angle(self, M: pin.SE3, n: int) -> float:
        impl = self.impl
        assert impl is not None
        R = M.rotation @ impl.ref[n].rotation.T
        v = impl.E @ R @ impl.E[0]
        return math.atan2(float(v[1]), float(v[0]))

    def encode(self, q: np.ndarray) -> np.ndarray:
        """The system point of a configuration ``q`` (Pinocchio forward kinematics)."""
        impl = self.impl
        assert impl is not None
        model = self.mechanism.model
        q = finite_vector(q, model.nq, "q", f"model {self.mechanism.name!r} has nq = {model.nq}")
        P = self._poses(q)
        x = np.zeros(self.system.n)
        for g, (ic, is_) in impl.gvars.items():
            t = self._angle(P[impl.gnode[g]], impl.gnode[g])
            x[ic], x[is_] = math.cos(t), math.sin(t)
        for n, i in impl.dvars.items():
            x[i] = q[impl.joints[n].idx_q]
        for ci, length, (ic, is_) in impl.bars:
            c = self.mechanism.closures[ci]
            pa = (P[c.joint_a] * c.placement_a).translation
            pb = (P[c.joint_b] * c.placement_b).translation
            d = impl.E @ (pb - pa) / length
            x[ic], x[is_] = float(d[0]), float(d[1])
        return x

    #: every joint limit is kept by the system (:class:`~kinbox.formulation.protocol.MechanismFormulation`)
    limits_after = False

    def admissible(self, x: np.ndarray, width: float = 0.0) -> bool:
        """Always: the system keeps every joint limit."""
        return True

    def decode(self, x: np.ndarray) -> np.ndarray:
        """The Pinocchio ``q`` of a system point ``x``: relative angles of revolute joints
        (wrapped into their limits), displacements of prismatic ones, locked values; joints
        off every loop at their neutral value."""
        impl = self.impl
        assert impl is not None
        x = finite_vector(x, self.system.n, "system point", f"the system has {self.system.n} variables")
        q = impl.q_ref.copy()

        def theta(n: int) -> float:
            g = impl.group.get(n, 0)
            t = impl.offset.get(n, 0.0)
            if g in impl.gvars:
                ic, is_ = impl.gvars[g]
                t += math.atan2(x[is_], x[ic])
            return t

        for n, j in impl.joints.items():
            if j.kind == "revolute":
                t = _ref_angle(impl.q_ref, j) + j.sign * (theta(n) - theta(j.parent))
                if j.unbounded:
                    q[j.idx_q : j.idx_q + 2] = [math.cos(t), math.sin(t)]
                else:
                    q[j.idx_q] = wrap_angle(t, j.lo, j.hi)
            elif j.kind == "prismatic":
                q[j.idx_q] = x[impl.dvars[n]]
        return q

    def summary(self) -> dict:
        return {**self.system.summary(), "formulation": "planar"}


def _weld_angle(v: np.ndarray) -> float:
    """A weld's angle from its rotation's image of ``e1`` in the plane (binary64; the shadow
    build encloses its cosine and sine exactly: ``PlanarConstants.weld``)."""
    return math.atan2(float(v[1]), float(v[0]))


def _ref_angle(q_ref: np.ndarray, j: _Joint) -> float:
    if j.unbounded:
        return math.atan2(q_ref[j.idx_q + 1], q_ref[j.idx_q])
    return float(q_ref[j.idx_q])


def planar_axis(mech: Mechanism) -> np.ndarray | None:
    """The common axis ``w`` of a planar mechanism (see the module docstring), or None."""
    try:
        return _analyse(mech)[0]
    except _NotPlanar:
        return None


class _NotPlanar(Exception):
    pass


def _analyse(mech: Mechanism):
    model = mech.model
    if not mech.closures:
        raise _NotPlanar("no closure")
    parents = [int(p) for p in model.parents]
    locked = mech.locked_q()
    q_ref, data = reference_configuration(mech)
    ref = [pin.SE3(M) for M in data.oMi]
    on_path: set[int] = set()
    frames: set[int] = set()
    for c in mech.closures:
        js, fs = tree_path(parents, int(c.joint_a), int(c.joint_b))
        on_path.update(js)
        frames.update(fs)
    w = None
    axes: dict[int, tuple[str, np.ndarray, Part]] = {}
    for j in sorted(on_path):
        if j in locked:
            continue
        parts = joint_parts(model.joints[j], model.names[j], model.jointPlacements[j])
        if len(parts) != 1 or parts[0].kind not in ("revolute", "prismatic") or parts[0].axis is None:
            raise _NotPlanar(f"joint {model.names[j]!r}")
        a = ref[j].rotation @ np.asarray(parts[0].axis, dtype=float)
        a = a / np.linalg.norm(a)
        axes[j] = (parts[0].kind, a, parts[0])
        if parts[0].kind == "revolute" and w is None:
            w = a
    if w is None:
        raise _NotPlanar("no revolute joint")
    for kind, a, part in axes.values():
        if kind == "revolute" and np.linalg.norm(np.cross(a, w)) > PARALLEL_TOL:
            raise _NotPlanar("axes not parallel")
        if kind == "prismatic" and abs(float(a @ w)) > PARALLEL_TOL:
            raise _NotPlanar("slide not in the plane")
        if kind == "prismatic":  # the general formulation bounds an unlimited slide
            lo, hi = part_limits(model, part)
            if not (abs(float(lo[0])) < 1e100 and abs(float(hi[0])) < 1e100):
                raise _NotPlanar("unlimited slide")
    return w, parents, locked, q_ref, ref, on_path, frames, axes


def formulate_planar(mech: Mechanism, legs: str = "auto", enclose: bool = False) -> PlanarFormulation | None:
    """The planar system of ``mech``, or None if it is not planar (:func:`planar_axis`).

    ``legs``: distance closures as ``"vector"`` (a unit vector per bar, linear loop rows; the
    default, ``"auto"``) or ``"squared"`` (one row ``|p_b - p_a|^2 = l^2``, no new variables).
    ``enclose``: the shadow build (:mod:`kinbox.formulation.enclose_rows`), its constants as
    ``EF``; the system built for a search carries its core rows' errors from it
    (``System.core_errors``, None where the shadow build does not cover the mechanism).
    """
    if legs not in PLANAR_LEGS:
        raise InputError(f"legs must be one of {', '.join(PLANAR_LEGS)}, not {legs!r}")
    check_mechanism(mech)
    try:
        w, parents, locked, q_ref, ref, on_path, frames, axes = _analyse(mech)
    except _NotPlanar:
        return None
    model = mech.model
    for c in mech.closures:
        if c.kind == "distance" and not (math.isfinite(c.length) and c.length >= 0):
            raise FormulationError(f"closure {c.name!r}: distance length is not set ({c.length})")
    # the plane's basis: for w = +-z, e1 = x
    k = int(np.argmax(np.abs(w)))
    if abs(abs(w[k]) - 1.0) < 1e-14:
        w = np.zeros(3)
        w[k] = 1.0
        e1 = np.zeros(3)
        e1[(k + 1) % 3] = 1.0
    else:
        e = np.zeros(3)
        e[int(np.argmin(np.abs(w)))] = 1.0
        e1 = e - w * float(w @ e)
        e1 /= np.linalg.norm(e1)
    E = np.vstack([e1, np.cross(w, e1)])

    ef = None

    def plane(p) -> np.ndarray:
        return E @ np.asarray(p, dtype=float) if ef is None else ef.project(p)

    if enclose:
        from .enclose_rows import PlanarConstants  # noqa: PLC0415 - mpmath, only here

        wj = next(j for j in sorted(axes) if axes[j][0] == "revolute")  # the joint w was taken from
        ef = PlanarConstants(mech, q_ref, ref, w, wj, E)

    # -- nodes, joints, rotation groups ---------------------------------------------------------
    top: dict[int, int] = {}
    joints: dict[int, _Joint] = {}
    for n in sorted(frames):
        t = n
        while t in on_path:
            t = parents[t]
        top[n] = t
    group: dict[int, int] = {}
    offset: dict[int, float] = {}
    ngroups = 0
    for n in sorted(frames):  # parents before children
        offset[n] = 0.0
        if n not in on_path:
            group[n] = 0
            continue
        p = parents[n]
        name = model.names[n]
        if n in locked:
            joints[n] = _Joint(n, name, "locked", p)
            group[n] = group[p]
            continue
        kind, a, part = axes[n]
        lo, hi = part_limits(model, part)
        j = _Joint(n, name, kind, p, idx_q=part.idx_q, nq=part.nq, unbounded=part.unbounded, lo=float(lo[0]), hi=float(hi[0]))
        if kind == "revolute":
            j.sign = 1.0 if float(a @ w) > 0 else -1.0
            j.J = plane(ref[n].translation if ef is None else ef.point(n, None, ref[n].translation)[0])
            if ef is not None:
                ef.axis(n, kind, a)
            ngroups += 1
            group[n] = ngroups
        else:
            j.u = plane(a if ef is None else ef.axis(n, kind, a))
            group[n] = group[p]
        joints[n] = j

    # welds turn two groups together: theta_a = theta_b + phi
    sys = System()
    held: list[tuple[str, float]] = []  # constant rows that must vanish (checked below)
    # the shadow build follows each offset exactly as (cos, sin) intervals (PlanarConstants.weld;
    # test_planar_enclosures.py::test_a_dropped_weld_enclosure_misses_the_root)
    zoff = {n: ef.zero_turn() for n in offset} if ef is not None else {}
    for ci, c in enumerate(mech.closures):
        if c.kind != "weld":
            continue
        na, nb = int(c.joint_a), int(c.joint_b)
        M = ref[nb].rotation @ c.placement_b.rotation @ c.placement_a.rotation.T @ ref[na].rotation.T
        if np.linalg.norm(M @ w - w) > 1e-9:
            return None  # the weld turns out of the plane: leave it to the general formulation
        phi = _weld_angle(E @ M @ e1)  # theta_a - theta_b
        zphi = ef.weld(na, c.placement_a, nb, c.placement_b, c.name or f"closure{ci}") if ef is not None else None
        ga, gb = group[na], group[nb]
        if ga == gb:
            miss = offset[na] - offset[nb] - phi
            held.append((f"weld:{c.name or ci}", math.hypot(math.cos(miss) - 1.0, math.sin(miss))))
            continue
        # merge the group of b into a's (the held group 0 always absorbs the other)
        flip = gb == 0
        if flip:
            ga, gb, na, nb, phi = gb, ga, nb, na, -phi
        shift = offset[na] - phi - offset[nb]  # theta_b = theta_a - phi
        zshift = None
        if ef is not None and zphi is not None:
            zshift = ef.compose(ef.compose(zoff[na], zphi, conj_b=not flip), zoff[nb], conj_b=True)
        for n in group:
            if group[n] == gb:
                group[n] = ga
                offset[n] += shift
                if ef is not None and zshift is not None:
                    zoff[n] = ef.compose(zoff[n], zshift)

    names = {g: None for g in set(group.values()) if g != 0}
    for n in sorted(frames):
        g = group[n]
        if g != 0 and names[g] is None and abs(offset[n]) == 0.0:
            names[g] = n
    gvars: dict[int, tuple[int, int]] = {}
    gnode: dict[int, int] = {}
    rot: dict[int, tuple] = {}
    for g in sorted(names):
        n = names[g]
        if n is None:  # every node of the group has an offset: read it at the first one
            n = min(m for m in group if group[m] == g)
        gnode[g] = n
        label = model.names[n]
        cv = sys.add_var(f"c[{label}]", -1.0, 1.0, "cos")
        sv = sys.add_var(f"s[{label}]", -1.0, 1.0, "sin")
        sys.add_eq(cv * cv + sv * sv - 1.0, f"unit:{label}")
        gvars[g] = (sys.n - 2, sys.n - 1)
    # the angle of a node from its group's angle: theta_n = theta_g + offset_n - offset_gnode
    base = {g: offset[n] for g, n in gnode.items()}
    zbase = {g: zoff[n] for g, n in gnode.items()} if ef is not None else {}
    for n in offset:
        if group[n] != 0:
            offset[n] -= base[group[n]]
            if ef is not None:
                zoff[n] = ef.compose(zoff[n], zbase[group[n]], conj_b=True)
    for n in sorted(frames):
        g, t = group[n], offset[n]
        ct, st = (math.cos(t), math.sin(t)) if ef is None else ef.turn(zoff[n], t)
        if g == 0:
            rot[n] = (ct, st)
        else:
            cv, sv = (Expr.var(i) for i in gvars[g])
            rot[n] = (_lin((ct, cv), (-st, sv)), _lin((st, cv), (ct, sv)))

    # -- positions -------------------------------------------------------------------------------
    origin: dict[int, Vec] = {}
    dvars: dict[int, int] = {}
    joint_vars: dict[str, list[str]] = {}
    for n in sorted(frames):
        if n not in on_path:
            origin[n] = [0.0, 0.0]
            continue
        j = joints[n]
        p = j.parent
        if j.kind == "locked":
            origin[n] = origin[p]
            joint_vars[j.name] = []
            continue
        if j.kind == "revolute":
            assert j.J is not None
            origin[n] = _vadd(_vadd(origin[p], _rotate(rot[p], j.J)), _rotate(rot[n], j.J), -1.0)
            g = group[n]
            joint_vars[j.name] = [sys.names[i] for i in gvars[g]] if gnode.get(g) == n else []
            if revolute_is_limited(j.lo, j.hi, j.unbounded):
                _limit(sys, j, rot[p], rot[n], float(q_ref[j.idx_q]))
        else:
            assert j.u is not None
            d = sys.add_var(f"d[{j.name}]", j.lo, j.hi, "disp")
            dvars[n] = sys.n - 1
            joint_vars[j.name] = [f"d[{j.name}]"]
            du = _rotate(rot[p], j.u)  # R_parent u
            qr = float(q_ref[j.idx_q])
            step = [(d - qr) * e if isinstance(e, Expr) else (d - qr) * num(e) for e in du]
            origin[n] = _vadd(origin[p], step)

    # -- closures --------------------------------------------------------------------------------
    bars = []
    closure_vars: dict[str, list[str]] = {}
    for ci, c in enumerate(mech.closures):
        cn = c.name or f"closure{ci}"
        na, nb = int(c.joint_a), int(c.joint_b)
        wa = ref[na] * c.placement_a
        wb = ref[nb] * c.placement_b
        pa_ref, pb_ref = plane(wa.translation), plane(wb.translation)
        ha, hb = float(w @ wa.translation), float(w @ wb.translation)
        if ef is not None:
            (ta, ha_x), (tb, hb_x) = ef.point(na, c.placement_a, wa.translation), ef.point(nb, c.placement_b, wb.translation)
            pa_ref, pb_ref = plane(ta), plane(tb)
            if c.kind in ("point", "weld"):
                ef.same_height(ha_x, hb_x, cn)
        # world point now: o_n + R_n (p_ref - o_n_ref) with o_n_ref = 0, theta_n_ref = 0
        pa = _vadd(origin[na], _rotate(rot[na], pa_ref))
        pb = _vadd(origin[nb], _rotate(rot[nb], pb_ref))
        size = 1.0 + abs(ha) + abs(hb)
        if c.kind in ("point", "weld"):
            held.append((f"height:{cn}", abs(ha - hb) / size))
            for k in range(2):
                sys.add_eq(_lin((1.0, pa[k]), (-1.0, pb[k])), f"loop:{cn}[{k}]")
            continue
        l2 = c.length**2 - (ha - hb) ** 2
        if l2 < -1e-12 * c.length**2 - 1e-300:
            held.append((f"height:{cn}", 1.0))
            continue
        length = math.sqrt(max(l2, 0.0))
        if ef is not None:
            length = ef.length(c.length, ha_x, hb_x, length)
        if length == 0.0:
            for k in range(2):
                sys.add_eq(_lin((1.0, pa[k]), (-1.0, pb[k])), f"loop:{cn}[{k}]")
            continue
        if legs == "squared":
            dx, dy = _lin((1.0, pb[0]), (-1.0, pa[0])), _lin((1.0, pb[1]), (-1.0, pa[1]))
            sys.add_eq(as_e(dx) * as_e(dx) + as_e(dy) * as_e(dy) - length * length, f"leg:{cn}")
            continue
        # the bar's direction is derived: its loop rows give it as (p_b - p_a) / l, linear in the
        # links' cosines and sines, so the search splits those only (Watt-Baranov: 10.9 against
        # 14.3 s CPU, 4669 against 4347 boxes; docs/cuiksuite.md)
        u = sys.add_var(f"dir[{cn}][0]", -1.0, 1.0, "aux")
        v = sys.add_var(f"dir[{cn}][1]", -1.0, 1.0, "aux")
        sys.add_eq(u * u + v * v - 1.0, f"unit:dir[{cn}]")
        for k, dk in enumerate((u, v)):
            sys.add_eq(_lin((1.0, pa[k]), (length, dk), (-1.0, pb[k])), f"loop:{cn}[{k}]")
        bars.append((ci, length, (sys.n - 2, sys.n - 1)))
        closure_vars[cn] = [f"dir[{cn}][0]", f"dir[{cn}][1]"]
    for name, err in held:
        if err > 1e-12:
            sys.add_eq(Expr.const(1.0), f"{name}: cannot hold in the plane")

    not_planar = rounded = None
    if not enclose:
        errors = _core_errors(mech, legs, sys)
        if isinstance(errors, _Rounded):
            rounded, errors = errors.why, None
        not_planar = errors if isinstance(errors, str) else None
        sys.core_errors = None if isinstance(errors, str) else errors
    if ef is not None and ef.unproven:  # the shadow build: the model may not be planar as given
        rounded = ef.unproven[0]
    dropped = [model.names[j] for j in range(1, model.njoints) if j not in on_path and j not in locked]
    impl = _Impl(w, E, q_ref, ref, top, joints, group, offset, gvars, gnode, dvars, bars, locked)
    return PlanarFormulation(mech, sys, dropped, joint_vars, closure_vars, impl, not_planar=not_planar, rounded=rounded)


@dataclass
class _Rounded:
    """The shadow build does not cover the model: why (the rows are taken as rounded)."""

    why: str


def _core_errors(mech: Mechanism, legs: str, sys: System):
    """The core rows' distance to those of the model as given (``System.core_errors``) from
    the shadow build (:mod:`kinbox.formulation.enclose_rows`), None where it does not cover
    the mechanism (the rows are then taken as rounded; :class:`_Rounded`, why), or why the model
    as given is not exactly planar (a str: ``enclose_rows.NotPlanar``)."""
    from . import enclose_rows  # noqa: PLC0415 - mpmath's interval arithmetic, only here

    try:
        shadow = formulate_planar(mech, legs, enclose=True)
    except enclose_rows.NotPlanar as exc:
        return str(exc)
    except enclose_rows.NotEnclosed as exc:
        return _Rounded(str(exc))
    if shadow is not None and shadow.rounded:
        return _Rounded(shadow.rounded)
    return None if shadow is None else enclose_rows.core_errors(sys, shadow.system)


def circles_and_lines(system: System) -> bool:
    """Is ``system`` square with every core row linear but the unit circles ``c^2 + s^2 = 1``
    of its cosine/sine pairs (and no inequality)? Its linear relaxation is then exact on every
    other row, and LP rounds that bound every variable on every box settle it in few boxes
    (:meth:`kinbox.problems.mechanism.Problem.search_defaults`; tests/formulation/test_planar.py)."""
    if not system.is_square or system.count("ineq") or system.count("redundant"):
        return False
    for c in system.constraints:
        quad = {k: v for k, v in c.expr.terms.items() if len(k) == 2}
        if not quad:
            continue
        keys = sorted(quad)
        if len(keys) != 2 or any(k[0] != k[1] or quad[k] != 1.0 for k in keys) or len(c.expr.terms) != 3:
            return False
        if c.expr.terms.get((), 0.0) != -1.0:
            return False
        if {system.tags[keys[0][0]], system.tags[keys[1][0]]} != {"cos", "sin"}:
            return False
    return True


def as_e(a) -> Expr:
    return a if isinstance(a, Expr) else Expr.const(num(a))


def _limit(sys: System, j: _Joint, rp: tuple, rc: tuple, qr: float) -> None:
    """``cos(t - mid) >= cos(half)`` for the relative angle ``t`` of a limited revolute joint
    (``q = q_ref + sign t`` in ``[lo, hi]``): exactly the allowed arc."""
    a, b = sorted((j.sign * (j.lo - qr), j.sign * (j.hi - qr)))
    mid, half = 0.5 * (a + b), 0.5 * (b - a)
    (cp, sp), (cc, sc) = (as_e(v) for v in rp), (as_e(v) for v in rc)
    ct = cc * cp + sc * sp  # cos t = cos(theta_c - theta_p)
    st = sc * cp - cc * sp
    pad = 8 * np.finfo(float).eps
    sys.add_ineq((math.cos(half) - pad) - (ct * math.cos(mid) + st * math.sin(mid)), f"limit:{j.name}")
