"""Where the roots of a pose the closed form does not decide can be: boxes in joint space.

The interval closed form (:mod:`kinbox.search.closed_form`) decides a pose when every pivot and
discriminant is proven away from zero. Near a singularity it is not, and the pose goes to the
branch and prune. The same algebra, evaluated with the undecided steps *relaxed*, still says
where the roots can be, and the branch and prune then searches only there:

* ``A c + B s = K`` (:func:`~kinbox.search.closed_form.sp_lin`) with ``D = r2 - K^2`` holding
  zero: both roots' enclosures with ``sqrt D`` taken over ``[0, sqrt(D_hi)]`` (each root of every
  ``(A, B, K)`` in the intervals is in one of them; none where ``D < 0``); with ``r2`` holding
  zero, the joint is *free*: its enclosure is that of the box being evaluated;
* the rotation taking ``u`` to ``v`` (:func:`~kinbox.search.closed_form.sp_rot`) with
  ``|u_xy|^2`` holding zero (a wrist singularity): the joint is free.

Every step of the closed form is a condition every root meets (each step is necessary for the
next), so every root of the pose lies in the enclosure of one branch: relaxing a step only
widens its branch's enclosure, a free joint keeps the box's whole range, and a branch is
dropped only where a discriminant is proven negative or an enclosure misses the box. A joint
left free on the arm of three parallel axes (the wrist's last joint at a wrist singularity) is
cut into arcs, and each arc evaluated again (the joints after it in the closed form then have
enclosures of the arc's width). The boxes of the kinbox system searched are the branches'
enclosures, moved to the system's angles, widened by :data:`PAD` and merged where they meet
(:func:`system_boxes`); the two boxes of a relaxed elbow, which overlap in a slab about the
double root where they meet, are their hull cut in two there (:func:`_fold_cut`), so that the
roots next to the double root are searched once, not in both boxes. ``tests/search/test_cf_fallback.py`` plants roots next to
singularities and checks that each lies in a box, and that the search inside the boxes finds
what the search of the whole domain finds.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from .closed_form import (
    MAX_ROOTS,
    _b_of,
    _dn,
    _elbow,
    _elbow_lin,
    _lin_about,
    _rotated_by,
    _up,
    cst,
    ez_times,
    fmtv,
    fmv,
    iadd,
    imtv,
    imul,
    imv,
    ineg,
    iscale,
    isub,
    mcol,
    mrow,
    rz,
    rzt,
    solve_branches,
    sp_lin,
    sp_rot,
    vadd,
    vdot,
    vnorm2,
    vscale,
    vsub,
)

#: the most boxes one evaluation of the arm of three parallel axes gives (2 x 2 x 2 branches)
MAX_BRANCHES = 8
#: arcs the free wrist joint is cut into
WRIST_ARCS = 2
#: the most boxes handed to the search; beyond it, the whole domain is searched
MAX_BOXES = 64
#: each box is widened by this (plus :data:`WIDEN` times its width) in every system variable,
#: so that a root on its face is inside the box the search starts from
PAD = 1e-6
WIDEN = 0.05


@nb.njit(cache=True)
def _meet(a, lo, hi):
    """``a`` intersected with ``[lo, hi]``: (ok, interval)."""
    l0 = max(a[0], lo)
    h0 = min(a[1], hi)
    return l0 <= h0, (l0, h0)


@nb.njit(cache=True)
def _in_box(c, s, box, j):
    """``(c, s)`` met with joint ``j``'s enclosure ``box[j] = (c_lo, c_hi, s_lo, s_hi)``."""
    okc, c2 = _meet(c, box[j, 0], box[j, 1])
    oks, s2 = _meet(s, box[j, 2], box[j, 3])
    return okc and oks, c2, s2


@nb.njit(cache=True)
def arc_box(a, b, out, j):
    """The enclosure of ``(cos, sin)`` over the arc ``[a, b]`` (``b - a <= 2 pi``) into ``out[j]``:
    the ends' values, and +-1 where the arc passes a multiple of ``pi / 2``; widened by 1e-15
    (``math.cos``, ``math.sin`` are within an ulp)."""
    ca, cb, sa, sb = math.cos(a), math.cos(b), math.sin(a), math.sin(b)
    clo, chi = min(ca, cb), max(ca, cb)
    slo, shi = min(sa, sb), max(sa, sb)
    k = math.ceil(a / (0.5 * math.pi) - 1e-12)
    while k * 0.5 * math.pi <= b + 1e-12:
        m = k % 4
        if m == 0:
            chi = 1.0
        elif m == 1:
            shi = 1.0
        elif m == 2:
            clo = -1.0
        else:
            slo = -1.0
        k += 1
    e = 1e-15
    out[j, 0] = max(-1.0, clo - e)
    out[j, 1] = min(1.0, chi + e)
    out[j, 2] = max(-1.0, slo - e)
    out[j, 3] = min(1.0, shi + e)


