"""Uncertified isolated roots certified from Newton's point, where the search's boxes are not.

Next to a singularity the search may end with a root in no certified box: a UR5 1e-8 from its
wrist singularity written in the general formulation (``formulation="general"``) left four of its
eight roots as uncertified points, each standing for a cluster of boxes 0.01 to 0.05 wide along
the valley of near-solutions of the singular arm's self-motion. Here each such point (an
isolated root, not singular, of multiplicity 1) is handed to
:class:`kinbox.search.point.SeededCertifier`: Newton on the square core from it, then Krawczyk on
boxes grown about Newton's point until one is proven to hold exactly one root (a fixed number of
boxes). A proven root replaces the uncertified point only where nothing is lost:

* its proof region must be disjoint from every certified root's box (else nothing changes:
  the same root, or one the proof cannot tell apart, would be reported twice);
* each box of the point's cluster is accounted for (:meth:`SeededCertifier.settles`: inside the
  proof's region, in a box Krawczyk proves to hold exactly one zero together with it, or proven
  empty) or stays reported as undecided: every box the search returned is still in the answer.

Only the general formulation asks for it (:func:`kinbox.answer.result.build_result`);
``tests/answer/test_newton_proof.py`` checks it against the 40-digit roots.
"""

from __future__ import annotations

import dataclasses

import numpy as np


def certify_from_newton(comps: list, undecided: list[int], boxes, seeded) -> tuple[list, list[int]]:
    """``comps`` (:class:`kinbox.answer.components.Component`) with each uncertified isolated root
    proven where it can be (see the module's text), and the undecided boxes with the boxes of its
    cluster that are not accounted for."""
    left = list(undecided)
    out: list = []
    proven = [(c.point - c.width, c.point + c.width) for c in comps if c.certified and c.dimension == 0 and c.point is not None]
    for c in comps:
        if c.dimension != 0 or c.certified or c.singular or c.multiplicity != 1 or c.point is None:
            out.append(c)
            continue
        sb = seeded.prove(c.point)
        if sb is None or any(np.all(sb.hi >= lo) and np.all(sb.lo <= hi) for lo, hi in proven):
            out.append(c)
            continue
        held = [i for i in c.boxes if seeded.settles(boxes[i].lo, boxes[i].hi, sb)]
        kept = set(held)
        left += [i for i in c.boxes if i not in kept]
        n = len(sb.x)
        out.append(dataclasses.replace(c, boxes=held, certified=True, rank=n, dof=0, point=np.asarray(sb.x, dtype=float), width=sb.width))
        proven.append((np.asarray(sb.lo, dtype=float), np.asarray(sb.hi, dtype=float)))
    return out, sorted(left)
