"""The closed form's roots next to a singularity, certified on the kinbox system from Newton's point.

Where the interval closed form (:mod:`kinbox.search.closed_form`) bounds a pose's count of
roots but its certificates fail -- a near-double root, 1e-6 from the elbow singularity of a
UR5: the closed form's root (the midpoint of its enclosure) is 1e-7 off the root, and the
Jacobian's condition number is 1e7 -- the roots are certified here by Krawczyk on the pose's
own kinbox system (:meth:`kinbox.search.certify.Certifier.krawczyk`, the search's test).

*The bound.* The closed form with its undecided discriminants relaxed (``relax=True`` of
:func:`~kinbox.search.closed_form.solve_branches`: where ``D`` holds zero and ``r2`` is proven
positive, both roots' enclosures with ``sqrt D`` over ``[0, sqrt D_hi]``) gives ``N``
enclosures; each step has at most two roots given the joints before it, so every root of the
pose is the root of one branch and lies in that branch's enclosure: at most ``N`` roots, and
at most ``M`` within the joint limits, ``M`` the enclosures not proven outside them
(:func:`~kinbox.search.closed_form._in_limits`). Where a pivot holds zero (a joint left free
on its circle: a wrist singularity, possibly a curve of roots) or a root's limits are not
decided, there is no bound, and nothing is done here.

*The roots.* From the midpoint of each of the ``M`` enclosures: Newton on the system's core
(a float iterate, no proof), then Krawczyk on boxes about it whose half-widths are
:data:`~kinbox.search.seeded.GROWTH` times the radius ``K`` has for a point box there (its *floor*: the error of
``F`` and the rows' uncertainty through ``|J^-1|``; :func:`kinbox.search.seeded.cube_proof`), until one is proven to hold exactly one
root (``K(X) ⊂ int X`` and ``|I - Y J(X)| d < d``); the number of boxes tried is fixed
(counters, never time). Each proof box must lie in the search domain and be disjoint from the
others.

*One root per enclosure.* The count bounds the roots of the family's binary64 arm; the model as
given is that arm within ``Delta`` (the goal widened by it), and two of its roots could share
one branch's enclosure. So each of the ``M`` enclosures must lie in a box where Krawczyk in
the six joint angles (:func:`kinbox.search.slab_proof.krawczyk_wide`, the model's links
enclosed, the goal the closed form's whole goal box) proves exactly one root
(:func:`_one_root_each`): then the ``M`` enclosures hold at most ``M`` roots of the model.

``M`` disjoint proof boxes hold ``M`` distinct roots, and there are at most ``M``: they are
all the roots, each certified, and the answer is complete, as on the closed form's fast path
(:func:`kinbox.answer.closed_form.closed_form_result`). Otherwise None: the pose goes to the
branch and prune (:mod:`kinbox.search.cf_fallback`), as it would without the seed. ``tests/search/test_cf_seeded.py``
compares the answers with the search of the whole domain on planted near-singular poses.
"""

from __future__ import annotations

import math

import numpy as np

from .certify import Certifier
from .closed_form import (
    MAX_ROOTS,
    POSE_CLOSED_FORM,
    Batch,
    ClosedForm,
    _in_limits,
    encode_rows,
    root_angles,
    solve_branches,
)
from .seeded import GROWTH, cube_proof

__all__ = ["GROWTH", "relaxed_roots", "seeded_roots"]

#: Newton steps from the closed form's root
NEWTON_STEPS = 20


