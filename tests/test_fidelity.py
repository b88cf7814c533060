"""Named fidelity tiers (terrasph.fidelity): bad input refused by name, the reference kept free of
approximations, and a tier's outcomes against the reference's within its stated error.

Reference for the slow test: the coarse leg-wheel of tests/test_leg_wheel.py (Δx = 5 mm, legs
1.5 cm thick, 0.5 s at rest then 1 s driven) at fidelity ``reference`` (C = 0.25, every grain
updated). ``standard`` (C = 0.9) must hold the mean slip and the mean sinkage within the 2 % the
tier states; ``fast`` (C = 1 and the active domain) within 5 % (its stated scatter of ±2 % around
the few-per-cent bias the active domain was measured to give on the default leg-wheel).
"""

from __future__ import annotations

import dataclasses
import json

import pytest
from terrasph.config import ConfigError
from terrasph.fidelity import TIERS, scene_numerics, tier_help
from terrasph.scenes import SCENES, scene_entry
from terrasph.scenes.column_collapse import ColumnCollapse
from terrasph.scenes.leg_rotation import LegRotation
from terrasph.scenes.leg_wheel import LegWheel, run_leg_wheel
from terrasph.scenes.plate_intrusion import PlateIntrusion


@pytest.mark.parametrize("make", [ColumnCollapse, LegRotation, PlateIntrusion, LegWheel])
def test_an_unknown_tier_is_refused_by_name(make) -> None:
    with pytest.raises(ConfigError, match=r"'fidelity' = 'turbo'.*reference, standard, fast"):
        make(fidelity="turbo")


@pytest.mark.parametrize("override", [{"freeze_speed": 0.001}, {"mass_scaling": 4.0}, {"cfl": 0.5}])
def test_an_override_that_brings_an_approximation_into_the_reference_is_refused(override) -> None:
    name = next(iter(override))
    with pytest.raises(ConfigError, match=rf"'numerics\.{name}'.*contradicts fidelity 'reference'"):
        scene_numerics("leg-wheel", "reference", 0.005, overrides=override)


def test_the_reference_takes_a_finer_step_than_the_other_tiers() -> None:
    """The reference is the converged end: no tier of any scene steps finer or drops fewer
    approximations (a smaller cfl, no active domain, no mass scaling)."""
    for scene in SCENES:
        reference = scene_numerics(scene, "reference", 0.005)
        for tier in TIERS:
            numerics = scene_numerics(scene, tier, 0.005)
            assert numerics.cfl >= reference.cfl, (scene, tier)
        assert reference.freeze_speed == 0.0 and reference.mass_scaling == 1.0, scene
        assert all(tier in tier_help(scene) for tier in TIERS)


def test_the_tier_is_kept_with_the_configuration() -> None:
    """A run file stores the scene's configuration as JSON; the tier comes back from it."""
    config = LegRotation(fidelity="fast")
    saved = json.loads(json.dumps(dataclasses.asdict(config)))
    assert scene_entry("leg-rotation").config_from(saved).fidelity == "fast"


def _coarse_leg_wheel(fidelity: str) -> dict[str, float]:
    config = LegWheel(wheel="c-leg", spacing=0.005, thickness=0.015, leg_length=0.05, bed_width=0.3,
                      bed_depth=0.05, start_x=0.1, settle_time=0.5, t_end=1.5, fidelity=fidelity)
    return run_leg_wheel(config).summary()


@pytest.mark.slow
def test_each_tier_keeps_the_leg_wheels_outcomes_within_its_stated_error() -> None:
    reference = _coarse_leg_wheel("reference")
    for tier, band in (("standard", 0.02), ("fast", 0.05)):
        outcome = _coarse_leg_wheel(tier)
        assert outcome["leaked_particles"] == 0
        assert outcome["steps"] < reference["steps"] / 3
        for key in ("mean_slip", "mean_sinkage"):
            assert outcome[key] == pytest.approx(reference[key], rel=band), (tier, key, outcome[key], reference[key])


@pytest.mark.parametrize("tier", ["standard", "fast", pytest.param("reference", marks=pytest.mark.slow)])
def test_every_leg_rotation_tier_keeps_the_bed_at_rest_during_the_pause(tier) -> None:
    """Nothing moves the bed during the pause before the sweep, so at every tier the grains stay
    where the geostatic start put them (fast: below 0.003 m/s, no grain higher by 0.1 mm after 0.1 s).
    Mass scaling 16 at C = 0.9 (the fast tier until 2026-12-05) erupted here: the top grains 5 mm
    higher and 0.18 m/s after 0.1 s, the bed 2–4 cm higher for the whole sweep (docs/fidelity.md)."""
    import numpy as np
    from terrasph.scenes.leg_rotation import build_leg_rotation
    from terrasph.simulation import Simulation

    config = LegRotation(leg="c-leg", bed_depth=0.08, settle_time=0.3, fidelity=tier)
    scene, material, numerics = build_leg_rotation(config)
    sim = Simulation(scene, material, numerics, width=config.width)
    top = float(sim.position[:, 1].max())
    sim.advance(0.1)
    assert float(sim.position[:, 1].max()) - top < 0.25 * config.grid_spacing
    assert float(np.abs(sim.velocity).max()) < 0.02
