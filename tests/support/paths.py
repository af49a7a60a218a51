"""Where the tests find the repository, their data and the built-in robots."""

from __future__ import annotations

from pathlib import Path

#: the repository's root (the folder holding ``src/``, ``tests/`` and ``docs/``)
ROOT = Path(__file__).resolve().parents[2]
#: the tests' data files
DATA = ROOT / "tests" / "data"
#: published reference answers
REFERENCE = DATA / "reference"
#: kinbox's built-in robot and mechanism files
ROBOTS = ROOT / "src" / "kinbox" / "robots"
