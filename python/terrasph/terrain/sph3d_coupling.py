"""A 3D MuJoCo model two-way coupled with a 3D SPH bed (``terrain="sph3d"`` of :func:`terrasph.terrain.attach`).

Each coupled body's collision geoms (sphere, capsule, cylinder, ellipsoid, box) are filled with particles
(:mod:`terrasph.sph3d`'s shells) in the body's frame and made one driven body of a
:func:`terrasph.sph3d.geostatic_bed` of glass beads whose free surface lies at the model's floor.
The coupled step is the planar coupling's (:mod:`terrasph.terrain.sph_coupling`), in 3D:

1. dt is the SPH step bound at t_n (``numerics.fixed_dt`` if set): both sides take the same dt.
2. Each coupled body's wrench from the grains at t_n (the rate evaluation that ended the previous
   SPH step; force and torque about the body's frame origin) is moved to its centre of mass,
   τ_com = τ_ref + (x_ref − x_com) × F, and put in MuJoCo's ``xfrc_applied`` (world axes).
3. MuJoCo takes a step of dt (:func:`terrasph.terrain.sph_coupling.mujoco_step`, its velocity servos
   handled as there).
4. Each body's frame pose (``xpos``, ``xquat``), its velocity and angular velocity at the frame
   origin (``mj_objectVelocity`` of the body frame, mjOBJ_XBODY; mjOBJ_BODY is the centre of mass's) at t_{n+1} and their change over the step / dt are
   the driven body's kinematics at the end of the next SPH step.
5. The SPH takes one step of dt; a body that has come within a kernel support of a side of the
   bed stops the run (:meth:`Coupled3D.check_sides`).

The scheme is explicit (the load lags the body by one step) and deterministic.
"""

from __future__ import annotations

import os
import pathlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

import mujoco
import numpy as np

from terrasph import InstabilityError
from terrasph.config import ConfigError, Material, Numerics, as_dict, parameter_units
from terrasph.geometry import wall_layers_needed
from terrasph.mjcf.geoms import is_collision_geom
from terrasph.sph3d import (
    Bed3D,
    BodyShape3D,
    bed_simulation,
    box,
    capsule,
    cylinder,
    ellipsoid,
    geostatic_bed,
    sphere,
)
from terrasph.sph3d_run import CoreOutputs
from terrasph.terrain.sph_coupling import (
    check_mass_ratio,
    divergence_error,
    divergences,
    mujoco_state,
    mujoco_step,
    restore_mujoco_state,
    step_until,
    velocity_servos,
)

__all__ = ["Coupled3D", "CoupledBody3D", "Robot3DOnBed", "bed_under", "body_shape_3d"]

#: the geom types filled with particles, and the shell of each from MuJoCo's ``geom_size``
_SHAPES = {
    mujoco.mjtGeom.mjGEOM_SPHERE: lambda size, dx, h: sphere(size[0], dx, h),
    mujoco.mjtGeom.mjGEOM_CAPSULE: lambda size, dx, h: capsule(size[0], size[1], dx, h),
    mujoco.mjtGeom.mjGEOM_CYLINDER: lambda size, dx, h: cylinder(size[0], size[1], dx, h),
    mujoco.mjtGeom.mjGEOM_BOX: lambda size, dx, h: box((size[0], size[1], size[2]), dx, h),
    mujoco.mjtGeom.mjGEOM_ELLIPSOID: lambda size, dx, h: ellipsoid((size[0], size[1], size[2]), dx, h),
}


def _geom_name(model: mujoco.MjModel, geom: int) -> str:
    return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, geom) or f"#{geom}"


def _rotation(quaternion: np.ndarray) -> np.ndarray:
    matrix = np.empty(9)
    mujoco.mju_quat2Mat(matrix, np.asarray(quaternion, float))
    return matrix.reshape(3, 3)


