"""The pairs and closures of a mechanism, one module per pair family (Porta, Ros and Thomas 2009, Sec. III, Table III,
Appendices I and II).

Each family module defines a :class:`~.family.PairFamily` (which Pinocchio joint types it
covers, how the child frame's orientation follows the parent's, its variables with the joint
limits as domains, and how its ``q`` is read back) and registers it;
:mod:`kinbox.formulation.build` walks the kinematic tree and asks each edge's family. Adding a
pair touches one module here.

==============================  =================================================================
module                          what it holds
==============================  =================================================================
:mod:`.family`                  :class:`PairFamily`, :class:`Part`, the registry
                                (:func:`family`), :func:`joint_parts` (composite joints: one part
                                per sub-joint, in sequence; :func:`sub_joint`)
:mod:`.revolute`                ``c, s`` with the domains of Appendix I and the chord inequality
                                (:func:`revolute_angle`), propagation
                                (:func:`revolute_propagate`), closing equations
                                (:func:`revolute_closing`), decoding (:func:`wrap_angle`)
:mod:`.prismatic`               ``d`` (:func:`displacement`)
:mod:`.planar`                  ``x, y``; rotation as a revolute about z
:mod:`.translation`             ``x, y, z``
:mod:`.universal`               two revolute parts about orthogonal axes through one point
:mod:`.spherical`               spherical and ZYX: :func:`free_rotation` of the child frame
:mod:`.free_flyer`              free rotation + world position (:func:`free_flyer_translation`,
                                :func:`free_flyer_limits`)
:mod:`.fixed`                   locked joints and welds (constant relative orientation,
                                :func:`const_propagate`)
:mod:`.closures`                point, weld (:func:`weld_orientation`) and distance closures
:mod:`.algebra`                 scalars, vectors and matrices of ``Expr``; :class:`Rot`
==============================  =================================================================

Orientations are 3x3 matrices held by :class:`Rot`: either a numpy array (a constant) or
nested lists of :class:`~kinbox.system.Expr`/floats of degree <= 2. A degree-2 orientation (a
revolute propagated from a non-constant frame) is only **materialized** (its two moving columns
become auxiliary variables) when something needs it linear: a further propagation across a
revolute, a closing equation, or a product with a displacement variable. Used only in position
sums, it stays bilinear and costs no variable.

Variable names: ``c[j]``, ``s[j]`` (cos and sin of revolute ``j``), ``d[j]`` (prismatic),
``d[j][k]`` (planar / translation displacements), ``t[j][k]`` (free-flyer translation, world
frame, eliminated), ``R[f][r,k]`` (entry ``(r, k)`` of the orientation of frame ``f``: free
rotations, and materialized columns of a revolute's child frame when the axis is a coordinate
axis; ``R[f][r,b1]`` / ``R[f][r,b2]`` when it is not: entry ``r`` of ``R_f b1``),
``Rin[j][r,k]`` (the same for the frame *before* the motion of ``j``, ``R_parent * Rp``, when
propagating backwards across ``j``), ``dir[closure][k]`` (unit vector of a distance closure).
Tags: ``cos``, ``sin``, ``rot``, ``disp``, ``unit``.
"""

from .algebra import (
    PLACEHOLDER_BOUND,
    SNAP,
    UNBOUNDED,
    Equations,
    Rot,
    add_eq,
    add_ineq,
    axis_basis,
    columns,
    const_propagate,
    deg,
    finite_limit,
    from_columns,
    lincomb,
    mat_degree,
    mat_mul_const,
    mat_value,
    mat_vec_const,
    materialize,
    simplify,
    snap,
    vadd,
    vcross,
    vdot,
    vscale,
    vsub,
)
from .closures import distance_closure, point_closure, unit_vector, weld_orientation
from .family import FAMILIES, DecodeView, PairFamily, Part, family, joint_axis, joint_parts, part_limits, sub_joint
from .fixed import Fixed
from .free_flyer import FreeFlyer, free_flyer_limits, free_flyer_translation
from .planar import Planar
from .prismatic import Prismatic, displacement
from .revolute import Revolute, revolute_angle, revolute_closing, revolute_is_limited, revolute_propagate, wrap_angle
from .spherical import Spherical, SphericalZYX, free_rotation, project_rotation, quaternion, zyx_angles
from .translation import Translation
from .universal import Universal  # noqa: F401 (importing the module registers the pair)

__all__ = [
    "FAMILIES",
    "PLACEHOLDER_BOUND",
    "SNAP",
    "UNBOUNDED",
    "DecodeView",
    "Equations",
    "Fixed",
    "FreeFlyer",
    "PairFamily",
    "Part",
    "Planar",
    "Prismatic",
    "Revolute",
    "Rot",
    "Spherical",
    "SphericalZYX",
    "Translation",
    "add_eq",
    "add_ineq",
    "axis_basis",
    "columns",
    "const_propagate",
    "deg",
    "displacement",
    "distance_closure",
    "family",
    "finite_limit",
    "free_flyer_limits",
    "free_flyer_translation",
    "free_rotation",
    "from_columns",
    "joint_axis",
    "joint_parts",
    "part_limits",
    "lincomb",
    "mat_degree",
    "mat_mul_const",
    "mat_value",
    "mat_vec_const",
    "materialize",
    "point_closure",
    "project_rotation",
    "quaternion",
    "revolute_angle",
    "revolute_closing",
    "revolute_is_limited",
    "revolute_propagate",
    "simplify",
    "snap",
    "sub_joint",
    "unit_vector",
    "vadd",
    "vcross",
    "vdot",
    "vscale",
    "vsub",
    "weld_orientation",
    "wrap_angle",
    "zyx_angles",
]
