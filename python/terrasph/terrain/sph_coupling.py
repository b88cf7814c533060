"""Two-way coupling of a MuJoCo robot with the SPH terrain (docs/design.md §3.6, dissertation Eq. 4.1–4.7).

The coupled step from t_n to t_{n+1} = t_n + dt (docs/robots.md):

1. dt is the SPH step bound at t_n (``numerics.fixed_dt`` if set): both sides take the same dt.
2. The granular load of each coupled body at t_n — force and torque (N, N·m for its real width)
   from the SPH rate evaluation that ended the previous step (Eq. 3.24–3.25 / 4.6–4.7) — is put
   in MuJoCo's ``xfrc_applied`` (world frame, at the centre of mass, torque about +y = clockwise).
3. MuJoCo advances by dt (its integrator, default semi-implicit Euler): q_{n+1}, q̇_{n+1}, with the
   load held constant over the step (Eq. 4.4–4.5 done by MuJoCo, with joints, motors and gravity).
   A torque-limited velocity servo at its limit is given its force instead (below).
4. Each coupled body's pose and velocity at t_{n+1} and its acceleration over the step,
   a = (v_{n+1} − v_n)/dt and α = (ω_{n+1} − ω_n)/dt of the frame origin (for a body on its own
   slide–slide–hinge joints this is MuJoCo's q̈ of the step exactly), are given to
   :meth:`Simulation.set_body_kinematics` as the body's state at the end of the next SPH step.
5. The SPH takes one step of dt: the body particles move to the pose at t_{n+1} with velocity
   v_c + ω J r and wall acceleration a_c + α J r − ω² r (Eq. 4.1–4.3); its rate evaluation at
   t_{n+1} gives the load used in step 2 of the next coupled step.

The scheme is explicit (the load lags the body by one step), deterministic (MuJoCo runs
serially, the SPH is bitwise thread-count independent) and keeps the two clocks equal. A MuJoCo
step that cannot be integrated (MuJoCo then silently resets the robot) raises
:class:`terrasph.InstabilityError`, as an SPH blow-up does, so the run records it as unstable.

Torque-limited velocity servos (MJCF ``<velocity kv=...>`` with a ``forcerange``): MuJoCo's
implicit integrators take a servo's damping kv into the step's solve, but not while its force is
held at the limit, where the step is explicit and changes the joint speed by τ_max dt/M (M the
joint's inertia). Where kv dt > M that jump carries the speed past the servo's linear band
|ω_cmd − ω| < τ_max/kv to the limit on the other side, and the servo can lock into a swing of
±τ_max dt/M every step: a C-leg wheel of 4 cm legs at Δx = 5 mm (kv dt/M = 6–19), commanded
1.5 rad/s, swung between ±2.4 rad/s and barely advanced (slip 0.97 instead of 0.44) once the step
passed C = 0.55 on the wave speed (docs/archive/speed_history.md, eleventh round). So a servo whose force at
the step's start would be clamped takes the step as a plain force: the limit, or the smaller force
M·(ω_cmd − ω)/dt that brings the speed to the command by the step's end (the other loads aside),
which cannot carry it past. Within the limits it stays MuJoCo's servo, its damping implicit. The
caller's command and the model's servo are put back after the step.
"""

from __future__ import annotations

import dataclasses
import math
import os
import pathlib
import warnings
from collections.abc import Callable, Mapping
from typing import Any

import mujoco
import numpy as np

from terrasph import InstabilityError
from terrasph.config import ConfigError, Material, glass_beads
from terrasph.fidelity import scene_numerics
from terrasph.geometry import wall_layers_needed
from terrasph.mjcf.model import CoupledBody, PlanarRobot, check_planar, load_model
from terrasph.mjcf.terrain_robot import COUPLE_BELOW, terrain_robot
from terrasph.scene import Scene
from terrasph.simulation import Simulation

