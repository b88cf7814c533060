"""Plate intrusion: a horizontal plate pushed slowly down into a settled bed, then pulled up.

A plate 4 cm long, three particle rows thick (the thinnest a body may be, bodies.minimum_thickness)
and 2.54 cm wide starts with its underside one spacing above the free surface of a 20 cm × 10 cm
bed of 3 mm glass beads, at the bed's centre. After a settling pause it moves down at constant
speed until its underside is 4 cm below the surface, then back up at the same speed to where it
started. The vertical force of the beads on the plate, F_z (N for the real width, + up), is
recorded against the depth of the underside below the undisturbed surface.

It is the simplest check of the body coupling and a calibration point: in dry granular media the
resisting stress on a slowly intruding flat plate grows linearly with depth, σ_z ≈ α ρ g z with α
of order 10 (resistive force theory, Li, Zhang & Goldman 2013, Science 339:1408; impact and
intrusion, Katsuragi & Durian 2007, Nature Phys. 3:420; in soil mechanics the bearing capacity
q = γ D N_q + ½ γ B N_γ, with N_q = e^{π tan φ} tan²(45° + φ/2) ≈ 9–26 for φ = 23–33°,
Terzaghi 1943). :meth:`PlateResult.fit` gives the slope k of F_z against depth and
:meth:`PlateResult.alpha` = k / (ρ0 g L W), the α of that scaling.

**Buried start** (``buried_depth`` = H): the plate is placed in the bed with its top face
H below the surface before anything moves, so the grains above it form an intact column that
settles on it; after ``settle_time`` it is pulled straight up by ``pull_distance`` at ``speed``.
This is the plane-strain strip-anchor uplift test of soil mechanics, to compare with the dead
weight of the grains above, γHB, and the vertical-slip-surface estimate γHB(1 + K tan φ·H/B)
(:func:`anchor_uplift_references`). The default (``buried_depth=None``) pushes the plate in from
above the surface first, so what lies above it on the way up is the loosened refill of its crater.
"""

from __future__ import annotations

import dataclasses
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from terrasph import bodies
from terrasph.analysis import fit_line
from terrasph.config import (
    ConfigError,
    Material,
    Numerics,
    check_settle_time,
    parameter,
)
from terrasph.fidelity import check_tier, fidelity_option, scene_numerics
from terrasph.geometry import wall_layers_needed
from terrasph.io import write_results
from terrasph.motion import Hold, Motion, Move
from terrasph.options import option, shared
from terrasph.scene import GRAVITY, Scene
from terrasph.scenes.leg_rotation import BeadBed
from terrasph.simulation import RunResult, Simulation
from terrasph.size_guard import Footprint

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["RESOLUTIONS", "PlateIntrusion", "PlateResult", "anchor_uplift_references", "build_plate_intrusion",
           "plot_intrusion", "run_plate_intrusion", "stroke_samples"]

#: Wall height above the free surface (m): room for the plate above the bed and for heaped grains.
WALL_FREEBOARD = 0.05

#: Depth (m) from which the summary's line F_z = k·depth + b is fitted: past the first contact,
#: where the load builds up (docs/benchmarks.md, tests/test_plate_intrusion.py); a stroke shallower
#: than 4 cm is fitted from a quarter of its depth.
FIT_FROM_DEPTH = 0.01

#: Particle spacing Δx (m) per named resolution; "coarse" is the default PlateIntrusion.spacing.
RESOLUTIONS: dict[str, float] = {"coarse": 0.0025, "fine": 0.002, "finer": 0.0016}


class PlateConfig(BeadBed):
    """What the plate scenes' configurations share (plate-intrusion, plate-drag): the bed's material
    options, the numerics at their `spacing` and fidelity tier with their `numerics` overrides, and the
    plate's thickness."""

    SCENE: ClassVar[str]  #: the registered scene, whose fidelity tiers apply
    spacing: float
    thickness: float | None
    fidelity: str
    numerics: dict[str, Any]

    def build_numerics(self) -> Numerics:
        """terrasph.Numerics at this spacing and fidelity with the overrides applied."""
        return scene_numerics(self.SCENE, self.fidelity, self.spacing, overrides=self.numerics)

    @property
    def plate_thickness(self) -> float:
        """Thickness as given, or the least allowed: ceil(2·h_factor) rows of Δx."""
        if self.thickness is not None:
            return self.thickness
        return bodies.minimum_thickness(self.spacing, self.build_numerics().h_factor)


