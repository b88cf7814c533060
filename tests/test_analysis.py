"""Tests of terrasph.analysis on synthetic particle sets with known answers."""

from __future__ import annotations

import numpy as np
import pytest
from terrasph import analysis

SPACING = 0.002  # m, the column-collapse lattice spacing (d = 2 mm)


def lattice_block(nx: int, nz: int, spacing: float = SPACING, x0: float = 0.0, z0: float = 0.0) -> np.ndarray:
    """Cell-centred square lattice filling [x0, x0 + nx·spacing] × [z0, z0 + nz·spacing]."""
    x, z = np.meshgrid(x0 + (np.arange(nx) + 0.5) * spacing, z0 + (np.arange(nz) + 0.5) * spacing)
    return np.column_stack((x.ravel(), z.ravel()))


def stresses(p: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """Symmetric stresses with σ_xx = −p + τ, σ_zz = −p − τ, σ_xz = 0, so invariants are (p, τ)."""
    sigma = np.zeros((p.size, 2, 2))
    sigma[:, 0, 0] = -p + tau
    sigma[:, 1, 1] = -p - tau
    return sigma


def test_surface_profile_of_a_block_is_its_height() -> None:
    # 7 cm × 8 cm column of 35 × 40 cells: every bin must read H0 = 0.08 m (to 1e-12 m).
    centres, heights = analysis.surface_profile(lattice_block(35, 40), SPACING)
    assert centres.shape == (35,)
    np.testing.assert_allclose(heights, 0.08, atol=1e-12)
    np.testing.assert_allclose(centres, (np.arange(35) + 0.5) * SPACING, atol=1e-12)


def test_surface_profile_with_edges_floor_and_empty_bins() -> None:
    # Block of 5 cells wide, 3 tall standing on a floor at z = 0.01 m; edges reach beyond it.
    block = lattice_block(5, 3, z0=0.01)
    edges = np.arange(-2, 8) * SPACING
    centres, heights = analysis.surface_profile(block, SPACING, edges, floor=0.01)
    expected = np.where((centres > 0) & (centres < 5 * SPACING), 3 * SPACING, 0.0)
    np.testing.assert_allclose(heights, expected, atol=1e-12)


def test_surface_profile_follows_a_staircase() -> None:
    # Columns of heights 4, 3, 2, 1 cells: the profile must reproduce them exactly.
    columns = [lattice_block(1, n, x0=i * SPACING) for i, n in enumerate((4, 3, 2, 1))]
    _, heights = analysis.surface_profile(np.vstack(columns), SPACING)
    np.testing.assert_allclose(heights, np.array([4, 3, 2, 1]) * SPACING, atol=1e-12)


def test_front_position_ignores_a_detached_particle() -> None:
    block = lattice_block(35, 40)
    grain = np.array([[0.2, 0.5 * SPACING]])  # 13 cm beyond the toe
    front = analysis.front_position(np.vstack((block, grain)), SPACING)
    assert front == pytest.approx(0.07, abs=1e-12)


def test_front_position_keeps_a_grain_within_the_detach_gap() -> None:
    block = lattice_block(35, 40)
    # Last column centre at 0.07 − spacing/2; the grain's centre is 1.5 spacing further (< default 2 spacing).
    grain = np.array([[0.07 + SPACING, 0.5 * SPACING]])
    front = analysis.front_position(np.vstack((block, grain)), SPACING)
    assert front == pytest.approx(0.07 + 1.5 * SPACING, abs=1e-12)
    front = analysis.front_position(np.vstack((block, grain)), SPACING, detach_gap=SPACING)
    assert front == pytest.approx(0.07, abs=1e-12)


def test_front_position_min_particles_and_floor() -> None:
    # A one-grain-thick tongue of 3 cells ahead of the block is dropped with min_particles=2.
    block = lattice_block(10, 5)
    tongue = lattice_block(3, 1, x0=10 * SPACING)
    deposit = np.vstack((block, tongue))
    assert analysis.front_position(deposit, SPACING) == pytest.approx(13 * SPACING, abs=1e-12)
    assert analysis.front_position(deposit, SPACING, min_particles=2) == pytest.approx(10 * SPACING, abs=1e-12)
    # A grain that leaked below the floor (z = −1 cm) is not part of the deposit.
    leaked = np.array([[11.5 * SPACING, -0.01]])
    front = analysis.front_position(np.vstack((block, leaked)), SPACING)
    assert front == pytest.approx(10 * SPACING, abs=1e-12)


def test_runout_and_height_normalisation() -> None:
    # Column L0 = 7 cm against a wall at x = 0 spreading to 14 cm: L* = 1; H_f = 4 cm of H0 = 8 cm: H* = 0.5.
    assert analysis.normalised_runout(0.14, 0.0, 0.07) == pytest.approx(1.0, rel=1e-12)
    assert analysis.normalised_runout(0.07 + 0.02, 0.02, 0.07) == pytest.approx(0.0, abs=1e-12)
    deposit = lattice_block(70, 20)
    assert analysis.final_height(deposit, SPACING) == pytest.approx(0.04, abs=1e-12)
    assert analysis.normalised_height(analysis.final_height(deposit, SPACING), 0.08) == pytest.approx(0.5, rel=1e-12)


def test_energies_of_known_particles() -> None:
    mass = np.array([1.0, 2.0, 3.0])  # kg/m
    velocity = np.array([[1.0, 0.0], [0.0, -2.0], [3.0, 4.0]])  # |v|² = 1, 4, 25
    # ½(1·1 + 2·4 + 3·25) = 42 J/m; × width 0.1 m = 4.2 J.
    assert analysis.kinetic_energy(mass, velocity) == pytest.approx(42.0, rel=1e-12)
    assert analysis.kinetic_energy(mass, velocity, width=0.1) == pytest.approx(4.2, rel=1e-12)
    position = np.array([[0.0, 1.0], [5.0, 0.5], [1.0, -1.0]])
    # g Σ m z = 9.81 (1 + 1 − 3) = −9.81 J/m.
    assert analysis.potential_energy(mass, position) == pytest.approx(-9.81, rel=1e-12)
    assert analysis.potential_energy(mass, position, gravity=10.0, width=2.0) == pytest.approx(-20.0, rel=1e-12)


def test_at_rest_is_relative() -> None:
    assert analysis.at_rest(0.9e-4, 1.0)
    assert not analysis.at_rest(1.1e-4, 1.0)
    assert analysis.at_rest(0.9e-2, 100.0)  # same ratio at another scale
    assert not analysis.at_rest(0.5, 1.0, tolerance=0.1)


def test_stress_invariants_of_known_tensors() -> None:
    sigma = np.array(
        [
            [[-100.0, 0.0], [0.0, -100.0]],  # isotropic compression: p = 100, τ = 0
            [[-50.0, 30.0], [30.0, -150.0]],  # p = 100, τ = √(50² + 30²)
            [[0.0, 20.0], [20.0, 0.0]],  # pure shear: p = 0, τ = 20
        ]
    )
    p, tau = analysis.stress_invariants(sigma)
    np.testing.assert_allclose(p, [100.0, 100.0, 0.0], rtol=1e-12)
    np.testing.assert_allclose(tau, [0.0, np.hypot(50.0, 30.0), 20.0], rtol=1e-12, atol=1e-12)


def test_stress_invariants_are_rotation_invariant() -> None:
    rng = np.random.default_rng(1)
    a = rng.normal(size=(50, 2, 2))
    sigma = a + np.transpose(a, (0, 2, 1))
    angle = 0.7
    rotation = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    rotated = rotation @ sigma @ rotation.T
    for original, turned in zip(analysis.stress_invariants(sigma), analysis.stress_invariants(rotated)):
        np.testing.assert_allclose(original, turned, rtol=1e-12, atol=1e-12)


def test_yield_locus_recovers_friction_coefficient() -> None:
    # Particles at or below τ = μp (μ = tan 21° ≈ 0.384) with the top of each isobar on the line.
    mu = np.tan(np.radians(21.0))
    rng = np.random.default_rng(2)
    p = rng.uniform(0.0, 1500.0, 2000)
    tau = mu * p * np.where(rng.uniform(size=p.size) < 0.2, 1.0, rng.uniform(0.0, 0.99, p.size))
    p_locus, tau_locus = analysis.yield_locus(stresses(p, tau), pressure_bins=20)
    assert p_locus.size == 20
    assert np.all(np.diff(p_locus) > 0)
    slope, intercept, r_squared = analysis.fit_line(p_locus, tau_locus)
    assert slope == pytest.approx(mu, rel=1e-9)
    assert intercept == pytest.approx(0.0, abs=1e-6)
    assert r_squared == pytest.approx(1.0, abs=1e-12)


def test_fit_line_on_known_data() -> None:
    x = np.array([0.0, 1.0, 2.0, 3.0])
    assert analysis.fit_line(x, 2.0 * x + 1.0) == pytest.approx((2.0, 1.0, 1.0), abs=1e-12)
    slope, intercept, r_squared = analysis.fit_line(x, np.array([0.0, 1.0, 0.0, 1.0]))
    # Least squares by hand: slope 0.2, intercept 0.2, R² = 1 − 0.8/1 = 0.2.
    assert (slope, intercept, r_squared) == pytest.approx((0.2, 0.2, 0.2), abs=1e-12)


def test_vertical_stress_profile_is_linear_with_depth() -> None:
    # Hydrostatic-like column: σ_zz = −ρ g (H − z); layer means must lie on that line.
    rho, g, height = 1600.0, 9.81, 0.08
    block = lattice_block(35, 40)
    sigma = np.zeros((block.shape[0], 2, 2))
    sigma[:, 1, 1] = -rho * g * (height - block[:, 1])
    z, sigma_v = analysis.vertical_stress_profile(block, sigma, SPACING, (0.02, 0.05))
    assert z.shape == (40,)
    np.testing.assert_allclose(z, (np.arange(40) + 0.5) * SPACING, atol=1e-12)
    slope, intercept, r_squared = analysis.fit_line(height - z, sigma_v)
    assert slope == pytest.approx(rho * g, rel=1e-10)
    assert intercept == pytest.approx(0.0, abs=1e-8)
    assert r_squared == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize(
    ("call", "argument"),
    [
        (lambda: analysis.surface_profile(np.zeros((3, 3)), SPACING), "position"),
        (lambda: analysis.surface_profile(np.zeros((3, 2)), 0.0), "spacing"),
        (lambda: analysis.surface_profile(np.zeros((3, 2)), SPACING, np.array([1.0, 0.0])), "x_edges"),
        (lambda: analysis.front_position(np.zeros((3, 2)), -1.0), "spacing"),
        (lambda: analysis.front_position(np.zeros((3, 2)), SPACING, min_particles=0), "min_particles"),
        (lambda: analysis.front_position(np.zeros((3, 2)), SPACING, detach_gap=0.0), "detach_gap"),
        (lambda: analysis.normalised_runout(0.1, 0.0, 0.0), "initial_length"),
        (lambda: analysis.final_height(np.array([[0.0, np.nan]]), SPACING), "position"),
        (lambda: analysis.kinetic_energy(np.ones(2), np.zeros((3, 2))), "mass"),
        (lambda: analysis.kinetic_energy(np.ones(3), np.zeros((3, 2)), width=0.0), "width"),
        (lambda: analysis.potential_energy(np.ones(3), np.zeros((3, 2)), gravity=-9.81), "gravity"),
        (lambda: analysis.at_rest(1.0, 0.0), "potential_drop_scale"),
        (lambda: analysis.at_rest(1.0, 1.0, tolerance=2.0), "tolerance"),
        (lambda: analysis.stress_invariants(np.zeros((3, 3, 3))), "stress"),
        (lambda: analysis.yield_locus(np.zeros((3, 2, 2)), pressure_bins=0), "pressure_bins"),
        (lambda: analysis.fit_line(np.ones(3), np.arange(3.0)), "x"),
        (lambda: analysis.fit_line(np.arange(3.0), np.arange(4.0)), "y"),
        (lambda: analysis.vertical_stress_profile(np.zeros((3, 2)), np.zeros((2, 2, 2)), SPACING, (0, 1)), "stress"),
        (lambda: analysis.vertical_stress_profile(np.zeros((3, 2)), np.zeros((3, 2, 2)), SPACING, (1, 0)), "x_range"),
    ],
)
def test_bad_input_names_the_argument(call, argument: str) -> None:
    with pytest.raises(ValueError, match=rf"\b{argument}\b"):
        call()


def test_deposit_front_stops_at_the_first_thin_bin() -> None:
    """A 10-particle-tall block followed by a one-particle tail and a detached clump: with a
    threshold of 3 particles the front is the block's right edge (x = 10Δx), exactly."""
    dx = 0.01
    block = analysis_lattice(0, 10, 0, 10, dx)
    tail = analysis_lattice(10, 20, 0, 1, dx)
    clump = analysis_lattice(25, 27, 0, 5, dx)
    points = np.concatenate([block, tail, clump])
    assert analysis.deposit_front(points, dx, 3 * dx) == pytest.approx(10 * dx)
    assert analysis.deposit_front(points, dx, 0.5 * dx) == pytest.approx(20 * dx)  # the tail counts
    with pytest.raises(ValueError, match="min_thickness"):
        analysis.deposit_front(points, dx, 0.0)


def analysis_lattice(i0: int, i1: int, k0: int, k1: int, dx: float) -> np.ndarray:
    """Cell-centred lattice points of columns i0..i1-1 and rows k0..k1-1."""
    i, k = np.meshgrid(np.arange(i0, i1), np.arange(k0, k1))
    return np.column_stack([(i.ravel() + 0.5) * dx, (k.ravel() + 0.5) * dx])


def test_vertical_stress_scatter_is_the_mean_within_layer_spread() -> None:
    """Layers of a lattice with σ_zz = −ρg·depth ± a (alternating along x): every layer's std is a,
    so the scatter is a; particles outside x_range do not count."""
    dx, a = 0.01, 7.0
    xs, zs = np.meshgrid(np.arange(10) * dx + 0.5 * dx, np.arange(6) * dx + 0.5 * dx)
    x, z = xs.ravel(), zs.ravel()
    sign = np.where(np.arange(x.size) % 2 == 0, 1.0, -1.0)
    stress = np.zeros((x.size, 2, 2))
    stress[:, 1, 1] = -1500.0 * 9.81 * (0.06 - z) + a * sign
    stress[x > 0.08, 1, 1] += 1e6  # outside the range
    assert analysis.vertical_stress_scatter(np.c_[x, z], stress, dx, (0.0, 0.08)) == pytest.approx(a, rel=1e-9)


# -- shear strain from displacements (Falk & Langer 1998 fit, Shimizu et al. 2007 invariant) ------
def _lattice(nx: int = 20, nz: int = 12, spacing: float = 0.002) -> np.ndarray:
    return np.mgrid[0:nx, 0:nz].reshape(2, -1).T.astype(float) * spacing


def test_shear_strain_of_a_simple_shear_is_the_closed_form() -> None:
    # x' = x + γz: F = [[1, γ], [0, 1]], E = ½(FᵀF − I) = [[0, γ/2], [γ/2, γ²/2]],
    # η² = E_xz² + (E_xx² + E_zz² + (E_xx − E_zz)²)/6 = γ²/4 + γ⁴/12
    reference = _lattice()
    for gamma in (0.01, 0.3, 1.5):
        current = reference + np.column_stack([gamma * reference[:, 1], np.zeros(len(reference))])
        eta = analysis.shear_strain(reference, current, 2.5 * 0.002)
        assert np.allclose(eta, np.sqrt(gamma**2 / 4 + gamma**4 / 12), rtol=1e-10, atol=0)


def test_shear_strain_of_a_stretch_and_of_a_rigid_motion() -> None:
    reference = _lattice()
    # x' = (1 + e)x: E_xx = ((1 + e)² − 1)/2, E_zz = E_xz = 0, η = |E_xx|/√3
    e = 0.05
    stretched = reference * np.array([1 + e, 1.0])
    expected = ((1 + e) ** 2 - 1) / 2 / np.sqrt(3)
    assert np.allclose(analysis.shear_strain(reference, stretched, 0.005), expected, rtol=1e-10)
    angle = 0.8
    rotation = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    moved = reference @ rotation.T + np.array([0.3, -0.1])
    assert np.nanmax(analysis.shear_strain(reference, moved, 0.005)) < 1e-12


def test_shear_strain_is_local_and_refuses_bad_input() -> None:
    reference = _lattice(40, 10)
    # shear only the right half: particles well inside the left half see none
    current = reference.copy()
    right = reference[:, 0] > 0.04
    current[right, 0] += 0.2 * reference[right, 1]
    eta = analysis.shear_strain(reference, current, 0.005)
    assert np.all(eta[reference[:, 0] < 0.03] < 1e-12)
    assert np.allclose(eta[reference[:, 0] > 0.05], np.sqrt(0.2**2 / 4 + 0.2**4 / 12), rtol=1e-10)
    # a particle with no neighbour within the radius has no strain to report
    lonely = np.vstack([reference, [[1.0, 1.0]]])
    assert np.isnan(analysis.shear_strain(lonely, lonely, 0.005)[-1])
    with pytest.raises(ValueError, match="current"):
        analysis.shear_strain(reference, reference[:-1], 0.005)
    with pytest.raises(ValueError, match="radius"):
        analysis.shear_strain(reference, reference, 0.0)
