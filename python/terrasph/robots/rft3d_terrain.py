"""Any MuJoCo robot — hinges about any axis, free joints — on a flat 3D RFT terrain (terrasph.rft3d).

:func:`rft_robot` reads the MJCF model as the SPH terrain does (:func:`terrasph.robots.terrain_robot.
terrain_model`: the floor switched off, the bodies near it coupled) and gives each coupled body its
collision geoms' surface as 3D RFT elements; the free surface is the floor's height, the model's
frame is kept. :class:`RFT3DCoupling` is the run loop's stepper (terrasph.run_loop.Stepper, driven by
:func:`terrasph.robots.run.run_coupled`). Each step of dt, from the state at t_n:

1. each coupled body's RFT wrench W_n (force and torque about its centre of mass, world frame) at
   the state of t_n goes into MuJoCo's ``xfrc_applied`` and MuJoCo steps: velocities q̇*, poses q*;
2. the step is made backward Euler in the RFT load: M (q̇ − q̇*) = dt (G(q̇) − G_n), G = Σ_b J_bᵀ W_b(J_b q̇)
   the generalised load (J_b the body's 6 × nv Jacobian at its centre of mass, at t_n's pose), solved
   by Newton's method with the wrenches' velocity Jacobians (forward differences of the twist,
   :data:`DIFFERENCE_SPEED`); the positions move by dt (q̇ − q̇*).

Why implicit, as in the planar stepper (terrasph.robots.rft_terrain): the regularised load's
derivative in the normal speed is F / v_ε with v_ε = 0.1 mm/s, a damping that an explicit step
of dt cannot carry unless dt < 2 m v_ε / F, i.e. microseconds for a robot resting on the sand
(docs/rft.md, "3D RFT"). The loads are taken at the step's start pose.
MuJoCo's own actuators (velocity servos included) act inside its step as usual.
"""

from __future__ import annotations

import math
import os
import pathlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from terrasph import rft
from terrasph.config import ConfigError
from terrasph.rft3d import BodyElements, element_forces
from terrasph.robots.coupling import _velocity_servos, divergence_error, divergences, mujoco_state, restore_mujoco_state
from terrasph.robots.metrics import slip
from terrasph.robots.terrain_robot import COUPLE_BELOW, terrain_model

__all__ = ["DIFFERENCE_SPEED", "RFT3D_TIME_STEP", "ROVER4", "RFT3DCoupling", "Robot3D", "RobotLoads3D", "WHEEL_BALANCE", "rft_robot",
           "wheel_radii"]

#: the example non-planar robot shipped with the package: a four-wheeled rover on a free joint (see the file)
ROVER4 = pathlib.Path(__file__).with_name("models") / "rover4.xml"

#: MuJoCo's step on the 3D RFT terrain (s): the rover's travel at 1e-3 s within 0.3 % of that at 5e-4 s,
#: at 2e-3 s 12 % short (docs/rft.md, "3D RFT"; benchmarks/studies/rft3d_rover.py)
RFT3D_TIME_STEP = 1e-3

#: the velocity step (m/s; an angular one of this over the body's size) of the forward differences
#: that give the wrench's Jacobian: far below the regularisation speed, 1e-4 m/s, over which the load
#: of a face turns on
DIFFERENCE_SPEED = 1e-8

#: Newton iterations per step at most, halvings of a step that fails to reduce the residual, and the
#: residual (relative to the step's momentum change) at which the iterations stop
NEWTON_ITERATIONS = 12
NEWTON_HALVINGS = 6
NEWTON_TOLERANCE = 1e-8


@dataclass(frozen=True)
class Body3D:
    """A coupled MuJoCo body: its `name`, `body_id` and RFT `elements` (in its frame)."""

    name: str
    body_id: int
    elements: BodyElements


