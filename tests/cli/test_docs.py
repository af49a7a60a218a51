"""The docs say what is true now: every Python snippet of the README and docs/ runs as written,
every ``kinbox.x.y`` they name exists, and no section of them is dated.

A snippet that cannot run here (it needs a Dask cluster) is preceded by a line
``<!-- not run by tests/cli/test_docs.py: REASON -->``.
"""

from __future__ import annotations

import importlib
import re
import textwrap
from pathlib import Path

import pytest

from tests.support import paths as PATHS

ROOT = PATHS.ROOT
PAGES = [
    ROOT / "README.md",
    ROOT / "CONTRIBUTING.md",
    ROOT / "CHANGELOG.md",
    ROOT / "examples" / "README.md",
    *sorted((ROOT / "docs").glob("*.md")),
    *sorted((ROOT / "tests" / "data").glob("*/README.md")),
]
FENCE = re.compile(r"^( *)```python\n(.*?)^\1```", re.S | re.M)
NOT_RUN = "<!-- not run by tests/cli/test_docs.py:"


def snippets(page: Path) -> list[str]:
    text = page.read_text(encoding="utf-8")
    out = []
    for m in FENCE.finditer(text):
        before = text[: m.start()].rstrip().splitlines()
        if before and before[-1].strip().startswith(NOT_RUN):
            continue
        out.append(textwrap.dedent(m.group(2)))
    return out


RUNNABLE = [p for p in PAGES if p.exists() and snippets(p)]


@pytest.mark.parametrize("page", RUNNABLE, ids=[p.name for p in RUNNABLE])
def test_python_snippets_run(page, tmp_path, monkeypatch):
    """The snippets of one page run in order in one namespace (a later one may use an earlier
    one's names), in an empty directory."""
    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": "__main__"}
    for i, code in enumerate(snippets(page)):
        exec(compile(code, f"{page.name} snippet {i + 1}", "exec"), namespace)  # noqa: S102


def _resolve(dotted: str) -> object:
    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for attr in parts[i:]:
            obj = getattr(obj, attr)
        return obj
    raise ImportError(dotted)


def test_every_kinbox_name_in_the_docs_exists():
    bad = []
    for page in PAGES:
        if not page.exists():
            continue
        for m in re.finditer(r"(?<![\w/.-])kinbox(?:\.[A-Za-z_]\w*)+", page.read_text(encoding="utf-8")):
            name = m.group(0)
            try:
                _resolve(name)
            except (ImportError, AttributeError):
                bad.append(f"{page.name}: {name}")
    assert not bad, bad


def test_no_dated_section_and_no_issue_numbers():
    """Docs describe what is true now: no date (history is in git and CHANGELOG.md), no
    reference to an issue tracker a user does not have."""
    bad = []
    for page in PAGES:
        if not page.exists():
            continue
        for n, line in enumerate(page.read_text(encoding="utf-8").splitlines(), 1):
            if re.search(r"\b20\d\d-\d\d\b|\bissues? ?#?\d", line, re.I):
                bad.append(f"{page.name}:{n}: {line.strip()[:80]}")
    assert not bad, bad


def test_src_comments_name_no_issue_and_no_benchmark_page():
    """Code comments state the rule and the test that guards it: no tracker numbers, and no
    pointer into docs/benchmarks.md, whose sections are rewritten on every run."""
    bad = []
    for path in sorted((ROOT / "src" / "kinbox").rglob("*.py")):
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if re.search(r"\bissues? ?#?\d|docs/benchmarks", line, re.I):
                bad.append(f"{path.relative_to(ROOT)}:{n}: {line.strip()[:80]}")
    assert not bad, bad