def body_shape_3d(model: mujoco.MjModel, body: int, name: str, spacing: float, h_factor: float) -> BodyShape3D:
    """The particles of body `body`'s collision geoms in the body's frame (each geom's shell moved by
    its ``geom_pos``, ``geom_quat``); ConfigError naming a geom of a type not filled (mesh,
    plane, …) or too thin for the wall layers, or a body without collision geom."""
    positions, normals = [], []
    for geom in range(model.ngeom):
        if model.geom_bodyid[geom] != body or not is_collision_geom(model, geom):
            continue
        kind = int(model.geom_type[geom])
        if kind not in _SHAPES:
            raise ConfigError(f"geom '{_geom_name(model, geom)}' of coupled body '{name}' is a "
                              f"{mujoco.mjtGeom(kind).name[7:].lower()}: the 3D SPH terrain fills sphere, capsule, "
                              "cylinder, ellipsoid and box geoms (give it contype=conaffinity=0, or leave its body out)")
        try:
            shell = _SHAPES[kind](model.geom_size[geom], spacing, h_factor)
        except ConfigError as error:
            raise ConfigError(f"geom '{_geom_name(model, geom)}' of coupled body '{name}': {error}") from None
        rotation = _rotation(model.geom_quat[geom])
        positions.append(shell.position @ rotation.T + model.geom_pos[geom])
        normals.append(shell.normal @ rotation.T)
    if not positions:
        raise ConfigError(f"coupled body '{name}' has no collision geom to meet the sand with")
    return BodyShape3D(name, np.concatenate(positions), np.concatenate(normals), spacing)


def bed_under(extent: tuple[np.ndarray, np.ndarray], surface: float, size: Sequence[float] | None, margin: float,
              depth: float, material: Material, spacing: float, h_factor: float, rim: float) -> Bed3D:
    """A geostatic bed `depth` (m) deep whose free surface is at z = `surface`, centred under the
    horizontal `extent` (lower, upper corners; m) and `size` (x, y; m) across, or the extent with
    `margin` (m) on each side."""
    lower, upper = extent
    across = upper[:2] - lower[:2] + 2.0 * margin if size is None else np.asarray(size, float)
    bed = geostatic_bed((float(across[0]), float(across[1]), depth), material, spacing, h_factor=h_factor, rim=rim)
    shift = np.array([0.5 * (lower[0] + upper[0] - bed.size[0]), 0.5 * (lower[1] + upper[1] - bed.size[1]),
                      surface - bed.size[2]])
    granular = {**bed.granular, "position": bed.granular["position"] + shift}
    walls = {**bed.walls, "position": bed.walls["position"] + shift}
    return replace(bed, granular=granular, walls=walls)


@dataclass(frozen=True)
class CoupledBody3D:
    """A coupled MuJoCo body: its name, id and particles (its frame)."""

    name: str
    body_id: int
    shape: BodyShape3D


