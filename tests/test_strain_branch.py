"""The strain-based quasi-static branch of Eq. 3.6 (``material.model = "mu_i_strain"``).

References (independent of the code, tolerances stated):
* Patch test: particles moved by a homogeneous deformation x = F X from their reference lattice X
  have the displacement u = x − X = (I − F⁻¹) x, linear in the current positions, so the SPH
  gradient (renormalised) must give E = sym(I − F⁻¹) at every particle, edges and corners of the
  free patch included, to round-off (1e-12 against |E| ~ 1e-3). For small strain this is sym(F − I)
  to O(|F − I|²) (checked to 1e-5).
* Branch direction: below I = 0.001 the deviatoric stress is (μ(I)P + c) E′/(|E′| + ε) (Eq. 3.6;
  E′ the deviator of E, hand formula here, 1e-12); above it, the rate form of Eq. 2.29, the same
  stress as ``mu_i_rate`` (exact).
* The reference follows the particles until ``strain_reference_time`` and is fixed from then on;
  a checkpoint carries it (a restored run continues bit for bit, and its reference is not the one
  a fresh start would take).
* Scenes with another model register neither field (they pay nothing for the option).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from terrasph import _core
from terrasph.config import ConfigError, Material, Numerics
from terrasph.geometry import wall_layers_needed
from terrasph.scene import Scene
from terrasph.simulation import Simulation

DX = 0.005
RHO0 = Material().reference_density


def _patch(model: str = "mu_i_strain") -> Simulation:
    """A free 10 × 8 lattice patch (no walls)."""
    scene = Scene(spacing=DX)
    scene.add_block(0.0, 0.0, 10 * DX, 8 * DX)
    return Simulation(scene, Material(model=model), Numerics(spacing=DX))


def _bed(**material: float | str) -> Simulation:
    """The 0.12 × 0.05 m bed of tests/test_mls.py in a rough box (240 grains)."""
    scene = Scene(spacing=DX)
    scene.add_block(0.0, 0.0, 0.12, 0.05)
    scene.add_wall("box", [(0.0, 0.08), (0.0, 0.0), (0.12, 0.0), (0.12, 0.08)], layers=wall_layers_needed(1.3))
    return Simulation(scene, Material(model="mu_i_strain", **material), Numerics(spacing=DX))


def test_homogeneous_deformation_gives_the_exact_small_strain_everywhere() -> None:
    sim = _patch()
    reference = np.array(sim.position)
    deformation = np.eye(2) + np.array([[1.0e-3, 2.0e-3], [-0.5e-3, -1.5e-3]])
    sim.position = reference @ deformation.T
    sim.refresh()
    strain = sim.field("small_strain").reshape(-1, 2, 2)
    gradient = np.eye(2) - np.linalg.inv(deformation)
    exact = 0.5 * (gradient + gradient.T)
    assert np.abs(strain - exact).max() < 1e-12 * 1e3  # round-off on ~1e-3 strains, every particle
    small = 0.5 * (deformation - np.eye(2) + (deformation - np.eye(2)).T)
    assert np.abs(exact - small).max() < 1e-5  # the small-strain tensor of the prescribed F
    np.testing.assert_array_equal(sim.field("reference_position"), reference)


def _update(velocity_gradient: np.ndarray, strain: np.ndarray, model: str = "mu_i_strain") -> np.ndarray:
    params = _core.ModelParams2D()
    params.material.model = model
    state = {"small_strain": strain} if model == "mu_i_strain" else {}
    return _core.constitutive_update(params, velocity_gradient, 1.001 * RHO0, 1e-5, state)


def test_below_the_quasi_static_inertial_number_the_stress_follows_the_strain() -> None:
    strain = np.array([[2e-4, 3e-4], [3e-4, 1e-4]])
    slow = 1e-4 * np.array([[0.0, 1.0], [0.0, 0.0]])  # simple shear at I ~ 1e-6
    out = _update(slow, strain)
    material = Material()
    p = out["pressure"]
    assert p > 0
    deviator = strain - 0.5 * np.trace(strain) * np.eye(2)
    magnitude = math.sqrt(0.5 * np.sum(deviator**2))
    epsilon = Numerics().strain_rate_epsilon  # a rate (1/s), independent of h
    shear_rate = 0.5e-4  # |D′| of the simple shear: √(½ D′:D′) with D′_xz = ½γ̇
    # I with Jop, Forterre & Pouliquen (2006)'s rate γ̇ = 2|D′| (|D′| = √(½ D′:D′), `shear_rate` here)
    inertial = 2.0 * shear_rate * material.grain_diameter / math.sqrt(p / material.grain_density)
    assert inertial < 1e-3
    mu = material.mu1 + (material.mu2 - material.mu1) * inertial / (material.inertial_number_i0 + inertial)
    expected = mu * p / (magnitude + epsilon) * deviator - p * np.eye(2)
    np.testing.assert_allclose(out["stress"], expected, rtol=1e-12, atol=1e-12 * p)
    # the shear stress points along E′, not along the strain rate (which is pure xz shear)
    assert out["stress"][0, 0] - out["stress"][1, 1] > 0.2 * mu * p


def test_above_the_quasi_static_inertial_number_the_rate_form_holds() -> None:
    strain = np.array([[2e-4, 3e-4], [3e-4, 1e-4]])
    fast = 50.0 * np.array([[0.1, 1.0], [0.3, -0.2]])
    np.testing.assert_array_equal(_update(fast, strain)["stress"], _update(fast, strain, "mu_i_rate")["stress"])


def test_the_reference_follows_the_particles_until_the_reference_time() -> None:
    sim = _bed(strain_reference_time=0.004)
    initial = np.array(sim.position)
    sim.advance(0.002)
    np.testing.assert_array_equal(sim.field("reference_position"), sim.position)
    assert np.abs(sim.position - initial).max() > 0  # the bed moved, so "follows" means something
    sim.advance(0.004)
    taken = np.array(sim.field("reference_position"))
    np.testing.assert_array_equal(taken, sim.position)  # the step boundary at the reference time
    sim.advance(0.006)
    np.testing.assert_array_equal(sim.field("reference_position"), taken)
    assert np.abs(sim.position - taken).max() > 0
    assert np.abs(sim.field("small_strain")).max() > 0


def test_a_checkpoint_carries_the_reference_positions(tmp_path) -> None:
    sim = _bed(strain_reference_time=0.002)
    sim.advance(0.003)
    sim.checkpoint(tmp_path / "strain.h5")
    sim.advance(0.005)
    restored = _bed(strain_reference_time=0.002)
    assert np.abs(restored.field("reference_position") - sim.field("reference_position")).max() > 0
    restored.restore(tmp_path / "strain.h5")
    restored.advance(0.005)
    for name in ("position", "velocity", "stress", "reference_position", "small_strain"):
        np.testing.assert_array_equal(restored.field(name), sim.field(name), err_msg=name)


@pytest.mark.parametrize("model", ["mu_i_rate", "mu_i_hypoelastic", "drucker_prager"])
def test_other_models_store_no_reference_positions(model: str) -> None:
    names = _patch(model).core.field_names("granular")
    assert "reference_position" not in names and "small_strain" not in names
    assert "reference_position" in _patch().core.field_names("granular")


def test_a_negative_reference_time_is_refused_by_name() -> None:
    with pytest.raises(ConfigError, match="strain_reference_time"):
        Material(model="mu_i_strain", strain_reference_time=-1.0)
