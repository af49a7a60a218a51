"""The revolute pair (Porta, Ros and Thomas 2009, Appendix I; Table III): ``c = cos q``, ``s = sin q`` with the joint
limits, the orientation propagated across the pair, and its closing equations."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from ...errors import FormulationError
from ...interval import cos_range, sin_range
from ..system import Expr, System
from .algebra import Equations, Rot, add_eq, add_ineq, columns, deg, finite_limit, from_columns, mat_mul_const, materialize, simplify, vdot
from .family import DecodeView, FamilyBase, Part, joint_axis, register

TWO_PI = 2.0 * math.pi
_AXES = {"X": np.array([1.0, 0.0, 0.0]), "Y": np.array([0.0, 1.0, 0.0]), "Z": np.array([0.0, 0.0, 1.0])}


def revolute_is_limited(lo: float, hi: float, unbounded: bool = False) -> bool:
    """A revolute range narrower than ``2 pi`` limits the joint; anything else does not."""
    return (not unbounded) and finite_limit(lo, hi) and (hi - lo) < 2 * math.pi


def revolute_angle(sys: Equations, name: str, lo: float = -math.inf, hi: float = math.inf, unbounded: bool = False) -> tuple[Expr, Expr]:
    """The variables ``c[name] = cos q``, ``s[name] = sin q`` of a revolute pair.

    Joint limits (Appendix I): for a range ``[lo, hi]`` narrower than ``2 pi``, ``c`` and ``s``
    get the interval enclosures of ``cos``/``sin`` over the range, and the chord inequality
    ``cos(mid) c + sin(mid) s >= cos(half)`` (``mid``/``half``: centre and half-width of the
    range) cuts the unit circle to exactly the allowed arc (padded outward by a few ulps).
    Unlimited joints get ``[-1, 1]``. The circle equation is written by the caller
    (:func:`revolute_propagate`: core, :func:`revolute_closing`: redundant).
    """
    if lo > hi:
        raise FormulationError(f"joint {name!r} has an empty range [{lo}, {hi}]")
    if revolute_is_limited(lo, hi, unbounded):
        clo, chi = cos_range(lo, hi)
        slo, shi = sin_range(lo, hi)
        c = sys.add_var(f"c[{name}]", clo, chi, "cos")
        s = sys.add_var(f"s[{name}]", slo, shi, "sin")
        mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
        pad = 8 * np.finfo(float).eps
        add_ineq(sys, (math.cos(half) - pad) - (c * math.cos(mid) + s * math.sin(mid)), f"limit:{name}")
    else:
        c = sys.add_var(f"c[{name}]", -1.0, 1.0, "cos")
        s = sys.add_var(f"s[{name}]", -1.0, 1.0, "sin")
    return c, s


def _rot_z_columns(c, s, P1, P2, transpose: bool):
    """Columns 0 and 1 of ``[P1 P2 .] Rot_z(c, s)`` (or ``Rot_z^T`` if ``transpose``)."""
    if not transpose:
        u = [simplify(c * P1[r] + s * P2[r]) for r in range(3)]
        v = [simplify(c * P2[r] - s * P1[r]) for r in range(3)]
    else:
        u = [simplify(c * P1[r] - s * P2[r]) for r in range(3)]
        v = [simplify(s * P1[r] + c * P2[r]) for r in range(3)]
    return u, v


def revolute_propagate(
    sys: System,
    name: str,
    known: Rot,
    Rp: np.ndarray,
    B: np.ndarray,
    labels: tuple[str, str],
    c: Expr,
    s: Expr,
    forward: bool,
    new_frame: str,
) -> Rot:
    """Orientation across a revolute pair, ``R_child = R_parent Rp Rot_a(c, s)``.

    ``forward``: ``known`` is the parent, returns ``R_child``; else ``known`` is the child and
    returns ``R_parent = R_child Rot_a(c, s)^T Rp^T``. Writes the core ``c^2 + s^2 = 1``.

    With ``B = [b1 b2 a]``: ``R_child B = R_parent Rp B Rot_z(c, s)``. If ``known`` is constant
    the result is linear in ``(c, s)``. Otherwise it is bilinear; the two moving columns
    (``R_child b1, R_child b2``, or ``R_parent Rp b1, R_parent Rp b2`` backwards) are
    materialized as 6 variables in ``[-1, 1]`` (6 core definitions; redundant ``|u| = |v| = 1``,
    ``u . v = 0``) only when the result is needed linear (:meth:`Rot.linear`).
    """
    add_eq(sys, c * c + s * s - 1.0, f"circle:{name}")
    Bt = B.T
    if forward:
        P = mat_mul_const(known.linear(), Rp @ B)  # R_parent Rp B
    else:
        P = mat_mul_const(known.linear(), B)  # R_child B
    P1, P2, P3 = columns(P)
    u, v = _rot_z_columns(c, s, P1, P2, transpose=not forward)
    post = Bt if forward else Bt @ Rp.T

    def assemble(u, v):
        return mat_mul_const(from_columns([u, v, P3]), post)

    out = Rot(assemble(u, v))
    if max(deg(a) for a in u + v) > 1:
        prefix = f"R[{new_frame}]" if forward else f"Rin[{name}]"

        def make_linear():
            uu = [materialize(sys, u[r], f"{prefix}[{r},{labels[0]}]") for r in range(3)]
            vv = [materialize(sys, v[r], f"{prefix}[{r},{labels[1]}]") for r in range(3)]
            add_eq(sys, vdot(uu, uu) - 1.0, f"unit:{prefix}[{labels[0]}]", redundant=True)
            add_eq(sys, vdot(vv, vv) - 1.0, f"unit:{prefix}[{labels[1]}]", redundant=True)
            add_eq(sys, vdot(uu, vv), f"ortho:{prefix}", redundant=True)
            out.M = assemble(uu, vv)

        out.on_linear(make_linear)
    return out


def revolute_closing(sys: System, name: str, parent: Rot, Rp: np.ndarray, child: Rot, B: np.ndarray, c: Expr, s: Expr) -> None:
    """Closing equations of a revolute pair whose two frames were both reached elsewhere.

    With ``M = (R_parent Rp B)^T (R_child B)`` (which must be ``Rot_z(c, s)``): core
    ``M[0,2] = M[1,2] = 0`` (the axes agree up to sign), ``M[0,0] = c``, ``M[1,0] = s``;
    inequality ``M[2,2] >= 0`` (not the flipped axis); redundant ``M[2,2] = 1``,
    ``c^2 + s^2 = 1``, ``M[0,1] = -s``, ``M[1,1] = c``, ``M[2,0] = M[2,1] = 0``.
    """
    P = columns(mat_mul_const(parent.linear(), Rp @ B))
    Q = columns(mat_mul_const(child.linear(), B))

    def M(i, j):
        return vdot(P[i], Q[j])

    add_eq(sys, M(0, 2), f"axis:{name}[0]")
    add_eq(sys, M(1, 2), f"axis:{name}[1]")
    add_eq(sys, M(0, 0) - c, f"cos:{name}")
    add_eq(sys, M(1, 0) - s, f"sin:{name}")
    add_ineq(sys, -M(2, 2), f"axis-sign:{name}")
    add_eq(sys, M(2, 2) - 1.0, f"axis:{name}[2]", redundant=True)
    add_eq(sys, c * c + s * s - 1.0, f"circle:{name}", redundant=True)
    add_eq(sys, M(0, 1) + s, f"rot:{name}[0,1]", redundant=True)
    add_eq(sys, M(1, 1) - c, f"rot:{name}[1,1]", redundant=True)
    add_eq(sys, M(2, 0), f"rot:{name}[2,0]", redundant=True)
    add_eq(sys, M(2, 1), f"rot:{name}[2,1]", redundant=True)


def wrap_angle(theta: float, lo: float = -math.inf, hi: float = math.inf, unbounded: bool = False) -> float:
    """``theta`` moved by a multiple of ``2 pi`` into ``[lo, hi]`` if that range is narrower
    than ``2 pi`` (the copy nearest the middle of the range), else into ``(-pi, pi]``."""
    if revolute_is_limited(lo, hi, unbounded):
        mid = 0.5 * (lo + hi)
        return theta + TWO_PI * round((mid - theta) / TWO_PI)
    t = math.remainder(theta, TWO_PI)
    return math.pi if t <= -math.pi else t


class Revolute(FamilyBase):
    """RX, RY, RZ, RevoluteUnaligned; continuous RUBX, RUBY, RUBZ, RevoluteUnboundedUnaligned
    (``nq = 2``, ``q = (cos, sin)``)."""

    kind = "revolute"
    label = "revolute, continuous"
    rotation = "rev"
    translation = "none"
    pinocchio_types = ("RX", "RY", "RZ", "RevoluteUnaligned", "RUBX", "RUBY", "RUBZ", "RevoluteUnboundedUnaligned")

    def part(self, jmodel, short: str, placement: pin.SE3, path: tuple) -> Part:
        unbounded = short.startswith("RUB") or short == "RevoluteUnboundedUnaligned"
        axis = _AXES[short[-1]].copy() if short in ("RX", "RY", "RZ", "RUBX", "RUBY", "RUBZ") else joint_axis(jmodel, True)
        return Part(self.kind, placement, int(jmodel.idx_q), int(jmodel.nq), axis, unbounded=unbounded, path=path)

    def angle(self, sys: Equations, name: str, part: Part, lo: np.ndarray, hi: np.ndarray) -> tuple[Expr, Expr]:
        return revolute_angle(sys, name, float(lo[0]), float(hi[0]), part.unbounded)

    def decode(self, part: Part, variables: dict, view: DecodeView) -> np.ndarray:
        c, s = view.value(variables["c"]), view.value(variables["s"])
        if part.unbounded:
            nrm = math.hypot(c, s) or 1.0
            return np.array([c / nrm, s / nrm])
        return np.array([wrap_angle(math.atan2(s, c), float(view.lo[0]), float(view.hi[0]))])

    def limits_search(self, part: Part, lo: np.ndarray, hi: np.ndarray) -> bool:
        return revolute_is_limited(float(lo[0]), float(hi[0]), part.unbounded)


REVOLUTE = register(Revolute())
