"""Every inverse-kinematics solution of a UR5, each certified and checked with Pinocchio.

Run: ``python examples/ur5_ik.py``.
"""

import numpy as np
import pinocchio as pin

import kinbox

ik = kinbox.IK("ur5", "tool0")  # the robot from example-robot-data; the arm is formulated once
q_ref = np.array([0.3, -1.2, 1.5, -0.8, 1.2, 0.4])
goal = ik.pose_at(q_ref)  # a reachable pose: the frame's placement at q_ref (pin.SE3)

res = ik.solve(goal)
print(res)  # a table of the solutions; res.to_json() for machines
assert res.complete  # the search ran to its end: there is no other solution

model = ik.robot.model
data = model.createData()
frame = model.getFrameId("tool0")
for s in res.solutions:
    pin.framesForwardKinematics(model, data, s.q)  # check each solution independently
    err = np.linalg.norm(pin.log6(data.oMf[frame].actInv(goal)).vector)
    print(f"q = {np.round(s.q, 4)}  certified={s.certified}  |log6 error| = {err:.1e}")
print(f"{len(res.solutions)} solutions; the generating q is among them:", any(np.allclose(s.q, q_ref, atol=1e-6) for s in res.solutions))
