"""Named fidelity tiers: the numerics each scene runs with, decided by measurement.

A scene's numerics are built in one order: the core's defaults (``Numerics()``: the density advanced
before the forces, C = 0.5, each pair once in cell order), the scene's own needs (a Shepard filter,
a density floor), the chosen tier's settings for that scene, then the user's ``numerics`` overrides
(``--numerics NAME=VALUE``). Three tiers:

* ``reference``: the converged setting the others are measured against: C = 0.25, no active domain,
  no mass scaling. An override that brings one of those approximations back contradicts the tier
  and is refused (:class:`~terrasph.config.ConfigError`).
* ``standard`` (the default): per scene, the fastest settings whose reported figures stayed within
  2 % of ``reference`` where measured (``error`` of each tier).
* ``fast``: larger errors, stated, for exploration and data sets.

Each tier's measured error and the command behind it are in docs/fidelity.md and in
``terrasph run SCENE --help``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from terrasph.config import ConfigError, Numerics, from_mapping
from terrasph.options import option

__all__ = ["DEFAULT_TIER", "TIERS", "Tier", "check_tier", "fidelity_option", "scene_numerics", "scene_tiers",
           "tier_help"]

#: The tiers, finest first; ``standard`` is every scene's default.
TIERS: tuple[str, ...] = ("reference", "standard", "fast")
DEFAULT_TIER = "standard"

#: What the reference tier leaves out: (parameter, the value it must keep, why).
_REFERENCE_RULES: tuple[tuple[str, Any, str], ...] = (
    ("freeze_speed", 0.0, "no active domain"),
    ("active_radius", 0.0, "no active domain"),
    ("mass_scaling", 1.0, "no mass scaling"),
)
_REFERENCE_CFL = 0.25


@dataclass(frozen=True)
class Tier:
    """One scene's settings at one fidelity, with the error measured against ``reference``."""

    numerics: Mapping[str, Any] = field(default_factory=dict)  #: over the core's defaults
    error: str = "not measured"  #: the reported figures' measured deviation from ``reference``


_REFERENCE = Tier({"cfl": _REFERENCE_CFL}, "the reference itself")

#: Per scene and tier. Errors are against ``reference`` (docs/fidelity.md gives the commands).
_SCENE_TIERS: dict[str, dict[str, Tier]] = {
    "column-collapse": {
        "reference": _REFERENCE,
        "standard": Tier({}, "H* -0.0 %, L* +5.1 % (its front, 3 dx; fine column, C = 0.5 against 0.25)"),
        "fast": Tier({"cfl": 0.9}, "L*, H* within 1 % (coarse column)"),
    },
    "leg-rotation": {
        "reference": _REFERENCE,
        "standard": Tier({"cfl": 0.9}, "peak lift +0.6 %, peak thrust -0.7 % (coarse C-leg at 0.8 rad/s)"),
        "fast": Tier({"cfl": 0.5, "mass_scaling": 16.0},
                     "slow sweeps only: peaks within 4.6 % of standard at 0.2 rad/s (five legs), but +21 %, +33 % at 0.8 rad/s"),
    },
    "plate-drag": {
        "reference": _REFERENCE,
        "standard": Tier({}, "not measured (C = 0.5, the core's default)"),
        "fast": Tier({"cfl": 0.9}, "not measured (the legs at C = 0.9: within 0.5 %)"),
    },
    "plate-intrusion": {
        "reference": _REFERENCE,
        "standard": Tier({}, "not measured on the plate (C = 0.5; the legs: within 0.4 %)"),
        "fast": Tier({"cfl": 0.9}, "not measured on the plate (the legs at C = 0.9: within 0.5 %)"),
    },
    "plate-intrusion-3d": {
        "reference": _REFERENCE,
        "standard": Tier({}, "not measured (C = 0.5, the core's default)"),
        "fast": Tier({"cfl": 0.9}, "not measured (the planar legs at C = 0.9: within 0.5 %)"),
    },
    "leg-wheel": {
        "reference": _REFERENCE,
        "standard": Tier({"cfl": 0.9}, "mean slip -0.8 %, mean sinkage -0.3 % (C = 0.9, no active domain)"),
        "fast": Tier({"cfl": 1.0, "freeze_speed": 0.001, "active_radius": 0.1},
                     "mean slip -1.1 %, mean sinkage -0.4 %, scatter +-2 % over active-domain settings"),
    },
    "rover": {
        "reference": _REFERENCE,
        "standard": Tier({"cfl": 0.9}, "as the leg-wheel (same bed and coupling; not measured on the rover)"),
        "fast": Tier({"cfl": 1.0, "freeze_speed": 0.001, "active_radius": 0.1},
                     "as the leg-wheel's fast tier (not measured on the rover)"),
    },
    "mjcf": {
        "reference": _REFERENCE,
        "standard": Tier({}, "not measured (C = 0.5, the core's default)"),
        "fast": Tier({"cfl": 0.9}, "not measured (the leg-wheel's standard step)"),
    },
}


