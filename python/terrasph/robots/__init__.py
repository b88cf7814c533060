"""Dynamic robots on the SPH terrain: planar MJCF robots simulated by MuJoCo, two-way coupled
with the granular bodies (docs/design.md §3.6). See docs/robots.md."""

from terrasph.robots.coupling import CoupledSimulation
from terrasph.robots.metrics import sinkage, slip
from terrasph.robots.mjcf import ROVER, CoupledBody, Coupling, Inertial, PlanarRobot, shape_inertial

__all__ = ["ROVER", "CoupledBody", "CoupledSimulation", "Coupling", "Inertial", "PlanarRobot", "shape_inertial",
           "sinkage", "slip"]
