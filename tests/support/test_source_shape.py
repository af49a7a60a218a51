"""The source's shape: no import cycle among kinbox's modules, counting the imports inside
functions and under ``TYPE_CHECKING`` too (the layers contract of ``lint-imports`` checks only
the direction between stages), and no function of the search stage longer than a screen or two."""

from __future__ import annotations

import ast

import grimp  # import-linter's graph library (the test extra installs it with import-linter)

from tests.support import paths

#: the longest function ``src/kinbox/search`` may hold, in lines (its docstring included)
MAX_SEARCH_FUNCTION_LINES = 120


def _cycles(graph: grimp.ImportGraph) -> list[list[str]]:
    """The strongly connected components of more than one module: a module's component is the
    modules it imports (directly or not) that import it back."""
    seen: set[str] = set()
    out = []
    for m in sorted(graph.modules):
        if m in seen:
            continue
        part = graph.find_upstream_modules(m) & graph.find_downstream_modules(m)
        if part:
            component = sorted(part | {m})
            seen.update(component)
            out.append(component)
    return out


def test_no_import_cycle_even_through_function_level_imports():
    """grimp reads every ``import`` statement of a module, those inside functions and under
    ``if TYPE_CHECKING:`` included (``exclude_type_checking_imports`` left off): a module that
    imports another inside a function depends on it all the same."""
    graph = grimp.build_graph("kinbox", cache_dir=None)
    assert graph.find_modules_directly_imported_by("kinbox.search.cf_certify"), "the graph has no edges"
    cycles = _cycles(graph)
    detail = [
        " -> ".join(graph.find_shortest_chain(importer=c[0], imported=c[1]) or ())
        + " ... "
        + " -> ".join(graph.find_shortest_chain(importer=c[1], imported=c[0]) or ())
        for c in cycles
    ]
    assert not cycles, detail


def test_the_cycle_finder_sees_a_cycle():
    graph = grimp.ImportGraph()
    for a, b in (("p.a", "p.b"), ("p.b", "p.c"), ("p.c", "p.a"), ("p.c", "p.d")):
        graph.add_import(importer=a, imported=b)
    assert _cycles(graph) == [["p.a", "p.b", "p.c"]]


def test_no_function_of_the_search_stage_is_over_a_screen_or_two():
    long = []
    for path in sorted((paths.ROOT / "src" / "kinbox" / "search").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = (node.end_lineno or node.lineno) - node.lineno + 1
                if n > MAX_SEARCH_FUNCTION_LINES:
                    long.append(f"{path.name}:{node.lineno} {node.name}: {n} lines")
    assert not long, long


def test_every_test_module_a_comment_or_page_names_exists():
    """A comment names the test that guards its rule: that test is where it says (the tests
    moved into stage folders once; a path left behind names nothing)."""
    import re

    root = paths.ROOT
    files = [*(root / "src" / "kinbox").rglob("*.py"), root / "README.md", root / "CONTRIBUTING.md", *(root / "docs").glob("*.md")]
    missing = []
    for f in files:
        for m in re.finditer(r"\btests/(?:[a-z_]+/)*test_\w+\.py", f.read_text(encoding="utf-8")):
            if not (root / m.group(0)).is_file():
                missing.append(f"{f.relative_to(root)}: {m.group(0)}")
    assert not missing, sorted(set(missing))
