"""Scene ``leg-wheel`` (dissertation ch. 4, Fig. 4.2–4.4): one hybrid leg-wheel, free in x and z,
driven through a bed of 3 mm glass beads.

The robot (MJCF built by :func:`leg_wheel_mjcf`) is a test rig: a *chassis* free to slide in x and
z that carries the load (its mass is load/g: the dissertation's 4.9 N is 0.4995 kg) and the axle,
and the *wheel* on a hinge about y, turned by a velocity servo (gain ``motor_gain`` N·m·s/rad,
torque limit ``motor_torque`` N·m) that holds ω = 0 for the settling pause and then
``omega`` clockwise. The wheel's mass and inertia are those of its shape at ``wheel_density``
(:func:`terrasph.mjcf.model.shape_inertial`). MuJoCo integrates with ``implicitfast`` so the stiff
servo is stable at the SPH step.

Readings (the figure is not in the text): ``leg_length`` is the dissertation's "2R = 8 cm" read
as in chapter 3, the hip-to-toe length of each leg, so the tips lie on a circle of radius 8 cm;
the wheels have ``legs`` = 3 legs (Whegs-like); the plain wheel has the same outer radius. Slip
(Eq. 4.8) uses that radius. Sinkage is the depth of the wheel's lowest point below the bed's
undisturbed free surface, measured at each sample away from the wheel
(:func:`terrasph.terrain.sph_coupling.undisturbed_surface`).
"""

from __future__ import annotations

import dataclasses
import math
import os
import pathlib
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from terrasph import bodies
from terrasph.config import ConfigError, Material, Numerics, check_settle_time
from terrasph.fidelity import check_tier, fidelity_option, scene_numerics
from terrasph.geometry import wall_layers_needed
from terrasph.io import write_results
from terrasph.mjcf.model import Coupling, PlanarRobot, shape_inertial
from terrasph.options import option, shared
from terrasph.robots.metrics import slip
from terrasph.robots.plots import plot_robot
from terrasph.robots.run import BedEnds, RobotRun, run_coupled
from terrasph.scene import GRAVITY, Scene, flung_height
from terrasph.scenes.leg_rotation import BeadBed
from terrasph.schedules import check_knots, evaluate
from terrasph.settle_cache import SettleCache, run_after_pause
from terrasph.simulation import Simulation
from terrasph.size_guard import Footprint
from terrasph.terrain import rft
from terrasph.terrain.interface import Terrain, couple
from terrasph.terrain.sph_coupling import BED_NUMERICS, CoupledSimulation, RobotStepper

__all__ = ["SPH_BED_WIDTH", "WHEELS", "LegWheel", "build_leg_wheel", "leg_wheel_mjcf", "plot_leg_wheel", "run_leg_wheel"]

#: the five morphologies of Fig. 4.2 and the plain wheel
WHEELS = ("flat-leg", "c-leg", "reversed-c-leg", "l-leg", "reversed-l-leg", "wheel")
#: the SPH bed's default width (m), the container of the dissertation's Fig. 4.3 runs
SPH_BED_WIDTH = 0.5


@dataclass(frozen=True)
class WheelScene(BeadBed):
    """What the leg-wheel and rover configurations share: the wheel, the bed (its material options
    from BeadBed), the times. Lengths in m, times in s, angles in rad (clockwise)."""

    #: fields saved under another name by earlier versions (run files, sweep SPECs): old → new
    RENAMED_FIELDS: ClassVar[Mapping[str, str]] = {"duration": "t_end"}
    #: the fields that act only after the pause: runs differing only in them share the state at its
    #: end (terrasph.settle_cache); every other field is part of that state's key
    DRIVE_FIELDS: ClassVar[tuple[str, ...]] = ("omega", "t_end")
    SCENE: ClassVar[str] = "leg-wheel"  #: the registered scene, whose fidelity tiers apply

    wheel: str = option("c-leg", choices=WHEELS, help="morphology (Fig. 4.2) or plain wheel")
    legs: int = option(3, help="legs of a leg-wheel, 1-12")
    omega: float = option(1.5, help="commanded spin after the pause, clockwise", unit="rad/s")
    #: hip-to-toe length of each leg, so the radius of the circle of its tips (the dissertation's
    #: "2R = 8 cm" read as this length, module docstring)
    leg_length: float = shared("leg_length", 0.08)
    thickness: float = option(0.005, help="leg thickness, >= 3 dx", unit="m")
    width: float = option(0.1, help="each wheel's out-of-plane width; loads are for it", unit="m")
    foot_ratio: float = option(0.33, help="foot/leg length of the L-legs")
    spacing: float = option(0.005 / 3, help="particle spacing dx; parts thinner than 3 dx are refused", unit="m")
    bed_width: float = shared("bed_width", SPH_BED_WIDTH)
    bed_depth: float = shared("bed_depth", 0.1)
    start_x: float = option(0.12, help="axle x at start (the rover: the middle of its axles)", unit="m")
    settle_time: float = shared("settle_time", 2.0)
    #: 2.5 s of driving: the default C-leg wheel's axle, measured on the SPH bed, is at 0.129 m at 2.0 s
    #: and 0.360 m at 4.5 s, so its legs reach at most 0.44 m, short of the 0.5 m bed's end less
    #: BED_END_MARGIN; at 6 s it was at 0.536 m, off the bed (docs/robots.md)
    t_end: float = shared("t_end", 4.5)
    series_interval: float = option(0.01, help="time between series samples", unit="s")
    frame_interval: float = shared("frame_interval", 0.05)
    fidelity: str = fidelity_option("leg-wheel")
    numerics: dict[str, Any] = field(default_factory=dict)  #: overrides of the tier's numerics


