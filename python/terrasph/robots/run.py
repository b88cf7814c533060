"""A coupled robot's run: the run loop (terrasph.run_loop) stepping a :class:`terrasph.terrain.Terrain`
(:class:`ControlledRun`: the terrain's coupling with the scene's control) and the robot's series as a
recorder (:class:`RobotLoads`).

Layout of the file (terrasph.io.RunWriter, docs/hdf5_schema.md): frames, ``/static``,
``/series/diagnostics`` and ``/run`` as for any run, the frames with ``wall_position`` added (on the
RFT terrain, which has no grains, the frames hold the coupled bodies only);
``/series/robot/<body>`` per coupled body (time,
reference (x, z) m, angle rad and omega rad/s clockwise, velocity (v_x, v_z) m/s, force (F_x, F_z)
N and torque N·m clockwise about the body origin, both for the body's real width and averaged over
the sampling interval, lowest_z m, surface m (the bed's undisturbed free surface at that time,
:func:`terrasph.terrain.sph_coupling.undisturbed_surface`), sinkage m = surface − lowest_z, slip (Eq. 4.8
with the shape's radius)); ``/series/robot/actuators`` (time, qpos, qvel, ctrl, the whole robot's centre of mass
com (x, z) m, actuator force — a motor's torque in N·m for a hinge — and the total actuator power in W).
"""

from __future__ import annotations

import math
import os
import pathlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from terrasph.config import ConfigError
from terrasph.io import defined_values
from terrasph.mjcf.model import CoupledBody, mujoco_warnings
from terrasph.robots.metrics import sinkage, slip
from terrasph.run_loop import END_OF_BED, Recorder
from terrasph.terrain.interface import Terrain
from terrasph.terrain.rft3d_coupling import RFT3DCoupling, Robot3D
from terrasph.terrain.sph3d_coupling import Coupled3D
from terrasph.terrain.sph_coupling import SURFACE_MARGIN, CoupledSimulation, RobotStepper

__all__ = ["BED_END_MARGIN", "WHEEL_BALANCE", "BedEnds", "ControlledRun", "RobotLoads", "RobotLoads3D", "RobotRun",
           "body_row", "run_coupled", "wheel_radii"]

#: a coupled body that comes this close (m) to an end of its bed has reached it: the grains between
#: it and the end wall are those it disturbs (SURFACE_MARGIN), so from there on the wall is part of
#: what it measures
BED_END_MARGIN = SURFACE_MARGIN


def body_row(coupled: RobotStepper, body: CoupledBody, surface: float) -> dict[str, Any]:
    """One sample of a coupled body's series (granular loads averaged since the last reset;
    sinkage below the free surface at `surface`, m)."""
    name = body.name
    state = coupled.body_sample(name)
    velocity, omega = coupled.robot.velocity(body)
    return {"time": coupled.time, "reference": coupled.robot.reference(body), "angle": coupled.angle(name),
            "velocity": velocity, "omega": omega, "force": state["force"], "torque": state["torque"],
            "lowest_z": state["lowest_z"], "surface": surface, "sinkage": float(sinkage(state["lowest_z"], surface)),
            "slip": float(slip(velocity[0], omega, body.shape.radius))}


def _actuator_row(coupled: RobotStepper) -> dict[str, Any]:
    data = coupled.robot.data
    return {"time": coupled.time, "qpos": data.qpos.copy(), "qvel": data.qvel.copy(), "ctrl": data.ctrl.copy(),
            "com": data.subtree_com[0][[0, 2]].copy(), "actuator_force": data.actuator_force.copy(),
            "power": float(np.dot(data.actuator_force, data.actuator_velocity))}


