"""The one curve view of every kinbox result: :class:`Curve`, the points of a curve component in
order along each branch, with its bifurcation points.

A mechanism's curves (:attr:`kinbox.answer.result.Result.curves`) hold configurations ``q``; a
constraint system's (:attr:`kinbox.answer.assembly.AssemblyResult.curves`) hold assemblies.
Both are written to JSON as the component's ``samples`` (:meth:`Curve.samples`), a mechanism's
also as its ``polyline`` and ``branches``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Generic, TypeVar

#: what a curve's points are: a configuration (``np.ndarray``) or an assembly
P = TypeVar("P")


@dataclass
class Curve(Generic[P]):
    """A curve component: ordered points of each branch (the longest first; ``closed[k]``: the
    last point of branch ``k`` joins its first), ``residual`` the largest error measured on any
    of them, and its bifurcation points."""

    branches: list[list[P]]
    closed: list[bool]
    residual: float
    bifurcations: list[P]
    #: against a scene: per branch, its collision-free stretches (kinbox.answer.collision)
    collision: list[dict] | None = None

    @property
    def polyline(self) -> list[P]:
        """The longest branch's points in order (what a replay sweeps)."""
        return self.branches[0] if self.branches else []

    def samples(self, at_most: int = 200) -> list[P]:
        """Up to about ``at_most`` points spread evenly along the branches (longest first):
        the ``samples`` of the component in JSON."""
        ordered = [p for b in self.branches for p in b]
        return ordered[:: max(1, len(ordered) // at_most)]
