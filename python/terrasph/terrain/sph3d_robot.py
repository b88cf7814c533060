"""A MuJoCo model on the 3D SPH bed as a run of the one run loop: ``terrasph run mjcf ROBOT.xml
--terrain sph3d`` (docs/sph3d.md).

The model is put on the bed by :func:`terrasph.terrain.attach` (``terrain="sph3d"``: the same
checks, bed and coupling as from Python), and :class:`SandRun3D` drives the :class:`Terrain` it
returns as the run loop's stepper (terrasph.run_loop.Stepper): one ``Terrain.step()`` (the model's
``opt.timestep``) per call of the controller, so a controller acts at the model's own step, as it
would in a Python loop over ``sand.step()``. What a run writes is the output contract of every run
(docs/hdf5_schema.md): frames of the grains and the bodies' particles in 3D (XDMF sidecars with XYZ
geometry), ``/series/robot/<body>`` as on the 3D RFT terrain
(:class:`terrasph.robots.rft3d_terrain.RobotLoads3D`: pose, velocity, load about the centre of mass,
sinkage), the run's status, checkpoints and bitwise resume. :func:`run_mjcf_scene` is the ``mjcf``
scene's run function over all its terrains (the scene registry's).
"""

from __future__ import annotations

import os
import pathlib
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

from terrasph.config import as_dict, parameter_units
from terrasph.robots.mjcf_scene import MjcfScene, run_mjcf
from terrasph.robots.rft3d_terrain import RobotLoads3D
from terrasph.robots.run import RobotRun
from terrasph.sph3d_run import diagnostics, frame_fields, run_attributes, static_arrays
from terrasph.terrain.sph3d_coupling import Coupled3D

if TYPE_CHECKING:
    from terrasph.terrain.interface import SPH3DTerrain

__all__ = ["SandLoads3D", "SandRun3D", "run_mjcf_scene", "sand_run_3d"]


class SandRun3D:
    """A :class:`terrasph.terrain.interface.SPH3DTerrain` as the run loop's stepper (module
    docstring). The coupled bodies' loads are each ``Terrain.step`` call's mean
    (:meth:`~terrasph.terrain.interface.Terrain.loads`: force, torque about the centre of mass, world
    axes), averaged here over the calls since :meth:`reset_body_means`, each weighted by its time."""

    def __init__(self, sand: SPH3DTerrain) -> None:
        self.sand = sand
        self.coupling: Coupled3D = sand.coupling
        self.robot = self.coupling  # model, data, coupled and surface: what the robot's recorders read
        self._sums = np.zeros((len(sand.bodies), 6))
        self._since = self.time

    @property
    def time(self) -> float:
        """Simulated time (s), MuJoCo's and the SPH's."""
        return self.coupling.time

    @property
    def step_count(self) -> int:
        """SPH steps so far."""
        return self.coupling.step_count

    def advance(self, t_end: float, max_steps: int = 2**62, control: Callable[[Any], None] | None = None) -> int:
        """Model steps (``Terrain.step()``, each several SPH steps) until `t_end` (s) is reached or
        passed or `max_steps` SPH steps are taken; `control`, if given, is called with this run before
        each model step. Returns the SPH steps taken."""
        start = self.step_count
        while self.step_count - start < max_steps and self.time < t_end * (1 - 1e-14):
            if control:
                control(self)
            before = self.time
            self.sand.step()
            self._sums += (self.time - before) * np.array(list(self.sand.loads().values()))
        return self.step_count - start

    def reset_body_means(self) -> None:
        """Starts a new averaging interval of the coupled bodies' loads."""
        self._sums[:] = 0.0
        self._since = self.time

    def body_sample(self, k: int) -> dict[str, Any]:
        """Coupled body `k`'s load (force N, torque N·m about its centre of mass, world axes) averaged
        since :meth:`reset_body_means` (NaN before a step), and the lowest z (m) of its particles."""
        span = self.time - self._since
        load = self._sums[k] / span if span > 0 else np.full(6, np.nan)
        return {"force": load[:3].copy(), "torque": load[3:].copy(), "lowest_z": self.coupling.lowest_z(k)}

    def recorder(self) -> SandLoads3D:
        """The run loop's recorder of this run's robot series."""
        return SandLoads3D(self)

    # -- what the run loop writes ---------------------------------------------------------------
    def describe(self) -> dict[str, Any]:
        """The bed, its grains and the coupled bodies, for the run file and its checkpoints."""
        coupling = self.coupling
        return {"dimensions": 3, "spacing": coupling.numerics.spacing, "parameter_units": parameter_units(),
                "terrain": {"kind": "sph3d", "surface": coupling.surface, "bed_size": list(coupling.bed.size),
                            "domain": [coupling.lower.tolist(), coupling.upper.tolist()],
                            "material": as_dict(coupling.material), "numerics": as_dict(coupling.numerics)},
                "robot": {"coupled": list(self.sand.bodies), "mujoco": mujoco.__version__,
                          "particles": {b.name: len(b.shape.position) for b in coupling.coupled},
                          "units": "force N, torque N*m about each body's centre of mass, world axes"}}

    def frame_fields(self) -> dict[str, np.ndarray]:
        """The grains (position, velocity, density, pressure, stress) and the bodies' particles."""
        return frame_fields(self.coupling.core)

    def static_arrays(self) -> dict[str, np.ndarray]:
        """Grain masses and ids, the fixed walls, the body particles' ids and body indices."""
        return static_arrays(self.coupling.core)

    def diagnostics(self) -> dict[str, float]:
        """One row of ``/series/diagnostics`` but the time and wall time."""
        return diagnostics(self.coupling.core)

    def run_attributes(self) -> dict[str, int]:
        """Particle counts and the leak counter, for a run file's ``/run``."""
        return run_attributes(self.coupling.core)

    def checkpoint(self, path: str | os.PathLike[str], progress: dict[str, Any] | None = None) -> pathlib.Path:
        """Writes the terrain's whole state (:meth:`Terrain.state`: the SPH's State to the file's
        particle sets, MuJoCo's integration state and the coupling's memory as plain data under
        ``progress["robot"]``) with this run's load sums to `path`."""
        from terrasph.checkpoint import write_checkpoint

        state = self.sand.state()
        sph = state["terrain"].pop("sph")
        robot = {**state, "sums": self._sums, "since": self._since}
        return write_checkpoint(path, sph, self.describe(), {**(progress or {}), "robot": robot})

    def restore(self, path: str | os.PathLike[str]) -> dict[str, Any]:
        """Continues from a :meth:`checkpoint` of the same configuration, bit for bit; returns the rest
        of its progress."""
        from terrasph.checkpoint import CheckpointError, configuration_differences, read_checkpoint

        sph, config, progress = read_checkpoint(path)
        differences = configuration_differences(config, self.describe())
        if differences or "robot" not in progress:
            raise CheckpointError(f"checkpoint {path} belongs to another configuration; it differs in: "
                                  f"{', '.join(differences) or 'robot'}")
        robot = progress.pop("robot")
        try:
            self.sand.restore({"mujoco": np.asarray(robot["mujoco"], dtype=float),
                               "terrain": {**robot["terrain"], "sph": sph},
                               "loads": {name: np.asarray(load, dtype=float) for name, load in robot["loads"].items()}})
        except (ValueError, TypeError, KeyError) as error:
            raise CheckpointError(f"checkpoint {path} does not fit this simulation: {error}") from error
        self._sums[:] = np.asarray(robot["sums"], dtype=float)
        self._since = float(robot["since"])
        return progress