@nb.njit(cache=True)
def _emit(out, free, n, j, c, s, fr):
    out[n, j, 0] = c[0]
    out[n, j, 1] = c[1]
    out[n, j, 2] = s[0]
    out[n, j, 3] = s[1]
    free[n, j] = fr


@nb.njit(cache=True)
def parallel_enclosures(LR, Lt, d, Rlo, Rhi, tlo, thi, box, out, free, fold):
    """The arm of three parallel axes (family code 3) with every undecided step relaxed, inside
    the joint box ``box`` ((6, 4): each joint's ``(c, s)`` enclosure): the enclosure of every
    branch into ``out[k]`` ((6, 4)), ``free[k, j]`` where joint ``j`` kept the box's enclosure.
    ``fold[k]``: 1 and 2 on the two branches of a relaxed elbow (both roots' enclosures of a
    discriminant holding zero, emitted one after the other), else 0.
    Returns the number of branches, or -1 where joint 1's pivot holds zero (a shoulder
    singularity: nothing is decided). The algebra is that of
    :func:`~kinbox.search.closed_form.solve_branches` (``code == 3``)."""
    R = (
        ((Rlo[0, 0], Rhi[0, 0]), (Rlo[0, 1], Rhi[0, 1]), (Rlo[0, 2], Rhi[0, 2])),
        ((Rlo[1, 0], Rhi[1, 0]), (Rlo[1, 1], Rhi[1, 1]), (Rlo[1, 2], Rhi[1, 2])),
        ((Rlo[2, 0], Rhi[2, 0]), (Rlo[2, 1], Rhi[2, 1]), (Rlo[2, 2], Rhi[2, 2])),
    )
    t = ((tlo[0], thi[0]), (tlo[1], thi[1]), (tlo[2], thi[2]))
    Rez = (R[0][2], R[1][2], R[2][2])
    base, f, g = _elbow(LR, Lt, d)
    a = LR[3][2, :]
    h = LR[4][:, 2]
    sigma = LR[1][2, 2] * LR[2][2, 2]
    nn = LR[0][:, 2]
    o5 = vsub(t, vscale(cst(d[5]), Rez))
    hz = iadd(iadd(cst(d[1]), cst(Lt[1][2])), iscale(LR[1][2, 2], iadd(iadd(cst(d[2]), cst(Lt[2][2])), iscale(LR[2][2, 2], cst(d[3])))))
    Kc = iadd(hz, iscale(sigma, iadd(cst(Lt[3][2]), imul(cst(d[4]), cst(LR[3][2, 2])))))
    A1, B1, C1 = _rotated_by(nn, o5)
    K1 = isub(iadd(Kc, vdot(mcol(LR[0], 2), mrow(Lt, 0))), C1)
    st1, c1a, s1a, c1b, s1b = sp_lin(A1, B1, K1, True)
    if st1 < 0:
        return -1
    n = 0
    A5, B5, C5 = _lin_about(a, h)
    ex = ((1.0, 1.0), (0.0, 0.0), (0.0, 0.0))
    for i1 in range(min(st1, 2)):
        ok1, c1, s1 = _in_box(c1a if i1 == 0 else c1b, s1a if i1 == 0 else s1b, box, 0)
        if not ok1:
            continue
        zeta = fmtv(LR[0], rzt(c1, s1, Rez))
        st5, c5a, s5a, c5b, s5b = sp_lin(A5, B5, isub(iscale(sigma, zeta[2]), C5), True)
        if st5 == 0:
            continue
        rho = imtv(R, rz(c1, s1, mcol(LR[0], 2)))
        for i5 in range(2 if st5 > 0 else 1):
            free5 = st5 < 0
            if free5:
                c5, s5 = (box[4, 0], box[4, 1]), (box[4, 2], box[4, 3])
            else:
                ok5, c5, s5 = _in_box(c5a if i5 == 0 else c5b, s5a if i5 == 0 else s5b, box, 4)
                if not ok5:
                    continue
            kk = fmtv(LR[4], rzt(c5, s5, mrow(LR[3], 2)))
            ok, cp, sp = sp_rot(kk, (iscale(sigma, rho[0]), iscale(sigma, rho[1]), iscale(sigma, rho[2])))
            free6 = not ok
            if free6:  # a wrist singularity: joint 6 anywhere in the box
                c6, s6 = (box[5, 0], box[5, 1]), (box[5, 2], box[5, 3])
            else:
                ok6, c6, s6 = _in_box(cp, ineg(sp), box, 5)
                if not ok6:
                    continue
            t45 = vadd(
                mrow(Lt, 3),
                fmv(LR[3], rz(c5, s5, vadd(vadd(ez_times(cst(d[4])), mrow(Lt, 4)), vscale(cst(d[5]), mcol(LR[4], 2))))),
            )
            R45t_t45 = rzt(c6, s6, fmtv(LR[4], rzt(c5, s5, fmtv(LR[3], t45))))
            R45t_ex = rzt(c6, s6, fmtv(LR[4], rzt(c5, s5, fmtv(LR[3], ex))))
            Xt = fmtv(LR[0], vsub(rzt(c1, s1, vsub(t, imv(R, R45t_t45))), mrow(Lt, 0)))
            Xex = fmtv(LR[0], rzt(c1, s1, imv(R, R45t_ex)))
            A3, B3, K3 = _elbow_lin(f, g, vnorm2(Xt))
            st3, c3a, s3a, c3b, s3b = sp_lin(A3, B3, K3, True)
            if st3 == 0:
                continue
            for i3 in range(2 if st3 > 0 else 1):
                free3 = st3 < 0
                if free3:
                    c3, s3 = (box[2, 0], box[2, 1]), (box[2, 2], box[2, 3])
                else:
                    ok3, c3, s3 = _in_box(c3a if i3 == 0 else c3b, s3a if i3 == 0 else s3b, box, 2)
                    if not ok3:
                        continue
                b = _b_of(LR, base, g, c3, s3)
                ok, cq, sq = sp_rot(b, Xt)
                free2 = not ok
                if free2:
                    c2, s2 = (box[1, 0], box[1, 1]), (box[1, 2], box[1, 3])
                else:
                    ok2, c2, s2 = _in_box(cq, sq, box, 1)
                    if not ok2:
                        continue
                col = fmtv(LR[2], rzt(c3, s3, fmtv(LR[1], rzt(c2, s2, Xex))))
                ok4, c4, s4 = _in_box(col[0], col[1], box, 3)
                if not ok4:
                    continue
                _emit(out, free, n, 0, c1, s1, False)
                _emit(out, free, n, 1, c2, s2, free2)
                _emit(out, free, n, 2, c3, s3, free3)
                _emit(out, free, n, 3, c4, s4, False)
                _emit(out, free, n, 4, c5, s5, free5)
                _emit(out, free, n, 5, c6, s6, free6)
                fold[n] = 1 + i3 if st3 == 3 else 0
                n += 1
    return n


