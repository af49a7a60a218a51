"""The workspace of a serial arm's frame: :func:`reach`, which paves it with the tool at a fixed
orientation (:class:`~kinbox.workspace.arm.Reach`), with any orientation or within a cone
(:class:`~kinbox.workspace.free.FreeReach`, built on the former) -- one entry above the two
deciders, so neither imports the other back (``tests/support/test_source_shape.py``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ..errors import InputError
from ..pipeline import IK, parse_pose
from .arm import Reach, default_region
from .free import FreeReach
from .paving import MAX_BOXES, Paving, check_region, check_resolution, pave


def reach(
    robot,
    frame: str,
    orientation: Sequence[float] | str | None = None,
    *,
    cone: Sequence[float] | None = None,
    region: Sequence[float] | None = None,
    resolution: float = 0.05,
    base: str | None = None,
    lock: dict | None = None,
    workers: int | None = None,
    executor=None,
    max_boxes: int = MAX_BOXES,
    progress: Callable[[dict], None] | None = None,
    method: str = "auto",
    resume: Paving | None = None,
) -> Paving:
    """The workspace of ``frame`` with the tool held at ``orientation`` (``qx qy qz qw`` in the base
    frame; default ``0 0 0 1``), or with any orientation (``orientation="any"``: the position
    workspace), or with the tool's ``z`` axis within a cone (``cone=(ax, ay, az, angle)``, the angle
    in radians; :mod:`kinbox.workspace.free`) as a :class:`Paving` of ``region`` (``xmin ymin zmin
    xmax ymax zmax``; default :func:`default_region`) down to boxes of side ``resolution`` (metres).
    ``workers`` decides boxes over local processes, ``executor`` (a ``dask.distributed.Client`` or a
    scheduler address) on a Dask cluster: the paving is the same either way. ``progress`` is called
    after each wave and subtree task with the counts and volumes decided so far. ``method``: "auto" decides boxes
    with the arm's closed form where its geometry has one, "search" always with the IK system's
    search and the parametric Krawczyk test (:data:`METHODS`). ``resume``: a paving of the same
    problem stopped by its budget, continued (:func:`~kinbox.workspace.paving.pave`).
    """
    resolution = check_resolution(resolution)
    free = cone is not None or isinstance(orientation, str)
    if isinstance(orientation, str) and orientation != "any":
        raise InputError(f"the orientation is four numbers qx qy qz qw or 'any', not {orientation!r}")
    if cone is not None and orientation is not None:
        raise InputError("give the tool's orientation once: a fixed orientation, 'any', or a cone")
    ik = IK(robot, frame, base=base, lock=lock, formulation="arm")
    reach_: Any
    if free:
        reach_ = FreeReach(ik, cone, method)
        orient: Any = "any" if reach_.cone is None else None
    else:
        reach_ = Reach(ik, (0.0, 0.0, 0.0, 1.0) if orientation is None else orientation, method)  # type: ignore[arg-type]
        orient = [float(v) for v in reach_.quat]
    if region is None:
        reg = default_region(ik)
    else:
        reg = check_region(region, 3)
    if not free:
        parse_pose(np.concatenate([0.5 * (reg[0] + reg[1]), reach_.quat]))  # validated as any pose
    meta = {
        "robot": robot if isinstance(robot, str) else ik.robot.name,
        "frame": frame,
        "base": base,
        "orientation": orient,
        "lock": dict(lock or {}),
        "joints": [ik.robot.model.names[j] for j in ik.chain],
    }
    if free and reach_.cone is not None:
        meta["cone"] = [*(float(v) for v in reach_.cone[0]), reach_.cone[1]]
    return pave(reach_, reg, resolution, meta, workers=workers, executor=executor, max_boxes=max_boxes, progress=progress, resume=resume)


__all__ = ["reach"]