@dataclass(frozen=True)
class LegWheel(WheelScene):
    """Configuration of a leg-wheel run: a WheelScene with its load, motor and bed material."""

    #: the settings of the SPH bed only, refused on the RFT terrain unless at their defaults
    SPH_ONLY_FIELDS: ClassVar[tuple[str, ...]] = ("mu1_deg", "mu2_deg", "water_content", "bed_depth", "fidelity",
                                                  "numerics")
    DRIVE_FIELDS: ClassVar[tuple[str, ...]] = (*WheelScene.DRIVE_FIELDS, "omega_schedule")

    #: if given, the commanded spin after the pause instead of `omega`: knots (t − settle_time, ω) of a
    #: piecewise-linear schedule (terrasph.schedules; a repeated time is a step), ω ≥ 0
    omega_schedule: tuple[tuple[float, float], ...] = ()
    #: the bed the wheel runs on, x from 0 to bed_width (m); its run ends at either end (BedEnds). On
    #: the SPH its container's inner width, default SPH_BED_WIDTH; the RFT terrain is a plane without
    #: ends, so there the run ends at a bed only when one is given (the RFT run is as long as asked)
    bed_width: float | None = shared("bed_width", None,  # type: ignore[assignment]  # None on RFT: no ends
                                     default_text=f"{SPH_BED_WIDTH} on the SPH; on RFT none (a plane without ends)")
    load: float = option(4.9, help="vertical load carried by the chassis", unit="N")
    wheel_density: float = option(1200.0, help="the wheel's material (a printed polymer)", unit="kg/m^3")
    motor_gain: float = option(20.0, help="velocity servo gain", unit="N m s/rad")
    motor_torque: float = option(5.0, help="motor torque limit", unit="N m")
    terrain: str = shared("terrain", "sph")
    rft_table: str = shared("rft_table", "generic")

    def __post_init__(self) -> None:
        if self.bed_width is None and self.terrain != "rft":
            object.__setattr__(self, "bed_width", SPH_BED_WIDTH)
        check_wheel_config(self, positive=("wheel_density", "motor_gain", "motor_torque"), nonnegative=("load",))
        rft.check_terrain(self, self.SPH_ONLY_FIELDS, ("rft_table",))
        object.__setattr__(self, "omega_schedule", check_knots("omega_schedule", self.omega_schedule, lower=0.0))
        far = math.inf if self.bed_width is None else self.bed_width - self.leg_length
        if not self.leg_length < self.start_x < far:
            raise ConfigError(f"parameter 'start_x' = {self.start_x!r} is invalid: allowed between leg_length and "
                              "bed_width − leg_length (the wheel must start clear of the container)")

    def material(self) -> Material:
        """The bed (:meth:`terrasph.scenes.leg_rotation.BeadBed.bed_material`)."""
        return self.bed_material()

    def shape(self) -> bodies.BodyShape:
        """The wheel in its own frame (axle at the origin; leg 0 pointing down)."""
        return wheel_shape(self)

    def footprint(self) -> Footprint:
        """The bed, the wheel and the container (size guard)."""
        return wheel_footprint(self, wheels=1, material=self.material())

    def commanded_omega(self, time: np.ndarray | float) -> np.ndarray:
        """The motor's commanded spin (rad/s) at `time` (s): 0 during the pause, then `omega` or the schedule."""
        after = np.asarray(time, dtype=float) - self.settle_time
        driven = evaluate(self.omega_schedule, after) if self.omega_schedule else np.full(after.shape, self.omega)
        return np.where(after >= 0, driven, 0.0)