def joint_enclosures(cf, R: np.ndarray, t: np.ndarray, arcs: int | None = None) -> list[np.ndarray] | None:
    """Boxes ``(6, 4)`` of the family's canonical ``(c, s)`` per joint holding every root of the
    goal ``(R, t)`` (see the module's text), or None where the closed form decides nothing
    (then the whole domain is searched)."""
    got = folded_enclosures(cf, R, t, arcs)
    return None if got is None else got[0]


def folded_enclosures(cf, R: np.ndarray, t: np.ndarray, arcs: int | None = None) -> tuple[list[np.ndarray], list[int]] | None:
    """:func:`joint_enclosures` and, per box, an id shared by the two branches of one relaxed
    elbow (the enclosures of both roots of a discriminant holding zero, which meet at the
    double root), or -1."""
    Rlo, Rhi, tlo, thi = (np.ascontiguousarray(x[0]) for x in cf.goal_arrays(R[None], t[None]))
    if cf.code != 3:
        out = np.zeros((MAX_ROOTS, 6, 4))
        n, undecided = solve_branches(cf.code, cf.LR, cf.Lt, cf.d, Rlo, Rhi, tlo, thi, out, np.zeros((4, 3, 4)), True, True)
        if undecided:
            return None
        m = n if n >= 0 else -2 - n
        return [out[k].copy() for k in range(m)], [-1] * m
    if cf.LR.ndim != 3:
        return None  # enclosed links (cf_delta.kernel_links): parallel_enclosures takes binary64 ones only
    whole = np.tile(np.array([-1.0, 1.0, -1.0, 1.0]), (6, 1))
    out = np.zeros((MAX_BRANCHES, 6, 4))
    free = np.zeros((MAX_BRANCHES, 6), dtype=np.bool_)
    fold = np.zeros(MAX_BRANCHES, dtype=np.int64)
    pairs: list[int] = []

    def take(m: int, keep) -> list[np.ndarray]:
        got = []
        for k in range(m):
            if not keep(k):
                continue
            # the second branch of a relaxed elbow shares the id of the first (the box before it)
            second = fold[k] == 2 and k > 0 and fold[k - 1] == 1 and keep(k - 1)
            pairs.append(len(pairs) - 1 if second else (len(pairs) if fold[k] == 1 else -1))
            got.append(out[k].copy())
        return got

    n = parallel_enclosures(cf.LR, cf.Lt, cf.d, Rlo, Rhi, tlo, thi, whole, out, free, fold)
    if n < 0:
        return None
    boxes = take(n, lambda k: not free[k, 5])
    if not any(free[k, 5] for k in range(n)):
        return boxes, pairs
    # the wrist's last joint free on some branch: those branches again, one arc at a time
    arcs = WRIST_ARCS if arcs is None else arcs
    step = 2.0 * math.pi / arcs
    for i in range(arcs):
        box = whole.copy()
        arc_box(-math.pi + i * step, -math.pi + (i + 1) * step, box, 5)
        m = parallel_enclosures(cf.LR, cf.Lt, cf.d, Rlo, Rhi, tlo, thi, box, out, free, fold)
        if m < 0:
            return None
        boxes += take(m, lambda k: bool(free[k, 5]))
    return boxes, pairs