def seeded_roots(
    cf: ClosedForm,
    cert: Certifier,
    goal_R: np.ndarray,
    goal_t: np.ndarray,
    lo0: np.ndarray,
    hi0: np.ndarray,
    bound: tuple[np.ndarray, list[int]] | None = None,
    pose: np.ndarray | None = None,
) -> Batch | None:
    """The roots of the goal ``(goal_R, goal_t)`` certified on its kinbox system (``cert``, its
    search domain ``lo0``, ``hi0``) from Newton's point (see the module's text), as a one-pose
    :class:`~kinbox.search.closed_form.Batch` with the system certificate, or None (the closed
    form does not bound the roots, or a root is not certified so). ``bound``: the goal's
    :func:`relaxed_roots`, if computed already; ``pose``: the goal's XYZQUAT as given (for
    :func:`_pairs_separated`; None: enclosures Krawczyk does not prove alone send the pose on)."""
    tc = cf.certifier
    if tc is None or not cert.square or tc.n != cert.comp.n:
        return None
    bound = bound if bound is not None else relaxed_roots(cf, goal_R, goal_t)
    if bound is None:
        return None
    enc, keep = bound
    if not _one_root_each(cf, goal_R, goal_t, enc, keep, pose):
        return None
    theta = np.zeros((len(keep), 6))
    for m, r in enumerate(keep):
        root_angles(enc[r], theta[m])
    P, _ = tc.params(goal_R[None], goal_t[None])
    X = np.zeros((len(keep), tc.n))
    encode_rows(theta, P[0], tc.fixed, tc.cvar, tc.svar, tc.shift, tc.def_target, tc.def_start, tc.def_param, tc.def_coef,
                tc.def_a, tc.def_b, X)  # fmt: skip
    xs: list[np.ndarray] = []
    los: list[np.ndarray] = []
    his: list[np.ndarray] = []
    res: list[float] = []
    for m in range(len(keep)):
        x = cert.newton(X[m], iters=NEWTON_STEPS)
        if not np.all(np.isfinite(x)):
            return None
        proof = cube_proof(cert, x)
        if proof is None:
            return None
        _, _, klo, khi = proof
        if np.any(klo < lo0) or np.any(khi > hi0):
            return None
        if not all(np.any(khi < plo) or np.any(klo > phi) for plo, phi in zip(los, his)):
            return None
        theta[m] = _angles(x, tc, theta[m])
        xs.append(x)
        los.append(klo)
        his.append(khi)
        res.append(float(np.max(np.abs(cert.comp.eval_eqs(x)), initial=0.0)))
    m = len(keep)
    e = np.zeros((m, tc.n))
    return Batch(
        np.array([POSE_CLOSED_FORM]),
        np.array([0]),
        np.array([m]),
        theta,
        np.array(xs).reshape(m, tc.n),
        np.array(los).reshape(m, tc.n) if m else e,
        np.array(his).reshape(m, tc.n) if m else e,
        np.array(res),
        True,
        "system",
    )


#: Krawczyk's boxes about an enclosure: these many times how far its roots may lie from the
#: box's centre (Newton's point from the enclosure's middle), or from Newton's reach
ONE_ROOT_GROWTH = (1.0625, 1.5, 3.0)


def _one_root_each(
    cf: ClosedForm, goal_R: np.ndarray, goal_t: np.ndarray, enc: np.ndarray, keep: list[int], pose: np.ndarray | None = None
) -> bool:
    """Does each enclosure ``enc[r]`` (``r`` in ``keep``) lie in a box of the six joint angles
    where Krawczyk proves exactly one root for every arm within the model's links' radii and
    every goal in the closed form's goal box (which holds the pose as given, :func:`relaxed_roots`)
    -- or, for those where it does not, two by two, do the angle boxes of each two hold exactly
    two roots of the model (:func:`_pairs_separated`, with ``pose`` the goal's XYZQUAT as given)?
    False where there is no joint certifier
    (``tests/search/test_cf_seeded_one_root.py::test_a_merged_pair_is_answered_only_where_it_is_separated``)."""
    from .cf_certify import CERT_UNIQUE, JointCertifier, enclosure_reach, newton6, workspace
    from .slab_proof import krawczyk_wide

    jc = cf.joint_certifier
    if not isinstance(jc, JointCertifier):
        return False
    Rlo, Rhi, tlo, thi = (a[0] for a in cf.goal_arrays(goal_R[None], goal_t[None]))
    Gm = 0.5 * Rlo + 0.5 * Rhi
    Gr = np.nextafter(np.maximum(Gm - Rlo, Rhi - Gm), np.inf)
    gtm = 0.5 * tlo + 0.5 * thi
    gtr = np.nextafter(np.maximum(gtm - tlo, thi - gtm), np.inf)
    G = (np.ascontiguousarray(Gm.T), np.ascontiguousarray(Gr.T), gtm, gtr)
    LR, Lt, d, _, _, _, _, _, perm, shift = jc.kernel_args()
    ws = workspace()
    ang, th, need, step, rad, klo, khi = (np.zeros(6) for _ in range(7))
    failed: list[tuple[np.ndarray, np.ndarray]] = []
    for r in keep:
        root_angles(enc[r], ang)
        th[perm] = ang + shift
        centre = th.copy()
        if not enclosure_reach(enc[r], ang, centre, perm, shift, need):
            return False
        box = (centre - need, centre + need)
        if not newton6(th, LR, Lt, d, *G, ws, NEWTON_STEPS, step) or not enclosure_reach(enc[r], ang, th, perm, shift, need):
            failed.append(box)
            continue
        for grow in ONE_ROOT_GROWTH:
            rad[:] = np.maximum(grow * need, grow * np.abs(step))
            if krawczyk_wide(th, rad, LR, Lt, d, *G, klo, khi, ws) == CERT_UNIQUE:
                break
        else:
            failed.append(box)
    return not failed or (pose is not None and _pairs_separated(cf, pose, failed))