def check_wheel_config(config: Any, positive: tuple[str, ...] = (), nonnegative: tuple[str, ...] = ()) -> None:
    """Checks what the leg-wheel and rover configurations share (the wheel, the bed, the times, the
    fidelity) and the extra `positive` / `nonnegative` numbers of each; ConfigError naming the first
    offender."""
    check_tier(config.fidelity)
    config.check_bed_material()
    if config.wheel not in WHEELS:
        raise ConfigError(f"parameter 'wheel' = {config.wheel!r} is invalid: allowed one of {', '.join(WHEELS)}")
    if isinstance(config.legs, bool) or not isinstance(config.legs, int) or not 1 <= config.legs <= 12:
        raise ConfigError(f"parameter 'legs' = {config.legs!r} is invalid: allowed an integer 1–12")
    for name in ("leg_length", "thickness", "width", "spacing", "bed_width", "bed_depth", "t_end",
                 "series_interval", "frame_interval", *positive):
        value = getattr(config, name)
        if name == "bed_width" and value is None:  # the RFT terrain's plane without ends (LegWheel)
            continue
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise ConfigError(f"parameter '{name}' = {value!r} is invalid: allowed a finite number > 0")
    check_settle_time(config.settle_time, config.t_end)
    for name in ("omega", *nonnegative):
        value = getattr(config, name)
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
            raise ConfigError(f"parameter '{name}' = {value!r} is invalid: allowed a finite number >= 0")


def wheel_shape(config: WheelScene) -> bodies.BodyShape:
    """A wheel or leg-wheel in its own frame (axle at the origin; leg 0 pointing down)."""
    args = (config.leg_length, config.thickness, config.width, config.spacing)
    if config.wheel == "wheel":
        return bodies.wheel(*args)
    extra = {"foot_ratio": config.foot_ratio} if config.wheel in ("l-leg", "reversed-l-leg") else {}
    return bodies.leg_wheel(config.wheel, config.legs, *args, **extra)


def wheel_numerics(config: WheelScene) -> Numerics:
    """The numerics of the robot scenes: BED_NUMERICS, then the scene's fidelity tier, then the
    overrides, at the configured spacing."""
    return scene_numerics(config.SCENE, config.fidelity, config.spacing, BED_NUMERICS, config.numerics)


def wheel_footprint(config: WheelScene, wheels: int, material: Material) -> Footprint:
    """The bed, `wheels` wheels and the container of bed_and_wheel (size guard); a bed without a
    width (the RFT terrain's plane) holds no grains and no container."""
    wheel_area = wheels * config.legs * config.leg_length * config.thickness
    if config.bed_width is None:
        return Footprint(config.spacing, wheel_area, 0.0, config.t_end, material, wheel_numerics(config))
    return Footprint(config.spacing, config.bed_width * config.bed_depth + wheel_area,
                     config.bed_width + 2.0 * (config.bed_depth + 2.5 * config.leg_length), config.t_end,
                     material, wheel_numerics(config))


def bed_and_wheel(config: WheelScene) -> tuple[Scene, Numerics, float, bodies.BodyShape]:
    """The bed of chapter 4's glass beads in its container (scene, numerics, surface height) and the
    wheel's shape; a shape the spacing cannot build is refused naming the wheel."""
    numerics = wheel_numerics(config)
    scene = Scene(spacing=config.spacing)
    try:
        shape = wheel_shape(config)
    except ValueError as error:
        raise ConfigError(f"wheel '{config.wheel}': {error}") from None
    surface, _ = scene.add_bed_in_container(config.bed_width, config.bed_depth, wheel_freeboard(config, shape),
                                            layers=wall_layers_needed(numerics.h_factor))
    return scene, numerics, surface, shape


def wheel_freeboard(config: WheelScene, shape: bodies.BodyShape) -> float:
    """Height (m) of the container's walls above the bed: 2.5 leg lengths, or more if grains flung by
    the wheel's farthest point (at the highest commanded spin, its axle's speed neglected) may rise
    higher (:func:`terrasph.scene.flung_height`)."""
    knots = getattr(config, "omega_schedule", ())
    spin = max([config.omega, *(w for _, w in knots)])
    return max(2.5 * config.leg_length, flung_height(spin * float(np.hypot(*shape.position.T).max()), GRAVITY))


