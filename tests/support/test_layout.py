"""The tests mirror the source: each test module sits in the folder of the stage it tests, and
no test module imports another (shared code lives in ``tests/support``)."""

from __future__ import annotations

import ast

from tests.support import paths

TESTS = paths.ROOT / "tests"
STAGES = {"model", "formulation", "search", "answer", "viz", "cli", "workspace", "support"}


def test_every_test_module_is_in_a_stage_folder():
    misplaced = [
        p.relative_to(TESTS).as_posix() for p in TESTS.rglob("test_*.py") if p.parent.name not in STAGES or p.parent.parent != TESTS
    ]
    assert not misplaced, misplaced
    src = {p.name for p in (paths.ROOT / "src" / "kinbox").iterdir() if p.is_dir() and not p.name.startswith("_")}
    assert STAGES - {"support", "cli"} <= src | {"workspace"}


def test_no_test_module_imports_another():
    offenders = []
    for p in TESTS.rglob("*.py"):
        for node in ast.walk(ast.parse(p.read_text())):
            names = []
            if isinstance(node, ast.ImportFrom) and node.module:
                names = [node.module, *(f"{node.module}.{a.name}" for a in node.names)]
            elif isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            if any(part.startswith("test_") for n in names for part in n.split(".")):
                offenders.append(p.relative_to(TESTS).as_posix())
    assert not offenders, offenders


def test_every_import_of_a_support_module_names_the_package():
    """In-function imports included: a helper moved into ``tests.support`` is imported from there."""
    support = {p.stem for p in (TESTS / "support").glob("*.py")} | {"oracles"}
    offenders = []
    for p in TESTS.rglob("*.py"):
        for node in ast.walk(ast.parse(p.read_text())):
            mods = []
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                mods = [node.module] + ([f"tests.{a.name}" for a in node.names] if node.module == "tests" else [])
            elif isinstance(node, ast.Import):
                mods = [a.name for a in node.names]
            for m in mods:
                parts = m.split(".")
                if parts[0] in support or (parts[0] == "tests" and len(parts) > 1 and parts[1] not in STAGES):
                    offenders.append(f"{p.relative_to(TESTS).as_posix()}: {m}")
    assert not offenders, offenders
