"""Geostatic initial stress of the hypoelastic μ(I) (``Simulation(..., geostatic=True)``).

Reference: a bed at rest under gravity has σ_zz = −ρ0 g depth and σ_xx = K0 σ_zz with Jaky's
K0 = 1 − sin φ (φ = atan μ1 = 21°: K0 = 0.642). Started so, the 0.12 × 0.05 m bed (Δx = 5 mm) in a
rough box keeps σ_xx/σ_zz within 0.05 of K0 over 0.2 s [0.633], carries the lithostatic −σ_zz at
the bottom row within 5 % [+2.8 %] and comes to rest (mean |v| < 1e-4 m/s [8e-6]); without the
option it is isotropic (σ_xx/σ_zz > 0.9 [0.98]). δ-SPH is on (the default δ = 0.1): its
hydrostatic density correction takes the share ½(1 + K0) of the weight that the geostatic
pressure carries (numerics.density_diffusion_pressure_share, set by the geostatic start); with the
full weight (share 1) it drives the bed back towards isotropy (σ_xx/σ_zz 0.64 → 0.87 in 0.2 s).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from terrasph.config import ConfigError, Material, Numerics
from terrasph.geometry import wall_layers_needed
from terrasph.scene import Scene
from terrasph.simulation import Simulation

DX, WIDTH, HEIGHT, G = 0.005, 0.12, 0.05, 9.81


def _bed(material: Material, geostatic: bool, **numerics: float) -> Simulation:
    scene = Scene(spacing=DX)
    scene.add_block(0.0, 0.0, WIDTH, HEIGHT)
    scene.add_wall("box", [(0.0, 0.08), (0.0, 0.0), (WIDTH, 0.0), (WIDTH, 0.08)], layers=wall_layers_needed(1.3))
    return Simulation(scene, material, Numerics(spacing=DX, **numerics), geostatic=geostatic)


def _earth_pressure_ratio(sim: Simulation) -> float:
    """Σσ_xx/Σσ_zz over the central 70 % of the width, below the top two rows."""
    x, stress = sim.position, sim.stress
    inside = (x[:, 0] > 0.15 * WIDTH) & (x[:, 0] < 0.85 * WIDTH) & (x[:, 1] < HEIGHT - 2 * DX)
    return float(stress[inside, 0, 0].sum() / stress[inside, 1, 1].sum())


def test_a_geostatic_hypoelastic_bed_keeps_k0() -> None:
    material = Material()
    k0 = 1.0 - math.sin(math.atan(material.mu1))
    sim = _bed(material, geostatic=True)
    assert _earth_pressure_ratio(sim) == pytest.approx(k0, abs=0.01)  # the start
    sim.advance(0.2)
    assert _earth_pressure_ratio(sim) == pytest.approx(k0, abs=0.05)
    x = sim.position
    bottom = (x[:, 1] < DX) & (x[:, 0] > 2 * DX) & (x[:, 0] < WIDTH - 2 * DX)
    lithostatic = material.reference_density * G * (HEIGHT - 0.5 * DX)
    assert -sim.stress[bottom, 1, 1].mean() == pytest.approx(lithostatic, rel=0.05)
    assert np.linalg.norm(sim.velocity, axis=1).mean() < 1e-4
    assert sim.leaked_particles == 0
    isotropic = _bed(material, geostatic=False)
    isotropic.advance(0.2)
    assert _earth_pressure_ratio(isotropic) > 0.9


def test_density_diffusion_with_the_full_weight_undoes_the_geostatic_start() -> None:
    sim = _bed(Material(), geostatic=True, density_diffusion_pressure_share=1.0)
    sim.advance(0.2)
    assert _earth_pressure_ratio(sim) > 0.75


@pytest.mark.parametrize("model", ["mu_i_rate", "mu_i_strain"])
def test_geostatic_needs_a_model_with_stress_state(model: str) -> None:
    with pytest.raises(ConfigError, match="'geostatic'.*mu_i_hypoelastic, drucker_prager"):
        _bed(Material(model=model), geostatic=True)