def leg_wheel_mjcf(config: LegWheel, shape: bodies.BodyShape, axle: tuple[float, float], gravity: float) -> str:
    """The rig's MJCF: chassis (slide x, slide z, mass load/g) → wheel (hinge y, velocity servo)."""
    inertial = shape_inertial(shape, config.wheel_density, config.width)
    chassis_mass = max(config.load / gravity, 1e-6)  # MuJoCo needs a mass on a moving body
    return f"""<mujoco model="leg-wheel rig">
  <option gravity="0 0 {-gravity!r}" integrator="implicitfast"/>
  <worldbody>
    <body name="chassis" pos="{axle[0]!r} 0 {axle[1]!r}">
      <joint name="x" type="slide" axis="1 0 0"/>
      <joint name="z" type="slide" axis="0 0 1"/>
      <inertial pos="0 0 0" mass="{chassis_mass!r}" diaginertia="1e-4 1e-4 1e-4"/>
      <body name="wheel">
        <joint name="axle" type="hinge" axis="0 1 0"/>
        {inertial.mjcf()}
      </body>
    </body>
  </worldbody>
  <actuator>
    <velocity name="motor" joint="axle" kv="{config.motor_gain!r}" forcerange="{-config.motor_torque!r} {config.motor_torque!r}"/>
  </actuator>
</mujoco>"""


def build_leg_wheel(config: LegWheel) -> Terrain:
    """Bed, container, robot and the terrain coupling them (:func:`terrasph.terrain.interface.couple`),
    ready to run (on the RFT terrain: the robot on a flat surface at z = 0, its wheel touching it)."""
    if config.terrain == "rft":
        try:
            shape = wheel_shape(config)
        except ValueError as error:
            raise ConfigError(f"wheel '{config.wheel}': {error}") from None
        axle = (config.start_x, -shape.lowest_point())
        robot = PlanarRobot(leg_wheel_mjcf(config, shape, axle, GRAVITY), {"wheel": Coupling(shape, config.width)},
                            gravity=GRAVITY)
        return couple(robot, "rft", config.rft_table, surface=0.0)
    scene, numerics, surface, shape = bed_and_wheel(config)
    axle = (config.start_x, surface - shape.lowest_point() + 0.5 * config.spacing)
    robot = PlanarRobot(leg_wheel_mjcf(config, shape, axle, scene.gravity), {"wheel": Coupling(shape, config.width)},
                        gravity=scene.gravity)
    robot.add_to_scene(scene)
    return couple(robot, "sph", simulation=Simulation(scene, config.material(), numerics))


def wheel_bed_ends(config: WheelScene, coupled: RobotStepper, resume: bool) -> BedEnds | None:
    """Where a wheel scene's run ends (:class:`terrasph.robots.run.BedEnds`): the container's inner
    walls on the SPH; on the RFT terrain the bed from 0 to `bed_width` if one is given (None, the
    default there: a plane without ends, no end check)."""
    if isinstance(coupled, CoupledSimulation) and coupled.sim.scene.bed_ends is not None:
        return BedEnds(coupled, coupled.sim.scene.bed_ends, resume=resume)
    return None if config.bed_width is None else BedEnds(coupled, (0.0, config.bed_width), resume=resume)