class SandLoads3D(RobotLoads3D):
    """The run loop's recorder of a :class:`SandRun3D`: the series of
    :class:`terrasph.robots.rft3d_terrain.RobotLoads3D` (per coupled body ``robot/<body>``: pose,
    velocity, mean load, lowest point, sinkage; ``robot/actuators``), without the wheels' slip."""

    def __init__(self, coupled: SandRun3D) -> None:
        """Records `coupled`; no wheels (:func:`~terrasph.robots.rft3d_terrain.wheel_radii` reads RFT elements)."""
        self.coupled = coupled  # type: ignore[assignment]
        self.wheels = {}


def sand_run_3d(model_path: str | os.PathLike[str], *, bodies: Sequence[str], couple_below: float, spacing: float,
                bed_margin: float, bed_depth: float, freeboard: float, fidelity: str,
                numerics: dict[str, Any]) -> SandRun3D:
    """The MJCF model at `model_path` on a 3D SPH bed (:func:`terrasph.terrain.attach` with
    ``terrain="sph3d"`` and these options; its checks refuse bad input, ConfigError, before the bed
    is built), as a run-loop stepper."""
    from terrasph.robots.mjcf import load_model, mujoco_warnings
    from terrasph.terrain.interface import attach

    model = load_model(model_path)
    data = mujoco.MjData(model)
    with mujoco_warnings():
        sand = attach(model, data, "sph3d", bodies=tuple(bodies) or None, couple_below=couple_below,
                      spacing=spacing, bed_margin=bed_margin, bed_depth=bed_depth, freeboard=freeboard,
                      fidelity=fidelity, numerics=dict(numerics) or None)
    return SandRun3D(sand)  # type: ignore[arg-type]


def run_mjcf_scene(config: MjcfScene, output: str | os.PathLike[str] | None = None, **options: Any) -> RobotRun:
    """The ``mjcf`` scene on any of its terrains (the scene registry's run function; `options` those of
    :func:`terrasph.robots.mjcf_scene.run_mjcf`): on ``sph3d`` the model is put on the bed here
    (:func:`sand_run_3d`: robots/mjcf_scene.py cannot import terrasph.terrain, which imports it), the
    planar bed and the 3D RFT terrain are built by ``run_mjcf`` itself."""
    if config.terrain != "sph3d":
        return run_mjcf(config, output, **options)
    coupled = sand_run_3d(config.model, bodies=config.bodies, couple_below=config.couple_below,
                          spacing=config.bed_spacing, bed_margin=config.bed_margin, bed_depth=config.bed_depth,
                          freeboard=config.freeboard, fidelity=config.fidelity, numerics=config.numerics)
    return run_mjcf(config, output, coupled=coupled, **options)
