"""The named choices of every problem kind, in a module that loads nothing heavy: the library
checks its arguments against them and the command line offers them (``choices=``), so the two
cannot differ (tests/cli/test_cli.py::test_cli_choices_are_the_library_s)."""

from ..formulation.options import LEGS

#: how :class:`kinbox.IK` formulates: ``"auto"`` (for six revolute joints with no wrist or
#: shoulder centre, Raghavan and Roth's invariants; for other chains of six revolute or
#: prismatic joints the arm template; else the general formulation), ``"invariants"`` or
#: ``"arm"`` (that template, or an error) or ``"general"``
#: (:func:`~kinbox.formulation.build.formulate` for every pose)
ARM_FORMULATIONS = ("auto", "invariants", "arm", "general")
#: ``formulation=`` of :func:`kinbox.solve`: the planar one for a mechanism whose joint axes are
#: all parallel (:mod:`kinbox.formulation.planar`), else the general one
MECHANISM_FORMULATIONS = ("auto", "planar", "general")
#: ``formulation=`` of :func:`kinbox.assemble`: coordinates of the entities, or distances
#: under Cayley-Menger conditions (points and lines under distances only)
CONSTRAINT_FORMULATIONS = ("auto", "coordinates", "distances")
#: ``kinbox solve --formulation``: a constraint system's or a mechanism's
SOLVE_FORMULATIONS = tuple(dict.fromkeys(CONSTRAINT_FORMULATIONS + MECHANISM_FORMULATIONS))

__all__ = ["ARM_FORMULATIONS", "CONSTRAINT_FORMULATIONS", "LEGS", "MECHANISM_FORMULATIONS", "SOLVE_FORMULATIONS"]
