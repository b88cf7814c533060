"""Scene ``mjcf``: any planar MJCF model on a bed of chapter 4's glass beads, or any MJCF model —
hinges about any axis, free joints — on the 3D resistive-force-theory terrain (docs/mjcf.md) or on
a 3D SPH bed of glass beads (docs/sph3d.md).

The model's floor is replaced by the terrain and the bodies near the floor meet it with their
collision geoms: on the SPH bed as planar terrain bodies (:mod:`terrasph.mjcf.terrain_robot`),
on the RFT terrain (``terrain = "rft"``) as 3D RFT surface elements
(:mod:`terrasph.terrain.rft3d_coupling`), on the 3D SPH bed (``terrain = "sph3d"``) as particles
filling them (:mod:`terrasph.terrain.sph3d_coupling`, the bed of :func:`terrasph.terrain.attach`).
Every terrain is a :class:`terrasph.terrain.Terrain` stepped by the one run loop
(:func:`terrasph.robots.run.run_coupled`). Its actuators follow the ``ctrl`` specs
(:mod:`terrasph.robots.control`) or, from Python, any controller ``(time, model, data) -> ctrl``.
:func:`rigid_floor_run` runs the same model and controller on MuJoCo's own floor, for comparison.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import pathlib
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

import mujoco
import numpy as np
from matplotlib.figure import Figure

from terrasph.cli_common import positive_float
from terrasph.config import ConfigError, check_settle_time
from terrasph.fidelity import check_tier, fidelity_option
from terrasph.io import write_results
from terrasph.mjcf.geoms import is_collision_geom
from terrasph.mjcf.model import PlanarRobot, body_name, load_model, mujoco_warnings
from terrasph.mjcf.terrain_robot import COUPLE_BELOW, world_support
from terrasph.options import check_unused_fields, option, shared
from terrasph.robots.control import FORMS, Controller, parse_spec, spec_controller
from terrasph.robots.metrics import slip
from terrasph.robots.plots import body_legend, plot_robot_3d
from terrasph.robots.run import BedEnds, RobotLoads3D, RobotRun, run_coupled, wheel_radii
from terrasph.scenes.leg_rotation import BeadBed
from terrasph.sph3d import BED_MARGIN, BED_SPACING
from terrasph.terrain import rft
from terrasph.terrain.interface import Terrain, attach, couple
from terrasph.terrain.rft3d_coupling import (
    RFT3D_TIME_STEP,
    RFT3DCoupling,
    Robot3D,
    rft_robot,
)
from terrasph.terrain.sph_coupling import CoupledSimulation, planar_sph_bed

__all__ = ["MjcfScene", "build_mjcf", "plot_mjcf", "rigid_floor_run", "run_mjcf"]

#: the planar SPH bed's particle spacing (m) unless given
PLANAR_BED_SPACING = 0.01


def _body_width(text: str) -> tuple[str, float]:
    """argparse type of ``--width``: ``NAME=METRES`` with a finite width > 0."""
    name, sep, value = text.partition("=")
    if not sep or not name:
        raise argparse.ArgumentTypeError(f"expected NAME=METRES, got {text!r}")
    try:
        return name, positive_float(value)
    except argparse.ArgumentTypeError as error:
        raise argparse.ArgumentTypeError(f"width of {name}: {error}") from None


@dataclass(frozen=True)
class MjcfScene(BeadBed):
    """Configuration of an MJCF model on the bed (a planar model), on the 3D RFT terrain or on a 3D
    SPH bed (any model). Lengths in m, times in s."""

    #: fields saved under another name by earlier versions (run files, sweep SPECs): old → new
    RENAMED_FIELDS: ClassVar[Mapping[str, str]] = {"duration": "t_end"}
    #: the settings of the SPH bed only, refused on the RFT terrain unless at their defaults
    SPH_ONLY_FIELDS: ClassVar[tuple[str, ...]] = ("bed_width", "bed_depth", "spacing", "start_x", "widths",
                                                  "freeboard", "fidelity", "numerics", "mu1_deg", "mu2_deg",
                                                  "water_content")
    #: the settings of the RFT terrain only, refused on the SPH bed unless at their defaults
    RFT_ONLY_FIELDS: ClassVar[tuple[str, ...]] = ("rft_table", "element_length")
    #: the settings of the planar SPH bed only and of the 3D one only, each refused on the other unless at its default
    PLANAR_ONLY_FIELDS: ClassVar[tuple[str, ...]] = ("bed_width", "start_x", "widths", "mu1_deg", "mu2_deg",
                                                     "water_content")
    SPH3D_ONLY_FIELDS: ClassVar[tuple[str, ...]] = ("bed_margin", "bed_size")

    model: str = option("", positional=True, cli="ROBOT.xml",
                        help="the MJCF file (not changed; its floor is switched off in the loaded copy)")
    bed_width: float = shared("bed_width", 1.0)
    bed_depth: float = shared("bed_depth", 0.1)
    spacing: float | None = option(None, help="particle spacing dx; every coupled body must be >= 3 dx thick", unit="m",
                                   default_text=f"{PLANAR_BED_SPACING:g} (sph), {BED_SPACING:g} (sph3d)")
    bed_margin: float = option(BED_MARGIN, help="terrain sph3d: the bed's reach beyond the coupled bodies' geoms on "
                                                "each side, in x and y", unit="m")
    bed_size: tuple[float, float] | None = option(None, help="terrain sph3d: the bed's length (x) and breadth (y), "
                                                             "centred under the coupled bodies, in place of "
                                                             "--bed-margin", unit="m",
                                                  default_text="the coupled geoms' extent and --bed-margin")
    start_x: float | None = option(None, help="x of the robot's centre of mass at start, bed frame", unit="m",
                                   default_text="mid-bed")
    settle_time: float = shared("settle_time", 0.5, help="pause before the ctrl schedules start (hold acts throughout)")
    t_end: float = shared("t_end", 2.0)
    ctrl: tuple[str, ...] = option((), cli="ctrl", repeat=True, unit="ACTUATOR=FORM", default_text="0",
                                   help="an actuator's input (by name, joint or #index); FORM: " + " | ".join(FORMS))
    bodies: tuple[str, ...] = option((), cli="body", repeat=True, unit="NAME",
                                     default_text="every body with a collision geom below --couple-below",
                                     help="a body that meets the terrain")
    couple_below: float = option(COUPLE_BELOW, help="height above the floor that selects the coupled bodies", unit="m")
    widths: dict[str, float] = option(cli="body-width", repeat=True, unit="NAME=METRES", parse=_body_width,
                                      default_factory=dict, default_text="its geoms' extent across the plane",
                                      help="a coupled body's out-of-plane width")
    freeboard: float = option(0.2, help="container wall height above the bed's surface", unit="m")
    series_interval: float = option(0.01, help="time between series samples", unit="s")
    frame_interval: float = shared("frame_interval", 0.05)
    fidelity: str = fidelity_option("mjcf")
    numerics: dict[str, Any] = field(default_factory=dict)  #: overrides of the tier's numerics
    terrain: str = shared("terrain", "sph", choices=("sph", "rft", "sph3d"),
                          help="the planar SPH bed, the 3D resistive-force-theory terrain (rft, docs/rft.md) or a 3D "
                               "SPH bed (sph3d, docs/sph3d.md)")
    rft_table: str = shared("rft_table", "generic")
    element_length: float | None = option(None, help="terrain rft: the size of the 3D RFT surface elements",
                                          unit="m", default_text="0.1 of each coupled body's largest geom's "
                                                                 "bounding radius")

    def __post_init__(self) -> None:
        check_tier(self.fidelity)
        self.check_bed_material()
        if not pathlib.Path(str(self.model)).is_file():
            raise ConfigError(f"parameter 'model' = {self.model!r} is invalid: no such file (allowed the path of an "
                              "MJCF file)")
        for name in ("bed_width", "bed_depth", "spacing", "t_end", "couple_below", "freeboard",
                     "series_interval", "frame_interval", "bed_margin"):
            value = getattr(self, name)
            if name == "spacing" and value is None:
                continue
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ConfigError(f"parameter '{name}' = {value!r} is invalid: allowed a finite number > 0")
        check_settle_time(self.settle_time, self.t_end)
        if self.bed_size is not None:
            size = self.bed_size
            if (isinstance(size, (str, bytes)) or not hasattr(size, "__len__") or len(size) != 2
                    or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > 0
                               for v in size)):
                raise ConfigError(f"parameter 'bed_size' = {size!r} is invalid: allowed None or two finite "
                                  "numbers > 0 (m), the length and breadth")
            object.__setattr__(self, "bed_size", (float(size[0]), float(size[1])))
        if self.start_x is not None and not 0 < self.start_x < self.bed_width:
            raise ConfigError(f"parameter 'start_x' = {self.start_x!r} is invalid: allowed in (0, bed_width)")
        object.__setattr__(self, "ctrl", tuple(str(c) for c in self.ctrl))
        object.__setattr__(self, "bodies", tuple(str(b) for b in self.bodies))
        for spec in self.ctrl:
            parse_spec(spec)  # the forms now; the actuators' names once the model is loaded
        for body, width in dict(self.widths).items():
            if not (isinstance(width, (int, float)) and math.isfinite(width) and width > 0):
                raise ConfigError(f"parameter 'widths' of body '{body}' = {width!r} is invalid: allowed a finite "
                                  "number > 0 (m)")
        length = self.element_length
        if length is not None and (isinstance(length, bool) or not isinstance(length, (int, float))
                                   or not (math.isfinite(length) and length > 0)):
            raise ConfigError(f"parameter 'element_length' = {self.element_length!r} is invalid: allowed a finite "
                              "number > 0 (m)")
        rft.check_terrain(self, self.SPH_ONLY_FIELDS + self.SPH3D_ONLY_FIELDS, self.RFT_ONLY_FIELDS)
        if self.terrain == "sph3d":
            check_unused_fields(self, self.PLANAR_ONLY_FIELDS, "it sets the planar bed; the 3D bed is glass beads "
                                                               "reaching bed_margin beyond the coupled geoms")
        elif self.terrain == "sph":
            check_unused_fields(self, self.SPH3D_ONLY_FIELDS, "it sets the 3D bed: add terrain 'sph3d'")

    @property
    def bed_spacing(self) -> float:
        """The particle spacing (m): `spacing`, or the terrain's default."""
        if self.spacing is not None:
            return self.spacing
        return BED_SPACING if self.terrain == "sph3d" else PLANAR_BED_SPACING


