"""Plate drag: Li, Zhang & Goldman's (2013) RFT experiment in the SPH, one (β, γ) per run.

A plate 5 cm long, ``thickness`` thick and 2.54 cm wide, at attack angle β (its tangent (cos β, sin β),
counter-clockwise from the horizontal, terrasph.terrain.rft's convention) is placed in a settled bed of the
chapter 3 glass beads with its centre ``start_depth`` below the free surface (the grains on it removed,
as the buried plate of plate-intrusion), held for ``settle_time``, then moved at constant ``speed``
in the direction γ (velocity ∥ (cos γ, −sin γ): γ = π/2 straight down, −π/2 straight up) by
``travel``. The stress per unit depth of each load sample,

    α_x = −F_x / (A d),   α_z = F_z / (A d)          (A = plate length × width, d = centre depth),

is RFT's α(β, γ) (terrasph.terrain.rft, Li et al. 2013 Eq. 1 with the sign of F_x for v_x ≥ 0); the summary
gives their means over the last ``measure_fraction`` of the travel, where the load has built up.
A sweep over (β, γ) (benchmarks/studies/sweep_rft_calibration.yaml) gives the map that ``terrasph
rft-calibrate`` fits. Li et al. pushed a thin plate in from the surface; here the plate starts buried
(so a stroke of any direction meets grains all round) and has three particle rows of thickness,
which loads its edges too: both are recorded with the map (docs/rft.md).
"""

from __future__ import annotations

import dataclasses
import math
import os
import pathlib
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from terrasph import bodies
from terrasph.config import ConfigError, Material, Numerics, check_settle_time
from terrasph.fidelity import check_tier, fidelity_option
from terrasph.geometry import wall_layers_needed
from terrasph.io import write_results
from terrasph.motion import Hold, Motion, Move
from terrasph.options import option, shared
from terrasph.scene import Scene
from terrasph.scenes.plate_intrusion import PlateConfig
from terrasph.simulation import RunResult, Simulation

__all__ = ["PlateDrag", "PlateDragResult", "build_plate_drag", "run_plate_drag"]


