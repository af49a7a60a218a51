"""From a :class:`~kinbox.mechanism.Mechanism` to a quadratic :class:`~kinbox.system.System`.

:func:`formulate` follows ``docs/formulation.md``:

1. **What enters.** Only joints on the tree path between the two ends of some closure enter
   the system; the others are *dropped* (``Formulation.dropped_joints``, decoded at
   ``pin.neutral``). Locked joints on a path are constants (their motion at the locked value).
   Each connected piece of the union of the paths is a subtree; its top frame (the world, or
   the lowest common ancestor of its closures) is held at its pose for the reference
   configuration (neutral ``q`` with the locked values): the loops inside it only fix relative
   poses.
2. **Orientations.** Breadth-first from known orientations (the top frames) over the graph
   whose edges are the joints and the weld closures; a revolute hop costs one, constant
   relations (prismatic, translation, locked joints, welds) cost zero, free rotations
   (spherical, free-flyer) are not crossed. A part of the graph no known frame reaches gets a
   free rotation (9 variables) at the child of a free joint, and the search goes on. Edges
   not used to reach a frame get closing equations. The pair equations are in
   :mod:`kinbox.formulation.pairs` (one module per pair family).
3. **Positions.** ``o_i = o_p + R_p t_p + (joint term)`` down the tree, no variables except a
   free-flyer's world position ``t``, eliminated at the end with
   :meth:`System.eliminate_linear`.
4. **Closures.** Point, weld (point part; the orientation part seeded the search or closed an
   orientation cycle) and distance closures give the loop equations.

:class:`Formulation` maps a Pinocchio ``q`` to a system point (:meth:`Formulation.encode`)
and back (:meth:`Formulation.decode`, see :mod:`kinbox.decode`).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from ..errors import FormulationError, InputError, finite_vector
from ..model.mechanism import Mechanism, check_mechanism
from . import pairs
from .options import LEGS
from .pairs import PLACEHOLDER_BOUND  # domain of an unlimited translation, eliminated later
from .system import Constraint, Expr, System

#: the identity rotation
I3 = np.eye(3)


@dataclass(eq=False)
class _Node:
    name: str  # joint name, "joint/k" for the frame after part k of a composite, "universe"
    joint: int  # Pinocchio joint id of the joint this frame belongs to
    root: int  # node index of the top frame of its piece
    edge: int | None = None  # tree edge whose child this is (None for a top frame)
    R: pairs.Rot | None = None
    o: list | None = None

    @property
    def rot(self) -> pairs.Rot:
        """Its orientation, once the walk has reached it."""
        if self.R is None:  # pragma: no cover - a formulation bug
            raise FormulationError(f"internal: frame {self.name!r} has no orientation yet")
        return self.R


@dataclass(eq=False)
class _Edge:
    name: str  # variable stem: joint name, or "joint/k" for part k of a composite
    joint: str  # joint (or closure) name
    jid: int  # Pinocchio joint id (-1 for a weld closure)
    kind: str
    parent: int
    child: int
    Rp: np.ndarray
    tp: np.ndarray
    K: np.ndarray  # constant relative rotation (const edges): R_child = R_parent K
    part: pairs.Part | None = None
    B: np.ndarray | None = None
    labels: tuple[str, str] = ("0", "1")
    vars: dict = field(default_factory=dict)

    @property
    def family(self) -> pairs.PairFamily:
        return pairs.family(self.kind)

    @property
    def pt(self) -> pairs.Part:
        """Its pair part (every edge of a joint has one; weld closures and fixed edges do not)."""
        if self.part is None:  # pragma: no cover - a formulation bug
            raise FormulationError(f"internal: edge {self.name!r} has no pair part")
        return self.part

    @property
    def rot_kind(self) -> str:
        """``"rev"``, ``"const"`` or ``"free"`` (:attr:`PairFamily.rotation`)."""
        return self.family.rotation


@dataclass
class _Impl:
    """Everything :meth:`Formulation.encode`/``decode`` need (not part of the public API)."""

    full: System  # the system before the elimination of free-flyer translations
    nodes: list[_Node]
    edges: list[_Edge]  # tree edges, then weld closures
    n_tree: int
    jnode: dict[int, int]  # joint id -> node index
    q_ref: np.ndarray
    ref_poses: list[pin.SE3]  # data.oMi at q_ref
    locked: dict[int, np.ndarray]
    getters: dict[int, tuple]  # full-system variable index -> how to read it (see _read)
    defs: dict[int, Expr]  # full-system aux variable index -> defining expression
    keep: np.ndarray  # full-system indices of the final system's variables
    closure_ends: list  # per closure: (node a, placement a, node b, placement b)


@dataclass
class Formulation:
    """A mechanism, its polynomial system and the maps between ``q`` and system points."""

    mechanism: Mechanism
    system: System
    dropped_joints: list[str]
    #: every joint that enters the system (on a closure path, not locked) -> names of its
    #: variables in ``system`` (materialized columns included). The list may be empty: a
    #: spherical joint, or a free-flyer whose frame is reached by propagation, has no variable
    #: of its own (its frames' orientations carry its motion).
    joint_vars: dict[str, list[str]]
    #: closure name -> names of its variables in ``system`` (unit vectors of distance closures)
    closure_vars: dict[str, list[str]] = field(default_factory=dict)
    #: what :meth:`encode` and :meth:`decode` need (internal to the formulation stage)
    impl: _Impl | None = field(default=None, repr=False)
    kind: str = "general"

    # ------------------------------------------------------------------------------------------
    def encode(self, q: np.ndarray) -> np.ndarray:
        """The system point of a Pinocchio configuration ``q`` (forward kinematics by Pinocchio).

        Exact (up to rounding) when ``q`` satisfies the closures and the locked values; the
        top frame of a piece not attached to the world is moved to its reference pose first.
        """
        impl = self.impl
        assert impl is not None  # every Formulation that formulate() returns has one
        model = self.mechanism.model
        q = finite_vector(q, model.nq, "q", f"model {self.mechanism.name!r} has nq = {model.nq}")
        poses = _node_poses(impl, model, q)
        full = impl.full
        x = np.zeros(full.n)
        for i in range(full.n):
            if i in impl.getters:
                x[i] = _read(impl, impl.getters[i], poses)
            elif i in impl.defs:
                x[i] = impl.defs[i].value(x)
            else:  # pragma: no cover - a formulation bug
                raise FormulationError(f"internal: no way to encode variable {full.names[i]!r}")
        return x[impl.keep]

    def decode(self, x: np.ndarray) -> np.ndarray:
        """The Pinocchio ``q`` of a system point ``x`` (see :func:`kinbox.decode.decode`)."""
        from .decode import decode

        return decode(self, x)

    #: every joint limit is kept by the system (:class:`~kinbox.formulation.protocol.MechanismFormulation`)
    limits_after = False

    def admissible(self, x: np.ndarray, width: float = 0.0) -> bool:
        """Always: the system keeps every joint limit."""
        return True

    def summary(self) -> dict:
        s = self.system.summary()
        s["dropped_joints"] = list(self.dropped_joints)
        s["eliminated"] = list(self.system.eliminated)
        return s


# ----------------------------------------------------------------------------------------------
def reference_configuration(mech: Mechanism) -> tuple[np.ndarray, pin.Data]:
    """``(q_ref, data)``: the neutral configuration with the locked joints at their values, and
    Pinocchio's data there (``oMi``, ``liMi``), from which the formulations write the loops."""
    model = mech.model
    q_ref = pin.neutral(model)
    for jid, v in mech.locked_q().items():
        j = model.joints[jid]
        q_ref[j.idx_q : j.idx_q + j.nq] = v
    data = model.createData()
    pin.forwardKinematics(model, data, q_ref)
    return q_ref, data


