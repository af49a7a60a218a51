"""The 3-D view of a workspace paving: the merged meshes of its verdicts, and the page."""

from __future__ import annotations

import numpy as np
import pytest

from kinbox import cli
from kinbox.workspace.view3d import merged_mesh


def _faces(g, verdict):
    V, F = merged_mesh(np.zeros(3), np.ones(3), g, verdict)
    return len(F) // 4  # four triangles per face (two, each way round)


def test_the_merged_mesh_keeps_only_outer_faces():
    g = np.full((3, 3, 3), 0, dtype=np.int8)
    g[1, 1, 1] = 1
    assert _faces(g, 1) == 6
    g[1, 1, 2] = 1  # a neighbour: the face between them is gone
    assert _faces(g, 1) == 10
    g[:] = 1
    assert _faces(g, 1) == 6 * 9  # a solid block: its skin only
    V, F = merged_mesh(np.array([1.0, 2.0, 3.0]), np.array([0.5, 0.5, 0.5]), g, 1)
    assert np.allclose(V.min(axis=0), [1.0, 2.0, 3.0]) and np.allclose(V.max(axis=0), [2.5, 3.5, 4.5])
    assert F.max() < len(V)


@pytest.mark.slow
def test_replay_writes_the_page_of_a_paving(tmp_path):
    m = tmp_path / "m.npz"
    argv = ["reach", "ur5", "--frame", "tool0", "--orientation", "1", "0", "0", "0", "--quiet"]
    argv += ["--region", "0.3", "0.0", "0.1", "0.4", "0.1", "0.2", "--resolution", "0.05", "--out", str(m)]
    assert cli.main(argv) == 0
    page = tmp_path / "m.html"
    assert cli.main(["replay", str(m), "--html", str(page)]) == 0
    text = page.read_text()
    assert "workspace of ur5 tool0" in text and "witness 1 of" in text
    assert cli.main(["replay", str(m)]) == 2  # a paving is a page: --html is needed