__all__ = [
    "ACCURATE_MASS_RATIO",
    "BED_NUMERICS",
    "KICK_HEIGHT",
    "MIN_MASS_RATIO",
    "SURFACE_MARGIN",
    "CoupledSimulation",
    "RobotStepper",
    "check_mass_ratio",
    "displaced_grain_mass",
    "divergences",
    "free_surface",
    "mujoco_derived",
    "mujoco_state",
    "mujoco_step",
    "planar_sph_bed",
    "restore_mujoco_state",
    "step_until",
    "undisturbed_surface",
    "unwrapped",
    "velocity_servos",
]

#: Smallest mass of a coupled body over the mass of the grains its shape displaces that the
#: explicit scheme accepts. Measured limit (docs/robots.md, benchmarks/validation/bench_robot_coupling.py):
#: a plate set down on the bed is thrown off it at 1.5e-4 and stays at 2e-4 (Δx = 5 mm); the
#: accepted range starts a factor 5 above that.
MIN_MASS_RATIO = 1e-3
#: Below this ratio (and above MIN_MASS_RATIO) the coupling warns: a driven leg-wheel turned by a
#: constant motor torque (its spin free, not held by a servo) is stable down to 5e-4 but its mean
#: spin departs from that of heavier wheels below 1e-2 (x5 at 1e-3; docs/robots.md,
#: benchmarks/validation/bench_robot_driven.py). A wheel whose spin a velocity servo holds is not affected.
ACCURATE_MASS_RATIO = 1e-2


#: What the bed needs at every fidelity: the Shepard filter every 100 steps and the density floor
#: ρ ≥ ρ0, as the chapter 3 legs (terrasph.scenes.leg_rotation.SCENE_NUMERICS).
BED_NUMERICS: dict[str, Any] = {"shepard_interval": 100, "density_floor": 1.0}

#: height (m) of the domain box above the container's walls: a grain kicked up at 3 m/s rises
#: v²/2g = 0.46 m
KICK_HEIGHT = 1.0


#: MuJoCo's warnings of a state it cannot integrate (non-finite or huge qacc, qpos, qvel): mj_step
#: then resets the data to the model's initial state and counts the warning instead of failing
_DIVERGENCE_WARNINGS = (mujoco.mjtWarning.mjWARN_BADQACC, mujoco.mjtWarning.mjWARN_BADQPOS,
                        mujoco.mjtWarning.mjWARN_BADQVEL)


def divergences(data: mujoco.MjData) -> int:
    """How many times MuJoCo has reset `data` after a state it could not integrate."""
    return sum(int(data.warning[warning].number) for warning in _DIVERGENCE_WARNINGS)


def divergence_error(steps: str, step: int, time: float, hint: str = "") -> InstabilityError:
    """The error of MuJoCo steps that could not be integrated (MuJoCo reset the robot's data): the run
    is unstable, as an SPH blow-up is (particle -1: no grain is at fault). `steps` says which steps
    ("at step 12", "within steps 3–9"), `step` and `time` (s) are the error's."""
    error = InstabilityError(f"MuJoCo could not integrate the robot's state (bad qacc, qpos or qvel) {steps}, "
                             f"t = {time:.6g} s, and reset it{hint}")
    error.step, error.time, error.particle, error.reason = step, time, -1, "robot"
    return error


def unwrapped(previous: float, wrapped: float) -> float:
    """The angle equal to `wrapped` modulo 2π nearest to `previous` (a step turns far less than π)."""
    return previous + math.remainder(wrapped - previous, 2.0 * math.pi)


def displaced_grain_mass(body: CoupledBody, grain_density: float) -> float:
    """Mass (kg) of the grains at `grain_density` (ρ0, kg/m³) that the body's shape displaces:
    ρ0 × (its particles' Δx × Δx cells) × its width."""
    return grain_density * len(body.shape) * body.shape.spacing ** 2 * body.width


def _check_mass_ratios(robot: PlanarRobot, grain_density: float) -> None:
    """Refuses a coupled body lighter than MIN_MASS_RATIO × the grains it displaces (:func:`check_mass_ratio`).
    The body's own MuJoCo mass counts, not what it is jointed to (conservative for a wheel on a chassis)."""
    for body in robot.coupled:
        check_mass_ratio(body.name, float(robot.model.body_mass[body.body_id]) / displaced_grain_mass(body, grain_density))