@nb.njit(cache=True)
def _definitions(lo, hi, plo, phi, def_target, def_start, def_param, def_coef, def_a, def_b, dom_lo, dom_hi):
    """The variables the arm template defines from the joints' (``x_target = sum p coef x_a
    x_b``, :meth:`~kinbox.search.closed_form.TemplateCertifier` ``encode``'s program, in its
    order) enclosed over the box ``[lo, hi]`` with the parameters in ``[plo, phi]``, widened by
    :data:`PAD` and met with the domain, into ``lo``, ``hi``. False if one is empty."""
    for k in range(def_target.shape[0]):
        acc = (0.0, 0.0)
        for e in range(def_start[k], def_start[k + 1]):
            v = iscale(def_coef[e], (plo[def_param[e]], phi[def_param[e]]))
            if def_a[e] >= 0:
                v = imul(v, (lo[def_a[e]], hi[def_a[e]]))
            if def_b[e] >= 0:
                v = imul(v, (lo[def_b[e]], hi[def_b[e]]))
            acc = iadd(acc, v)
        tg = def_target[k]
        lo[tg] = max(dom_lo[tg], _dn(acc[0] - PAD))
        hi[tg] = min(dom_hi[tg], _up(acc[1] + PAD))
        if lo[tg] > hi[tg]:
            return False
    return True