def build_mjcf(config: MjcfScene) -> Terrain:
    """The model on its terrain, coupled (:func:`terrasph.terrain.interface.couple`); every check
    done before any step. On the SPH: the bed, its container and the model standing on it (a planar
    model only). On RFT: the model in its own frame on the 3D RFT terrain, whose flat surface is at
    its floor's height; the controller is called every step (a ``hold`` spec is a servo), as on the
    SPH. On the 3D SPH bed (``sph3d``): the model in its own frame, put on the bed by
    :func:`terrasph.terrain.attach` (the same checks, bed and coupling as from Python)."""
    if config.terrain == "sph3d":
        model = load_model(config.model)
        data = mujoco.MjData(model)
        with mujoco_warnings():
            return attach(model, data, "sph3d", bodies=config.bodies or None, couple_below=config.couple_below,
                          spacing=config.bed_spacing, bed_size=config.bed_size, bed_margin=config.bed_margin,
                          bed_depth=config.bed_depth,
                          freeboard=config.freeboard, fidelity=config.fidelity, numerics=dict(config.numerics) or None)
    if config.terrain == "rft":
        robot = rft_robot(config.model, bodies=config.bodies, couple_below=config.couple_below,
                          element_length=config.element_length)
        return couple(robot, "rft3d", config.rft_table, control_interval=RFT3D_TIME_STEP)
    robot, simulation = planar_sph_bed(config.model, spacing=config.bed_spacing, bed_width=config.bed_width,
                                       bed_depth=config.bed_depth, freeboard=config.freeboard, fidelity=config.fidelity,
                                       numerics=config.numerics, start_x=config.start_x, bodies=config.bodies,
                                       couple_below=config.couple_below, widths=config.widths,
                                       material=config.bed_material())
    return couple(robot, "sph", simulation=simulation)


