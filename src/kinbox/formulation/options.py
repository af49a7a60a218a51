"""The named choices of the formulation stage, in a module that loads nothing else (the command
line draws its ``choices=`` from here without loading the stage)."""

#: equations of distance closures (legs): ``"squared"`` (fewest variables), ``"vector"`` (a unit
#: vector per leg: linear loop equations, tighter on curves) or ``"auto"`` (by the local
#: dimension of the solution set: :func:`kinbox.problems.mechanism.choose_formulation`)
LEGS = ("auto", "squared", "vector")
