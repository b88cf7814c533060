"""Granular column collapse (dissertation ch. 2): a 7 cm wide, 8 cm tall column of 2 mm glass
beads against a rough left wall, released by removing a gate on its right, on a rough floor that is
flat or curved (Fig. 2.7–2.8: the lowest point of a circular or elliptical trough at the left wall,
the bed rising to the right)."""

from __future__ import annotations

import dataclasses
import math
import os
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from terrasph.config import ConfigError, Material, Numerics, check_settle_time, parameter
from terrasph.fidelity import check_tier, fidelity_option, scene_numerics
from terrasph.geometry import aligned_wall_layers, elliptical_arc, trough_height, wall_layers_needed
from terrasph.io import write_results
from terrasph.options import option, shared
from terrasph.scene import Scene
from terrasph.simulation import RunResult, Simulation
from terrasph.size_guard import Footprint

__all__ = ["BEDS", "FLOOR_RUNOUT_FACTOR", "MATERIAL_PRESETS", "MIN_FLOOR_LENGTH", "RESOLUTIONS", "ColumnCollapse",
           "ColumnResult", "build_column_collapse", "lube_runout", "run_column_collapse"]

#: the flat floor's least length (m), the dissertation's
MIN_FLOOR_LENGTH = 0.35
#: the flat floor reaches this many times the runout of Lube et al.'s fit (:func:`lube_runout`) past
#: the column: the 0.5 m tall column (a = 7.25, coarse) ran out 1.35 times the fit to its deposit
#: front and its toe 1.39 times, so a floor of the fit's reach let it run past its end (the run ended
#: "unstable" as its grains left the domain box)
FLOOR_RUNOUT_FACTOR = 2.0


def lube_runout(aspect: float) -> float:
    """The quasi-2D runout L* = (L∞ − L0)/L0 of Lube, Huppert, Sparks & Freundt (2005, Phys. Rev. E 72,
    041301) for aspect ratio a = H0/L0: 1.2a for a ≤ 1.8, 1.9a^(2/3) for a ≥ 2.8, and in the
    transition between them the value of the nearer branch's end, linearly interpolated (their data
    pass from one law to the other there)."""
    if aspect <= 1.8:
        return 1.2 * aspect
    if aspect >= 2.8:
        return 1.9 * aspect ** (2.0 / 3.0)
    low, high = 1.2 * 1.8, 1.9 * 2.8 ** (2.0 / 3.0)
    return low + (high - low) * (aspect - 1.8) / (2.8 - 1.8)

#: The runout front is where the deposit first becomes thinner than this many grain diameters (8 mm
#: for the 2 mm beads; 0.1·H0 for the 8 cm column). A physical thickness, not a fraction of H0, so
#: that tall columns' fronts are not cut into the real deposit. The thin tail beyond it is
#: not resolved: one to three particles thick, with no overburden, so P ≈ 0 and no basal friction,
#: it runs far during the collapse as a resolution artefact (it does come to rest, by ~0.6 s on the
#: 7 × 8 cm column) and lengthens with refinement (docs/design_decisions.md, docs/chapter2.md).
#: Its reach is reported separately as `toe_front`; ``numerics.wall_friction_coefficient`` stops
#: it earlier and shorter.
DEPOSIT_THICKNESS_GRAIN_DIAMETERS = 4.0

#: Target numbers of interior (granular) particles: the dissertation's 475 / 1036 / 2310 (Fig. 2.5d)
#: and two finer levels, 2× and 4× "fine".
RESOLUTIONS: dict[str, int] = {"coarse": 475, "fit": 1036, "fine": 2310, "finer": 4620, "finest": 9240}

#: Bed shapes: flat (the floor), circular (radius `bed_radius`) and elliptical (semi-axes `bed_axes`).
BEDS = ("flat", "circular", "elliptical")

#: Bulk (reference) density of the column material. "table_2_1": the dissertation's Table 2.1,
#: ρ0 = 2507 kg/m³ beside the grain density ρ_s = 2532 kg/m³, which makes Eq. 2.44's artificial
#: sound speed c0 = √(κγρ_s/(ρ0(ρ_s − ρ0))) = 89 m/s and so the step small. "packed": the bulk
#: density of the same beads in a random packing, ρ0 = ν ρ_s with the material's packing fraction
#: ν = 0.6 (1519 kg/m³; c0 = 18 m/s, the elastic P-wave speed 14 m/s), a five times larger step.
MATERIAL_PRESETS = ("table_2_1", "packed")
TABLE_2_1_REFERENCE_DENSITY = 2507.0  #: ρ0 of Table 2.1 (kg/m³), the "table_2_1" preset


