"""Workspaces: where a robot can put a frame or its platform, as a certified paving of position
space into boxes proven inside, proven outside, and a boundary layer at the resolution.

* :func:`reach` (:mod:`.serial`): a serial arm's frame with the tool at a fixed orientation
  (:mod:`.arm`), at any orientation or within a cone (:mod:`.free`);
* :func:`reach_platform`: a parallel platform (Gough-Stewart, 3-RPR) at a constant orientation
  (:mod:`.platform`);
* :class:`Paving`: the answer, and :func:`pave`, the set-inversion loop both share (:mod:`.paving`).
"""

from .arm import Reach, default_region
from .paving import BOUNDARY, INSIDE, OUTSIDE, VERDICTS, Paving, pave
from .platform import PlatformReach, reach_platform
from .serial import reach

__all__ = [
    "Paving",
    "Reach",
    "PlatformReach",
    "reach",
    "reach_platform",
    "pave",
    "default_region",
    "VERDICTS",
    "OUTSIDE",
    "INSIDE",
    "BOUNDARY",
]
