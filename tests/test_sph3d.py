"""Shapes, the bed at rest and plate intrusion in 3D (terrasph.sph3d, docs/sph3d.md).

References: a filled shape keeps the lattice points inside it within the wall layers' thickness
t = ceil(2 h/Δx) Δx of its surface, each normal a unit vector pointing out (n · ∇d < 0 for the
shape's distance-below-surface d, checked against the analytic surface), and its particle count is
the shell's volume over Δx³ within 5 % (a lattice's sampling of a curved shell, R/Δx = 5–7.5
[1.2 %, 2.5 %]);
a part thinner than t is refused, naming the parameter. An extruded planar section has one copy of
the section per row across the width, the rows at the ends facing ±y. A bed at rest started at
Jáky's K0 = 1 − sin φ state (φ = atan μ1, K0 = 0.642) keeps σ_xx/σ_zz and σ_yy/σ_zz within 0.05
of K0 over 0.1 s [0.647] and −σ_zz of every row of grains away from the walls within 3 % of the
weight above it per unit area [−0.2 to +0.5 %], at rest (mean speed < 0.2 mm/s [0.01]); so does a bed between smooth walls facing ±y (the slab of
terrasph.scenes.plane_strain_3d). A box
plate pushed down into the bed at constant speed meets a resistance that grows with depth, about
in proportion as a shallow footing's in cohesionless soil (Terzaghi: q ∝ γ d): from 4 to 16 mm more
than 3× [4.3×].
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from terrasph.bodies import c_leg
from terrasph.config import ConfigError, Material, Numerics
from terrasph.sph3d import (
        bed_simulation,
    body_walls,
    box,
    capsule,
    cylinder,
    ellipsoid,
    extrude,
    geostatic_bed,
    sphere,
)

DX = 0.004
LAYERS = 3 * DX  # ceil(2 · 1.3) spacings


def _outward_and_in_shell(shape, depth_below_surface, gradient) -> None:
    depth = depth_below_surface(shape.position)
    assert depth.min() >= -1e-12 and depth.max() < LAYERS
    assert np.allclose(np.linalg.norm(shape.normal, axis=1), 1.0)
    assert np.all(np.einsum("ij,ij->i", shape.normal, gradient(shape.position)) < 0)


def test_box_sphere_cylinder_and_capsule_shells() -> None:
    half = np.array([0.03, 0.02, 0.015])
    b = box(tuple(half), DX)
    def nearest_faces(x):  # −∇ of the distance to the nearest face(s)
        gaps = half - np.abs(x)
        return -np.sign(x) * (gaps == gaps.min(axis=1, keepdims=True))
    _outward_and_in_shell(b, lambda x: (half - np.abs(x)).min(axis=1), nearest_faces)
    r = 0.03
    s = sphere(r, DX)
    _outward_and_in_shell(s, lambda x: r - np.linalg.norm(x, axis=1), lambda x: -x)
    shell = 4.0 / 3.0 * math.pi * (r**3 - (r - LAYERS) ** 3)
    assert abs(len(s.position) * DX**3 / shell - 1.0) < 0.05
    c = capsule(0.02, 0.03, DX)

    def capsule_offset(x):
        return x - np.column_stack([np.zeros((len(x), 2)), np.clip(x[:, 2], -0.03, 0.03)])
    _outward_and_in_shell(c, lambda x: 0.02 - np.linalg.norm(capsule_offset(x), axis=1), lambda x: -capsule_offset(x))
    cyl = cylinder(0.02, 0.03, DX)
    def cylinder_gaps(x):
        return 0.02 - np.linalg.norm(x[:, :2], axis=1), 0.03 - np.abs(x[:, 2])

    def cylinder_gradient(x):  # ∇ of min(side gap, cap gap): −radial at the side, −sign(z) ẑ at a cap
        side, cap = cylinder_gaps(x)
        radial = np.column_stack([x[:, :2], np.zeros(len(x))]) / np.linalg.norm(x[:, :2], axis=1)[:, None]
        axial = np.column_stack([np.zeros((len(x), 2)), np.sign(x[:, 2])])
        return -(radial * (side <= cap)[:, None] + axial * (cap <= side)[:, None])
    _outward_and_in_shell(cyl, lambda x: np.minimum(*cylinder_gaps(x)), cylinder_gradient)
    volume = math.pi * 0.02**2 * 0.06 - math.pi * (0.02 - LAYERS) ** 2 * (0.06 - 2 * LAYERS)
    assert abs(len(cyl.position) * DX**3 / volume - 1.0) < 0.05


def test_an_ellipsoid_shell_against_the_exact_distance() -> None:
    """An ellipsoid of semi-axes 30, 24, 18 mm: every particle is inside it within the wall layers'
    thickness (+ half a spacing for the first-order depth) of its surface, every lattice point deeper
    than 0 and shallower than 0.9 × the layers is a particle (no hole for grains), and the normals
    point out. Reference: the distance to a dense sampling of the surface (x = a cos u sin v, …; 400
    × 200 points, spacing below 0.5 mm)."""
    axes = np.array([0.03, 0.024, 0.018])
    e = ellipsoid(tuple(axes), DX)
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 400), np.linspace(0, np.pi, 200))
    surface = np.column_stack([axes[0] * np.cos(u).ravel() * np.sin(v).ravel(),
                               axes[1] * np.sin(u).ravel() * np.sin(v).ravel(), axes[2] * np.cos(v).ravel()])

    def exact_depth(points: np.ndarray) -> np.ndarray:
        inside = np.linalg.norm(points / axes, axis=1) <= 1.0
        nearest = np.array([np.sqrt(((surface - p) ** 2).sum(axis=1)).min() for p in points])
        return np.where(inside, nearest, -nearest)

    depth = exact_depth(e.position)
    assert depth.min() >= -1e-12 and depth.max() < LAYERS + 0.5 * DX
    assert np.allclose(np.linalg.norm(e.normal, axis=1), 1.0)
    assert np.all(np.einsum("ij,ij->i", e.normal, e.position) > 0)
    n = np.round(2 * axes / DX).astype(int)
    grid = np.array(np.meshgrid(*[(np.arange(k) - (k - 1) / 2) * DX for k in n], indexing="ij")).reshape(3, -1).T
    grid_depth = exact_depth(grid)
    needed = grid[(grid_depth > 0) & (grid_depth < 0.9 * LAYERS)]
    have = {tuple(np.round(p / DX * 2).astype(int)) for p in e.position}
    assert all(tuple(np.round(p / DX * 2).astype(int)) in have for p in needed)


def test_thin_parts_are_refused() -> None:
    with pytest.raises(ConfigError, match="thickness of box"):
        box((0.03, 0.03, 0.004), DX)
    with pytest.raises(ConfigError, match="thickness of sphere"):
        sphere(0.005, DX)
    with pytest.raises(ConfigError, match="'width'"):
        extrude(c_leg(0.05, 0.012, 0.1, DX), 0.008)


def test_an_extruded_c_leg_has_a_section_per_row_and_faces_at_its_ends() -> None:
    section = c_leg(0.05, 0.012, 0.1, DX)
    leg = extrude(section, 0.04)
    rows = round(0.04 / DX)
    assert len(leg.position) == rows * len(section.position)
    y = leg.position[:, 1]
    assert np.allclose(np.unique(np.round(y / DX, 6)) * DX, (np.arange(rows) - (rows - 1) / 2) * DX)
    ends = np.abs(y) == np.abs(y).max()
    # the end rows (half a spacing from the side faces) face out along ±y unless at the section's outline
    assert np.mean(np.sign(y[ends]) * leg.normal[ends, 1] == 1.0) > 0.5
    middle = np.abs(y) < DX
    copies = middle.sum() // len(section.position)
    assert copies >= 1 and np.array_equal(leg.normal[middle][:, [0, 2]], np.tile(section.normal, (copies, 1)))
    assert np.all(leg.normal[middle, 1] == 0.0)


def _bed_sim(size, material: Material, extra=None, smooth_y_walls: bool = False):
    bed = geostatic_bed(size, material, DX, rim=0.02, smooth_y_walls=smooth_y_walls)
    lower = np.array([-0.05, -0.05, -0.05])
    upper = np.array([size[0] + 0.05, size[1] + 0.05, size[2] + 0.1])
    return bed, bed_simulation(bed, material, Numerics(spacing=DX), lower, upper, extra)


@pytest.mark.slow
@pytest.mark.parametrize("smooth_y_walls", [False, True])
def test_a_3d_bed_at_rest_keeps_k0_and_carries_its_weight(smooth_y_walls: bool) -> None:
    material = Material()
    size = (0.048, 0.048, 0.032)
    _, sim = _bed_sim(size, material, smooth_y_walls=smooth_y_walls)
    k0 = 1.0 - math.sin(math.atan(material.mu1))
    sim.advance(0.1, 100000)
    x, stress = sim.position, sim.stress
    central = np.all((x[:, :2] > 0.2 * np.array(size[:2])) & (x[:, :2] < 0.8 * np.array(size[:2])), axis=1)
    inside = central & (x[:, 2] < size[2] - 2 * DX)
    for axis in (0, 1):
        assert stress[inside, axis, axis].sum() / stress[inside, 2, 2].sum() == pytest.approx(k0, abs=0.05)
    rows = np.round(x[:, 2] / DX - 0.5).astype(int)
    ratios = []
    for row in range(rows.max()):  # the weight above each row's centre per unit area, from the masses
        layer, above = central & (rows == row), central & (rows > row)
        weight = (sim.density[above].sum() + 0.5 * sim.density[layer].sum()) * DX**3 * 9.81 / (layer.sum() * DX**2)
        ratios.append(-stress[layer, 2, 2].mean() / weight)
    assert len(ratios) >= 7 and np.all(np.abs(np.array(ratios) - 1.0) < 0.03), ratios
    assert np.linalg.norm(sim.velocity, axis=1).mean() < 2e-4
    assert sim.penetrated_particles == 0


@pytest.mark.slow
def test_a_3d_plate_meets_more_resistance_deeper() -> None:
    material = Material()
    size = (0.064, 0.064, 0.04)
    plate = box((0.012, 0.012, 0.006), DX)
    start = np.array([size[0] / 2, size[1] / 2, size[2] + 0.006 + 0.5 * DX])
    _, sim = _bed_sim(size, material, body_walls(plate, start, 2, material))
    speed = 0.05
    sim.add_body(2, start, np.array([1.0, 0.0, 0.0, 0.0]), [[math.inf, 0.0, 0.0, -speed, 0.0, 0.0, 0.0]])
    depths, forces = [], []
    for depth in (0.004, 0.008, 0.012, 0.016):
        sim.reset_body_means()
        sim.advance(depth / speed, 10**7)
        depths.append(depth)
        forces.append(sim.body_state(0)["mean_force"][2])
    assert all(np.diff(forces) > 0), forces
    assert forces[-1] > 3 * forces[0]
    assert sim.penetrated_particles == 0