@dataclass(frozen=True)
class ColumnCollapse:
    """Configuration of a column collapse. Lengths in m, times in s, friction angles in degrees."""

    #: fields saved under another name by earlier versions (run files, sweep SPECs): old → new
    RENAMED_FIELDS: ClassVar[Mapping[str, str]] = {"release_time": "settle_time"}

    column_width: float = option(0.07, help="column width L0", unit="m")
    column_height: float = option(0.08, help="column height H0", unit="m")
    resolution: str = option("coarse", choices=tuple(RESOLUTIONS), help="about " + "/".join(
        str(n) for n in RESOLUTIONS.values()) + " particles in the column (ignored when --spacing is given)")
    spacing: float | None = option(None, help="particle spacing dx, overrides --resolution", unit="m",
                                   default_text="from --resolution")
    friction_angles_deg: tuple[float, float] = option(
        (21.0, 33.0), cli=("mu1-deg", "mu2-deg"), unit="degrees",
        help="friction angle of the mu(I) rheology: --mu1-deg atan(mu1), --mu2-deg atan(mu2) >= it")
    #: > 0 gives the wet material of Table 2.1 with cohesion; help and range from the parameter table
    water_content: float = option(0.0, help=f"{parameter('material.water_content').doc}; allowed "
                                            f"{parameter('material.water_content').allowed}", unit="kg/kg")
    floor_length: float | None = option(None, help="length of the rough flat floor right of the left wall", unit="m",
                                        default_text=f"{MIN_FLOOR_LENGTH} m, or the column's width plus "
                                                     f"{FLOOR_RUNOUT_FACTOR:g} times its runout by the quasi-2D fit "
                                                     "if longer")
    bed: str = option("flat", choices=BEDS, help="bed under the column: flat floor, or a circular or elliptical "
                                                 "trough whose lowest point is at the left wall (Fig. 2.7-2.8)")
    bed_radius: float = option(0.35, help="radius of the circular trough", unit="m")
    bed_axes: tuple[float, float] = option((0.35, 0.15), help="semi-axes of the elliptical trough, along x then z",
                                           unit="m")
    settle_time: float = shared("settle_time", 0.0, help="pause before the gate is removed, while the column "
                                                          "settles")
    t_end: float = shared("t_end", 1.0, help="simulated time; the run stops earlier once at rest")
    rest_threshold: float = 1e-4  #: stop once mean ½|v|² < rest_threshold·g·Δx (after 0.3 s)
    frame_interval: float = shared("frame_interval", 0.02)
    width: float = option(0.1, help="out-of-plane width of the quasi-2D sample, scales reported energies", unit="m")
    material_preset: str = option("packed", choices=MATERIAL_PRESETS,
                                  help="bulk density of the beads: a random packing's, or Table 2.1's")
    model: str = option("mu_i_hypoelastic", choices=parameter("material.model").choices, cli="material-model",
                        help="constitutive model (material.model)")
    fidelity: str = fidelity_option("column-collapse")
    numerics: dict[str, Any] = field(default_factory=dict)  #: overrides of terrasph.Numerics

    def __post_init__(self) -> None:
        check_tier(self.fidelity)
        check_tier(self.fidelity)
        for name in ("column_width", "column_height", "t_end", "frame_interval", "width"):
            value = getattr(self, name)
            if not (value > 0 and math.isfinite(value)):
                raise ConfigError(f"parameter '{name}' = {value!r} is invalid: allowed a finite number > 0")
        if self.spacing is None and self.resolution not in RESOLUTIONS:
            raise ConfigError(f"parameter 'resolution' = {self.resolution!r} is invalid: allowed one of "
                              f"{', '.join(RESOLUTIONS)}")
        if self.spacing is not None and not (self.spacing > 0 and math.isfinite(self.spacing)):
            raise ConfigError(f"parameter 'spacing' = {self.spacing!r} is invalid: allowed a finite number > 0")
        if self.bed not in BEDS:
            raise ConfigError(f"parameter 'bed' = {self.bed!r} is invalid: allowed one of {', '.join(BEDS)}")
        if self.bed == "circular" and not (self.bed_radius > 0 and math.isfinite(self.bed_radius)):
            raise ConfigError(f"parameter 'bed_radius' = {self.bed_radius!r} is invalid: allowed a finite number "
                              "> 0 (m)")
        if self.bed == "elliptical" and not (len(self.bed_axes) == 2 and all(
                isinstance(v, (int, float)) and v > 0 and math.isfinite(v) for v in self.bed_axes)):
            raise ConfigError(f"parameter 'bed_axes' = {self.bed_axes!r} is invalid: allowed two finite "
                              "semi-axes > 0 (m)")
        semi_axes = self.bed_semi_axes
        if semi_axes is not None and semi_axes[0] <= 2 * self.column_width:
            name = "bed_radius" if self.bed == "circular" else "bed_axes"
            raise ConfigError(f"parameter '{name}' = {getattr(self, name)!r} is invalid: allowed a trough "
                              f"half-width > 2*column_width = {2 * self.column_width:g} m")
        if self.floor_length is not None:
            if not (isinstance(self.floor_length, (int, float)) and math.isfinite(self.floor_length)
                    and self.floor_length > self.column_width):
                raise ConfigError(f"parameter 'floor_length' = {self.floor_length!r} is invalid: allowed a finite "
                                  f"number > column_width = {self.column_width:g} m")
            if self.bed == "flat" and self.floor_length < self.expected_reach:
                warnings.warn(f"floor_length = {self.floor_length:g} m is shorter than where this column's runout may "
                              f"reach, {self.expected_reach:.3g} m ({FLOOR_RUNOUT_FACTOR:g} times the quasi-2D fit's "
                              "runout): grains that run past the floor's end leave the domain box and end the run "
                              "(leave floor_length at its default to size it)", RuntimeWarning, stacklevel=3)
        check_settle_time(self.settle_time, self.t_end)
        if self.material_preset not in MATERIAL_PRESETS:
            raise ConfigError(f"parameter 'material_preset' = {self.material_preset!r} is invalid: allowed one of "
                              f"{', '.join(MATERIAL_PRESETS)}")
        mu1_deg, mu2_deg = self.friction_angles_deg
        if not 0 <= mu1_deg <= mu2_deg < 90:
            raise ConfigError(f"parameter 'friction_angles_deg' = {self.friction_angles_deg} is invalid: "
                              "allowed 0 <= mu1 angle <= mu2 angle < 90 degrees")
        self.material()  # the material's own checks (e.g. the pendular range of the water content)

    @property
    def grid_spacing(self) -> float:
        """Δx: as given, or the one that puts about RESOLUTIONS[resolution] particles in the column."""
        if self.spacing is not None:
            return self.spacing
        return math.sqrt(self.column_width * self.column_height / RESOLUTIONS[self.resolution])

    @property
    def expected_reach(self) -> float:
        """How far (m) the collapse may run: the column's width plus FLOOR_RUNOUT_FACTOR times the
        runout of the quasi-2D fit (:func:`lube_runout`) at its aspect ratio."""
        return self.column_width * (1.0 + FLOOR_RUNOUT_FACTOR * lube_runout(self.column_height / self.column_width))

    @property
    def floor(self) -> float:
        """The flat floor's length (m): `floor_length`, or MIN_FLOOR_LENGTH or the expected reach if longer."""
        return self.floor_length if self.floor_length is not None else max(MIN_FLOOR_LENGTH, self.expected_reach)

    @property
    def bed_semi_axes(self) -> tuple[float, float] | None:
        """(a, b) of the trough, None for the flat floor."""
        if self.bed == "circular":
            return (self.bed_radius, self.bed_radius)
        if self.bed == "elliptical":
            return (float(self.bed_axes[0]), float(self.bed_axes[1]))
        return None

    def bed_height(self, x: np.ndarray) -> np.ndarray:
        """Height z_b(x) of the bed surface (0 on the flat floor)."""
        semi_axes = self.bed_semi_axes
        if semi_axes is None:
            return np.zeros_like(np.asarray(x, float))
        return trough_height(x, semi_axes)

    def build_numerics(self) -> Numerics:
        """terrasph.Numerics at this spacing and fidelity with the overrides applied."""
        return scene_numerics("column-collapse", self.fidelity, self.grid_spacing, overrides=self.numerics)

    def footprint(self) -> Footprint:
        """The column's area and the floor, left wall and gate (size guard)."""
        semi_axes = self.bed_semi_axes
        floor = self.floor if semi_axes is None else 0.25 * math.pi * (semi_axes[0] + semi_axes[1])
        return Footprint(self.grid_spacing, self.column_width * self.column_height,
                         floor + 2.0 * self.column_height, self.t_end, self.material(), self.build_numerics())

    def material(self) -> Material:
        """Glass beads of Table 2.1 with this configuration's friction, water content, bulk density
        (material_preset) and constitutive model."""
        mu1, mu2 = (math.tan(math.radians(a)) for a in self.friction_angles_deg)
        overrides: dict[str, float | str] = {"mu1": mu1, "mu2": mu2, "model": self.model}
        if self.material_preset == "table_2_1":
            overrides["reference_density"] = TABLE_2_1_REFERENCE_DENSITY
        if self.water_content > 0:
            return Material.wet(self.water_content, **overrides)
        return Material(**overrides)