def check_tier(tier: str) -> str:
    """`tier` if it names a tier; ConfigError naming the parameter and the allowed tiers otherwise."""
    if tier not in TIERS:
        raise ConfigError(f"parameter 'fidelity' = {tier!r} is invalid: allowed one of {', '.join(TIERS)}")
    return tier


def scene_tiers(scene: str) -> dict[str, Tier]:
    """The tiers of the registered `scene`; ConfigError for a scene without a table."""
    if scene not in _SCENE_TIERS:
        raise ConfigError(f"scene {scene!r} has no fidelity tiers: allowed one of {', '.join(_SCENE_TIERS)}")
    return _SCENE_TIERS[scene]


def tier_help(scene: str) -> str:
    """One line per tier with its settings and measured error, for ``--help``."""
    lines = []
    for name, tier in scene_tiers(scene).items():
        settings = ", ".join(f"{key}={value}" for key, value in tier.numerics.items()) or "the core's defaults"
        lines.append(f"{name}: {settings} ({tier.error})")
    return "; ".join(lines)


def fidelity_option(scene: str) -> Any:
    """The ``fidelity`` field of a scene's configuration: the default tier, the choices and, in its
    ``--fidelity`` help, each tier's settings and measured error for `scene`."""
    return option(DEFAULT_TIER, choices=TIERS, help="numerics tier (docs/fidelity.md): " + tier_help(scene))


def _check_reference(values: Mapping[str, Any], overrides: Mapping[str, Any]) -> None:
    """ConfigError if `overrides` bring an approximation back into the reference tier."""
    for name, kept, why in _REFERENCE_RULES:
        if name in overrides and values[name] != kept:
            raise ConfigError(f"parameter 'numerics.{name}' = {values[name]!r} contradicts fidelity 'reference' "
                              f"({why}: allowed {kept!r}); use fidelity 'standard' or 'fast'")
    if "cfl" in overrides and values["cfl"] > _REFERENCE_CFL:
        raise ConfigError(f"parameter 'numerics.cfl' = {values['cfl']!r} contradicts fidelity 'reference' "
                          f"(allowed cfl <= {_REFERENCE_CFL}); use fidelity 'standard' or 'fast'")


def scene_numerics(scene: str, tier: str, spacing: float, scene_needs: Mapping[str, Any] | None = None,
                   overrides: Mapping[str, Any] | None = None) -> Numerics:
    """The numerics of `scene` at fidelity `tier`: the core's defaults, then `scene_needs` (what the
    scene requires at every tier), the tier's settings, then the user's `overrides`. ConfigError for
    an unknown tier, a bad override, or an override that contradicts the reference tier."""
    check_tier(tier)
    overrides = dict(overrides or {})
    values = {"spacing": spacing, **(scene_needs or {}), **scene_tiers(scene)[tier].numerics, **overrides}
    numerics = from_mapping(Numerics, values)
    if tier == "reference":
        _check_reference(vars(numerics), overrides)
    return numerics