def test_tests_benchmarks_and_scripts_name_no_issue():
    """The tests, benchmarks, scripts and examples state their rule too, not a tracker number
    a reader does not have."""
    bad = []
    for folder in ("tests", "benchmarks", "scripts", "examples"):
        for path in sorted((ROOT / folder).rglob("*.py")):
            for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
                if re.search(r"\bissues? ?#?\d", line, re.I):
                    bad.append(f"{path.relative_to(ROOT)}:{n}: {line.strip()[:80]}")
    assert not bad, bad


SH_FENCE = re.compile(r"^( *)```(?:sh|bash|console)\n(.*?)^\1```", re.S | re.M)


def _command_lines(page: Path) -> list[list[str]]:
    """The ``kinbox ...`` command lines of a page's shell blocks, without comments and redirections."""
    import shlex

    out = []
    for m in SH_FENCE.finditer(page.read_text(encoding="utf-8")):
        for line in textwrap.dedent(m.group(2)).replace("\\\n", " ").splitlines():
            # a command substitution is the shell's to expand, "..." a placeholder for the reader
            if not line.startswith("kinbox ") or "$(" in line or " ... " in line:
                continue
            words = shlex.split(line, comments=True)
            if not words or words[0] != "kinbox":
                continue
            cut = next((i for i, w in enumerate(words) if w in (">", ">>", "|", "2>", "&&")), len(words))
            out.append(words[1:cut])
    return out


def test_every_command_line_in_the_docs_parses(capsys):
    """Each ``kinbox ...`` line of the README and docs/ names a subcommand and flags that exist
    (parsed by the program's own argument parser; running them is the job of the CLI tests)."""
    from kinbox.cli import _parser

    bad = []
    for page in PAGES:
        if not page.exists():
            continue
        for argv in _command_lines(page):
            try:
                _parser().parse_args(argv)
            except SystemExit as e:
                if e.code not in (0, None):  # --help exits 0
                    bad.append(f"{page.name}: kinbox {' '.join(argv)}")
    capsys.readouterr()
    assert not bad, bad


JSON_FENCE = re.compile(r"^( *)```json\n(.*?)^\1```", re.S | re.M)


def test_json_examples_in_the_docs_load(tmp_path):
    """A JSON block of the docs is a schematic (it says ``...``), an excerpt (not an object), or a
    file kinbox loads:
    a constraint system, a scene, or a mechanism file."""
    import json

    import kinbox

    loaded = 0
    for page in PAGES:
        if not page.exists():
            continue
        for k, m in enumerate(JSON_FENCE.finditer(page.read_text(encoding="utf-8"))):
            text = textwrap.dedent(m.group(2))
            if "..." in text or not text.lstrip().startswith("{"):  # a schematic, or an excerpt of an answer
                continue
            data = json.loads(text)
            path = tmp_path / f"{page.stem}-{k}.json"
            path.write_text(text, encoding="utf-8")
            if data.get("kind") == "constraints":
                kinbox.load_constraints(str(path))
            elif data.get("kind") == "scene":
                from kinbox.errors import InputError
                from kinbox.model.scene import read_scene

                try:
                    read_scene(str(path))
                except InputError as e:  # a mesh file the reader brings: everything else was read
                    assert "no such file" in str(e), e
            else:
                kinbox.load(str(path))
            loaded += 1
    assert loaded >= 2  # the constraint file of docs/constraints.md, the mechanism file of docs/mechanism-files.md


PAPER_CODE = re.compile(r"(?<![\w.,])(?<!\d )00[0-4](?!\w|\.\d|,\d)")


def test_papers_are_named_by_author_and_year():
    """The papers are cited as "Porta, Ros and Thomas 2009", never by the numbers 000-004 of the
    files they were read from (docs/references.md keys those numbers)."""
    files = [p for p in PAGES if p.exists() and p.name != "references.md" and p.parent.name != "reference"]
    files += sorted((ROOT / "src" / "kinbox").rglob("*.py"))
    bad = []
    for path in files:
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if PAPER_CODE.search(line):
                bad.append(f"{path.relative_to(ROOT)}:{n}: {line.strip()[:80]}")
    assert not bad, bad
