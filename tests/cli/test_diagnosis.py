"""Diagnosis before solving (Ruiz 1994): degrees of freedom, redundant and inconsistent
constraints, under-constrained entities, on small systems built so that the answer is known by
construction, on Ruiz's own examples, and mobility of mechanisms."""

from __future__ import annotations

import pytest

import kinbox
from kinbox.errors import InconsistentError
from kinbox.model.constraints import load_constraints, parse
from kinbox.model.loading import load
from kinbox.problems.diagnosis import diagnose, diagnose_mechanism, refuse_if_inconsistent
from tests.support import paths as PATHS

DATA = PATHS.DATA / "constraints"

TETRA = {  # a tetrahedron: four free points, six distances (rigid)
    "kind": "constraints",
    "entities": {f"p{i}": {"type": "point"} for i in range(1, 5)},
    "constraints": [
        {"type": "distance", "entities": [f"p{a}", f"p{b}"], "value": v, "name": f"e{a}{b}"}
        for (a, b), v in {(1, 2): 1.0, (1, 3): 1.1, (1, 4): 1.2, (2, 3): 1.3, (2, 4): 1.15, (3, 4): 1.25}.items()
    ],
}


def system(base: dict, *extra: dict, **top) -> dict:
    d = {**base, **top}
    d["constraints"] = list(base["constraints"]) + list(extra)
    return d


def names(labels: list[str]) -> set[str]:
    return {s.split()[0] for s in labels}


def check(d: dict):
    m = parse(d, d.get("name", "test"))
    diag = diagnose(m)
    try:
        refuse_if_inconsistent(m, diag)
    except InconsistentError:
        pass
    return diag


FIXED_LINE = {"type": "line", "fixed": {"point": [0, 0, 0], "direction": [1, 0, 0]}}
FIXED_XY = {"type": "plane", "fixed": {"point": [0, 0, 0], "normal": [0, 0, 1]}}
FIXED_XY1 = {"type": "plane", "fixed": {"point": [0, 0, 1], "normal": [0, 0, 1]}}

# (system, dof at a solution or None if inconsistent, redundant names, inconsistent names)
SUITE = [
    ("rigid tetrahedron", system(TETRA), 0, set(), set()),
    (
        "a distance given twice",
        system(TETRA, {"type": "distance", "entities": ["p2", "p1"], "value": 1.0, "name": "again"}),
        0,
        {"again"},
        set(),
    ),
    (
        "a distance given twice, differently",
        system(TETRA, {"type": "distance", "entities": ["p1", "p2"], "value": 1.5, "name": "again"}),
        None,
        set(),
        {"e12", "again"},
    ),
    (
        "triangle inequality",
        {
            "kind": "constraints",
            "entities": {f"p{i}": {"type": "point"} for i in range(1, 4)},
            "constraints": [
                {"type": "distance", "entities": ["p1", "p2"], "value": 1.0, "name": "a"},
                {"type": "distance", "entities": ["p2", "p3"], "value": 1.0, "name": "b"},
                {"type": "distance", "entities": ["p1", "p3"], "value": 2.5, "name": "c"},
            ],
        },
        None,
        set(),
        {"a", "b", "c"},
    ),
    (
        "a point on two parallel planes",
        {
            "kind": "constraints",
            "entities": {"P": FIXED_XY, "Q": FIXED_XY1, "p": {"type": "point"}, "o": {"type": "point", "fixed": [0, 0, 0]}},
            "constraints": [
                {"type": "distance", "entities": ["p", "o"], "value": 2.0, "name": "r"},
                {"type": "incident", "entities": ["p", "P"], "name": "onP"},
                {"type": "incident", "entities": ["p", "Q"], "name": "onQ"},
            ],
        },
        None,
        set(),
        {"onP", "onQ"},
    ),
    (
        "a point on a line in a plane",
        {
            "kind": "constraints",
            "entities": {"L": FIXED_LINE, "P": FIXED_XY, "p": {"type": "point"}, "o": {"type": "point", "fixed": [0, 0, 0]}},
            "constraints": [
                {"type": "distance", "entities": ["p", "o"], "value": 2.0, "name": "r"},
                {"type": "incident", "entities": ["p", "L"], "name": "onL"},
                {"type": "incident", "entities": ["p", "P"], "name": "onP"},
            ],
        },
        0,
        {"onP"},
        set(),
    ),
    (
        "parallel and perpendicular lines",
        {
            "kind": "constraints",
            "bounds": 3,
            "entities": {"L": FIXED_LINE, "M": {"type": "line"}},
            "constraints": [
                {"type": "parallel", "entities": ["L", "M"], "name": "par"},
                {"type": "perpendicular", "entities": ["M", "L"], "name": "perp"},
            ],
        },
        None,
        set(),
        {"par", "perp"},
    ),
    (
        "parallel lines at an angle",
        {
            "kind": "constraints",
            "bounds": 3,
            "entities": {"L": FIXED_LINE, "M": {"type": "line"}},
            "constraints": [
                {"type": "parallel", "entities": ["L", "M"], "name": "par"},
                {"type": "angle", "entities": ["M", "L"], "value": 0.5, "name": "ang"},
            ],
        },
        None,
        set(),
        {"par", "ang"},
    ),
    (
        "a plane on a plane, then parallel to it",
        {
            "kind": "constraints",
            "bounds": 3,
            "entities": {"P": FIXED_XY, "Q": {"type": "plane"}},
            "constraints": [
                {"type": "incident", "entities": ["Q", "P"], "name": "on"},
                {"type": "parallel", "entities": ["P", "Q"], "name": "par"},
            ],
        },
        0,
        {"par"},
        set(),
    ),
    (
        "a point at a distance from a fixed point",
        {
            "kind": "constraints",
            "entities": {"o": {"type": "point", "fixed": [0, 0, 0]}, "p": {"type": "point"}},
            "constraints": [{"type": "distance", "entities": ["o", "p"], "value": 1.0, "name": "r"}],
        },
        2,
        set(),
        set(),
    ),
]


