"""A geometric constraint system: all 12 lines at distance 1.45 from four points.

Points, lines and planes under distances, angles and incidences (docs/constraints.md). The system
is diagnosed before it is solved (degrees of freedom, redundant or inconsistent constraints),
then every assembly is found and each isolated one certified. The problem is that of Porta et
al. 2005, Sec. V-B (docs/references.md): four points sqrt(8) apart, 12 tangent lines.

Run: ``python examples/constraint_system.py``.
"""

import numpy as np

import kinbox

problem = kinbox.Assemble("tangent-lines")  # a built-in system (src/kinbox/robots/constraints/)
print("degrees of freedom:", problem.diagnosis.dof, " formulation:", problem.formulation)

res = problem.solve()
print(f"complete={res.complete}: {len(res.solutions)} lines, {sum(a.certified for a in res.solutions)} certified")
for a in res.solutions[:3]:
    line = a.entities["L"]  # the unknown line: a point p and a unit direction d
    print(f"  p = {np.round(line.p, 4)}  d = {np.round(line.d, 4)}")

# the same system from a dict: three free points, pairwise distances 1 -- a triangle, rigid up
# to rotation and translation, so the diagnosis pins it before the search
triangle = {
    "kind": "constraints",
    "name": "triangle",
    "entities": {"a": {"type": "point"}, "b": {"type": "point"}, "c": {"type": "point"}},
    "constraints": [
        {"type": "distance", "entities": ["a", "b"], "value": 1.0},
        {"type": "distance", "entities": ["b", "c"], "value": 1.0},
        {"type": "distance", "entities": ["c", "a"], "value": 1.0},
    ],
}
tri = kinbox.assemble(triangle)  # "auto": coordinates here (distances need five free points or more)
print(f"triangle: {tri.shapes} shape(s) up to reflection, complete={tri.complete}")