def tree_path(parents, a: int, b: int) -> tuple[list[int], list[int]]:
    """(joints on the tree path between a and b, frames on it incl. the common ancestor)."""
    up_a = [a]
    while up_a[-1] != 0:
        up_a.append(parents[up_a[-1]])
    up_b = [b]
    while up_b[-1] != 0:
        up_b.append(parents[up_b[-1]])
    sb = set(up_b)
    lca = next(n for n in up_a if n in sb)
    ja = up_a[: up_a.index(lca)]
    jb = up_b[: up_b.index(lca)]
    return ja + jb, ja + jb + [lca]


def _closure_names(mech: Mechanism) -> list[str]:
    out, seen = [], set()
    for k, c in enumerate(mech.closures):
        n = c.name or f"{c.kind}{k}"
        if n in seen:
            n = f"{n}#{k}"
        seen.add(n)
        out.append(n)
    return out


def formulate(mech: Mechanism, legs: str = "auto") -> Formulation:
    """Build the quadratic system of ``mech`` (see the module docstring and the design doc).

    ``legs`` chooses the equations of distance closures (:func:`joints.distance_closure`):
    ``"squared"`` (``|pb - pa|^2 = l^2``, where both ends are linear in bounded unknowns: the
    fewest variables, fastest on isolated assembly modes), ``"vector"`` (``pa + l d = pb`` with a
    unit leg vector ``d``: more variables, but tighter relaxations, much faster on mobile
    platforms whose solution set is a curve), ``"auto"`` (``"squared"`` where it applies).

    The steps of the module docstring, in order, each a method of :class:`_Steps`.
    """
    if legs not in LEGS:
        raise InputError(f"legs must be one of {', '.join(LEGS)}, not {legs!r}")
    check_mechanism(mech)
    st = _Steps(mech, legs)
    st.joints_that_enter()
    st.frames_and_edges()
    st.orientations()
    st.closing_equations()
    st.positions()
    st.closures()
    st.eliminate_free_flyers()
    st.vector_legs()
    form = st.formulation()
    st.final.core_errors = _core_errors(mech, legs, st.final)
    return form


