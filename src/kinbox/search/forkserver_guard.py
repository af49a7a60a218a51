"""Imported by the multiprocessing fork server of a kinbox search when it starts (its
``preload``): the fork server dies with the process that started it, and so (by their own
parent-death signal) do the workers it forked. See :mod:`kinbox.search.lifeline`."""

from .lifeline import die_with_parent

die_with_parent()
