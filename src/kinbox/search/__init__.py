"""Stage 3, the search: branch-and-prune (:mod:`~kinbox.search.solver`, in the shape of Ibex's
generic solver) over contractors that each only ever discard what holds no solution, behind one
interface (:mod:`~kinbox.search.contract`): interval propagation (:mod:`~kinbox.search.propagate`),
Krawczyk (:mod:`~kinbox.search.certify`), the transverse test (:mod:`~kinbox.search.transverse`),
the LP relaxation (:mod:`~kinbox.search.relaxation`, or the Bernstein polytope of
:mod:`~kinbox.search.bernstein`); the per-box sequence in :mod:`~kinbox.search.steps`, the wave
loop in :mod:`~kinbox.search.waves`, parallel runs in :mod:`~kinbox.search.parallel`."""
