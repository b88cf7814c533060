"""The Python face of a run: a scene + material + numerics turned into a core simulation, and the
run loop with progress, HDF5 output, scheduled wall removal and safe interruption."""

from __future__ import annotations

import dataclasses
import math
import os
import platform
import time as wallclock
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from terrasph import _core
from terrasph.config import ConfigError, Material, Numerics, as_dict
from terrasph.scene import Scene, hydrostatic_density

__all__ = ["RunResult", "Simulation", "versions"]

#: Wall time (s) one call into the core may take, so Ctrl-C and the progress bar stay responsive
#: however slow a step is; the steps per call follow from the last call's seconds per step.
CHUNK_SECONDS = 0.2
MAX_STEPS_PER_CHUNK = 500


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


class Simulation:
    """A granular SPH simulation in plane strain, built from a validated scene.

    Particle arrays (``position``, ``velocity``, ``density``, ``pressure``, ``stress``, …) are zero-copy
    views into the C++ state: read them freely; after writing to them call :meth:`refresh`. Granular
    views stay valid for the simulation's lifetime; views of wall arrays (``core.wall_position``, …)
    are invalidated when a wall group is removed, so take them afresh after a removal.
    Granular masses are per metre of depth (m = ρ·Δx²); multiply by ``width`` for the real sample.
    """

    def __init__(self, scene: Scene, material: Material, numerics: Numerics, *,
                 initial_density: np.ndarray | None = None, width: float = 1.0) -> None:
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
        if initial_density is None:
            initial_density = hydrostatic_density(position[:, 1].max() + 0.5 * scene.spacing - position[:, 1],
                                                  material, scene.gravity)
        density = np.asarray(initial_density, dtype=float)
        if density.shape != (len(position),):
            raise ConfigError(f"parameter 'initial_density' must have shape ({len(position)},)")
        dx2 = scene.spacing**2
        walls = scene.wall_position
        wall_group = np.concatenate([np.full(len(w.position), w.group_id, np.int32) for w in scene.walls]) \
            if scene.walls else np.zeros(0, np.int32)
        wall_no_slip = np.concatenate([np.full(len(w.position), w.no_slip, np.uint8) for w in scene.walls]) \
            if scene.walls else np.zeros(0, np.uint8)
        self._removals = sorted((w.remove_at, w.group_id) for w in scene.walls if w.remove_at is not None)
        self.core = _core.Simulation2D(
            self._core_params(), position, np.zeros_like(position), density, density * dx2,
            walls, scene.wall_normal, np.full(len(walls), material.reference_density * dx2), wall_no_slip, wall_group)
        self.bodies = scene.bodies
        for body in self.bodies:
            self.core.add_body(body.group_id, np.asarray(body.reference), body.angle, body.motion.rows())

    def _core_params(self) -> _core.ModelParams2D:
        params = _core.ModelParams2D()
        material = params.material
        for key in ("grain_density", "reference_density", "grain_diameter", "mu1", "mu2", "inertial_number_i0",
                    "bulk_stiffness", "eos_exponent", "water_content", "shear_modulus"):
            setattr(material, key, float(getattr(self.material, key)))
        material.cohesion = self.material.cohesion
        material.elastic_quasi_static = self.material.quasi_static == "elastic"
        params.material = material
        numerics = params.numerics
        for f in dataclasses.fields(Numerics):
            setattr(numerics, f.name, getattr(self.numerics, f.name))
        params.numerics = numerics
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
        """Granular positions (N, 2), m (view)."""
        return self.core.position

    @property
    def velocity(self) -> np.ndarray:
        """Granular velocities (N, 2), m/s (view)."""
        return self.core.velocity

    @property
    def density(self) -> np.ndarray:
        """Granular densities (N,), kg/m³ (view)."""
        return self.core.density

    @property
    def pressure(self) -> np.ndarray:
        """Granular pressures from the EOS (N,), Pa (view)."""
        return self.core.pressure

    @property
    def stress(self) -> np.ndarray:
        """Granular Cauchy stress (N, 2, 2), Pa (view)."""
        return self.core.stress

    @property
    def mass(self) -> np.ndarray:
        """Granular masses per metre of depth (N,), kg/m (view)."""
        return self.core.mass

    def kinetic_energy(self) -> float:
        """½ Σ m|v|² for the real width (J)."""
        v = self.core.velocity
        return 0.5 * float(np.dot(self.core.mass, np.einsum("ij,ij->i", v, v))) * self.width

    def body_state(self, name: str) -> dict[str, Any]:
        """Pose and load of a body, loads in N and N·m for its real width (DESIGN §2).

        Keys: ``reference`` (x, z) m, ``angle`` rad and ``omega`` rad/s (clockwise-positive),
        ``velocity`` (vx, vz) m/s, ``force`` (F_x, F_z) N of the terrain on the body and ``torque``
        N·m (clockwise-positive, about the reference point), both averaged over the time since the
        last :meth:`reset_body_means` (a box filter; the instant values are ``force_now`` and
        ``torque_now``), ``lowest_z`` m and, when the scene has a ``surface_level``, ``sinkage`` m.
        """
        index = self._body_index(name)
        body = self.bodies[index]
        raw = self.core.body_state(index)
        mask = np.asarray(self.core.wall_group) == body.group_id
        lowest = float(np.asarray(self.core.wall_position)[mask, 1].min() - 0.5 * self.scene.spacing)
        state = {"reference": np.asarray(raw["reference"]), "angle": raw["angle"],
                 "velocity": np.asarray(raw["velocity"]), "omega": raw["spin"],
                 "force": np.asarray(raw["mean_force"]) * body.width, "torque": raw["mean_torque"] * body.width,
                 "force_now": np.asarray(raw["force"]) * body.width, "torque_now": raw["torque"] * body.width,
                 "lowest_z": lowest}
        if self.scene.surface_level is not None:
            state["sinkage"] = self.scene.surface_level - lowest
        return state

    def reset_body_means(self) -> None:
        """Restarts the time averages of body forces and torques."""
        self.core.reset_body_means()

    def _body_index(self, name: str) -> int:
        for index, body in enumerate(self.bodies):
            if body.name == name:
                return index
        raise KeyError(f"no body named {name!r}; bodies: {[b.name for b in self.bodies]}")

    @property
    def leaked_particles(self) -> int:
        """Distinct granular particles that have been inside a wall or body (closer than Δx/2 to a
        wall particle) at any step so far: the leak counter of DESIGN §3.5."""
        return int(self.core.penetrated_particles)

    def refresh(self) -> None:
        """Rebuilds neighbours and rates after the state was edited through a view."""
        self.core.refresh()

    def advance(self, t_end: float, max_steps: int = 2**62) -> int:
        """Steps to `t_end` (s), applying scheduled wall removals; returns the steps taken."""
        taken = 0
        self._remove_due_walls()
        while self.core.time < t_end * (1 - 1e-14) and taken < max_steps:
            target = min(t_end, self._removals[0][0]) if self._removals else t_end
            taken += self.core.advance(target, max_steps - taken)
            self._remove_due_walls()
        return taken

    def _remove_due_walls(self) -> None:
        """Removes the wall groups whose removal time has come."""
        while self._removals and self._removals[0][0] <= self.core.time:
            self.core.remove_wall_group(self._removals.pop(0)[1])

    # -- run loop -------------------------------------------------------------------------
    def run(self, t_end: float, *, output: str | os.PathLike | None = None, frame_interval: float = 0.05,
            progress: bool = True, config: dict[str, Any] | None = None,
            stop_when_at_rest: float | None = None, min_time: float = 0.0,
            on_frame: Callable[[Simulation], None] | None = None,
            body_interval: float = 0.01) -> RunResult:
        """Runs to `t_end` (s), writing a frame every `frame_interval` (s) to `output` (HDF5).

        Every `body_interval` (s) each body's pose and load, averaged over the interval, is
        appended to ``/series/bodies/<name>`` and to ``RunResult.bodies``.

        With ``stop_when_at_rest = r`` the run ends once t ≥ `min_time` and the kinetic energy per
        unit mass ½|v|² (mean) drops below r·g·Δx — a bed whose grains move less than about
        √(2r g Δx). Ctrl-C ends the run cleanly: the last frame is written and the file closed.
        An :class:`terrasph.InstabilityError` is recorded in the file before it propagates.
        """
        if not (t_end > self.time):
            raise ConfigError(f"parameter 't_end' = {t_end} is invalid: allowed > current time {self.time}")
        if not frame_interval > 0:
            raise ConfigError(f"parameter 'frame_interval' = {frame_interval} is invalid: allowed > 0")
        if not body_interval > 0:
            raise ConfigError(f"parameter 'body_interval' = {body_interval} is invalid: allowed > 0")
        if progress:
            from tqdm.auto import tqdm
        else:  # tqdm.auto warns about missing notebook widgets even for a disabled bar
            from tqdm import tqdm

        from terrasph.io import RunWriter, write_xdmf

        writer = RunWriter(output, config or self.describe(), versions=versions()) if output else None
        if writer:
            writer.write_static("granular/mass", np.array(self.mass))
            on_body = self._on_body()
            wall_group = np.asarray(self.core.wall_group)
            writer.write_static("walls/position", np.array(np.asarray(self.core.wall_position)[~on_body]))
            writer.write_static("walls/group", np.array(wall_group[~on_body]))
            if self.bodies:  # which body each particle of the frames' body_* fields belongs to
                index_of_group = {body.group_id: index for index, body in enumerate(self.bodies)}
                writer.write_static("bodies/index", np.array([index_of_group[g] for g in wall_group[on_body]],
                                                             dtype=np.int32))
        diagnostics: dict[str, list[float]] = {k: [] for k in ("time", "step", "dt", "kinetic_energy",
                                                                 "max_speed", "neighbour_builds", "wall_time",
                                                                 "leaked_particles")}
        body_series: dict[str, dict[str, list[Any]]] = {b.name: {} for b in self.bodies}
        start = wallclock.perf_counter()
        frames = 0
        status = "completed"
        total_mass = float(self.mass.sum())
        rest_threshold = None if stop_when_at_rest is None else stop_when_at_rest * self.scene.gravity * self.scene.spacing

        def record() -> None:
            nonlocal frames
            row = {"time": self.time, "step": self.step_count, "dt": self.core.last_dt,
                   "kinetic_energy": self.kinetic_energy(), "max_speed": self.core.max_speed,
                   "neighbour_builds": self.core.neighbour_builds,
                   "wall_time": wallclock.perf_counter() - start, "leaked_particles": self.leaked_particles}
            for key, value in row.items():
                diagnostics[key].append(float(value))
            if writer:
                writer.write_frame(self.time, self.step_count, self.frame_fields())
                writer.append_series("diagnostics", row)
            frames += 1
            if on_frame:
                on_frame(self)

        def record_bodies() -> None:
            for body in self.bodies:
                row = {"time": self.time, **self.body_state(body.name)}
                for key, value in row.items():
                    body_series[body.name].setdefault(key, []).append(value)
                if writer:
                    writer.append_series(f"bodies/{body.name}", row)
            self.reset_body_means()

        t_start = self.time
        bar = tqdm(total=round(t_end - t_start, 9), unit="s", disable=not progress, mininterval=0.5,
                   bar_format="{l_bar}{bar}| {n:.3f}/{total:.3f} s simulated [{elapsed}<{remaining}]{postfix}")
        chunk_steps = 1  # steps per call into the core, adapted to CHUNK_SECONDS of wall time

        def advance_chunk(target: float) -> None:
            nonlocal chunk_steps
            started, steps_before = wallclock.perf_counter(), self.step_count
            self.advance(target, max_steps=chunk_steps)
            per_step = (wallclock.perf_counter() - started) / max(1, self.step_count - steps_before)
            chunk_steps = max(1, min(MAX_STEPS_PER_CHUNK, int(CHUNK_SECONDS / max(per_step, 1e-9))))
            # the bar shows simulated time, never past its total (float sums of dt overshoot)
            bar.update(min(bar.total, round(self.time - t_start, 9)) - bar.n)

        def close_bar(finished: bool) -> None:
            if finished:  # a run that stops early (at rest) ends its bar at 100 %
                bar.total = bar.n
            bar.refresh()
            bar.close()

        def record_end(end_status: str, **extra: Any) -> None:
            """The final /run attributes, for every way a run ends."""
            writer.set_attrs("/run", {"status": end_status, "wall_time": wallclock.perf_counter() - start,
                                      "steps": self.step_count, "time": self.time, **extra})

        try:
            record()
            if self.bodies:
                record_bodies()
            next_frame = self.time + frame_interval
            next_sample = self.time + body_interval if self.bodies else math.inf
            while self.time < t_end * (1 - 1e-14):
                # short chunks keep Ctrl-C and the progress bar responsive (the GIL is released inside)
                advance_chunk(min(next_frame, next_sample, t_end))
                if self.time >= next_sample * (1 - 1e-12) or (self.bodies and self.time >= t_end * (1 - 1e-14)):
                    record_bodies()
                    next_sample += body_interval
                bar.set_postfix(steps=self.step_count, dt=f"{self.core.last_dt:.2e}", refresh=False)
                if self.time >= next_frame * (1 - 1e-12) or self.time >= t_end * (1 - 1e-14):
                    record()
                    next_frame += frame_interval
                    specific_energy = diagnostics["kinetic_energy"][-1] / (total_mass * self.width)
                    if rest_threshold is not None and self.time >= min_time and specific_energy < rest_threshold:
                        status = "at_rest"
                        break
        except KeyboardInterrupt:
            close_bar(finished=False)
            if writer:
                writer.write_frame(self.time, self.step_count, self.frame_fields())
                record_end("interrupted")
                writer.close()
                write_xdmf(output)
            raise
        except _core.InstabilityError as error:
            close_bar(finished=False)
            if writer:
                record_end("unstable", message=str(error), step=error.step, particle=error.particle)
                writer.set_attrs("/run", {"time": error.time})
                writer.close()
                write_xdmf(output)
            raise
        close_bar(finished=True)
        wall_time = wallclock.perf_counter() - start
        if writer:
            writer.set_attrs("/run", {"status": status, "wall_time": wall_time, "steps": self.step_count,
                                      "time": self.time, "granular_particles": len(self.mass),
                                      "wall_particles": len(self.core.wall_position),
                                      "leaked_particles": self.leaked_particles})
            writer.close()
            write_xdmf(output)
        bodies = {name: {key: np.asarray(values) for key, values in series.items()}
                  for name, series in body_series.items()}
        return RunResult(self.time, self.step_count, wall_time, frames, os.fspath(output) if output else None,
                         status, diagnostics, bodies)

    def frame_fields(self) -> dict[str, np.ndarray]:
        """Copies of the per-particle fields written to each frame: the grains' fields and, in a
        scene with bodies, ``body_position`` and ``body_velocity`` of every body particle (which
        body each belongs to is ``/static/bodies/index``)."""
        fields = {"position": np.array(self.position), "velocity": np.array(self.velocity),
                  "density": np.array(self.density), "pressure": np.array(self.pressure),
                  "stress": np.array(self.stress)}
        if self.bodies:
            on_body = self._on_body()
            fields["body_position"] = np.array(np.asarray(self.core.wall_position)[on_body])
            fields["body_velocity"] = np.array(np.asarray(self.core.wall_velocity)[on_body])
        return fields

    def _on_body(self) -> np.ndarray:
        """Mask of the wall particles that belong to a body."""
        return np.isin(np.asarray(self.core.wall_group), [body.group_id for body in self.bodies])

    def describe(self) -> dict[str, Any]:
        """Configuration of this simulation as plain data (saved with the output)."""
        return {"material": as_dict(self.material), "numerics": as_dict(self.numerics),
                "spacing": self.scene.spacing, "width": self.width, "gravity": self.scene.gravity,
                "walls": [{"name": w.name, "no_slip": w.no_slip, "remove_at": w.remove_at,
                           "particles": len(w.position)} for w in self.scene.walls],
                "bodies": [{"name": b.name, "shape": b.shape.name if b.shape else None, "reference": list(b.reference),
                            "angle": b.angle, "width": b.width, "motion": b.motion.rows(),
                            "units": "force N and torque N*m for the body's width; angles clockwise"}
                           for b in self.bodies],
                "granular_particles": len(self.mass)}