def run_mjcf(config: MjcfScene, output: str | os.PathLike[str] | None = None, *, progress: bool = False,
             plot: bool = True, resume: bool = False, until: float | None = None,
             controller: Controller | None = None) -> RobotRun:
    """Runs the scene; `controller` (time, model, data) -> ctrl replaces the ``ctrl`` specs. Returns
    a summary (:func:`_summary`: travel of the centre of mass after the pause, each coupled body's
    sinkage, the terrain's lift over the robot's weight, in 3D (RFT, sph3d) the final pose and each
    body's load, on RFT each wheel's slip, and ``through_the_bed``: the uncoupled bodies that reached below the
    terrain's surface, with the first time, each also warned of; on the SPH bed ``end_of_bed``, the
    reason, when a coupled body reached an end of the bed and the run ended there:
    :class:`terrasph.robots.run.BedEnds`) and the series; with `plot` and an
    `output`, the PNG beside it. ``resume`` and ``until`` as in
    :func:`terrasph.scenes.leg_wheel.run_leg_wheel`."""
    sand = build_mjcf(config)
    coupled = sand.coupling
    model, data = sand.model, sand.data
    drive = controller or spec_controller(config.ctrl, model, data, config.settle_time)
    memory: dict[str, Any] = {}  # the run's checkpointed values: BedCrossings' record
    three_d = sand.kind in ("rft3d", "sph3d")  # series and summary of a 3D model
    surface = coupled.robot.surface if three_d else float(coupled.sim.scene.surface_level)
    crossings = BedCrossings(coupled.robot, surface, memory)
    # the SPH bed ends at its container's walls; the 3D RFT terrain is a plane without ends
    bed = None
    if isinstance(coupled, CoupledSimulation) and coupled.sim.scene.bed_ends is not None:
        bed = BedEnds(coupled, coupled.sim.scene.bed_ends, resume=resume)

    def control(run: Any) -> None:
        crossings.check(run.time)
        data.ctrl[:] = drive(run.time, model, data)

    described = coupled.describe() if three_d else coupled.sim.describe()
    series = run_coupled(sand, config.t_end if until is None else until, output=output,
                         frame_interval=config.frame_interval, series_interval=config.series_interval,
                         control=control, progress=progress, resume=resume, memory=memory,
                         recorder=RobotLoads3D(coupled) if three_d else None, end_check=bed,
                         config={"scene": "mjcf", "mjcf": dataclasses.asdict(config), **described})
    summary = {**_summary(config, coupled, series), "through_the_bed": dict(memory["through_the_bed"]),
               "end_of_bed": bed.reason if bed else None}
    if output is not None:  # /results holds plain values: the bodies that went through, by name
        write_results(output, {**summary, "through_the_bed": json.dumps(summary["through_the_bed"])})
    figure = None
    if plot and output is not None:
        figure = str(pathlib.Path(output).with_suffix(".png"))
        draw = plot_robot_3d if three_d else plot_mjcf
        draw(series, [b.name for b in coupled.robot.coupled], figure, settle_time=config.settle_time,
             title=pathlib.Path(config.model).stem, weight=_weight(model))
    return RobotRun(summary, series, figure)