def _core_errors(mech: Mechanism, legs: str, final: System):
    """The core rows' distance to those of the model as given (``System.core_errors``), from
    the shadow build of :mod:`kinbox.formulation.enclose_rows`; None where it does not cover
    the mechanism (the rows are then taken as rounded)."""
    from . import enclose_rows  # noqa: PLC0415 - mpmath's interval arithmetic, only here

    try:
        sh = _Steps(mech, legs, enclose=True)
        sh.joints_that_enter()
        sh.frames_and_edges()
        sh.orientations()
        sh.closing_equations()
        sh.positions()
        sh.closures()
        sh.eliminate_free_flyers()
    except (enclose_rows.NotEnclosed, FormulationError, ZeroDivisionError):
        return None
    return enclose_rows.core_errors(final, sh.final)


def _idx(e: Expr) -> int:
    """The index of the variable ``e`` is."""
    (k,) = next(iter(e.terms))
    return k


class _Steps:
    """The state :func:`formulate` builds up, one step (method) at a time."""

    def __init__(self, mech: Mechanism, legs: str, enclose: bool = False):
        #: the shadow build (:mod:`kinbox.formulation.enclose_rows`): constants as ``EF``
        self.enclose = enclose
        self.mech = mech
        self.legs = legs
        self.model = model = mech.model
        self.parents = [int(p) for p in model.parents]
        self.locked = mech.locked_q()
        self.cnames = _closure_names(mech)
        for c, cn in zip(mech.closures, self.cnames):
            if c.kind == "distance" and not (math.isfinite(c.length) and c.length >= 0):
                raise FormulationError(f"closure {cn!r}: distance length is not set ({c.length})")
        self.q_ref, self.data = reference_configuration(mech)
        self.ref_poses = [pin.SE3(M) for M in self.data.oMi]
        self.sys = System()
        self.getters: dict[int, tuple] = {}  # variable index -> how to read it off the poses (_read)
        self.nodes: list[_Node] = []
        self.edges: list[_Edge] = []
        self.jnode: dict[int, int] = {}
        self.closure_ends: list = []
        self.used: set[int] = set()  # edges the orientations were propagated over
        # o_child = o_parent + R_parent tp + joint term: the two steps of each frame (None for a
        # free-flyer's frame, whose position is its own variable), for the projected loops
        self.steps: dict[int, tuple[list, list] | None] = {}
        self.ff_vars: list[tuple[str, list[Expr], bool]] = []
        self.closure_dirs: dict[str, list[Expr]] = {}

    # -- 1. what enters ----------------------------------------------------------------------
    def joints_that_enter(self) -> None:
        """The joints on the tree path of some closure, the frames on those paths, and the
        joints dropped (on no path, not locked)."""
        model = self.model
        self.on_path: set[int] = set()
        self.frames: set[int] = set()
        for c in self.mech.closures:
            js, fs = tree_path(self.parents, int(c.joint_a), int(c.joint_b))
            self.on_path.update(js)
            self.frames.update(fs)
        self.dropped = [model.names[j] for j in range(1, model.njoints) if j not in self.on_path and j not in self.locked]

    def frames_and_edges(self) -> None:
        """Frames (nodes) and joints (edges), parents before children; then the weld closures'
        edges."""
        model, nodes, edges, jnode = self.model, self.nodes, self.edges, self.jnode
        for j in sorted(self.frames):
            name = model.names[j]
            if j not in self.on_path:  # top frame of a piece
                jnode[j] = len(nodes)
                nodes.append(_Node(name, j, len(nodes)))
                continue
            p = jnode[self.parents[j]]
            root = nodes[p].root
            if j in self.locked:
                L = self.data.liMi[j]
                Rp, tp = pairs.snap(L.rotation), pairs.snap(L.translation)
                if self.enclose:
                    Rp, tp = (pairs.snap(a) for a in self._ef().relative(model, self.parents[j], j, self.q_ref, L))
                jnode[j] = len(nodes)
                nodes.append(_Node(name, j, root, edge=len(edges)))
                edges.append(_Edge(name, name, j, "fixed", p, jnode[j], Rp, tp, Rp))
                continue
            parts = pairs.joint_parts(model.joints[j], name, model.jointPlacements[j])
            if self.enclose:
                axes = self._ef().part_axes(model.joints[j], parts)
                places = self._ef().part_placements(model.joints[j], model.jointPlacements[j], parts)
            for k, part in enumerate(parts):
                last = k == len(parts) - 1
                stem = name if len(parts) == 1 else f"{name}/{k}"
                child = len(nodes)
                nodes.append(_Node(name if last else stem, j, root, edge=len(edges)))
                Rp, tp = pairs.snap(part.placement.rotation), pairs.snap(part.placement.translation)
                if self.enclose:
                    Rp, tp = (pairs.snap(a) for a in places[k])
                e = _Edge(stem, name, j, part.kind, p, child, Rp, tp, Rp, part=part)
                if part.axis is not None:
                    e.B, e.labels = pairs.axis_basis(part.axis)
                    if self.enclose:
                        e.B = self._ef().basis(axes[k][0], e.B, axes[k][1])
                    part.axis = e.B[:, 2].copy()
                edges.append(e)
                p = child
            jnode[j] = p
        self.n_tree = len(edges)
        for c, cn in zip(self.mech.closures, self.cnames):
            na, nb = jnode[int(c.joint_a)], jnode[int(c.joint_b)]
            self.closure_ends.append((na, c.placement_a, nb, c.placement_b))
            if c.kind == "weld":
                Ka, Kb = pairs.snap(c.placement_a.rotation), pairs.snap(c.placement_b.rotation)
                if self.enclose:
                    Ka, Kb = self._ef().given(c.placement_a)[0], self._ef().given(c.placement_b)[0]
                edges.append(_Edge(cn, cn, -1, "weld", na, nb, I3, np.zeros(3), pairs.snap(Ka @ Kb.T)))

    # -- the constants of the model as given (the shadow build) ------------------------------
    def _ef(self):
        from . import enclose_rows  # noqa: PLC0415 - mpmath's interval arithmetic, only here

        return enclose_rows

    def _top(self, joint: int) -> tuple[np.ndarray, np.ndarray]:
        """The pose of a top frame at the reference configuration (Pinocchio's, in binary64;
        in the shadow build with its distance to the model's exact pose)."""
        M = self.ref_poses[joint]
        if not self.enclose:
            return M.rotation, M.translation
        if joint == 0:
            return self._ef().ef_array(M.rotation, 0.0), self._ef().ef_array(M.translation, 0.0)
        return self._ef().relative(self.model, 0, joint, self.q_ref, M)

    def _trans(self, P: pin.SE3) -> np.ndarray:
        """A closure point's translation (exact as given: an ``EF`` of no error in the shadow build)."""
        return self._ef().ef_array(P.translation, 0.0) if self.enclose else P.translation

    # -- 2. orientations ---------------------------------------------------------------------
    def angle_vars(self, e: _Edge) -> tuple[Expr, Expr]:
        """The cosine and sine of a revolute edge's angle, made at their first use."""
        if "c" not in e.vars:
            c, s = e.family.angle(self.sys, e.name, e.pt, *pairs.part_limits(self.model, e.pt))
            e.vars["c"], e.vars["s"] = c, s
            self.getters[_idx(c)] = ("rel_rot", self.edges.index(e), 0)
            self.getters[_idx(s)] = ("rel_rot", self.edges.index(e), 1)
        return e.vars["c"], e.vars["s"]

    def propagate(self, e: _Edge, src: int, dst: int) -> pairs.Rot:
        """The orientation of frame ``dst`` from that of ``src`` across edge ``e``."""
        forward = src == e.parent
        known = self.nodes[src].rot
        if e.rot_kind == "const":
            return pairs.const_propagate(known, e.K, forward)
        B = e.B if e.B is not None else I3
        c, s = self.angle_vars(e)
        return pairs.revolute_propagate(self.sys, e.name, known, e.Rp, B, e.labels, c, s, forward, self.nodes[dst].name)

    def orientations(self) -> None:
        """0-1 breadth-first search from the known orientations (the top frames); a free
        rotation for a frame none of them reaches, and the search goes on."""
        nodes, edges = self.nodes, self.edges
        adj: list[list[int]] = [[] for _ in nodes]
        for k, e in enumerate(edges):
            adj[e.parent].append(k)
            if e.child != e.parent:
                adj[e.child].append(k)
        best: dict[int, tuple[int, int | None, int | None]] = {}
        done: set[int] = set()
        dq: deque = deque()
        for n, node in enumerate(nodes):
            if node.edge is None:
                node.R = pairs.Rot.const(self._top(node.joint)[0])
                best[n] = (0, None, None)
                dq.append((0, n))
        while True:
            while dq:
                d, n = dq.popleft()
                if n in done or best[n][0] != d:
                    continue
                done.add(n)
                _, ek, src = best[n]
                if ek is not None and src is not None:
                    self.used.add(ek)
                    nodes[n].R = self.propagate(edges[ek], src, n)
                for k in adj[n]:
                    e = edges[k]
                    if e.rot_kind == "free":
                        continue
                    m = e.child if e.parent == n else e.parent
                    if m in done:
                        continue
                    w = 0 if e.rot_kind == "const" else 1
                    if m not in best or d + w < best[m][0]:
                        best[m] = (d + w, k, n)
                        if w == 0:
                            dq.appendleft((d, m))
                        else:
                            dq.append((d + 1, m))
            if len(done) == len(nodes):
                break
            n = self._unreached(done)
            nodes[n].R = pairs.free_rotation(self.sys, nodes[n].name)
            for r in range(3):
                for cc in range(3):
                    self.getters[self.sys.index(f"R[{nodes[n].name}][{r},{cc}]")] = ("rot", n, r, cc)
            best[n] = (0, None, None)
            dq.append((0, n))

    def _unreached(self, done: set[int]) -> int:
        """The frame to give a free rotation: the far end of a free joint from a reached frame."""
        for e in self.edges[: self.n_tree]:
            if e.rot_kind == "free" and e.parent in done and e.child not in done:
                return e.child
        for e in self.edges[: self.n_tree]:
            if e.rot_kind == "free" and e.child in done and e.parent not in done:
                return e.parent
        return min(set(range(len(self.nodes))) - done)  # pragma: no cover - every unreached piece hangs on a free joint

    def closing_equations(self) -> None:
        """The orientation equations of the edges the search did not cross."""
        for k, e in enumerate(self.edges):
            if k in self.used or e.rot_kind == "free":
                continue
            Rpar, Rch = self.nodes[e.parent].rot, self.nodes[e.child].rot
            if e.rot_kind == "rev":
                c, s = self.angle_vars(e)
                B = e.B if e.B is not None else I3
                pairs.revolute_closing(self.sys, e.name, Rpar, e.Rp, Rch, B, c, s)
            else:
                pairs.weld_orientation(self.sys, e.name, Rpar, e.K, Rch, I3)

    # -- 3. positions ------------------------------------------------------------------------
    def positions(self) -> None:
        """``o_i = o_p + R_p t_p + (joint term)`` down the tree; a free-flyer's world position
        is a variable of its own."""
        sys, model, getters = self.sys, self.model, self.getters
        for n, node in enumerate(self.nodes):
            if node.edge is None:
                node.o = list(self._top(node.joint)[1]) if self.enclose else [float(v) for v in self.ref_poses[node.joint].translation]
                continue
            e = self.edges[node.edge]
            par = self.nodes[e.parent]
            fixed_step = pairs.mat_vec_const(par.rot.M, e.tp)
            self.steps[n] = (fixed_step, [0.0, 0.0, 0.0])
            base = pairs.vadd(par.o, fixed_step)
            if e.family.translation == "world":  # a free-flyer: its world position
                lo, hi = (a[:3] for a in pairs.part_limits(model, e.pt))
                limited = all(pairs.finite_limit(lo[k], hi[k]) for k in range(3))
                fixed_pre = par.rot.is_const and all(not isinstance(v, Expr) for v in base)
                dlo, dhi = np.full(3, -PLACEHOLDER_BOUND), np.full(3, PLACEHOLDER_BOUND)
                if fixed_pre and limited:  # world box of base + R_pre [lo, hi] (binary64 in both builds)
                    Rpre = np.asarray(par.rot.M, dtype=float) @ np.asarray(e.Rp, dtype=float)
                    mid, rad = np.array(base, dtype=float) + Rpre @ (0.5 * (lo + hi)), np.abs(Rpre) @ (0.5 * (hi - lo))
                    pad = 1e-9 * (1.0 + np.abs(mid) + rad)
                    dlo, dhi = mid - rad - pad, mid + rad + pad
                t = pairs.free_flyer_translation(sys, e.name, dlo, dhi)
                if fixed_pre:
                    pairs.free_flyer_limits(sys, e.name, t, base, pairs.mat_mul_const(par.rot.M, e.Rp), lo, hi)
                for k in range(3):
                    getters[_idx(t[k])] = ("pos", n, k)
                self.ff_vars.append((e.joint, t, fixed_pre and limited))
                e.vars["t"] = t
                node.o = list(t)
                self.steps[n] = None
            elif e.family.translation == "local":
                dv, local = [], []
                for v, a in e.family.displacements(sys, e.name, e.pt, *pairs.part_limits(model, e.pt)):
                    dv.append(v)
                    local.append(a)
                e.vars["d"] = dv
                for k, v in enumerate(dv):
                    getters[_idx(v)] = ("disp", node.edge, local[k])
                Rpre = pairs.mat_mul_const(par.rot.linear(), e.Rp)
                term = [0.0, 0.0, 0.0]
                for v, a in zip(dv, local):
                    term = pairs.vadd(term, pairs.vscale(v, pairs.mat_vec_const(Rpre, a)))
                node.o = pairs.vadd(base, term)
                self.steps[n] = (fixed_step, term)
            else:  # no translation of their own (revolute, spherical, fixed)
                node.o = base

    # -- 4. closures -------------------------------------------------------------------------
    def closures(self) -> None:
        """The loop equations of point, weld and distance closures, and the projected loops
        along runs of parallel revolute axes."""
        nodes = self.nodes
        for ci, (c, cn, (na, Pa, nb, Pb)) in enumerate(zip(self.mech.closures, self.cnames, self.closure_ends)):
            ta, tb = self._trans(Pa), self._trans(Pb)
            pa = pairs.vadd(nodes[na].o, pairs.mat_vec_const(nodes[na].rot.M, pairs.snap(ta)))
            pb = pairs.vadd(nodes[nb].o, pairs.mat_vec_const(nodes[nb].rot.M, pairs.snap(tb)))
            if c.kind in ("point", "weld"):
                pairs.point_closure(self.sys, cn, pa, pb)
            else:
                length = self._ef().length(c.length) if self.enclose else float(c.length)
                dv = pairs.distance_closure(self.sys, cn, pa, pb, length, squared=self.legs != "vector")
                self.closure_dirs[cn] = dv
                for k, v in enumerate(dv):
                    self.getters[_idx(v)] = ("dir", ci, float(c.length), k)
            if c.kind in ("point", "weld"):
                ends = (na, pairs.snap(ta)), (nb, pairs.snap(tb))
                _projected_loops(self.sys, cn, nodes, self.edges, self.steps, *ends)

    def eliminate_free_flyers(self) -> None:
        """The final system: the full one with the free-flyers' translations eliminated."""
        full = self.sys
        final = full
        for jname, t, has_domain in self.ff_vars:
            names = [full.names[_idx(v)] for v in t]
            try:
                final = final.eliminate_linear(names)
            except FormulationError as exc:
                if not has_domain:
                    raise FormulationError(
                        f"free-flyer joint {jname!r}: its translation cannot be eliminated ({exc}) and "
                        f"it has no finite position limits under a fixed frame"
                    ) from None
        self.final = final

    def vector_legs(self) -> None:
        """Vector legs: their squared form (redundant), and which are derived.

        A leg vector its loop rows give as a linear function of other variables (d = -e / c) is
        derived: not split and not bounded by LPs, like a rotation's third column, unless another
        leg's loop rows read it (as the first leg's vector after a platform's translation was
        eliminated): the derived ones then never depend on each other. Fewer LPs per box on a
        mobile platform, for about as many boxes (benchmarks/mobile.py; tests/formulation/test_formulation.py,
        vector legs get their squared form and are derived)."""
        full, final = self.sys, self.final
        legs_from: dict[str, tuple[list[str], set[int]]] = {}
        for cn, dv in self.closure_dirs.items():
            dnames = [full.names[_idx(v)] for v in dv]
            inputs = squared_leg(final, cn, dnames)
            if inputs is not None:
                legs_from[cn] = (dnames, inputs)
        read = set().union(*(inputs for _, inputs in legs_from.values()))
        for dnames, _ in legs_from.values():
            ids = [final.index(nm) for nm in dnames]
            if read.isdisjoint(ids):
                for i in ids:
                    final.tags[i] = "aux"

    # -- the formulation ---------------------------------------------------------------------
    def formulation(self) -> Formulation:
        """The maps between ``q`` and system points, and the names of each joint's variables."""
        full, final, model = self.sys, self.final, self.model
        defs = {}
        by_name = {c.name: c for c in full.constraints if c.name.startswith("def:")}
        for i, nm in enumerate(full.names):
            if i not in self.getters:
                con = by_name.get(f"def:{nm}")
                if con is None:  # pragma: no cover
                    raise FormulationError(f"internal: variable {nm!r} has neither a getter nor a definition")
                defs[i] = Expr.var(i) - con.expr  # v - (v - e) = e
        keep = np.array([full.index(nm) for nm in final.names], dtype=np.int64)

        stems = {}
        for node in self.nodes:
            stems[node.name] = model.names[node.joint]
        for e in self.edges[: self.n_tree]:
            stems[e.name] = e.joint
        joint_vars: dict[str, list[str]] = {model.names[j]: [] for j in sorted(self.on_path) if j not in self.locked}
        closure_vars = {cn: [full.names[_idx(v)] for v in dv] for cn, dv in self.closure_dirs.items()}
        for nm in final.names:
            owner = _owner(nm, stems)
            if owner is not None and not nm.startswith("dir["):
                joint_vars.setdefault(owner, []).append(nm)

        for node in self.nodes:  # nothing is materialized after this point; keep the object picklable
            node.rot._make_linear = None
        impl = _Impl(
            full=full,
            nodes=self.nodes,
            edges=self.edges,
            n_tree=self.n_tree,
            jnode=self.jnode,
            q_ref=self.q_ref,
            ref_poses=self.ref_poses,
            locked=self.locked,
            getters=self.getters,
            defs=defs,
            keep=keep,
            closure_ends=self.closure_ends,
        )
        return Formulation(
            mechanism=self.mech, system=final, dropped_joints=self.dropped, joint_vars=joint_vars, closure_vars=closure_vars, impl=impl
        )


