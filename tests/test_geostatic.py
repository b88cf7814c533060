"""Geostatic initial stress, the default start of every model with a stress state.

Reference: a bed at rest under gravity has σ_zz = −ρ0 g depth and σ_xx = K0 σ_zz with Jaky's
K0 = 1 − sin φ (φ = atan μ1 = 21°: K0 = 0.642). Started so, the 0.12 × 0.05 m bed (Δx = 5 mm) in a
rough box keeps σ_xx/σ_zz within 0.05 of K0 over 0.2 s [0.649], carries the lithostatic −σ_zz at
every row within 3 % (the kernel's gradient normalised, the default) and comes to rest; with ``geostatic=False`` it is isotropic (σ_xx/σ_zz > 0.9 [0.98]). δ-SPH is on (the default δ = 0.1): its
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


def _bed(material: Material, geostatic: bool | None = None, **numerics: float) -> Simulation:
    scene = Scene(spacing=DX)
    scene.add_block(0.0, 0.0, WIDTH, HEIGHT)
    scene.add_wall("box", [(0.0, 0.08), (0.0, 0.0), (WIDTH, 0.0), (WIDTH, 0.08)], layers=wall_layers_needed(1.3))
    return Simulation(scene, material, Numerics(spacing=DX, **numerics), geostatic=geostatic)


def _earth_pressure_ratio(sim: Simulation) -> float:
    """Σσ_xx/Σσ_zz over the central 70 % of the width, below the top two rows."""
    x, stress = sim.position, sim.stress
    inside = (x[:, 0] > 0.15 * WIDTH) & (x[:, 0] < 0.85 * WIDTH) & (x[:, 1] < HEIGHT - 2 * DX)
    return float(stress[inside, 0, 0].sum() / stress[inside, 1, 1].sum())


def _vertical_stress_over_weight(sim: Simulation) -> np.ndarray:
    """Per row of grains below the top one: the mean −σ_zz over the central 70 % of the width over
    the weight per unit width above the row's centre (the rows above and half its own, ρΔx²g each,
    over the bed's width) — the lithostatic stress from the particles' own masses."""
    x, density = sim.position, sim.density
    rows = np.round(x[:, 1] / DX - 0.5).astype(int)
    central = (x[:, 0] > 0.15 * WIDTH) & (x[:, 0] < 0.85 * WIDTH)
    ratios = []
    for row in range(rows.max()):
        weight = (density[rows > row].sum() + 0.5 * density[rows == row].sum()) * DX * DX * G / WIDTH
        ratios.append(-sim.stress[central & (rows == row), 1, 1].mean() / weight)
    return np.array(ratios)


@pytest.mark.parametrize("model", ["mu_i_hypoelastic", "drucker_prager"])
def test_a_default_bed_keeps_k0_and_carries_its_weight(model: str) -> None:
    """K within Jáky's K0 ± 0.05 [0.649 hypoelastic, 0.640 Drucker–Prager]; −σ_zz within 3 % of the
    weight above every row [−0.4 to +0.5 % hypoelastic, −2.7 (the row on the floor) to +1.5 %
    Drucker–Prager], ∇W divided by the lattice moment s (numerics.kernel_gradient_normalisation,
    the default)."""
    material = Material(model=model)
    k0 = 1.0 - math.sin(math.atan(material.mu1))
    sim = _bed(material)  # the default start: geostatic for every model with a stress state
    assert _earth_pressure_ratio(sim) == pytest.approx(k0, abs=0.01)  # the start
    sim.advance(0.2)
    assert _earth_pressure_ratio(sim) == pytest.approx(k0, abs=0.05)
    assert 0.55 <= _earth_pressure_ratio(sim) <= 0.67
    ratios = _vertical_stress_over_weight(sim)
    assert len(ratios) >= 8 and np.all(np.abs(ratios - 1.0) < 0.03)
    assert np.linalg.norm(sim.velocity, axis=1).mean() < 2e-4
    assert sim.leaked_particles == 0
    if model == "mu_i_hypoelastic":
        isotropic = _bed(material, geostatic=False)
        isotropic.advance(0.2)
        assert _earth_pressure_ratio(isotropic) > 0.9


def test_the_kernels_own_gradient_moment_is_the_excess_stress() -> None:
    """With the kernel's own gradient (kernel_gradient_normalisation=False) the hypoelastic bed
    carries its weight with a stress steeper than the lattice moment's 1/s − 1 = 2.7 % at every row
    (s = 0.974 at h = 1.3Δx) [+3.3 to +4.4 %]: the discrete equilibrium Σ_j V_j (σ_j − σ_i)∇W = s ∇σ,
    the excess the normalisation removes."""
    sim = _bed(Material(), kernel_gradient_normalisation=False)
    sim.advance(0.2)
    ratios = _vertical_stress_over_weight(sim)
    assert len(ratios) >= 8 and np.all(ratios - 1.0 > 0.027)


def test_density_diffusion_with_the_full_weight_undoes_the_geostatic_start() -> None:
    sim = _bed(Material(), geostatic=True, density_diffusion_pressure_share=1.0)
    sim.advance(0.2)
    assert _earth_pressure_ratio(sim) > 0.75


@pytest.mark.parametrize("model", ["mu_i_rate", "mu_i_strain"])
def test_geostatic_needs_a_model_with_stress_state(model: str) -> None:
    with pytest.raises(ConfigError, match=r"'geostatic'.*mu_i_hypoelastic, drucker_prager"):
        _bed(Material(model=model), geostatic=True)
