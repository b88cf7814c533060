"""Plate intrusion in 3D: a horizontal box plate pushed down at constant speed into a bed at rest
(docs/sph3d.md).

A plate L × B (x, y) and three particle layers thick (the thinnest a body may be) starts with its
underside one spacing above the free surface of a bed of the chapter 3 glass beads in a box of
fixed ghost walls, at the bed's centre. After a settling pause it moves down at constant speed
until its underside is ``max_depth`` below the surface, and stays there. The vertical force of the
beads on the plate, F_z (N, + up), is recorded against the depth of its underside; in dry granular
media the resisting stress on a slowly intruding flat plate grows linearly with depth, σ_z ≈ α ρ g
z with α of order 10 (as the planar scene, :mod:`terrasph.scenes.plate_intrusion`, which names
the sources). :meth:`PlateResult3D.fit` gives the slope k of F_z against depth and
:meth:`PlateResult3D.alpha` = k / (ρ0 g L B).
"""

from __future__ import annotations

import dataclasses
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from terrasph.analysis import fit_line
from terrasph.config import ConfigError, Material, Numerics, check_settle_time, parameter
from terrasph.fidelity import fidelity_option, scene_numerics
from terrasph.io import write_results
from terrasph.options import option
from terrasph.scene import GRAVITY
from terrasph.scenes.leg_rotation import BeadBed
from terrasph.simulation import RunResult
from terrasph.size_guard import Footprint
from terrasph.sph3d import box, geostatic_bed
from terrasph.sph3d_run import Body3D, Simulation3D

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["PlateIntrusion3D", "PlateResult3D", "build_plate_intrusion_3d", "plot_intrusion_3d",
           "run_plate_intrusion_3d"]

#: Wall height above the free surface (m): room for the plate above the bed and for heaped grains.
WALL_FREEBOARD = 0.03
#: Depth (m) from which the summary's line F_z = k·depth + b is fitted (past the first contact),
#: a quarter of a shallower stroke.
FIT_FROM_DEPTH = 0.005


def _positive(name: str, value: Any) -> None:
    if not (isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and value > 0):
        raise ConfigError(f"parameter '{name}' = {value!r} is invalid: allowed a finite number > 0")


