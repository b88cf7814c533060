"""A MuJoCo robot on the resistive-force-theory terrain (terrasph.rft): the SPH coupling's interface
without the SPH.

:class:`RFTCoupling` is a stepper like :class:`terrasph.robots.coupling.CoupledSimulation` (the same
methods, driven by :func:`terrasph.robots.run.run_coupled`). The terrain is a flat free surface at
z = ``surface`` and keeps no state. Each step of dt:

1. takes the RFT load of each coupled body (:func:`terrasph.rft.body_load`) and the force of each
   torque-limited velocity servo at the state of t_n, puts them in MuJoCo's ``xfrc_applied`` and the
   actuators, and lets MuJoCo advance by dt (:func:`coupling.mujoco_step`): velocities q̇*;
2. makes the step backward Euler in those forces: M (q̇ − q̇*) = dt (G(q̇) − G(q̇_n)), G the
   generalised RFT loads and servo forces at the step's poses, solved by Newton's method with their
   Jacobian (:attr:`terrasph.rft.BodyLoad.jacobian`), and moves the positions by dt (q̇ − q̇*).

Why implicit: RFT's stress depends on the direction of motion only (a body at rest under load, a
wheel's legs reversing), so held over a step it flips sign step by step — a wheel of 3·10⁻⁴ kg·m²
chattered at ±14 rad/s with an explicit 2 ms step — and a servo given its limit as a plain force
(the SPH coupling's rule) jumps past its command. Solved with the step's end velocities, a resting
body rests (creeping below :data:`terrasph.rft.REGULARISATION_SPEED`) and a stalled wheel turns once
its motor beats the sand. The loads are taken at the step's start pose (first order in dt).
:data:`RFT_TIME_STEP` is the measured step (docs/rft.md).
"""

from __future__ import annotations

import os
import pathlib
from typing import Any

import mujoco
import numpy as np

from terrasph import rft
from terrasph.config import ConfigError
from terrasph.robots.coupling import (RobotStepper, mujoco_derived, mujoco_state, mujoco_step,
                                      restore_mujoco_state, unwrapped, velocity_servos)
from terrasph.robots.mjcf import CoupledBody, PlanarRobot

__all__ = ["RFT_TIME_STEP", "RFTCoupling"]

#: MuJoCo's step on the RFT terrain (s): the flat-leg and C-leg wheels' slip and sinkage at 2e-3 s are
#: within 0.004 and 0.3 mm of those at 5e-4 s; at 5e-3 s the flat-leg wheel's spin runs away (docs/rft.md)
RFT_TIME_STEP = 2e-3


#: Newton iterations of the implicit load per step at most, the halvings of an iteration's step that
#: may fail to reduce the residual before the iterations stop (the best velocities kept), and the
#: residual (relative to the step's momentum change) at which they stop
NEWTON_ITERATIONS = 20
NEWTON_HALVINGS = 6
NEWTON_TOLERANCE = 1e-8