def run_leg_wheel(config: LegWheel, output: str | os.PathLike[str] | None = None, *, progress: bool = False,
                  plot: bool = True, resume: bool = False, until: float | None = None,
                  cache: SettleCache | bool = True) -> RobotRun:
    """Runs the scene; returns a summary (mean forward speed, slip and sinkage after the pause, final
    and maximum sinkage, motor work, cost of transport, leaks; ``end_of_bed``, the reason, when the
    wheel reached the end of its bed and the run ended there: :func:`wheel_bed_ends`) and the series,
    and with `plot` and an `output` draws the PNG beside it. ``resume=True`` continues the run in
    `output` from its checkpoint, ``until`` replaces the end time
    (:func:`terrasph.robots.run.run_coupled`).

    On the SPH bed a run starts from the cached state at the end of its pause when a run with the same
    bed, robot, numerics and code made it (terrasph.settle_cache; bit for bit the run that settles
    itself), and caches it otherwise: `cache` is the cache (True: the default one,
    :func:`terrasph.settle_cache.default_cache`; False: settle without it)."""
    sand = build_leg_wheel(config)
    coupled = sand.coupling
    bed = wheel_bed_ends(config, coupled, resume)
    # positive motor work since the pause (J) and the axle's x when the spin began (NaN before)
    work = {"motor": 0.0, "start_x": math.nan}

    def motor(run: RobotStepper) -> None:
        data = run.robot.data
        data.ctrl[0] = float(config.commanded_omega(run.time))
        if run.time >= config.settle_time:
            if math.isnan(work["start_x"]):
                work["start_x"] = float(data.qpos[0])
            # positive motor work, power at the step's start × the span the command is held (the
            # motor cannot recover energy)
            work["motor"] += max(float(np.dot(data.actuator_force, data.actuator_velocity)), 0.0) * run.control_span()

    run_config = {"scene": "leg-wheel", "leg_wheel": dataclasses.asdict(config), **coupled.describe()}
    t_end = config.t_end if until is None else until

    def run(terrain: Terrain, end: float, out: str | os.PathLike[str] | None,
            resumed: bool) -> dict[str, dict[str, np.ndarray]]:
        if bed is not None:
            bed.coupled = terrain.coupling  # the end check follows the terrain that runs (a cached pause continues on another)
        return run_coupled(terrain, end, output=out, frame_interval=config.frame_interval,
                           series_interval=config.series_interval, control=motor, progress=progress, memory=work,
                           resume=resumed, end_check=bed, config=run_config)

    if cache is not False and not resume and config.terrain == "sph" and 0 < config.settle_time < t_end:
        series, sand, _ = run_after_pause(cache, "leg-wheel", config, sand, lambda: build_leg_wheel(config),
                                          run, output, run_config, config.settle_time, t_end)
        coupled = sand.coupling
    else:
        series = run(sand, t_end, output, resume)
    wheel = series["robot/wheel"]
    # the driven phase: after the pause, once the servo has brought ω to half the command
    driving = (wheel["time"] > config.settle_time) & (wheel["omega"] >= 0.5 * config.commanded_omega(wheel["time"]))
    speed = float(np.mean(wheel["velocity"][driving, 0])) if driving.any() else math.nan
    spin = float(np.mean(wheel["omega"][driving])) if driving.any() else math.nan
    summary = {"wheel": config.wheel, "legs": config.legs, "terrain": config.terrain, "steps": coupled.step_count,
               "leaked_particles": coupled.run_attributes()["leaked_particles"],
               "final_sinkage": float(wheel["sinkage"][-1]), "max_sinkage": float(np.max(wheel["sinkage"])),
               # the driven phase's mean (its samples are series_interval apart): unlike the final
               # value, which may fall on a stroke's steep flank, it does not hinge on one instant
               "mean_sinkage": float(np.mean(wheel["sinkage"][driving])) if driving.any() else math.nan,
               "mean_forward_speed": speed, "mean_omega": spin, "motor_work": work["motor"],
               "cost_of_transport": _cost_of_transport(work["motor"], coupled,
                                                       float(coupled.robot.data.qpos[0]) - work["start_x"]),
               # Eq. 4.8 of the phase's mean speed and spin (a mean of the samples would be dominated
               # by the spin-up, where Rω is near 0)
               "mean_slip": (float(slip(speed, spin, coupled.robot.coupled[0].shape.radius)) if driving.any()
                             else math.nan),
               "end_of_bed": bed.reason if bed is not None else None}
    if output is not None:
        write_results(output, summary)
    figure = None
    if plot and output is not None:
        figure = str(pathlib.Path(output).with_suffix(".png"))
        plot_leg_wheel(series, figure, label=config.wheel, settle_time=config.settle_time)
    return RobotRun(summary, series, figure)


def _cost_of_transport(work: float, coupled: RobotStepper, distance: float) -> float:
    """Motor work / (robot weight × distance travelled after the pause); inf if it did not move."""
    model = coupled.robot.model
    weight = float(model.body_subtreemass[1]) * -float(model.opt.gravity[2])
    return work / (weight * abs(distance)) if distance != 0 else math.inf


def plot_leg_wheel(series: dict[str, dict[str, np.ndarray]], path: str | os.PathLike[str] | None = None,
                   label: str = "", settle_time: float | None = None) -> Any:
    """Trajectory of the axle, slip and sinkage against time (:func:`terrasph.robots.plots.plot_robot`)."""
    return plot_robot(series, ["wheel"], path, settle_time=settle_time, title=label)