class BedEnds:
    """The run loop's `end_check` of a robot on a bed between x = `ends` (m): the run ends (status
    :data:`END_OF_BED`, its reason recorded) on the first frame at which a coupled body's x extent
    at its pose (its shape's particles) comes within `margin` of either end, so every series and
    summary value covers the robot's time on the bed only. A robot that starts that close is refused
    before any step (unless `resume`: the run then ends on its first frame, as before). `reason`
    holds the reason once the check has ended a run (None until then)."""

    def __init__(self, coupled: RobotStepper, ends: tuple[float, float], margin: float = BED_END_MARGIN,
                 resume: bool = False) -> None:
        self.coupled, self.ends, self.margin = coupled, (float(ends[0]), float(ends[1])), float(margin)
        self.reason: str | None = None
        if not resume:
            for name, (low, high) in self.extents().items():
                if low < self.ends[0] + margin or high > self.ends[1] - margin:
                    raise ConfigError(f"coupled body '{name}' starts at x in [{low:.4g}, {high:.4g}] m, within "
                                      f"{margin:g} m of the bed's ends x = {self.ends[0]:.4g} and {self.ends[1]:.4g} m;"
                                      " place the robot farther from them (start_x) or widen the bed (bed_width)")

    def extents(self) -> dict[str, tuple[float, float]]:
        """Each coupled body's x extent (m) at its pose now."""
        coupled, extents = self.coupled, {}
        for body in coupled.robot.coupled:
            points, _ = body.shape.transformed(coupled.angle(body.name), tuple(coupled.robot.reference(body)))
            extents[body.name] = (float(points[:, 0].min()), float(points[:, 0].max()))
        return extents

    def __call__(self) -> tuple[str, str] | None:
        """(END_OF_BED, reason) once a coupled body has reached an end of the bed, else None."""
        for name, (low, high) in self.extents().items():
            for reached, end, side in ((high > self.ends[1] - self.margin, self.ends[1], "far"),
                                       (low < self.ends[0] + self.margin, self.ends[0], "near")):
                if reached:
                    self.reason = (f"coupled body '{name}' reached the {side} end of the bed (x = {end:.4g} m, "
                                   f"margin {self.margin:g} m) at t = {self.coupled.time:.4g} s: the run ends "
                                   "there and its values cover the time on the bed")
                    return END_OF_BED, self.reason
        return None


class RobotLoads:
    """Recorder of the run loop: each coupled body's row (:func:`body_row`) as ``robot/<body>`` and,
    for a robot with actuators, ``robot/actuators``; the bodies' load means restarted after each sample."""

    def __init__(self, coupled: RobotStepper) -> None:
        self.coupled = coupled
        self.groups = [(f"robot/{body.name}", body) for body in coupled.robot.coupled]  #: (group, body) of each series

    def rows(self) -> dict[str, dict[str, Any]]:
        coupled = self.coupled
        surface = coupled.surface()
        rows = {group: body_row(coupled, body, surface) for group, body in self.groups}
        if coupled.robot.model.nu:  # a robot without actuators has no such series (HDF5 has no 0-wide columns)
            rows["robot/actuators"] = _actuator_row(coupled)
        coupled.reset_body_means()
        return rows


class ControlledRun:
    """A terrain as the run loop's stepper (terrasph.run_loop.Stepper): :meth:`Terrain.advance` with the
    caller's `control` (called with the terrain's coupling, before each step or control interval),
    the rest read from its coupling; the caller's running values `memory` (plain data) are kept in the
    checkpoints with MuJoCo's state."""

    def __init__(self, terrain: Terrain, control: Callable[[Any], None] | None, memory: dict[str, Any]) -> None:
        self.terrain = terrain
        self.coupled = terrain.coupling
        self.control = control
        self.memory = memory

    @property
    def time(self) -> float:
        return self.coupled.time

    @property
    def step_count(self) -> int:
        return self.coupled.step_count

    def advance(self, t_end: float, max_steps: int) -> int:
        return self.terrain.advance(t_end, max_steps, self.control)

    def checkpoint(self, path: str | os.PathLike[str], progress: dict[str, Any] | None = None) -> pathlib.Path:
        return self.coupled.checkpoint(path, {**(progress or {}), "memory": self.memory})

    def restore(self, path: str | os.PathLike[str]) -> dict[str, Any]:
        progress = self.coupled.restore(path)
        self.memory.update(progress.pop("memory", {}))
        return progress

    def frame_fields(self) -> dict[str, np.ndarray]:
        return self.coupled.frame_fields()

    def static_arrays(self) -> dict[str, np.ndarray]:
        return self.coupled.static_arrays()

    def diagnostics(self) -> dict[str, float]:
        return self.coupled.diagnostics()

    def run_attributes(self) -> dict[str, int]:
        return self.coupled.run_attributes()


@dataclass
class RobotRun:
    """What a robot scene's run gives back: its summary values, the robot series by group name,
    and the path of its figure (None if none was drawn)."""

    values: dict[str, Any]
    series: dict[str, dict[str, np.ndarray]]
    plot: str | None = None

    def summary(self) -> dict[str, Any]:
        """The summary values (JSON-ready: an undefined value, NaN, is None)."""
        return defined_values(self.values)


