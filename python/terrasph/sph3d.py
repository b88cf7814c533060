"""Granular SPH in 3D: a box bed with fixed ghost walls, rigid bodies filled with particles, and
plate intrusion on ``_core.Simulation3D`` (docs/sph3d.md).

Axes: x and y horizontal, z up; gravity (0, 0, −g). A body's orientation is a unit quaternion
(w, x, y, z) and its angular velocity a vector (rad/s, right-handed): a body turning about +y moves
in the x–z plane as the planar (2D) body turning clockwise. Loads are whole (N, N·m), not per
metre of depth.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from terrasph import _core
from terrasph.bodies import BodyShape, minimum_thickness
from terrasph.config import ConfigError, Material, Numerics
from terrasph.geometry import wall_layers_needed
from terrasph.scene import GRAVITY, earth_pressure_at_rest

__all__ = ["BED_MARGIN", "BED_SPACING", "BED_WALLS", "Bed3D", "BodyShape3D", "bed_simulation", "body_walls", "box",
           "capsule", "core_params", "cylinder", "ellipsoid", "extrude", "geostatic_bed", "geostatic_deviatoric_stress",
           "quaternion_matrix", "sphere", "turn_about_y"]

BED_WALLS = {"floor": 0, "sides": 1}  # wall groups of a bed's box
#: how far (m) a 3D bed under a MuJoCo model (terrasph.terrain.attach) reaches beyond the coupled geoms on
#: each side (x, y) unless its size is given: room for a robot of gymnasium's Ant's size to settle and step
BED_MARGIN = 0.3
#: the grains' spacing (m) of a 3D bed under a MuJoCo model unless given: coarse, the coarsest at which the
#: Ant's capsules (16 cm across) hold the three wall layers a body needs
BED_SPACING = 0.05


@dataclass(frozen=True)
class BodyShape3D:
    """Particles of a rigid body in its own frame (reference point at the origin).

    Attributes:
        name: shape name, e.g. ``"sphere"``.
        position: (M, 3) body-frame particle positions (m), centres of cubic cells of side Δx.
        normal: (M, 3) unit outward normals of the nearest surface (out of the body, into the sand).
        spacing: Δx (m).
    """

    name: str
    position: np.ndarray
    normal: np.ndarray
    spacing: float


def _cells(half_extent: np.ndarray, spacing: float) -> np.ndarray:
    """Cell centres of a lattice of spacing Δx, symmetric about the origin, covering ±half_extent."""
    axes = []
    for h in half_extent:
        n = max(1, round(2.0 * h / spacing))
        axes.append((np.arange(n) - (n - 1) / 2.0) * spacing)
    return np.array(np.meshgrid(*axes, indexing="ij")).reshape(3, -1).T


def _shell(name: str, points: np.ndarray, depth: np.ndarray, normal: np.ndarray, spacing: float,
           thinnest: float, h_factor: float) -> BodyShape3D:
    """The lattice points inside the body (depth ≥ 0 below the surface) within the wall layers'
    thickness of it, a part thinner than that thickness refused (grains would leak through it)."""
    layers = minimum_thickness(spacing, h_factor)
    if thinnest < layers * (1 - 1e-9):
        raise ConfigError(f"parameter 'thickness of {name}' = {thinnest:g} m is invalid: allowed >= {layers:g} m "
                          f"(= {wall_layers_needed(h_factor)} wall layers × spacing {spacing:g} m); grains could "
                          "leak through the part")
    keep = (depth >= 0.0) & (depth < layers)
    return BodyShape3D(name, points[keep], normal[keep], spacing)


def _positive(name: str, value: float) -> float:
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
        raise ConfigError(f"parameter '{name}' = {value!r} is invalid: allowed a finite number > 0 (m)")
    return float(value)


def box(half_extent: tuple[float, float, float], spacing: float, h_factor: float = 1.3) -> BodyShape3D:
    """A box of half-sides ``half_extent`` (m) centred at the origin; normals of the nearest face."""
    half = np.array([_positive("half_extent", h) for h in half_extent])
    dx = _positive("spacing", spacing)
    points = _cells(half, dx)
    gaps = half - np.abs(points)  # distance to the two faces of each axis
    axis = np.argmin(gaps, axis=1)
    rows = np.arange(len(points))
    normal = np.zeros_like(points)
    normal[rows, axis] = np.sign(points[rows, axis])
    return _shell("box", points, gaps[rows, axis], normal, dx, 2.0 * half.min(), h_factor)


def sphere(radius: float, spacing: float, h_factor: float = 1.3) -> BodyShape3D:
    """A sphere of radius R at the origin; radial normals."""
    r0, dx = _positive("radius", radius), _positive("spacing", spacing)
    points = _cells(np.full(3, r0), dx)
    r = np.linalg.norm(points, axis=1)
    normal = points / np.maximum(r, 1e-300)[:, None]
    return _shell("sphere", points, r0 - r, normal, dx, 2.0 * r0, h_factor)


def ellipsoid(half_axes: tuple[float, float, float], spacing: float, h_factor: float = 1.3) -> BodyShape3D:
    """An ellipsoid of semi-axes (a, b, c) along x, y, z at the origin (MuJoCo's ellipsoid). With
    F = |(x/a, y/b, z/c)|, the depth below the surface is taken to first order, (1 − F)/|∇F| (exact
    for a sphere), and the normal along ∇F."""
    axes = np.array([_positive("half_axes", h) for h in half_axes])
    dx = _positive("spacing", spacing)
    points = _cells(axes, dx)
    scaled = np.linalg.norm(points / axes, axis=1)
    gradient = points / axes**2 / np.maximum(scaled, 1e-300)[:, None]  # ∇F
    size = np.linalg.norm(gradient, axis=1)
    at_centre = size == 0.0
    size[at_centre] = 1.0 / axes.min()  # the centre: depth the smallest semi-axis
    normal = gradient / size[:, None]
    normal[at_centre] = (0.0, 0.0, 1.0)
    return _shell("ellipsoid", points, (1.0 - scaled) / size, normal, dx, 2.0 * axes.min(), h_factor)


def _segment_shell(name: str, radius: float, half_length: float, spacing: float, h_factor: float,
                   rounded: bool) -> BodyShape3D:
    """A cylinder (flat caps) or a capsule (hemispherical caps) of radius R about the z axis whose
    straight part spans |z| ≤ half_length."""
    r0, dx = _positive("radius", radius), _positive("spacing", spacing)
    length = _positive("half_length", half_length)
    points = _cells(np.array([r0, r0, length + (r0 if rounded else 0.0)]), dx)
    if rounded:  # distance from the axis segment
        nearest = np.column_stack([np.zeros((len(points), 2)), np.clip(points[:, 2], -length, length)])
        offset = points - nearest
        r = np.linalg.norm(offset, axis=1)
        return _shell(name, points, r0 - r, offset / np.maximum(r, 1e-300)[:, None], dx, 2.0 * r0, h_factor)
    radial = np.linalg.norm(points[:, :2], axis=1)
    side_gap, cap_gap = r0 - radial, length - np.abs(points[:, 2])
    normal = np.zeros_like(points)
    on_side = side_gap <= cap_gap
    normal[on_side, :2] = points[on_side, :2] / np.maximum(radial[on_side], 1e-300)[:, None]
    normal[~on_side, 2] = np.sign(points[~on_side, 2])
    return _shell(name, points, np.minimum(side_gap, cap_gap), normal, dx, 2.0 * min(r0, length), h_factor)


def cylinder(radius: float, half_length: float, spacing: float, h_factor: float = 1.3) -> BodyShape3D:
    """A cylinder of radius R about the z axis, |z| ≤ half_length; normals of the nearest face."""
    return _segment_shell("cylinder", radius, half_length, spacing, h_factor, rounded=False)


def capsule(radius: float, half_length: float, spacing: float, h_factor: float = 1.3) -> BodyShape3D:
    """A capsule of radius R about the segment |z| ≤ half_length of the z axis (MuJoCo's capsule)."""
    return _segment_shell("capsule", radius, half_length, spacing, h_factor, rounded=True)


def extrude(section: BodyShape, width: float, h_factor: float = 1.3) -> BodyShape3D:
    """A planar :class:`terrasph.bodies.BodyShape` (x–z section: a C-leg, a plate, a leg-wheel)
    extruded along y to ``width`` (m), centred on y = 0. A particle nearer a side face than the
    section's outline takes that face's normal ±y, the others keep their in-plane normal."""
    dx = float(section.spacing)
    w = _positive("width", width)
    minimum = minimum_thickness(dx, h_factor)
    if w < minimum * (1 - 1e-9):
        raise ConfigError(f"parameter 'width' = {w:g} m is invalid: allowed >= {minimum:g} m "
                          f"(= {wall_layers_needed(h_factor)} wall layers × spacing {dx:g} m)")
    rows = max(1, round(w / dx))
    ys = (np.arange(rows) - (rows - 1) / 2.0) * dx
    inner = _outline_depth(section)
    position, normal = [], []
    for y in ys:
        side_gap = w / 2.0 - abs(y)
        to_side = side_gap < inner
        n = np.column_stack([section.normal[:, 0], np.zeros(len(section.normal)), section.normal[:, 1]])
        n[to_side] = (0.0, math.copysign(1.0, y), 0.0)
        position.append(np.column_stack([section.position[:, 0], np.full(len(section.position), y),
                                         section.position[:, 1]]))
        normal.append(n)
    return BodyShape3D(f"{section.name}-extruded", np.concatenate(position), np.concatenate(normal), dx)


def _outline_depth(section: BodyShape) -> np.ndarray:
    """Each section particle's distance to the section's outline (its nearest edge); half a spacing
    for a section given as particles only (every particle then treated as at the surface)."""
    points = np.asarray(section.position)
    if not section.outline:
        return np.full(len(points), 0.5 * section.spacing)
    best = np.full(len(points), np.inf)
    for loop in section.outline:
        a, b = loop, np.roll(loop, -1, axis=0)
        for p0, p1 in zip(a, b):
            edge = p1 - p0
            t = np.clip((points - p0) @ edge / max(edge @ edge, 1e-300), 0.0, 1.0)
            best = np.minimum(best, np.linalg.norm(points - (p0 + t[:, None] * edge), axis=1))
    return best


def core_params(material: Material, numerics: Numerics, lower: np.ndarray, upper: np.ndarray,
                gravity: float = GRAVITY) -> _core.ModelParams3D:
    """The core's 3D parameters: ``material`` and ``numerics`` in the domain box [lower, upper]
    (a grain leaving it stops the run), gravity (0, 0, −g)."""
    params = _core.ModelParams3D()
    params.material = material.to_core()
    params.numerics = numerics.to_core()
    domain = params.domain
    domain.lower, domain.upper = np.asarray(lower, float), np.asarray(upper, float)
    domain.gravity = np.array([0.0, 0.0, -gravity])
    params.domain = domain
    params.validate()
    return params


@dataclass(frozen=True)
class Bed3D:
    """A bed of grains on a cubic lattice in an open box of fixed ghost walls (the core's arrays).

    Attributes:
        granular: position, velocity, density, mass of the grains (masses ρ Δx³, kg).
        walls: position, normal, mass, no_slip, group of the wall particles (groups BED_WALLS).
        size: the grains' extent (x, y, z) (m), the bed's floor at z = 0 and its corner at x = y = 0.
        depth: the grains' depth below the surface per grain (m).
    """

    granular: dict[str, np.ndarray]
    walls: dict[str, np.ndarray]
    size: tuple[float, float, float]
    depth: np.ndarray


def geostatic_bed(size: tuple[float, float, float], material: Material, spacing: float, *,
                  h_factor: float = 1.3, rim: float = 0.0, gravity: float = GRAVITY,
                  smooth_y_walls: bool = False) -> Bed3D:
    """A bed of ``size`` (x, y, z; m) at rest: grains at the density of the mean geostatic
    pressure (1 + 2 K0)/3 ρ0 g depth (the EOS inverted, Jáky's K0 = 1 − sin φ), in an open box of
    no-slip walls as thick as the kernel support (``wall_layers_needed(h_factor)`` layers) rising
    ``rim`` (m) above the grains. With ``smooth_y_walls`` the two walls facing ±y are smooth (the
    core's free-slip ghost walls: no shear traction, no tangential viscosity): a slab between them
    deforms in plane strain in x–z."""
    dx = _positive("spacing", spacing)
    counts = [max(1, round(_positive("size", s) / dx)) for s in size]
    if min(counts) < 2:
        raise ConfigError(f"parameter 'size' = {tuple(size)} is invalid: allowed at least 2 spacings ({2 * dx:g} m) "
                          "along each axis")
    axes = [(np.arange(n) + 0.5) * dx for n in counts]
    x = np.array(np.meshgrid(*axes, indexing="ij")).reshape(3, -1).T
    height = counts[2] * dx
    depth = height - x[:, 2]
    k0 = earth_pressure_at_rest(material)
    mean = (1.0 + 2.0 * k0) / 3.0 * material.reference_density * gravity * depth  # −tr σ / 3, geostatic
    stiffness = material.bulk_stiffness * (1.0 + material.water_content)
    rho = material.reference_density * (mean / stiffness + 1.0) ** (1.0 / material.eos_exponent)  # Eq. 2.30 inverted
    granular = {"position": x, "velocity": np.zeros_like(x), "density": rho, "mass": rho * dx**3}
    layers = wall_layers_needed(h_factor)
    top = counts[2] + max(0, round(rim / dx))
    cells = np.meshgrid(np.arange(-layers, counts[0] + layers), np.arange(-layers, counts[1] + layers),
                        np.arange(-layers, top), indexing="ij")
    i, j, k = (axis.ravel() for axis in cells)
    inside = (i >= 0) & (i < counts[0]) & (j >= 0) & (j < counts[1]) & (k >= 0)
    i, j, k = i[~inside], j[~inside], k[~inside]
    position = (np.column_stack([i, j, k]) + 0.5) * dx
    normal = np.zeros_like(position)
    floor = k < 0
    beside_x = ~floor & ((i < 0) | (i >= counts[0]))
    beside_y = ~floor & ~beside_x
    normal[floor, 2] = 1.0
    normal[beside_x, 0] = np.where(i[beside_x] < 0, 1.0, -1.0)
    normal[beside_y, 1] = np.where(j[beside_y] < 0, 1.0, -1.0)
    group = np.where(floor, BED_WALLS["floor"], BED_WALLS["sides"]).astype(np.int32)
    walls = {"position": position, "normal": normal,
             "mass": np.full(len(position), material.reference_density * dx**3),
             "no_slip": np.where(beside_y & smooth_y_walls, 0, 1).astype(np.uint8), "group": group}
    return Bed3D(granular, walls, (counts[0] * dx, counts[1] * dx, height), depth)


def geostatic_deviatoric_stress(depth: np.ndarray, material: Material, gravity: float = GRAVITY) -> np.ndarray:
    """Deviatoric stress s (N, 3, 3) of the geostatic state σ_zz = −ρ0 g depth, σ_xx = σ_yy = K0 σ_zz
    for the hypoelastic μ(I), whose σ = −P I + s with the EOS pressure P = (1 + 2K0)/3 ρ0 g depth:
    s_xx = s_yy = (1 − K0)/3 ρ0 g depth, s_zz = −2 (1 − K0)/3 ρ0 g depth."""
    third = (1.0 - earth_pressure_at_rest(material)) / 3.0 * material.reference_density * gravity
    s = np.zeros((len(depth), 3, 3))
    s[:, 0, 0] = s[:, 1, 1] = third * np.clip(depth, 0.0, None)
    s[:, 2, 2] = -2.0 * s[:, 0, 0]
    return s


def bed_simulation(bed: Bed3D, material: Material, numerics: Numerics, lower: np.ndarray, upper: np.ndarray,
                   extra_walls: dict[str, np.ndarray] | None = None,
                   gravity: float = GRAVITY) -> _core.Simulation3D:
    """The core simulation of ``bed`` (with ``extra_walls`` appended: a body's particles), started
    geostatic: the hypoelastic μ(I) takes the deviatoric stress of Jáky's K0 state, and δ-SPH's
    hydrostatic density correction the share (1 + 2K0)/3 of the weight that its mean stress carries
    (numerics.density_diffusion_pressure_share, unless set), as the planar Simulation does with ½(1 + K0)."""
    walls = bed.walls if extra_walls is None else {k: np.concatenate([bed.walls[k], extra_walls[k]]) for k in bed.walls}
    if material.model == "mu_i_hypoelastic" and numerics.density_diffusion_pressure_share == 0.0:
        share = (1.0 + 2.0 * earth_pressure_at_rest(material)) / 3.0
        numerics = dataclasses.replace(numerics, density_diffusion_pressure_share=share)
    sim = _core.Simulation3D(core_params(material, numerics, lower, upper, gravity), bed.granular, walls)
    if material.model == "mu_i_hypoelastic":
        sim.set_field("deviatoric_stress", geostatic_deviatoric_stress(bed.depth, material, gravity))
        sim.refresh()
    return sim


def quaternion_matrix(orientation: tuple[float, float, float, float] | np.ndarray) -> np.ndarray:
    """The rotation matrix (3, 3) of a unit quaternion (w, x, y, z): body-frame to world vectors."""
    w, x, y, z = np.asarray(orientation, float) / np.linalg.norm(orientation)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def turn_about_y(angle: float) -> tuple[float, float, float, float]:
    """The unit quaternion (w, x, y, z) of a right-handed turn by ``angle`` (rad) about +y: in the
    x–z plane the planar core's clockwise angle (docs/sph3d.md, conventions)."""
    return (math.cos(0.5 * angle), 0.0, math.sin(0.5 * angle), 0.0)


def body_walls(shape: BodyShape3D, reference: np.ndarray, group: int, material: Material,
               orientation: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)) -> dict[str, np.ndarray]:
    """The wall-set arrays of a body of ``shape`` turned by ``orientation`` (unit quaternion w, x,
    y, z) and placed with its reference point at ``reference``, wall group ``group``, no-slip."""
    n = len(shape.position)
    turn = quaternion_matrix(orientation)
    return {"position": shape.position @ turn.T + np.asarray(reference, float), "normal": shape.normal @ turn.T,
            "mass": np.full(n, material.reference_density * shape.spacing**3),
            "no_slip": np.ones(n, np.uint8), "group": np.full(n, group, np.int32)}