def check_mass_ratio(name: str, ratio: float, stacklevel: int = 4) -> None:
    """Refuses coupled body `name` whose mass over that of the grains its shape displaces, `ratio`,
    is below MIN_MASS_RATIO: the load lags the body by one step, and a body that light is thrown
    off the bed by it (docs/robots.md); warns below ACCURATE_MASS_RATIO (the warning points
    `stacklevel` frames up: the user's call)."""
    if ratio < MIN_MASS_RATIO:
        raise ConfigError(f"coupled body '{name}' is too light for the coupling: its mass over that of the "
                          f"grains it displaces is {ratio:.3g}, allowed >= {MIN_MASS_RATIO:g} (the explicit "
                          "scheme's stability limit, docs/robots.md); make it heavier")
    if ratio < ACCURATE_MASS_RATIO:
        warnings.warn(f"coupled body '{name}' is light for the coupling: its mass over that of the grains it "
                      f"displaces is {ratio:.3g}, below {ACCURATE_MASS_RATIO:g}; if it turns freely or under a torque "
                      "(not held by a velocity servo) its motion depends on its mass (docs/robots.md)",
                      RuntimeWarning, stacklevel=stacklevel)


@dataclasses.dataclass(frozen=True)
class _VelocityServo:
    """A torque-limited velocity servo of the robot: actuator `actuator`, force kv·(ctrl − gear·q̇)
    on joint DOF `dof`, held within [lower, upper] (N·m or N); `inertia` is the joint's inertia seen
    by the actuator, M/gear² (module docstring)."""

    actuator: int
    dof: int
    kv: float
    gear: float
    lower: float
    upper: float
    inertia: float

    def prepare(self, model: mujoco.MjModel, data: mujoco.MjData, command: float, dt: float) -> None:
        """Sets the actuator for a step of dt toward `command`: MuJoCo's servo while its force at the
        step's start is within the limits (its damping then implicit); else a plain force, the limit
        or the smaller force that brings the speed to the command by the step's end."""
        error = command - self.gear * float(data.qvel[self.dof])
        if self.lower <= self.kv * error <= self.upper:
            return  # the model's servo and the command, as restore() and the caller left them
        self._set(model, gain=1.0, damping=0.0)
        data.ctrl[self.actuator] = min(max(error * self.inertia / dt, self.lower), self.upper)

    def force(self, command: float, qvel: np.ndarray) -> tuple[float, float]:
        """The servo's force kv·(command − gear·q̇) held within its limits at joint velocities `qvel`,
        and its derivative in the joint's velocity (−kv·gear within the limits, 0 at them)."""
        raw = self.kv * (command - self.gear * float(qvel[self.dof]))
        if raw <= self.lower:
            return self.lower, 0.0
        if raw >= self.upper:
            return self.upper, 0.0
        return raw, -self.kv * self.gear

    def apply_force(self, model: mujoco.MjModel, data: mujoco.MjData, force: float) -> None:
        """Sets the actuator to a plain force for the next step (:meth:`restore` puts the servo back)."""
        self._set(model, gain=1.0, damping=0.0)
        data.ctrl[self.actuator] = force

    def restore(self, model: mujoco.MjModel) -> None:
        """The servo as the model defines it."""
        self._set(model, gain=self.kv, damping=-self.kv)

    def _set(self, model: mujoco.MjModel, gain: float, damping: float) -> None:
        model.actuator_gainprm[self.actuator, 0] = gain
        model.actuator_biasprm[self.actuator, 2] = damping


