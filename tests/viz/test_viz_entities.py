"""Drawing constraint-system answers: the static page holds every entity, and the transform of
each shape puts it where the answer says."""

from __future__ import annotations

import numpy as np

from kinbox.viz import entities


def test_shapes_sit_on_their_entities():
    line = {"point": [1.0, 2.0, 3.0], "direction": [0.0, 0.6, 0.8]}
    T = entities.transform(line)
    assert np.allclose(T[:3, 3], line["point"]) and np.allclose(T[:3, 1], line["direction"])  # cylinders: y axis
    plane = {"point": [0.0, 0.0, 2.0], "normal": [0.0, 0.0, 1.0]}
    T = entities.transform(plane)
    assert np.allclose(T[:3, 2], plane["normal"]) and abs(np.linalg.det(T[:3, :3]) - 1) < 1e-12
    assert np.allclose(entities.transform([1.0, 2.0, 3.0])[:3, 3], [1, 2, 3])


def test_static_page_holds_every_assembly(tmp_path):
    result = {
        "kind": "constraints",
        "problem": "demo",
        "solutions": [
            {
                "entities": {
                    "p": [0, 0, 0],
                    "L": {"point": [0, 0, 0], "direction": [1, 0, 0]},
                    "P": {"point": [0, 0, 1], "normal": [0, 0, 1]},
                },
                "certified": True,
            },
            {
                "entities": {
                    "p": [1, 0, 0],
                    "L": {"point": [0, 1, 0], "direction": [0, 1, 0]},
                    "P": {"point": [0, 0, -1], "normal": [0, 0, 1]},
                },
                "certified": False,
            },
        ],
        "components": [],
    }
    out = entities.to_html(result, tmp_path / "page.html", delay=0.5)
    page = out.read_text()
    assert "MeshCat" in page and "assembly 2 of 2 (not certified)" in page
    assert page.count('fetch("data:application/octet-binary') >= 4  # three shapes and the animation
