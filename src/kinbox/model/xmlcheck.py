"""Limits of a robot file (URDF or MJCF), checked on its text before Pinocchio sees it.

Pinocchio reads the model; this module only walks the XML elements once with the standard
library's expat parser to count and bound what would make the loader crash, run out of memory
or silently drop a value:

* the root element says what the file is (``<robot>``: URDF, ``<mujoco>``: MJCF), not a
  word found anywhere in its first bytes (a comment may mention the other);
* links (URDF) and bodies (MJCF) at most :data:`~kinbox.errors.MAX_LINKS`, movable joints at
  most :data:`~kinbox.errors.MAX_MODEL_DOF`, elements nested at most
  :data:`~kinbox.errors.MAX_XML_DEPTH` deep (Pinocchio's loaders recurse along the tree);
* numbers of the kinematic and inertial attributes finite (urdfdom skips an inertial it
  cannot read, MuJoCo's format has no NaN);
* a URDF ``<mimic>`` names a joint of the file; an MJCF ``<include>`` is refused (it reads
  another file, which these checks would not see).

Each refusal is a :class:`~kinbox.errors.ModelError` naming the file and the line.
"""

from __future__ import annotations

import math
from xml.parsers import expat

from ..errors import MAX_LINKS, MAX_MODEL_DOF, MAX_XML_DEPTH, ModelError

#: attributes that hold numbers, in URDF and MJCF
_NUMERIC = frozenset(
    "xyz rpy value ixx ixy ixz iyy iyz izz lower upper effort velocity multiplier offset "
    "pos quat euler axisangle xyaxes zaxis axis range mass diaginertia fullinertia fromto ref "
    "springref anchor relpose".split()
)


class _Refused(Exception):
    pass


def robot_format(data: bytes, where: str) -> str:
    """``"urdf"`` or ``"mjcf"`` for the robot file ``data`` (its bytes), after the checks of
    the module docstring; ``where`` names the file in messages
    (tests/cli/test_hostile.py::test_robot_file_limits)."""
    try:
        data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise ModelError(f"{where} is not UTF-8 text (byte {e.start}); save it as UTF-8") from None
    state = {"depth": 0, "links": 0, "movable": 0}
    root = [""]
    joints: set[str] = set()
    mimics: list[tuple[str, int]] = []
    p = expat.ParserCreate()

    def start(tag: str, attrs: dict[str, str]) -> None:
        line = p.CurrentLineNumber
        state["depth"] += 1
        depth = state["depth"]
        if depth == 1:
            root[0] = tag
            if tag not in ("robot", "mujoco"):
                raise _Refused(f"its root element is <{tag}>, neither <robot> (URDF) nor <mujoco> (MJCF)")
        if depth > MAX_XML_DEPTH:
            raise _Refused(f"line {line}: elements nested deeper than {MAX_XML_DEPTH} levels")
        for k, v in attrs.items():
            if k in _NUMERIC and not _finite_numbers(v, allow_inf=k in ("lower", "upper", "range")):
                raise _Refused(f'line {line}: <{tag} {k}="{v[:40]}">: not a finite number')
        urdf = root[0] == "robot"
        if (urdf and tag == "link" and depth == 2) or (not urdf and tag == "body"):
            state["links"] += 1
            if state["links"] > MAX_LINKS:
                what = "links" if urdf else "bodies"
                raise _Refused(f"more than {MAX_LINKS} {what} (line {line}), the limit")
        if urdf and tag == "joint" and depth == 2:
            joints.add(attrs.get("name", ""))
            movable = attrs.get("type", "fixed") != "fixed"
        else:
            movable = not urdf and tag in ("joint", "freejoint")
        if movable:  # counted to the end, to name the number
            state["movable"] += 1
        if urdf and tag == "mimic":
            mimics.append((attrs.get("joint", ""), line))
        if not urdf and tag == "include":
            raise _Refused(
                f"line {line}: <include> is not supported (it would read {attrs.get('file', 'another file')!r}); merge the files"
            )

    def end(tag: str) -> None:
        state["depth"] -= 1

    p.StartElementHandler = start
    p.EndElementHandler = end
    try:
        p.Parse(data, True)
    except _Refused as e:
        raise ModelError(f"{where}: {e}") from None
    except expat.ExpatError as e:
        raise ModelError(f"{where} is not well-formed XML: {expat.ErrorString(e.code)} (line {e.lineno})") from None
    if state["movable"] > MAX_MODEL_DOF:
        n = state["movable"]
        raise ModelError(f"{where}: {n} movable joints, at least {n} degrees of freedom, more than the limit of {MAX_MODEL_DOF}")
    for name, line in mimics:
        if name not in joints:
            raise ModelError(f"{where}: line {line}: <mimic joint={name!r}> names no joint of the file")
    return "urdf" if root[0] == "robot" else "mjcf"


def _finite_numbers(text: str, allow_inf: bool = False) -> bool:
    """False if ``text`` holds a NaN (or an infinity, unless ``allow_inf``: an unlimited
    joint) among its numbers; other words are left to the loader, which names them."""
    for tok in text.replace(",", " ").split():
        try:
            x = float(tok)
        except ValueError:
            continue
        if math.isnan(x) or (math.isinf(x) and not allow_inf):
            return False
    return True
