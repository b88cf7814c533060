"""A MuJoCo robot on the resistive-force-theory terrain (terrasph.terrain.rft): the SPH coupling's interface
without the SPH.

:class:`RFTCoupling` is a stepper like :class:`terrasph.terrain.sph_coupling.CoupledSimulation` (the same
methods, driven by :func:`terrasph.robots.run.run_coupled`). The terrain is a flat free surface at
z = ``surface`` and keeps no state. Each step of dt:

1. takes the RFT load of each coupled body (:func:`terrasph.terrain.rft.body_load`'s) and the force of each
   torque-limited velocity servo at the state of t_n, puts them in MuJoCo's ``xfrc_applied`` and the
   actuators (each servo a plain force for the step), and lets MuJoCo advance by dt: velocities q̇*;
2. makes the step backward Euler in those forces: M (q̇ − q̇*) = dt (G(q̇) − G(q̇_n)), G the
   generalised RFT loads and servo forces at the step's poses, solved by Newton's method with their
   Jacobian (:attr:`terrasph.terrain.rft.BodyLoad.jacobian`) from the linearly implicit step (G linearised
   at q̇_n: (M − dt K_n)(q̇ − q̇*) = dt K_n (q̇* − q̇_n), K_n = ∂G/∂q̇ there; one load evaluation
   fewer per step than starting from q̇*, docs/rft.md "Cost"), and moves the positions by dt (q̇ − q̇*).

Why implicit: RFT's stress depends on the direction of motion only (a body at rest under load, a
wheel's legs reversing), so held over a step it flips sign step by step — a wheel of 3·10⁻⁴ kg·m²
chattered at ±14 rad/s with an explicit 2 ms step — and a servo given its limit as a plain force
(the SPH coupling's rule) jumps past its command. Solved with the step's end velocities, a resting
body rests (creeping below :data:`terrasph.terrain.rft.REGULARISATION_SPEED`) and a stalled wheel turns once
its motor beats the sand. The loads are taken at the step's start pose (first order in dt).
:data:`RFT_TIME_STEP` is the measured step (docs/rft.md). A state MuJoCo cannot integrate (it then
resets the robot) raises :class:`terrasph.InstabilityError`, as on the SPH terrain, so the run
records it as unstable.

The step runs in the compiled core (``terrasph._core.PlanarRobotStepper``, cpp/src/rft_robot.cpp),
which calls the MuJoCo library of the ``mujoco`` package on the robot's own ``model`` and ``data``:
:meth:`RFTCoupling.advance` takes many steps per Python call. A controller is called every
:data:`RFT_CONTROL_INTERVAL` of simulated time (a robot's control rate) and its commands are held
in between; :meth:`RFTCoupling.control_span` tells it for how long.
"""

from __future__ import annotations

import math
import os
import pathlib
import sys
from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np

from terrasph import _core
from terrasph.config import ConfigError
from terrasph.mjcf.model import CoupledBody, PlanarRobot
from terrasph.terrain import rft
from terrasph.terrain.sph_coupling import (
    RobotStepper,
    divergence_error,
    divergences,
    mujoco_state,
    restore_mujoco_state,
    velocity_servos,
)

__all__ = ["RFT_CONTROL_INTERVAL", "RFT_TIME_STEP", "NativeRFTStepper", "RFTCoupling", "check_step_options",
           "mujoco_library"]

#: MuJoCo's step on the RFT terrain (s): the flat-leg and C-leg wheels' slip and sinkage at 2e-3 s are
#: within 0.004 and 0.3 mm of those at 5e-4 s; at 5e-3 s the flat-leg wheel's spin runs away (docs/rft.md)
RFT_TIME_STEP = 2e-3

#: How often (s of simulated time) :meth:`RFTCoupling.advance` calls a controller, its commands held
#: in between: 100 Hz, a robot controller's rate, five 2 ms steps (the leg-wheel's slip and sinkage
#: against a call every step: docs/rft.md)
RFT_CONTROL_INTERVAL = 1e-2


#: Newton iterations of the implicit load per step at most, the halvings of an iteration's step that
#: may fail to reduce the residual before the iterations stop (the best velocities kept), and the
#: residual (its largest component relative to the larger of the step's momentum M q̇* and impulse
#: dt G_n) at which they stop; the solver, shared by both steppers: cpp/src/backward_euler.hpp
NEWTON_ITERATIONS = 20
NEWTON_HALVINGS = 6
NEWTON_TOLERANCE = 1e-8


