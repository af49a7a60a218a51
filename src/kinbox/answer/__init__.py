"""Stage 4, the answer: solver boxes turned into joint-space solutions checked with Pinocchio
(:mod:`~kinbox.answer.result`, :mod:`~kinbox.answer.refine`) and their structure
(:mod:`~kinbox.answer.components`)."""
