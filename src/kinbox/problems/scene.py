"""A collision scene of a loaded robot, shared by the problem kinds that take ``scene=``."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

from ..answer.result import Result
from ..errors import InputError
from ..model.mechanism import Mechanism

if TYPE_CHECKING:  # loaded with a scene only (tests/answer/test_scene.py::test_no_scene_loads_no_geometry)
    from ..answer.collision import Checker
    from ..model.scene import CollisionScene


class Scene:
    """A collision scene of a loaded robot, its geometry built at once (and again in each
    worker process that receives it pickled: the geometry is not pickled)."""

    def __init__(self, mechanism: Mechanism, robot, scene, srdf: str | None = None):
        from ..model.scene import read_scene

        self.spec = read_scene(scene)
        self.name = self.spec.source or self.spec.name
        self.mechanism = mechanism
        self.robot = robot if isinstance(robot, str) else None
        if srdf is not None and not os.path.isfile(srdf):
            raise InputError(f"no SRDF file {srdf!r}")
        self._robot = robot
        self.srdf = srdf
        self._built: CollisionScene | None = None
        self._checker: Checker | None = None
        _ = self.collision  # a bad mesh or name is reported now, not after the first search

    def __getstate__(self):
        return {**self.__dict__, "_built": None, "_checker": None}

    @property
    def collision(self):
        """The :class:`~kinbox.model.scene.CollisionScene` (built at the first use)."""
        if self._built is None:
            from ..model.scene import build_scene

            self._built = build_scene(self.mechanism, self._robot, self.spec, self.srdf)
        return self._built

    def pruner(self, form):
        """The box test of :mod:`kinbox.search.scene_prune` for a search of ``form``, or None
        (a formulation whose ``c[joint]``, ``s[joint]`` are not the joint angle's cosine and
        sine, or nothing to prune with)."""
        from ..formulation.build import Formulation
        from ..search.scene_prune import scene_pruner

        if not isinstance(form, Formulation) or len(form.system.names) != form.system.n:
            return None
        assert form.impl is not None  # a formulation built by formulate() has one
        return scene_pruner(self.mechanism.model, form.system, self.collision, locked=form.impl.locked)

    def annotate(self, res: Result, collision_free: bool = False, polish=None) -> Result:
        from ..answer.collision import Checker, annotate

        if self._checker is None or self._checker.scene is not self.collision:
            self._checker = Checker(self.collision)  # its Pinocchio and coal data, made once
        return annotate(res, self.collision, collision_free=collision_free, polish=polish, checker=self._checker)
