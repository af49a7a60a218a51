"""The constraint-system model: file format, validation (one-line errors naming the entity or
constraint), parameters, and the coordinate formulation's equations against geometry built by
hand (each constraint type holds exactly on configurations constructed to satisfy it)."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

from kinbox.answer.assembly import deviation, max_deviation
from kinbox.errors import FormulationError, KinboxError, ModelError, NameNotFound
from kinbox.formulation.geometry import Placement, formulate
from kinbox.model.constraints import builtin_constraint_files, load_constraints, parse

BASE = {
    "kind": "constraints",
    "entities": {"p": {"type": "point", "fixed": [0, 0, 0]}, "q": {"type": "point"}},
    "constraints": [{"type": "distance", "entities": ["p", "q"], "value": 1.0}],
}


def with_(**changes) -> dict:
    d = copy.deepcopy(BASE)
    d.update(changes)
    return d


def test_every_builtin_system_loads():
    files = builtin_constraint_files()
    assert {
        "octahedral-a",
        "octahedral-b",
        "cyclohexane",
        "tangent-lines",
        "dietmeier-constraints",
        "ruiz-dph",
        "ruiz-cartesian-table",
        "bennett",
    } <= set(files)
    for name in files:
        m = load_constraints(name)
        assert m.constraints and m.meta.get("source"), name  # every example cites its paper


@pytest.mark.parametrize(
    "d, words",
    [
        (with_(kind="stewart"), ["kind"]),
        (with_(entities={"p": {"type": "circle"}}), ["entity 'p'", "type"]),
        (with_(entities={"p": {"type": "point", "fixed": [0, 0]}, "q": {"type": "point"}}), ["entity 'p'", "3 numbers"]),
        (with_(entities={"L": {"type": "line", "fixed": {"point": [0, 0, 0]}}}), ["entity 'L'", "direction"]),
        (with_(entities={"P": {"type": "plane", "fixed": {"point": [0, 0, 0], "normal": [0, 0, 0]}}}), ["entity 'P'", "zero"]),
        (with_(constraints=[{"type": "distance", "entities": ["p", "r"], "value": 1}]), ["constraint #1", "unknown entity 'r'"]),
        (with_(constraints=[{"type": "glued", "entities": ["p", "q"]}]), ["constraint #1", "type"]),
        (with_(constraints=[{"type": "distance", "entities": ["p", "q"]}]), ["#1", "value"]),
        (with_(constraints=[{"type": "distance", "entities": ["p", "q"], "value": -1}]), ["#1", "negative"]),
        (with_(constraints=[{"type": "distance", "entities": ["p", "q"], "value": "len"}]), ["#1", "unknown parameter 'len'"]),
        (with_(constraints=[{"type": "angle", "entities": ["p", "q"], "value": 0.3}]), ["#1", "angle", "point"]),
        (with_(constraints=[{"type": "parallel", "entities": ["p", "q"], "value": 0.3}]), ["#1"]),
        (with_(constraints=[{"type": "incident", "entities": ["p", "q"], "name": "weld"}]) | {"extra": 1}, ["extra"]),
        (with_(bodies={"B": {"entities": {"a": {"type": "point", "at": [0, 0, 0]}}}}), ["body 'B'", "pose"]),
        (with_(bodies={"B": {"entities": {"p": {"type": "point", "at": [0, 0, 0]}}}}), ["entity 'p'", "twice"]),
        (with_(bounds=-1), ["bounds"]),
    ],
)
def test_bad_files_say_what_is_wrong_in_one_line(d, words):
    with pytest.raises(ModelError) as e:
        parse(d, "test")
    msg = str(e.value)
    assert "\n" not in msg
    for w in words:
        assert w in msg, (w, msg)


def test_parameters_are_set_by_name_and_checked():
    m = parse(with_(parameters={"len": 2.0}, constraints=[{"type": "distance", "entities": ["p", "q"], "value": "len"}]))
    assert m.value(m.constraints[0]) == 2.0
    assert m.with_parameters({"len": 3.0}).value(m.constraints[0]) == 3.0
    assert m.value(m.constraints[0]) == 2.0  # the original is not changed
    with pytest.raises(NameNotFound, match="no parameter named 'ln'"):
        m.with_parameters({"ln": 1.0})
    with pytest.raises(ModelError, match="negative"):
        m.with_parameters({"len": -1.0})
    sq = parse(with_(constraints=[{"type": "distance", "entities": ["p", "q"], "squared": 4.0}]))
    assert sq.value(sq.constraints[0]) == 2.0


def test_an_unbounded_entity_is_named():
    d = with_(
        entities={"p": {"type": "point", "fixed": [0, 0, 0]}, "q": {"type": "point"}, "L": {"type": "line"}},
        constraints=[{"type": "distance", "entities": ["p", "L"], "value": 1.0}, {"type": "incident", "entities": ["q", "L"]}],
    )
    with pytest.raises(FormulationError, match="point 'q'.*bounds"):
        formulate(parse(d))
    formulate(parse(d | {"bounds": 3}))  # with a world box it is fine


# ----------------------------------------------------------------------------------------------
# the equations of every constraint type vanish on configurations made to satisfy it
# ----------------------------------------------------------------------------------------------
def _unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def _perp(v, rng):
    w = np.cross(v, rng.normal(size=3))
    return w / np.linalg.norm(w)


def _configurations(rng):
    """(entity types, constraint spec without entities, placements A, B satisfying it)."""
    p = rng.normal(size=3)
    d1 = _unit(rng.normal(size=3))
    n1 = _unit(rng.normal(size=3))
    u = _perp(d1, rng)
    out = []
    # distances
    out.append(
        (
            ("point", "point"),
            {"type": "distance", "value": 1.3},
            Placement("point", p),
            Placement("point", p + 1.3 * _unit(rng.normal(size=3))),
        )
    )
    out.append(
        (("point", "line"), {"type": "distance", "value": 0.7}, Placement("point", p + 0.7 * u + 2.0 * d1), Placement("line", p, d1))
    )
    out.append(
        (
            ("point", "plane"),
            {"type": "distance", "value": 0.4},
            Placement("point", p - 0.4 * n1),
            Placement("plane", None, n1, float(np.dot(n1, p))),
        )
    )
    w = _perp(d1, rng)
    d2 = _unit(np.cross(w, rng.normal(size=3)))  # perpendicular to the common normal w
    out.append(
        (("line", "line"), {"type": "distance", "value": 0.9}, Placement("line", p, d1), Placement("line", p + 0.9 * w + 0.3 * d2, d2))
    )
    out.append((("line", "line"), {"type": "distance", "value": 0.0}, Placement("line", p, d1), Placement("line", p + 0.5 * d1, d2)))
    out.append(
        (
            ("line", "plane"),
            {"type": "distance", "value": 0.6},
            Placement("line", p + 0.6 * n1, _perp(n1, rng)),
            Placement("plane", None, n1, float(np.dot(n1, p))),
        )
    )
    out.append(
        (("plane", "plane"), {"type": "distance", "value": 0.8}, Placement("plane", None, n1, 0.3), Placement("plane", None, -n1, -1.1))
    )
    # angles
    th = 0.6
    e = math.cos(th) * d1 + math.sin(th) * u
    out.append((("line", "line"), {"type": "angle", "value": th}, Placement("line", p, d1), Placement("line", rng.normal(size=3), -e)))
    out.append(
        (("plane", "plane"), {"type": "angle", "value": math.pi - th}, Placement("plane", None, d1, 0.2), Placement("plane", None, e, -0.4))
    )
    f = math.sin(th) * d1 + math.cos(th) * u  # angle th with the plane of normal d1
    out.append((("line", "plane"), {"type": "angle", "value": th}, Placement("line", p, f), Placement("plane", None, d1, 1.0)))
    # incidences
    out.append((("point", "point"), {"type": "incident"}, Placement("point", p), Placement("point", p.copy())))
    out.append((("point", "line"), {"type": "incident"}, Placement("point", p + 1.7 * d1), Placement("line", p, d1)))
    out.append(
        (
            ("point", "plane"),
            {"type": "incident"},
            Placement("point", p + u - np.dot(u, n1) * n1),
            Placement("plane", None, n1, float(np.dot(n1, p))),
        )
    )
    out.append((("line", "line"), {"type": "incident"}, Placement("line", p, d1), Placement("line", p - 2 * d1, -d1)))
    out.append(
        (("line", "plane"), {"type": "incident"}, Placement("line", p, _perp(n1, rng)), Placement("plane", None, n1, float(np.dot(n1, p))))
    )
    out.append((("plane", "plane"), {"type": "incident"}, Placement("plane", None, n1, 0.5), Placement("plane", None, -n1, -0.5)))
    # parallel and perpendicular
    out.append((("line", "line"), {"type": "parallel"}, Placement("line", p, d1), Placement("line", p + u, -d1)))
    out.append((("line", "plane"), {"type": "parallel"}, Placement("line", p, _perp(n1, rng)), Placement("plane", None, n1, 2.0)))
    out.append((("plane", "plane"), {"type": "parallel"}, Placement("plane", None, n1, 0.1), Placement("plane", None, n1, 0.9)))
    out.append((("line", "line"), {"type": "perpendicular"}, Placement("line", p, d1), Placement("line", -p, u)))
    out.append((("line", "plane"), {"type": "perpendicular"}, Placement("line", p, -n1), Placement("plane", None, n1, 0.4)))
    out.append((("plane", "plane"), {"type": "perpendicular"}, Placement("plane", None, d1, 0.1), Placement("plane", None, u, 0.3)))
    return out


def _model(ta, tb, spec, fixed_a: Placement | None):
    ents = {"A": {"type": ta}, "B": {"type": tb}}
    if fixed_a is not None:
        ents["A"]["fixed"] = (
            list(fixed_a.p)
            if ta == "point"
            else {"point": list(fixed_a.p), "direction": list(fixed_a.d)}
            if ta == "line"
            else {"point": list(fixed_a.d * fixed_a.h), "normal": list(fixed_a.d)}
        )
    return parse({"kind": "constraints", "entities": ents, "bounds": 10, "constraints": [dict(spec, entities=["A", "B"])]})


@pytest.mark.parametrize("substitute", [True, False])
def test_each_constraint_holds_exactly_on_its_configurations(substitute):
    rng = np.random.default_rng(3)
    for (ta, tb), spec, A, B in _configurations(rng):
        m = _model(ta, tb, spec, A)
        assert max_deviation(m, {"A": A, "B": B}) < 1e-12, spec
        geo = formulate(m, substitute=substitute)
        x = geo.encode({"A": A, "B": B})
        res = geo.system.residuals(x)
        assert np.max(np.abs(res), initial=0.0) < 1e-11, (ta, tb, spec, res)
        # and the placements read back are the same sets
        back = geo.placements(x)
        assert back["B"].distance(B) < 1e-9, (ta, tb, spec)


def test_a_violated_constraint_is_measured():
    rng = np.random.default_rng(4)
    for (ta, tb), spec, A, B in _configurations(rng):
        m = _model(ta, tb, spec, A)
        moved = Placement(
            B.type,
            None if B.p is None else B.p + 0.05 * rng.normal(size=3),
            None if B.d is None else _unit(B.d + 0.05 * rng.normal(size=3)),
            None if B.h is None else B.h + 0.05,
        )
        assert deviation(m, m.constraints[0], {"A": A, "B": moved}) > 1e-4, spec


def test_kinbox_errors_are_kinbox_errors():
    assert issubclass(ModelError, KinboxError) and issubclass(FormulationError, KinboxError)