class Robot3D:
    """A MuJoCo model (any joints) and the bodies that meet the terrain: ``model``, ``data`` and
    ``coupled`` (:class:`Body3D`), the names MuJoCo gives them; `surface` is the floor's height (m)."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, coupled: Sequence[Body3D], surface: float) -> None:
        self.model, self.data, self.coupled, self.surface = model, data, list(coupled), float(surface)


def rft_robot(mjcf: str | os.PathLike[str] | mujoco.MjModel, *, bodies: Sequence[str] = (),
              couple_below: float = COUPLE_BELOW, element_length: float | None = None) -> Robot3D:
    """The MJCF model on the 3D RFT terrain: the floor switched off and the coupled bodies chosen as
    on the SPH terrain (:func:`terrasph.robots.terrain_robot.terrain_model`), each with its collision
    geoms' surface as elements about `element_length` m across
    (:meth:`terrasph.rft3d.BodyElements.from_body`); the free surface at the floor's height."""
    model, data, level, chosen = terrain_model(mjcf, bodies=bodies, couple_below=couple_below)
    coupled = []
    for body in chosen:
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, body) or f"#{body}"
        if not model.body_mass[body] > 0:
            raise ConfigError(f"coupled body '{name}' has no mass in the MJCF model; give it geoms with mass or an "
                              "<inertial>")
        coupled.append(Body3D(name, body, BodyElements.from_body(model, body, element_length)))
    return Robot3D(model, data, coupled, level)


