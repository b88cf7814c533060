"""Scene ``rover``: the example planar rover (``terrasph.robots.ROVER``: a chassis
free in x, z and pitch, two wheels on hinges 12 cm apart, velocity-servo motors) crossing a bed of
3 mm glass beads, both wheels the same leg-wheel (or plain wheel) shape, paused and then driven
clockwise at ω. Masses and inertias are the MJCF's (chassis 0.3 kg, wheels 0.1 kg each)."""

from __future__ import annotations

import dataclasses
import math
import os
import pathlib
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from terrasph import bodies
from terrasph.config import ConfigError
from terrasph.io import write_results
from terrasph.mjcf.model import Coupling, PlanarRobot
from terrasph.options import option, redefault
from terrasph.robots import ROVER
from terrasph.robots.metrics import slip
from terrasph.robots.plots import plot_robot
from terrasph.robots.run import RobotRun, run_coupled
from terrasph.scenes.leg_wheel import (
    WheelScene,
    bed_and_wheel,
    check_wheel_config,
    wheel_bed_ends,
    wheel_footprint,
    wheel_shape,
)
from terrasph.settle_cache import SettleCache, run_after_pause
from terrasph.simulation import Simulation
from terrasph.size_guard import Footprint
from terrasph.terrain.interface import Terrain, couple
from terrasph.terrain.sph_coupling import CoupledSimulation

__all__ = ["WHEEL_BODIES", "Rover", "build_rover", "run_rover"]

#: the rover's coupled bodies and their motors' indices in data.ctrl (the MJCF's order)
WHEEL_BODIES = ("rear_wheel", "front_wheel")
#: axle spacing of the shipped MJCF (m)
AXLE_SPACING = 0.12


@dataclass(frozen=True)
class Rover(WheelScene):
    """Configuration of a rover run: a WheelScene (both wheels alike) with the rover's own defaults
    (smaller wheels that clear each other, a shorter run) and the robot's MJCF."""

    SCENE: ClassVar[str] = "rover"  #: the registered scene, whose fidelity tiers apply
    leg_length: float = redefault(WheelScene, "leg_length", 0.04)  #: the wheels, 12 cm apart, must clear each other
    width: float = redefault(WheelScene, "width", 0.05)
    settle_time: float = redefault(WheelScene, "settle_time", 1.0)
    t_end: float = redefault(WheelScene, "t_end", 4.0)
    #: a planar MJCF robot instead of the example rover; its wheels are the bodies named in WHEEL_BODIES
    mjcf: str | None = option(None, cli="model", unit="MJCF file",
                              help="your planar robot: an MJCF whose wheel bodies are named rear_wheel and "
                                   "front_wheel, each driven by a velocity motor (docs/robots.md)",
                              default_text="the example rover, terrasph/robots/models/rover.xml")

    def __post_init__(self) -> None:
        check_wheel_config(self)
        if self.mjcf is not None and not pathlib.Path(self.mjcf).is_file():
            raise ConfigError(f"parameter 'mjcf' = {self.mjcf!r} is invalid: allowed an existing MJCF file")
        if not 2 * self.leg_length < AXLE_SPACING:
            raise ConfigError(f"parameter 'leg_length' = {self.leg_length!r} is invalid: allowed < "
                              f"{AXLE_SPACING / 2} m (the wheels, {AXLE_SPACING} m apart, must not touch)")
        reach = 0.5 * AXLE_SPACING + self.leg_length
        if not reach < self.start_x < self.bed_width - reach:
            raise ConfigError(f"parameter 'start_x' = {self.start_x!r} is invalid: allowed between {reach:.4g} and "
                              f"bed_width − {reach:.4g} m (both wheels clear of the container)")

    def shape(self) -> bodies.BodyShape:
        """One wheel in its own frame (axle at the origin)."""
        return wheel_shape(self)

    def footprint(self) -> Footprint:
        """The bed, both wheels and the container (size guard)."""
        return wheel_footprint(self, wheels=len(WHEEL_BODIES), material=self.bed_material())