def run_coupled(terrain: Terrain, t_end: float, *, output: str | os.PathLike[str] | None = None,
                frame_interval: float = 0.05, series_interval: float = 0.01,
                config: dict[str, Any] | None = None, control: Callable[[Any], None] | None = None,
                progress: bool = False, memory: dict[str, Any] | None = None,
                checkpoint_every: float | None = 600.0, resume: bool = False,
                recorder: Recorder | None = None,
                end_check: Callable[[], tuple[str, str] | None] | None = None) -> dict[str, dict[str, np.ndarray]]:
    """Runs `terrain` (a :class:`terrasph.terrain.Terrain` of :func:`terrasph.terrain.interface.couple`,
    coupling a robot with the SPH, planar RFT or, with its `recorder`, 3D RFT) to `t_end` (s),
    stepping it by :meth:`~terrasph.terrain.Terrain.advance`; writes frames (the grains and
    bodies; on the RFT terrain the bodies only) every `frame_interval` and robot samples every
    `series_interval` (s) to `output` (HDF5) if given. `control`, if given, is called before each
    step (to set MuJoCo's ``data.ctrl`` from the time, say); its own running values belong in
    `memory` (plain data), which is checkpointed with the run. Returns the run's series by group
    name (``robot/…``, ``diagnostics``, ``walls/…``; the whole run's, when resumed). After
    ``terrain.coupling.sim.track_wall_loads(...)`` (on the SPH) the load of
    the grains on each fixed wall (:meth:`terrasph.Simulation.wall_loads`) is sampled too, as
    ``walls/<name>`` (kept in checkpoints: track them again, about the same point, before resuming).
    `recorder` records the robot's series (default :class:`RobotLoads`, the planar robot's; the 3D
    RFT terrain's is :class:`RobotLoads3D`). `end_check`, asked on each
    frame (a :class:`BedEnds`, say), ends the run early when it returns (status, reason).

    As :meth:`terrasph.Simulation.run` (the same loop, terrasph.run_loop.RunLoop): with an `output`,
    the SPH State, MuJoCo's state (qpos, qvel, act, ctrl, warm start, time), the coupling's memory
    and `memory` go to :func:`terrasph.run_loop.checkpoint_path` every `checkpoint_every` s of wall
    time (None: never), when the run ends and when SIGINT or SIGTERM stops it at the next step
    boundary (the file is closed and ``KeyboardInterrupt`` raised). ``resume=True`` continues an
    interrupted or finished run from that checkpoint into the same file (rows and frames written
    after it are dropped), bitwise the run that never stopped.
    """
    from terrasph.run_loop import RunLoop, check_run_options
    from terrasph.simulation import WallLoads, versions

    # the loop checks them too, under its own names: these are the caller's
    check_run_options({"frame_interval": frame_interval, "series_interval": series_interval}, checkpoint_every,
                      resume, output)
    coupled = terrain.coupling
    walls = WallLoads(coupled.sim) if isinstance(coupled, CoupledSimulation) else None
    if not resume:  # the first sample's means start now
        coupled.reset_body_means()
        if walls:
            coupled.sim.reset_wall_load_means()
    loop = RunLoop(ControlledRun(terrain, control, {} if memory is None else memory), output, frame_interval,
                   series_interval, [recorder or RobotLoads(coupled), *([walls] if walls and walls.groups else [])],
                   config or coupled.describe(), {**versions(), "mujoco": mujoco.__version__}, checkpoint_every,
                   progress, end_check=end_check)
    with mujoco_warnings():  # MuJoCo's warnings as Python's, not into MUJOCO_LOG.TXT in the working directory
        return loop.run(t_end, resume).series


#: a body's centre of mass within this fraction of its rolling radius from its hinge's axis makes it a wheel
WHEEL_BALANCE = 0.01


