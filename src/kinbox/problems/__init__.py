"""Problem kinds around one :func:`~kinbox.problems.run.run`: the stage between the answer and the
command line.

* :mod:`kinbox.problems.run`: :func:`run` (the clock, the options, the search, the answer, the
  search again) and the :class:`~kinbox.problems.run.Searchable` protocol of a problem kind;
* :mod:`kinbox.problems.mechanism`: a joint-space :class:`Problem`; :func:`solve` (mechanisms
  with loops);
* :mod:`kinbox.problems.ik`: :class:`IK` and :func:`ik` (every configuration for a pose);
* :mod:`kinbox.problems.batch`: many poses of one arm (the API's and the command line's);
* :mod:`kinbox.problems.constraints`: :class:`Assemble`, :func:`assemble` (geometric
  constraint systems) and :func:`check` (diagnosis before solving, :mod:`kinbox.problems.diagnosis`);
* :mod:`kinbox.problems.scene`: a collision scene for ``scene=``;
* :mod:`kinbox.problems.kernels`: every compiled kernel loaded at once (``make setup``).

The modules load on first use (``import kinbox`` loads none of them).
"""
