"""A mobile linkage: the configuration curves of a planar four-bar, and its assemblies at one input.

With its crank free the four-bar moves, and its configurations form curves (two circuits, the two
assembly branches); with the crank held they are isolated points again.

Run: ``python examples/four_bar_curves.py``.
"""

import numpy as np

import kinbox

res = kinbox.solve("four-bar")  # sigma (the box size along a curve) defaults to 0.05 here
curves = [c for c in res.components if c.dimension == 1]
print(f"complete={res.complete}: {len(curves)} curves, {len(res.solutions)} isolated configurations")
for i, curve in res.curves.items():  # each curve's configurations in order, joint space
    q = np.asarray(curve.polyline)  # its longest branch (curve.branches holds every branch)
    names = ", ".join(res.joint_names)
    print(f"curve {i}: {len(q)} configurations of ({names}); crank from {q[:, 0].min():.2f} to {q[:, 0].max():.2f} rad")

held = kinbox.solve("four-bar", set={"crank": 0.7})  # the crank held: two assembly modes
for s in held.solutions:
    print(f"crank 0.7: q = {np.round(s.q, 4)}  certified={s.certified}")
