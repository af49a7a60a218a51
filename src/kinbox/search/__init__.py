"""Stage 3, the search: branch-and-prune (:mod:`~kinbox.search.solver`) over contractors that
each only ever discard what holds no solution: interval propagation
(:mod:`~kinbox.search.propagate`), the LP relaxation (:mod:`~kinbox.search.relaxation`, or the
Bernstein polytope of :mod:`~kinbox.search.bernstein`) and
Krawczyk (:mod:`~kinbox.search.certify`); parallel runs in :mod:`~kinbox.search.parallel`."""
