"""The Python face of a run: a scene + material + numerics turned into a core simulation, the
stepper that terrasph.run_loop runs (progress, HDF5 output, checkpoints, safe interruption), and
the recorders of its bodies' and fixed walls' loads."""

from __future__ import annotations

import dataclasses
import math
import os
import pathlib
import platform
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from terrasph import _core
from terrasph.config import ConfigError, Material, Numerics, as_dict, parameter_units
from terrasph.run_loop import checkpoint_path
from terrasph.scene import (
    Scene,
    earth_pressure_at_rest,
    geostatic_deviatoric_stress,
    geostatic_stress,
    hydrostatic_density,
)

__all__ = ["BodyLoads", "RunResult", "Simulation", "WallLoads", "checkpoint_path", "versions"]


def versions() -> dict[str, str]:
    """Versions of terrasph and the libraries that shape a result (saved with every run)."""
    import h5py

    from terrasph import __version__

    return {"terrasph": __version__, "numpy": np.__version__, "h5py": h5py.__version__,
            "python": platform.python_version()}


@dataclass
class RunResult:
    """What a run did: how far it got, how long it took, and where its output is."""

    time: float
    steps: int
    wall_time: float
    frames: int
    output: str | None
    status: str  # "completed", "at_rest", "interrupted" or "unstable"
    diagnostics: dict[str, list[float]] = field(default_factory=dict)
    #: per body: time series of pose and load as in :meth:`Simulation.body_state` (arrays)
    bodies: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)
    #: per fixed wall, when tracked: time series of its load as in :meth:`Simulation.wall_loads` (arrays)
    walls: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)


class BodyLoads:
    """Recorder of the run loop: each body's pose and load (:meth:`Simulation.body_state`) as
    ``bodies/<name>``, its means restarted after each sample."""

    def __init__(self, sim: Simulation) -> None:
        self.sim = sim
        self.groups = [f"bodies/{body.name}" for body in sim.bodies]

    def rows(self) -> dict[str, dict[str, Any]]:
        rows = {f"bodies/{body.name}": {"time": self.sim.time, **self.sim.body_state(body.name)}
                for body in self.sim.bodies}
        self.sim.reset_body_means()
        return rows


class WallLoads:
    """Recorder of the run loop: after :meth:`Simulation.track_wall_loads`, each fixed wall's load
    (:meth:`Simulation.wall_loads`) as ``walls/<name>``, its means restarted after each sample."""

    def __init__(self, sim: Simulation) -> None:
        self.sim = sim
        self.names = list(sim.wall_loads())
        self.groups = [f"walls/{name}" for name in self.names]

    def rows(self) -> dict[str, dict[str, Any]]:
        rows = {f"walls/{name}": {"time": self.sim.time, **load} for name, load in self.sim.wall_loads().items()}
        self.sim.reset_wall_load_means()
        return rows


#: The constitutive models that keep a stress state, so a bed at rest can hold K0 = 1 − sin φ.
STRESS_STATE_MODELS = ("mu_i_hypoelastic", "drucker_prager")


def _geostatic_hypoelastic(geostatic: bool | None, material: Material) -> bool:
    """Whether to start the hypoelastic μ(I) geostatic (None: yes, as every model with a stress
    state); ConfigError for True with a model without stress state."""
    if geostatic is None:
        geostatic = material.model in STRESS_STATE_MODELS
    if not isinstance(geostatic, bool):
        raise ConfigError(f"parameter 'geostatic' = {geostatic!r} is invalid: allowed True, False or None")
    if geostatic and material.model not in STRESS_STATE_MODELS:
        raise ConfigError(f"parameter 'geostatic' = True is invalid for material.model = '{material.model}': "
                          "allowed only with a model that keeps a stress state (mu_i_hypoelastic, drucker_prager)")
    return geostatic and material.model == "mu_i_hypoelastic"