def build_column_collapse(config: ColumnCollapse) -> tuple[Scene, Material, Numerics]:
    """The scene (column, rough floor + left wall, gate), material and numerics of a collapse."""
    dx = config.grid_spacing
    numerics = config.build_numerics()
    layers = wall_layers_needed(numerics.h_factor)
    scene = Scene(spacing=dx)
    column = scene.add_block(0.0, 0.0, config.column_width, config.column_height)
    top = float(column[:, 1].max()) + 0.5 * dx
    right = float(column[:, 0].max()) + 0.5 * dx
    wall_top = top + 4 * dx
    margin = (layers + 2) * dx
    semi_axes = config.bed_semi_axes
    if semi_axes is None:
        scene.add_wall("floor", [(0.0, wall_top), (0.0, 0.0), (config.floor, 0.0)], layers=layers,
                       no_slip=True)
        bed_right, bed_top = config.floor, 0.0
    else:
        _add_trough(scene, semi_axes, wall_top, layers)
        scene.granular[0] = column[_above_bed(column, config, dx)]
        bed_right, bed_top = semi_axes
    gate_bottom = float(config.bed_height(np.array([right]))[0])
    scene.add_wall("gate", [(right, gate_bottom), (right, wall_top)], layers=layers, no_slip=False,
                   remove_at=config.settle_time)
    scene.domain_lower = (-margin, -margin)
    scene.domain_upper = (bed_right + margin, max(wall_top, bed_top) + 0.5 * config.column_height)
    return scene, config.material(), numerics