def _pairs_separated(cf: ClosedForm, pose: np.ndarray, boxes: list[tuple[np.ndarray, np.ndarray]]) -> bool:
    """The enclosures Krawczyk does not prove alone (their angle boxes, geometry angles, each
    holding every root its enclosure holds), each with its nearest: do the two boxes of each
    hold exactly two roots of the model (:func:`kinbox.search.separate.separate_pair`, about
    the middle of their centres, the arm's constants enclosed)? Then the enclosures hold at
    most as many roots as there are of them."""
    from .separate import arm_constants, separate_pair

    tc = cf.certifier
    if len(boxes) % 2 or tc is None:
        return False
    cs = arm_constants(tc.arm.geometry, tc.arm.constants)
    rest = list(boxes)
    while rest:
        a = rest.pop(0)
        ca = 0.5 * (a[0] + a[1])
        k = min(range(len(rest)), key=lambda j: float(np.max(np.abs(0.5 * (rest[j][0] + rest[j][1]) - ca))))
        b = rest.pop(k)
        c = 0.5 * (ca + 0.5 * (b[0] + b[1]))
        if separate_pair(cs, np.asarray(pose, dtype=float), c, [a, b]) is None:
            return False
    return True


def _angles(x: np.ndarray, tc, theta: np.ndarray) -> np.ndarray:
    """The family's angles at the system point ``x`` (where both of a joint's variables are
    there; else ``theta``'s)."""
    out = theta.copy()
    for i in range(6):
        if tc.cvar[i] >= 0 and tc.svar[i] >= 0:
            out[i] = math.atan2(x[tc.svar[i]], x[tc.cvar[i]]) - tc.shift[i]
    return out


def relaxed_roots(cf: ClosedForm, goal_R: np.ndarray, goal_t: np.ndarray) -> tuple[np.ndarray, list[int]] | None:
    """The closed form's enclosures of the goal with its undecided discriminants relaxed, and
    the indices of those not proven outside the joint limits (at most one root within the
    limits each, every such root in one: see the module's text); None where there is no bound
    (a pivot holding zero, a joint free on its circle, a root's limits undecided)."""
    Rlo, Rhi, tlo, thi = (np.ascontiguousarray(a[0]) for a in cf.goal_arrays(goal_R[None], goal_t[None]))
    enc = np.zeros((MAX_ROOTS, 6, 4))
    n, _ = solve_branches(cf.code, cf.LR, cf.Lt, cf.d, Rlo, Rhi, tlo, thi, enc, np.zeros((4, 3, 4)), False, True)
    if n == -1:
        return None
    n = n if n >= 0 else -2 - n
    keep = []
    for k in range(n):
        if np.any((enc[k, :, 0] <= -1.0) & (enc[k, :, 1] >= 1.0) & (enc[k, :, 2] <= -1.0) & (enc[k, :, 3] >= 1.0)):
            return None  # a joint free on its circle (a wrist singularity): no bound on the roots
        verdict = _in_limits(enc[k], cf.limits)
        if verdict < 0:
            return None
        if verdict == 1:
            keep.append(k)
    return enc, keep