class Robot3DOnBed:
    """The model and data a MuJoCo step of :func:`terrasph.terrain.sph_coupling.mujoco_step` moves,
    the `coupled` bodies and the bed's free surface z (m): what a run's recorders read of a robot
    (as of :class:`terrasph.terrain.rft3d_coupling.Robot3D`)."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, coupled: Sequence[CoupledBody3D],
                 surface: float) -> None:
        self.model, self.data, self.coupled, self.surface = model, data, list(coupled), float(surface)


class Coupled3D(CoreOutputs):
    """The 3D model's `coupled` bodies on an SPH `bed` (module docstring); the domain reaches
    `headroom` (m) above the surface for grains a foot kicks up."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, coupled: Sequence[CoupledBody3D], bed: Bed3D,
                 surface: float, material: Material, numerics: Numerics, headroom: float) -> None:
        self.model, self.data, self.coupled = model, data, list(coupled)
        self.material, self.numerics, self.surface = material, numerics, surface
        for body in self.coupled:  # the grains its particles' cells displace
            displaced = material.reference_density * len(body.shape.position) * body.shape.spacing ** 3
            check_mass_ratio(body.name, float(model.body_mass[body.body_id]) / displaced, stacklevel=5)  # attach's caller
        walls = []
        for k, body in enumerate(self.coupled):
            n = len(body.shape.position)
            walls.append({"position": self._world(body, body.shape.position),
                          "normal": body.shape.normal @ _rotation(data.xquat[body.body_id]).T,
                          "mass": np.full(n, material.reference_density * body.shape.spacing ** 3),
                          "no_slip": np.ones(n, np.uint8), "group": np.full(n, 2 + k, np.int32)})
        extra = {key: np.concatenate([w[key] for w in walls]) for key in walls[0]}
        every = np.concatenate([bed.walls["position"], extra["position"]])
        reach = wall_layers_needed(numerics.h_factor) * numerics.spacing + headroom
        lower = every.min(axis=0) - reach
        upper = np.maximum(every.max(axis=0), [0.0, 0.0, surface + headroom]) + reach
        upper[:2] = every.max(axis=0)[:2] + reach
        self.bed, self.lower, self.upper = bed, lower, upper
        grains = bed.granular["position"]
        half = 0.5 * numerics.spacing
        #: the inner faces of the bed's side walls (x, y; m): low corner, high corner
        self.sides = (grains[:, :2].min(axis=0) - half, grains[:, :2].max(axis=0) + half)
        self.core = bed_simulation(bed, material, numerics, lower, upper, extra)
        self._index = [self.core.add_driven_body(2 + k, np.array(data.xpos[b.body_id]),
                                                 np.array(data.xquat[b.body_id])) for k, b in enumerate(self.coupled)]
        self.robot = Robot3DOnBed(model, data, self.coupled, surface)
        self._servos = velocity_servos(self.robot)  # type: ignore[arg-type]
        self.restart()

    def _world(self, body: CoupledBody3D, points: np.ndarray) -> np.ndarray:
        return points @ _rotation(self.data.xquat[body.body_id]).T + self.data.xpos[body.body_id]

    @property
    def time(self) -> float:
        """Simulated time (s), the same on both sides."""
        return float(self.core.time)

    @property
    def step_count(self) -> int:
        """Coupled steps so far (one SPH step each)."""
        return int(self.core.step)

    @property
    def leaked_particles(self) -> int:
        """Grains that ever got past a wall's surface row."""
        return int(self.core.penetrated_particles)

    def time_step(self) -> float:
        """The next step's dt (s): the SPH's fixed step if set, else its stable bound."""
        fixed = self.numerics.fixed_dt
        return fixed if fixed > 0 else float(self.core.stable_time_step())

    def _rates(self, body: CoupledBody3D) -> tuple[np.ndarray, np.ndarray]:
        """Velocity and angular velocity (world axes) of the body's frame origin now."""
        rates = np.empty(6)
        mujoco.mj_objectVelocity(self.model, self.data, mujoco.mjtObj.mjOBJ_XBODY, body.body_id, rates, 0)
        return rates[3:].copy(), rates[:3].copy()

    def _at_com(self, body: CoupledBody3D, force: np.ndarray, torque: np.ndarray) -> np.ndarray:
        """An ``xfrc_applied`` row: the force, the torque about the frame origin moved to the centre of
        mass, τ_com = τ_ref + (x_ref − x_com) × F."""
        offset = self.data.xpos[body.body_id] - self.data.xipos[body.body_id]
        return np.concatenate([force, torque + np.cross(offset, force)])

    def step(self) -> float:
        """One coupled step (module docstring); returns its dt."""
        dt = self.time_step()
        for body, index in zip(self.coupled, self._index):
            raw = self.core.body_state(index)
            self.data.xfrc_applied[body.body_id] = self._at_com(body, np.asarray(raw["force"]),
                                                                np.asarray(raw["torque"]))
        before = divergences(self.data)
        mujoco_step(self.robot, self._servos, dt)  # type: ignore[arg-type]
        if divergences(self.data) > before:
            raise divergence_error(f"at step {self.step_count}", self.step_count, self.time,
                                   "; a smaller step (numerics.cfl) or a heavier body may help")
        for body, index in zip(self.coupled, self._index):
            velocity, omega = self._rates(body)
            old_velocity, old_omega = self._velocity[body.name]
            self.core.set_body_kinematics(index, np.array(self.data.xpos[body.body_id]),
                                          np.array(self.data.xquat[body.body_id]), velocity, omega,
                                          (velocity - old_velocity) / dt, (omega - old_omega) / dt)
            self._velocity[body.name] = (velocity, omega)
        self.core.advance(self.core.time + dt, 1)
        self.check_sides()
        return dt

    def advance(self, t_end: float, max_steps: int = 2**62, control: Callable[[Any], None] | None = None) -> int:
        """Steps until `t_end` (s) is reached or passed, at most `max_steps`; returns the number taken.
        `control`, if given, is called with the coupling before each step."""
        return step_until(self, t_end, max_steps, control)

    def check_sides(self) -> None:
        """:class:`terrasph.InstabilityError` naming the first coupled body with a particle within
        a kernel support and a spacing (2h + Δx) of a side wall of the bed, lower than that above the
        surface: grains between them would be squeezed against the fixed wall, which does not yield
        as the bed beyond it would."""
        reach = (2.0 * self.numerics.h_factor + 1.0) * self.numerics.spacing
        low, high = self.sides
        for body in self.coupled:
            points = self._world(body, body.shape.position)
            near = points[points[:, 2] < self.surface + reach]
            if len(near) and (np.any(near[:, :2] < low + reach) or np.any(near[:, :2] > high - reach)):
                error = InstabilityError(
                    f"coupled body '{body.name}' reached a side of the 3D bed (x, y in [{low[0]:.4g}, {high[0]:.4g}] × "
                    f"[{low[1]:.4g}, {high[1]:.4g}] m) at t = {self.time:.6g} s; widen the bed (bed_size or "
                    "bed_margin of attach, --bed-margin of terrasph run mjcf)")
                error.step, error.time, error.particle, error.reason = self.step_count, self.time, -1, "bed side"
                raise error

    def reset_body_means(self) -> None:
        """Starts a new averaging interval of the bodies' loads."""
        self.core.reset_body_means()

    def mean_load(self, k: int) -> np.ndarray:
        """Body `k`'s mean load since :meth:`reset_body_means` as an ``xfrc_applied`` row (force N,
        torque N·m about its centre of mass now, world axes)."""
        raw = self.core.body_state(self._index[k])
        return self._at_com(self.coupled[k], np.asarray(raw["mean_force"]), np.asarray(raw["mean_torque"]))

    def lowest_z(self, k: int) -> float:
        """The lowest z (m) of body `k`'s particles now."""
        owner = np.asarray(self.core.wall_body)
        return float(np.asarray(self.core.wall_position)[owner == self._index[k], 2].min())

    def state(self) -> dict[str, Any]:
        """The coupling's own memory (each body's last rates) as plain data (JSON floats round-trip
        exactly); the SPH's is its core's state."""
        return {"velocity": {k: [v.tolist(), w.tolist()] for k, (v, w) in self._velocity.items()}}

    def restore_state(self, saved: dict[str, Any]) -> None:
        """Puts back a :meth:`state` (after the core's state of the same moment)."""
        self._velocity = {k: (np.array(v), np.array(w)) for k, (v, w) in saved["velocity"].items()}

    def restart(self) -> None:
        """The bodies' rates read again from MuJoCo's data (derived quantities current) and handed to
        the SPH with their poses; MuJoCo's clock set to the SPH's."""
        self.data.time = self.time
        self._velocity = {b.name: self._rates(b) for b in self.coupled}
        zero = np.zeros(3)
        for body, index in zip(self.coupled, self._index):
            velocity, omega = self._velocity[body.name]
            self.core.set_body_kinematics(index, np.array(self.data.xpos[body.body_id]),
                                          np.array(self.data.xquat[body.body_id]), velocity, omega, zero, zero)

    # -- what a run loop records (terrasph.robots.run.run_coupled) ------------------------------
    def body_sample(self, k: int) -> dict[str, Any]:
        """Coupled body `k`'s load (force N, torque N·m about its centre of mass, world axes) averaged
        since :meth:`reset_body_means` (:meth:`mean_load`), and the lowest z (m) of its particles."""
        load = self.mean_load(k)
        return {"force": load[:3].copy(), "torque": load[3:].copy(), "lowest_z": self.lowest_z(k)}

    def describe(self) -> dict[str, Any]:
        """The bed, its grains and the coupled bodies, for the run file and its checkpoints."""
        return {"dimensions": 3, "spacing": self.numerics.spacing, "parameter_units": parameter_units(),
                "terrain": {"kind": "sph3d", "surface": self.surface, "bed_size": list(self.bed.size),
                            "domain": [self.lower.tolist(), self.upper.tolist()],
                            "material": as_dict(self.material), "numerics": as_dict(self.numerics)},
                "robot": {"coupled": [b.name for b in self.coupled], "mujoco": mujoco.__version__,
                          "particles": {b.name: len(b.shape.position) for b in self.coupled},
                          "units": "force N, torque N*m about each body's centre of mass, world axes"}}

    # -- checkpoints ----------------------------------------------------------------------------
    def checkpoint(self, path: str | os.PathLike[str], progress: dict[str, Any] | None = None) -> pathlib.Path:
        """Writes the SPH's State with MuJoCo's state and the coupling's memory (under
        ``progress["robot"]``) to `path`."""
        from terrasph.checkpoint import write_checkpoint

        robot = {**mujoco_state(self.robot), **self.state()}  # type: ignore[arg-type]
        return write_checkpoint(path, self.core.state(), self.describe(), {**(progress or {}), "robot": robot})

    def restore(self, path: str | os.PathLike[str]) -> dict[str, Any]:
        """Continues from a :meth:`checkpoint` of the same configuration, bit for bit; returns the rest
        of its progress."""
        from terrasph.checkpoint import CheckpointError, restore_core

        progress = restore_core(self.core, path, self.describe())
        if "robot" not in progress:
            raise CheckpointError(f"checkpoint {path} holds no robot state; it was not written by a coupled run")
        saved = progress.pop("robot")
        restore_mujoco_state(self.robot, saved)  # type: ignore[arg-type]
        self.restore_state(saved)
        return progress