@pytest.mark.parametrize("title, d, dof, redundant, inconsistent", SUITE, ids=[s[0] for s in SUITE])
def test_diagnosis_of_small_systems(title, d, dof, redundant, inconsistent):
    diag = check(d)
    if inconsistent:
        assert diag.consistent is False and diag.proven, (title, diag.report(title))
        assert names(diag.inconsistent) == inconsistent, diag.report(title)
        for n in inconsistent:
            assert n in diag.message
    else:
        assert diag.consistent, diag.report(title)
        assert diag.dof == dof, diag.report(title)
        assert names(diag.redundant) == redundant, diag.report(title)


def test_underconstrained_entities_are_named():
    d = system(TETRA, TETRA["constraints"][0])  # duplicate of e12
    d["entities"] = dict(d["entities"], p5={"type": "point"})
    d["constraints"] = d["constraints"] + [
        {"type": "distance", "entities": ["p5", "p1"], "value": 1.0, "name": "f"},
        {"type": "distance", "entities": ["p5", "p2"], "value": 1.0, "name": "g"},
    ]
    diag = check(d)
    assert diag.dof == 1  # p5 turns about the line p1 p2
    assert diag.underconstrained == {"p5": 1}


def test_generic_and_special_geometry():
    """A plane through three points generically; a fourth point on it is generically
    independent. Four points on a fixed line: the constraints are generically rigid but
    special collinear placements are not."""
    # Ruiz's Bennett mechanism: rigid for generic links, mobile for Bennett's
    diag = diagnose(load_constraints("bennett"))
    assert diag.generic_dof == 0 and diag.dof == 1, diag.report("bennett")
    assert diag.underconstrained and "B1" not in diag.underconstrained  # B1 is the fixed link


def test_ruiz_double_peg_and_hole_sequence():
    """Ruiz 1994, Sec. 3.2.3: after LN1 on LN3 and LN2 on LN4 one degree of freedom is left (Eq. 3.11),
    P1 on P3 leaves finitely many assemblies (Eq. 3.12: two), P2 on P4 is inconsistent (Eq. 3.13)."""
    m = load_constraints("ruiz-dph")
    diag = diagnose(m)
    left = [s.left for s in diag.at_solution]
    assert left == [2, 1, 0], diag.report(m.name)
    assert [s.status for s in diag.at_solution] == ["independent", "partially redundant", "partially redundant"]
    two = kinbox.assemble(m.subset([0, 1]), check=False, sigma=0.2)  # the two translation families
    assert two.complete and sorted(c.dimension for c in two.components if c.dimension) == [1, 1]
    res = kinbox.assemble(m)
    assert res.complete and len(res.solutions) == 2 and all(s.certified for s in res.solutions)
    bad = load_constraints(DATA / "ruiz-dph-inconsistent.json")
    with pytest.raises(InconsistentError) as e:
        kinbox.assemble(bad)
    assert "C3" in str(e.value) and "C4" in str(e.value) and "C1" not in str(e.value)


def test_ruiz_cartesian_table_has_three_degrees_of_freedom():
    """Ruiz 1994, Sec. 5.5.3: the table translates in its plane (2) and the bars' assembly slides
    along the line where the planes F14 and F15 meet (1); the table does not turn."""
    diag = diagnose(load_constraints("ruiz-cartesian-table"))
    assert diag.generic_dof == 3 and diag.dof == 3, diag.report("ct")
    assert diag.underconstrained["B4"] == 2  # the table: a planar translation, no rotation


def test_mechanisms_mobility_by_counting_and_at_solutions():
    bricard = diagnose_mechanism(load("bricard"))
    assert bricard.counted_mobility == 0 and 1 in bricard.at_solutions  # Bricard's loop moves
    six = diagnose_mechanism(load("general-6r"))
    assert six.counted_mobility == 0 and set(six.at_solutions) == {0}