def _projected_loops(
    sys: System,
    name: str,
    nodes: list[_Node],
    edges: list[_Edge],
    steps: dict,
    end_a: tuple[int, np.ndarray],
    end_b: tuple[int, np.ndarray],
) -> None:
    """Redundant loop equations along the common axis of consecutive parallel revolute joints.

    The frames of a run of revolute joints with parallel axes (and the frame the run hangs
    from) all see the run's world axis ``w`` as a constant vector ``b_f`` (``w = R_f b_f``), so
    every displacement fixed in one of them has a constant component along ``w`` (so has a
    displacement along the axis of a joint right after them). Projecting the loop equation
    ``pa - pb = 0`` on ``w`` and replacing those components by their constants gives an
    equation that holds at every solution but that no linear combination of the loop
    equations gives (``w`` is a variable): for an arm with three parallel joints (UR5) it ties
    the base angle to the wrist, as the closed-form solutions do. Only runs whose axes are
    parallel to 1e-15 (exactly, after snapping, for URDF axes and rotations) are used, so the
    constants are exact up to rounding, like every other constant of the system.
    """
    terms, chains = _loop_terms(nodes, edges, steps, end_a, end_b)
    runs = [r for chain in chains for r in _parallel_runs(edges, chain)]
    for run in runs:
        first = edges[run[0]]
        b = {first.parent: first.Rp @ _axis(first), first.child: _axis(first)}
        for e in run[1:]:
            b[edges[e].child] = edges[e].Rp.T @ b[edges[e].parent]

        def constant(f: int, v: np.ndarray):
            """``w^T R_f v`` if it is a constant, else None."""
            if f in b:
                return float(b[f] @ v)
            ef = nodes[f].edge
            e = edges[ef] if ef is not None else None
            if e is not None and e.kind == "revolute" and e.parent in b and _exactly_parallel(v, _axis(e)):
                return float(b[e.parent] @ (e.Rp @ v))  # v on f's axis: fixed in its parent
            return None

        ws = [pairs.mat_vec_const(nodes[f].rot.M, bf) for f, bf in b.items()]
        w = min(ws, key=lambda v: (max(pairs.deg(x) for x in v), len(set().union(*[x.variables() for x in v if isinstance(x, Expr)]))))
        for f, v in zip(b, ws):  # the same w seen from frames reached by other paths
            for k in range(3):
                pairs.add_eq(sys, pairs.simplify(w[k] - v[k]), f"axis-run:{first.joint}:{nodes[f].name}[{k}]", redundant=True)
        total = 0.0
        try:
            for sign, kind, n, v, vec in terms:
                c = None
                if kind == "step":
                    c = constant(edges[nodes[n].edge].parent, v)
                elif kind == "end":
                    c = constant(n, v)
                total = total + sign * (c if c is not None else pairs.vdot(w, vec))
        except FormulationError:
            continue  # a product of degree > 2: not worth new variables
        pairs.add_eq(sys, pairs.simplify(total), f"axis-loop:{name}:{first.joint}", redundant=True)


