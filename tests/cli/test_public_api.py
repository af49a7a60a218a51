"""The public API is visible: ``dir(kinbox)``, ``__all__`` and the names type checkers see."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import kinbox

INIT = Path(kinbox.__file__)


def _type_checking_names() -> set[str]:
    """The names imported under ``if TYPE_CHECKING:`` in kinbox/__init__.py."""
    tree = ast.parse(INIT.read_text())
    names: set[str] = set()
    for node in tree.body:
        if isinstance(node, ast.If) and isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING":
            for imp in node.body:
                assert isinstance(imp, ast.ImportFrom)
                names |= {a.asname or a.name for a in imp.names}
    return names


def test_dir_shows_the_public_api():
    shown = dir(kinbox)
    for name in ("ik", "IK", "solve", "assemble", "Result", "KinboxError", "__version__"):
        assert name in shown
    assert set(kinbox.__all__) <= set(shown)


def test_every_public_name_resolves_and_type_checkers_see_it():
    lazy = set(kinbox._LAZY)
    assert _type_checking_names() == lazy  # the TYPE_CHECKING block lists exactly the lazy names
    for name in kinbox.__all__:
        assert getattr(kinbox, name) is not None, name


def test_the_type_checking_block_imports_what_getattr_loads():
    """Each name of the TYPE_CHECKING block comes from the module that __getattr__ loads it from."""
    tree = ast.parse(INIT.read_text())
    for node in tree.body:
        if isinstance(node, ast.If) and isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING":
            for imp in node.body:
                assert isinstance(imp, ast.ImportFrom)
                for a in imp.names:
                    assert kinbox._LAZY[a.name] == imp.module, a.name


def test_dir_does_not_import_the_heavy_stages():
    code = "import sys, kinbox; dir(kinbox); print('kinbox.pipeline' in sys.modules, 'pinocchio' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["False", "False"]


def test_all_is_the_lazy_names_and_the_errors():
    errors = {n for n in vars(kinbox) if n.endswith("Error") or n == "NameNotFound"}
    assert set(kinbox.__all__) == set(kinbox._LAZY) | errors
    assert len(kinbox.__all__) == len(set(kinbox.__all__))
