"""The cost of constraint systems' core rows as enclosures of the input as given: the built-in
constraint systems prepared and solved (``kinbox.Assemble(name).solve()``, the default
formulation and sigma) with the core rows carrying ``merr``/``mgrad`` from the shadow build
(:mod:`kinbox.formulation.enclose_constraints`, the default) and without them (the rows as
rounded taken as exact), interleaved in one process so that the ratio is measured on the same
machine state.

    python benchmarks/constraint_enclosures.py [--repeat 3] [--json] [--only NAME ...]

Per problem: the median CPU seconds of each variant over ``--repeat`` interleaved runs
(``time.process_time``, preparing included: the shadow build is part of the cost; one warm-up
run of each first), their ratio, the boxes of each and the assemblies (found and certified).
"""

from __future__ import annotations

import argparse
import json
import sys

import report

#: the built-in systems solved to completion in seconds (Bennett's and Dietmeier's are slower)
PROBLEMS = ("tangent-lines", "octahedral-a", "octahedral-b", "cyclohexane", "ruiz-dph", "perpendicular-tangents")

_TANGENT_POINTS = {"p1": [1.0, 0.2, 0.3], "p2": [-0.4, 0.9, -0.2], "p3": [0.1, -0.7, 0.8]}
#: systems written here: a free line at distance 0.9 from three fixed points and at the angle
#: binary64 pi/2 to a fixed line (the angle taken as perpendicularity, its row's error the
#: exact angle's cosine: ``Numbers.snapped``)
SYSTEMS = {
    "perpendicular-tangents": {
        "kind": "constraints",
        "name": "perpendicular-tangents",
        "bounds": 4,
        "entities": {
            **{k: {"type": "point", "fixed": v} for k, v in _TANGENT_POINTS.items()},
            "M": {"type": "line", "fixed": {"point": [0, 0, 0], "direction": [0.3, 0.5, 0.8]}},
            "L": {"type": "line"},
        },
        "constraints": [{"type": "distance", "entities": [k, "L"], "value": 0.9} for k in _TANGENT_POINTS]
        + [{"type": "angle", "entities": ["L", "M"], "value": 1.5707963267948966}],
    }
}


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--only", nargs="*", default=None)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args(argv)

    import kinbox
    from kinbox.formulation import enclose_constraints

    shadow = enclose_constraints.enclosed_core

    def off(*args):  # the rows as rounded, taken as exact
        return None

    def variant_on(on: bool) -> None:
        enclose_constraints.enclosed_core = shadow if on else off  # type: ignore[assignment]

    rows = []
    for name in a.only or PROBLEMS:

        def run(name=name):
            return kinbox.Assemble(SYSTEMS.get(name, name)).solve(progress=False)

        row = report.interleaved(name, run, variant_on, a.repeat)
        rows.append(row)
        print(json.dumps(row), file=sys.stderr)
    return report.interleaved_summary(rows, a.json, 24)


if __name__ == "__main__":
    main()
