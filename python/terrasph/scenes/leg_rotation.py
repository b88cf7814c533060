"""Rotating robot leg in a bed of glass beads (dissertation ch. 3, Fig. 3.2–3.5).

A leg of length 2R = 7.62 cm (hip to toe), 6.4 mm thick and 2.54 cm wide is held for a settling
pause in a 24 cm × 15 cm bed of 3 mm glass beads with its axle (hip) 2 cm above the free surface,
then rotated clockwise at ω about the axle from θ = −π/4 (toe forward-down) to θ = π/4 (toe
backward-down). The lift F_z and thrust F_x of the beads on the leg are recorded against θ, in N
for the real leg width.
"""

from __future__ import annotations

import dataclasses
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from terrasph import bodies
from terrasph.config import ConfigError, Material, Numerics, check_settle_time, glass_beads
from terrasph.fidelity import check_tier, fidelity_option, scene_numerics
from terrasph.geometry import wall_layers_needed
from terrasph.io import write_results
from terrasph.motion import hold_then_rotate
from terrasph.options import option, shared
from terrasph.scene import Scene, flung_height
from terrasph.simulation import RunResult, Simulation
from terrasph.size_guard import Footprint
from terrasph.terrain import rft

__all__ = ["LEGS", "RESOLUTIONS", "SCENE_NUMERICS", "BeadBed", "LegResult", "LegRotation", "RFTLegSweep",
           "build_leg_rotation", "container_freeboard", "run_leg_rotation"]

#: Leg shapes by name (bodies.py documents each reading of the dissertation's figures).
LEGS = ("flat-leg", "c-leg", "reversed-c-leg", "l-leg", "reversed-l-leg")
#: leg names of earlier versions (run files, SPECs), read as their current names: the shape names of
#: leg-rotation and leg-wheel are one set
OLD_LEG_NAMES = {"flat": "flat-leg"}

#: Rows across the leg's thickness per resolution: Δx = thickness / rows. Three rows is the least
#: that fills the kernel support 2h = 2.6Δx (bodies.minimum_thickness), so "coarse" is the coarsest
#: resolution at which no grain can interact through the leg.
RESOLUTIONS: dict[str, int] = {"coarse": 3, "fine": 4, "finer": 5}

#: The scene's numerics beyond the defaults: the Shepard filter every 100 steps (Eq. 3.18, as in
#: chapter 3) and the density floor ρ ≥ ρ0. Without them grains that separate from the bed (the
#: free surface of the heap the leg pushes up, the cavity behind it) dilated below 0.5ρ0 and
#: stopped 0.2 and 0.8 rad/s sweeps of the flat leg (docs/design_decisions.md).
SCENE_NUMERICS: dict[str, Any] = {"shepard_interval": 100, "density_floor": 1.0}


@dataclass(frozen=True)
class BeadBed:
    """The material options of every scene on chapter 3's glass beads (the leg rotation, the plates,
    the robots): the friction angles and the water content of the bed, each a --option of the
    scene. At the defaults the material is :func:`glass_beads` itself."""

    mu1_deg: float = shared("mu1_deg", 23.0)
    mu2_deg: float = shared("mu2_deg", 33.0)
    water_content: float = shared("water_content", 0.0)

    def check_bed_material(self) -> None:
        """ConfigError naming the first bad material option (called by each scene's checks)."""
        for name in ("mu1_deg", "mu2_deg"):
            value = getattr(self, name)
            if isinstance(value, bool) or not (isinstance(value, (int, float)) and 0 <= value < 90):
                raise ConfigError(f"parameter '{name}' = {value!r} is invalid: allowed a number in [0, 90) degrees")
        if self.mu1_deg > self.mu2_deg:
            raise ConfigError(f"parameter 'mu1_deg' = {self.mu1_deg!r} is invalid: allowed <= mu2_deg = "
                              f"{self.mu2_deg!r}")
        try:
            self.bed_material()  # the material's own checks (the pendular range of the water content)
        except ConfigError as error:
            raise ConfigError(f"parameter 'water_content' = {self.water_content!r} is refused by the bed material: "
                              f"{error}") from None

    def bed_material(self) -> Material:
        """The bed: the glass beads with these friction angles and water content (a wet material's
        densities × (1 + w), as Material.wet)."""
        beads = dataclasses.replace(glass_beads(), mu1=math.tan(math.radians(self.mu1_deg)),
                                    mu2=math.tan(math.radians(self.mu2_deg)))
        if self.water_content == 0:
            return beads
        w = self.water_content
        return dataclasses.replace(beads, water_content=w, grain_density=beads.grain_density * (1 + w),
                                   reference_density=beads.reference_density * (1 + w))


