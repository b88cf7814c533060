"""A small run loop for a coupled robot: coupled steps, HDF5 frames and robot time series.

Layout of the file (terrasph.io.RunWriter): frames as for any run; ``/series/diagnostics``
(time, step, dt, leaked_particles, wall_time); ``/series/robot/<body>`` per coupled body (time,
reference (x, z) m, angle rad and omega rad/s clockwise, velocity (v_x, v_z) m/s, force (F_x, F_z)
N and torque N·m clockwise about the body origin, both for the body's real width and averaged over
the sampling interval, lowest_z m, surface m (the bed's undisturbed free surface at that time,
:func:`undisturbed_surface`), sinkage m = surface − lowest_z, slip (Eq. 4.8 with the shape's
radius)); ``/series/robot/actuators`` (time, qpos, qvel, actuator force — a
motor's torque in N·m for a hinge — and the total actuator power in W).
"""

from __future__ import annotations

import os
import time as wallclock
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import mujoco
import numpy as np

from terrasph.config import ConfigError
from terrasph.robots.coupling import CoupledSimulation
from terrasph.robots.metrics import free_surface, sinkage, slip

__all__ = ["SURFACE_MARGIN", "RobotRun", "Stepper", "body_row", "run_coupled", "undisturbed_surface"]

#: columns of the bed closer than this (m) to a coupled body's x extent are disturbed by it (its
#: rut and the grains it pushes up) and left out of the free-surface level
SURFACE_MARGIN = 0.02


class Stepper(Protocol):
    """What :func:`run_coupled` drives: a robot on a terrain advanced step by step. The SPH coupling
    (:class:`CoupledSimulation`) and the RFT terrain (:class:`terrasph.robots.rft_terrain.RFTCoupling`)
    implement it; see CoupledSimulation for each method's meaning."""

    robot: Any

    @property
    def time(self) -> float: ...
    def time_step(self) -> float: ...
    def step(self) -> float: ...
    def angle(self, name: str) -> float: ...
    def describe(self) -> dict[str, Any]: ...
    def write_static(self, writer: Any) -> None: ...
    def body_sample(self, name: str) -> dict[str, Any]: ...
    def surface(self) -> float: ...
    def wall_loads(self) -> dict[str, dict[str, Any]]: ...
    def reset_means(self) -> None: ...
    def counters(self) -> dict[str, Any]: ...
    def frame_fields(self) -> dict[str, np.ndarray] | None: ...
    def checkpoint(self, path: str | os.PathLike[str], progress: dict[str, Any] | None = None) -> Any: ...
    def restore(self, path: str | os.PathLike[str]) -> dict[str, Any]: ...


def undisturbed_surface(coupled: CoupledSimulation, margin: float = SURFACE_MARGIN) -> float:
    """The bed's free surface now (m; :func:`terrasph.robots.metrics.free_surface`) away from every
    coupled body: columns within `margin` of a body's x extent are left out. Sinkage is measured
    from it, so the bed's own settling (it is built at its hydrostatic density and settles by
    less than Δx) is not counted as the robot sinking."""
    sim = coupled.sim
    walls, owner = np.asarray(sim.core.wall_position), np.asarray(sim.core.wall_body)
    names = [b.name for b in sim.bodies]
    extents = []
    for body in coupled.robot.coupled:
        x = walls[owner == names.index(body.name), 0]
        extents.append((float(x.min()), float(x.max())))
    return free_surface(np.asarray(sim.core.position), sim.scene.spacing, extents, margin)


def body_row(coupled: Stepper, name: str, surface: float) -> dict[str, Any]:
    """One sample of a coupled body's series (granular loads averaged since the last reset;
    sinkage below the free surface at `surface`, m)."""
    body = next(b for b in coupled.robot.coupled if b.name == name)
    state = coupled.body_sample(name)
    velocity, omega = coupled.robot.velocity(body)
    return {"time": coupled.time, "reference": coupled.robot.reference(body), "angle": coupled.angle(name),
            "velocity": velocity, "omega": omega, "force": state["force"], "torque": state["torque"],
            "lowest_z": state["lowest_z"], "surface": surface, "sinkage": float(sinkage(state["lowest_z"], surface)),
            "slip": float(slip(velocity[0], omega, body.shape.radius))}


def _actuator_row(coupled: Stepper) -> dict[str, Any]:
    data = coupled.robot.data
    return {"time": coupled.time, "qpos": data.qpos.copy(), "qvel": data.qvel.copy(),
            "actuator_force": data.actuator_force.copy(),
            "power": float(np.dot(data.actuator_force, data.actuator_velocity))}


@dataclass
class RobotRun:
    """What a robot scene's run gives back: its summary values, the robot series by group name,
    and the path of its figure (None if none was drawn)."""

    values: dict[str, Any]
    series: dict[str, dict[str, np.ndarray]]
    plot: str | None = None

    def summary(self) -> dict[str, Any]:
        """The summary values (JSON-ready)."""
        return self.values


