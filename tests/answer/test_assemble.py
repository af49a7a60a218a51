"""The published problems of Porta et al. 2005 (and its conference version, Porta et al. 2003) and Dietmeier's platform as
constraint systems: the solver's answer against the published counts, every isolated assembly
certified and checked on its placements, and the two formulations agreeing."""

from __future__ import annotations

import numpy as np
import pytest

import kinbox
from kinbox.answer.assembly import max_deviation
from kinbox.answer.resultfile import check_result
from kinbox.model.constraints import load_constraints


def distinct(values, tol=1e-6) -> list:
    out: list = []
    for v in values:
        if not any(np.max(np.abs(np.subtract(v, o))) < tol for o in out):
            out.append(v)
    return out


def shapes(res):
    """One solution per pair of mirror images."""
    return [s for k, s in enumerate(res.solutions) if s.mirror is None or s.mirror > k]


def r(s, a, b) -> float:
    return float(np.sum((s.entities[a].p - s.entities[b].p) ** 2))


def check_sound(res, name):
    m = load_constraints(name)
    assert res.complete, res.message
    for s in res.solutions:
        assert s.certified, res.table()
        assert max_deviation(m, s.entities) < 1e-9  # measured on the placements, not the equations


def same_answer(a, b) -> None:
    assert len(a.solutions) == len(b.solutions)
    for s in a.solutions:
        assert min(s.distance(o) for o in b.solutions) < 1e-8


def test_octahedral_configuration_a():
    """Porta et al. 2005, Sec. V-A, configuration 'a': the two curves of Eq. (7) meet in two points (Fig. 7e),
    two assemblies up to a reflection."""
    res = kinbox.assemble("octahedral-a", formulation="coordinates")
    check_sound(res, "octahedral-a")
    assert len(res.solutions) == 4 and res.shapes == 2
    dist = kinbox.assemble("octahedral-a", formulation="distances")
    check_sound(dist, "octahedral-a")
    same_answer(res, dist)


@pytest.mark.parametrize("formulation", ["coordinates", "distances"])
def test_octahedral_configuration_b(formulation):
    """Porta et al. 2005, Sec. V-A, configuration 'b' (all squared legs 4.75): the curves of Eq. (7) in the
    plane (r14, r36) meet in six points and are tangent at two of them (Fig. 7f): each tangency
    is two solutions with different r25 (the redundant formulation, Eq. (8), separates them:
    Fig. 7d)."""
    res = kinbox.assemble("octahedral-b", formulation=formulation)
    check_sound(res, "octahedral-b")
    sh = shapes(res)
    assert len(res.solutions) == 16 and len(sh) == 8
    pts = [(r(s, "p1", "p4"), r(s, "p3", "p6")) for s in sh]
    uniq = distinct(pts)
    assert len(uniq) == 6
    doubles = [u for u in uniq if sum(1 for p in pts if np.allclose(p, u, atol=1e-6)) == 2]
    assert len(doubles) == 2


def test_cyclohexane_chair_and_boat():
    """Porta et al. 2005, Sec. V-A, Fig. 8: the chair form is isolated, the boat form a one-dimensional
    continuum, both plotted in the box r14 = r25 = r36 in [2.75, 3.95]."""
    res = kinbox.assemble("cyclohexane")
    check_sound(res, "cyclohexane")
    assert res.shapes == 1 and len(res.solutions) == 2  # the chair and its mirror image
    chair = res.solutions[0]
    r14, r25, r36 = r(chair, "c1", "c4"), r(chair, "c2", "c5"), r(chair, "c3", "c6")
    assert 2.75 <= r14 <= 3.95 and abs(r14 - r25) < 1e-9 and abs(r14 - r36) < 1e-9
    curves = [c for c in res.components if c.dimension >= 1]
    assert len(curves) == 1 and curves[0].dimension == 1
    samples = res.samples[res.components.index(curves[0])]
    m = load_constraints("cyclohexane")
    assert samples and all(max_deviation(m, s.entities) < 1e-6 for s in samples)
    # Fig. 8c frames the continuum with the box [2.75, 3.95]^3; the curve reaches slightly past
    # it (r14 from 2.727 to 3.963 here), so the check allows a margin of 0.05
    assert all(2.70 <= r(s, "c1", "c4") <= 4.0 for s in samples)
    check_result(res.to_dict())  # isolated assemblies and component samples match the schema
    # the one curve view: the boat continuum as one closed branch of assemblies in order, each a
    # small step from the one before (its samples are drawn from it)
    cv = res.curves[res.components.index(curves[0])]
    (branch,) = cv.branches
    span = max(branch[0].distance(a) for a in branch)
    steps = [a.distance(b) for a, b in zip(branch, branch[1:] + branch[:1])]
    assert cv.closed == [True] and max(steps) < 0.05 * span
    assert all(any(s is a for a in branch) for s in samples)