@dataclass(frozen=True)
class LegRotation(BeadBed):
    """Configuration of a leg-rotation run. Lengths in m, times in s, angles in rad (clockwise)."""

    #: the settings of the SPH bed only, refused on the RFT terrain unless at their defaults
    SPH_ONLY_FIELDS: ClassVar[tuple[str, ...]] = ("bed_width", "bed_depth", "fidelity", "numerics", "mu1_deg",
                                                  "mu2_deg", "water_content")

    leg: str = option("c-leg", choices=LEGS, help="leg shape")
    omega: float = option(0.2, help="angular velocity of the sweep, clockwise", unit="rad/s")
    foot_ratio: float = option(0.33, help="foot/leg length ratio fl of the L-legs")
    resolution: str = option("coarse", choices=tuple(RESOLUTIONS), help="/".join(
        str(n) for n in RESOLUTIONS.values()) + " particle rows across the leg's thickness (ignored when --spacing "
                                                "is given)")
    spacing: float | None = option(None, help="particle spacing dx, overrides --resolution", unit="m",
                                   default_text="thickness / rows of --resolution")
    leg_length: float = shared("leg_length", 0.0762)  #: 2R of the dissertation
    thickness: float = option(0.0064, help="leg thickness", unit="m")
    width: float = option(0.0254, help="out-of-plane leg width; forces are reported for it", unit="m")
    bed_width: float = shared("bed_width", 0.24)
    bed_depth: float = shared("bed_depth", 0.15)
    hip_height: float = option(0.02, help="axle height above the undisturbed free surface", unit="m")
    start_angle: float = option(-math.pi / 4, help="leg angle at the start, clockwise from down", unit="rad")
    end_angle: float = option(math.pi / 4, help="leg angle at the end of the sweep", unit="rad")
    settle_time: float = shared("settle_time", 2.0)  #: the leg is held still
    #: load samples (each a time average, see Simulation.run)
    samples_per_radian: float = option(100.0, help="load samples per radian of the sweep", unit="1/rad")
    frame_interval: float = shared("frame_interval", 0.1)
    t_end: float | None = shared("t_end", None, default_text="the end of the sweep, settle_time + sweep angle / omega")
    fidelity: str = fidelity_option("leg-rotation")
    numerics: dict[str, Any] = field(default_factory=dict)  #: overrides of SCENE_NUMERICS and terrasph.Numerics
    terrain: str = shared("terrain", "sph")
    rft_table: str = shared("rft_table", "generic")

    def __post_init__(self) -> None:
        check_tier(self.fidelity)
        self.check_bed_material()
        object.__setattr__(self, "leg", OLD_LEG_NAMES.get(self.leg, self.leg))
        if self.leg not in LEGS:
            raise ConfigError(f"parameter 'leg' = {self.leg!r} is invalid: allowed one of {', '.join(LEGS)}")
        for name in ("omega", "leg_length", "thickness", "width", "bed_width", "bed_depth",
                     "samples_per_radian", "frame_interval"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ConfigError(f"parameter '{name}' = {value!r} is invalid: allowed a finite number > 0")
        if self.t_end is not None and not (isinstance(self.t_end, (int, float)) and math.isfinite(self.t_end)
                                           and self.t_end > 0):
            raise ConfigError(f"parameter 't_end' = {self.t_end!r} is invalid: allowed a finite number > 0 s or None")
        check_settle_time(self.settle_time, self.t_end)
        if not 0 < self.foot_ratio <= 2:
            raise ConfigError(f"parameter 'foot_ratio' = {self.foot_ratio!r} is invalid: allowed (0, 2]")
        if self.spacing is None and self.resolution not in RESOLUTIONS:
            raise ConfigError(f"parameter 'resolution' = {self.resolution!r} is invalid: allowed one of "
                              f"{', '.join(RESOLUTIONS)}")
        if self.spacing is not None and not (self.spacing > 0 and math.isfinite(self.spacing)):
            raise ConfigError(f"parameter 'spacing' = {self.spacing!r} is invalid: allowed a finite number > 0")
        if not (-math.pi < self.start_angle < self.end_angle < math.pi):
            raise ConfigError(f"parameters 'start_angle' = {self.start_angle}, 'end_angle' = {self.end_angle} are "
                              "invalid: allowed -pi < start_angle < end_angle < pi")
        if not (math.isfinite(self.hip_height) and -self.bed_depth < self.hip_height < self.leg_length):
            raise ConfigError(f"parameter 'hip_height' = {self.hip_height!r} is invalid: allowed between "
                              f"-bed_depth and leg_length (the leg must reach the sand)")
        rft.check_terrain(self, self.SPH_ONLY_FIELDS, ("rft_table",))

    @property
    def grid_spacing(self) -> float:
        """Δx: as given, or thickness / RESOLUTIONS[resolution]."""
        return self.spacing if self.spacing is not None else self.thickness / RESOLUTIONS[self.resolution]

    @property
    def duration(self) -> float:
        """Settling pause plus the sweep (s)."""
        return self.settle_time + (self.end_angle - self.start_angle) / self.omega

    @property
    def end_time(self) -> float:
        """When the run stops: `t_end`, or the end of the sweep (s)."""
        return self.duration if self.t_end is None else self.t_end

    def build_numerics(self) -> Numerics:
        """terrasph.Numerics at this spacing and fidelity: SCENE_NUMERICS, the tier, then the overrides."""
        return scene_numerics("leg-rotation", self.fidelity, self.grid_spacing, SCENE_NUMERICS, self.numerics)

    def footprint(self) -> Footprint:
        """The bed and the leg, the container's floor and sides (size guard)."""
        return Footprint(self.grid_spacing, self.bed_width * self.bed_depth + self.leg_length * self.thickness,
                         self.bed_width + 2.0 * (self.bed_depth + self.leg_length), self.end_time, self.bed_material(),
                         self.build_numerics())

    def shape(self) -> bodies.BodyShape:
        """The leg in its own frame (hip at the origin, pointing down at θ = 0)."""
        args = (self.leg_length, self.thickness, self.width, self.grid_spacing)
        if self.leg == "flat-leg":
            return bodies.flat_leg(*args)
        if self.leg == "c-leg":
            return bodies.c_leg(*args)
        if self.leg == "reversed-c-leg":
            return bodies.reversed_c_leg(*args)
        if self.leg == "l-leg":
            return bodies.l_leg(*args, foot_ratio=self.foot_ratio)
        return bodies.reversed_l_leg(*args, foot_ratio=self.foot_ratio)


def container_freeboard(config: LegRotation, shape: bodies.BodyShape, gravity: float) -> float:
    """Height (m) of the container's walls above the bed: the top of the leg at its hip (hip height
    + leg length), so the sand the leg heaps and carries up stays in, or more if grains it flings
    (its farthest point, of `shape` about the hip, turning at ω) rise higher."""
    tip_speed = config.omega * float(np.hypot(*shape.position.T).max())
    return max(max(config.hip_height, 0.0) + config.leg_length, flung_height(tip_speed, gravity))


def build_leg_rotation(config: LegRotation) -> tuple[Scene, Material, Numerics]:
    """The bed in its container, the leg at its start angle, the material and the numerics."""
    dx = config.grid_spacing
    numerics = config.build_numerics()
    layers = wall_layers_needed(numerics.h_factor)
    scene = Scene(spacing=dx)
    try:
        shape = config.shape()
    except ValueError as error:
        raise ConfigError(f"leg geometry: {error}") from None
    surface, right = scene.add_bed_in_container(config.bed_width, config.bed_depth,
                                                container_freeboard(config, shape, scene.gravity), layers=layers)
    hip = (0.5 * right, surface + config.hip_height)
    sweep = np.linspace(config.start_angle, config.end_angle, 91)
    lowest = min(shape.lowest_point(angle, hip) for angle in sweep)
    if lowest < 3 * dx:
        raise ConfigError(f"parameter 'bed_depth' = {config.bed_depth} is invalid: the leg reaches z = {lowest:.4f} m "
                          f"during its sweep, within 3 particle spacings of the container floor; allowed a bed "
                          f"deeper than {config.bed_depth - lowest + 3 * dx:.4f} m (or a higher hip)")
    motion = hold_then_rotate(config.settle_time, config.omega, config.end_angle - config.start_angle)
    scene.add_body("leg", shape, reference=hip, angle=config.start_angle, motion=motion, width=config.width)
    return scene, config.bed_material(), numerics


@dataclass
class LegResult:
    """Loads on the leg against its angle during the sweep (N for the real width, θ clockwise)."""

    theta: np.ndarray  #: leg angle at each sample (rad)
    lift: np.ndarray  #: F_z (N), mean over each sample interval
    thrust: np.ndarray  #: F_x (N)
    torque: np.ndarray  #: clockwise torque about the hip (N·m)
    config: LegRotation
    granular_particles: int
    leaked_particles: int
    run: RunResult
    plot: str | None = None

    @property
    def peak_lift(self) -> float:
        """Largest lift of the sweep (N); NaN before the sweep began (a run ended in the pause)."""
        return float(self.lift.max()) if self.lift.size else math.nan

    @property
    def peak_thrust(self) -> float:
        """Largest thrust of the sweep (N); NaN before the sweep began."""
        return float(self.thrust.max()) if self.thrust.size else math.nan

    def noise(self, values: np.ndarray, skip: float = 0.1) -> float:
        """Step-to-step noise of a load curve: the largest deviation of a sample from the mean of its
        two neighbours, as a fraction of the curve's peak magnitude. Each sample is already the
        time average over its interval (1/samples_per_radian of the sweep; the box filter of
        Simulation.run). The first `skip` rad of the sweep, where the load builds up from rest, is
        left out; NaN for a sweep too short for a sample with two neighbours."""
        if self.theta.size == 0:
            return math.nan
        keep = self.theta >= self.theta[0] + skip
        v = np.asarray(values)[keep]
        if v.size < 3:
            return math.nan
        return float(np.abs(v[1:-1] - 0.5 * (v[:-2] + v[2:])).max() / np.abs(values).max())

    def summary(self) -> dict[str, Any]:
        """Flat dict for tables and HDF5 attributes."""
        return {"leg": self.config.leg, "omega": self.config.omega, "spacing": self.config.grid_spacing,
                "peak_lift": self.peak_lift, "peak_thrust": self.peak_thrust,
                "lift_noise": self.noise(self.lift), "thrust_noise": self.noise(self.thrust),
                "granular_particles": self.granular_particles, "leaked_particles": self.leaked_particles,
                "steps": self.run.steps, "time": self.run.time, "wall_time": self.run.wall_time,
                "status": self.run.status}


def run_leg_rotation(config: LegRotation = LegRotation(), *, output: str | os.PathLike | None = None,
                     progress: bool = True, plot: bool = True,
                     resume: bool = False, until: float | None = None) -> LegResult:
    """Builds and runs a leg rotation; writes HDF5 (body series under /series/bodies/leg) and a
    PNG of lift and thrust against θ beside it.

    ``resume=True`` continues the run in `output` from its checkpoint; ``until`` replaces the end
    time (see :meth:`terrasph.simulation.Simulation.run`).
    """
    if config.terrain == "rft":
        return _run_rft_leg_rotation(config, output, plot, progress, resume, until)
    scene, material, numerics = build_leg_rotation(config)
    sim = Simulation(scene, material, numerics, width=config.width)
    interval = 1.0 / (config.samples_per_radian * config.omega)
    run = sim.run(config.end_time if until is None else until, output=output, resume=resume,
                  frame_interval=config.frame_interval, progress=progress,
                  body_interval=interval,
                  config={"scene": "leg-rotation", "leg_rotation": dataclasses.asdict(config), **sim.describe()})
    series = run.bodies["leg"]
    turning = series["time"] > config.settle_time + 1e-9
    result = LegResult(series["angle"][turning], series["force"][turning, 1], series["force"][turning, 0],
                       series["torque"][turning], config, len(sim.mass), sim.leaked_particles, run)
    _finish(result, output, plot, f"ω = {config.omega:g} rad/s, Δx = {1e3 * config.grid_spacing:.2f} mm")
    return result


def _finish(result: LegResult, output: str | os.PathLike | None, plot: bool, title: str) -> None:
    """Writes the summary into the run file and, with `plot`, the PNG of lift and thrust beside it."""
    if output is None:
        return
    write_results(output, result.summary())
    if plot:
        from terrasph import plotting

        png = Path(output).with_suffix(".png")
        plotting.plot_leg_loads([(result.theta, result.lift, result.thrust, result.config.leg)], path=png, title=title)
        result.plot = os.fspath(png)


def _run_rft_leg_rotation(config: LegRotation, output: str | os.PathLike | None, plot: bool, progress: bool,
                          resume: bool, until: float | None) -> LegResult:
    """The sweep on the RFT terrain (terrasph.terrain.rft; :class:`RFTLegSweep`) through the run loop, sampled as
    the SPH's; the run file holds the same ``/series/bodies/leg`` (time, angle, force, torque) and
    frames of the leg."""
    from terrasph.run_loop import RunLoop
    from terrasph.simulation import versions

    sweep = RFTLegSweep(config)
    loop = RunLoop(sweep, output, config.frame_interval, sweep.interval, [sweep],
                   {"scene": "leg-rotation", "leg_rotation": dataclasses.asdict(config), **sweep.describe()},
                   versions(), progress=progress)
    done = loop.run(config.end_time if until is None else until, resume)
    series = done.series["bodies/leg"]
    run = RunResult(done.time, done.steps, done.wall_time, done.frames, None if output is None else os.fspath(output),
                    done.status, bodies={"leg": series})
    turning = series["time"] > config.settle_time + 1e-9
    result = LegResult(series["angle"][turning], series["force"][turning, 1], series["force"][turning, 0],
                       series["torque"][turning], config, 0, 0, run)
    table = sweep.table
    _finish(result, output, plot, f"RFT ({table.source or config.rft_table}, ζ = {table.zeta:.3g} N/m³), "
                                  f"ω = {config.omega:g} rad/s")
    return result


class RFTLegSweep:
    """The leg's prescribed sweep on the RFT terrain, a stepper of the run loop
    (:class:`terrasph.run_loop.Stepper`) and its recorder of ``bodies/leg``.

    The hip is ``hip_height`` above a flat surface at z = 0; the leg rests for the pause, then turns at
    ω from ``start_angle`` to ``end_angle`` (as the SPH's :func:`terrasph.motion.hold_then_rotate`).
    RFT is quasi-static and stateless, so a step of at most :attr:`interval` (the SPH's load sampling
    interval, ending at the pause's end and the sweep's end) takes the load at its middle; a sample's
    force and torque are their means over the steps since the previous sample (the SPH's body
    series' averages), its angle that of the sample's time. Frames hold the leg's particles.
    """

    def __init__(self, config: LegRotation) -> None:
        self.shape = config.shape()
        try:
            self.elements = rft.SurfaceElements.from_shape(self.shape, width=config.width)
        except ValueError as error:
            raise ConfigError(f"leg geometry: {error}") from None
        self.config = config
        self.table = rft.coefficient_table(config.rft_table)
        self.hip = np.array([0.0, config.hip_height])
        #: the SPH's load sampling interval (run_leg_rotation), one step at most
        self.interval = 1.0 / (config.samples_per_radian * config.omega)
        self._turn = (config.settle_time, config.duration)
        angles = np.linspace(config.start_angle, config.end_angle, 64)
        reach = min(float((self.elements.centre @ bodies.rotation_matrix(a).T)[:, 1].min()) for a in angles)
        if reach + config.hip_height >= 0:
            raise ConfigError(f"parameter 'hip_height' = {config.hip_height!r} is invalid for the RFT terrain: no "
                              "element of the leg's surface goes below the free surface during the sweep")
        self._time, self._steps, self._since = 0.0, 0, 0.0
        self._impulse = np.zeros(3)  # ∫ (F_x, F_z, τ) dt since the last sample

    @property
    def time(self) -> float:
        """Simulated time (s)."""
        return self._time

    @property
    def step_count(self) -> int:
        """Steps taken so far."""
        return self._steps

    def angle(self, t: float) -> float:
        """The leg's clockwise angle (rad) at time `t` (s)."""
        start, end = self._turn
        return self.config.start_angle + self.config.omega * (min(max(t, start), end) - start)

    def spin(self, t: float) -> float:
        """The leg's clockwise spin (rad/s) at time `t` (s)."""
        return self.config.omega if self._turn[0] <= t < self._turn[1] else 0.0

    def advance(self, t_end: float, max_steps: int = 2**62) -> int:
        """Steps toward `t_end` (s), at most `max_steps`, each of at most :attr:`interval` and none across
        the start or end of the turn; returns the number taken."""
        taken = 0
        while taken < max_steps and self._time < t_end * (1 - 1e-14):
            t1 = min(self._time + self.interval, t_end, *(b for b in self._turn if b > self._time))
            middle = 0.5 * (self._time + t1)
            load = rft.body_load(self.elements, self.angle(middle), self.hip, np.zeros(2), self.spin(middle), 0.0,
                                 self.table)
            self._impulse += (t1 - self._time) * np.array([*load.force, load.torque])
            self._time = t1
            self._steps += 1
            taken += 1
        return taken

    def rows(self) -> dict[str, dict[str, Any]]:
        """The recorder's sample ``bodies/leg``: time, angle, and the force and torque averaged since the
        previous sample (then restarted)."""
        span = self._time - self._since
        mean = self._impulse / span if span > 0 else np.zeros(3)
        self._impulse, self._since = np.zeros(3), self._time
        return {"bodies/leg": {"time": self._time, "angle": self.angle(self._time), "force": mean[:2],
                               "torque": float(mean[2])}}

    def describe(self) -> dict[str, Any]:
        """The terrain, for the run file (a flat surface at z = 0, as the robots' RFT terrain)."""
        return {"terrain": {"kind": "rft", "surface": 0.0, "zeta": self.table.zeta,
                            "coefficients": dict(self.table.coefficients),
                            "source": self.table.source, "elements": {"leg": len(self.elements)}}}

    def frame_fields(self) -> dict[str, np.ndarray]:
        """The leg's particles (``body_position``, m) and their velocities (``body_velocity``, m/s) now."""
        points, _ = self.shape.transformed(self.angle(self._time), tuple(self.hip))
        arm = points - self.hip
        return {"body_position": points,
                "body_velocity": self.spin(self._time) * np.column_stack([arm[:, 1], -arm[:, 0]])}

    def static_arrays(self) -> dict[str, np.ndarray]:
        """The leg's body index per particle and its RFT surface elements (its own frame)."""
        return {"bodies/index": np.zeros(len(self.shape.position), dtype=np.int32),
                "rft/leg/centre": self.elements.centre, "rft/leg/normal": self.elements.normal,
                "rft/leg/length": self.elements.length}

    def diagnostics(self) -> dict[str, float]:
        """A diagnostics row: the step count and the sampling interval (s); no grains to leak."""
        return {"step": self._steps, "dt": self.interval, "leaked_particles": 0}

    def run_attributes(self) -> dict[str, int]:
        """The counts of the run file's ``/run``: no grains."""
        return {"granular_particles": 0, "wall_particles": 0, "leaked_particles": 0}

    def checkpoint(self, path: str | os.PathLike[str], progress: dict[str, Any] | None = None) -> Path:
        """Writes the sweep's time, step count and running load sums with the run loop's `progress`."""
        from terrasph.checkpoint import grain_free_state, write_checkpoint

        state = grain_free_state(self._steps)
        sweep = {"time": self._time, "since": self._since, "impulse": self._impulse.tolist()}
        return write_checkpoint(path, state, self.describe(), {**(progress or {}), "sweep": sweep})

    def restore(self, path: str | os.PathLike[str]) -> dict[str, Any]:
        """Continues from a :meth:`checkpoint` of the same sweep; returns the rest of its progress."""
        from terrasph.checkpoint import CheckpointError, configuration_differences, read_checkpoint

        state, saved, progress = read_checkpoint(path)
        differences = configuration_differences(saved, self.describe())
        if differences or "sweep" not in progress:
            raise CheckpointError(f"checkpoint {path} belongs to another RFT run: {', '.join(differences) or 'no sweep'}")
        sweep = progress.pop("sweep")
        self._steps = int(state["counters"]["steps"])
        self._time, self._since = float(sweep["time"]), float(sweep["since"])
        self._impulse = np.array(sweep["impulse"], dtype=float)
        return progress