@dataclass(frozen=True)
class PlateIntrusion(PlateConfig):
    """Configuration of a plate intrusion. Lengths in m, times in s, speeds in m/s."""

    SCENE: ClassVar[str] = "plate-intrusion"

    speed: float = option(0.02, help="plate speed, down then up", unit="m/s")
    max_depth: float = option(0.04, help="depth of the plate's underside below the free surface at the turn",
                              unit="m")
    spacing: float = option(0.0025, help="particle spacing dx", unit="m", presets=RESOLUTIONS)
    plate_length: float = option(0.04, help="plate length L, along x", unit="m")
    thickness: float | None = option(None, help="plate thickness", unit="m",
                                     default_text="the least, 3 dx at h = 1.3 dx")
    width: float = option(0.0254, help="out-of-plane plate width W; forces are reported for it", unit="m")
    bed_width: float = shared("bed_width", 0.20)
    bed_depth: float = shared("bed_depth", 0.10)
    gap: float | None = option(None, help="start height of the underside above the surface", unit="m",
                               default_text="dx, the least")
    settle_time: float = shared("settle_time", 0.2)  #: the plate is held still
    sample_travel: float = option(0.001, help="plate travel per load sample (each a time average over it)", unit="m")
    frame_interval: float = shared("frame_interval", 0.1)
    model: str = option("mu_i_hypoelastic", choices=parameter("material.model").choices, cli="material-model",
                        help="constitutive model of the beads (material.model)")
    fidelity: str = fidelity_option("plate-intrusion")
    numerics: dict[str, Any] = field(default_factory=dict)  #: overrides of terrasph.Numerics
    buried_depth: float | None = option(
        None, unit="m", default_text="start above the surface, push in to --max-depth and pull out",
        help="start buried instead, the plate's top face this far below the surface, and only pull it up "
             "(a strip anchor)")
    pull_distance: float = option(0.015, help="with --buried-depth: upward travel of the plate", unit="m")
    geostatic: bool | None = option(None, help="start geostatic, K0 = 1 - sin(phi) (Simulation's geostatic)",
                                    default_text="yes for every model with a stress state")
    t_end: float | None = shared("t_end", None, default_text="the end of the strokes")

    def __post_init__(self) -> None:
        self.check_bed_material()
        check_tier(self.fidelity)
        for name in ("speed", "max_depth", "spacing", "plate_length", "width", "bed_width", "bed_depth",
                     "sample_travel", "frame_interval"):
            value = getattr(self, name)
            if not (_is_number(value) and math.isfinite(value) and value > 0):
                raise ConfigError(f"parameter '{name}' = {value!r} is invalid: allowed a finite number > 0")
        if self.t_end is not None and not (_is_number(self.t_end) and math.isfinite(self.t_end) and self.t_end > 0):
            raise ConfigError(f"parameter 't_end' = {self.t_end!r} is invalid: allowed a finite number > 0 s or None")
        check_settle_time(self.settle_time, self.t_end)
        numerics = self.build_numerics()  # raises ConfigError for bad overrides
        self.material()  # raises ConfigError for an unknown model
        least = bodies.minimum_thickness(self.spacing, numerics.h_factor)
        if self.thickness is not None and not (_is_number(self.thickness) and math.isfinite(self.thickness)
                                               and least * (1 - 1e-9) <= self.thickness < 0.5 * self.plate_length):
            raise ConfigError(f"parameter 'thickness' = {self.thickness!r} is invalid: allowed [{least:g}, "
                              f"{0.5 * self.plate_length:g}) m (at least {wall_layers_needed(numerics.h_factor)} "
                              "particle rows, so that no grain interacts through the plate; less than half its length)")
        if self.gap is not None and not (_is_number(self.gap) and math.isfinite(self.gap)
                                         and self.spacing * (1 - 1e-9) <= self.gap <= WALL_FREEBOARD / 2):
            raise ConfigError(f"parameter 'gap' = {self.gap!r} is invalid: allowed [{self.spacing:g}, "
                              f"{WALL_FREEBOARD / 2:g}] m (at least one spacing above the surface)")
        if self.geostatic is not None and not isinstance(self.geostatic, bool):
            raise ConfigError(f"parameter 'geostatic' = {self.geostatic!r} is invalid: allowed True, False or None")
        # the plate's underside must stay clear of the floor's kernel support, buried or pushed in
        floor_clear = self.bed_depth - self.plate_thickness - 2 * wall_layers_needed(numerics.h_factor) * self.spacing
        if self.buried_depth is not None:
            lowest = 2 * self.spacing
            if not (_is_number(self.buried_depth) and math.isfinite(self.buried_depth)
                    and lowest * (1 - 1e-9) <= self.buried_depth < floor_clear):
                raise ConfigError(f"parameter 'buried_depth' = {self.buried_depth!r} is invalid: allowed "
                                  f"[{lowest:g}, {floor_clear:g}) m (at least two particle rows above the "
                                  "plate; its underside clear of the floor's kernel support)")
            if not (_is_number(self.pull_distance) and math.isfinite(self.pull_distance)
                    and 0 < self.pull_distance <= self.buried_depth + WALL_FREEBOARD / 2):
                raise ConfigError(f"parameter 'pull_distance' = {self.pull_distance!r} is invalid: allowed "
                                  f"(0, {self.buried_depth + WALL_FREEBOARD / 2:g}] m (buried_depth + half the "
                                  "wall freeboard)")
        if not 2 * self.spacing <= 0.5 * self.plate_length:
            raise ConfigError(f"parameter 'plate_length' = {self.plate_length!r} is invalid: allowed >= "
                              f"{4 * self.spacing:g} m (4 spacings)")
        if not self.plate_length <= self.bed_width / 3:
            raise ConfigError(f"parameter 'plate_length' = {self.plate_length!r} is invalid: allowed <= bed_width/3 "
                              f"= {self.bed_width / 3:g} m (side walls at least one plate length from its ends)")
        if self.buried_depth is None and not self.max_depth < floor_clear:  # a buried start does not use it
            raise ConfigError(f"parameter 'max_depth' = {self.max_depth!r} is invalid: allowed (0, {floor_clear:g}) m "
                              "(the plate must stay clear of the floor's kernel support)")

    def material(self) -> Material:
        """The bed's glass beads (:meth:`bed_material`) under the configured constitutive model."""
        return dataclasses.replace(self.bed_material(), model=self.model)

    def footprint(self) -> Footprint:
        """The bed and the plate, the container's floor and sides (size guard)."""
        return Footprint(self.spacing, self.bed_width * self.bed_depth + self.plate_length * self.plate_thickness,
                         self.bed_width + 2.0 * (self.bed_depth + WALL_FREEBOARD), self.end_time, self.material(),
                         self.build_numerics())

    @property
    def buried(self) -> bool:
        """Whether the plate starts buried in the bed (``buried_depth`` given)."""
        return self.buried_depth is not None

    @property
    def start_gap(self) -> float:
        """Height of the plate's underside above the free surface at the start (m); negative for
        a buried start (−(buried_depth + thickness))."""
        if self.buried_depth is not None:
            return -(self.buried_depth + self.plate_thickness)
        return self.spacing if self.gap is None else self.gap

    @property
    def stroke(self) -> float:
        """Travel of one stroke (m): from the start to the deepest point, or the buried start's
        pull distance."""
        if self.buried_depth is not None:
            return self.pull_distance
        return self.start_gap + self.max_depth

    @property
    def stroke_time(self) -> float:
        """Duration of one stroke (s)."""
        return self.stroke / self.speed

    @property
    def sample_interval(self) -> float:
        """Time between load samples (s): `sample_travel` of travel, adjusted so a stroke holds a
        whole number of samples."""
        return self.stroke_time / max(1, round(self.stroke / self.sample_travel))

    @property
    def strokes(self) -> int:
        """2 (down and up) from above the surface, 1 (up) from a buried start."""
        return 1 if self.buried else 2

    @property
    def duration(self) -> float:
        """Settling pause plus the strokes (s)."""
        return self.settle_time + self.strokes * self.stroke_time

    @property
    def end_time(self) -> float:
        """When the run stops: `t_end`, or the end of the strokes (s)."""
        return self.duration if self.t_end is None else self.t_end

    def motion(self) -> Motion:
        """Hold, down at `speed` through the stroke, up at `speed` back to the start, then hold; from
        a buried start: hold, then up at `speed` by `pull_distance`."""
        pieces: list[Hold | Move] = [Hold(self.settle_time)] if self.settle_time > 0 else []
        if not self.buried:
            pieces.append(Move(self.stroke_time, (0.0, -self.speed)))
        pieces.append(Move(self.stroke_time, (0.0, self.speed)))
        return Motion(tuple(pieces))


