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

import numpy as np
import pinocchio as pin

from ..errors import finite_vector
from .pairs import DecodeView, family, mat_value, part_limits, project_rotation
from .system import Expr


def _val(a, x) -> float:
    return a.value(x) if isinstance(a, Expr) else float(a)


def decode(form, x: np.ndarray) -> np.ndarray:
    """The Pinocchio ``q`` of the system point ``x`` of ``form`` (see the module docstring)."""
    impl = form.impl
    system = form.system
    model = form.mechanism.model
    x = finite_vector(x, system.n, "system point", f"the system has {system.n} variables")
    vals = system.full_point(x)
    full = impl.full
    xf = np.array([vals[n] for n in full.names], dtype=float)

    q = pin.neutral(model)
    for jid, v in impl.locked.items():
        j = model.joints[jid]
        q[j.idx_q : j.idx_q + j.nq] = v

    R_cache: dict[int, np.ndarray] = {}

    def R(n: int) -> np.ndarray:
        if n not in R_cache:
            R_cache[n] = mat_value(impl.nodes[n].R.M, xf)
        return R_cache[n]

    def o(n: int) -> np.ndarray:
        return np.array([_val(a, xf) for a in impl.nodes[n].o])

    for e in impl.edges[: impl.n_tree]:
        fam = family(e.kind)

        def rel_rotation(e=e) -> np.ndarray:
            return (R(e.parent) @ e.Rp).T @ R(e.child)

        def rel_translation(e=e) -> np.ndarray:
            Rpar = project_rotation(R(e.parent))
            return (Rpar @ e.Rp).T @ (o(e.child) - o(e.parent) - Rpar @ e.tp)

        if e.part is None:  # a locked joint: its locked value is already in q
            continue
        lo, hi = part_limits(model, e.part)
        v = fam.decode(e.part, e.vars, DecodeView(lambda a: _val(a, xf), rel_rotation, rel_translation, lo, hi))
        if v is not None:
            q[e.part.idx_q : e.part.idx_q + len(v)] = v
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
        locked = max(locked, float(np.max(np.abs(q[j.idx_q : j.idx_q + j.nq] - v))))
    return {
        "closures": out,
        "max_position": max((r["position"] for r in out.values()), default=0.0),
        "max_orientation": max((r["orientation"] for r in out.values()), default=0.0),
        "locked": locked,
    }
