"""Independent reference solutions ("oracles") for kinbox tests.

Every oracle here is computed in closed form (or by an independent polynomial method), never by
kinbox and never by a numerical IK solver:

* :mod:`tests.oracles.ur_ik` -- analytic inverse kinematics of the Universal Robots UR3/UR5/UR10
  (published DH parameters), mapped to the example-robot-data Pinocchio models.
* :mod:`tests.oracles.planar` -- four-bar assembly modes (circle-circle intersection) and 3-RPR
  forward kinematics (tangent half-angle -> univariate polynomial of degree <= 6).
"""