def _loop_terms(nodes: list[_Node], edges: list[_Edge], steps: dict, end_a: tuple, end_b: tuple):
    """The loop ``pa - pb`` as signed terms ``(sign, kind, frame, constant vector, Expr vector)``:
    ``"step"``: ``R_parent tp`` into a frame; ``"end"``: ``R P`` of a closure point; ``"joint"``:
    a joint's own translation; ``"free"``: a free-flyer frame's absolute position. Also the
    edges of the tree path on each side of the loop, from the common frame down."""

    def up(n):  # frames from n to its top frame
        out = [n]
        while nodes[out[-1]].edge is not None:
            out.append(edges[nodes[out[-1]].edge].parent)
        return out

    ua, ub = up(end_a[0]), up(end_b[0])
    lca = next(n for n in ua if n in set(ub))
    terms, chains, reached = [], [], []
    for sign, (n, P) in ((1.0, end_a), (-1.0, end_b)):
        terms.append((sign, "end", n, P, pairs.mat_vec_const(nodes[n].rot.M, P)))
        chain, ok = [], True
        while n != lca:
            st = steps.get(n)
            if st is None:
                terms.append((sign, "free", n, None, nodes[n].o))
                ok = False
                break
            terms.append((sign, "step", n, edges[nodes[n].edge].tp, st[0]))
            terms.append((sign, "joint", n, None, st[1]))
            chain.append(nodes[n].edge)
            n = edges[nodes[n].edge].parent
        reached.append(ok)
        chains.append(chain[::-1])
    if reached[0] != reached[1]:  # one side starts at a free-flyer: the other at the common frame
        terms.append((1.0 if reached[0] else -1.0, "free", lca, None, nodes[lca].o))
    return terms, chains