def _velocity_servos(model: mujoco.MjModel, data: mujoco.MjData) -> list[_VelocityServo]:
    """The model's torque-limited velocity servos: joint transmission, no activation, gain kv, bias
    −kv times the actuator's speed (MJCF ``<velocity>``), a force range and no control range (the
    force given in its place must not be clamped again); the joint's inertia from the mass matrix
    at `data`'s pose (a scratch copy; `data` is left untouched)."""
    scratch = mujoco.MjData(model)
    scratch.qpos[:] = data.qpos
    mujoco.mj_forward(model, scratch)
    mass_matrix = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, scratch, mass_matrix)
    servos = []
    for a in range(model.nu):
        kv = float(model.actuator_gainprm[a, 0])
        is_limited_velocity_servo = (model.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT
                                     and model.actuator_dyntype[a] == mujoco.mjtDyn.mjDYN_NONE
                                     and model.actuator_gaintype[a] == mujoco.mjtGain.mjGAIN_FIXED
                                     and model.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_AFFINE
                                     and kv > 0 and model.actuator_biasprm[a, 0] == 0
                                     and model.actuator_biasprm[a, 1] == 0 and model.actuator_biasprm[a, 2] == -kv
                                     and bool(model.actuator_forcelimited[a]) and not model.actuator_ctrllimited[a])
        if is_limited_velocity_servo:
            lower, upper = (float(f) for f in model.actuator_forcerange[a])
            dof = int(model.jnt_dofadr[model.actuator_trnid[a, 0]])
            gear = float(model.actuator_gear[a, 0])
            servos.append(_VelocityServo(a, dof, kv, gear, lower, upper, float(mass_matrix[dof, dof]) / gear**2))
    return servos


def mujoco_step(robot: PlanarRobot, servos: list[_VelocityServo], dt: float, *, derived: bool = True,
                forces: list[float] | None = None) -> None:
    """MuJoCo's step of dt with the loads already applied (steps 2–3 of the module docstring): each
    torque-limited velocity servo prepared for the step (or, with `forces`, given that plain force)
    and put back after it, the caller's command kept; with `derived`, poses and velocities brought to
    the step's end (else the caller does it with :func:`mujoco_derived` after changing the state)."""
    model, data = robot.model, robot.data
    model.opt.timestep = dt
    command = data.ctrl.copy()
    try:
        for k, servo in enumerate(servos):
            if forces is None:
                servo.prepare(model, data, float(command[servo.actuator]), dt)
            else:
                servo.apply_force(model, data, forces[k])
        mujoco.mj_step(model, data)
    finally:  # the model's servos and the caller's command stay the state (checkpoints, the next step)
        for servo in servos:
            servo.restore(model)
        data.ctrl[:] = command
    if derived:
        mujoco_derived(robot)


def mujoco_derived(robot: PlanarRobot) -> None:
    """Poses and velocities at the state's time: mj_step leaves the derived quantities at the step's start."""
    mujoco.mj_kinematics(robot.model, robot.data)
    mujoco.mj_comPos(robot.model, robot.data)
    mujoco.mj_comVel(robot.model, robot.data)


def mujoco_state(robot: PlanarRobot) -> dict[str, Any]:
    """MuJoCo's state (time, qpos, qvel, act, warm start, ctrl) as plain data (JSON floats round-trip
    exactly), for a checkpoint's progress, with the actuator forces and velocities of the last step,
    which a controller may read (the leg-wheel's motor work, their product) and mj_forward would not
    give back: a servo given its force for a step (at its torque limit) ends it with a force
    mj_forward would not recompute, and mj_step leaves the actuators' velocities at the step's start
    (:func:`mujoco_derived` brings the poses, not them, to its end)."""
    data = robot.data
    return {"time": data.time, "qpos": data.qpos.tolist(), "qvel": data.qvel.tolist(), "act": data.act.tolist(),
            "qacc_warmstart": data.qacc_warmstart.tolist(), "ctrl": data.ctrl.tolist(),
            "actuator_force": data.actuator_force.tolist(), "actuator_velocity": data.actuator_velocity.tolist()}


