"""Joints whose range is wider than a full turn (an IRB 120's sixth joint, +-400 degrees; a
UR's +-2 pi): the search works on the angle's cosine and sine, so one solution stands for every
``q + 2 pi k`` inside the limits. The answer names these joints and how many configurations
within the limits its solutions stand for; ``all_turns=True`` lists them all, each a solution
of its own (test_joints_wider_than_a_turn_list_their_copies).

The solution kept by default is the copy in ``(-pi, pi]`` when it is inside the limits, else the
copy inside the limits nearest to it: never a value outside the limits.
"""

from __future__ import annotations

import copy
import itertools
import math

import numpy as np

TWO_PI = 2.0 * math.pi
#: a range wider than a turn by more than this (radians) holds two copies of some angles
WIDER = 1e-9


def wrapping_joints(res) -> dict[str, tuple[int, float, float]]:
    """Joint name -> (its ``q`` index, lower, upper limit) of the solved joints of a result
    whose finite range is wider than a full turn (revolute joints of one ``q`` entry)."""
    form = res.formulated
    if form is None:
        return {}
    model = form.mechanism.model
    names = list(form.joint_vars)
    out: dict[str, tuple[int, float, float]] = {}
    for name in names:
        if not model.existJointName(name) or name in form.mechanism.locked:
            continue
        j = model.joints[model.getJointId(name)]
        if j.nq != 1 or j.nv != 1 or not j.shortname().startswith(("JointModelR", "JointModelRevolute")):
            continue
        if "Unbounded" in j.shortname():
            continue
        lo, hi = float(model.lowerPositionLimit[j.idx_q]), float(model.upperPositionLimit[j.idx_q])
        if math.isfinite(lo) and math.isfinite(hi) and hi - lo > TWO_PI + WIDER:
            out[name] = (j.idx_q, lo, hi)
    return out


def copies(theta: float, lo: float, hi: float) -> list[float]:
    """Every ``theta + 2 pi k`` in ``[lo, hi]``, in increasing order."""
    k0 = math.ceil((lo - theta) / TWO_PI)
    out = []
    k = k0
    while theta + TWO_PI * k <= hi:
        v = theta + TWO_PI * k
        if v >= lo:
            out.append(v)
        k += 1
    return out


def add_turns(res, all_turns: bool = False, wrap: dict[str, tuple[int, float, float]] | None = None) -> None:
    """Name the joints of ``res`` that wrap (``stats["wrapping_joints"]``, a note), count the
    configurations within the limits its solutions stand for (``stats["configurations_within_limits"]``),
    keep each solution inside the limits, and with ``all_turns`` list every copy. ``wrap``:
    :func:`wrapping_joints` of ``res`` if known already."""
    if wrap is None:
        wrap = wrapping_joints(res)
    if not wrap:
        return
    mech = res.formulated.mechanism
    from .result import max_residual

    data = mech.model.createData()
    out = []
    total = 0
    for s in res.solutions:
        choices = []
        for _name, (i, lo, hi) in wrap.items():
            c = copies(float(s.q[i]), lo, hi)
            choices.append(c)
        n = math.prod(len(c) for c in choices)
        total += n
        if all_turns:
            for combo in itertools.product(*choices):
                t = copy.copy(s)
                t.q = np.array(s.q, dtype=float)
                for (i, _, _), v in zip(wrap.values(), combo):
                    t.q[i] = v
                t.residual = max_residual(mech, t.q, data)
                out.append(t)
        else:
            t = s
            for (i, _, _), c in zip(wrap.values(), choices):
                if float(s.q[i]) not in c:  # outside the limits: the nearest copy inside
                    if t is s:
                        t = copy.copy(s)
                        t.q = np.array(s.q, dtype=float)
                    t.q[i] = min(c, key=lambda v: abs(v - float(s.q[i])))
            if t is not s:
                t.residual = max_residual(mech, t.q, data)
            out.append(t)
    res.solutions = out
    res.stats["wrapping_joints"] = {n: [lo, hi] for n, (_, lo, hi) in wrap.items()}
    res.stats["configurations_within_limits"] = total
    res.stats["solutions"] = len(out)
    listed = "listed, each a solution" if all_turns else "one listed per solution (--all-turns lists every one)"
    res.notes.append(
        f"joints with a range wider than a turn: {', '.join(f'{n} [{lo:.4g}, {hi:.4g}]' for n, (_, lo, hi) in wrap.items())}; "
        f"each value q also stands for q + 2 pi k within the limits: {total} configuration(s) within the limits, {listed}"
        + ("; curves are given over one turn" if any(c.dimension >= 1 for c in res.components) else "")
    )