def _add_trough(scene: Scene, semi_axes: tuple[float, float], wall_top: float, layers: int) -> None:
    """The rough left wall and the curved bed as one wall group "floor": the quarter of the trough
    from its lowest point at the wall to its rim, and the wall, extended `layers` rows below the
    bed so the corner is filled, each with rows lined up along its normals."""
    dx = scene.spacing
    bed, bed_normal = elliptical_arc(semi_axes, (0.0, 0.5 * math.pi), dx)
    heights = (np.arange(-layers, math.ceil(wall_top / dx)) + 0.5) * dx
    wall = np.column_stack([np.zeros_like(heights), heights])
    wall_normal = np.tile([1.0, 0.0], (len(heights), 1))
    rows = [aligned_wall_layers(bed, bed_normal, dx, layers), aligned_wall_layers(wall, wall_normal, dx, layers)]
    scene.add_wall_particles("floor", np.concatenate([r[0] for r in rows]), np.concatenate([r[1] for r in rows]),
                             no_slip=True)


def _above_bed(points: np.ndarray, config: ColumnCollapse, dx: float) -> np.ndarray:
    """Lattice particles at least Δx/2 above the curved bed along its normal (as the flat floor's
    first row): z − z_b(x) ≥ ½Δx·√(1 + z_b′(x)²)."""
    x = points[:, 0]
    a, b = config.bed_semi_axes  # type: ignore[misc]
    ratio = np.clip(x / a, -0.999999, 0.999999)
    slope = b * ratio / (a * np.sqrt(1.0 - ratio**2))  # z_b'(x)
    return points[:, 1] - config.bed_height(x) >= 0.5 * dx * np.sqrt(1.0 + slope**2)