def restore_mujoco_state(robot: PlanarRobot, saved: dict[str, Any]) -> None:
    """Puts back a :func:`mujoco_state` (a checkpoint without actuator forces or velocities, from an
    earlier version, keeps mj_forward's)."""
    data = robot.data
    data.time = saved["time"]
    for key in ("qpos", "qvel", "act", "ctrl"):
        getattr(data, key)[:] = saved[key]
    mujoco.mj_forward(robot.model, data)
    data.qacc_warmstart[:] = saved["qacc_warmstart"]
    for key in ("actuator_force", "actuator_velocity"):
        if key in saved:
            getattr(data, key)[:] = saved[key]


def velocity_servos(robot: PlanarRobot) -> list[_VelocityServo]:
    """The robot's torque-limited velocity servos, for :func:`mujoco_step`."""
    return _velocity_servos(robot.model, robot.data)


def step_until(stepper: Any, t_end: float, max_steps: int, control: Callable[[Any], None] | None) -> int:
    """Takes `stepper`'s ``step()`` until its ``time`` reaches or passes `t_end` (s), at most
    `max_steps` steps, calling `control` (if given) with it before each; returns the number taken
    (the last step may end past `t_end`): the explicit couplings' advance, planar and 3D."""
    taken = 0
    while taken < max_steps and stepper.time < t_end * (1 - 1e-14):
        if control:
            control(stepper)
        stepper.step()
        taken += 1
    return taken


class RobotStepper:
    """What every stepper of a robot on a terrain shares (:class:`CoupledSimulation`, the RFT terrain's
    :class:`terrasph.terrain.rft_coupling.RFTCoupling`): `robot`, `time`, `step_count`, `step()` and
    the continuous angle of each coupled body in ``_angle``, set by the subclass. The run loop
    (terrasph.robots.run.run_coupled) reads the rest: describe, body_sample, surface,
    reset_body_means, frame_fields, static_arrays, diagnostics, run_attributes, checkpoint and restore."""

    robot: PlanarRobot
    _angle: dict[str, float]

    @property
    def time(self) -> float:
        raise NotImplementedError

    @property
    def step_count(self) -> int:
        raise NotImplementedError

    def step(self) -> float:
        raise NotImplementedError

    def time_step(self) -> float:
        raise NotImplementedError

    def control_span(self) -> float:
        """The simulated time (s) over which the commands a controller sets now are held: the next
        step (a stepper that calls its controller less often says otherwise)."""
        return self.time_step()

    def advance(self, t_end: float, max_steps: int = 2**62, control: Callable[[Any], None] | None = None) -> int:
        """Steps until `t_end` (s) is reached or passed, at most `max_steps`; returns the number
        taken (the last step may end past `t_end`). `control`, if given, is called with the stepper
        before each step (to set MuJoCo's ``data.ctrl``, say)."""
        return step_until(self, t_end, max_steps, control)

    def angle(self, name: str) -> float:
        """Clockwise angle (rad) of a coupled body, continuous over turns."""
        return self._angle[name]

    def robot_description(self) -> dict[str, Any]:
        """The coupled bodies (shape name, width) and MuJoCo's version, for the run file."""
        return {"couplings": {b.name: {"shape": b.shape.name, "width": b.width} for b in self.robot.coupled},
                "mujoco": mujoco.__version__}


