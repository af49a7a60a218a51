"""Stage 2, the equations: polynomial systems of degree two (:mod:`~kinbox.formulation.system`),
the pair equations (:mod:`~kinbox.formulation.pairs`), a mechanism's system
(:mod:`~kinbox.formulation.build`) and the way back to joint values
(:mod:`~kinbox.formulation.decode`)."""