def _is_number(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def build_plate_intrusion(config: PlateIntrusion) -> tuple[Scene, Material, Numerics]:
    """The bed in its rough container, the plate above its centre (or buried under it, with the
    grains within Δx of the plate removed), the material and the numerics."""
    dx = config.spacing
    numerics = config.build_numerics()
    layers = wall_layers_needed(numerics.h_factor)
    scene = Scene(spacing=dx)
    surface, right = scene.add_bed_in_container(config.bed_width, config.bed_depth, WALL_FREEBOARD, layers=layers)
    try:
        shape = bodies.plate(config.plate_length, config.plate_thickness, config.width, dx)
    except ValueError as error:
        raise ConfigError(f"plate geometry: {error}") from None
    # the reference point is the plate's centre; its underside is half the realised rows below it
    half = 0.5 * dx * round(config.plate_thickness / dx)
    centre = (0.5 * right, surface + config.start_gap + half)
    plate = scene.add_body("plate", shape, reference=centre, motion=config.motion(), width=config.width,
                           clear_granular=not config.buried)
    if config.buried:  # the plate's particles sit on lattice sites: remove the grains on them only,
        scene.clear_granular_near(plate.position, 0.5 * dx)  # so the bed touches it at Δx all round
    return scene, config.material(), numerics


@dataclass
class PlateResult:
    """Vertical load on the plate against the depth of its underside, per load sample.

    Each sample is a time average over `sample_travel` of travel; samples whose averaging window
    straddles the turn (or the start) are dropped, so every one belongs wholly to a stroke.
    """

    depth: np.ndarray  #: underside below the undisturbed surface at the window's middle (m, + down)
    force: np.ndarray  #: F_z of the beads on the plate (N for the real width, + up), window mean
    phase: np.ndarray  #: "down" or "up" per sample
    time: np.ndarray  #: end of each averaging window (s)
    config: PlateIntrusion
    granular_particles: int
    leaked_particles: int
    bulk_density: float  #: ρ0 of the material (kg/m³), for alpha
    run: RunResult
    plot: str | None = None

    def stroke(self, phase: str) -> tuple[np.ndarray, np.ndarray]:
        """(depth, F_z) of the "down" or "up" stroke, ordered by increasing depth."""
        if phase not in ("down", "up"):
            raise ValueError(f"phase = {phase!r} must be 'down' or 'up'")
        mask = self.phase == phase
        order = np.argsort(self.depth[mask])
        return self.depth[mask][order], self.force[mask][order]

    @property
    def fit_from(self) -> float:
        """The depth (m) from which the run's line is fitted: FIT_FROM_DEPTH, or a quarter of a
        stroke shallower than 4 cm."""
        return min(FIT_FROM_DEPTH, 0.25 * self.config.max_depth)

    def fit(self, min_depth: float | None = None, max_depth: float | None = None) -> tuple[float, float, float]:
        """Line F_z = k·depth + b over the down stroke for min_depth < depth ≤ max_depth (defaults:
        :attr:`fit_from` and the deepest: the one fit of the summary and the figure); returns (k in
        N/m, b in N, R²), NaN for a run stopped before two samples of that range."""
        min_depth = self.fit_from if min_depth is None else min_depth
        depth, force = self.stroke("down")
        upper = (depth.max() if depth.size else math.nan) if max_depth is None else max_depth
        mask = (depth > min_depth) & (depth <= upper + 1e-12)
        if np.count_nonzero(mask) < 2:
            return math.nan, math.nan, math.nan
        return fit_line(depth[mask], force[mask])

    @property
    def reference_slope(self) -> float:
        """ρ0 g L W (N/m): the slope of F_z against depth for α = 1 in σ_z = α ρ g z."""
        return self.bulk_density * GRAVITY * self.config.plate_length * self.config.width

    def alpha(self, min_depth: float | None = None) -> float:
        """α = k / (ρ0 g L W), the slope of the down-stroke fit (:meth:`fit`) in units of the hydrostatic one."""
        return self.fit(min_depth)[0] / self.reference_slope

    def hysteresis(self, depths: np.ndarray) -> np.ndarray:
        """F_z(down) − F_z(up) at the given depths (N), by linear interpolation along each stroke."""
        down_d, down_f = self.stroke("down")
        up_d, up_f = self.stroke("up")
        return np.interp(depths, down_d, down_f) - np.interp(depths, up_d, up_f)

    def extraction_peak(self) -> tuple[float, float]:
        """Buried start: (uplift in m, load in N) of the largest downward load of the beads on the
        plate during the pull (the up stroke's most negative F_z, sign flipped); uplift is the
        plate's travel from its buried position at that sample's window middle."""
        depth, force = self.stroke("up")
        if len(force) == 0:
            raise ValueError("no sample of the up stroke")
        k = int(np.argmax(-force))
        return float(self.uplift(depth[k])), float(-force[k])

    def uplift(self, depth: np.ndarray | float) -> np.ndarray | float:
        """Buried start: the plate's travel from its buried position (m) at underside `depth` (m)."""
        return (self.config.buried_depth or 0.0) + self.config.plate_thickness - depth

    def uplift_references(self) -> dict[str, float]:
        """Buried start: :func:`anchor_uplift_references` for this plate, bed and material
        (H = buried_depth, B = plate_length, W = width, γ = ρ0 g, φ = atan μ1)."""
        if self.config.buried_depth is None:
            raise ValueError("uplift references need a buried start (buried_depth)")
        return anchor_uplift_references(self.config.buried_depth, self.config.plate_length, self.config.width,
                                        self.bulk_density, float(np.arctan(self.config.material().mu1)))

    def summary(self) -> dict[str, Any]:
        """Flat dict for tables and HDF5 attributes; the fit starts at `fit_from` (FIT_FROM_DEPTH).
        Values a run stopped early has not reached yet are NaN. A buried start has no down stroke: its summary holds the peak extraction load and the
        uplift references instead of the fit."""
        run = {"samples": len(self.depth), "granular_particles": self.granular_particles,
               "leaked_particles": self.leaked_particles, "steps": self.run.steps, "time": self.run.time,
               "wall_time": self.run.wall_time, "status": self.run.status}
        if self.config.buried:  # a run stopped before the pull began has no peak yet (NaN)
            uplift, peak = self.extraction_peak() if len(self.stroke("up")[1]) else (math.nan, math.nan)
            refs = self.uplift_references()
            return {"speed": self.config.speed, "buried_depth": self.config.buried_depth,
                    "pull_distance": self.config.pull_distance, "spacing": self.config.spacing,
                    "plate_thickness": self.config.plate_thickness, "peak_extraction": peak,
                    "peak_uplift": uplift, "dead_weight": refs["dead_weight"],
                    "vertical_slip": refs["vertical_slip"], "peak_over_dead_weight": peak / refs["dead_weight"],
                    "peak_over_vertical_slip": peak / refs["vertical_slip"], **run}
        fit_from = self.fit_from
        slope, intercept, r_squared = self.fit()
        _, down_force = self.stroke("down")
        return {"speed": self.config.speed, "max_depth": self.config.max_depth, "spacing": self.config.spacing,
                "plate_thickness": self.config.plate_thickness, "fit_from": fit_from,
                "slope": slope, "intercept": intercept,
                "r_squared": r_squared, "alpha": slope / self.reference_slope,
                "peak_force": float(down_force.max()) if down_force.size else math.nan, "samples": len(self.depth),
                "granular_particles": self.granular_particles, "leaked_particles": self.leaked_particles,
                "steps": self.run.steps, "time": self.run.time, "wall_time": self.run.wall_time,
                "status": self.run.status}


def stroke_samples(series: dict[str, np.ndarray], config: PlateIntrusion) -> tuple[np.ndarray, ...]:
    """Depth at the window middle, F_z, phase and window end of the samples inside one stroke, from a
    body series (time, sinkage of the underside, force (x, z)); the planar and the 3D plate share it."""
    time = series["time"]
    depth = series["sinkage"]
    start, end = config.settle_time, config.duration
    turn = start if config.buried else start + config.stroke_time  # a buried start has only the up stroke
    tol = 1e-6 * config.sample_interval
    begin = time[:-1]  # window k runs from sample k-1 to sample k; the plate moves linearly, so
    stop = time[1:]  # the mean depth over it is the mean of its end depths
    middle = 0.5 * (depth[:-1] + depth[1:])
    down = (begin >= start - tol) & (stop <= turn + tol)
    up = (begin >= turn - tol) & (stop <= end + tol)
    keep = down | up
    phase = np.where(down, "down", "up")[keep]
    return middle[keep], series["force"][1:, 1][keep], phase, stop[keep]


def run_plate_intrusion(config: PlateIntrusion = PlateIntrusion(), *, output: str | os.PathLike | None = None,
                        progress: bool = True, plot: bool = True,
                        resume: bool = False, until: float | None = None) -> PlateResult:
    """Builds and runs a plate intrusion; writes HDF5 (body series under /series/bodies/plate,
    summary under /results) and a PNG of F_z against depth beside it.

    ``resume=True`` continues the run in `output` from its checkpoint; ``until`` replaces the end
    time (see :meth:`terrasph.simulation.Simulation.run`).
    """
    scene, material, numerics = build_plate_intrusion(config)
    sim = Simulation(scene, material, numerics, width=config.width, geostatic=config.geostatic)
    run = sim.run(config.end_time if until is None else until, output=output, resume=resume,
                  frame_interval=config.frame_interval, progress=progress,
                  body_interval=config.sample_interval,
                  config={"scene": "plate-intrusion", "plate_intrusion": dataclasses.asdict(config), **sim.describe()})
    depth, force, phase, time = stroke_samples(run.bodies["plate"], config)
    result = PlateResult(depth, force, phase, time, config, len(sim.mass), sim.leaked_particles,
                         material.reference_density, run)
    if output is not None:
        write_results(output, result.summary(),
                      {"depth": depth, "force_z": force, "phase": phase.astype("S4"), "time": time})
        if plot:
            png = Path(output).with_suffix(".png")
            plot_intrusion(result, path=png)
            result.plot = os.fspath(png)
    return result


def anchor_uplift_references(depth: float, breadth: float, width: float, bulk_density: float,
                             friction_angle: float, gravity: float = GRAVITY) -> dict[str, float]:
    """Uplift resistance of a plane-strain strip anchor of breadth B whose top face lies H below
    the surface of a cohesionless bed of unit weight γ = ρ g, for an out-of-plane width W (N):

    * ``dead_weight`` γHBW, the grains right above the plate;
    * ``vertical_slip`` γHBW(1 + K tan φ·H/B) with K = K0 = 1 − sin φ: the prism above the plate
      lifted along two vertical slip surfaces, each carrying the shear ∫0^H K γ z tan φ dz. The
      vertical slip surface model goes back to Majer (1955) and is the form Murray & Geddes (1987)
      compare with their strip-anchor tests in sand; Dickin (1994, Soils and Foundations 34(2):41)
      found it "alone in providing sensible predictions" for pipes in loose sand, and White, Cheuk &
      Bolton (2008, Géotechnique 58(10):771) build their limit-equilibrium solution for pipes and
      strip anchors on it (with a dilation-dependent K; K0 is the at-rest, no-dilation choice).
    """
    k0 = 1.0 - math.sin(friction_angle)
    dead = bulk_density * gravity * depth * breadth * width
    return {"dead_weight": dead, "vertical_slip": dead * (1.0 + k0 * math.tan(friction_angle) * depth / breadth),
            "k0": k0}


def plot_intrusion(result: PlateResult, *, path: str | os.PathLike[str] | None = None) -> Figure:
    """F_z against depth for the down and up strokes with the down-stroke line fit, or for a buried
    start the extraction load against uplift with the dead weight and vertical-slip references
    (matplotlib Figure, no pyplot); saved to `path` when given."""
    from matplotlib.figure import Figure

    figure = Figure(figsize=(6.4, 4.0), layout="constrained")
    axes = figure.add_subplot()
    (_draw_pull if result.config.buried else _draw_strokes)(axes, result)
    axes.legend()
    if path is not None:
        figure.savefig(path, dpi=150)
    return figure


def _draw_pull(axes: Axes, result: PlateResult) -> None:
    """Buried start: the extraction load against uplift, with the dead weight and vertical-slip lines."""
    depth, force = result.stroke("up")
    axes.plot(1e3 * result.uplift(depth), -force, "s-", ms=3, label="extraction load (down)")
    refs = result.uplift_references()
    axes.axhline(refs["dead_weight"], color="k", ls="--", label="dead weight γHBW")
    axes.axhline(refs["vertical_slip"], color="k", ls=":", label="vertical slip γHBW(1 + K0 tan φ H/B)")
    axes.set_xlabel("uplift of the plate (mm)")
    axes.set_ylabel("load of the beads on the plate, down (N)")
    axes.set_title(f"buried plate {1e3 * result.config.plate_length:g} mm at H = "
                   f"{1e3 * (result.config.buried_depth or 0.0):g} mm, v = {1e3 * result.config.speed:g} mm/s")


def _draw_strokes(axes: Axes, result: PlateResult) -> None:
    """Start above the bed: F_z against depth for both strokes, with the down stroke's line fit (the
    summary's, from its fit_from depth: the line is drawn over that range)."""
    for phase, style in (("down", "o-"), ("up", "s-")):
        depth, force = result.stroke(phase)
        axes.plot(1e3 * depth, force, style, ms=3, label=f"{phase} stroke")
    slope, intercept, r_squared = result.fit()
    if math.isfinite(slope):  # a run stopped early may have no fit yet
        line = np.array([result.fit_from, result.config.max_depth])
        axes.plot(1e3 * line, slope * line + intercept, "k--",
                  label=f"fit from {1e3 * result.fit_from:.3g} mm: k = {slope:.3g} N/m, R² = {r_squared:.3f}, "
                        f"α = {slope / result.reference_slope:.3g}")
    axes.axhline(0.0, color="0.6", lw=0.8)
    axes.axvline(0.0, color="0.6", lw=0.8)
    axes.set_xlabel("depth of the plate underside (mm)")
    axes.set_ylabel("vertical force $F_z$ (N)")
    axes.set_title(f"plate {1e3 * result.config.plate_length:g} mm, v = {1e3 * result.config.speed:g} mm/s, "
                   f"Δx = {1e3 * result.config.spacing:g} mm")
