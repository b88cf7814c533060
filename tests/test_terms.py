"""Properties of the optional terms and wall kinds that had no test of their own.

* Free-slip (smooth) walls transmit no shear: a settled block given a uniform 0.2 m/s slide along a
  smooth floor keeps its x-momentum (≥ 99 % after 0.05 s [99.96 %]), while on a rough floor the
  grains' friction with the wall stops most of it (≤ 30 % left [10 %]); no grain leaks either way.
* XSPH (Eq. 2.49) moves particles, not momentum: its correction vanishes exactly for a uniform
  velocity, and Σ_i m_i δv_i = 0 for any velocity field (pairwise antisymmetric, round-off 1e-12
  of Σ m|δv|), with δv = χ Σ_j (m_j/ρ̄_ij)(v_j − v_i) W_ij checked against a direct sum.
* Shepard filter (Eq. 2.41): a uniform density in the bulk of a lattice is a fixed point (1e-12),
  a density bump is smoothed (its peak drops), and the filter changes no mass.
"""

from __future__ import annotations

import numpy as np
import pytest
from terrasph import _core
from terrasph.config import Material, Numerics
from terrasph.geometry import wall_layers_needed
from terrasph.scene import Scene
from terrasph.simulation import Simulation

DX = 0.004


def sliding_block(no_slip: bool) -> tuple[float, int]:
    """Fraction of the x-momentum a block keeps 0.05 s after it was set sliding, and its leaks."""
    scene = Scene(spacing=DX)
    scene.add_block(0.0, 0.0, 0.08, 0.02)
    scene.add_wall("floor", [(-0.3, 0.0), (0.4, 0.0)], layers=wall_layers_needed(1.3), no_slip=no_slip)
    scene.domain_lower, scene.domain_upper = (-0.35, -0.05), (0.45, 0.2)
    sim = Simulation(scene, Material(), Numerics(spacing=DX))
    sim.advance(0.1)  # settle on the floor
    sim.velocity = sim.velocity + [0.2, 0.0]
    sim.refresh()
    start = sim.mass @ sim.velocity
    sim.advance(sim.time + 0.05)
    return float((sim.mass @ sim.velocity)[0] / start[0]), sim.leaked_particles


def test_free_slip_walls_transmit_no_shear() -> None:
    smooth, smooth_leaks = sliding_block(no_slip=False)
    rough, rough_leaks = sliding_block(no_slip=True)
    assert smooth >= 0.99
    assert rough <= 0.3
    assert smooth_leaks == rough_leaks == 0


def xsph_block(free_block, velocity) -> Simulation:
    scene, block = free_block(DX, 12, 10)
    sim = Simulation(scene, Material(), Numerics(spacing=DX, xsph=0.2),
                     initial_density=np.full(len(block), 1.001 * Material().reference_density))
    sim.velocity = velocity(sim.position)
    sim.refresh()
    return sim


def test_xsph_vanishes_for_a_uniform_velocity(free_block) -> None:
    sim = xsph_block(free_block, lambda x: np.tile([0.3, -0.1], (len(x), 1)))
    assert np.all(sim.field("xsph_correction") == 0.0)


def test_xsph_moves_particles_not_momentum(free_block, rng) -> None:
    sim = xsph_block(free_block, lambda x: rng.normal(0.0, 0.1, x.shape))
    correction = sim.field("xsph_correction")
    mass = sim.mass
    assert np.abs(mass @ correction).max() < 1e-12 * np.sum(mass * np.linalg.norm(correction, axis=1))
    # a direct O(N²) sum of Eq. 2.49
    x, v, rho = sim.position, sim.velocity, sim.density
    h = sim.core.smoothing_length
    distance = np.linalg.norm(x[:, None, :] - x[None, :, :], axis=2)
    weight, _ = _core.wendland_c2_2d(distance.ravel(), h)
    weight = weight.reshape(distance.shape)
    np.fill_diagonal(weight, 0.0)
    rho_mean = 0.5 * (rho[:, None] + rho[None, :])
    expected = 0.2 * np.einsum("ij,ijk->ik", mass[None, :] / rho_mean * weight, v[None, :, :] - v[:, None, :])
    assert np.allclose(correction, expected, rtol=1e-10, atol=1e-14)


def test_shepard_filter_keeps_a_uniform_bulk_and_smooths_a_bump(free_block, bulk_mask) -> None:
    scene, block = free_block(DX, 16, 16)
    rho0 = Material().reference_density
    density = np.full(len(block), 1.001 * rho0)
    sim = Simulation(scene, Material(), Numerics(spacing=DX), initial_density=density)
    bulk = bulk_mask(sim.position, block, 2 * sim.core.smoothing_length)
    mass_before = sim.mass
    sim.core.apply_shepard_filter()
    assert np.allclose(sim.density[bulk], 1.001 * rho0, rtol=1e-12, atol=0.0)
    assert np.array_equal(sim.mass, mass_before)

    bumped = density.copy()
    centre = np.argmin(np.linalg.norm(sim.position - sim.position.mean(axis=0), axis=1))
    bumped[centre] *= 1.01
    sim.density = bumped
    sim.refresh()
    sim.core.apply_shepard_filter()
    assert sim.density[centre] < bumped[centre]
    assert sim.density[centre] == pytest.approx(1.001 * rho0, rel=0.01)
