"""Mass scaling (numerics.mass_scaling = f): each grain's inertia is f times its mass,
gravity and every force unchanged, so a wave is √f slower while an equilibrium stays where it was.

Scene: test_step_bound's bed (Δx = 5 mm, 0.12 × 0.05 m of the default beads in a rough box). Started
unstressed (the reference density throughout), it is loaded suddenly by its own weight and rings in
its lowest vertical mode; started geostatic (the default) it is at rest. References:
* the first compression of its top row comes half a period of that mode after the start, at
  2H/c_P with the hypoelastic P-wave speed c_P = √((K + 4G/3)/ρ0) (a quarter-wave layer on a rigid
  floor, free on top), within 10 % [7.25 ms against 6.93 ms]; with f = 4 it comes √4 = 2 times
  later, within 5 %, and as deep, within 5 % (the static compression does not depend on inertia)
  [14.5 ms, 0.2 %];
* from the geostatic start, run with f = 16 for the same number of bed wave periods (t √f), the bed's vertical stress
  profile equals the unscaled run's layer by layer within 1.5 % of the deepest layer's stress
  (equilibrium ∇·σ + ρg = 0 holds whatever the inertia) [0.20 %].
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from terrasph import _core, analysis
from terrasph.config import Material, Numerics
from terrasph.geometry import wall_layers_needed
from terrasph.scene import Scene
from terrasph.simulation import Simulation

DX = 0.005
WIDTH, HEIGHT = 0.12, 0.05


def p_wave_speed(material: Material) -> float:
    """c_P of the hypoelastic μ(I) model: K = κγ, G = 3K(1 − 2ν)/(2(1 + ν)) with ν = 0.3."""
    bulk = material.bulk_stiffness * material.eos_exponent
    shear = 3 * bulk * (1 - 2 * 0.3) / (2 * (1 + 0.3))
    return math.sqrt((bulk + 4 * shear / 3) / material.reference_density)


def bed(mass_scaling: float, unstressed: bool = False) -> Simulation:
    """The bed, geostatic (the default start) or `unstressed` (ρ0 throughout, no stress)."""
    numerics = Numerics(spacing=DX, mass_scaling=mass_scaling)
    scene = Scene(spacing=DX)
    scene.add_block(0.0, 0.0, WIDTH, HEIGHT)
    top = HEIGHT + 6 * DX
    scene.add_wall("box", [(0.0, top), (0.0, 0.0), (WIDTH, 0.0), (WIDTH, top)],
                   layers=wall_layers_needed(numerics.h_factor), no_slip=True)
    material = Material()
    if not unstressed:
        return Simulation(scene, material, numerics)
    density = np.full(sum(len(block) for block in scene.granular), material.reference_density)
    return Simulation(scene, material, numerics, initial_density=density, geostatic=False)


def first_compression(mass_scaling: float) -> tuple[float, float]:
    """Time and depth of the deepest dip of the top row's mean height within 1.5 periods' wait."""
    sim = bed(mass_scaling, unstressed=True)
    z0 = np.array(sim.position)[:, 1]
    top = z0 > z0.max() - 1e-9
    window = 0.02 * math.sqrt(mass_scaling)  # about 1.1 half-periods of the unscaled mode
    times, dips = [], []
    for k in range(1, 81):
        sim.advance(window * k / 80)
        times.append(sim.time)
        dips.append(float(np.array(sim.position)[top, 1].mean() - z0[top].mean()))
    deepest = int(np.argmin(dips))
    return times[deepest], dips[deepest]


def test_a_wave_is_sqrt_f_slower_and_the_static_compression_unchanged() -> None:
    half_period = 2 * HEIGHT / p_wave_speed(Material())
    t1, dip1 = first_compression(1.0)
    t4, dip4 = first_compression(4.0)
    assert t1 == pytest.approx(half_period, rel=0.10)
    assert t4 / t1 == pytest.approx(2.0, rel=0.05)
    assert dip1 < 0.0 and dip4 == pytest.approx(dip1, rel=0.05)


def stress_profile(sim: Simulation) -> np.ndarray:
    _, sigma_v = analysis.vertical_stress_profile(np.array(sim.position), np.array(sim.stress), DX,
                                                  (0.15 * WIDTH, 0.85 * WIDTH))
    return sigma_v


def test_the_settled_bed_carries_its_weight_as_without_scaling() -> None:
    reference, scaled = bed(1.0), bed(16.0)
    reference.advance(0.2)
    scaled.advance(0.2 * 4.0)  # the same number of the bed's (4× longer) wave periods
    expected, got = stress_profile(reference), stress_profile(scaled)
    assert len(got) == len(expected) >= 8
    assert np.max(np.abs(got - expected)) < 0.015 * expected.max()
    assert scaled.leaked_particles == 0


def test_bitwise_identical_with_one_two_and_three_threads(restore_threads) -> None:
    def state(threads: int) -> dict:
        _core.set_num_threads(threads)
        sim = bed(9.0)
        sim.advance(1.0, max_steps=200)
        return sim.core.state()

    one = state(1)
    for threads in (2, 3):
        other = state(threads)
        for name in one["granular"]:
            assert np.array_equal(one["granular"][name], other["granular"][name]), name