class CoupledSimulation(RobotStepper):
    """A :class:`PlanarRobot` two-way coupled with a :class:`Simulation` whose scene holds its coupled
    bodies as driven bodies (add them with :meth:`PlanarRobot.add_to_scene`)."""

    def __init__(self, robot: PlanarRobot, sim: Simulation) -> None:
        names = {b.name: b for b in sim.bodies}
        for body in robot.coupled:
            if body.name not in names or not names[body.name].driven:
                raise ConfigError(f"coupled body '{body.name}' is not a driven body of the simulation's scene; "
                                  "add it with PlanarRobot.add_to_scene before building the Simulation")
        removed = [w.name for w in sim.scene.walls if w.remove_at is not None]
        if removed:
            raise ConfigError(f"wall(s) {removed} have a 'remove_at' time; a removal would cut an SPH step short "
                              "of MuJoCo's, which a coupled run does not support")
        _check_mass_ratios(robot, sim.material.reference_density)
        self.robot = robot
        self.sim = sim
        self._servos = _velocity_servos(robot.model, robot.data)
        #: the core's index of each coupled body (Simulation.bodies is in the core's order)
        self._core_index = {body.name: [b.name for b in sim.bodies].index(body.name) for body in robot.coupled}
        self.robot.data.time = sim.time
        self._angle = {b.name: robot.wrapped_angle(b) for b in robot.coupled}
        self._velocity = {b.name: robot.velocity(b) for b in robot.coupled}
        self._divergences = divergences(robot.data)

    @property
    def time(self) -> float:
        """Simulated time (s), the same on both sides."""
        return self.sim.time

    def time_step(self) -> float:
        """The next step's dt (s): the SPH's fixed step if set, else its stable bound."""
        fixed = self.sim.numerics.fixed_dt
        return fixed if fixed > 0 else float(self.sim.core.stable_time_step())

    def step(self) -> float:
        """One coupled step (module docstring); returns its dt."""
        dt = self.time_step()
        robot = self.robot
        for body in robot.coupled:
            force, torque = self.granular_load(body)
            robot.apply_load(body, force, torque)
        mujoco_step(robot, self._servos, dt)
        if divergences(robot.data) > self._divergences:
            raise self._diverged()
        for body in robot.coupled:
            self._drive(body, dt)
        t_end = self.sim.time + dt
        self.sim.advance(t_end, max_steps=1)
        if self.sim.core.last_dt != dt:  # cannot happen without wall removals, refused in __init__
            raise RuntimeError(f"the SPH step was {self.sim.core.last_dt} s, MuJoCo's {dt} s")
        return dt

    def _diverged(self) -> InstabilityError:
        """The error of a MuJoCo step that could not be integrated (it reset the robot's data):
        the coupled run is unstable, as an SPH blow-up is (particle -1: no grain is at fault)."""
        return divergence_error(f"at step {self.sim.step_count}", self.sim.step_count, self.sim.time,
                                "; a smaller step (numerics.cfl) or a heavier body may help")

    def granular_load(self, body: CoupledBody) -> tuple[np.ndarray, float]:
        """Force (N) and clockwise torque (N·m, about the body origin) of the grains on `body` from the
        last rate evaluation, for its real width: ``force_now``/``torque_now`` of
        :meth:`Simulation.body_state` without that method's copy of every wall particle."""
        raw = self.sim.core.body_state(self._core_index[body.name])
        return np.asarray(raw["force"]) * body.width, raw["torque"] * body.width

    def _drive(self, body: CoupledBody, dt: float) -> None:
        """Hands MuJoCo's state of `body` at t_{n+1} to the SPH (step 4)."""
        velocity, omega = self.robot.velocity(body)
        old_velocity, old_omega = self._velocity[body.name]
        angle = unwrapped(self._angle[body.name], self.robot.wrapped_angle(body))
        self.sim.set_body_kinematics(body.name, self.robot.reference(body), angle, velocity, omega,
                                     (velocity - old_velocity) / dt, (omega - old_omega) / dt)
        self._angle[body.name] = angle
        self._velocity[body.name] = (velocity, omega)

    @property
    def step_count(self) -> int:
        """Coupled steps taken so far (the SPH's step count: one SPH step per coupled step)."""
        return self.sim.step_count

    def frame_fields(self) -> dict[str, np.ndarray]:
        """The SPH's frame fields and ``wall_position`` of every wall particle (id order), so the
        moving bodies can be drawn with the fixed walls (a run file's frames)."""
        return {**self.sim.frame_fields(), "wall_position": np.array(self.sim.core.wall_position)}

    # -- what a run loop records (terrasph.robots.run.run_coupled) ----------------------------
    def describe(self) -> dict[str, Any]:
        """The run's configuration for its file: the SPH's and the coupled bodies'."""
        return {**self.sim.describe(), "robot": self.robot_description()}

    def body_sample(self, name: str) -> dict[str, Any]:
        """Force (N) and clockwise torque (N·m) of the grains on coupled body `name`, averaged since
        :meth:`reset_body_means`, and its lowest z (m)."""
        state = self.sim.body_state(name)
        return {"force": state["force"], "torque": state["torque"], "lowest_z": state["lowest_z"]}

    def surface(self) -> float:
        """The bed's undisturbed free surface now (m; :func:`undisturbed_surface`)."""
        return undisturbed_surface(self)

    def wall_loads(self) -> dict[str, dict[str, Any]]:
        """Loads of the grains on each tracked fixed wall (:meth:`Simulation.wall_loads`)."""
        return self.sim.wall_loads()


    def reset_body_means(self) -> None:
        """Starts a new averaging interval of the coupled bodies' loads."""
        self.sim.reset_body_means()

    def static_arrays(self) -> dict[str, np.ndarray]:
        """The run file's static arrays (the SPH's)."""
        return self.sim.static_arrays()

    def diagnostics(self) -> dict[str, float]:
        """A diagnostics row of the run file (the SPH's)."""
        return self.sim.diagnostics()

    def run_attributes(self) -> dict[str, int]:
        """The counts of the run file's ``/run`` (the SPH's)."""
        return self.sim.run_attributes()

    # -- checkpoints ----------------------------------------------------------------------
    def checkpoint(self, path: str | os.PathLike[str], progress: dict[str, Any] | None = None) -> pathlib.Path:
        """Writes the SPH State with MuJoCo's state (under ``progress["robot"]``) to `path`."""
        return self.sim.checkpoint(path, {**(progress or {}), "robot": self.state()})

    def restore(self, path: str | os.PathLike[str]) -> dict[str, Any]:
        """Continues from a :meth:`checkpoint` bit for bit; returns the rest of its progress."""
        progress = self.sim.restore(path)
        if "robot" not in progress:
            raise ConfigError(f"checkpoint {path} holds no robot state; it was not written by a coupled run")
        self.restore_state(progress.pop("robot"))
        return progress

    def state(self) -> dict[str, Any]:
        """MuJoCo's state and the coupling's own memory as plain data (JSON floats round-trip
        exactly), for the ``progress`` of :meth:`Simulation.checkpoint`."""
        return {**mujoco_state(self.robot), "angle": dict(self._angle),
                "velocity": {k: [v.tolist(), w] for k, (v, w) in self._velocity.items()}}

    def restart(self) -> None:
        """The coupling's memory afresh for the state now in the robot's data, after its owner reset
        it (and put back a bed with the bodies where they are now): each body's angle and velocity
        read again from its pose and handed to the SPH as its kinematics, MuJoCo's clock set to the
        SPH's and its divergence count read again."""
        robot = self.robot
        robot.data.time = self.sim.time
        self._angle = {b.name: robot.wrapped_angle(b) for b in robot.coupled}
        self._velocity = {b.name: robot.velocity(b) for b in robot.coupled}
        self._divergences = divergences(robot.data)
        for body in robot.coupled:
            velocity, omega = self._velocity[body.name]
            self.sim.set_body_kinematics(body.name, tuple(robot.reference(body)), self._angle[body.name],
                                         tuple(velocity), omega)

    def restore_state(self, saved: dict[str, Any]) -> None:
        """Puts back a :meth:`state` (after :meth:`Simulation.restore` of the same checkpoint)."""
        restore_mujoco_state(self.robot, saved)
        self._divergences = divergences(self.robot.data)
        self._angle = {k: float(v) for k, v in saved["angle"].items()}
        self._velocity = {k: (np.array(v), float(w)) for k, (v, w) in saved["velocity"].items()}