class RFTCoupling(RobotStepper):
    """A :class:`PlanarRobot` on the RFT terrain: a flat granular surface at z = `surface` (m) with the
    coefficient map `table`; `time_step` (s) is MuJoCo's step, `element_length` (m) that of the RFT
    surface elements (default: :class:`terrasph.rft.SurfaceElements`'s)."""

    def __init__(self, robot: PlanarRobot, surface: float, table: rft.RFTCoefficients | str = "generic", *,
                 time_step: float = RFT_TIME_STEP, element_length: float | None = None) -> None:
        if not (isinstance(time_step, (int, float)) and np.isfinite(time_step) and time_step > 0):
            raise ConfigError(f"parameter 'time_step' = {time_step!r} is invalid: allowed a finite number > 0 (s)")
        if not (isinstance(surface, (int, float)) and np.isfinite(surface)):
            raise ConfigError(f"parameter 'surface' = {surface!r} is invalid: allowed a finite number (m)")
        self.robot = robot
        self.surface_level = float(surface)
        self.table = rft.coefficient_table(table)
        self._dt = float(time_step)
        self._elements = {b.name: rft.SurfaceElements.from_shape(b.shape, element_length, b.width)
                          for b in robot.coupled}
        self._servos = velocity_servos(robot)
        self._steps = 0
        self._angle = {b.name: robot.wrapped_angle(b) for b in robot.coupled}
        self._sums = {b.name: (np.zeros(2), 0.0) for b in robot.coupled}
        self._since = float(robot.data.time)

    @property
    def time(self) -> float:
        """Simulated time (s), MuJoCo's."""
        return float(self.robot.data.time)

    def time_step(self) -> float:
        """The step's dt (s)."""
        return self._dt

    def granular_load(self, body: CoupledBody) -> tuple[np.ndarray, float]:
        """RFT force (N) and clockwise torque (N·m, about the body origin) on `body` now."""
        load = self._load(body, jacobian=False)
        return load.force, load.torque

    def _load(self, body: CoupledBody, jacobian: bool) -> rft.BodyLoad:
        velocity, omega = self.robot.velocity(body)
        return rft.body_load(self._elements[body.name], self._angle[body.name], self.robot.reference(body),
                             velocity, omega, self.surface_level, self.table, jacobian=jacobian)

    def _twist_jacobian(self, body: CoupledBody) -> np.ndarray:
        """∂(v_x, v_z, ω)/∂q̇ of the body's frame origin (3 × nv)."""
        model, data = self.robot.model, self.robot.data
        linear, angular = np.zeros((3, model.nv)), np.zeros((3, model.nv))
        mujoco.mj_jac(model, data, linear, angular, data.xpos[body.body_id], body.body_id)
        return np.vstack([linear[0], linear[2], angular[1]])

    def step(self) -> float:
        """One step (module docstring); returns its dt."""
        dt = self._dt
        robot, data = self.robot, self.robot.data
        twists = [(body, self._twist_jacobian(body)) for body in robot.coupled]
        start = data.qvel.copy()
        commands = [float(data.ctrl[servo.actuator]) for servo in self._servos]
        loads, applied, stiffness = self._loads(twists, commands, start)
        for (body, _), load in zip(twists, loads):
            robot.apply_load(body, load.force, load.torque)
        mujoco_step(robot, self._servos, dt, derived=False,
                    forces=[servo.force(c, start)[0] for servo, c in zip(self._servos, commands)])
        if stiffness.any():
            loads = self._implicit_load(twists, commands, applied, dt)
        for (body, _), load in zip(twists, loads):
            total, moment = self._sums[body.name]
            self._sums[body.name] = (total + load.force * dt, moment + load.torque * dt)
        mujoco_derived(robot)
        for body in robot.coupled:
            self._angle[body.name] = unwrapped(self._angle[body.name], self.robot.wrapped_angle(body))
        self._steps += 1
        return dt

    def _loads(self, twists: list[tuple[CoupledBody, np.ndarray]], commands: list[float],
               qvel: np.ndarray) -> tuple[list[rft.BodyLoad], np.ndarray, np.ndarray]:
        """The RFT load of each body at the poses of the step's start and joint velocities `qvel`; the
        generalised force of the loads and the velocity servos (at `commands`), Σ Jᵀ(F, τ) + servo
        forces, and its derivative in q̇, Σ Jᵀ D J + the servos' (J: each body's twist Jacobian)."""
        nv = self.robot.model.nv
        generalised, stiffness, loads = np.zeros(nv), np.zeros((nv, nv)), []
        for body, jacobian in twists:
            twist = jacobian @ qvel
            load = rft.body_load(self._elements[body.name], self._angle[body.name], self.robot.reference(body),
                                 twist[:2], float(twist[2]), self.surface_level, self.table, jacobian=True)
            loads.append(load)
            generalised += jacobian.T @ np.r_[load.force, load.torque]
            stiffness += jacobian.T @ load.jacobian @ jacobian
        for servo, command in zip(self._servos, commands):
            force, slope = servo.force(command, qvel)
            generalised[servo.dof] += servo.gear * force
            stiffness[servo.dof, servo.dof] += servo.gear * slope
        return loads, generalised, stiffness

    def _implicit_load(self, twists: list[tuple[CoupledBody, np.ndarray]], commands: list[float],
                       applied: np.ndarray, dt: float) -> list[rft.BodyLoad]:
        """Turns MuJoCo's step with the loads and servo forces `applied` (generalised, at q̇_n) held into
        a backward-Euler step in them, M (q̇ − q̇*) = dt (G(q̇) − G(q̇_n)) at the step's poses, solved by
        Newton's method with their Jacobian (at most :data:`NEWTON_ITERATIONS`, each step halved while
        the residual does not fall, up to :data:`NEWTON_HALVINGS` times). M is the matrix MuJoCo's step
        solved with (the mass matrix plus dt × the joints' damping), q̇* its result; the positions move
        by dt (q̇ − q̇*). Returns the loads at the solution."""
        model, data = self.robot.model, self.robot.data
        matrix = np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(model, data, matrix)  # qM is still that of the step's start
        matrix[np.diag_indices(model.nv)] += dt * model.dof_damping
        explicit = data.qvel.copy()
        scale = float(np.abs(matrix @ explicit).max() + dt * np.abs(applied).max()) + 1e-300

        def residual(qvel: np.ndarray) -> tuple[np.ndarray, list[rft.BodyLoad], np.ndarray]:
            loads, generalised, stiffness = self._loads(twists, commands, qvel)
            return matrix @ (qvel - explicit) - dt * (generalised - applied), loads, stiffness

        qvel = explicit
        r, loads, stiffness = residual(qvel)
        for _ in range(NEWTON_ITERATIONS):
            if np.abs(r).max() <= NEWTON_TOLERANCE * scale:
                break
            step = np.linalg.solve(matrix - dt * stiffness, r)
            for _ in range(NEWTON_HALVINGS):  # halve the step while it does not reduce the residual
                trial = qvel - step
                r_trial, loads_trial, stiffness_trial = residual(trial)
                if np.abs(r_trial).max() < np.abs(r).max():
                    break
                step = 0.5 * step
            else:  # at a kink of the regularisation no step reduces it: keep the best so far
                break
            qvel, r, loads, stiffness = trial, r_trial, loads_trial, stiffness_trial
        mujoco.mj_integratePos(model, data.qpos, qvel - explicit, dt)
        data.qvel[:] = qvel
        return loads

    # -- what a run loop records ------------------------------------------------------------------
    def describe(self) -> dict[str, Any]:
        """The terrain and the coupled bodies, for the run file."""
        return {"terrain": {"kind": "rft", "surface": self.surface_level, "zeta": self.table.zeta,
                            "coefficients": dict(zip(rft.COEFFICIENT_NAMES, self.table.vector.tolist())),
                            "source": self.table.source, "time_step": self._dt,
                            "elements": {name: len(e) for name, e in self._elements.items()}},
                "robot": self.robot_description()}

    def static_arrays(self) -> dict[str, np.ndarray]:
        """Each coupled body's RFT surface elements in its own frame (``/static/rft/<body>/...``)."""
        arrays = {}
        for name, elements in self._elements.items():
            arrays.update({f"rft/{name}/centre": elements.centre, f"rft/{name}/normal": elements.normal,
                           f"rft/{name}/length": elements.length})
        return arrays

    def body_sample(self, name: str) -> dict[str, Any]:
        """RFT force (N) and torque (N·m) on body `name` averaged since :meth:`reset_body_means` (the load of
        each step weighted by its dt), and its lowest z (m, :meth:`BodyShape.lowest_point`)."""
        body = next(b for b in self.robot.coupled if b.name == name)
        total, moment = self._sums[name]
        span = self.time - self._since
        if span > 0:
            force, torque = total / span, moment / span
        else:
            force, torque = self.granular_load(body)
        lowest = body.shape.lowest_point(self._angle[name], tuple(self.robot.reference(body)))
        return {"force": force, "torque": float(torque), "lowest_z": lowest}

    def surface(self) -> float:
        """The free surface (m): flat and fixed, the terrain has no state."""
        return self.surface_level

    def reset_body_means(self) -> None:
        """Starts a new averaging interval of the body loads."""
        self._sums = {name: (np.zeros(2), 0.0) for name in self._sums}
        self._since = self.time

    @property
    def step_count(self) -> int:
        """Steps taken so far."""
        return self._steps

    def diagnostics(self) -> dict[str, float]:
        """A diagnostics row: the step count and dt (s); no grains to leak."""
        return {"step": self._steps, "dt": self._dt, "leaked_particles": 0}

    def run_attributes(self) -> dict[str, int]:
        """The counts of the run file's ``/run``: no grains, none leaked."""
        return {"granular_particles": 0, "wall_particles": 0, "leaked_particles": 0}

    def frame_fields(self) -> dict[str, np.ndarray] | None:
        """No frames: the terrain has no particles (the robot's path is in its series)."""
        return None

    # -- checkpoints ---------------------------------------------------------------------------
    def checkpoint(self, path: str | os.PathLike[str], progress: dict[str, Any] | None = None) -> pathlib.Path:
        """Writes MuJoCo's state and the stepper's memory (under ``progress["robot"]``) to `path`."""
        from terrasph.checkpoint import write_checkpoint

        state = {"granular": {}, "walls": {}, "counters": {"steps": self._steps}, "bodies": [], "removals": [],
                 "wall_loads": {"tracked": False}}
        return write_checkpoint(path, state, self.describe(), {**(progress or {}), "robot": self.state()})

    def restore(self, path: str | os.PathLike[str]) -> dict[str, Any]:
        """Continues from a :meth:`checkpoint`; returns the rest of its progress."""
        from terrasph.checkpoint import CheckpointError, configuration_differences, read_checkpoint

        state, config, progress = read_checkpoint(path)
        differences = configuration_differences(config, self.describe())
        if differences or "robot" not in progress:
            raise CheckpointError(f"checkpoint {path} belongs to another RFT run: {', '.join(differences) or 'no robot'}")
        self._steps = int(state["counters"]["steps"])
        self.restore_state(progress.pop("robot"))
        return progress

    def state(self) -> dict[str, Any]:
        """MuJoCo's state and the stepper's memory as plain data."""
        return {**mujoco_state(self.robot), "angle": dict(self._angle),
                "sums": {k: [f.tolist(), m] for k, (f, m) in self._sums.items()}, "since": self._since}

    def restore_state(self, saved: dict[str, Any]) -> None:
        """Puts back a :meth:`state`."""
        restore_mujoco_state(self.robot, saved)
        self._angle = {k: float(v) for k, v in saved["angle"].items()}
        self._sums = {k: (np.array(f), float(m)) for k, (f, m) in saved["sums"].items()}
        self._since = float(saved["since"])