def build_rover(config: Rover) -> Terrain:
    """Bed, container and the rover standing on it (wheels Δx/2 above the surface), coupled
    (:func:`terrasph.terrain.interface.couple`)."""
    scene, numerics, surface, shape = bed_and_wheel(config)
    axle_z = surface - shape.lowest_point() + 0.5 * config.spacing
    robot = PlanarRobot(config.mjcf or ROVER, {name: Coupling(shape, config.width) for name in WHEEL_BODIES},
                        gravity=scene.gravity, initial={"x": config.start_x, "z": axle_z})
    robot.add_to_scene(scene)
    return couple(robot, "sph", simulation=Simulation(scene, config.bed_material(), numerics))


def run_rover(config: Rover, output: str | os.PathLike[str] | None = None, *, progress: bool = False,
              plot: bool = True, resume: bool = False, until: float | None = None,
              cache: SettleCache | bool = True) -> RobotRun:
    """Runs the scene; returns a summary (distance, mean speed and slip of each wheel after the
    pause, final sinkage of each wheel, pitch, leaks; ``end_of_bed`` as in :func:`run_leg_wheel`) and
    the series, and with `plot` and an `output` draws the PNG beside it. ``resume``, ``until`` and
    ``cache`` (the settled pause, terrasph.settle_cache) as in :func:`run_leg_wheel`."""
    sand = build_rover(config)
    coupled = sand.coupling
    bed = wheel_bed_ends(config, coupled, resume)
    assert bed is not None  # the rover runs on the SPH, whose bed has its container's ends

    def motors(run: CoupledSimulation) -> None:
        run.robot.data.ctrl[:] = config.omega if run.time >= config.settle_time else 0.0

    run_config = {"scene": "rover", "rover": dataclasses.asdict(config), **coupled.sim.describe()}
    t_end = config.t_end if until is None else until

    def run(terrain: Terrain, end: float, out: str | os.PathLike[str] | None,
            resumed: bool) -> dict[str, dict[str, np.ndarray]]:
        bed.coupled = terrain.coupling  # the end check follows the terrain that runs (a cached pause continues on another)
        return run_coupled(terrain, end, output=out, frame_interval=config.frame_interval,
                           series_interval=config.series_interval, control=motors, progress=progress,
                           resume=resumed, end_check=bed, config=run_config)

    if cache is not False and not resume and 0 < config.settle_time < t_end:
        series, sand, _ = run_after_pause(cache, "rover", config, sand, lambda: build_rover(config), run, output,
                                          run_config, config.settle_time, t_end)
        coupled = sand.coupling
    else:
        series = run(sand, t_end, output, resume)
    summary: dict[str, Any] = {"wheel": config.wheel, "steps": coupled.sim.step_count,
                               "leaked_particles": coupled.sim.leaked_particles,
                               "distance": float(coupled.robot.data.qpos[0] - config.start_x),
                               "final_pitch": float(coupled.robot.data.qpos[2]), "end_of_bed": bed.reason}
    radius = coupled.robot.coupled[0].shape.radius
    for name in WHEEL_BODIES:
        body = series[f"robot/{name}"]
        driving = (body["time"] > config.settle_time) & (body["omega"] >= 0.5 * config.omega)
        speed = float(np.mean(body["velocity"][driving, 0])) if driving.any() else math.nan
        spin = float(np.mean(body["omega"][driving])) if driving.any() else math.nan
        summary[f"{name}_mean_slip"] = float(slip(speed, spin, radius)) if driving.any() else math.nan
        summary[f"{name}_final_sinkage"] = float(body["sinkage"][-1])
        summary[f"{name}_mean_sinkage"] = float(np.mean(body["sinkage"][driving])) if driving.any() else math.nan
        summary[f"{name}_mean_forward_speed"] = speed
    if output is not None:
        write_results(output, summary)
    figure = None
    if plot and output is not None:
        figure = str(pathlib.Path(output).with_suffix(".png"))
        plot_robot(series, WHEEL_BODIES, figure, settle_time=config.settle_time, title=f"rover, {config.wheel}")
    return RobotRun(summary, series, figure)
