"""Scene building: granular particles, wall groups and the domain, turned into a core simulation."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from terrasph.bodies import BodyShape, check_thickness
from terrasph.config import ConfigError, Material, Numerics
from terrasph.geometry import lattice_block, polyline_wall
from terrasph.motion import Motion

__all__ = ["LAUNCH_HEIGHT_FACTOR", "BodyGroup", "Scene", "WallGroup", "earth_pressure_at_rest", "flung_height",
           "geostatic_deviatoric_stress", "hydrostatic_density"]

GRAVITY = 9.81
#: grains struck by a part moving at speed v rise up to about v²/2g above the bed: at ω = 30 rad/s
#: the coarse C-leg of `leg-rotation` (tip speed 2.29 m/s, v²/2g = 0.266 m) threw them 0.255 m above
#: the surface, over its container's side walls; walls this many times that height keep them in
LAUNCH_HEIGHT_FACTOR = 1.5


def flung_height(speed: float, gravity: float = GRAVITY) -> float:
    """How high above the bed (m) grains flung by a part moving at `speed` (m/s) may rise: the
    ballistic height v²/2g times :data:`LAUNCH_HEIGHT_FACTOR`. Container walls at least this high keep
    them in the container, instead of letting them fall outside it and out of the domain box."""
    return LAUNCH_HEIGHT_FACTOR * speed * speed / (2.0 * gravity)


@dataclass
class WallGroup:
    """A named set of wall particles with one slip condition, removable at `remove_at` (s)."""

    name: str
    group_id: int
    position: np.ndarray
    normal: np.ndarray
    no_slip: bool = True
    remove_at: float | None = None


@dataclass
class BodyGroup(WallGroup):
    """A wall group that is a rigid body: its shape placed at `reference` turned clockwise by
    `angle` (rad), following `motion` from t = 0, or, if `driven`, the kinematics set on the
    simulation before each step (a multibody engine's). Loads are reported for the real `width` (m)."""

    shape: BodyShape | None = None
    reference: tuple[float, float] = (0.0, 0.0)
    angle: float = 0.0
    motion: Motion = field(default_factory=Motion)
    width: float = 1.0
    driven: bool = False


def _close_pairs(a: np.ndarray, b: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs (i in a, j in b) closer than `radius`, through the core's neighbour search."""
    from terrasph._core import neighbour_lists

    if len(a) == 0 or len(b) == 0:
        return np.zeros(0, int), np.zeros(0, int)
    both = np.concatenate([a, b])
    offsets, indices = neighbour_lists(both, radius)
    rows = np.repeat(np.arange(len(both)), np.diff(offsets))
    keep = (rows < len(a)) & (indices >= len(a))
    return rows[keep], indices[keep] - len(a)


def hydrostatic_density(depth: np.ndarray, material: Material, gravity: float = GRAVITY,
                        pressure_ratio: float = 1.0) -> np.ndarray:
    """ρ(depth) from the inverse EOS of the pressure pressure_ratio·ρ0·g·depth (Eq. 2.30 inverted);
    pressure_ratio = 1: the lithostatic pressure.

    Starting a bed at this density avoids the initial compression wave of a bed released at ρ0.
    """
    pressure = pressure_ratio * material.reference_density * gravity * np.clip(depth, 0.0, None)
    stiffness = material.bulk_stiffness * (1.0 + material.water_content)
    return material.reference_density * (pressure / stiffness + 1.0) ** (1.0 / material.eos_exponent)


def earth_pressure_at_rest(material: Material) -> float:
    """Jaky's K0 = 1 − sin φ with φ = atan μ1, the ratio σ_xx/σ_zz of a bed at rest."""
    return float(1.0 - np.sin(np.arctan(material.mu1)))


def geostatic_stress(depth: np.ndarray, material: Material, gravity: float = GRAVITY) -> np.ndarray:
    """Geostatic stress (N, 3, 3) for a model that keeps the full stress as state (Drucker–Prager):
    σ_zz = −ρ0 g depth and σ_xx = σ_yy = K0 σ_zz with Jaky's K0 = 1 − sin φ, φ = atan μ1; rows and
    columns x, z, then the out-of-plane y (compression negative)."""
    vertical = -material.reference_density * gravity * np.clip(depth, 0.0, None)
    k0 = earth_pressure_at_rest(material)
    stress = np.zeros((len(depth), 3, 3))
    stress[:, 0, 0] = stress[:, 2, 2] = k0 * vertical
    stress[:, 1, 1] = vertical
    return stress


def geostatic_deviatoric_stress(depth: np.ndarray, material: Material, gravity: float = GRAVITY) -> np.ndarray:
    """In-plane deviatoric stress s (N, 2, 2) of the geostatic state for the hypoelastic μ(I), whose
    σ = −P I + s with the EOS pressure P: σ_zz = −ρ0 g depth and σ_xx = K0 σ_zz give
    P = ½(1 + K0) ρ0 g depth (the 2D mean; start the density at it) and
    s_xx = −s_zz = ½(1 − K0) ρ0 g depth."""
    half_difference = 0.5 * (1.0 - earth_pressure_at_rest(material)) * material.reference_density * gravity
    s = np.zeros((len(depth), 2, 2))
    s[:, 0, 0] = half_difference * np.clip(depth, 0.0, None)
    s[:, 1, 1] = -s[:, 0, 0]
    return s


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
    #: z of the undisturbed free surface, for the sinkage of bodies (docs/design.md §3.8); None: not reported
    surface_level: float | None = None
    #: x of the bed's two ends (its container's inner walls, m), where a robot's run ends; None: no bed
    bed_ends: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        if not (self.spacing > 0 and np.isfinite(self.spacing)):
            raise ConfigError(f"parameter 'spacing' = {self.spacing!r} is invalid: allowed a finite number > 0")

    # -- building -------------------------------------------------------------------------
    def add_block(self, x0: float, z0: float, width: float, height: float) -> np.ndarray:
        """Adds a lattice block of granular particles; returns its positions.

        Raises:
            ConfigError: naming 'spacing' when the lattice cannot resolve the block (fewer than
                geometry.MIN_PARTICLES_ACROSS particles across it).
        """
        try:
            block = lattice_block(x0, z0, width, height, self.spacing)
        except ValueError as error:
            raise ConfigError(f"parameter 'spacing': {error}") from None
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

    def add_wall_particles(self, name: str, position: np.ndarray, normal: np.ndarray, *, no_slip: bool = True,
                           remove_at: float | None = None) -> WallGroup:
        """Adds a wall group from ready-made particles and their unit normals into the granular side
        (e.g. :func:`terrasph.geometry.aligned_wall_layers` along a curved bed)."""
        if any(w.name == name for w in self.walls):
            raise ConfigError(f"wall name '{name}' is used twice")
        position, normal = np.asarray(position, float), np.asarray(normal, float)
        if position.ndim != 2 or position.shape[1] != 2 or normal.shape != position.shape:
            raise ConfigError(f"wall '{name}': position and normal must both be (M, 2) arrays")
        if not np.allclose(np.hypot(normal[:, 0], normal[:, 1]), 1.0, atol=1e-9):
            raise ConfigError(f"wall '{name}': every normal must be a unit vector")
        group = WallGroup(name, len(self.walls), position, normal, no_slip, remove_at)
        self.walls.append(group)
        return group

    def add_bed_in_container(self, width: float, depth: float, freeboard: float, *, layers: int,
                             no_slip: bool = True) -> tuple[float, float]:
        """A `width` × `depth` bed at the origin in a container drawn as one polyline (a box of
        separate walls would leave gaps at its corners) reaching `freeboard` above the bed's
        surface, with the domain box around it and room above for lifted grains. Sets
        `surface_level` and `bed_ends`; returns (surface z, inner width) as realised on the lattice."""
        bed = self.add_block(0.0, 0.0, width, depth)
        surface = float(bed[:, 1].max()) + 0.5 * self.spacing
        right = float(bed[:, 0].max()) + 0.5 * self.spacing
        top = surface + freeboard
        self.add_wall("container", [(0.0, top), (0.0, 0.0), (right, 0.0), (right, top)], layers=layers,
                      no_slip=no_slip)
        self.surface_level = surface
        self.bed_ends = (0.0, right)
        margin = (layers + 2) * self.spacing
        self.domain_lower = (-margin, -margin)
        self.domain_upper = (right + margin, top + 0.1)
        return surface, right

    def add_body(self, name: str, shape: BodyShape, *, reference: tuple[float, float], angle: float = 0.0,
                 motion: Motion | None = None, width: float | None = None, no_slip: bool = True,
                 clear_granular: bool = True, driven: bool = False) -> BodyGroup:
        """Adds a rigid body: `shape` turned clockwise by `angle` (rad) about its reference point,
        placed at `reference` (m), following `motion` (default: held still) or, with `driven`,
        the kinematics given to :meth:`Simulation.set_body_kinematics` before each step. Loads are
        reported in N for `width` (default: the shape's width). With `clear_granular`, granular
        particles closer than Δx to the body are removed so it starts in a hole of its own shape."""
        if any(w.name == name for w in self.walls):
            raise ConfigError(f"wall name '{name}' is used twice")
        if not isinstance(shape, BodyShape):
            raise ConfigError(f"parameter 'shape' of body '{name}' must be a terrasph.bodies.BodyShape")
        if abs(shape.spacing - self.spacing) > 1e-9 * self.spacing:
            raise ConfigError(f"body '{name}' was sampled at spacing {shape.spacing}, the scene uses "
                              f"{self.spacing}; build the shape with the scene's spacing")
        width = shape.width if width is None else width
        if not (isinstance(width, (int, float)) and np.isfinite(width) and width > 0):
            raise ConfigError(f"parameter 'width' of body '{name}' = {width!r} is invalid: allowed > 0 (m)")
        if not np.isfinite(angle) or len(reference) != 2 or not np.all(np.isfinite(reference)):
            raise ConfigError(f"body '{name}': reference must be (x, z) and angle finite")
        if driven and motion is not None:
            raise ConfigError(f"body '{name}' is driven from outside; it cannot also have a 'motion'")
        motion = Motion() if motion is None else motion
        if not isinstance(motion, Motion):
            raise ConfigError(f"parameter 'motion' of body '{name}' must be a terrasph.motion.Motion")
        position, normal = shape.transformed(angle, (float(reference[0]), float(reference[1])))
        group = BodyGroup(name, len(self.walls), position, normal, no_slip, None, shape,
                          (float(reference[0]), float(reference[1])), float(angle), motion, float(width),
                          bool(driven))
        self.walls.append(group)
        if clear_granular:
            self.clear_granular_near(position, self.spacing)
        return group

    def clear_granular_near(self, points: np.ndarray, distance: float) -> int:
        """Removes granular particles closer than `distance` to any of `points`; returns how many."""
        removed = 0
        for k, block in enumerate(self.granular):
            close, _ = _close_pairs(block, np.asarray(points, float), distance)
            if len(close):
                keep = np.ones(len(block), bool)
                keep[close] = False
                removed += int((~keep).sum())
                self.granular[k] = block[keep]
        return removed

    @property
    def bodies(self) -> list[BodyGroup]:
        """The rigid bodies, in the order they were added (the core's body indices)."""
        return [w for w in self.walls if isinstance(w, BodyGroup)]

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
            clashes, _ = _close_pairs(x, walls, 0.5 * self.spacing)
            if len(clashes):
                i = int(clashes.min())
                raise ConfigError(f"granular particle {i} at {x[i].tolist()} overlaps a wall particle "
                                  "(closer than Δx/2); move the block or the wall")
        for body in self.bodies:
            try:
                if body.shape is not None:
                    check_thickness(body.shape, self.spacing, numerics.h_factor)
            except ValueError as error:
                raise ConfigError(f"body '{body.name}': {error}") from None
            # driven bodies are a multibody engine's, which owns their contacts with each other (the
            # links of a robot overlap at their joints); each must still clear the fixed walls
            others = [w.position for w in self.walls
                      if w is not body and not (body.driven and isinstance(w, BodyGroup) and w.driven)]
            if others:
                # the solids overlap when particles of the two are closer than one spacing
                hits, _ = _close_pairs(body.position, np.concatenate(others), 0.99 * self.spacing)
                if len(hits):
                    k = int(hits.min())
                    raise ConfigError(f"body '{body.name}' intersects another wall at start (its particle "
                                      f"{k} at {body.position[k].tolist()}); move it or change its angle")
