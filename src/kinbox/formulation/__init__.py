"""Stage 2, the equations: polynomial systems of degree two (:mod:`~kinbox.formulation.system`),
the pair equations (:mod:`~kinbox.formulation.pairs`), a mechanism's system
(:mod:`~kinbox.formulation.build`) and the way back to joint values
(:mod:`~kinbox.formulation.decode`); for inverse kinematics of six-joint serial arms, a smaller
system built once per arm and frame (:mod:`~kinbox.formulation.arm`) whose coefficients depend
on the goal pose (:mod:`~kinbox.formulation.template`)."""
