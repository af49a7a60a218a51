"""Planar mechanisms: links in the plane, revolute and prismatic pairs, fixed links and bars.

A kinbox mechanism file of ``"kind": "planar"`` (``docs/mechanism-files.md``) describes a
linkage in the plane ``z = 0``:

* ``links``: ``{link: {point: [x, y], ...}}``, the named points of each link in its own frame;
* ``ground`` (optional, default ``"ground"``): the link held fixed (its frame is the world);
* ``joints``: a list of ``{"type": "revolute" | "prismatic" | "fixed", "between": [A, B], ...}``
  where ``A`` and ``B`` are points of two links, ``"link.point"`` or ``["link", [x, y]]``.
  A revolute pair makes the two points coincide; a prismatic pair slides ``B``'s point along
  the line through ``A``'s point of direction ``axis`` (in ``A``'s frame; ``q`` is the signed
  distance, ``limits`` required) with ``B`` turned by ``angle`` (default 0) from ``A``; a fixed
  pair welds ``B`` to ``A`` (points coincide, ``B`` turned by ``angle``). Optional ``name``
  (default ``j1, j2, ...``) and, for revolute pairs, ``limits`` (radians, relative angle of
  ``B``'s frame to ``A``'s);
* ``bars``: ``[{"between": [A, B], "length": L, "name": ...}]``, binary links given by the
  distance between two points.

:func:`planar_mechanism` builds a Pinocchio model of it (Pinocchio does the geometry): links
joined by fixed pairs are one body; a spanning tree of the pairs (prismatic pairs first, from
the ground breadth-first) becomes joints -- revolute ``RZ`` with ``q`` the relative angle of
the child link's frame to the parent's, prismatic along the slide's direction -- and the other
revolute pairs become ``point`` closures, the bars ``distance`` closures. Each link gets a frame
of its name, each named point a frame ``link.point``. The planar formulation
(:mod:`kinbox.formulation.planar`) recognises the model as planar (every axis along ``z``).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..errors import InputError
from .mechanism import Closure, Mechanism

PI = math.pi
_JOINT_KEYS = {"name", "type", "between", "axis", "angle", "limits"}
_BAR_KEYS = {"name", "between", "length"}


def _num(x, what: str) -> float:
    if isinstance(x, bool) or not isinstance(x, (int, float)):
        raise InputError(f"{what} must be a number, got {x!r:.60}")
    v = float(x)
    if not math.isfinite(v):
        raise InputError(f"{what} is not finite: {v}")
    return v


def _vec2(x, what: str) -> np.ndarray:
    if not isinstance(x, (list, tuple)) or len(x) != 2:
        raise InputError(f"{what} must be a pair [x, y], got {x!r:.60}")
    return np.array([_num(x[0], f"{what}[0]"), _num(x[1], f"{what}[1]")])


def _rot(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s], [s, c]])


def _se3(angle: float, p) -> pin.SE3:
    R = np.eye(3)
    R[:2, :2] = _rot(angle)
    return pin.SE3(R, np.array([float(p[0]), float(p[1]), 0.0]))


@dataclass
class _Pair:
    name: str
    kind: str  # revolute, prismatic, fixed
    a: str  # link names
    b: str
    pa: np.ndarray  # points in the links' frames
    pb: np.ndarray
    axis: np.ndarray | None = None
    angle: float = 0.0
    limits: tuple[float, float] | None = None


def _point(ref, links: dict[str, dict[str, np.ndarray]], what: str) -> tuple[str, np.ndarray]:
    """``"link.point"`` or ``["link", [x, y]]`` -> (link, point in its frame)."""
    if isinstance(ref, str):
        link, dot, pt = ref.rpartition(".")
        if not dot or link not in links:
            raise InputError(f"{what}: {ref!r} is not 'link.point' with a link of 'links' ({', '.join(links)})")
        if pt not in links[link]:
            raise InputError(f"{what}: link {link!r} has no point {pt!r}; points: {', '.join(links[link]) or 'none'}")
        return link, links[link][pt]
    if isinstance(ref, (list, tuple)) and len(ref) == 2 and isinstance(ref[0], str):
        if ref[0] not in links:
            raise InputError(f"{what}: unknown link {ref[0]!r}; links: {', '.join(links)}")
        return ref[0], _vec2(ref[1], what)
    raise InputError(f'{what}: a point is "link.point" or ["link", [x, y]], got {ref!r:.60}')


def _between(item: dict, links, what: str):
    pair = item.get("between")
    if not isinstance(pair, (list, tuple)) or len(pair) != 2:
        raise InputError(f'{what}: "between" must list two points, got {pair!r:.60}')
    (a, pa), (b, pb) = _point(pair[0], links, f"{what} point 1"), _point(pair[1], links, f"{what} point 2")
    return a, pa, b, pb


def _links(spec) -> dict[str, dict[str, np.ndarray]]:
    if not isinstance(spec, dict) or not spec:
        raise InputError('"links" must map link names to their points {"P": [x, y], ...}')
    out: dict[str, dict[str, np.ndarray]] = {}
    for link, pts in spec.items():
        if not link or "." in link:
            raise InputError(f"link name {link!r} must be non-empty and without '.'")
        if not isinstance(pts, dict):
            raise InputError(f"link {link!r}: its points must be an object {{name: [x, y]}}")
        out[link] = {p: _vec2(v, f"point {link}.{p}") for p, v in pts.items()}
    return out


def _pairs(spec, links) -> list[_Pair]:
    if not isinstance(spec, list):
        raise InputError('"joints" must be a list of pairs')
    out: list[_Pair] = []
    names: set[str] = set()
    for k, item in enumerate(spec, start=1):
        what = f"joint {k}"
        if not isinstance(item, dict):
            raise InputError(f"{what} must be an object")
        extra = set(item) - _JOINT_KEYS
        if extra:
            raise InputError(f"{what}: unknown key(s) {', '.join(sorted(extra))}; keys: {', '.join(sorted(_JOINT_KEYS))}")
        name = item.get("name", f"j{k}")
        if not isinstance(name, str) or not name or name in names:
            raise InputError(f"{what}: name {name!r} must be a new non-empty string")
        names.add(name)
        what = f"joint {name!r}"
        kind = item.get("type")
        if kind not in ("revolute", "prismatic", "fixed"):
            raise InputError(f'{what}: "type" must be revolute, prismatic or fixed, got {kind!r:.40}')
        a, pa, b, pb = _between(item, links, what)
        if a == b:
            raise InputError(f"{what} joins link {a!r} to itself")
        p = _Pair(name, kind, a, b, pa, pb, angle=_num(item.get("angle", 0.0), f"{what} angle"))
        if kind != "revolute" and "limits" in item and kind == "fixed":
            raise InputError(f"{what}: a fixed pair has no limits")
        if "limits" in item:
            lim = item["limits"]
            if not isinstance(lim, (list, tuple)) or len(lim) != 2:
                raise InputError(f"{what}: limits must be [lower, upper]")
            lo, hi = _num(lim[0], f"{what} lower limit"), _num(lim[1], f"{what} upper limit")
            if lo > hi:
                raise InputError(f"{what}: lower limit {lo} > upper limit {hi}")
            p.limits = (lo, hi)
        if kind == "prismatic":
            u = _vec2(item.get("axis", [1.0, 0.0]), f"{what} axis")
            n = float(np.hypot(*u))
            if not n > 1e-9:
                raise InputError(f"{what}: axis {u.tolist()} is not a direction")
            p.axis = u / n
            if p.limits is None:
                raise InputError(f"{what}: a prismatic pair needs limits [lower, upper]")
        elif "axis" in item:
            raise InputError(f"{what}: only a prismatic pair has an axis")
        if kind == "revolute" and "angle" in item:
            raise InputError(f"{what}: a revolute pair has no angle (its angle is its motion)")
        out.append(p)
    return out


def _bars(spec, links) -> list[tuple[str, str, np.ndarray, str, np.ndarray, float]]:
    if spec is None:
        return []
    if not isinstance(spec, list):
        raise InputError('"bars" must be a list')
    out = []
    for k, item in enumerate(spec, start=1):
        if not isinstance(item, dict):
            raise InputError(f"bar {k} must be an object")
        extra = set(item) - _BAR_KEYS
        if extra:
            raise InputError(f"bar {k}: unknown key(s) {', '.join(sorted(extra))}; keys: {', '.join(sorted(_BAR_KEYS))}")
        name = item.get("name", f"bar{k}")
        if not isinstance(name, str) or not name:
            raise InputError(f"bar {k}: name must be a non-empty string")
        a, pa, b, pb = _between(item, links, f"bar {name!r}")
        length = _num(item.get("length"), f"bar {name!r} length")
        if length < 0:
            raise InputError(f"bar {name!r}: length {length} is negative")
        out.append((name, a, pa, b, pb, length))
    return out


def planar_mechanism(links, joints, bars=None, ground: str = "ground", name: str = "planar") -> Mechanism:
    """A Pinocchio :class:`Mechanism` of a planar linkage (see the module docstring)."""
    L = _links(links)
    if ground not in L:
        raise InputError(f"ground link {ground!r} is not in 'links' ({', '.join(L)})")
    pairs = _pairs(joints, L)
    bar_list = _bars(bars, L)

    # links welded by fixed pairs are one body: pose of each link in its body's frame (angle, origin)
    body = {n: n for n in L}
    pose = {n: (0.0, np.zeros(2)) for n in L}
    for p in pairs:
        if p.kind != "fixed":
            continue
        ra, rb = body[p.a], body[p.b]
        if ra == rb:
            # a cycle of fixed pairs: it must hold as given
            (ta, oa), (tb, ob) = pose[p.a], pose[p.b]
            wa, wb = oa + _rot(ta) @ p.pa, ob + _rot(tb) @ p.pb
            if abs(math.remainder(tb - ta - p.angle, 2 * PI)) > 1e-9 or float(np.hypot(*(wa - wb))) > 1e-9 * (1 + float(np.abs(wa).max())):
                raise InputError(f"fixed joint {p.name!r} contradicts the fixed joints before it")
            continue
        if rb == ground:  # keep the ground as the root of its body
            ra, rb = rb, ra
            p = _Pair(p.name, p.kind, p.b, p.a, p.pb, p.pa, angle=-p.angle)
        # move body rb into ra: link b's frame in ra's frame, then every link of rb
        ta, oa = pose[p.a]
        tb_new = ta + p.angle
        ob_new = oa + _rot(ta) @ p.pa - _rot(tb_new) @ p.pb
        tb_old, ob_old = pose[p.b]
        # x_ra = R(tb_new) R(tb_old)^T (x_rb - ob_old) + ob_new
        dt = tb_new - tb_old
        for n in L:
            if body[n] == rb:
                tn, on = pose[n]
                pose[n] = (tn + dt, ob_new + _rot(dt) @ (on - ob_old))
                body[n] = ra

    def local(link: str, p: np.ndarray) -> np.ndarray:  # a link's point in its body's frame
        t, o = pose[link]
        return o + _rot(t) @ p

    moving = [p for p in pairs if p.kind != "fixed"]
    # spanning tree: prismatic pairs first (a closure is a point or distance: a prismatic pair
    # cannot close a loop), then revolute ones, in file order
    parent_of: dict[str, str] = {}
    comp = {b: b for b in set(body.values())}

    def find(x: str) -> str:
        while comp[x] != x:
            comp[x] = comp[comp[x]]
            x = comp[x]
        return x

    tree: list[_Pair] = []
    closing: list[_Pair] = []
    for p in sorted(moving, key=lambda p: p.kind != "prismatic"):
        ra, rb = find(body[p.a]), find(body[p.b])
        if ra == rb:
            if p.kind == "prismatic":
                raise InputError(f"prismatic joint {p.name!r} closes a loop of prismatic joints; kinbox closes loops with revolute joints")
            closing.append(p)
        else:
            comp[ra] = rb
            tree.append(p)
    closing.sort(key=lambda p: moving.index(p))

    # orient the tree from the ground, breadth-first
    adj: dict[str, list[_Pair]] = {b: [] for b in comp}
    for p in tree:
        adj[body[p.a]].append(p)
        adj[body[p.b]].append(p)
    order: list[tuple[_Pair, bool]] = []  # (pair, forward: a is the parent)
    seen = {ground}
    dq = deque([ground])
    while dq:
        b = dq.popleft()
        for p in adj[b]:
            fwd = body[p.a] == b
            other = body[p.b] if fwd else body[p.a]
            if other in seen:
                continue
            seen.add(other)
            parent_of[other] = b
            order.append((p, fwd))
            dq.append(other)
    lost = sorted({body[n] for n in L} - seen)
    if lost:
        loose = sorted(n for n in L if body[n] in lost)
        raise InputError(f"link(s) {', '.join(loose)} not joined to the ground {ground!r} by joints (bars alone do not carry a link)")

    model = pin.Model()
    model.name = name
    jid = {ground: 0}
    jpt = {ground: np.zeros(2)}  # each body's joint origin in the body's frame
    for p, fwd in order:
        if not fwd:  # the pair seen from the parent's side, with the same q
            if p.kind == "revolute":
                p = _Pair(p.name, "revolute-", p.b, p.a, p.pb, p.pa, limits=p.limits)
            else:  # A's point slides along B's line the other way, A turned by -angle from B
                assert p.axis is not None
                p = _Pair(p.name, p.kind, p.b, p.a, p.pb, p.pa, axis=-(_rot(-p.angle) @ p.axis), angle=-p.angle, limits=p.limits)
        par, ch = body[p.a], body[p.b]
        ta, tb = pose[p.a][0], pose[p.b][0]
        # the child body's frame turns by ``phi`` from the parent's at q = 0, so that q is the
        # angle of link b's frame relative to link a's (minus a prismatic pair's fixed angle)
        phi = ta + p.angle - tb
        place = _se3(phi, local(p.a, p.pa) - jpt[par])
        if p.kind == "prismatic":
            assert p.axis is not None
            u = _rot(ta - phi) @ p.axis  # A's axis in the joint frame
            jmodel = pin.JointModelPrismaticUnaligned(np.array([u[0], u[1], 0.0]))
        elif p.kind == "revolute":
            jmodel = pin.JointModelRZ()
        else:  # revolute with the child on the pair's first side: q counts the other way
            jmodel = pin.JointModelRevoluteUnaligned(np.array([0.0, 0.0, -1.0]))
        lo, hi = p.limits if p.limits is not None else (-PI, PI)
        j = model.addJoint(jid[par], jmodel, place, p.name, np.full(1, 1e3), np.full(1, 1e3), np.array([lo]), np.array([hi]))
        model.addJointFrame(j)
        jid[ch] = j
        jpt[ch] = local(p.b, p.pb)  # the joint frame's origin is the child's point, turned as the body
    mech = Mechanism(model, name=name)

    def anchor(link: str, p: np.ndarray) -> tuple[int, pin.SE3]:
        b = body[link]
        return jid[b], _se3(0.0, local(link, p) - jpt[b])

    for n, pts in L.items():
        j, M = anchor(n, np.zeros(2))
        parent_frame = model.getFrameId(model.names[j], pin.FrameType.JOINT) if j > 0 else 0
        model.addFrame(pin.Frame(n, j, parent_frame, _se3(pose[n][0], M.translation[:2]), pin.FrameType.OP_FRAME))
        for pt, v in pts.items():
            j, M = anchor(n, v)
            model.addFrame(pin.Frame(f"{n}.{pt}", j, parent_frame, M, pin.FrameType.OP_FRAME))
    for p in closing:
        ja, Ma = anchor(p.a, p.pa)
        jb, Mb = anchor(p.b, p.pb)
        mech.closures.append(Closure("point", ja, Ma, jb, Mb, name=p.name))
    for bn, a, pa, b, pb, length in bar_list:
        ja, Ma = anchor(a, pa)
        jb, Mb = anchor(b, pb)
        mech.closures.append(Closure("distance", ja, Ma, jb, Mb, length=length, name=bn))
    return mech


def kind_planar(params: dict, name: str, base_dir) -> Mechanism:
    """The ``"kind": "planar"`` builder of mechanism files."""
    from .builders import take

    p = take(params, "planar", ["links", "joints"], ["bars", "ground"])
    ground = p.get("ground", "ground")
    if not isinstance(ground, str):
        raise InputError('"ground" must be a link name')
    return planar_mechanism(p["links"], p["joints"], p.get("bars"), ground=ground, name=name)


def plane_normal(mech, q: np.ndarray) -> np.ndarray | None:
    """The normal of the plane a mechanism moves in, or None when it is not planar: every
    free joint's motion (its columns of Pinocchio's world Jacobian at ``q``) a rotation about
    one direction ``n`` with a velocity normal to it, at least one of them a rotation. Then
    every body moves in a plane normal to ``n``, whatever the configuration
    (test_check_counts_planar_mechanisms_in_the_plane)."""
    model = mech.model
    data = model.createData()
    pin.computeJointJacobians(model, data, q)
    cols = [
        data.J[:, model.joints[j].idx_v + k]
        for j in range(1, model.njoints)
        if model.names[j] not in mech.locked
        for k in range(model.joints[j].nv)
    ]
    if not cols:
        return None
    scale = max(1.0, max(float(np.linalg.norm(c[:3])) for c in cols))
    axes = [c[3:] for c in cols if np.linalg.norm(c[3:]) > 1e-9]
    if not axes:
        return None
    n = axes[0] / np.linalg.norm(axes[0])
    for c in cols:
        if np.linalg.norm(np.cross(c[3:], n)) > 1e-9 or abs(float(c[:3] @ n)) > 1e-9 * scale:
            return None
    return n