def run_coupled(coupled: Stepper, t_end: float, *, output: str | os.PathLike[str] | None = None,
                frame_interval: float = 0.05, series_interval: float = 0.01,
                config: dict[str, Any] | None = None, control: Callable[[Any], None] | None = None,
                progress: bool = False, memory: dict[str, Any] | None = None,
                checkpoint_every: float | None = 600.0, resume: bool = False) -> dict[str, dict[str, np.ndarray]]:
    """Runs `coupled` (a :class:`CoupledSimulation` or any :class:`Stepper`, e.g. the RFT terrain's
    :class:`terrasph.robots.rft_terrain.RFTCoupling`) to `t_end` (s); writes frames (if the stepper
    has any) every `frame_interval` and robot samples every `series_interval` (s) to `output` (HDF5)
    if given. `control`, if given, is called before each
    step (to set MuJoCo's ``data.ctrl`` from the time, say); its own running values belong in
    `memory` (plain data), which is checkpointed with the run. Returns the robot series by group
    name (the whole run's, when resumed). After ``coupled.sim.track_wall_loads(...)`` the load of
    the grains on each fixed wall (:meth:`terrasph.Simulation.wall_loads`) is sampled too, as
    ``walls/<name>`` (kept in checkpoints: track them again, about the same point, before resuming).

    As :meth:`terrasph.Simulation.run`: with an `output`, the SPH State, MuJoCo's state (qpos,
    qvel, act, ctrl, warm start, time), the coupling's memory and `memory` go to
    :func:`terrasph.simulation.checkpoint_path` every `checkpoint_every` s of wall time (None: never)
    and when SIGINT or SIGTERM stops the run at the next step boundary (the file is closed and
    ``KeyboardInterrupt`` raised). ``resume=True`` continues from that checkpoint into the same
    file (rows and frames written after it are dropped), bitwise the run that never stopped.
    """
    from terrasph.io import RunWriter, read_run
    from terrasph.simulation import (
        _StopRequest,
        check_run_options,
        checkpoint_path,
        simulated_time_bar,
        versions,
    )

    check_run_options({"frame_interval": frame_interval, "series_interval": series_interval}, checkpoint_every,
                      resume, output)

    memory = {} if memory is None else memory
    saved = coupled.restore(checkpoint_path(output)) if resume else {}
    memory.update(saved.get("memory", {}))
    if not t_end > coupled.time:
        raise ConfigError(f"parameter 't_end' = {t_end} is invalid: allowed > current time {coupled.time}")
    writer = None
    if resume:
        writer = RunWriter.reopen(output, frames=saved["frames"], series_rows=saved["series_rows"])
    elif output is not None:
        writer = RunWriter(output, config or coupled.describe(), versions={**versions(), "mujoco": mujoco.__version__})
        coupled.write_static(writer)
    series: dict[str, dict[str, list[Any]]] = {}
    series_rows: dict[str, int] = dict(saved.get("series_rows", {}))
    frames = saved.get("frames", 0)
    start = wallclock.perf_counter() - saved.get("wall_time", 0.0)

    def append(group: str, row: dict[str, Any]) -> None:
        for key, value in row.items():
            series.setdefault(group, {}).setdefault(key, []).append(value)
        if writer:
            writer.append_series(group, row)
            series_rows[group] = series_rows.get(group, 0) + 1

    def sample() -> None:
        surface = coupled.surface()
        for body in coupled.robot.coupled:
            append(f"robot/{body.name}", body_row(coupled, body.name, surface))
        if coupled.robot.model.nu:  # a robot without actuators has no such series (HDF5 has no 0-wide columns)
            append("robot/actuators", _actuator_row(coupled))
        append("diagnostics", {"time": coupled.time, **coupled.counters(),
                               "wall_time": wallclock.perf_counter() - start})
        for name, load in coupled.wall_loads().items():
            append(f"walls/{name}", {"time": coupled.time, **load})
        coupled.reset_means()

    def frame() -> None:
        nonlocal frames
        fields = coupled.frame_fields() if writer else None
        if fields is not None:
            writer.write_frame(coupled.time, coupled.counters()["step"], fields)
            frames += 1

    def save_checkpoint() -> None:
        if writer:
            coupled.checkpoint(checkpoint_path(output), {
                "next_sample": next_sample, "next_frame": next_frame, "frames": frames, "series_rows": series_rows,
                "wall_time": wallclock.perf_counter() - start, "memory": memory})

    if resume:
        next_sample, next_frame = saved["next_sample"], saved["next_frame"]
    else:
        coupled.reset_means()
        sample()
        frame()
        next_sample, next_frame = coupled.time + series_interval, coupled.time + frame_interval
    t_start = coupled.time
    bar = simulated_time_bar(t_end - t_start, progress)
    stop = _StopRequest()
    try:
        with stop.catching_signals():
            last_checkpoint = wallclock.perf_counter()
            while coupled.time < t_end * (1 - 1e-14):
                if control:
                    control(coupled)
                coupled.step()
                # the last step may end past t_end: the bar stops at its total, never beyond (tqdm clamps with a warning)
                bar.update(min(bar.total, round(coupled.time - t_start, 9)) - bar.n)
                if coupled.time >= next_sample * (1 - 1e-12):
                    sample()
                    next_sample += series_interval
                if coupled.time >= next_frame * (1 - 1e-12):
                    frame()
                    next_frame += frame_interval
                if stop.requested:
                    raise KeyboardInterrupt
                if checkpoint_every is not None and wallclock.perf_counter() - last_checkpoint >= checkpoint_every:
                    save_checkpoint()
                    last_checkpoint = wallclock.perf_counter()
        if writer:
            counters = coupled.counters()
            writer.set_attrs("/run", {"status": "completed", "time": coupled.time, "steps": counters["step"],
                                      "leaked_particles": counters["leaked_particles"],
                                      "wall_time": wallclock.perf_counter() - start})
    except KeyboardInterrupt:
        if writer:
            save_checkpoint()
            writer.set_attrs("/run", {"status": "interrupted", "time": coupled.time,
                                      "steps": coupled.counters()["step"], "checkpoint": checkpoint_path(output).name})
        raise
    finally:
        bar.close()
        if writer:
            writer.close()
    if resume:  # the whole run's series, not only the resumed part
        return {group: dict(values) for group, values in read_run(output).series.items()
                if group.startswith("robot/") or group == "diagnostics"}
    return {group: {key: np.asarray(values) for key, values in rows.items()} for group, rows in series.items()}
