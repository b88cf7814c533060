"""The core in 3D: ``Simulation<3>`` runs, although every scene is 2D.

References: on a cubic lattice at rest, Wendland C2 with h = 1.3Δx in 3D gives Σ_j V_j W_ij = 1
within 1.5 % [0.95 %] and Σ_j V_j ∇W_ij = 0 to round-off (1e-12 / h) in the bulk (the lattice is
symmetric), and the SPH gradient of a linear velocity field there is exact to round-off (1e-10; the
kernel's own gradient misses it by 1 − s = 0.021, s = 0.979 its lattice moment at h = 1.3Δx in 3D,
which the default divides out); a bed of grains in a rough box under gravity, started at the lithostatic density
ρ = ρ0 (1 + ρ0 g depth / κ)^(1/γ) (the EOS inverted), stays at rest (mean speed below 1 mm/s after
600 steps [0.04 mm/s]) with −σ_zz of the bottom layer within 5 % of ρ0 g depth [1.6 %], no
particle past a wall (leak counter 0).
"""

from __future__ import annotations

import numpy as np
from terrasph import _core

DX = 0.004
G = 9.81


def lattice(n: int) -> np.ndarray:
    centres = (np.arange(n) + 0.5) * DX
    return np.array(np.meshgrid(centres, centres, centres, indexing="ij")).reshape(3, -1).T


def params(gravity: float) -> _core.ModelParams3D:
    p = _core.ModelParams3D()
    p.numerics.spacing = DX
    p.domain.lower = np.full(3, -0.5)
    p.domain.upper = np.full(3, 0.5)
    p.domain.gravity = np.array([0.0, 0.0, -gravity])
    return p


def no_walls() -> dict[str, np.ndarray]:
    return {"position": np.zeros((0, 3)), "normal": np.zeros((0, 3)), "mass": np.zeros(0),
            "no_slip": np.zeros(0, np.uint8), "group": np.zeros(0, np.int32)}


def box_walls(n: int, layers: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Wall particles of an open-topped box around an n × n × n block, with inward normals."""
    position, normal = [], []
    for i in range(-layers, n + layers):
        for j in range(-layers, n + layers):
            for k in range(-layers, n + 2):
                if 0 <= i < n and 0 <= j < n and k >= 0:
                    continue
                inward = np.zeros(3)
                if k < 0:
                    inward[2] = 1.0
                elif i < 0 or i >= n:
                    inward[0] = 1.0 if i < 0 else -1.0
                else:
                    inward[1] = 1.0 if j < 0 else -1.0
                position.append((np.array([i, j, k]) + 0.5) * DX)
                normal.append(inward)
    return np.array(position), np.array(normal)


def test_kernel_moments_on_a_3d_lattice() -> None:
    p = params(gravity=0.0)
    x = lattice(10)
    rho = np.full(len(x), p.material.reference_density)
    sim = _core.Simulation3D(p, {"position": x, "velocity": np.zeros_like(x), "density": rho, "mass": rho * DX**3},
                             no_walls())
    h = sim.smoothing_length
    bulk = np.all((x > 2 * h) & (x < 10 * DX - 2 * h), axis=1)
    assert bulk.sum() >= 27
    assert np.abs(sim.kernel_sum()[bulk] - 1.0).max() < 0.015
    assert np.abs(sim.kernel_gradient_sum()[bulk]).max() < 1e-12 / h


def test_a_linear_field_gradient_is_exact_on_a_3d_lattice() -> None:
    x = lattice(10)
    gradient = np.array([[0.3, -0.7, 0.2], [1.1, 0.2, -0.4], [0.5, 0.6, -0.9]])  # 1/s
    errors = []
    for normalisation in (True, False):
        p = params(gravity=0.0)
        p.numerics.kernel_gradient_normalisation = normalisation
        rho = np.full(len(x), p.material.reference_density)
        sim = _core.Simulation3D(p, {"position": x, "velocity": x @ gradient.T, "density": rho,
                                     "mass": rho * DX**3}, no_walls())
        h = sim.smoothing_length
        bulk = np.all((x > 2 * h) & (x < 10 * DX - 2 * h), axis=1)
        errors.append(np.abs(sim.velocity_gradient[bulk] - gradient).max() / np.abs(gradient).max())
    assert errors[0] < 1e-10
    assert 0.01 < errors[1] < 0.05  # the check above is not vacuous


def test_a_3d_bed_in_a_box_stays_at_rest_under_its_weight() -> None:
    p = params(gravity=G)
    n = 5
    x = lattice(n)
    rho0 = p.material.reference_density
    bulk_modulus = p.material.bulk_stiffness
    depth = n * DX - x[:, 2]
    rho = rho0 * (rho0 * G * depth / bulk_modulus + 1.0) ** (1.0 / p.material.eos_exponent)  # inverse EOS
    walls, normals = box_walls(n)
    sim = _core.Simulation3D(
        p, {"position": x, "velocity": np.zeros_like(x), "density": rho, "mass": rho * DX**3},
        {"position": walls, "normal": normals, "mass": np.full(len(walls), rho0 * DX**3),
         "no_slip": np.ones(len(walls), np.uint8), "group": np.zeros(len(walls), np.int32)})
    sim.advance(1.0, 600)
    assert sim.step == 600
    assert np.linalg.norm(sim.velocity, axis=1).mean() < 1e-3
    bottom = sim.position[:, 2] < DX
    lithostatic = rho0 * G * (n - 0.5) * DX
    assert abs(-sim.stress[bottom, 2, 2].mean() - lithostatic) < 0.05 * lithostatic
    assert sim.penetrated_particles == 0