def mujoco_library() -> str:
    """The path of the MuJoCo shared library that the ``mujoco`` package loads (its wheel ships it
    beside the bindings), for the native step to call."""
    folder = pathlib.Path(mujoco.__file__).parent
    pattern = {"darwin": "libmujoco*.dylib", "win32": "mujoco*.dll"}.get(sys.platform, "libmujoco.so*")
    found = sorted(folder.glob(pattern))
    if not found:
        raise ConfigError(f"the MuJoCo library ({pattern}) is not in {folder}: reinstall the mujoco package")
    return str(found[-1])


def check_step_options(time_step: float, control_interval: float) -> None:
    """ConfigError naming `time_step` (s) or `control_interval` (s, at least the step) if out of range."""
    if not (isinstance(time_step, (int, float)) and math.isfinite(time_step) and time_step > 0):
        raise ConfigError(f"parameter 'time_step' = {time_step!r} is invalid: allowed a finite number > 0 (s)")
    if not (isinstance(control_interval, (int, float)) and math.isfinite(control_interval)
            and control_interval >= time_step):
        raise ConfigError(f"parameter 'control_interval' = {control_interval!r} is invalid: allowed a finite "
                          f"number >= the time step {time_step!r} s")


class NativeRFTStepper:
    """What the planar and 3D RFT steppers share (:class:`RFTCoupling`,
    terrasph.terrain.rft3d_coupling.RFT3DCoupling): a compiled stepper ``_native`` that advances MuJoCo's
    ``robot.model`` and ``robot.data`` by dt ``_dt`` per step and sums each coupled body's load times
    dt (``LOAD_SIZE`` numbers per body) since :meth:`reset_body_means`; the subclass sets them, and
    its :meth:`state` and :meth:`restore_state` hold its memory."""

    #: the numbers of a body's load in the native stepper's sums
    LOAD_SIZE: int
    robot: Any
    _native: Any

    def _start(self, time_step: float, control_interval: float) -> None:
        """The shared memory at the start: dt, the controller's interval in steps, the load means' start."""
        check_step_options(time_step, control_interval)
        self._dt = float(time_step)
        self._control_steps = max(1, round(control_interval / time_step))
        self._span = self._dt
        self._since = float(self.robot.data.time)
        self._divergences = divergences(self.robot.data)

    @property
    def time(self) -> float:
        """Simulated time (s), MuJoCo's."""
        return float(self.robot.data.time)

    @property
    def step_count(self) -> int:
        """Steps taken so far."""
        return int(self._native.step_count)

    @step_count.setter
    def step_count(self, count: int) -> None:
        self._native.step_count = int(count)

    def restart(self) -> None:
        """The stepper's memory afresh for the state now in the robot's data, after its owner reset it
        (the load means restarted, MuJoCo's divergence count read again)."""
        self.reset_body_means()
        self._divergences = divergences(self.robot.data)

    def time_step(self) -> float:
        """The step's dt (s)."""
        return self._dt

    def control_span(self) -> float:
        """The simulated time (s) over which the controller's commands of this call are held."""
        return self._span

    def step(self) -> float:
        """One step (the subclass's module docstring); returns its dt."""
        self.steps(1)
        return self._dt

    def steps(self, count: int) -> None:
        """`count` steps in one call of the native stepper. If MuJoCo met a state it could not integrate
        among them (and reset the robot: its time back to 0), :class:`terrasph.InstabilityError`, as
        the SPH coupling raises, with the step and time of the call's start."""
        time, steps = self.time, self.step_count
        if self._native.steps(count) > self._divergences:
            raise divergence_error(f"within steps {steps}–{self.step_count}", steps, time)

    def advance(self, t_end: float, max_steps: int = 2**62, control: Callable[[Any], None] | None = None) -> int:
        """Steps until `t_end` (s) is reached or passed, at most `max_steps`, many steps per call of the
        native stepper (:meth:`steps`); returns the number taken. `control`, if given, is called with
        the stepper every ``control_interval`` of simulated time (at its multiples) and its commands
        held in between (:meth:`control_span`)."""
        taken, interval = 0, self._control_steps * self._dt
        while taken < max_steps and self.time < t_end * (1 - 1e-14):
            target = t_end
            if control:
                target = min(t_end, interval * (math.floor(self.time / interval + 1e-6) + 1))
            count = min(max_steps - taken, max(1, math.ceil((target - self.time) / self._dt - 1e-6)))
            if control:
                self._span = count * self._dt
                control(self)
            self.steps(count)
            taken += count
        return taken

    def reset_body_means(self) -> None:
        """Starts a new averaging interval of the body loads."""
        self._native.load_sums = [0.0] * (self.LOAD_SIZE * len(self.robot.coupled))
        self._since = self.time

    def load_means(self) -> np.ndarray:
        """Each coupled body's load averaged since :meth:`reset_body_means` (rows of ``LOAD_SIZE``, the
        load of each step weighted by its dt); NaN before a step."""
        span = self.time - self._since
        sums = np.asarray(self._native.load_sums, dtype=float).reshape(len(self.robot.coupled), self.LOAD_SIZE)
        return sums / span if span > 0 else np.full_like(sums, math.nan)

    def diagnostics(self) -> dict[str, float]:
        """A diagnostics row: the step count and dt (s); no grains to leak."""
        return {"step": self.step_count, "dt": self._dt, "leaked_particles": 0}

    def run_attributes(self) -> dict[str, int]:
        """The counts of the run file's ``/run``: no grains, none leaked."""
        return {"granular_particles": 0, "wall_particles": 0, "leaked_particles": 0}

    def describe(self) -> dict[str, Any]:
        raise NotImplementedError

    def lowest_z(self, k: int) -> float:
        """The lowest z (m) of coupled body `k` now."""
        raise NotImplementedError

    def state(self) -> dict[str, Any]:
        raise NotImplementedError

    def restore_state(self, saved: dict[str, Any]) -> None:
        raise NotImplementedError

    # -- checkpoints ---------------------------------------------------------------------------
    def checkpoint(self, path: str | os.PathLike[str], progress: dict[str, Any] | None = None) -> pathlib.Path:
        """Writes MuJoCo's state and the stepper's memory (under ``progress["robot"]``) to `path`."""
        from terrasph.checkpoint import grain_free_state, write_checkpoint

        state = grain_free_state(self.step_count)
        return write_checkpoint(path, state, self.describe(), {**(progress or {}), "robot": self.state()})

    def restore(self, path: str | os.PathLike[str]) -> dict[str, Any]:
        """Continues from a :meth:`checkpoint`; returns the rest of its progress."""
        from terrasph.checkpoint import (
            CheckpointError,
            configuration_differences,
            read_checkpoint,
        )

        state, config, progress = read_checkpoint(path)
        differences = configuration_differences(config, self.describe())
        if differences or "robot" not in progress:
            raise CheckpointError(f"checkpoint {path} belongs to another RFT run: {', '.join(differences) or 'no robot'}")
        self.step_count = int(state["counters"]["steps"])
        self.restore_state(progress.pop("robot"))
        return progress


