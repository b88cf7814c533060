"""Small 3D scenes built straight on the core (``_core.Simulation3D``) for the 3D tests: a lattice
bed started at the lithostatic density in an open box of wall particles, and a box-shaped body."""

from __future__ import annotations

import numpy as np
from terrasph import _core

G = 9.81
FLOOR, SIDES, BODY = 0, 1, 2  # wall groups


def params(spacing: float, gravity: float = G) -> _core.ModelParams3D:
    """Default material and numerics at ``spacing``, a large domain, gravity along −z."""
    p = _core.ModelParams3D()
    p.numerics.spacing = spacing
    p.domain.lower = np.full(3, -0.5)
    p.domain.upper = np.full(3, 0.5)
    p.domain.gravity = np.array([0.0, 0.0, -gravity])
    return p


def lattice(counts: tuple[int, int, int], spacing: float) -> np.ndarray:
    """Cell centres of a counts[0] × counts[1] × counts[2] block of cubes of side ``spacing`` at the origin."""
    axes = [(np.arange(n) + 0.5) * spacing for n in counts]
    return np.array(np.meshgrid(*axes, indexing="ij")).reshape(3, -1).T


def box_walls(counts: tuple[int, int, int], spacing: float, layers: int = 3,
              rim: int = 2) -> dict[str, np.ndarray]:
    """An open-topped box of wall particles around a lattice block: the floor (group FLOOR) and
    the four sides (group SIDES) ``layers`` thick, rising ``rim`` cells above the block, inward
    normals, no-slip."""
    nx, ny, nz = counts
    position, normal, group = [], [], []
    for i in range(-layers, nx + layers):
        for j in range(-layers, ny + layers):
            for k in range(-layers, nz + rim):
                if 0 <= i < nx and 0 <= j < ny and k >= 0:
                    continue
                inward = np.zeros(3)
                if k < 0:
                    inward[2] = 1.0
                elif i < 0 or i >= nx:
                    inward[0] = 1.0 if i < 0 else -1.0
                else:
                    inward[1] = 1.0 if j < 0 else -1.0
                position.append((np.array([i, j, k]) + 0.5) * spacing)
                normal.append(inward)
                group.append(FLOOR if k < 0 else SIDES)
    return walls_dict(np.array(position), np.array(normal), np.array(group, np.int32), spacing)


def walls_dict(position: np.ndarray, normal: np.ndarray, group: np.ndarray, spacing: float,
               density: float = 1500.0) -> dict[str, np.ndarray]:
    """The core's wall-set arrays for particles at ``position`` with ``normal`` and ``group``."""
    return {"position": position, "normal": normal, "mass": np.full(len(position), density * spacing**3),
            "no_slip": np.ones(len(position), np.uint8), "group": group}


def box_body(centre: np.ndarray, cells: tuple[int, int, int], spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """Particles of a solid box of cells[0] × cells[1] × cells[2] cubes centred at ``centre``, each
    with the outward normal of its nearest face."""
    half = np.array(cells) * spacing / 2.0
    local = lattice(cells, spacing) - half
    depth = (half - np.abs(local)) / half  # relative distance to the two faces of each axis
    axis = np.argmin(depth, axis=1)
    normal = np.zeros_like(local)
    normal[np.arange(len(local)), axis] = np.sign(local[np.arange(len(local)), axis])
    return centre + local, normal


def lithostatic_bed(p: _core.ModelParams3D, counts: tuple[int, int, int], spacing: float) -> dict[str, np.ndarray]:
    """Grains on the lattice at rest with the lithostatic density ρ0 (1 + ρ0 g depth / κ)^(1/γ)
    (the equation of state inverted), so the bed starts in equilibrium under its weight."""
    x = lattice(counts, spacing)
    rho0, gravity = p.material.reference_density, -p.domain.gravity[2]
    depth = counts[2] * spacing - x[:, 2]
    rho = rho0 * (rho0 * gravity * depth / p.material.bulk_stiffness + 1.0) ** (1.0 / p.material.eos_exponent)
    return {"position": x, "velocity": np.zeros_like(x), "density": rho, "mass": rho * spacing**3}


def with_body(walls: dict[str, np.ndarray], position: np.ndarray, normal: np.ndarray,
              spacing: float) -> dict[str, np.ndarray]:
    """The wall set with a body's particles appended as group BODY."""
    body = walls_dict(position, normal, np.full(len(position), BODY, np.int32), spacing)
    return {key: np.concatenate([walls[key], body[key]]) for key in walls}


def rotation_matrix(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues' formula: the right-handed rotation by ``angle`` about the unit vector ``axis``."""
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + np.sin(angle) * k + (1.0 - np.cos(angle)) * k @ k


def quaternion_matrix(q: np.ndarray) -> np.ndarray:
    """The rotation matrix of the unit quaternion (w, x, y, z)."""
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
