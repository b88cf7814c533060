"""Validated, documented configuration: granular material and numerical settings.

Every value is checked when the object is made; a bad or unknown parameter raises
:class:`ConfigError` naming it and its allowed range, before any work starts.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, TypeVar

__all__ = ["ConfigError", "Material", "Numerics", "as_dict", "from_mapping"]


class ConfigError(ValueError):
    """A configuration value is missing, unknown or outside its allowed range."""


def _require(condition: bool, name: str, value: Any, allowed: str) -> None:
    if not condition:
        raise ConfigError(f"parameter '{name}' = {value!r} is invalid: allowed {allowed}")


def _is_number(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _finite_positive(name: str, value: float) -> None:
    _require(_is_number(value) and math.isfinite(value) and value > 0, name, value, "a finite number > 0")


@dataclass(frozen=True)
class Material:
    """Granular material for the μ(I) rheology (Eq. 2.29–2.34), SI units.

    Defaults are the dry glass beads of the column collapse (Table 2.1, μ1 = tan 21°, μ2 = tan 33°).
    Densities of a wet material scale with (1 + w) (Table 2.1); use :meth:`wet`.
    """

    grain_density: float = 2532.0  #: ρ_s (kg/m³)
    reference_density: float = 2507.0  #: ρ0 of the EOS (kg/m³)
    grain_diameter: float = 0.002  #: d (m)
    mu1: float = math.tan(math.radians(21.0))  #: quasi-static friction μ1
    mu2: float = math.tan(math.radians(33.0))  #: dynamic friction limit μ2
    inertial_number_i0: float = 0.279  #: I0 (Jop, Forterre & Pouliquen 2006)
    bulk_stiffness: float = 28000.0  #: κ (Pa)
    eos_exponent: float = 7.0  #: γ
    water_content: float = 0.0  #: w, gravimetric (kg water / kg grains)
    packing_fraction: float = 0.6  #: ν in the cohesion of Eq. 2.33
    bridges_per_grain: float = 6.0  #: k in Eq. 2.33
    surface_tension: float = 0.0725  #: γ_s (N/m), water
    filling_angle: float = math.radians(15.0)  #: φ of the liquid bridge (rad), Eq. 2.34
    #: Quasi-static branch: "rate" is Eq. 2.29 everywhere, τ = (μP + c)D′/(|D′| + ε); "elastic"
    #: keeps the deviatoric stress as state, loaded elastically with the Jaumann rate and capped at
    #: μ(I)P + c, so a bed at rest holds shear stress below yield (the aim of Eq. 3.6).
    quasi_static: str = "elastic"
    shear_modulus: float = 0.0  #: G (Pa) of the elastic branch; 0 → 3K(1−2ν)/(2(1+ν)), K = κγ(1+w), ν = 0.3

    def __post_init__(self) -> None:
        for name in ("grain_density", "reference_density", "grain_diameter", "inertial_number_i0",
                     "bulk_stiffness", "packing_fraction", "bridges_per_grain"):
            _finite_positive(f"material.{name}", getattr(self, name))
        _require(self.mu1 >= 0, "material.mu1", self.mu1, "mu1 >= 0")
        _require(self.mu2 >= self.mu1, "material.mu2", self.mu2, f"mu2 >= mu1 = {self.mu1:.6g}")
        _require(self.eos_exponent >= 1, "material.eos_exponent", self.eos_exponent, "gamma >= 1")
        _require(0 <= self.water_content < 1, "material.water_content", self.water_content, "0 <= w < 1")
        _require(self.surface_tension >= 0, "material.surface_tension", self.surface_tension, ">= 0")
        _require(0 <= self.filling_angle < math.pi / 2, "material.filling_angle", self.filling_angle,
                 "0 <= phi < pi/2 (radians)")
        _require(self.packing_fraction <= 1, "material.packing_fraction", self.packing_fraction, "(0, 1]")
        _require(self.quasi_static in ("rate", "elastic"), "material.quasi_static", self.quasi_static,
                 "'rate' or 'elastic'")
        _require(self.shear_modulus >= 0, "material.shear_modulus", self.shear_modulus, ">= 0 (0 = from the EOS)")

    @property
    def cohesion(self) -> float:
        """Capillary cohesion c (Pa) of a pendular wet material, 0 when dry.

        c = ν k F / (π d²) (Rumpf; Eq. 2.33) with the mean bridge force
        F = 2π r γ_s / (1 + tan(φ/2)) (Eq. 2.34), r = d/2.
        """
        if self.water_content == 0.0:
            return 0.0
        radius = 0.5 * self.grain_diameter
        bridge_force = 2.0 * math.pi * radius * self.surface_tension / (1.0 + math.tan(0.5 * self.filling_angle))
        return self.packing_fraction * self.bridges_per_grain * bridge_force / (math.pi * self.grain_diameter**2)

    @classmethod
    def wet(cls, water_content: float, **overrides: Any) -> Material:
        """Glass beads with water content w: densities scaled by (1 + w) as in Table 2.1."""
        base = cls(**overrides)
        return dataclasses.replace(base, water_content=water_content,
                                   grain_density=base.grain_density * (1 + water_content),
                                   reference_density=base.reference_density * (1 + water_content))


@dataclass(frozen=True)
class Numerics:
    """Discretisation and optional numerical terms; a term set to 0 is switched off and costs nothing.

    ``h_factor`` = 1.3 is the default (h = 1.3 Δx, about 21 neighbours in 2D with the Wendland C2
    support 2h), inside the usual 1.2–1.5 range.
    """

    spacing: float = 0.0026  #: Δx (m)
    h_factor: float = 1.3  #: h = h_factor·Δx
    cfl: float = 0.25  #: C of the adaptive step
    fixed_dt: float = 0.0  #: > 0: fixed step (s), checked against the stable bound every step
    sound_speed: float = 0.0  #: c0 (m/s); 0 → Eq. 2.44
    artificial_viscosity: float = 0.1  #: α_Π (Eq. 2.46) between grains; the dissertation uses 1 (docs/design_decisions.md)
    wall_artificial_viscosity: float = 1.0  #: α_Π for granular–wall pairs, which keeps grains out of walls
    #: strength of the contact barrier that pushes a grain centre out of a wall's solid (closer than
    #: Δx/2 to a wall particle); 1 = K = c²/h, 0 = off (docs/design_decisions.md)
    wall_barrier: float = 1.0
    delta_sph: float = 0.1  #: δ of the density diffusion (Eq. 2.42–2.43)
    xsph: float = 0.2  #: χ (Eq. 2.49)
    shepard_interval: int = 0  #: Shepard filter every N steps (Eq. 2.41); 0 = off
    kernel_gradient_correction: bool = False  #: renormalised ∇v (exact for linear fields)
    strain_rate_epsilon: float = -1.0  #: ε (1/s) of |D′| + ε; < 0 → 0.01·h² as in the dissertation
    neighbour_skin: float = 0.15  #: Verlet skin as a fraction of h
    #: ρ ≥ density_floor·ρ0 after every kick, 0 = off. With the tension-free EOS a separating grain
    #: has P = 0 below ρ0 anyway; a floor of 1 lets it push back as soon as it re-enters the bed
    density_floor: float = 0.0
    density_ratio_min: float = 0.5  #: the run stops if ρ/ρ0 leaves [min, max]
    density_ratio_max: float = 1.5

    def __post_init__(self) -> None:
        _finite_positive("numerics.spacing", self.spacing)
        _require(1.0 <= self.h_factor <= 2.0, "numerics.h_factor", self.h_factor, "1.0 <= h_factor <= 2.0")
        _require(0 < self.cfl <= 0.5, "numerics.cfl", self.cfl, "0 < cfl <= 0.5")
        _require(self.fixed_dt >= 0, "numerics.fixed_dt", self.fixed_dt, ">= 0 (0 = adaptive)")
        _require(self.sound_speed >= 0, "numerics.sound_speed", self.sound_speed, ">= 0 (0 = Eq. 2.44)")
        _require(self.artificial_viscosity >= 0, "numerics.artificial_viscosity", self.artificial_viscosity, ">= 0")
        _require(self.wall_artificial_viscosity >= 0, "numerics.wall_artificial_viscosity",
                 self.wall_artificial_viscosity, ">= 0")
        _require(self.wall_barrier >= 0, "numerics.wall_barrier", self.wall_barrier, ">= 0 (0 = off)")
        _require(0 <= self.density_floor <= 1, "numerics.density_floor", self.density_floor, "[0, 1] (0 = off)")
        _require(0 <= self.delta_sph <= 1, "numerics.delta_sph", self.delta_sph, "0 <= delta <= 1")
        _require(0 <= self.xsph <= 1, "numerics.xsph", self.xsph, "0 <= chi <= 1")
        _require(isinstance(self.shepard_interval, int) and not isinstance(self.shepard_interval, bool)
                 and self.shepard_interval >= 0,
                 "numerics.shepard_interval", self.shepard_interval, "an integer >= 0")
        _require(0 <= self.neighbour_skin <= 1, "numerics.neighbour_skin", self.neighbour_skin, "0 <= skin <= 1")
        _require(0 < self.density_ratio_min < 1, "numerics.density_ratio_min", self.density_ratio_min, "(0, 1)")
        _require(self.density_ratio_max > 1, "numerics.density_ratio_max", self.density_ratio_max, "> 1")

    @property
    def smoothing_length(self) -> float:
        """h = h_factor·Δx (m)."""
        return self.h_factor * self.spacing


T = TypeVar("T", Material, Numerics)


def from_mapping(cls: type[T], values: Mapping[str, Any]) -> T:
    """Build ``cls`` from a mapping, rejecting unknown keys by name."""
    known = {f.name for f in dataclasses.fields(cls)}
    prefix = cls.__name__.lower()
    for key in values:
        if key not in known:
            raise ConfigError(f"unknown parameter '{prefix}.{key}'; known: {', '.join(sorted(known))}")
    return cls(**dict(values))


def as_dict(obj: Material | Numerics) -> dict[str, Any]:
    """Plain dict of a configuration object (for HDF5 attributes and JSON)."""
    return dataclasses.asdict(obj)


