"""Stage 5, pictures: replay in meshcat and HTML (:mod:`~kinbox.viz.replay`), plots with
matplotlib (:mod:`~kinbox.viz.plot`). Meshes load only here."""
