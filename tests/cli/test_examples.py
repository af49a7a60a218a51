"""Every script of examples/ runs as written, so none of them rots (each with a short budget
where its whole answer takes long)."""

from __future__ import annotations

import runpy
import sys

import pytest

from tests.support import paths as PATHS

EXAMPLES = PATHS.ROOT / "examples"
#: arguments a script gets here: a time limit where the whole answer takes tens of seconds
ARGS = {"stewart_platform.py": ["2"]}


def test_every_example_is_listed():
    assert sorted(p.name for p in EXAMPLES.glob("*.py")) == sorted(
        ["ur5_ik.py", "stewart_platform.py", "four_bar_curves.py", "constraint_system.py", "save_resume.py", "parallel_poses.py"]
    )


@pytest.mark.parametrize("name", sorted(p.name for p in EXAMPLES.glob("*.py")))
def test_example_runs(name, monkeypatch, capsys):
    monkeypatch.setattr(sys, "argv", [name, *ARGS.get(name, [])])
    runpy.run_path(str(EXAMPLES / name), run_name="__main__")
    out = capsys.readouterr().out
    assert out.strip(), f"{name} printed nothing"
    assert "Traceback" not in out
