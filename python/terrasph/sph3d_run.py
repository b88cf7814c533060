"""A 3D granular SPH simulation on the one run loop (:class:`terrasph.run_loop.RunLoop`): the
stepper of a bed built by :func:`terrasph.sph3d.geostatic_bed` with rigid bodies on
``_core.Simulation3D`` (docs/sph3d.md). It writes what every run writes (docs/hdf5_schema.md):
frames (XDMF sidecars with XYZ geometry), each body's pose and load as a series, the run's status,
and a checkpoint from which a run continues bit for bit."""

from __future__ import annotations

import os
import pathlib
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from terrasph.config import ConfigError, Material, Numerics, as_dict, parameter_units
from terrasph.simulation import BodyLoads, RunResult, versions
from terrasph.sph3d import Bed3D, BodyShape3D, bed_simulation, body_walls

__all__ = ["Body3D", "CoreOutputs", "Simulation3D", "diagnostics", "frame_fields", "kinetic_energy", "run_attributes",
           "static_arrays"]


@dataclass(frozen=True)
class Body3D:
    """A rigid body of a 3D run: its particles (``shape``, in its own frame), where its reference
    point starts, its starting orientation (unit quaternion w, x, y, z), and its prescribed motion:
    rows (duration s, velocity (3) m/s, angular velocity (3) rad/s) from t = 0, still after the last."""

    name: str
    shape: BodyShape3D
    reference: tuple[float, float, float]
    orientation: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    motion: tuple[tuple[float, ...], ...] = field(default_factory=tuple)


class CoreOutputs:
    """What the run loop reads of a 3D core for its output, for a class holding the core as `core`
    (:class:`Simulation3D`, the coupled robot's :class:`terrasph.terrain.sph3d_coupling.Coupled3D`)."""

    core: Any

    def frame_fields(self) -> dict[str, np.ndarray]:
        """The grains' and body particles' fields of a frame (:func:`frame_fields`)."""
        return frame_fields(self.core)

    def static_arrays(self) -> dict[str, np.ndarray]:
        """The arrays written once (:func:`static_arrays`)."""
        return static_arrays(self.core)

    def diagnostics(self) -> dict[str, float]:
        """One row of ``/series/diagnostics`` but the time and wall time (:func:`diagnostics`)."""
        return diagnostics(self.core)

    def run_attributes(self) -> dict[str, int]:
        """Particle counts and the leak counter, for a run file's ``/run``."""
        return run_attributes(self.core)


class Simulation3D(CoreOutputs):
    """A bed with bodies in 3D, as a run-loop stepper. Loads are whole (N, N·m), torques about each
    body's reference point, right-handed."""

    def __init__(self, bed: Bed3D, material: Material, numerics: Numerics, lower: np.ndarray, upper: np.ndarray,
                 bodies: tuple[Body3D, ...] = ()) -> None:
        names = [b.name for b in bodies]
        if len(set(names)) != len(names):
            raise ConfigError(f"parameter 'bodies' has repeated names {names}: allowed distinct names")
        groups = {name: 2 + k for k, name in enumerate(names)}  # after the bed's floor (0) and sides (1)
        extra = None
        for body in bodies:
            walls = body_walls(body.shape, np.asarray(body.reference), groups[body.name], material, body.orientation)
            extra = walls if extra is None else {k: np.concatenate([extra[k], walls[k]]) for k in walls}
        self.bed, self.material, self.numerics = bed, material, numerics
        self.lower, self.upper = np.asarray(lower, float), np.asarray(upper, float)
        self.core = bed_simulation(bed, material, numerics, self.lower, self.upper, extra)
        self.bodies = bodies
        self._index = {}
        for body in bodies:
            try:
                self._index[body.name] = self.core.add_body(groups[body.name], np.asarray(body.reference, float),
                                                            np.asarray(body.orientation, float),
                                                            [list(row) for row in body.motion])
            except ValueError as error:
                raise ConfigError(f"body {body.name!r}: {error}") from None

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
    def leaked_particles(self) -> int:
        """Grains that ever got past a wall's surface row (the leak counter)."""
        return self.core.penetrated_particles

    def advance(self, t_end: float, max_steps: int = 2**62) -> int:
        """At most `max_steps` steps toward `t_end` (s); InstabilityError on a blow-up."""
        return self.core.advance(t_end, max_steps)

    def body_state(self, name: str) -> dict[str, Any]:
        """Pose, rates and load of body `name`: reference (m), orientation (w, x, y, z), velocity,
        angular_velocity, force (N) and torque (N·m, about the reference point) at the last step and
        their means since the last :meth:`reset_body_means`."""
        if name not in self._index:
            raise ConfigError(f"no body {name!r}: allowed one of {sorted(self._index)}")
        raw = self.core.body_state(self._index[name])
        return {key: np.asarray(value) if isinstance(value, (list, np.ndarray)) else value for key, value in raw.items()
                if key != "driven"}

    def reset_body_means(self) -> None:
        """Restarts the time averages of every body's load."""
        self.core.reset_body_means()

    def kinetic_energy(self) -> float:
        """½ Σ m |v|² of the grains (J)."""
        return kinetic_energy(self.core)

    # -- run loop -------------------------------------------------------------------------
    def checkpoint(self, path: str | os.PathLike[str], progress: dict[str, Any] | None = None) -> pathlib.Path:
        """Writes the whole State to `path` (HDF5, atomically), with the run loop's `progress`."""
        from terrasph.checkpoint import write_checkpoint

        return write_checkpoint(path, self.core.state(), self.describe(), progress)

    def restore(self, path: str | os.PathLike[str]) -> dict[str, Any]:
        """Replaces the State by the one saved in `path` (of this configuration only) and returns the
        run loop's progress saved with it."""
        from terrasph.checkpoint import restore_core

        return restore_core(self.core, path, self.describe())

    def describe(self) -> dict[str, Any]:
        """Configuration of this simulation as plain data (saved with the output and checkpoints)."""
        return {"dimensions": 3, "material": as_dict(self.material), "numerics": as_dict(self.numerics),
                "parameter_units": parameter_units(), "spacing": self.numerics.spacing,
                "bed_size": list(self.bed.size), "domain": [self.lower.tolist(), self.upper.tolist()],
                "bodies": [{"name": b.name, "shape": b.shape.name, "particles": len(b.shape.position),
                            "reference": list(b.reference), "orientation": list(b.orientation),
                            "motion": [list(row) for row in b.motion],
                            "units": "force N, torque N*m about the reference point; orientation a unit "
                                     "quaternion (w, x, y, z)"} for b in self.bodies]}

    def run(self, t_end: float, *, output: str | os.PathLike[str] | None = None, frame_interval: float = 0.05,
            body_interval: float = 0.01, progress: bool = False, config: dict[str, Any] | None = None,
            checkpoint_every: float | None = 600.0, resume: bool = False) -> RunResult:
        """Runs to `t_end` (s) through the run loop, with its output contract (as
        :meth:`terrasph.simulation.Simulation.run`): frames every `frame_interval`, each body's
        pose and mean load every `body_interval` under ``/series/bodies/<name>``, checkpoints,
        ``resume`` bitwise."""
        from terrasph.run_loop import RunLoop

        recorders = [BodyLoads(self)] if self.bodies else []  # type: ignore[arg-type]
        loop = RunLoop(self, output, frame_interval, body_interval, recorders, config or self.describe(), versions(),
                       checkpoint_every, progress)
        done = loop.run(t_end, resume)
        series = done.series
        diagnostics = {key: list(map(float, values)) for key, values in series.get("diagnostics", {}).items()}
        bodies = {b.name: dict(series.get(f"bodies/{b.name}", {})) for b in self.bodies}
        return RunResult(done.time, done.steps, done.wall_time, done.frames, os.fspath(output) if output else None,
                         done.status, diagnostics, bodies, {})