#: columns of the bed closer than this (m) to a coupled body's x extent are disturbed by it (its
#: rut and the grains it pushes up) and left out of the free-surface level
SURFACE_MARGIN = 0.02


def free_surface(grains: np.ndarray, spacing: float, disturbed: list[tuple[float, float]],
                 margin: float) -> float:
    """Height (m) of the bed's undisturbed free surface: the grains (N × 2, x and z in m, on the
    lattice of `spacing` Δx) are binned into columns Δx wide, each column's surface is the top of
    its highest grain's cell (z + Δx/2), and the median is taken over the columns whose centre lies
    farther than `margin` from every `disturbed` interval [x_lo, x_hi] (the robot's parts). The
    median ignores a few grains thrown up above the bed. NaN if no column is left."""
    column = np.floor(grains[:, 0] / spacing).astype(np.int64)
    first = column.min()
    tops = np.full(column.max() - first + 1, -np.inf)
    np.maximum.at(tops, column - first, grains[:, 1] + 0.5 * spacing)
    centres = (np.arange(len(tops)) + first + 0.5) * spacing
    keep = np.isfinite(tops)
    for low, high in disturbed:
        keep &= (centres < low - margin) | (centres > high + margin)
    return float(np.median(tops[keep])) if keep.any() else float("nan")