def _axis(e: _Edge) -> np.ndarray:
    """The unit axis of a revolute or prismatic edge (in its child's frame)."""
    a = e.pt.axis
    if a is None:  # pragma: no cover - a formulation bug
        raise FormulationError(f"internal: edge {e.name!r} has no axis")
    return a


def _parallel_runs(edges: list[_Edge], chain: list[int]) -> list[list[int]]:
    """Maximal runs (two edges or more) of consecutive revolute edges with exactly parallel
    axes in ``chain`` (edges from the top down)."""
    runs: list[list[int]] = []
    run: list[int] = []
    axis: np.ndarray | None = None
    for k in chain:
        e = edges[k]
        if e.kind != "revolute":
            run, axis = [], None
        elif run and axis is not None and _exactly_parallel(e.Rp @ _axis(e), axis):
            run.append(k)
            axis = e.Rp.T @ axis
        else:
            run, axis = [k], _axis(e)
        if len(run) == 2:
            runs.append(run)  # the list grows in place while the run goes on
    return runs


def _exactly_parallel(u: np.ndarray, v: np.ndarray) -> bool:
    """Are unit vectors ``u`` and ``v`` parallel (or opposite) up to rounding?"""
    return bool(np.all(np.abs(np.cross(u, v)) <= 1e-15))