# -- what every run of a 3D core writes (the bed with bodies here, a MuJoCo model on a bed in
# terrasph.terrain.sph3d_coupling) ---------------------------------------------------------------

def kinetic_energy(core: Any) -> float:
    """½ Σ m |v|² of the grains of a ``_core.Simulation3D`` (J)."""
    velocity = np.asarray(core.velocity)
    return float(0.5 * (np.asarray(core.mass) * np.einsum("ij,ij->i", velocity, velocity)).sum())


def frame_fields(core: Any) -> dict[str, np.ndarray]:
    """A frame of a ``_core.Simulation3D``: the grains' position, velocity, density, pressure and
    stress (3 × 3), and, with bodies, their particles' position and velocity (copies)."""
    fields = {"position": core.position, "velocity": core.velocity, "density": core.density,
              "pressure": core.pressure, "stress": core.stress}
    on_body = np.asarray(core.wall_body) >= 0
    if on_body.any():
        fields["body_position"] = np.asarray(core.wall_position)[on_body]
        fields["body_velocity"] = np.asarray(core.wall_velocity)[on_body]
    return {name: np.array(value) for name, value in fields.items()}


def static_arrays(core: Any) -> dict[str, np.ndarray]:
    """Grain masses and ids, the fixed walls' positions, groups and ids, the body particles' ids
    and body indices (as the planar Simulation's)."""
    body = np.asarray(core.wall_body)
    arrays = {"granular/mass": np.array(core.mass), "granular/id": np.array(core.id)}
    for name in ("position", "group", "id"):
        arrays[f"walls/{name}"] = np.array(np.asarray(getattr(core, f"wall_{name}"))[body < 0])
    if (body >= 0).any():
        arrays["bodies/id"] = np.array(np.asarray(core.wall_id)[body >= 0])
        arrays["bodies/index"] = np.array(body[body >= 0], dtype=np.int32)
    return arrays


def diagnostics(core: Any) -> dict[str, float]:
    """One row of ``/series/diagnostics`` but the time and wall time."""
    return {"step": core.step, "dt": core.last_dt, "kinetic_energy": kinetic_energy(core),
            "max_speed": core.max_speed, "neighbour_builds": core.neighbour_builds,
            "leaked_particles": core.penetrated_particles}


def run_attributes(core: Any) -> dict[str, int]:
    """Particle counts and the leak counter, for a run file's ``/run``."""
    return {"granular_particles": len(core.mass), "wall_particles": len(core.wall_position),
            "leaked_particles": core.penetrated_particles}
