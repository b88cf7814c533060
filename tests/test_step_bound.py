"""The step's signal speed apart from c0 (numerics.step_at_wave_speed, issue 12).

The step bound is C·h/(c + |v|) with c = max(c0, the model's wave speed) by default; c0 of
Eq. 2.44 also sets the artificial viscosity α c0 and the density diffusion δ h c0.
step_at_wave_speed takes the step from the model's fastest physical wave alone and keeps the damping. For the Table 2.1 beads c0 = 89 m/s and the hypoelastic P-wave speed is
c_P = √((K + 4G/3)/ρ0) = 11.24 m/s (K = κγ, G from Poisson's ratio 0.3): 7.9× fewer steps.

Scene: test_settling's bed (Δx = 5 mm, 0.12 × 0.05 m, rough box), 0.2 s. References:
* at c = c_P the bed comes to rest as at the default step (mean |v| < 1e-4 m/s, max < 2e-3 m/s)
  and its vertical stress profile equals the default run's, layer by layer, within 0.5 % of the
  deepest layer's stress [measured 0.02 %];
* the first step from rest is C·h/c with c the model's wave speed by its formula: c_P for the
  hypoelastic model, the EOS speed √(κγ/ρ0) for the rate model (to 1e-12).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from terrasph import analysis
from terrasph.config import Material, Numerics
from terrasph.geometry import wall_layers_needed
from terrasph.scene import Scene
from terrasph.simulation import Simulation

DX = 0.005
WIDTH, HEIGHT = 0.12, 0.05
T_END = 0.2


def p_wave_speed(material: Material) -> float:
    """c_P of the hypoelastic μ(I) model: K = κγ, G = 3K(1 − 2ν)/(2(1 + ν)) with ν = 0.3."""
    bulk = material.bulk_stiffness * material.eos_exponent
    shear = 3 * bulk * (1 - 2 * 0.3) / (2 * (1 + 0.3))
    return math.sqrt((bulk + 4 * shear / 3) / material.reference_density)


def settled_bed(**numerics: float) -> Simulation:
    config = Numerics(spacing=DX, **numerics)
    scene = Scene(spacing=DX)
    scene.add_block(0.0, 0.0, WIDTH, HEIGHT)
    top = HEIGHT + 6 * DX
    scene.add_wall("box", [(0.0, top), (0.0, 0.0), (WIDTH, 0.0), (WIDTH, top)],
                   layers=wall_layers_needed(config.h_factor), no_slip=True)
    sim = Simulation(scene, Material(), config)
    sim.advance(T_END)
    return sim


def stress_profile(sim: Simulation) -> np.ndarray:
    _, sigma_v = analysis.vertical_stress_profile(np.array(sim.position), np.array(sim.stress), DX,
                                                  (0.15 * WIDTH, 0.85 * WIDTH))
    return sigma_v


def test_stepping_at_the_wave_speed_keeps_the_settled_bed() -> None:
    reference = settled_bed()
    fast = settled_bed(step_at_wave_speed=True)
    assert reference.step_count > 7 * fast.step_count  # c0 / c_P = 7.9
    speed = np.hypot(*fast.velocity.T)
    assert speed.mean() < 1e-4 and speed.max() < 2e-3
    assert fast.leaked_particles == 0
    expected, got = stress_profile(reference), stress_profile(fast)
    assert len(got) == len(expected) >= 8
    assert np.max(np.abs(got - expected)) < 0.005 * expected.max()


@pytest.mark.parametrize("model", ["mu_i_hypoelastic", "mu_i_rate"])
def test_the_first_step_resolves_the_models_wave_speed(model: str) -> None:
    material = Material(model=model)
    eos_speed = math.sqrt(material.bulk_stiffness * material.eos_exponent / material.reference_density)
    wave_speed = p_wave_speed(material) if model == "mu_i_hypoelastic" else eos_speed
    numerics = Numerics(spacing=DX, step_at_wave_speed=True)
    scene = Scene(spacing=DX)
    scene.add_block(0.0, 0.0, WIDTH, HEIGHT)
    sim = Simulation(scene, material, numerics)
    sim.advance(1.0, max_steps=1)
    assert sim.time == pytest.approx(numerics.cfl * numerics.h_factor * DX / wave_speed, rel=1e-12)
