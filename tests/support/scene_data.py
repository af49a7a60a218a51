"""Mechanism files with collision shapes for tests/answer/test_scene.py."""

#: the four-bar of src/kinbox/robots/four-bar.xml with a capsule on each moving link (at
#: heights 0, 0.2 and 0.4 so that the links never meet each other)
FOUR_BAR_BODIES = """<mujoco model="four-bar-bodies">
  <compiler angle="radian"/>
  <worldbody>
    <body name="crank" pos="0 0 0" euler="0 0 1.5707963267948966">
      <joint name="crank" type="hinge" axis="0 0 1" ref="1.5707963267948966"/>
      <geom name="crank_bar" type="capsule" fromto="0 0 0 1 0 0" size="0.05"/>
      <body name="coupler" pos="1 0 0" euler="0 0 -1.2334888453651298">
        <joint name="coupler" type="hinge" axis="0 0 1" ref="-1.2334888453651298"/>
        <geom name="coupler_bar" type="capsule" fromto="0 0 0.2 3 0 0.2" size="0.05"/>
        <body name="rocker" pos="3 0 0" euler="0 0 -1.8234765819369754">
          <joint name="rocker" type="hinge" axis="0 0 1" ref="-1.8234765819369754"/>
          <geom name="rocker_bar" type="capsule" fromto="0 0 0.4 2 0 0.4" size="0.05"/>
        </body>
      </body>
    </body>
  </worldbody>
  <equality>
    <connect name="ground_pivot" body1="rocker" anchor="2 0 0"/>
  </equality>
</mujoco>
"""
