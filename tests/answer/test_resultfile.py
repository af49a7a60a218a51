"""Result files read back against their JSON Schema: what kinbox writes passes, a malformed file
is one line naming the field (exit 2 from `kinbox replay` and `kinbox plot`)."""

from __future__ import annotations

import copy
import json
from importlib import resources

import pytest

import kinbox
from kinbox.answer.resultfile import SCHEMA_FILE, check_result, load_result, schema
from kinbox.cli import main
from kinbox.errors import InputError


@pytest.fixture(scope="module")
def written() -> dict:
    """A result as kinbox writes it: isolated solutions, a curve with samples, boxes."""
    res = kinbox.solve("four-bar", set={"crank": 0.7})
    d = json.loads(res.to_json())
    assert d["boxes"]["lo"] and d["solutions"]
    d["components"].append(
        {
            "dimension": 1,
            "boxes": 2,
            "certified": False,
            "bifurcation_boxes": 0,
            "samples": [s["q"] for s in d["solutions"]],
            "polyline": [s["q"] for s in d["solutions"]],
        }
    )
    return d


def test_the_schema_ships_with_the_package_and_is_a_valid_schema():
    from jsonschema import Draft202012Validator

    text = resources.files("kinbox.answer").joinpath(SCHEMA_FILE).read_text()
    Draft202012Validator.check_schema(json.loads(text))
    assert schema()["required"] == ["source", "solutions"]


def test_what_kinbox_writes_is_valid(written, tmp_path):
    check_result(written)
    res = kinbox.ik("ur5", "tool0", kinbox.IK("ur5", "tool0").pose_at([0.3, -1.2, 1.5, -0.8, 1.2, 0.4]))
    check_result(json.loads(res.to_json()))
    p = tmp_path / "r.json"
    p.write_text(json.dumps(written))
    assert load_result(p)["_dir"] == str(tmp_path.resolve())


def _set(d: dict, path: str, value) -> dict:
    """A copy of ``d`` with the field at ``path`` ("solutions.0.q.1") replaced (or deleted if
    ``value`` is ...)."""
    d = copy.deepcopy(d)
    *head, last = [int(k) if k.lstrip("-").isdigit() else k for k in path.split(".")]
    node = d
    for k in head:
        node = node[k]
    if value is ...:
        del node[last]
    else:
        node[last] = value
    return d


CASES = [  # (field to change, new value or ... to delete, expected message)
    ("solutions.0.q.1", "a", 'solutions[0].q[1]: "a" is not a number'),
    ("solutions.0.q", 3.0, "solutions[0].q: 3.0 is not a list"),
    ("solutions.0.q", ..., "solutions[0]: missing 'q'"),
    ("solutions.0.residual", -1.0, "solutions[0].residual: -1.0 is below 0"),
    ("solutions.0.certified", "yes", 'solutions[0].certified: "yes" is not true or false'),
    ("solutions", {"q": [1]}, "solutions: an object is not a list"),
    ("components.0.dimension", 1.5, "components[0].dimension: 1.5 is not an integer"),
    ("components.0.dimension", ..., "components[0]: missing 'dimension'"),
    ("components.-1.samples.0", [1, None], "components[2].samples[0][1]: null is not a number"),
    ("components.-1.polyline", [[1, 2], "x"], 'components[2].polyline[1]: "x" is not a list'),
    ("source", ..., "the file: missing 'source'"),
    ("source.kind", "plan", 'source.kind: "plan" is not one of "ik", "solve"'),
    ("source.mechanism", 7, "source.mechanism: 7 is not a string or null"),
    ("source.set", {"crank": "fast"}, 'source.set.crank: "fast" is not a number or a list of numbers'),
    ("joint_names.0", 1, "joint_names[0]: 1 is not a string"),
    ("complete", "yes", 'complete: "yes" is not true or false'),
    ("boxes.component.0", -2, "boxes.component[0]: -2 is below -1"),
    ("boxes.lo.0", [0.0], "boxes.lo[0]: 1 numbers, expected 4"),
    ("boxes.component", [0], "boxes.component: 1 entries for"),
]


@pytest.mark.parametrize("path, value, message", CASES, ids=[c[0] + ("-del" if c[1] is ... else "") for c in CASES])
def test_a_bad_field_is_named_in_one_line(written, path, value, message):
    with pytest.raises(InputError) as e:
        check_result(_set(written, path, value))
    text = str(e.value)
    assert message in text and "\n" not in text, text


