"""From a system point back to a Pinocchio ``q``, and checking a ``q`` with Pinocchio.

:func:`decode` (also :meth:`kinbox.formulation.Formulation.decode`) returns ``q`` in model
order:

* revolute joints: ``atan2(s, c)``, wrapped into the joint's range when it is narrower than
  ``2 pi`` (to the nearest equivalent angle if the point is slightly outside), else into
  ``(-pi, pi]``; continuous joints (``nq = 2``): ``(c, s)`` normalized;
* prismatic, planar and translation displacements: their variables (planar rotation as
  normalized ``(cos, sin)``);
* spherical and free-flyer joints: the relative rotation of the two frames, projected onto
  SO(3), as a unit quaternion ``(x, y, z, w)`` with ``w >= 0``; ``SphericalZYX``: its angles;
  free-flyer translation from the frame positions;
* locked joints: their locked values; dropped joints: ``pin.neutral``.

:func:`check` measures the closures at a ``q`` with Pinocchio's forward kinematics
(:meth:`Mechanism.closure_residuals`), never with the system.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from ..errors import finite_vector
from .pairs import mat_value, revolute_is_limited
from .system import Expr

TWO_PI = 2.0 * math.pi


def wrap_angle(theta: float, lo: float = -math.inf, hi: float = math.inf, unbounded: bool = False) -> float:
    """``theta`` moved by a multiple of ``2 pi`` into ``[lo, hi]`` if that range is narrower
    than ``2 pi`` (the copy nearest the middle of the range), else into ``(-pi, pi]``."""
    if revolute_is_limited(lo, hi, unbounded):
        mid = 0.5 * (lo + hi)
        return theta + TWO_PI * round((mid - theta) / TWO_PI)
    t = math.remainder(theta, TWO_PI)
    return math.pi if t <= -math.pi else t


def project_rotation(R: np.ndarray) -> np.ndarray:
    """The rotation matrix nearest to ``R`` (Frobenius norm)."""
    U, _, Vt = np.linalg.svd(R)
    D = np.diag([1.0, 1.0, float(np.sign(np.linalg.det(U @ Vt)) or 1.0)])
    return U @ D @ Vt


def quaternion(R: np.ndarray) -> np.ndarray:
    """Unit quaternion ``(x, y, z, w)`` of a rotation matrix (projected first), ``w >= 0``."""
    qv = pin.Quaternion(project_rotation(R)).coeffs().copy()
    qv /= np.linalg.norm(qv)
    return -qv if qv[3] < 0 else qv


def zyx_angles(R: np.ndarray) -> np.ndarray:
    """Angles ``(z, y, x)`` of ``R = Rz Ry Rx`` (Pinocchio's ``SphericalZYX`` ordering)."""
    r, p, y = pin.rpy.matrixToRpy(project_rotation(R))
    return np.array([y, p, r])


def _val(a, x) -> float:
    return a.value(x) if isinstance(a, Expr) else float(a)


def decode(form, x: np.ndarray) -> np.ndarray:
    """The Pinocchio ``q`` of the system point ``x`` of ``form`` (see the module docstring)."""
    impl = form._impl
    system = form.system
    model = form.mechanism.model
    x = finite_vector(x, system.n, "system point", f"the system has {system.n} variables")
    vals = system.full_point(x)
    full = impl.full
    xf = np.array([vals[n] for n in full.names], dtype=float)

    q = pin.neutral(model)
    for jid, v in impl.locked.items():
        j = model.joints[jid]
        q[j.idx_q: j.idx_q + j.nq] = v

    R_cache: dict[int, np.ndarray] = {}

    def R(n: int) -> np.ndarray:
        if n not in R_cache:
            R_cache[n] = mat_value(impl.nodes[n].R.M, xf)
        return R_cache[n]

    def o(n: int) -> np.ndarray:
        return np.array([_val(a, xf) for a in impl.nodes[n].o])

    lo_lim, hi_lim = model.lowerPositionLimit, model.upperPositionLimit
    for e in impl.edges[: impl.n_tree]:
        if e.kind == "fixed":
            continue
        iq = e.part.idx_q
        if e.kind in ("revolute", "planar"):
            c, s = _val(e.vars["c"], xf), _val(e.vars["s"], xf)
            if e.kind == "planar":
                nrm = math.hypot(c, s) or 1.0
                q[iq: iq + 2] = [_val(v, xf) for v in e.vars["d"]]
                q[iq + 2: iq + 4] = [c / nrm, s / nrm]
            elif e.part.unbounded:
                nrm = math.hypot(c, s) or 1.0
                q[iq: iq + 2] = [c / nrm, s / nrm]
            else:
                q[iq] = wrap_angle(math.atan2(s, c), float(lo_lim[iq]), float(hi_lim[iq]))
        elif e.kind in ("prismatic", "translation"):
            dv = e.vars["d"]
            q[iq: iq + len(dv)] = [_val(v, xf) for v in dv]
        else:  # spherical, spherical_zyx, free
            Rpre = R(e.parent) @ e.Rp
            Rrel = Rpre.T @ R(e.child)
            if e.kind == "spherical":
                q[iq: iq + 4] = quaternion(Rrel)
            elif e.kind == "spherical_zyx":
                q[iq: iq + 3] = zyx_angles(Rrel)
            else:
                Rpre = project_rotation(R(e.parent)) @ e.Rp
                t = Rpre.T @ (o(e.child) - o(e.parent) - project_rotation(R(e.parent)) @ e.tp)
                q[iq: iq + 3] = t
                q[iq + 3: iq + 7] = quaternion(Rrel)
    return q


def check(mech, q: np.ndarray) -> dict:
    """Closure residuals of ``mech`` at ``q``, by Pinocchio forward kinematics.

    Returns ``{"closures": {name: {"position": metres, "orientation": radians}},
    "max_position": ..., "max_orientation": ..., "locked": max |q - locked value|}``.
    Orientation errors are ``|log3(Ra^T Rb)|`` (0 for point and distance closures).
    """
    model = mech.model
    q = finite_vector(q, model.nq, "q", f"model {mech.name!r} has nq = {model.nq}")
    out: dict = {}
    for k, (name, pos, rot) in enumerate(mech.closure_residuals(q)):
        key = name if name not in out else f"{name}#{k}"
        out[key] = {"position": float(pos), "orientation": float(rot)}
    locked = 0.0
    for jid, v in mech.locked_q().items():
        j = model.joints[jid]
        locked = max(locked, float(np.max(np.abs(q[j.idx_q: j.idx_q + j.nq] - v))))
    return {
        "closures": out,
        "max_position": max((r["position"] for r in out.values()), default=0.0),
        "max_orientation": max((r["orientation"] for r in out.values()), default=0.0),
        "locked": locked,
    }