class Simulation:
    """A granular SPH simulation in plane strain, built from a validated scene.

    The grains start at the density of the lithostatic pressure ρ0 g depth (``initial_density``
    overrides it). Every model with a stress state starts geostatic, σ_xx = σ_yy = K0 σ_zz with
    K0 = 1 − sin φ (Jáky): Drucker–Prager always; the hypoelastic μ(I) with mean stress
    ½(1 + K0) ρ0 g depth from the EOS and deviatoric stress ½(1 − K0) ρ0 g depth unless
    ``geostatic=False`` (an isotropic start, which an elastic bed at rest keeps: K ≈ 1). The rate
    models hold no shear at rest, so their beds are isotropic whatever ``geostatic`` says
    (``True`` is refused for them).

    Particle arrays (``position``, ``velocity``, ``density``, ``pressure``, ``stress``, any registered
    field through :meth:`field`) are read-only copies in particle-id order: the core may store
    particles in any order, and nothing handed out can dangle. To edit the state, assign
    (``sim.velocity = v``) or call :meth:`set_field`, then :meth:`refresh`. Wall arrays
    (``core.wall_position``, ``core.wall_group``, …) are id-ordered copies too.
    Granular masses are per metre of depth (m = ρ·Δx²); multiply by ``width`` for the real sample.
    """

    def __init__(self, scene: Scene, material: Material, numerics: Numerics, *,
                 initial_density: np.ndarray | None = None, width: float = 1.0, geostatic: bool | None = None) -> None:
        if not isinstance(material, Material):
            raise ConfigError("parameter 'material' must be a terrasph.Material")
        if not isinstance(numerics, Numerics):
            raise ConfigError("parameter 'numerics' must be a terrasph.Numerics")
        if not (width > 0 and math.isfinite(width)):
            raise ConfigError(f"parameter 'width' = {width!r} is invalid: allowed a finite number > 0 (m)")
        scene.validate(numerics)
        self.scene = scene
        self.material = material
        self.numerics = numerics
        self.width = width
        position = scene.granular_position
        depth = position[:, 1].max() + 0.5 * scene.spacing - position[:, 1]
        geostatic_hypoelastic = _geostatic_hypoelastic(geostatic, material)
        # the geostatic hypoelastic state's mean stress is ½(1 + K0) ρ0 g depth: its density and
        # δ-SPH's hydrostatic correction follow that share of the weight
        ratio = 0.5 * (1.0 + earth_pressure_at_rest(material)) if geostatic_hypoelastic else 1.0
        if geostatic_hypoelastic and numerics.density_diffusion_pressure_share == 0.0:
            numerics = dataclasses.replace(numerics, density_diffusion_pressure_share=ratio)
            self.numerics = numerics
        if initial_density is None:
            initial_density = hydrostatic_density(depth, material, scene.gravity, ratio)
        density = np.asarray(initial_density, dtype=float)
        if density.shape != (len(position),):
            raise ConfigError(f"parameter 'initial_density' must have shape ({len(position)},)")
        dx2 = scene.spacing**2
        walls = scene.wall_position
        wall_group = np.concatenate([np.full(len(w.position), w.group_id, np.int32) for w in scene.walls]) \
            if scene.walls else np.zeros(0, np.int32)
        wall_no_slip = np.concatenate([np.full(len(w.position), w.no_slip, np.uint8) for w in scene.walls]) \
            if scene.walls else np.zeros(0, np.uint8)
        self.core = _core.Simulation2D(
            self._core_params(),
            granular={"position": position, "velocity": np.zeros_like(position), "density": density,
                      "mass": density * dx2},
            walls={"position": walls, "normal": scene.wall_normal,
                   "mass": np.full(len(walls), material.reference_density * dx2),
                   "no_slip": wall_no_slip, "group": wall_group})
        for wall in scene.walls:
            if wall.remove_at is not None:
                self.core.schedule_wall_removal(wall.group_id, wall.remove_at)
        self.bodies = scene.bodies
        for body in self.bodies:
            if body.driven:
                self.core.add_driven_body(body.group_id, np.asarray(body.reference), body.angle)
            else:
                self.core.add_body(body.group_id, np.asarray(body.reference), body.angle, body.motion.rows())
        if material.model == "drucker_prager":  # its stress is state: start from the geostatic one
            self.core.set_field("stress_state", geostatic_stress(depth, material, scene.gravity))
            self.core.refresh()
        if geostatic_hypoelastic:
            self.core.set_field("deviatoric_stress", geostatic_deviatoric_stress(depth, material, scene.gravity))
            self.core.refresh()

    def _core_params(self) -> _core.ModelParams2D:
        params = _core.ModelParams2D()
        params.material = self.material.to_core()
        params.numerics = self.numerics.to_core()
        lower, upper = self.scene.domain()
        domain = params.domain
        domain.lower, domain.upper = lower, upper
        domain.gravity = np.array([0.0, -self.scene.gravity])
        params.domain = domain
        params.validate()
        return params

    # -- state ----------------------------------------------------------------------------
    @property
    def time(self) -> float:
        """Simulated time (s)."""
        return self.core.time

    @property
    def step_count(self) -> int:
        """Steps taken so far."""
        return self.core.step

    @property
    def position(self) -> np.ndarray:
        """Granular positions (N, 2), m, in id order (a read-only copy; assign to change them)."""
        return self.core.position

    @position.setter
    def position(self, values: np.ndarray) -> None:
        self.set_field("position", values)

    @property
    def velocity(self) -> np.ndarray:
        """Granular velocities (N, 2), m/s, in id order (a read-only copy; assign to change them)."""
        return self.core.velocity

    @velocity.setter
    def velocity(self, values: np.ndarray) -> None:
        self.set_field("velocity", values)

    @property
    def density(self) -> np.ndarray:
        """Granular densities (N,), kg/m³, in id order (a read-only copy; assign to change them)."""
        return self.core.density

    @density.setter
    def density(self, values: np.ndarray) -> None:
        self.set_field("density", values)

    @property
    def pressure(self) -> np.ndarray:
        """Granular pressures from the EOS (N,), Pa, in id order (a read-only copy)."""
        return self.core.pressure

    @property
    def stress(self) -> np.ndarray:
        """Granular Cauchy stress (N, 2, 2), Pa, in id order (a read-only copy)."""
        return self.core.stress

    @property
    def mass(self) -> np.ndarray:
        """Granular masses per metre of depth (N,), kg/m, in id order (a read-only copy)."""
        return self.core.mass

    def field(self, name: str, particles: str = "granular") -> np.ndarray:
        """A registered per-particle field of ``particles`` ("granular" or "walls") in id order: a
        read-only copy. ``core.field_names(particles)`` lists the names, ``core.field_units`` their units."""
        return self.core.field(name, particles)

    def set_field(self, name: str, values: np.ndarray, particles: str = "granular") -> None:
        """Overwrites a per-particle field, rows in id order; call :meth:`refresh` before stepping on."""
        self.core.set_field(name, np.asarray(values), particles)

    def kinetic_energy(self) -> float:
        """½ Σ m|v|² for the real width (J)."""
        v = self.core.velocity
        return 0.5 * float(np.dot(self.core.mass, np.einsum("ij,ij->i", v, v))) * self.width

    def body_state(self, name: str) -> dict[str, Any]:
        """Pose and load of a body, loads in N and N·m for its real width (docs/design.md §2).

        Keys: ``reference`` (x, z) m, ``angle`` rad and ``omega`` rad/s (clockwise-positive),
        ``velocity`` (vx, vz) m/s, ``acceleration`` (ax, az) m/s² and ``angular_acceleration`` rad/s²
        (zero for a prescribed schedule), ``force`` (F_x, F_z) N of the terrain on the body and ``torque``
        N·m (clockwise-positive, about the reference point), both averaged over the time since the
        last :meth:`reset_body_means` (a box filter over ``averaged_over`` s; the instant values are
        ``force_now`` and ``torque_now``), ``lowest_z`` m and, when the scene has a ``surface_level``, ``sinkage`` m.
        """
        index = self._body_index(name)
        body = self.bodies[index]
        raw = self.core.body_state(index)
        mask = np.asarray(self.core.wall_group) == body.group_id
        lowest = float(np.asarray(self.core.wall_position)[mask, 1].min() - 0.5 * self.scene.spacing)
        state = {"reference": np.asarray(raw["reference"]), "angle": raw["angle"],
                 "velocity": np.asarray(raw["velocity"]), "omega": raw["spin"],
                 "force": np.asarray(raw["mean_force"]) * body.width, "torque": raw["mean_torque"] * body.width,
                 "acceleration": np.asarray(raw["acceleration"]), "angular_acceleration": raw["angular_acceleration"],
                 "force_now": np.asarray(raw["force"]) * body.width, "torque_now": raw["torque"] * body.width,
                 "averaged_over": raw["averaged_over"], "lowest_z": lowest}
        if self.scene.surface_level is not None:
            state["sinkage"] = self.scene.surface_level - lowest
        return state

    def set_body_kinematics(self, name: str, reference: tuple[float, float], angle: float,
                            velocity: tuple[float, float], omega: float,
                            acceleration: tuple[float, float] = (0.0, 0.0), angular_acceleration: float = 0.0) -> None:
        """Pose (m; rad, clockwise), velocity (m/s; rad/s) and acceleration (m/s²; rad/s²) of a
        driven body at the end of the next step (docs/design.md §3.6): its particles follow at that step,
        and the acceleration enters its walls' pressure, a_w = a_c + α J r − ω² r (Eq. 3.31)."""
        index = self._body_index(name)
        if not self.bodies[index].driven:
            raise ConfigError(f"body '{name}' follows a prescribed motion; add it with driven=True to drive it")
        self.core.set_body_kinematics(index, np.asarray(reference, float), float(angle), np.asarray(velocity, float),
                                      float(omega), np.asarray(acceleration, float), float(angular_acceleration))

    def reset_body_means(self) -> None:
        """Restarts the time averages of body forces and torques."""
        self.core.reset_body_means()

    def track_wall_loads(self, about: tuple[float, float] = (0.0, 0.0)) -> None:
        """Keeps, from now on, the load of the grains on every fixed wall (a wall group that is not a
        body), its torque clockwise about the point `about` (x, z) m; :meth:`wall_loads` reads it
        and :meth:`run` records it. Off by default: a simulation that does not ask pays nothing.
        Re-evaluates the rates at the present state, so call it before the first step (the run is
        then bitwise the one without it). Refused with the active domain on (numerics.freeze_speed)."""
        point = np.asarray(about, dtype=float)
        if point.shape != (2,) or not np.isfinite(point).all():
            raise ConfigError(f"parameter 'about' = {about!r} is invalid: allowed a point (x, z) of finite numbers (m)")
        if self.numerics.freeze_speed > 0:
            raise ConfigError("wall loads cannot be tracked with the active domain on (numerics.freeze_speed > 0): "
                              "its frozen grains keep old rates")
        self.core.track_wall_loads(point)

    def wall_loads(self) -> dict[str, dict[str, Any]]:
        """Load of the grains on each fixed wall, by wall name, in N and N·m for the simulation's
        `width`, after :meth:`track_wall_loads`: ``force`` (F_x, F_z) of the grains on the wall and
        ``torque`` (clockwise, about the tracking point) averaged over ``averaged_over`` s since the
        last :meth:`reset_wall_load_means`, and the instant values ``force_now`` and ``torque_now``
        (Eq. 3.24–3.25 summed over the wall's particles). Empty when not tracked."""
        names = {wall.group_id: wall.name for wall in self.scene.walls}
        return {names[group]: {"force": np.asarray(raw["mean_force"]) * self.width,
                               "torque": raw["mean_torque"] * self.width,
                               "force_now": np.asarray(raw["force"]) * self.width,
                               "torque_now": raw["torque"] * self.width,
                               "averaged_over": raw["averaged_over"]}
                for group, raw in self.core.wall_loads().items()}

    def reset_wall_load_means(self) -> None:
        """Restarts the time averages of the fixed walls' loads."""
        self.core.reset_wall_load_means()

    def _body_index(self, name: str) -> int:
        for index, body in enumerate(self.bodies):
            if body.name == name:
                return index
        raise KeyError(f"no body named {name!r}; bodies: {[b.name for b in self.bodies]}")

    @property
    def leaked_particles(self) -> int:
        """Distinct granular particles that have been inside a wall or body (closer than Δx/2 to a
        wall particle) at any step so far: the leak counter of docs/design.md §3.5."""
        return int(self.core.penetrated_particles)

    def refresh(self) -> None:
        """Rebuilds neighbours and rates after the state was edited through a view."""
        self.core.refresh()

    def advance(self, t_end: float, max_steps: int = 2**62) -> int:
        """Steps to `t_end` (s), applying scheduled wall removals; returns the steps taken."""
        return int(self.core.advance(t_end, max_steps))

    # -- checkpoints ----------------------------------------------------------------------
    def checkpoint(self, path: str | os.PathLike[str], progress: dict[str, Any] | None = None) -> pathlib.Path:
        """Writes the whole State to `path` (HDF5, atomically); :meth:`restore` continues from it
        bit for bit. `progress` is the run loop's own state (plain data), kept with it."""
        from terrasph.checkpoint import write_checkpoint

        return write_checkpoint(path, self.core.state(), self.describe(), progress)

    def restore(self, path: str | os.PathLike[str]) -> dict[str, Any]:
        """Replaces the State by the one saved in `path` and returns the run loop's progress saved
        with it. The checkpoint must belong to this simulation's configuration (scene, material,
        numerics, width, bodies): anything else is refused with :class:`CheckpointError` naming
        the entries that differ, as is a corrupted, truncated or other-version file."""
        from terrasph.checkpoint import restore_core

        return restore_core(self.core, path, self.describe())

    # -- run loop -------------------------------------------------------------------------
    def run(self, t_end: float, *, output: str | os.PathLike | None = None, frame_interval: float = 0.05,
            progress: bool = True, config: dict[str, Any] | None = None,
            stop_when_at_rest: float | None = None, min_time: float = 0.0,
            on_frame: Callable[[Simulation], None] | None = None,
            body_interval: float = 0.01, checkpoint_every: float | None = 600.0,
            resume: bool = False) -> RunResult:
        """Runs to `t_end` (s), writing a frame every `frame_interval` (s) to `output` (HDF5),
        through :class:`terrasph.run_loop.RunLoop` (its output contract: docs/hdf5_schema.md).

        Every `body_interval` (s) each body's pose and load, averaged over the interval, is
        appended to ``/series/bodies/<name>`` and to ``RunResult.bodies``; after
        :meth:`track_wall_loads`, each fixed wall's load likewise to ``/series/walls/<name>`` and
        ``RunResult.walls`` (kept in checkpoints: call :meth:`track_wall_loads` with the same point
        before resuming).

        With ``stop_when_at_rest = r`` the run ends once t ≥ `min_time` and the kinetic energy per
        unit mass ½|v|² (mean) drops below r·g·Δx — a bed whose grains move less than about
        √(2r g Δx).

        With an `output`, the State is checkpointed to :func:`checkpoint_path` (`output` with
        ``.checkpoint.h5``) every `checkpoint_every` seconds of wall time (None: never), when the
        run ends, and when it is stopped by Ctrl-C (SIGINT) or SIGTERM: the run then ends at the
        next step boundary, the last frame is written, the file closed, and ``KeyboardInterrupt``
        raised. ``resume=True`` continues such a run — interrupted or finished — from its
        checkpoint into the same file (frames and series written after the checkpoint are dropped
        first, so each appears once); the continued run is bitwise identical to one that never
        stopped. `t_end` may then exceed the original one. An :class:`terrasph.InstabilityError`
        is recorded in the file before it propagates.
        """
        from terrasph.run_loop import RunLoop, check_run_options

        # the loop checks them too, under its own names: these are the caller's
        check_run_options({"frame_interval": frame_interval, "body_interval": body_interval}, checkpoint_every,
                          resume, output)
        rest_threshold = None if stop_when_at_rest is None else stop_when_at_rest * self.scene.gravity * self.scene.spacing
        total_mass = float(self.mass.sum()) * self.width

        def at_rest(row: dict[str, float]) -> bool:
            return row["time"] >= min_time and row["kinetic_energy"] / total_mass < rest_threshold

        recorders = [recorder for recorder in (BodyLoads(self), WallLoads(self)) if recorder.groups]
        loop = RunLoop(self, output, frame_interval, body_interval, recorders, config or self.describe(), versions(),
                       checkpoint_every, progress, at_rest if rest_threshold is not None else None,
                       (lambda: on_frame(self)) if on_frame else None)
        done = loop.run(t_end, resume)
        series = done.series
        diagnostics = {key: list(map(float, values)) for key, values in series.get("diagnostics", {}).items()}
        bodies = {b.name: dict(series.get(f"bodies/{b.name}", {})) for b in self.bodies}
        walls = {name: dict(series.get(f"walls/{name}", {})) for name in WallLoads(self).names}
        return RunResult(done.time, done.steps, done.wall_time, done.frames, os.fspath(output) if output else None,
                         done.status, diagnostics, bodies, walls)

    def static_arrays(self) -> dict[str, np.ndarray]:
        """The arrays a run file holds once (``/static``): grain masses and ids, the fixed walls'
        positions, groups and ids, and in a scene with bodies the id and body index of each row of
        the frames' ``body_*`` fields."""
        body = np.asarray(self.core.wall_body)  # body index of each wall particle, -1: a fixed wall
        arrays = {"granular/mass": np.array(self.mass), "granular/id": np.array(self.core.id)}
        for name in ("position", "group", "id"):
            arrays[f"walls/{name}"] = np.array(np.asarray(getattr(self.core, f"wall_{name}"))[body < 0])
        if self.bodies:
            arrays["bodies/id"] = np.array(np.asarray(self.core.wall_id)[body >= 0])
            arrays["bodies/index"] = np.array(body[body >= 0], dtype=np.int32)
        return arrays

    def diagnostics(self) -> dict[str, float]:
        """One row of ``/series/diagnostics`` (docs/hdf5_schema.md) but the time and wall time."""
        return {"step": self.step_count, "dt": self.core.last_dt, "kinetic_energy": self.kinetic_energy(),
                "max_speed": self.core.max_speed, "neighbour_builds": self.core.neighbour_builds,
                "leaked_particles": self.leaked_particles}

    def run_attributes(self) -> dict[str, int]:
        """Particle counts and the leak counter, for a run file's ``/run``."""
        return {"granular_particles": len(self.mass), "wall_particles": len(self.core.wall_position),
                "leaked_particles": self.leaked_particles}

    def frame_fields(self) -> dict[str, np.ndarray]:
        """Copies of the per-particle fields written to each frame: the grains' fields and, in a
        scene with bodies, ``body_position`` and ``body_velocity`` of every body particle (which
        body each belongs to is ``/static/bodies/index``)."""
        fields = {"position": np.array(self.position), "velocity": np.array(self.velocity),
                  "density": np.array(self.density), "pressure": np.array(self.pressure),
                  "stress": np.array(self.stress)}
        if self.bodies:
            on_body = np.asarray(self.core.wall_body) >= 0
            fields["body_position"] = np.array(np.asarray(self.core.wall_position)[on_body])
            fields["body_velocity"] = np.array(np.asarray(self.core.wall_velocity)[on_body])
        return fields

    def describe(self) -> dict[str, Any]:
        """Configuration of this simulation as plain data (saved with the output)."""
        return {"material": as_dict(self.material), "numerics": as_dict(self.numerics),
                "parameter_units": parameter_units(),
                "spacing": self.scene.spacing, "width": self.width, "gravity": self.scene.gravity,
                "walls": [{"name": w.name, "no_slip": w.no_slip, "remove_at": w.remove_at,
                           "particles": len(w.position)} for w in self.scene.walls],
                "bodies": [{"name": b.name, "shape": b.shape.name if b.shape else None, "reference": list(b.reference),
                            "angle": b.angle, "width": b.width, "motion": b.motion.rows(), "driven": b.driven,
                            "units": "force N and torque N*m for the body's width; angles clockwise"}
                           for b in self.bodies],
                "granular_particles": len(self.mass)}