def _owner(name: str, stems: dict[str, str]) -> str | None:
    i = name.find("[")
    if i < 0:
        return None
    p = name.find("]", i + 1)
    while p >= 0:
        cand = name[i + 1 : p]
        if cand in stems:
            return stems[cand]
        p = name.find("]", p + 1)
    return None


# ----------------------------------------------------------------------------------------------
# poses for encode (Pinocchio forward kinematics, moved to the gauge of the system)
# ----------------------------------------------------------------------------------------------
def _node_poses(impl: _Impl, model: pin.Model, q: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    out: list = []
    gauge: dict[int, pin.SE3] = {}
    for n, node in enumerate(impl.nodes):
        if node.edge is None:
            gauge[n] = impl.ref_poses[node.joint] * data.oMi[node.joint].inverse()
            M = impl.ref_poses[node.joint]
        elif impl.jnode.get(node.joint) == n:
            M = gauge[node.root] * data.oMi[node.joint]
        else:  # an intermediate frame of a composite joint
            e = impl.edges[node.edge]
            Rpar, opar = out[e.parent]
            if e.pt.motion is not None:  # a part that is no Pinocchio sub-joint (universal)
                own = e.pt.motion(q)
            else:
                jm = pairs.sub_joint(model.joints[node.joint], e.pt.path)
                jd = jm.createData()
                jm.calc(jd, q)
                own = jd.M
            M = pin.SE3(Rpar, opar) * e.pt.placement * own
        out.append((np.array(M.rotation), np.array(M.translation)))
    return out


def _read(impl: _Impl, g: tuple, P) -> float:
    """The value of a primary variable at the poses ``P`` of the frames."""
    kind = g[0]
    if kind == "rel_rot":  # c or s of a revolute/planar edge
        return float(_rel_rot(P, impl.edges[g[1]])[g[2], 0])
    if kind == "rot":  # entry of a frame's orientation
        return float(P[g[1]][0][g[2], g[3]])
    if kind == "pos":  # entry of a frame's position
        return float(P[g[1]][1][g[2]])
    if kind == "disp":  # displacement along a local direction
        return float(g[2] @ _rel_trans(P, impl.edges[g[1]]))
    if kind == "dir":  # unit vector of a distance closure
        return float(_closure_vector(P, impl.closure_ends[g[1]])[g[3]] / g[2])
    raise FormulationError(f"internal: unknown getter {g!r}")  # pragma: no cover


def _rel_rot(P, e: _Edge) -> np.ndarray:
    """``B^T (R_parent Rp)^T R_child B`` of a revolute/planar edge at poses ``P``."""
    B = e.B if e.B is not None else np.eye(3)
    return B.T @ (P[e.parent][0] @ e.Rp).T @ P[e.child][0] @ B


def _rel_trans(P, e: _Edge) -> np.ndarray:
    """The joint's own translation, in the frame before its motion, at poses ``P``."""
    Rpar, opar = P[e.parent]
    return (Rpar @ e.Rp).T @ (P[e.child][1] - opar - Rpar @ e.tp)


def _closure_vector(P, ends) -> np.ndarray:
    na, Pa, nb, Pb = ends
    pa = P[na][1] + P[na][0] @ Pa.translation
    pb = P[nb][1] + P[nb][0] @ Pb.translation
    return pb - pa


def squared_leg(s: System, name: str, dirs: list[str]) -> set[int] | None:
    """Add the squared form of the vector leg ``name`` to ``s`` as a redundant equation, and
    return the variables its loop rows give the leg's vector from (None: nothing added).

    The leg's loop rows read ``e_k + c_k d_k = 0`` (``d`` the unit vector ``dirs``, ``e_k``
    linear in the other variables once a platform's translation is eliminated), so
    ``sum_k (e_k / c_k)^2 = |d|^2 = 1``. Quadratic in the platform's rotation and the first
    leg's vector, it gives the LP the bilinear products of those (their McCormick rows) beside
    the parabolas of ``d``: a much smaller tree on a mobile platform (``benchmarks/mobile.py``;
    tests/formulation/test_formulation.py checks the row).
    Nothing is added when a loop row is missing (eliminated with a translation) or ``e_k`` is
    not linear (its square would be of degree 4).
    """
    rows = {c.name: c for c in s.constraints if c.kind == "core"}
    total = Expr.const(-1.0)
    # how far the new row can be from 0 at a root: the loop rows hold up to their own rounding
    # (and the rounding of terms cancelled when they were derived), which enters through 2 e_k /
    # c_k (|e_k / c_k| <= 1 at a root, up to that rounding), and |d|^2 = 1 up to its own
    drift = 0.0
    unit = rows.get(f"unit:dir[{name}]")
    if unit is None:
        return None
    inputs: set[int] = set()
    for k, dn in enumerate(dirs):
        con = rows.get(f"loop:{name}[{k}]")
        if con is None or dn not in s.names:
            return None
        d = s.index(dn)
        c = con.expr.terms.get((d,), 0.0)
        e = con.expr - Expr.var(d) * c
        if c == 0.0 or e.degree > 1 or any(s.names[i] in dirs for i in e.variables()):
            return None
        inputs |= e.variables()
        total = total + (e / c) * (e / c)
        drift += 2.0 * max(s.size(con.expr), con.cancelled) / abs(c)
    drift += max(s.size(unit.expr), unit.cancelled)
    # appended as it is (a Constraint keeps the drift as the size of what was cancelled, which
    # the row's slack covers: docs/soundness.md)
    s.constraints.append(Constraint(total, f"leg:{name}", "redundant", drift))
    s.invalidate()
    return inputs