def wheel_radii(robot: Robot3D) -> dict[int, tuple[int, float]]:
    """The coupled bodies that are wheels — on one hinge joint of their own, with their centre of mass
    on its axis (within :data:`WHEEL_BALANCE` of R: a wheel or a leg-wheel, not a leg swinging about
    its hip) — by their index in ``robot.coupled``: the hinge's joint id and the rolling radius R (m),
    the largest distance of the body's element centres from the axis."""
    model, wheels = robot.model, {}
    for k, body in enumerate(robot.coupled):
        b = body.body_id
        joint = int(model.body_jntadr[b])
        if model.body_jntnum[b] != 1 or model.jnt_type[joint] != mujoco.mjtJoint.mjJNT_HINGE:
            continue
        axis = model.jnt_axis[joint] / np.linalg.norm(model.jnt_axis[joint])  # all in the body's frame

        def off_axis(points: np.ndarray) -> np.ndarray:  # uses this iteration's joint and axis; called within it
            arm = np.atleast_2d(points) - model.jnt_pos[joint]  # noqa: B023
            return np.linalg.norm(arm - np.outer(arm @ axis, axis), axis=1)  # noqa: B023

        radius = float(off_axis(body.elements.centre).max())
        if off_axis(model.body_ipos[b])[0] <= WHEEL_BALANCE * radius:
            wheels[k] = (joint, radius)
    return wheels


class RobotLoads3D:
    """Recorder of the run loop for a 3D model (:class:`RFT3DCoupling`, or
    :class:`terrasph.terrain.sph3d_coupling.Coupled3D` on the 3D SPH bed): per coupled body ``robot/<body>`` (time,
    position (3) m and quaternion (w, x, y, z) of its frame, velocity (3) m/s of its centre of mass
    and angular velocity (3) rad/s, world frame; force (3) N and torque (3) N·m about its centre of
    mass averaged over the sampling interval; lowest_z m, surface m, sinkage m = surface − lowest_z;
    for a wheel on RFT (:func:`wheel_radii`) also spin rad/s, its angular velocity about the hinge's axis a,
    forward_speed m/s, the velocity of the hinge's anchor along a × ẑ (where a positive spin rolls
    it), and slip, Eq. 4.8 of the two with the wheel's R (:func:`terrasph.robots.metrics.slip`; NaN
    while the axis is vertical)) and, for a robot with actuators, ``robot/actuators`` (time, qpos,
    qvel, ctrl, the robot's centre of mass com (3) m, actuator_force, power W)."""

    def __init__(self, coupled: RFT3DCoupling | Coupled3D) -> None:
        self.coupled = coupled
        # the wheels' rolling radii are read from the RFT elements (on the 3D SPH bed: no slip series)
        self.wheels = wheel_radii(coupled.robot) if isinstance(coupled, RFT3DCoupling) else {}

    def rows(self) -> dict[str, dict[str, Any]]:
        coupled = self.coupled
        model, data = coupled.robot.model, coupled.robot.data
        mujoco.mj_forward(model, data)
        surface = coupled.robot.surface
        rows: dict[str, dict[str, Any]] = {}
        for k, body in enumerate(coupled.robot.coupled):
            b = body.body_id
            sample = coupled.body_sample(k)
            twist = np.zeros(6)  # [angular, linear] at the centre of mass, world axes
            mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_BODY, b, twist, 0)
            rows[f"robot/{body.name}"] = row = {
                "time": coupled.time, "position": data.xpos[b].copy(), "quaternion": data.xquat[b].copy(),
                "velocity": twist[3:].copy(), "angular_velocity": twist[:3].copy(), "force": sample["force"],
                "torque": sample["torque"], "lowest_z": sample["lowest_z"], "surface": surface,
                "sinkage": surface - sample["lowest_z"]}
            if k in self.wheels:
                joint, radius = self.wheels[k]
                axis = data.xaxis[joint]
                forward = np.cross(axis, [0.0, 0.0, 1.0])
                size = float(np.linalg.norm(forward))
                anchor = twist[3:] + np.cross(twist[:3], data.xanchor[joint] - data.xipos[b])
                speed = float(anchor @ forward) / size if size > 1e-9 else math.nan
                spin = float(twist[:3] @ axis)
                row.update({"spin": spin, "forward_speed": speed, "slip": float(slip(speed, spin, radius))})
        if model.nu:
            rows["robot/actuators"] = {"time": coupled.time, "qpos": data.qpos.copy(), "qvel": data.qvel.copy(),
                                       "ctrl": data.ctrl.copy(), "com": data.subtree_com[0].copy(),
                                       "actuator_force": data.actuator_force.copy(),
                                       "power": float(np.dot(data.actuator_force, data.actuator_velocity))}
        coupled.reset_body_means()
        return rows