def system_boxes(
    cf,
    encs: list[np.ndarray],
    lo0: np.ndarray,
    hi0: np.ndarray,
    params: tuple[np.ndarray, np.ndarray] | None = None,
    pairs: list[int] | None = None,
) -> list[tuple[np.ndarray, np.ndarray]] | None:
    """The joint boxes ``encs`` (:func:`joint_enclosures`) as boxes of the arm template's system
    (its search domain ``lo0``, ``hi0``): each joint's ``(c, s)`` turned to the system's angle
    (the template's offset from the family's), widened by :data:`WIDEN` times its width and :data:`PAD`, met with
    the domain; with the pose's parameters ``params`` (enclosures ``(lo, hi)`` of
    :meth:`~kinbox.formulation.arm.ArmTemplate.params_enclosure`), the variables the template
    defines from the joints enclosed over the box (:func:`_definitions`), else over the whole
    domain. Boxes that meet are replaced by
    their hull where the hull is not much larger (:func:`_same_place`: the two enclosures of a
    relaxed discriminant; neighbouring arcs are kept apart). None without the template's
    joint variables (:class:`~kinbox.search.closed_form.TemplateCertifier`). ``pairs``
    (:func:`folded_enclosures`): the two boxes of a relaxed elbow are replaced by their hull cut
    in two at their fold (:func:`_fold_cut`)."""
    tc = cf.certifier
    if tc is None or tc.n != lo0.shape[0]:
        return None
    boxes: list[tuple[np.ndarray, np.ndarray] | None] = []
    for e in encs:
        lo, hi = lo0.copy(), hi0.copy()
        empty = False
        for i in range(6):
            cs, sn = math.cos(tc.shift[i]), math.sin(tc.shift[i])
            c, s = (e[i, 0], e[i, 1]), (e[i, 2], e[i, 3])
            c2 = isub(iscale(cs, c), iscale(sn, s))
            s2 = iadd(iscale(cs, s), iscale(sn, c))
            for var, iv in ((tc.cvar[i], c2), (tc.svar[i], s2)):
                if var < 0:
                    continue
                w = WIDEN * (iv[1] - iv[0]) + PAD
                lo[var] = max(lo0[var], _dn(iv[0] - w))
                hi[var] = min(hi0[var], _up(iv[1] + w))
                empty = empty or lo[var] > hi[var]
        if not empty and params is not None:
            plo, phi = params
            empty = not _definitions(lo, hi, plo, phi, tc.def_target, tc.def_start, tc.def_param, tc.def_coef, tc.def_a, tc.def_b, lo0, hi0)
        boxes.append(None if empty else (lo, hi))
    if pairs is not None:
        for k, pid in enumerate(pairs):
            if pid >= 0 and pid != k and boxes[k] is not None and boxes[pid] is not None:
                boxes[pid], boxes[k] = _fold_cut(boxes[pid], boxes[k])  # type: ignore[arg-type]
    return _merge([b for b in boxes if b is not None])


def _fold_cut(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray]) -> tuple:
    """The two boxes of a relaxed elbow, which overlap where they meet at the double root (each
    widened by :data:`PAD` and :data:`WIDEN`): their hull cut in two across the variable in
    which they overlap least (relative to the hull's width), at the middle of that overlap.
    The two halves cover the hull, so both boxes; they share a face instead of a slab, and the
    roots next to the double root (a near-double pair, the cluster of an elbow and a wrist
    both 1e-9 from singular) are searched once instead of in both boxes. Boxes that do not
    meet, or that :func:`_merge` replaces by their hull, are returned as they are."""
    (la, ha), (lb, hb) = a, b
    ov = np.minimum(ha, hb) - np.maximum(la, lb)
    hl, hh = np.minimum(la, lb), np.maximum(ha, hb)
    if np.any(ov < 0) or np.all(hh - hl <= 1.5 * np.maximum(ha - la, hb - lb)):
        return a, b  # apart, or merged into their hull by _merge
    share = ov / np.maximum(hh - hl, 1e-300)
    v = int(np.argmin(share))
    if share[v] >= 1.0:
        return a, b
    cut = 0.5 * (max(la[v], lb[v]) + min(ha[v], hb[v]))
    low, high = (hl.copy(), hh.copy()), (hl.copy(), hh.copy())
    low[1][v] = cut
    high[0][v] = cut
    return (low, high) if la[v] <= lb[v] else (high, low)


def _merge(boxes: list[tuple[np.ndarray, np.ndarray]]) -> list[tuple[np.ndarray, np.ndarray]]:
    """Boxes that meet with a hull at most 1.5 times either's width in every variable (the two
    enclosures of a relaxed discriminant; neighbouring arcs are kept apart) replaced by the hull
    of their group, until no two are such."""
    while len(boxes) > 1:
        L = np.array([b[0] for b in boxes])
        H = np.array([b[1] for b in boxes])
        W = H - L
        meet = np.all(L[:, None] <= H[None], axis=2) & np.all(L[None] <= H[:, None], axis=2)
        hull = np.maximum(H[:, None], H[None]) - np.minimum(L[:, None], L[None])
        same = meet & np.all(hull <= 1.5 * np.maximum(W[:, None], W[None]), axis=2)
        np.fill_diagonal(same, False)
        if not same.any():
            break
        group = list(range(len(boxes)))  # union-find over the pairs

        def root(i: int) -> int:
            while group[i] != i:
                i = group[i]
            return i

        for i, j in zip(*np.nonzero(same)):
            group[root(int(i))] = root(int(j))
        hulls: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        for i in range(len(boxes)):
            r = root(i)
            lo, hi = hulls.get(r, (L[i], H[i]))
            hulls[r] = (np.minimum(lo, L[i]), np.maximum(hi, H[i]))
        boxes = list(hulls.values())
    return boxes