@dataclass
class ColumnResult:
    """Outcome of a column collapse: normalised runout L* = (L − L0)/L0 (L: front of the connected
    deposit where it is at least DEPOSIT_THICKNESS_GRAIN_DIAMETERS grain diameters thick, measured from
    the bed: :func:`terrasph.analysis.deposit_front`) with its resolution error `runout_error` = Δx/L0
    (the front is known to one bin of the surface profile, Δx wide), and height H* = H_f/H0;
    `toe_front` is the x reached by any connected particle, the monolayer toe included."""

    runout_normalised: float
    final_height_normalised: float
    initial_length: float
    initial_height: float
    granular_particles: int
    spacing: float
    run: RunResult
    toe_front: float = float("nan")
    runout_error: float = float("nan")
    final_position: np.ndarray | None = None
    plot: str | None = None

    def summary(self) -> dict[str, Any]:
        """Flat dict for tables and HDF5 attributes."""
        return {"runout_normalised": self.runout_normalised, "runout_error": self.runout_error,
                "final_height_normalised": self.final_height_normalised,
                "initial_length": self.initial_length, "initial_height": self.initial_height,
                "toe_front": self.toe_front,
                "granular_particles": self.granular_particles, "spacing": self.spacing,
                "steps": self.run.steps, "time": self.run.time, "wall_time": self.run.wall_time,
                "status": self.run.status}


def run_column_collapse(config: ColumnCollapse = ColumnCollapse(), *, output: str | os.PathLike | None = None,
                        progress: bool = True, plot: bool = True,
                        resume: bool = False, until: float | None = None) -> ColumnResult:
    """Builds and runs a collapse until at rest (or t_end); writes HDF5, a PNG of the final profile
    and one of the final τ–p yield locus against μ1P + c and μ2P + c (``<output>_yield_locus.png``).

    ``resume=True`` continues the run in `output` from its checkpoint; ``until`` replaces the end
    time (see :meth:`terrasph.simulation.Simulation.run`).
    """
    from terrasph import analysis

    scene, material, numerics = build_column_collapse(config)
    sim = Simulation(scene, material, numerics, width=config.width)
    initial = np.array(sim.position)
    dx = scene.spacing
    length0 = float(initial[:, 0].max() + 0.5 * dx)
    height0 = float(initial[:, 1].max() + 0.5 * dx)
    run = sim.run(config.t_end if until is None else until, output=output, resume=resume,
                  frame_interval=config.frame_interval, progress=progress,
                  config={"scene": "column-collapse", "column_collapse": dataclasses.asdict(config),
                          **sim.describe()},
                  stop_when_at_rest=config.rest_threshold, min_time=config.settle_time + 0.3)
    final = np.array(sim.position)
    front = analysis.deposit_front(final, dx, DEPOSIT_THICKNESS_GRAIN_DIAMETERS * material.grain_diameter,
                                   bed_height=config.bed_height)
    toe = analysis.front_position(final, dx)
    result = ColumnResult(analysis.normalised_runout(front, 0.0, length0),
                          analysis.final_height(final, dx) / height0, length0, height0, len(final), dx, run,
                          toe_front=toe, runout_error=dx / length0, final_position=final)
    if output is not None:
        write_results(output, result.summary())
        if plot:
            from terrasph import plotting

            png = Path(output).with_suffix(".png")
            centres0, heights0 = analysis.surface_profile(initial, dx)
            centres, heights = analysis.surface_profile(final, dx)
            label = (f"t = {run.time:.2f} s, L* = {result.runout_normalised:.2f} ± {result.runout_error:.2f}, "
                     f"H* = {result.final_height_normalised:.2f}")
            bed = None
            if config.bed_semi_axes is not None:
                bed_x = np.linspace(0.0, float(centres.max()) + dx, 200)
                bed = (bed_x, config.bed_height(bed_x))
            plotting.plot_profiles([(centres, heights, label)], initial=(centres0, heights0), bed=bed, path=png)
            result.plot = os.fspath(png)
            stress = np.array(sim.stress)
            locus_p, locus_tau = analysis.yield_locus(stress)
            plotting.plot_yield_locus(
                locus_p, locus_tau, particles=analysis.stress_invariants(stress),
                yield_lines=[("μ1P + c", material.mu1, material.cohesion), ("μ2P + c", material.mu2, material.cohesion)],
                path=Path(output).with_name(Path(output).stem + "_yield_locus.png"))
    return result
