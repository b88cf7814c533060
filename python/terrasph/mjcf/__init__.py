"""The MuJoCo plumbing every terrain starts from: loading an MJCF model, the planar check, the planar
robot and its coupled bodies (model.py), a body's collision geoms as terrasph shapes and surfaces
(geoms.py), and the model's floor and the choice of the bodies that meet the sand (terrain_robot.py).
See docs/mjcf.md."""