@dataclass(frozen=True)
class PlateDrag(PlateConfig):
    """Configuration of a plate drag. Lengths in m, times in s, angles in rad (terrasph.terrain.rft's β, γ)."""

    SCENE: ClassVar[str] = "plate-drag"

    attack_angle: float = option(0.0, help="attack angle beta of the plate, in [-pi/2, pi/2] (terrasph.terrain.rft)",
                                 unit="rad")
    direction: float = option(math.pi / 2, help="direction gamma of its motion, in [-pi/2, pi/2]", unit="rad")
    speed: float = option(0.02, help="plate speed", unit="m/s")
    travel: float = option(0.015, help="distance the plate moves", unit="m")
    start_depth: float = option(0.04, help="the plate centre's depth below the free surface at the start", unit="m")
    spacing: float = option(0.005 / 1.5, help="particle spacing dx; the plate is at least ceil(2 h_factor) rows "
                                              "thick", unit="m")
    plate_length: float = option(0.05, help="plate length", unit="m")
    thickness: float | None = option(None, help="plate thickness", unit="m", default_text="three rows")
    width: float = option(0.0254, help="out-of-plane plate width; forces are reported for it", unit="m")
    bed_width: float = shared("bed_width", 0.24)
    bed_depth: float = shared("bed_depth", 0.12)
    settle_time: float = shared("settle_time", 0.2)
    samples: int = option(30, help="load samples over the travel (each a time average)")
    measure_fraction: float = option(0.5, help="the part of the travel (its end) the summary's alpha is the mean of")
    t_end: float | None = shared("t_end", None, default_text="the end of the travel, settle_time + travel / speed")
    fidelity: str = fidelity_option("plate-drag")
    numerics: dict[str, Any] = field(default_factory=dict)  #: overrides of the tier's numerics

    def __post_init__(self) -> None:
        self.check_bed_material()
        check_tier(self.fidelity)
        for name in ("attack_angle", "direction"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and -math.pi / 2 - 1e-12 <= value <= math.pi / 2 + 1e-12):
                raise ConfigError(f"parameter '{name}' = {value!r} is invalid: allowed [-pi/2, pi/2] rad")
        for name in ("speed", "travel", "start_depth", "spacing", "plate_length", "width", "bed_width", "bed_depth"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ConfigError(f"parameter '{name}' = {value!r} is invalid: allowed a finite number > 0")
        if not (isinstance(self.samples, int) and self.samples >= 4):
            raise ConfigError(f"parameter 'samples' = {self.samples!r} is invalid: allowed an integer >= 4")
        if not 0 < self.measure_fraction <= 1:
            raise ConfigError(f"parameter 'measure_fraction' = {self.measure_fraction!r} is invalid: allowed (0, 1]")
        check_settle_time(self.settle_time, self.t_end)
        numerics = self.build_numerics()
        half = 0.5 * self.plate_length * abs(math.sin(self.attack_angle)) + self.plate_thickness
        shallowest = self.start_depth - half - self.travel * max(0.0, -math.sin(self.direction))
        deepest = self.start_depth + half + self.travel * max(0.0, math.sin(self.direction))
        floor = self.bed_depth - 2 * wall_layers_needed(numerics.h_factor) * self.spacing
        if shallowest < 2 * self.spacing or deepest > floor:
            raise ConfigError(f"parameter 'start_depth' = {self.start_depth!r} is invalid for this β, γ and travel: "
                              f"the plate would reach {shallowest:.4f}–{deepest:.4f} m deep, allowed "
                              f"[{2 * self.spacing:g}, {floor:g}] m (two rows under the surface, clear of the floor)")
        if not 0.5 * self.bed_width - 0.5 * self.plate_length - self.travel > self.plate_length:
            raise ConfigError(f"parameter 'bed_width' = {self.bed_width!r} is invalid: allowed more than "
                              f"{3 * self.plate_length + 2 * self.travel:g} m (a plate length between the plate "
                              "and each side wall over its travel)")

    @property
    def duration(self) -> float:
        """Settling pause plus the stroke (s)."""
        return self.settle_time + self.travel / self.speed

    def velocity(self) -> tuple[float, float]:
        """(v_x, v_z) of the stroke (m/s)."""
        return (self.speed * math.cos(self.direction), -self.speed * math.sin(self.direction))


def build_plate_drag(config: PlateDrag) -> tuple[Scene, Material, Numerics]:
    """The bed in its container, the plate buried at its start with the grains on it removed."""
    numerics = config.build_numerics()
    scene = Scene(spacing=config.spacing)
    surface, right = scene.add_bed_in_container(config.bed_width, config.bed_depth, 0.02,
                                                layers=wall_layers_needed(numerics.h_factor))
    try:
        shape = bodies.plate(config.plate_length, config.plate_thickness, config.width, config.spacing)
    except ValueError as error:
        raise ConfigError(f"plate geometry: {error}") from None
    start_x = 0.5 * right - 0.5 * config.travel * math.cos(config.direction)
    pieces: list[Hold | Move] = [Hold(config.settle_time)] if config.settle_time > 0 else []
    pieces.append(Move(config.travel / config.speed, config.velocity()))
    plate = scene.add_body("plate", shape, reference=(start_x, surface - config.start_depth),
                           angle=-config.attack_angle, motion=Motion(tuple(pieces)), width=config.width,
                           clear_granular=False)
    scene.clear_granular_near(plate.position, 0.5 * config.spacing)
    return scene, config.bed_material(), numerics


@dataclass
class PlateDragResult:
    """The stress per unit depth on the plate during its stroke (N/m³, per sample)."""

    travel: np.ndarray  #: the plate's travel at each sample (m)
    alpha_x: np.ndarray  #: −F_x / (A d)
    alpha_z: np.ndarray  #: F_z / (A d)
    config: PlateDrag
    leaked_particles: int
    run: RunResult
    plot: str | None = None

    def summary(self) -> dict[str, Any]:
        """β, γ and the means of α_x, α_z over the measured part of the travel (N/m³) with their
        spread (standard deviation over those samples); NaN (undefined) for a run stopped before
        the measured part."""
        measured = self.travel >= (1 - self.config.measure_fraction) * self.config.travel - 1e-12

        def over_measured(statistic: Any, values: np.ndarray) -> float:
            return float(statistic(values[measured])) if measured.any() else math.nan

        return {"attack_angle": self.config.attack_angle, "direction": self.config.direction,
                "alpha_x": over_measured(np.mean, self.alpha_x), "alpha_z": over_measured(np.mean, self.alpha_z),
                "alpha_x_spread": over_measured(np.std, self.alpha_x),
                "alpha_z_spread": over_measured(np.std, self.alpha_z),
                "spacing": self.config.spacing, "plate_thickness": self.config.plate_thickness,
                "leaked_particles": self.leaked_particles, "steps": self.run.steps, "wall_time": self.run.wall_time,
                "status": self.run.status}


def run_plate_drag(config: PlateDrag = PlateDrag(), *, output: str | os.PathLike | None = None,
                   progress: bool = True, plot: bool = True, resume: bool = False,
                   until: float | None = None) -> PlateDragResult:
    """Builds and runs a plate drag; writes HDF5 (body series under /series/bodies/plate, the
    summary and the per-sample α under /results) and, with `plot`, α_x and α_z against the travel
    as a PNG beside it."""
    scene, material, numerics = build_plate_drag(config)
    sim = Simulation(scene, material, numerics, width=config.width)
    interval = config.travel / config.speed / config.samples
    run = sim.run((config.duration if config.t_end is None else config.t_end) if until is None else until, output=output, resume=resume, frame_interval=0.5,
                  progress=progress, body_interval=interval,
                  config={"scene": "plate-drag", "plate_drag": dataclasses.asdict(config), **sim.describe()})
    series = run.bodies["plate"]
    moving = series["time"] > config.settle_time + 1e-9
    # each sample is the mean over its interval: the pose at its middle, half an interval back
    travel = config.speed * (series["time"][moving] - config.settle_time - 0.5 * interval)
    depth = scene.surface_level - (series["reference"][moving, 1] - 0.5 * interval * config.velocity()[1])
    area_depth = config.plate_length * config.width * depth
    force = series["force"][moving]
    result = PlateDragResult(travel, -force[:, 0] / area_depth, force[:, 1] / area_depth, config,
                             sim.leaked_particles, run)
    if output is not None:
        write_results(output, result.summary(), {"travel": travel, "alpha_x": result.alpha_x,
                                                 "alpha_z": result.alpha_z})
        if plot:
            result.plot = str(pathlib.Path(output).with_suffix(".png"))
            plot_plate_drag(result, result.plot)
    return result


def plot_plate_drag(result: PlateDragResult, path: str | os.PathLike[str]) -> None:
    """α_x and α_z (N/m³) against the plate's travel (mm), the measured part shaded."""
    from matplotlib.figure import Figure

    config = result.config
    figure = Figure(figsize=(6, 4))
    axes = figure.add_subplot()
    axes.plot(result.travel * 1e3, result.alpha_x, "o-", label="alpha_x = -F_x/(A d)")
    axes.plot(result.travel * 1e3, result.alpha_z, "s-", label="alpha_z = F_z/(A d)")
    axes.axvspan((1 - config.measure_fraction) * config.travel * 1e3, config.travel * 1e3, color="0.9")
    axes.set_xlabel("travel (mm)")
    axes.set_ylabel("stress per unit depth (N/m^3)")
    axes.set_title(f"plate drag, beta = {math.degrees(config.attack_angle):.0f} deg, "
                   f"gamma = {math.degrees(config.direction):.0f} deg")
    axes.legend()
    figure.savefig(path, dpi=120, bbox_inches="tight")