def test_a_constraint_answer_is_valid_and_its_fields_checked(written):
    """A constraint system's answer places entities (no 'q'): the schema's constraint branch and
    the checks of meaning both accept it; a mechanism's answer without 'q' is still refused."""
    d = json.loads(kinbox.assemble("tangent-lines", progress=False).to_json())
    assert d["kind"] == "constraints" and d["solutions"] and "q" not in d["solutions"][0]
    d["components"].append(
        {"dimension": 1, "boxes": 2, "certified": False, "bifurcation_boxes": 0, "samples": [s["entities"] for s in d["solutions"][:3]]}
    )
    check_result(d)
    bad = _set(copy.deepcopy(d), "solutions.0.entities.L.point", [0.0, 1.0])
    with pytest.raises(InputError, match=r"solutions\[0\]\.entities\.L\.point"):
        check_result(bad)
    mech = copy.deepcopy(written)
    del mech["solutions"][0]["q"]
    with pytest.raises(InputError, match="missing 'q'"):
        check_result(mech)


@pytest.mark.parametrize("constant", ["NaN", "Infinity", "-Infinity"])
def test_non_finite_numbers_are_refused_where_numbers_belong(written, tmp_path, capsys, constant):
    text = json.dumps(written).replace(json.dumps(written["solutions"][0]["q"][1]), constant, 1)
    assert constant in text
    p = tmp_path / "nan.json"
    p.write_text(text)
    for cmd in (
        ["replay", str(p), "--html", str(tmp_path / "x.html")],
        ["plot", str(p), "--vars", "coupler,rocker", "-o", str(tmp_path / "x.png")],
    ):
        assert main(cmd) == 2
        err = capsys.readouterr().err.strip()
        assert err.startswith("kinbox: error: ") and "\n" not in err
        assert f"solutions[0].q[1]: {constant} is not a finite number" in err, err
    d = dict(written, stats={"seconds": 1.0})  # where no number is required (stats), they read back as floats
    p.write_text(json.dumps(d).replace('"seconds": 1.0', f'"seconds": {constant}'))
    assert str(load_result(p)["stats"]["seconds"]) in ("nan", "inf", "-inf")


def test_not_a_result(tmp_path):
    p = tmp_path / "x.json"
    for text in ("[1, 2]", '{"a": 1}', '"text"'):
        p.write_text(text)
        with pytest.raises(InputError, match="is not a kinbox result"):
            load_result(p)


def test_result_family_shares_one_status(written):
    """The joint-space answer, the constraint-system answer and the raw search result share one
    base and one status enum; the JSON carries the status beside ``complete``; every solution
    box has one box status, certified exactly when proven."""
    from kinbox.search.outcome import Outcome
    from kinbox.search.status import BoxStatus, Status

    res = kinbox.solve("four-bar", set={"crank": 0.7})
    asm = kinbox.assemble("tangent-lines", progress=False)
    stopped = kinbox.solve("general-6r", max_boxes=3, progress=False)
    for r in (res, asm, res.raw, asm.raw, stopped, stopped.raw):
        assert isinstance(r, Outcome) and isinstance(r.status, Status)
        assert r.complete == (r.status is Status.COMPLETE) == r.success
        d = json.loads(r.to_json())
        assert d["status"] == r.status.value and d["complete"] == r.complete
        assert str(r) == r.table() and r.message in r.table()
    assert res.complete and asm.complete
    assert stopped.status is Status.BOX_BUDGET and stopped.raw.status is Status.BOX_BUDGET
    statuses = {b.status for b in res.raw.boxes}
    assert statuses and statuses <= set(BoxStatus)
    assert all((b.status is BoxStatus.CERTIFIED) == b.certified for b in res.raw.boxes + asm.raw.boxes)
    assert all(b.status is BoxStatus.CURVE for b in res.raw.boxes if b.curve and not b.certified)
    assert json.loads(res.to_json())["boxes"]["status"] == [b.status.value for b in res.raw.boxes]
    # a result names its formulation by a string, in Python and in JSON, whatever its kind; the
    # solutions of both kinds carry one box status, certified exactly when it says so
    assert res.formulation == json.loads(res.to_json())["formulation"] == res.formulated.kind
    assert asm.formulation == json.loads(asm.to_json())["formulation"] and isinstance(asm.formulation, str)
    for r in (res, asm, stopped):
        for s, d in zip(r.solutions, json.loads(r.to_json())["solutions"]):
            assert isinstance(s.status, BoxStatus) and s.certified == (s.status is BoxStatus.CERTIFIED)
            assert d["status"] == s.status.value and d["certified"] == s.certified


def test_files_without_a_status_still_load(written):
    """Result files written before ``status`` was added (``complete`` alone) read back."""
    old = copy.deepcopy(written)
    old.pop("status", None)
    check_result(old)
    with pytest.raises(InputError, match="status"):
        check_result({**written, "status": "finished"})
