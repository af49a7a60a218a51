"""``kinbox solve`` and ``kinbox check`` on constraint systems: JSON answers, the diagnosis, the
refusal of an inconsistent system, one-line errors for bad files. One test runs the command as a
subprocess; the others call its ``main`` in this process (the same code, without a Python start
and the kernels' loading each time)."""

from __future__ import annotations

import json
import subprocess

import pytest

from kinbox.cli import main
from tests.support import paths as PATHS
from tests.support.cli import assert_usage_error
from tests.support.cli import kinbox_cli as subprocess_cli

DATA = PATHS.DATA / "constraints"


@pytest.fixture
def kinbox_cli(capsys):
    def run(*args) -> subprocess.CompletedProcess:
        capsys.readouterr()
        code = main([str(a) for a in args])
        out, err = capsys.readouterr()
        return subprocess.CompletedProcess(args, code, out, err)

    return run


def test_solve_a_builtin_system_as_json():
    p = subprocess_cli("solve", "octahedral-a", "--json", "--quiet")
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["kind"] == "constraints" and d["complete"] and d["shapes"] == 2
    assert len(d["solutions"]) == 4 and all(s["certified"] for s in d["solutions"])
    assert set(d["solutions"][0]["entities"]) == {f"p{i}" for i in range(1, 7)}
    assert d["diagnosis"]["dof"] == 0


def test_replay_draws_an_answer_and_plot_refuses_it(tmp_path, kinbox_cli):
    out = tmp_path / "octa.json"
    p = kinbox_cli("solve", "octahedral-a", "--json", "--quiet")
    assert p.returncode == 0, p.stderr
    out.write_text(p.stdout)
    page = tmp_path / "octa.html"
    p = kinbox_cli("replay", out, "--html", page, "--delay", "0.5")
    assert p.returncode == 0, p.stderr
    assert "assembly 4 of 4 (certified)" in page.read_text()
    assert_usage_error(kinbox_cli("plot", out, "--vars", "a,b", "-o", tmp_path / "x.png"), "constraint system", "replay")


def test_set_changes_a_parameter(tmp_path, kinbox_cli):
    p = kinbox_cli(
        "solve",
        "octahedral-a",
        "--set",
        "r15=4.75",
        "--set",
        "r26=4.75",
        "--set",
        "r34=4.75",
        "--set",
        "r16=4.75",
        "--set",
        "r24=4.75",
        "--set",
        "r35=4.75",
        "--formulation",
        "distances",
        "--json",
        "--quiet",
    )
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["formulation"] == "distances" and d["shapes"] == 8  # configuration 'b' of Porta et al. 2005


def test_check_prints_the_diagnosis(kinbox_cli):
    p = kinbox_cli("check", "ruiz-cartesian-table")
    assert p.returncode == 0, p.stderr
    assert "degrees of freedom at a solution: 3" in p.stdout and "under-constrained" in p.stdout
    p = kinbox_cli("check", "bricard", "--json")
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["counted_mobility"] == 0 and "1" in d["mobility_at_solutions"]


def test_an_inconsistent_system_is_refused_with_its_constraints(kinbox_cli):
    f = DATA / "ruiz-dph-inconsistent.json"
    line = assert_usage_error(kinbox_cli("solve", f, "--quiet"), "C3", "C4", "inconsistent")
    assert "C1" not in line
    p = kinbox_cli("check", f)
    assert p.returncode == 2 and "INCONSISTENT" in p.stdout and "C3" in p.stderr


@pytest.mark.parametrize(
    "spec, words",
    [
        ({"entities": {"p": {"type": "point"}}, "constraints": [{"type": "distance", "entities": ["p", "q"], "value": 1}]}, ["#1", "'q'"]),
        ({"entities": {"p": {"type": "pointe"}}}, ["'p'", "type"]),
        (
            {
                "entities": {"p": {"type": "point", "fixed": [0, 0, 0]}, "L": {"type": "line"}},
                "constraints": [{"type": "angle", "entities": ["p", "L"], "value": 1}],
            },
            ["#1", "angle"],
        ),
        (
            {
                "entities": {"o": {"type": "point", "fixed": [0, 0, 0]}, "p": {"type": "point"}, "L": {"type": "line"}},
                "constraints": [{"type": "distance", "entities": ["o", "L"], "value": 1}, {"type": "incident", "entities": ["p", "L"]}],
            },
            ["'p'", "bounds"],
        ),
    ],
)
def test_bad_files_give_one_line(tmp_path, spec, words, kinbox_cli):
    f = tmp_path / "bad.json"
    f.write_text(json.dumps({"kind": "constraints", **spec}))
    assert_usage_error(kinbox_cli("solve", f, "--quiet"), *words)


def test_unknown_parameter_and_formulation_errors(tmp_path, kinbox_cli):
    assert_usage_error(kinbox_cli("solve", "tangent-lines", "--set", "radiu=1.2", "--quiet"), "radiu")
    assert_usage_error(kinbox_cli("solve", "ruiz-dph", "--formulation", "distances", "--quiet"), "distance formulation")


def test_check_is_public_and_the_command_prints_it(kinbox_cli):
    """``kinbox.check`` is the diagnosis ``kinbox check`` prints: the same JSON; an inconsistent
    system's reason in ``inconsistent`` (the command's one line on stderr, exit 2)."""
    import kinbox

    c = kinbox.check("bricard")
    p = kinbox_cli("check", "bricard", "--json")
    assert p.returncode == 0, p.stderr
    assert json.loads(p.stdout) == json.loads(json.dumps(c.to_dict()))
    assert c.inconsistent is None and c.problem in c.table()
    bad = kinbox.check(DATA / "ruiz-dph-inconsistent.json")
    assert bad.inconsistent is not None and "C3" in bad.inconsistent and "INCONSISTENT" in bad.table()
