"""Fixtures shared by every stage's tests; oracles, references and helpers live in
``tests/support`` (a package: tests import it, never each other)."""

from __future__ import annotations

import json

import pytest

import kinbox
from tests.support import paths


@pytest.fixture
def ur5() -> kinbox.IK:
    """A fresh IK problem of example-robot-data's UR5 to its ``tool0`` frame (built per test,
    so a test may change its options)."""
    return kinbox.IK("ur5", "tool0")


@pytest.fixture
def reference():
    """A published answer of ``tests/data/reference`` by file name, as JSON."""

    def load(name: str) -> dict:
        return json.loads((paths.REFERENCE / name).read_text())

    return load
