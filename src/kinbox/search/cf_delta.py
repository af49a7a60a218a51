"""How far the model's exact arm can move the tool from the closed form's arm: the goal's widening.

The interval closed form (:mod:`kinbox.search.closed_form`) runs on the family's binary64
constants (:class:`kinbox.formulation.families.Family`: link rotations ``L_i.R``, translations
``L_i.t``, offsets ``d``) and on the canonical goal ``G = A M B`` of binary64 frames ``A``,
``B``. Where every link rotation is a signed permutation (entries 0 and +-1: exactly
orthogonal, the only exactly orthogonal binary64 matrices), those constants are an arm of the
family, and the closed form proves every root of that arm for every goal in its box. The model
as given (:mod:`kinbox.formulation.constants`) is the arm of the exact links ``L'_i`` on the same
``d`` and joint angles, with exact frames ``A'``, ``B'``, each entry within its radius of the
binary64 one. Its forward kinematics ``T'(theta)`` differs from the binary64 arm's ``T(theta)``
by at most, for every ``theta`` (rotations exactly orthogonal; ``|X|_F`` bounds the spectral
norm, which bounds every entry):

* rotation: ``sum_i |L'_i.R - L_i.R|_F``;
* translation: ``sum_i |dt_i| + sum_j (sum_{i before j} |dR_i|_F) (|tau_j| + |dt_j|)`` over the
  chain's translations ``tau_j`` (the ``d_k e_z`` and the links' ``L_i.t``), from ``t =
  sum_j R_<j tau_j``;

and its goal ``A' M B'`` from ``A M B`` by ``|dA.R|_F + (1 + |dA.R|_F) |dB.R|_F`` in the
rotation and ``|dA.R|_F (|B.t| + |dB.t| + |t_M|) + (1 + |dA.R|_F) |dB.t| + |dA.t|`` in the
translation. A root ``theta`` of the model as given for the goal ``M`` is then a root of the
binary64 arm for the goal ``T(theta)``, within :class:`Delta` of ``A M B``, entry by entry:
widened by it (and by :data:`~kinbox.search.closed_form.GOAL_ERR` for the rounding of ``A M
B``), the closed form's enclosures hold every root of the model as given. Computed once per
arm in ``mpmath.iv`` (120 bits, rounded outward), then rounded up to binary64
(``tests/search/test_cf_delta.py``).

Where a link rotation ``L_i.R`` is not a signed permutation (a twist that is no multiple of a
right angle, read off a DH table or a URDF's rpy), the binary64 matrix is no rotation, and the
arm compared against is instead the one of the rotations ``Q_i``, the orthogonal polar factors
of ``L_i.R``: exactly orthogonal, of determinant 1, and keeping every row and column of ``L_i.R``
that is exactly ``+-`` a unit vector (a block of a signed permutation is its own polar factor),
so that the family's structure (lines parallel: the ``z`` row and column ``+-e_z``) holds for
them exactly. With ``E = L_i.R^T L_i.R - I`` and ``L_i.R = U S V^T``, ``Q_i = U V^T`` and
``|Q_i - L_i.R|_2 = max |1 - s| <= max |1 - s^2| <= |E|_F``: each entry of ``Q_i`` lies within
``|E|_F`` of ``L_i.R`` (0 on the rows and columns kept), :func:`kernel_links`. The closed form's
kernels then take the enclosures ``[L_i.R - e, L_i.R + e]`` in place of the binary64 matrix
(:func:`kinbox.search.closed_form.lent`), so that every identity of the families' algebra
(orthogonality, the structure) holds for the exact ``Q_i`` inside them and the enclosures of
the roots are those of the arm of the ``Q_i``, and the bound above is taken with ``|L'_i -
Q_i| <= |L'_i - L_i.R| + e`` (``tests/search/test_cf_twist.py``).

Where the model's constants are not enclosed for the family's geometry (a family read off the
reversed chain; or no enclosure of the constants while a link is not a signed permutation),
there is no such arm: :attr:`Delta.proven` is False and the goal's box is the whole space
(:data:`UNPROVEN`), so that every pose goes to the branch and prune.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

#: the widening where no bound is proven: larger than any entry of a rotation or of a
#: translation the closed form is asked about, so that no discriminant is decided
UNPROVEN = 1e6


@dataclass(frozen=True)
class Delta:
    """Per entry of the canonical goal, the widening that holds the model's exact arm: ``R``
    (rotation entries), ``t0 + t1 |t_M|`` (translation entries, ``|t_M|`` the goal's
    translation length); ``proven`` False: no bound (module docstring)."""

    R: float
    t0: float
    t1: float
    proven: bool = True


NONE = Delta(0.0, 0.0, 0.0)
NOT_PROVEN = Delta(UNPROVEN, UNPROVEN, 0.0, False)


def signed_permutation(R: np.ndarray) -> bool:
    """Is ``R`` exactly a signed permutation (each row and column one entry +-1, the rest 0)?"""
    A = np.abs(np.asarray(R, dtype=float))
    return bool(np.all((A == 0.0) | (A == 1.0)) and np.all(A.sum(axis=0) == 1.0) and np.all(A.sum(axis=1) == 1.0))


def orthogonal_radii(R: np.ndarray) -> np.ndarray | None:
    """Per entry, a bound on ``|Q - R|`` for the orthogonal polar factor ``Q`` of the binary64
    matrix ``R`` (module docstring): ``|R^T R - I|_F`` (computed in ``mpmath.iv``, 120 bits,
    rounded up), 0 on each row and column of ``R`` exactly ``+-`` a unit vector; all 0 for a
    signed permutation. None where ``R`` is not within 1/4 of a rotation (no such bound taken)."""
    R = np.asarray(R, dtype=float)
    if signed_permutation(R):
        return np.zeros((3, 3))
    from mpmath import iv

    old = iv.prec
    iv.prec = 120
    try:
        X = [[iv.mpf(float(R[i, j])) for j in range(3)] for i in range(3)]
        s = iv.mpf(0)
        for i in range(3):
            for j in range(3):
                e = sum((X[k][i] * X[k][j] for k in range(3)), iv.mpf(0)) - (1 if i == j else 0)
                s += e * e
        eps = iv.sqrt(s)
        det = X[0][0] * (X[1][1] * X[2][2] - X[1][2] * X[2][1]) - X[0][1] * (X[1][0] * X[2][2] - X[1][2] * X[2][0])
        det += X[0][2] * (X[1][0] * X[2][1] - X[1][1] * X[2][0])
        if not (eps.b < 0.25 and det.a > 0.5):
            return None
        f = float(eps.b)
        bound = float(np.nextafter(f, np.inf)) if f < eps.b else f
    finally:
        iv.prec = old
    out = np.full((3, 3), bound)
    A = np.abs(R)
    for i in range(3):
        for j in range(3):
            # row i and column j hold one entry, +-1 at (i, j): kept exactly by the polar factor
            if A[i, j] == 1.0 and A[i].sum() == 1.0 and A[:, j].sum() == 1.0:
                out[i, :] = 0.0
                out[:, j] = 0.0
    return out


def kernel_links(LR: np.ndarray, e: np.ndarray) -> np.ndarray:
    """The link rotations the closed form's kernels take: ``LR`` itself (5, 3, 3) where every
    radius ``e`` (5, 3, 3, :func:`orthogonal_radii`) is 0 (signed permutations), else the
    enclosures ``[LR - e, LR + e]`` (5, 3, 3, 2), rounded outward, 0 radii as points."""
    LR = np.asarray(LR, dtype=float)
    if not np.any(e):
        return np.ascontiguousarray(LR)
    lo = np.where(e > 0.0, np.nextafter(LR - e, -np.inf), LR)
    hi = np.where(e > 0.0, np.nextafter(LR + e, np.inf), LR)
    return np.ascontiguousarray(np.stack([lo, hi], axis=-1))


def delta_of(LR: np.ndarray, Lt: np.ndarray, d: np.ndarray, radii: dict | None, Bt: np.ndarray, e: np.ndarray | None = None) -> Delta:
    """The bound of the module docstring for the family's constants ``LR`` (5, 3, 3), ``Lt``
    (5, 3), ``d`` (6,) and the radii of :func:`kinbox.formulation.constants.enclose_links` on
    the family's geometry (``links``, ``A``, ``B``); ``Bt``: the binary64 ``B``'s translation;
    ``e``: the radii of :func:`orthogonal_radii` per link (None: every link a signed
    permutation, else not proven). ``radii`` None: the binary64 constants are the model
    (:class:`JointCertifier` without constants), the bound zero, where they are an arm (signed
    permutations), else not proven."""
    if e is None:
        if not all(signed_permutation(R) for R in LR):
            return NOT_PROVEN
        e = np.zeros((len(LR), 3, 3))
    exact = not np.any(e)
    if radii is None:
        return NONE if exact else NOT_PROVEN
    if not exact:  # against the arm of the polar factors: |L' - Q| <= |L' - L.R| + e
        radii = dict(radii, links=[(np.nextafter(rR + ei, np.inf), rt) for (rR, rt), ei in zip(radii["links"], e)])
    from mpmath import iv

    old = iv.prec
    iv.prec = 120
    try:

        def norm(a) -> Any:  # an enclosure of the Euclidean / Frobenius norm of floats a
            s = iv.mpf(0)
            for x in np.ravel(np.asarray(a, dtype=float)):
                s += iv.mpf(float(x)) ** 2
            return iv.sqrt(s)

        nR = [norm(rR) for rR, _ in radii["links"]]
        nt = [norm(rt) for _, rt in radii["links"]]
        rot = iv.mpf(0)
        for x in nR:
            rot += x
        # translations along the chain: Tz(d_0), L_1.t, Tz(d_1), ..., L_5.t, Tz(d_5)
        tr = iv.mpf(0)
        before = iv.mpf(0)  # sum of |dR|_F of the links before this translation
        for k in range(6):
            tr += before * abs(iv.mpf(float(d[k])))
            if k == 5:
                break
            tau = norm(Lt[k])
            tr += nt[k] + before * (tau + nt[k])
            before += nR[k]
        (aR, at), (bR, bt) = radii["A"], radii["B"]
        nAR, nAt, nBR, nBt = norm(aR), norm(at), norm(bR), norm(bt)
        rot += nAR + (1 + nAR) * nBR
        tr += nAR * (norm(Bt) + nBt) + (1 + nAR) * nBt + nAt
        t1 = nAR
    finally:
        iv.prec = old

    def up(x) -> float:
        f = float(x.b)
        return float(np.nextafter(f, np.inf)) if f < x.b else f

    return Delta(up(rot), up(tr), up(t1))
