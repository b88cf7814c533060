"""What is robot-specific: the actuator controls and ``--ctrl`` specs (control.py), slip and sinkage
(metrics.py), the robot figures (plots.py), a coupled robot's run in the run loop (run.py) and the
example models shipped with the package (``models/``). The terrains they stand on are in
terrasph.terrain, the MuJoCo plumbing in terrasph.mjcf, the robot scenes in terrasph.scenes
(docs/architecture.md, docs/robots.md)."""

import pathlib

__all__ = ["LEG_WHEEL3D", "MODELS", "ROVER", "ROVER4"]

#: the folder of the example MJCF models
MODELS = pathlib.Path(__file__).with_name("models")

#: the example planar rover shipped with the package (a chassis and two driven wheels; see the file)
ROVER = MODELS / "rover.xml"

#: the example non-planar robot shipped with the package: a four-wheeled rover on a free joint (see the file)
ROVER4 = MODELS / "rover4.xml"

#: a narrow leg-wheel on chapter 4's rig for the 3D SPH bed: a chassis sliding in x and z, three
#: C-legs of box geoms 5 cm wide on a hinge with a velocity servo (see the file; docs/sph3d.md)
LEG_WHEEL3D = MODELS / "leg_wheel3d.xml"