def _weight(model: mujoco.MjModel) -> float:
    """The whole robot's weight (N) under the model's gravity (on the SPH, the scene's: PlanarRobot checks)."""
    return float(model.body_subtreemass[0]) * -float(model.opt.gravity[2])


def _summary(config: MjcfScene, coupled: Any,
             series: dict[str, dict[str, np.ndarray]]) -> dict[str, Any]:
    """The run's summary values from its series: the terrain's vertical load on the coupled bodies
    over the robot's weight in the last fifth of the run; with actuators, the distance along x and
    mean speed of the centre of mass after the pause (in 3D also its distance along y); each
    coupled body's final sinkage and mean sinkage after the pause; leaks (none on RFT). In 3D (RFT
    and sph3d) also the centre of mass's final position (x, y, z) m, the root body's final heading,
    pitch and roll (degrees, z–y–x angles of its frame), each coupled body's load (force, N, world
    axes) in the last fifth and, on RFT, each wheel's slip after the pause, Eq. 4.8 of its mean
    forward speed and mean spin (:class:`terrasph.robots.run.RobotLoads3D`)."""
    on_rft = isinstance(coupled, RFT3DCoupling)
    three_d = not isinstance(coupled, CoupledSimulation)
    model, data = coupled.robot.model, coupled.robot.data
    up = 2 if three_d else 1  # the vertical component of the series' forces and centre of mass
    names = [b.name for b in coupled.robot.coupled]
    time = series[f"robot/{names[0]}"]["time"]
    last = time >= time[-1] - 0.2 * (time[-1] - time[0])
    lift = sum(series[f"robot/{n}"]["force"][:, up] for n in names)
    wheels = wheel_radii(coupled.robot) if on_rft else {}
    radii = {coupled.robot.coupled[k].name: radius for k, (_, radius) in wheels.items()}
    summary: dict[str, Any] = {"model": pathlib.Path(config.model).name, "terrain": config.terrain,
                               "coupled_bodies": names, "steps": coupled.step_count,
                               "leaked_particles": coupled.run_attributes()["leaked_particles"],
                               "lift_over_weight": float(np.mean(lift[last]) / _weight(model))}
    actuators = series.get("robot/actuators")
    if actuators is not None:
        driven = actuators["time"] >= config.settle_time
        com = actuators["com"][driven]
        span = float(actuators["time"][driven][-1] - actuators["time"][driven][0]) if driven.sum() > 1 else 0.0
        summary["distance"] = float(com[-1, 0] - com[0, 0]) if len(com) else math.nan
        summary["mean_speed"] = summary["distance"] / span if span > 0 else math.nan
        if three_d:
            summary["distance_y"] = float(com[-1, 1] - com[0, 1]) if len(com) else math.nan
    for n in names:
        body = series[f"robot/{n}"]
        after = body["time"] >= config.settle_time
        summary[f"{n}_final_sinkage"] = float(body["sinkage"][-1])
        summary[f"{n}_mean_sinkage"] = float(np.mean(body["sinkage"][after]))
        if three_d:
            summary[f"{n}_mean_force"] = np.mean(body["force"][last], axis=0).tolist()
            if n in radii and after.any():
                speed, spin = np.mean(body["forward_speed"][after]), np.mean(body["spin"][after])
                summary[f"{n}_mean_slip"] = float(slip(speed, spin, radii[n]))
    if three_d:
        mujoco.mj_kinematics(model, data)  # the end state's derived quantities
        mujoco.mj_comPos(model, data)
        rotation = data.xmat[1].reshape(3, 3)
        summary.update({"final_com": data.subtree_com[0].tolist(),
                        "root_body": body_name(model, 1),
                        "final_heading_deg": math.degrees(math.atan2(rotation[1, 0], rotation[0, 0])),
                        "final_pitch_deg": math.degrees(math.asin(max(-1.0, min(1.0, -rotation[2, 0])))),
                        "final_roll_deg": math.degrees(math.atan2(rotation[2, 1], rotation[2, 2]))})
    return summary