def undisturbed_surface(coupled: CoupledSimulation, margin: float = SURFACE_MARGIN) -> float:
    """The bed's free surface now (m; :func:`free_surface`) away from every
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


def planar_sph_bed(mjcf: str | os.PathLike[str] | mujoco.MjModel, *, spacing: float, bed_width: float,
                   bed_depth: float, freeboard: float, fidelity: str, numerics: Mapping[str, Any] | None = None,
                   start_x: float | None = None, bodies: tuple[str, ...] = (), couple_below: float | None = COUPLE_BELOW,
                   widths: Mapping[str, float] | None = None, data: mujoco.MjData | None = None,
                   material: Material | None = None) -> tuple[PlanarRobot, Simulation]:
    """A planar model standing on an SPH bed of glass beads (`bed_width` × `bed_depth` m in its
    container, `freeboard` m of wall above it, particle spacing `spacing` m, the tier `fidelity`
    with `numerics` overrides; the bed's `material`, glass beads by default), its centre of mass at `start_x` (default mid-bed), coupled as
    :func:`terrasph.mjcf.terrain_robot.terrain_robot` chooses; with `data`, the caller's data of
    the compiled model `mjcf` is the robot's. ConfigError naming the joint or body of a model that
    is not planar. Returns the robot, added to the bed's scene, and the bed's simulation, for
    :func:`terrasph.terrain.interface.couple`."""
    _check_planar_model(mjcf, data)
    settings = scene_numerics("mjcf", fidelity, spacing, BED_NUMERICS, dict(numerics or {}))
    scene = Scene(spacing=spacing)
    surface, inner = scene.add_bed_in_container(bed_width, bed_depth, freeboard,
                                                layers=wall_layers_needed(settings.h_factor))
    # room above for grains a foot kicks up (a grain leaving the domain box stops the run)
    scene.domain_upper = (scene.domain_upper[0], surface + freeboard + KICK_HEIGHT)
    robot = terrain_robot(mjcf, spacing, surface, 0.5 * inner if start_x is None else start_x,
                          bodies=bodies, couple_below=couple_below, widths=widths, gravity=scene.gravity, data=data)
    robot.add_to_scene(scene)
    return robot, Simulation(scene, material or glass_beads(), settings)


def _check_planar_model(mjcf: str | os.PathLike[str] | mujoco.MjModel, data: mujoco.MjData | None = None) -> None:
    """ConfigError naming the first joint or body of the MJCF model (at the pose of `data`, if given)
    that is not planar, with the terrain that takes any model."""
    model = load_model(mjcf)
    data = mujoco.MjData(model) if data is None else data
    mujoco.mj_forward(model, data)
    try:
        check_planar(model, data)
    except ConfigError as error:
        raise ConfigError(f"{error}; the planar SPH terrain takes planar robots only: run this one on the 3D RFT "
                          "terrain, terrain 'rft' (--terrain rft), or on the 3D SPH bed (--terrain sph3d)") from None