class RFTCoupling(NativeRFTStepper, RobotStepper):
    """A :class:`PlanarRobot` on the RFT terrain: a flat granular surface at z = `surface` (m) with the
    coefficient map `table`; `time_step` (s) is MuJoCo's step, `element_length` (m) that of the RFT
    surface elements (default: :class:`terrasph.terrain.rft.SurfaceElements`'s), `control_interval` (s) how
    often :meth:`advance` calls a controller (a multiple of `time_step`; module docstring)."""

    LOAD_SIZE = 3  # F_x, F_z (N) and the clockwise torque about the body origin (N·m)

    def __init__(self, robot: PlanarRobot, surface: float, table: rft.RFTCoefficients | str = "generic", *,
                 time_step: float = RFT_TIME_STEP, element_length: float | None = None,
                 control_interval: float = RFT_CONTROL_INTERVAL) -> None:
        if not (isinstance(surface, (int, float)) and np.isfinite(surface)):
            raise ConfigError(f"parameter 'surface' = {surface!r} is invalid: allowed a finite number (m)")
        self.robot = robot
        self._start(time_step, control_interval)
        self.surface_level = float(surface)
        self.table = rft.coefficient_table(table)
        self._elements = {b.name: rft.SurfaceElements.from_shape(b.shape, element_length, b.width)
                          for b in robot.coupled}
        self._index = {b.name: k for k, b in enumerate(robot.coupled)}  # each body's row in the stepper's sums
        self._native = _core.PlanarRobotStepper(
            mujoco_library(), robot.model._address, robot.data._address,
            [(b.body_id, e.centre, e.normal, e.length, e.width, e.pockets)
             for b, e in zip(robot.coupled, self._elements.values())],
            [(s.actuator, s.dof, s.kv, s.gear, s.lower, s.upper) for s in velocity_servos(robot)],
            self.surface_level, self.table.terms, self.table.zeta, self.table.unit_weight, self._dt,
            rft.REGULARISATION_SPEED,
            NEWTON_ITERATIONS, NEWTON_HALVINGS, NEWTON_TOLERANCE)

    def restart(self) -> None:
        """As the base's, and each body's continuous angle read again from its pose."""
        super().restart()
        self._native.angles = [self.robot.wrapped_angle(b) for b in self.robot.coupled]

    def angle(self, name: str) -> float:
        """Clockwise angle (rad) of coupled body `name`, continuous over turns (the native stepper's)."""
        return self._native.angles[self._index[name]]

    @property
    def _angle(self) -> dict[str, float]:
        """Each coupled body's clockwise angle (rad), continuous over turns (the native stepper's)."""
        return dict(zip(self._elements, self._native.angles))

    def granular_load(self, body: CoupledBody) -> tuple[np.ndarray, float]:
        """RFT force (N) and clockwise torque (N·m, about the body origin) on `body` now."""
        velocity, omega = self.robot.velocity(body)
        load = rft.body_load(self._elements[body.name], self._angle[body.name], self.robot.reference(body),
                             velocity, omega, self.surface_level, self.table)
        return load.force, load.torque

    # -- what a run loop records ------------------------------------------------------------------
    def describe(self) -> dict[str, Any]:
        """The terrain and the coupled bodies, for the run file."""
        return {"terrain": {"kind": "rft", "surface": self.surface_level, "zeta": self.table.zeta,
                            "coefficients": dict(self.table.coefficients),
                            "source": self.table.source, "time_step": self._dt,
                            "elements": {name: len(e) for name, e in self._elements.items()}},
                "robot": self.robot_description()}

    def static_arrays(self) -> dict[str, np.ndarray]:
        """Each coupled body's RFT surface elements in its own frame (``/static/rft/<body>/...``) and
        the body of each row of the frames' body fields (``/static/bodies/index``: its place in the
        robot's coupled bodies)."""
        arrays = {"bodies/index": np.concatenate([np.full(len(b.shape.position), k, dtype=np.int32)
                                                  for k, b in enumerate(self.robot.coupled)])}
        for name, elements in self._elements.items():
            arrays.update({f"rft/{name}/centre": elements.centre, f"rft/{name}/normal": elements.normal,
                           f"rft/{name}/length": elements.length})
        return arrays

    def body_sample(self, name: str) -> dict[str, Any]:
        """RFT force (N) and torque (N·m) on body `name` averaged since :meth:`reset_body_means` (the load of
        each step weighted by its dt), and its lowest z (m, :meth:`BodyShape.lowest_point`)."""
        index = self._index[name]
        if self.time > self._since:
            fx, fz, torque = self.load_means()[index]
            force = np.array([fx, fz])
        else:
            force, torque = self.granular_load(self.robot.coupled[index])
        return {"force": force, "torque": float(torque), "lowest_z": self.lowest_z(index)}

    def lowest_z(self, k: int) -> float:
        """The lowest z (m) of coupled body `k`'s shape now (:meth:`BodyShape.lowest_point`)."""
        body = self.robot.coupled[k]
        return body.shape.lowest_point(self._native.angles[k], self.robot.reference(body))

    def surface(self) -> float:
        """The free surface (m): flat and fixed, the terrain has no state."""
        return self.surface_level

    def frame_fields(self) -> dict[str, np.ndarray]:
        """A frame of the coupled bodies only (the terrain has no grains): ``body_position`` and
        ``body_velocity`` (m, m/s) of each body's particles (:attr:`terrasph.bodies.BodyShape.position`,
        the robot's own drawing) at its pose now, bodies in the robot's order."""
        positions, velocities = [], []
        for body in self.robot.coupled:
            reference = self.robot.reference(body)
            points = body.shape.positions_at(self._angle[body.name], tuple(reference))
            velocity, omega = self.robot.velocity(body)
            arm = points - reference
            # a clockwise spin ω moves a point at arm (x, z) from the reference by ω (z, −x)
            velocities.append(np.asarray(velocity) + omega * np.column_stack([arm[:, 1], -arm[:, 0]]))
            positions.append(points)
        return {"body_position": np.concatenate(positions), "body_velocity": np.concatenate(velocities)}

    def state(self) -> dict[str, Any]:
        """MuJoCo's state and the stepper's memory as plain data."""
        sums = self._native.load_sums
        return {**mujoco_state(self.robot), "angle": self._angle,
                "sums": {k: [sums[3 * i:3 * i + 2], sums[3 * i + 2]] for i, k in enumerate(self._elements)},
                "since": self._since}

    def restore_state(self, saved: dict[str, Any]) -> None:
        """Puts back a :meth:`state`."""
        restore_mujoco_state(self.robot, saved)
        self._divergences = divergences(self.robot.data)
        self._native.angles = [float(saved["angle"][k]) for k in self._elements]
        self._native.load_sums = [float(v) for k in self._elements
                                  for v in (*saved["sums"][k][0], saved["sums"][k][1])]
        self._since = float(saved["since"])