def rigid_floor_run(model_path: str | os.PathLike[str], controller: Controller | None, duration: float,
                    settle_time: float = 0.0, timestep: float | None = None,
                    ctrl: tuple[str, ...] = ()) -> tuple[dict[str, float], np.ndarray]:
    """The model on MuJoCo's own floor (the file as it is) with the same controller (or ``ctrl``
    specs) for `duration` s at `timestep` (default the model's): the distance and mean speed of
    its centre of mass after `settle_time`, for comparison with the bed, and its path (rows of
    time, x, z in the model's frame, each step)."""
    check_settle_time(settle_time, duration)
    model = load_model(model_path)
    if timestep is not None:
        model.opt.timestep = timestep
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    drive = controller or spec_controller(ctrl, model, data, settle_time)
    path = [(0.0, *data.subtree_com[0][[0, 2]])]
    with mujoco_warnings():
        while data.time < duration * (1 - 1e-12):
            data.ctrl[:] = drive(data.time, model, data)
            mujoco.mj_step(model, data)
            mujoco.mj_kinematics(model, data)  # mj_step leaves the derived quantities at the step's start
            mujoco.mj_comPos(model, data)
            path.append((float(data.time), *data.subtree_com[0][[0, 2]]))
    trajectory = np.array(path)
    driven = trajectory[trajectory[:, 0] >= settle_time]
    distance = float(driven[-1, 1] - driven[0, 1])
    return {"distance": distance, "mean_speed": distance / float(driven[-1, 0] - driven[0, 0])}, trajectory