@pytest.fixture(scope="module")
def tangent_lines():
    return kinbox.assemble("tangent-lines")


def test_tangent_lines_to_four_spheres(tangent_lines):
    """Porta et al. 2005, Sec. V-B: all intercentre distances sqrt(8), radii 1.45: twelve lines."""
    res = tangent_lines
    check_sound(res, "tangent-lines")
    assert len(res.solutions) == 12
    lines = [s.entities["L"].canonical() for s in res.solutions]
    assert len(distinct([ln["point"] + ln["direction"] for ln in lines])) == 12  # each line once


@pytest.mark.slow
@pytest.mark.parametrize("name", ["cyclohexane", "tangent-lines"])
def test_distance_formulation_agrees(name):
    a = kinbox.assemble(name, formulation="coordinates")
    b = kinbox.assemble(name, formulation="distances")
    check_sound(b, name)
    same_answer(a, b)
    assert [c.dimension for c in a.components if c.dimension] == [c.dimension for c in b.components if c.dimension]


@pytest.mark.slow
def test_dietmeier_platform_as_a_constraint_system():
    """Dietmeier's 6-6 platform (Porta, Ros and Thomas 2009, Table II; Porta et al. 2005 cites Raghavan's bound): 40 assemblies."""
    res = kinbox.assemble("dietmeier-constraints")  # auto: coordinates
    check_sound(res, "dietmeier-constraints")
    assert len(res.solutions) == 40


@pytest.mark.slow
def test_dietmeier_by_distances_stops_at_its_budget():
    # the distance formulation (an expert's choice here: auto takes coordinates) has not been
    # seen to finish this platform (25 min CPU without an assembly); within a box budget it
    # must say it is incomplete, and whatever it returns must be a true assembly
    m = load_constraints("dietmeier-constraints")
    res = kinbox.assemble("dietmeier-constraints", formulation="distances", max_boxes=3000)
    if res.complete:
        check_sound(res, "dietmeier-constraints")
        assert len(res.solutions) == 40
    else:
        assert "budget" in res.message
        for s in res.solutions:
            assert max_deviation(m, s.entities) < 1e-9


def test_json_answer_reports_each_line_once(tangent_lines):
    d = tangent_lines.to_dict()
    assert d["kind"] == "constraints" and d["complete"] and len(d["solutions"]) == 12
    for s in d["solutions"]:
        L = s["entities"]["L"]
        assert set(L) == {"point", "direction"} and s["certified"] is True
        assert abs(np.dot(L["point"], L["direction"])) < 1e-9  # the point closest to the origin
        assert next(v for v in L["direction"] if abs(v) > 1e-12) > 0  # one sign per line
    check_result(d)


def test_a_broken_answer_file_is_refused_in_one_line(tangent_lines):
    d = tangent_lines.to_dict()
    d["solutions"][3]["entities"]["L"]["direction"] = [1.0, 2.0]
    with pytest.raises(kinbox.errors.InputError, match=r"solutions\[3\]\.entities\.L\.direction: 2 entries"):
        check_result(d)
    del d["solutions"][2]["entities"]
    with pytest.raises(kinbox.errors.InputError, match=r"solutions\[2\]: missing 'entities'"):
        check_result(d)


def test_automatic_choice_of_formulation():
    """Distances for pure distance problems with isolated assemblies, else coordinates."""
    assert kinbox.Assemble("octahedral-a").formulation == "distances"
    assert kinbox.Assemble("tangent-lines").formulation == "coordinates"  # a line, fixed points
    assert kinbox.Assemble("ruiz-dph").formulation == "coordinates"  # bodies


def test_a_tangent_root_is_flagged_not_certified():
    """A point on the unit sphere about o and on the plane z = 1 tangent to it (and on x = 0):
    one double root, where no proof of uniqueness is possible."""
    d = {
        "kind": "constraints",
        "entities": {
            "o": {"type": "point", "fixed": [0, 0, 0]},
            "P": {"type": "plane", "fixed": {"point": [0, 0, 1], "normal": [0, 0, 1]}},
            "Q": {"type": "plane", "fixed": {"point": [0, 0, 0], "normal": [1, 0, 0]}},
            "p": {"type": "point"},
        },
        "constraints": [
            {"type": "distance", "entities": ["o", "p"], "value": 1.0},
            {"type": "incident", "entities": ["p", "P"]},
            {"type": "incident", "entities": ["p", "Q"]},
        ],
    }
    res = kinbox.assemble(d)
    assert res.complete and len(res.solutions) == 1
    s = res.solutions[0]
    assert not s.certified and s.multiple and np.allclose(s.entities["p"].p, [0, 0, 1], atol=1e-6)