@dataclass(frozen=True)
class PlateIntrusion3D(BeadBed):
    """Configuration of a 3D plate intrusion. Lengths in m, times in s, speeds in m/s."""

    speed: float = option(0.02, help="plate speed, down", unit="m/s")
    max_depth: float = option(0.02, help="depth of the plate's underside below the free surface at the end",
                              unit="m")
    spacing: float = option(0.005, help="particle spacing dx", unit="m")
    plate_length: float = option(0.04, help="plate length L, along x", unit="m")
    plate_breadth: float = option(0.04, help="plate breadth B, along y", unit="m")
    bed_length: float = option(0.12, help="bed length along x", unit="m")
    bed_breadth: float = option(0.12, help="bed breadth along y", unit="m")
    bed_depth: float = option(0.06, help="bed depth", unit="m")
    settle_time: float = option(0.05, help="pause before the plate moves", unit="s")
    sample_travel: float = option(0.001, help="plate travel per load sample (each a time average over it)", unit="m")
    frame_interval: float = option(0.05, help="simulated time between frames", unit="s")
    model: str = option("mu_i_hypoelastic", choices=parameter("material.model").choices, cli="material-model",
                        help="constitutive model of the beads (material.model)")
    fidelity: str = fidelity_option("plate-intrusion-3d")
    numerics: dict[str, Any] = field(default_factory=dict)  #: overrides of the tier's numerics
    t_end: float | None = option(None, help="simulated end time", unit="s", default_text="the end of the stroke")

    def __post_init__(self) -> None:
        for name in ("speed", "max_depth", "spacing", "plate_length", "plate_breadth", "bed_length", "bed_breadth",
                     "bed_depth", "sample_travel", "frame_interval"):
            _positive(name, getattr(self, name))
        if self.t_end is not None:
            _positive("t_end", self.t_end)
        check_settle_time(self.settle_time, self.t_end)
        numerics = self.build_numerics()
        self.check_bed_material()
        self.material()
        layers = math.ceil(2.0 * numerics.h_factor) * self.spacing
        for name, plate, bed in (("plate_length", self.plate_length, self.bed_length),
                                 ("plate_breadth", self.plate_breadth, self.bed_breadth)):
            if not layers * (1 - 1e-9) <= plate <= bed / 2:
                raise ConfigError(f"parameter '{name}' = {plate!r} is invalid: allowed [{layers:g}, {bed / 2:g}] m "
                                  "(the wall layers' thickness, and at most half the bed so the sides stay clear)")
        floor_clear = self.bed_depth - 2 * layers
        if not self.max_depth < floor_clear:
            raise ConfigError(f"parameter 'max_depth' = {self.max_depth!r} is invalid: allowed (0, {floor_clear:g}) m "
                              "(the plate must stay clear of the floor's kernel support)")

    def build_numerics(self) -> Numerics:
        """terrasph.Numerics at this spacing: the fidelity tier's, with the overrides applied."""
        return scene_numerics("plate-intrusion-3d", self.fidelity, self.spacing, None, self.numerics)

    def material(self) -> Material:
        """The chapter 3 glass beads (with the bed's friction angles and water content) under the
        configured constitutive model."""
        return dataclasses.replace(self.bed_material(), model=self.model)

    def footprint(self) -> Footprint:
        """The bed and the plate, the box's floor and four sides up to the freeboard (size guard)."""
        height = self.bed_depth + WALL_FREEBOARD
        area = self.bed_length * self.bed_breadth + 2.0 * height * (self.bed_length + self.bed_breadth)
        return Footprint(self.spacing, 0.0, 0.0, self.end_time, self.material(), self.build_numerics(),
                         granular_volume=self.bed_length * self.bed_breadth * self.bed_depth
                         + self.plate_length * self.plate_breadth * self.thickness, wall_area=area)

    @property
    def thickness(self) -> float:
        """The plate's thickness: ceil(2·h_factor) layers of Δx, the least allowed."""
        return math.ceil(2.0 * self.build_numerics().h_factor) * self.spacing

    @property
    def stroke_time(self) -> float:
        """Time of the stroke, from one spacing above the surface to max_depth."""
        return (self.max_depth + self.spacing) / self.speed

    @property
    def end_time(self) -> float:
        """The configured t_end, or the end of the stroke."""
        return self.t_end if self.t_end is not None else self.settle_time + self.stroke_time