def plot_mjcf(series: dict[str, dict[str, np.ndarray]], bodies: list[str], path: str | os.PathLike[str] | None = None,
              *, settle_time: float | None = None, title: str = "", weight: float | None = None) -> Figure:
    """Three panels against time: the robot's centre of mass (x and z), each coupled body's sinkage,
    and the total vertical granular force on the coupled bodies (N), with the robot's `weight` (N)
    dashed if given."""
    figure = Figure(figsize=(6.4, 7.5), layout="constrained")
    com_ax, sink_ax, force_ax = figure.subplots(3, 1, sharex=True)
    actuators = series.get("robot/actuators")
    if actuators is not None:
        com_ax.plot(actuators["time"], actuators["com"][:, 0] * 100, label="x")
        com_ax.plot(actuators["time"], actuators["com"][:, 1] * 100, label="z")
        com_ax.legend()
    total = 0.0
    for name in bodies:
        body = series[f"robot/{name}"]
        sink_ax.plot(body["time"], body["sinkage"] * 100, label=name)
        total = total + body["force"][:, 1]
    force_ax.plot(series[f"robot/{bodies[0]}"]["time"], total, label="grains on the coupled bodies")
    if weight is not None:
        force_ax.axhline(weight, color="k", linestyle="--", linewidth=1, label="robot's weight")
        force_ax.legend(fontsize="small")
    com_ax.set(ylabel="centre of mass (cm)", title=title or "MJCF model on the bed")
    sink_ax.set(ylabel="sinkage (cm)")
    force_ax.set(xlabel="t (s)", ylabel="vertical granular force (N)")
    body_legend(figure, [sink_ax], bodies)
    if settle_time is not None:
        for ax in (com_ax, sink_ax, force_ax):
            ax.axvline(settle_time, color="0.5", linestyle=":", linewidth=1)
    if path is not None:
        figure.savefig(path, dpi=120)
    return figure


class BedCrossings:
    """Watches the bodies that are not coupled: with the floor off nothing holds them up, so one that
    reaches below the bed's surface passes through the grains unseen. The first time a body's
    collision geom does, :meth:`check` warns once naming it and records the time under
    ``memory["through_the_bed"]`` (plain data: a run's checkpointed memory, read at each check, so a
    resumed run's restored memory counts)."""

    def __init__(self, robot: PlanarRobot | Robot3D, surface: float, memory: dict[str, dict[str, float]]) -> None:
        model = robot.model
        coupled = {b.body_id for b in robot.coupled}
        self.robot, self.surface, self.memory = robot, surface, memory
        memory.setdefault("through_the_bed", {})
        self.geoms = np.array([g for g in range(model.ngeom) if model.geom_bodyid[g] > 0
                               and model.geom_bodyid[g] not in coupled and is_collision_geom(model, g)], dtype=int)

    def check(self, time: float) -> None:
        """Looks at the pose in the robot's data (cheaply: a geom whose bounding sphere clears the
        surface is not looked at further)."""
        model, data = self.robot.model, self.robot.data
        near = self.geoms[data.geom_xpos[self.geoms, 2] - model.geom_rbound[self.geoms] < self.surface]
        for g in near:
            name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, int(model.geom_bodyid[g])) or f"#{g}"
            seen = self.memory["through_the_bed"]
            if name not in seen and world_support(model, data, int(g), (0.0, 0.0, -1.0))[2] < self.surface:
                seen[name] = time
                warnings.warn(f"body '{name}' is not coupled and reached below the bed's surface at t = {time:.4g} s: "
                              "it passes through the grains (couple it: bodies or couple_below)", RuntimeWarning,
                              stacklevel=2)
