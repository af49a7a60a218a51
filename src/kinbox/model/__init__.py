"""Stage 1, the model: Pinocchio kinematic trees plus loop closures and locked joints
(:mod:`~kinbox.model.mechanism`), built from parameters (:mod:`~kinbox.model.builders`) or
loaded from files and names (:mod:`~kinbox.model.loading`)."""
