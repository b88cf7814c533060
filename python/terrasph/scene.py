"""Scene building: granular particles, wall groups and the domain, turned into a core simulation."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from terrasph.config import ConfigError, Material, Numerics
from terrasph.geometry import lattice_block, polyline_wall

__all__ = ["Scene", "WallGroup", "hydrostatic_density"]

GRAVITY = 9.81


@dataclass
class WallGroup:
    """A named set of wall particles with one slip condition, removable at `remove_at` (s)."""

    name: str
    group_id: int
    position: np.ndarray
    normal: np.ndarray
    no_slip: bool = True
    remove_at: float | None = None


def hydrostatic_density(depth: np.ndarray, material: Material, gravity: float = GRAVITY) -> np.ndarray:
    """ρ(depth) from the inverse EOS of the lithostatic pressure ρ0·g·depth (Eq. 2.30 inverted).

    Starting a bed at this density avoids the initial compression wave of a bed released at ρ0.
    """
    pressure = material.reference_density * gravity * np.clip(depth, 0.0, None)
    stiffness = material.bulk_stiffness * (1.0 + material.water_content)
    return material.reference_density * (pressure / stiffness + 1.0) ** (1.0 / material.eos_exponent)


@dataclass
class Scene:
    """Geometry of a run: granular particles on a lattice of spacing Δx and wall groups.

    The domain box bounds where granular particles may go; a particle leaving it stops the run
    (a leak through a wall or an escape). Gravity is (0, −g): z is up.
    """

    spacing: float
    granular: list[np.ndarray] = field(default_factory=list)
    walls: list[WallGroup] = field(default_factory=list)
    domain_lower: tuple[float, float] | None = None
    domain_upper: tuple[float, float] | None = None
    gravity: float = GRAVITY

    def __post_init__(self) -> None:
        if not (self.spacing > 0 and np.isfinite(self.spacing)):
            raise ConfigError(f"parameter 'spacing' = {self.spacing!r} is invalid: allowed a finite number > 0")

    # -- building -------------------------------------------------------------------------
    def add_block(self, x0: float, z0: float, width: float, height: float) -> np.ndarray:
        """Adds a lattice block of granular particles; returns its positions."""
        block = lattice_block(x0, z0, width, height, self.spacing)
        self.granular.append(block)
        return block

    def add_wall(self, name: str, vertices: np.ndarray | list[tuple[float, float]], *, layers: int,
                 no_slip: bool = True, remove_at: float | None = None) -> WallGroup:
        """Adds wall layers behind a polyline (granular side on the left of travel)."""
        if any(w.name == name for w in self.walls):
            raise ConfigError(f"wall name '{name}' is used twice")
        if remove_at is not None and remove_at < 0:
            raise ConfigError(f"parameter 'remove_at' of wall '{name}' = {remove_at} is invalid: allowed >= 0")
        position, normal = polyline_wall(vertices, self.spacing, layers)
        group = WallGroup(name, len(self.walls), position, normal, no_slip, remove_at)
        self.walls.append(group)
        return group

    # -- views ----------------------------------------------------------------------------
    @property
    def granular_position(self) -> np.ndarray:
        """All granular particle positions, (N, 2)."""
        return np.concatenate(self.granular) if self.granular else np.zeros((0, 2))

    @property
    def wall_position(self) -> np.ndarray:
        """All wall particle positions, (M, 2)."""
        return np.concatenate([w.position for w in self.walls]) if self.walls else np.zeros((0, 2))

    @property
    def wall_normal(self) -> np.ndarray:
        """Unit normals of all wall particles, pointing into the granular side, (M, 2)."""
        return np.concatenate([w.normal for w in self.walls]) if self.walls else np.zeros((0, 2))

    def domain(self, margin: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Domain box: as set, else the bounding box of all particles padded by `margin` (default 4Δx)."""
        pad = 4 * self.spacing if margin is None else margin
        points = np.concatenate([self.granular_position, self.wall_position])
        if len(points) == 0:
            raise ConfigError("the scene has no particles")
        lower = points.min(axis=0) - pad if self.domain_lower is None else np.asarray(self.domain_lower, float)
        upper = points.max(axis=0) + pad if self.domain_upper is None else np.asarray(self.domain_upper, float)
        return lower, upper

    def validate(self, numerics: Numerics) -> None:
        """Checks the scene against the numerics before any work starts."""
        if abs(numerics.spacing - self.spacing) > 1e-12 * self.spacing:
            raise ConfigError(f"parameter 'numerics.spacing' = {numerics.spacing} differs from the scene's "
                              f"spacing {self.spacing}; they must be equal")
        x = self.granular_position
        if len(x) == 0:
            raise ConfigError("the scene has no granular particles; add a block")
        lower, upper = self.domain()
        outside = np.flatnonzero(((x < lower) | (x > upper)).any(axis=1))
        if len(outside):
            raise ConfigError(f"granular particle {outside[0]} at {x[outside[0]].tolist()} lies outside the "
                              f"domain box {lower.tolist()}–{upper.tolist()} (parameter 'domain')")
        walls = self.wall_position
        if len(walls):
            # a granular particle inside a wall would be pushed through it at the first step
            from terrasph._core import neighbour_lists

            both = np.concatenate([x, walls])
            offsets, indices = neighbour_lists(both, 0.5 * self.spacing)
            n = len(x)
            rows = np.repeat(np.arange(len(both)), np.diff(offsets))
            clashes = rows[(rows < n) & (indices >= n)]
            if len(clashes):
                i = int(clashes.min())
                raise ConfigError(f"granular particle {i} at {x[i].tolist()} overlaps a wall particle "
                                  "(closer than Δx/2); move the block or the wall")
