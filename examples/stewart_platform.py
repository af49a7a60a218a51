"""Every assembly mode of a general 6-6 Gough-Stewart platform (Dietmeier's): 40, each certified.

The forward kinematics of a parallel platform: given the six leg lengths, every pose of the
platform. Dietmeier's geometry has the largest possible number of real assembly modes, 40
(Porta, Ros and Thomas 2009, Table II; docs/references.md).

Run: ``python examples/stewart_platform.py [TIME_LIMIT]`` (about 20 s of CPU for the whole answer).
"""

import sys

import kinbox

time_limit = float(sys.argv[1]) if len(sys.argv) > 1 else None

res = kinbox.solve("dietmeier", time_limit=time_limit)  # a built-in mechanism (src/kinbox/robots/)
print(res.table())
certified = sum(s.certified for s in res.solutions)
if res.complete:
    print(f"complete: {len(res.solutions)} assembly modes, {certified} certified")
else:  # a budget was hit: what was found so far, marked incomplete
    print(f"incomplete ({res.message}): {len(res.solutions)} assembly modes so far, {certified} certified")