class RFT3DCoupling:
    """A :class:`Robot3D` on the flat 3D RFT terrain with coefficient map `table` (module docstring);
    `time_step` (s) is MuJoCo's step; `control_interval` (s) how often :meth:`advance` calls a
    controller, its commands held in between."""

    def __init__(self, robot: Robot3D, table: rft.RFTCoefficients | str = "generic", *,
                 time_step: float = RFT3D_TIME_STEP, control_interval: float | None = None) -> None:
        from terrasph.robots.rft_terrain import RFT_CONTROL_INTERVAL

        interval = RFT_CONTROL_INTERVAL if control_interval is None else control_interval
        if not (isinstance(time_step, (int, float)) and math.isfinite(time_step) and time_step > 0):
            raise ConfigError(f"parameter 'time_step' = {time_step!r} is invalid: allowed a finite number > 0 (s)")
        if not (isinstance(interval, (int, float)) and math.isfinite(interval) and interval >= time_step):
            raise ConfigError(f"parameter 'control_interval' = {interval!r} is invalid: allowed a finite number >= "
                              f"the time step {time_step!r} s")
        self.robot = robot
        self.table = rft.coefficient_table(table)
        self._dt = float(time_step)
        self._control_steps = max(1, round(interval / time_step))
        self._span = self._dt
        self._steps = 0
        self._sums = np.zeros((len(robot.coupled), 6))
        self._since = float(robot.data.time)
        self._divergences = divergences(robot.data)
        self._size = np.array([max(1e-3, float(np.linalg.norm(b.elements.centre, axis=1).max())) for b in robot.coupled])
        model = robot.model
        model.opt.timestep = self._dt  # MuJoCo's step is the implicit correction's dt
        self._jacp, self._jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
        self._mass = np.zeros((model.nv, model.nv))
        mujoco.mj_forward(model, robot.data)
        self._servos = _velocity_servos(model, robot.data)

    # -- the stepper --------------------------------------------------------------------------
    @property
    def time(self) -> float:
        """Simulated time (s), MuJoCo's."""
        return float(self.robot.data.time)

    @property
    def step_count(self) -> int:
        """Steps taken so far."""
        return self._steps

    def time_step(self) -> float:
        """The step's dt (s)."""
        return self._dt

    def control_span(self) -> float:
        """The simulated time (s) over which the controller's commands of this call are held."""
        return self._span

    def _submerged(self) -> tuple[list[int], np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """At the current pose: the coupled bodies with elements below the surface, and those elements'
        owner (index into that list), arms from the owner's centre of mass, normals, depths and areas
        (world frame)."""
        data, surface = self.robot.data, self.robot.surface
        owners, arms, normals, depths, areas = [], [], [], [], []
        for k, body in enumerate(self.robot.coupled):
            b = body.body_id
            rotation = data.xmat[b].reshape(3, 3)
            centre = data.xpos[b] + body.elements.centre @ rotation.T
            depth = surface - centre[:, 2]
            below = depth > 0
            if below.any():
                owners.append(k)
                arms.append(centre[below] - data.xipos[b])
                normals.append(body.elements.normal[below] @ rotation.T)
                depths.append(depth[below])
                areas.append(body.elements.area[below])
        if not owners:
            empty = np.zeros((0, 3))
            return [], np.zeros(0, dtype=int), empty, empty, np.zeros(0), np.zeros(0)
        index = np.concatenate([np.full(len(a), i) for i, a in enumerate(arms)])
        return owners, index, np.concatenate(arms), np.concatenate(normals), np.concatenate(depths), np.concatenate(areas)

    def _wrenches(self, twists: np.ndarray, index: np.ndarray, arm: np.ndarray, normal: np.ndarray,
                  depth: np.ndarray, area: np.ndarray) -> np.ndarray:
        """The wrenches (..., B, 6) [force, torque about the centre of mass] of the submerged bodies
        for twists (..., B, 6) [velocity of the centre of mass, angular velocity]."""
        lead = twists.shape[:-2]
        velocity = twists[..., index, :3] + np.cross(twists[..., index, 3:], arm)
        shape = velocity.shape
        force = element_forces(np.broadcast_to(normal, shape).reshape(-1, 3), velocity.reshape(-1, 3),
                               np.broadcast_to(depth, shape[:-1]).ravel(), np.broadcast_to(area, shape[:-1]).ravel(),
                               self.table).reshape(shape)
        torque = np.cross(arm, force)
        per_element = np.concatenate([force, torque], axis=-1)
        starts = np.flatnonzero(np.r_[True, index[1:] != index[:-1]])
        return np.add.reduceat(per_element, starts, axis=-2).reshape(*lead, -1, 6)

    def step(self) -> float:
        """One step (module docstring); returns its dt."""
        model, data, dt = self.robot.model, self.robot.data, self._dt
        time, steps = self.time, self._steps
        mujoco.mj_forward(model, data)
        owners, index, arm, normal, depth, area = self._submerged()
        data.xfrc_applied[:] = 0.0
        if not owners:  # nothing in the sand: MuJoCo's step alone
            mujoco.mj_step(model, data)
            self._finish(time, steps, [], np.zeros((0, 6)))
            return dt
        jacobian = np.empty((len(owners), 6, model.nv))
        for i, k in enumerate(owners):
            b = self.robot.coupled[k].body_id
            mujoco.mj_jacBodyCom(model, data, self._jacp, self._jacr, b)
            jacobian[i, :3], jacobian[i, 3:] = self._jacp, self._jacr
        mujoco.mj_fullM(model, data, self._mass)
        start = data.qvel.copy()
        command = data.ctrl.copy()
        wrench = self._wrenches(jacobian @ start, index, arm, normal, depth, area)
        load = np.einsum("bij,bi->j", jacobian, wrench) + self._servo_load(command, start)[0]
        for i, k in enumerate(owners):
            data.xfrc_applied[self.robot.coupled[k].body_id] = wrench[i]
        try:  # each torque-limited velocity servo as a plain force, its force at t_n (the Newton step corrects it)
            for servo in self._servos:
                servo.apply_force(model, data, servo.force(float(command[servo.actuator]), start)[0])
            mujoco.mj_step(model, data)
        finally:
            for servo in self._servos:
                servo.restore(model)
            data.ctrl[:] = command
        explicit = data.qvel.copy()
        qvel = self._implicit(explicit, load, command, jacobian, index, arm, normal, depth, area, owners)
        wrench = self._wrenches(jacobian @ qvel, index, arm, normal, depth, area)
        mujoco.mj_integratePos(model, data.qpos, qvel - explicit, dt)
        data.qvel[:] = qvel
        data.xfrc_applied[:] = 0.0
        self._finish(time, steps, owners, wrench)
        return dt

    def _servo_load(self, command: np.ndarray, qvel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The generalised forces of the torque-limited velocity servos at joint velocities `qvel` and
        their derivative's diagonal (−kv·gear² within the force limits, 0 at them)."""
        force, derivative = np.zeros(len(qvel)), np.zeros(len(qvel))
        for servo in self._servos:
            value, slope = servo.force(float(command[servo.actuator]), qvel)
            force[servo.dof] += servo.gear * value
            derivative[servo.dof] += servo.gear * slope
        return force, derivative

    def _implicit(self, explicit: np.ndarray, load: np.ndarray, command: np.ndarray, jacobian: np.ndarray,
                  index: np.ndarray, arm: np.ndarray, normal: np.ndarray, depth: np.ndarray, area: np.ndarray,
                  owners: list[int]) -> np.ndarray:
        """The velocities q̇ that solve M (q̇ − q̇*) = dt (G(q̇) − G_n) (step 2 of the module docstring;
        G with the servos' forces)."""
        dt, mass = self._dt, self._mass
        size = self._size[owners]
        steps = np.zeros((7, len(owners), 6))
        for c in range(6):  # forward differences of each twist component, all bodies at once
            steps[c + 1, :, c] = DIFFERENCE_SPEED if c < 3 else DIFFERENCE_SPEED / size

        def residual(qvel: np.ndarray) -> np.ndarray:
            wrench = self._wrenches(jacobian @ qvel, index, arm, normal, depth, area)
            generalised = np.einsum("bij,bi->j", jacobian, wrench) + self._servo_load(command, qvel)[0]
            return mass @ (qvel - explicit) - dt * (generalised - load)

        scale = dt * float(np.linalg.norm(load)) + float(np.linalg.norm(mass @ explicit)) * 1e-6 + 1e-300
        qvel = explicit.copy()
        for _ in range(NEWTON_ITERATIONS):
            twists = jacobian @ qvel
            wrenches = self._wrenches(twists[None] + steps, index, arm, normal, depth, area)
            base = wrenches[0]
            servo_force, servo_slope = self._servo_load(command, qvel)
            r = mass @ (qvel - explicit) - dt * (np.einsum("bij,bi->j", jacobian, base) + servo_force - load)
            size_r = float(np.linalg.norm(r))
            if size_r <= NEWTON_TOLERANCE * scale:
                break
            derivative = (wrenches[1:] - base[None]) / steps[1:].sum(axis=2)[:, :, None]  # (6 twist, B, 6 wrench)
            stiffness = np.einsum("bik,cbi,bcj->kj", jacobian, derivative, jacobian)  # Σ Jᵀ (∂W/∂ξ) J
            delta = np.linalg.solve(mass - dt * (stiffness + np.diag(servo_slope)), -r)
            best, best_size = qvel, size_r
            for _ in range(NEWTON_HALVINGS):
                trial = qvel + delta
                trial_size = float(np.linalg.norm(residual(trial)))
                if trial_size < best_size:
                    best, best_size = trial, trial_size
                    break
                delta *= 0.5
            if best is qvel:  # no step along this direction reduces the residual: a kink; keep the best
                break
            qvel = best
        return qvel

    def _finish(self, time: float, steps: int, owners: list[int], wrench: np.ndarray) -> None:
        """Counts the step, adds its loads to the means, and raises :class:`terrasph.InstabilityError`
        if MuJoCo met a state it could not integrate (and reset the robot)."""
        self._steps += 1
        for i, k in enumerate(owners):
            self._sums[k] += wrench[i] * self._dt
        if divergences(self.robot.data) > self._divergences:
            raise divergence_error(f"at step {steps}", steps, time)

    def advance(self, t_end: float, max_steps: int = 2**62, control: Callable[[Any], None] | None = None) -> int:
        """Steps until `t_end` (s) is reached or passed, at most `max_steps`; returns the number taken.
        `control`, if given, is called with the stepper every ``control_interval`` of simulated time
        (at its multiples), its commands held in between (:meth:`control_span`)."""
        taken, interval = 0, self._control_steps * self._dt
        while taken < max_steps and self.time < t_end * (1 - 1e-14):
            if control and self._steps % self._control_steps == 0:
                self._span = interval
                control(self)
            self.step()
            taken += 1
        return taken

    # -- what the run loop records --------------------------------------------------------------
    def describe(self) -> dict[str, Any]:
        """The terrain and the coupled bodies, for the run file."""
        return {"terrain": {"kind": "rft3d", "surface": self.robot.surface, "zeta": self.table.zeta,
                            "coefficients": dict(self.table.coefficients),
                            "source": self.table.source, "time_step": self._dt,
                            "elements": {b.name: len(b.elements) for b in self.robot.coupled}},
                "robot": {"coupled": [b.name for b in self.robot.coupled], "mujoco": mujoco.__version__}}

    def body_sample(self, k: int) -> dict[str, Any]:
        """Coupled body `k`'s RFT force (N) and torque (N·m, about its centre of mass), world frame,
        averaged since :meth:`reset_body_means` (the load of each step weighted by its dt; the load
        now before any step), and its lowest element's z (m)."""
        body, data = self.robot.coupled[k], self.robot.data
        span = self.time - self._since
        if span > 0:
            wrench = self._sums[k] / span
        else:
            mujoco.mj_forward(self.robot.model, data)
            owners, index, arm, normal, depth, area = self._submerged()
            wrench = np.zeros(6)
            if k in owners:
                twist = np.zeros((len(owners), 6))
                for i, owner in enumerate(owners):
                    velocity = np.zeros(6)  # [angular, linear] at the centre of mass, world axes
                    mujoco.mj_objectVelocity(self.robot.model, data, mujoco.mjtObj.mjOBJ_BODY,
                                             self.robot.coupled[owner].body_id, velocity, 0)
                    twist[i] = np.r_[velocity[3:], velocity[:3]]
                wrench = self._wrenches(twist, index, arm, normal, depth, area)[owners.index(k)]
        rotation = data.xmat[body.body_id].reshape(3, 3)
        lowest = float((data.xpos[body.body_id] + body.elements.centre @ rotation.T)[:, 2].min())
        return {"force": wrench[:3].copy(), "torque": wrench[3:].copy(), "lowest_z": lowest}

    def reset_body_means(self) -> None:
        """Starts a new averaging interval of the body loads."""
        self._sums[:] = 0.0
        self._since = self.time

    def frame_fields(self) -> dict[str, np.ndarray]:
        """A frame of the coupled bodies (no grains): their elements' centres seen from the side,
        ``body_position`` (x, z) m, and the velocities there, ``body_velocity`` (v_x, v_z) m/s."""
        data = self.robot.data
        positions, velocities = [], []
        for body in self.robot.coupled:
            b = body.body_id
            rotation = data.xmat[b].reshape(3, 3)
            points = data.xpos[b] + body.elements.centre @ rotation.T
            twist = np.zeros(6)
            mujoco.mj_objectVelocity(self.robot.model, data, mujoco.mjtObj.mjOBJ_XBODY, b, twist, 0)
            velocity = twist[3:] + np.cross(twist[:3], points - data.xpos[b])
            positions.append(points[:, [0, 2]])
            velocities.append(velocity[:, [0, 2]])
        return {"body_position": np.concatenate(positions), "body_velocity": np.concatenate(velocities)}

    def static_arrays(self) -> dict[str, np.ndarray]:
        """Each coupled body's elements in its frame (``/static/rft3d/<body>/...``) and the body of each
        row of the frames' body fields (``/static/bodies/index``)."""
        arrays = {"bodies/index": np.concatenate([np.full(len(b.elements), k, dtype=np.int32)
                                                  for k, b in enumerate(self.robot.coupled)])}
        for body in self.robot.coupled:
            arrays.update({f"rft3d/{body.name}/centre": body.elements.centre,
                           f"rft3d/{body.name}/normal": body.elements.normal,
                           f"rft3d/{body.name}/area": body.elements.area})
        return arrays

    def diagnostics(self) -> dict[str, float]:
        """A diagnostics row: the step count and dt (s); no grains to leak."""
        return {"step": self._steps, "dt": self._dt, "leaked_particles": 0}

    def run_attributes(self) -> dict[str, int]:
        """The counts of the run file's ``/run``: no grains, none leaked."""
        return {"granular_particles": 0, "wall_particles": 0, "leaked_particles": 0}

    # -- checkpoints ---------------------------------------------------------------------------
    def checkpoint(self, path: str | os.PathLike[str], progress: dict[str, Any] | None = None) -> pathlib.Path:
        """Writes MuJoCo's state and the stepper's memory (under ``progress["robot"]``) to `path`."""
        from terrasph.checkpoint import grain_free_state, write_checkpoint

        state = grain_free_state(self._steps)
        saved = {**mujoco_state(self.robot), "sums": self._sums.tolist(), "since": self._since}
        return write_checkpoint(path, state, self.describe(), {**(progress or {}), "robot": saved})

    def restore(self, path: str | os.PathLike[str]) -> dict[str, Any]:
        """Continues from a :meth:`checkpoint`; returns the rest of its progress."""
        from terrasph.checkpoint import CheckpointError, configuration_differences, read_checkpoint

        state, config, progress = read_checkpoint(path)
        differences = configuration_differences(config, self.describe())
        if differences or "robot" not in progress:
            raise CheckpointError(f"checkpoint {path} belongs to another RFT run: {', '.join(differences) or 'no robot'}")
        saved = progress.pop("robot")
        self._steps = int(state["counters"]["steps"])
        restore_mujoco_state(self.robot, saved)
        self._divergences = divergences(self.robot.data)
        self._sums = np.array(saved["sums"], dtype=float).reshape(-1, 6)
        self._since = float(saved["since"])
        return progress


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

        def off_axis(points: np.ndarray) -> np.ndarray:
            arm = np.atleast_2d(points) - model.jnt_pos[joint]
            return np.linalg.norm(arm - np.outer(arm @ axis, axis), axis=1)

        radius = float(off_axis(body.elements.centre).max())
        if off_axis(model.body_ipos[b])[0] <= WHEEL_BALANCE * radius:
            wheels[k] = (joint, radius)
    return wheels


class RobotLoads3D:
    """Recorder of the run loop for :class:`RFT3DCoupling`: per coupled body ``robot/<body>`` (time,
    position (3) m and quaternion (w, x, y, z) of its frame, velocity (3) m/s of its centre of mass
    and angular velocity (3) rad/s, world frame; force (3) N and torque (3) N·m about its centre of
    mass averaged over the sampling interval; lowest_z m, surface m, sinkage m = surface − lowest_z;
    for a wheel (:func:`wheel_radii`) also spin rad/s, its angular velocity about the hinge's axis a,
    forward_speed m/s, the velocity of the hinge's anchor along a × ẑ (where a positive spin rolls
    it), and slip, Eq. 4.8 of the two with the wheel's R (:func:`terrasph.robots.metrics.slip`; NaN
    while the axis is vertical)) and, for a robot with actuators, ``robot/actuators`` (time, qpos,
    qvel, ctrl, the robot's centre of mass com (3) m, actuator_force, power W)."""

    def __init__(self, coupled: RFT3DCoupling) -> None:
        self.coupled = coupled
        self.wheels = wheel_radii(coupled.robot)

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