def build_plate_intrusion_3d(config: PlateIntrusion3D) -> Simulation3D:
    """The bed at rest (Jáky's K0 start) with the plate above its centre, moving as configured."""
    material, numerics = config.material(), config.build_numerics()
    bed = geostatic_bed((config.bed_length, config.bed_breadth, config.bed_depth), material, config.spacing,
                        h_factor=numerics.h_factor, rim=WALL_FREEBOARD)
    plate = box((config.plate_length / 2, config.plate_breadth / 2, config.thickness / 2), config.spacing,
                numerics.h_factor)
    surface = bed.size[2]
    centre = (bed.size[0] / 2, bed.size[1] / 2, surface + config.spacing + config.thickness / 2)
    motion = ((config.settle_time, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
              (config.stroke_time, 0.0, 0.0, -config.speed, 0.0, 0.0, 0.0)) if config.settle_time > 0 else \
        ((config.stroke_time, 0.0, 0.0, -config.speed, 0.0, 0.0, 0.0),)
    margin = 0.1 * max(bed.size)
    lower = np.array([-margin, -margin, -margin])
    upper = np.array([bed.size[0] + margin, bed.size[1] + margin, surface + WALL_FREEBOARD + margin])
    return Simulation3D(bed, material, numerics, lower, upper, (Body3D("plate", plate, centre, motion=motion),))


@dataclass
class PlateResult3D:
    """F_z (N, + up) of the beads on the plate against the depth of its underside (m), each a time
    average over one sample (its mean depth), from the start of the stroke on."""

    depth: np.ndarray
    force: np.ndarray
    config: PlateIntrusion3D
    granular_particles: int
    leaked_particles: int
    reference_density: float
    run: RunResult
    plot: str | None = None

    def fit(self) -> tuple[float, float, float]:
        """Slope k (N/m), intercept (N) and R² of F_z against depth past FIT_FROM_DEPTH (NaN if
        fewer than three samples)."""
        start = min(FIT_FROM_DEPTH, 0.25 * self.config.max_depth)
        keep = self.depth >= start
        if keep.sum() < 3:
            return math.nan, math.nan, math.nan
        return fit_line(self.depth[keep], self.force[keep])

    @property
    def reference_slope(self) -> float:
        """ρ0 g L B (N/m): the slope of F_z for α = 1."""
        return self.reference_density * GRAVITY * self.config.plate_length * self.config.plate_breadth

    def alpha(self) -> float:
        """α = k / (ρ0 g L B), the dimensionless slope."""
        return self.fit()[0] / self.reference_slope

    def summary(self) -> dict[str, Any]:
        """The run's key figures (JSON-ready)."""
        slope, intercept, r_squared = self.fit()
        return {"scene": "plate-intrusion-3d", "slope": slope, "intercept": intercept, "r_squared": r_squared,
                "alpha": self.alpha(), "max_force": float(self.force.max()) if len(self.force) else math.nan,
                "granular_particles": self.granular_particles, "leaked_particles": self.leaked_particles,
                "status": self.run.status, "time": self.run.time, "steps": self.run.steps,
                "wall_time": self.run.wall_time}


def run_plate_intrusion_3d(config: PlateIntrusion3D = PlateIntrusion3D(), *,
                           output: str | os.PathLike[str] | None = None, progress: bool = True, plot: bool = True,
                           resume: bool = False, until: float | None = None) -> PlateResult3D:
    """Builds and runs a 3D plate intrusion; writes the run file (frames, XDMF sidecars, the
    plate's series under /series/bodies/plate, the summary under /results, a checkpoint) and a PNG
    of F_z against depth beside it. ``resume=True`` continues the run in `output` from its
    checkpoint, bitwise; ``until`` replaces the end time."""
    sim = build_plate_intrusion_3d(config)
    sample = config.sample_travel / config.speed
    run = sim.run(config.end_time if until is None else until, output=output, resume=resume,
                  frame_interval=config.frame_interval, body_interval=sample, progress=progress,
                  config={"scene": "plate-intrusion-3d", "plate_intrusion_3d": dataclasses.asdict(config),
                          **sim.describe()})
    series = run.bodies["plate"]
    time = np.asarray(series.get("time", np.zeros(0)))
    underside = np.asarray(series.get("reference", np.zeros((0, 3))))[:, 2] - config.thickness / 2
    depth = sim.bed.size[2] - underside
    force = np.asarray(series.get("mean_force", np.zeros((0, 3))))[:, 2]
    moving = time[1:] > config.settle_time + 1e-12 if len(time) else np.zeros(0, bool)
    middle = 0.5 * (depth[:-1] + depth[1:]) if len(depth) else depth  # the mean depth over each sample
    result = PlateResult3D(middle[moving], force[1:][moving], config, len(sim.core.mass), sim.leaked_particles,
                           config.material().reference_density, run)
    if output is not None:
        write_results(output, result.summary(), {"depth": result.depth, "force_z": result.force})
        if plot:
            png = Path(output).with_suffix(".png")
            plot_intrusion_3d(result, path=png)
            result.plot = os.fspath(png)
    return result


def plot_intrusion_3d(result: PlateResult3D, *, path: str | os.PathLike[str] | None = None) -> Figure:
    """F_z against depth with the line fit (matplotlib Figure, no pyplot); saved to `path` when given."""
    from matplotlib.figure import Figure

    figure = Figure(figsize=(6.4, 4.0), layout="constrained")
    axes = figure.add_subplot()
    axes.plot(1e3 * result.depth, result.force, "o-", ms=3, label="down stroke")
    slope, intercept, r_squared = result.fit()
    if math.isfinite(slope):
        line = np.array([0.0, result.config.max_depth])
        axes.plot(1e3 * line, slope * line + intercept, "k--",
                  label=f"fit: k = {slope:.3g} N/m, R² = {r_squared:.3f}, α = {result.alpha():.2g}")
    axes.axhline(0.0, color="0.6", lw=0.8)
    axes.set_xlabel("depth of the plate underside (mm)")
    axes.set_ylabel("vertical force $F_z$ (N)")
    c = result.config
    axes.set_title(f"3D plate {1e3 * c.plate_length:g} × {1e3 * c.plate_breadth:g} mm, v = {1e3 * c.speed:g} mm/s, "
                   f"Δx = {1e3 * c.spacing:g} mm")
    axes.legend()
    if path is not None:
        figure.savefig(path, dpi=150)
    return figure
