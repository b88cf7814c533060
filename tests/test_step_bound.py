"""The step's signal speed: every term's, so no term outruns the step.

The step bound is C·h/(c + |v|) with c = max(c0, the model's fastest physical wave): c0 of Eq. 2.44
sets the artificial viscosity α c0 (Eq. 2.46) and the density diffusion δ h c0 (Eq. 2.42-2.43),
both integrated explicitly, and the wave is the elastic one of the model. References:
* with the packing's bulk density (ρ0 = ν ρ_s, the default) c0 = 18 m/s exceeds the hypoelastic
  P-wave speed c_P = √((K + 4G/3)/ρ0) = 14.4 m/s (K = κγ, G from Poisson's ratio 0.3), so the first
  step from rest is C·h/c0 (to 1e-12);
* with c0 set below the wave speed (numerics.sound_speed), the first step is C·h/c_P for the
  hypoelastic model and C·h/√(κγ/ρ0) for the rate model (to 1e-12).
"""

from __future__ import annotations

import math

import pytest
from terrasph import _core
from terrasph.config import Material, Numerics
from terrasph.scene import Scene
from terrasph.simulation import Simulation

DX = 0.005
WIDTH, HEIGHT = 0.12, 0.05


def p_wave_speed(material: Material) -> float:
    """c_P of the hypoelastic μ(I) model: K = κγ, G = 3K(1 − 2ν)/(2(1 + ν)) with ν = 0.3."""
    bulk = material.bulk_stiffness * material.eos_exponent
    shear = 3 * bulk * (1 - 2 * 0.3) / (2 * (1 + 0.3))
    return math.sqrt((bulk + 4 * shear / 3) / material.reference_density)


def eq_2_44_sound_speed(material: Material) -> float:
    """c0 = √(κγρ_s/(ρ0(ρ_s − ρ0))) (Eq. 2.44)."""
    m = material
    return math.sqrt(m.bulk_stiffness * m.eos_exponent * m.grain_density /
                     (m.reference_density * (m.grain_density - m.reference_density)))


def first_step(material: Material, numerics: Numerics) -> float:
    scene = Scene(spacing=DX)
    scene.add_block(0.0, 0.0, WIDTH, HEIGHT)
    sim = Simulation(scene, material, numerics)
    sim.advance(1.0, max_steps=1)
    return sim.time


def test_the_default_step_resolves_c0_above_the_wave() -> None:
    material, numerics = Material(), Numerics(spacing=DX)
    c0 = eq_2_44_sound_speed(material)
    assert c0 == pytest.approx(18.0, abs=0.1) and p_wave_speed(material) == pytest.approx(14.4, abs=0.1)
    assert first_step(material, numerics) == pytest.approx(numerics.cfl * numerics.h_factor * DX / c0, rel=1e-12)


@pytest.mark.parametrize("model", ["mu_i_hypoelastic", "mu_i_rate"])
def test_a_wave_faster_than_c0_sets_the_step(model: str) -> None:
    material = Material(model=model)
    eos_speed = math.sqrt(material.bulk_stiffness * material.eos_exponent / material.reference_density)
    wave_speed = p_wave_speed(material) if model == "mu_i_hypoelastic" else eos_speed
    numerics = Numerics(spacing=DX, sound_speed=0.5 * eos_speed)
    assert first_step(material, numerics) == pytest.approx(
        numerics.cfl * numerics.h_factor * DX / wave_speed, rel=1e-12)


def test_no_numerics_setting_steps_past_c0() -> None:
    """The wave-speed-only step (which let c0's damping outrun the step) is gone for good."""
    assert "step_at_wave_speed" not in {entry["name"] for entry in _core.parameter_table()}
