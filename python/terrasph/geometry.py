"""Particle geometry: granular blocks on a lattice and wall-particle layers along polylines.

Walls are fixed ghost (dummy) particles in ``layers`` rows behind the wall line, enough to fill
the kernel support 2h (docs/design.md §3.5). A polyline's granular side is on the *left* of its direction
of travel; wall layers go on the right.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

__all__ = ["MIN_PARTICLES_ACROSS", "aligned_wall_layers", "convex_hull", "elliptical_arc", "lattice_block", "polyline_wall",
           "trough_height", "wall_layers_needed"]


#: Fewest lattice particles across a granular block's width and height (lattice_block).
MIN_PARTICLES_ACROSS = 2


def wall_layers_needed(h_factor: float) -> int:
    """Layers of spacing Δx that fill the kernel support 2h = 2·h_factor·Δx behind a wall."""
    if not 1.0 <= h_factor <= 2.0:
        raise ValueError(f"h_factor = {h_factor} outside the allowed range [1.0, 2.0]")
    return int(math.ceil(2.0 * h_factor))


def lattice_block(x0: float, z0: float, width: float, height: float, spacing: float) -> np.ndarray:
    """Particles at cell centres of a square lattice filling [x0, x0+width] × [z0, z0+height].

    The number of columns and rows is the nearest integer to width/Δx and height/Δx, so the block's
    extent may differ from the request by up to Δx/2 on each axis. A block less than
    MIN_PARTICLES_ACROSS spacings wide or tall is refused: the lattice cannot resolve it (a single
    row would stick out of the requested rectangle by up to Δx/2 on both sides).
    """
    if spacing <= 0:
        raise ValueError(f"spacing = {spacing} must be > 0")
    if width <= 0 or height <= 0:
        raise ValueError(f"block width and height must be > 0, got {width}, {height}")
    nx = round(width / spacing)
    nz = round(height / spacing)
    if min(nx, nz) < MIN_PARTICLES_ACROSS:
        raise ValueError(f"spacing = {spacing:g} m cannot resolve a {width:g} × {height:g} m block: allowed "
                         f"spacing <= {min(width, height) / MIN_PARTICLES_ACROSS:g} m "
                         f"(at least {MIN_PARTICLES_ACROSS} particles across each side)")
    xs = x0 + (np.arange(nx) + 0.5) * spacing
    zs = z0 + (np.arange(nz) + 0.5) * spacing
    grid_x, grid_z = np.meshgrid(xs, zs)  # row-major: z rows, x fastest
    return np.column_stack([grid_x.ravel(), grid_z.ravel()])


def _resample(path: np.ndarray, spacing: float) -> np.ndarray:
    """Points every Δx along a polyline, centred in each Δx interval of arc length."""
    seg = np.diff(path, axis=0)
    lengths = np.hypot(seg[:, 0], seg[:, 1])
    total = float(lengths.sum())
    n = max(1, round(total / spacing))
    s = (np.arange(n) + 0.5) * total / n
    cumulative = np.concatenate([[0.0], np.cumsum(lengths)])
    x = np.interp(s, cumulative, path[:, 0])
    z = np.interp(s, cumulative, path[:, 1])
    return np.column_stack([x, z])


def _offset_path(vertices: np.ndarray, distance: float) -> np.ndarray:
    """The polyline shifted by `distance` to its right, with round joins at outer corners."""
    points: list[np.ndarray] = []
    directions = np.diff(vertices, axis=0)
    directions /= np.hypot(directions[:, 0], directions[:, 1])[:, None]
    right = np.column_stack([directions[:, 1], -directions[:, 0]])
    for k in range(len(directions)):
        if k > 0:
            turn = directions[k - 1, 0] * directions[k, 1] - directions[k - 1, 1] * directions[k, 0]
            if turn > 1e-12:  # left turn: the right (wall) side opens up; fill it with an arc
                # the right normal turns counter-clockwise with the direction, from a0 up to a1
                a0 = math.atan2(right[k - 1, 1], right[k - 1, 0])
                a1 = math.atan2(right[k, 1], right[k, 0])
                while a1 < a0:
                    a1 += 2 * math.pi
                for angle in np.linspace(a0, a1, 9)[1:-1]:
                    points.append(vertices[k] + distance * np.array([math.cos(angle), math.sin(angle)]))
        points.append(vertices[k] + distance * right[k])
        points.append(vertices[k + 1] + distance * right[k])
    return np.array(points)


def _nearest_on_polyline(points: np.ndarray, vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance from each point to a polyline and the nearest point on it."""
    best = np.full(len(points), np.inf)
    nearest_best = np.zeros_like(points)
    for a, b in itertools.pairwise(vertices):
        ab = b - a
        t = np.clip(((points - a) @ ab) / float(ab @ ab), 0.0, 1.0)
        nearest = a + t[:, None] * ab
        distance = np.hypot(*(points - nearest).T)
        closer = distance < best
        best[closer] = distance[closer]
        nearest_best[closer] = nearest[closer]
    return best, nearest_best


def polyline_wall(vertices: np.ndarray | list[tuple[float, float]], spacing: float,
                  layers: int) -> tuple[np.ndarray, np.ndarray]:
    """Wall particles in `layers` rows at depths (k + ½)Δx behind a polyline (on its right side),
    and their unit normals pointing to the wall line (into the granular side).

    Rows are resampled every Δx along the offset line, so curved beds get smooth walls; where offset
    rows of neighbouring segments overlap (inner corners), particles closer than ½Δx are merged.
    """
    v = np.asarray(vertices, dtype=float)
    if v.ndim != 2 or v.shape[1] != 2 or len(v) < 2:
        raise ValueError("vertices must be an array of at least two (x, z) points")
    if layers < 1:
        raise ValueError(f"layers = {layers} must be >= 1")
    rows = []
    for k in range(layers):
        depth = (k + 0.5) * spacing
        row = _resample(_offset_path(v, depth), spacing)
        keep = _nearest_on_polyline(row, v)[0] > depth - 0.25 * spacing
        rows.append(row[keep])
    points = _merge_close(np.concatenate(rows), 0.5 * spacing)
    distance, nearest = _nearest_on_polyline(points, v)
    normals = (nearest - points) / distance[:, None]
    return points, normals


def _merge_close(points: np.ndarray, tolerance: float) -> np.ndarray:
    """Drops points closer than `tolerance` to an earlier kept point (grid hashing, O(N))."""
    kept: list[int] = []
    buckets: dict[tuple[int, int], list[int]] = {}
    cell = tolerance
    for index, p in enumerate(points):
        key = (int(math.floor(p[0] / cell)), int(math.floor(p[1] / cell)))
        clash = False
        for dx in (-1, 0, 1):
            for dz in (-1, 0, 1):
                for other in buckets.get((key[0] + dx, key[1] + dz), ()):
                    if np.hypot(*(points[other] - p)) < tolerance:
                        clash = True
                        break
        if not clash:
            kept.append(index)
            buckets.setdefault(key, []).append(index)
    return points[kept]


# -- curved beds (Fig. 2.6–2.8) ---------------------------------------------------------------------
def _check_semi_axes(semi_axes: tuple[float, float]) -> tuple[float, float]:
    a, b = (float(v) for v in semi_axes)
    if not (a > 0 and b > 0 and math.isfinite(a) and math.isfinite(b)):
        raise ValueError(f"bed_axes = {tuple(semi_axes)!r} is invalid: allowed two finite semi-axes > 0 (m)")
    return a, b


def trough_height(x: np.ndarray, semi_axes: tuple[float, float]) -> np.ndarray:
    """Height of an elliptical trough's bed above its lowest point (0, 0):
    z_b(x) = b − b·√(1 − (x/a)²) for |x| ≤ a (the lower half of the ellipse centred at (0, b))."""
    a, b = _check_semi_axes(semi_axes)
    ratio = np.clip(np.asarray(x, float) / a, -1.0, 1.0)
    return b - b * np.sqrt(1.0 - ratio**2)


def elliptical_arc(semi_axes: tuple[float, float], angles: tuple[float, float],
                   spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """Points every Δx of arc length along an elliptical trough and their unit normals into it.

    The ellipse is centred at (0, b) with semi-axes a (x) and b (z); a point at angle θ is
    (a sin θ, b − b cos θ), θ = 0 the lowest point, θ from angles[0] to angles[1] (rad, within
    [−π/2, π/2]). Points sit at the centres of n equal arc-length intervals, n = round(length/Δx);
    the normal is −∇((x/a)² + ((z − b)/b)²) normalised: it points into the trough. A circle is
    the case a = b.
    """
    a, b = _check_semi_axes(semi_axes)
    theta0, theta1 = (float(v) for v in angles)
    if not -0.5 * math.pi <= theta0 < theta1 <= 0.5 * math.pi:
        raise ValueError(f"angles = {angles!r} is invalid: allowed -pi/2 <= start < end <= pi/2")
    dense = np.linspace(theta0, theta1, 20001)
    x, z = a * np.sin(dense), b - b * np.cos(dense)
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(z)))])
    n = max(1, round(arc[-1] / spacing))
    theta = np.interp((np.arange(n) + 0.5) * arc[-1] / n, arc, dense)
    points = np.column_stack([a * np.sin(theta), b - b * np.cos(theta)])
    inward = np.column_stack([-points[:, 0] / a**2, -(points[:, 1] - b) / b**2])
    return points, inward / np.hypot(inward[:, 0], inward[:, 1])[:, None]


def aligned_wall_layers(surface: np.ndarray, normals: np.ndarray, spacing: float,
                        layers: int) -> tuple[np.ndarray, np.ndarray]:
    """Wall particles in `layers` rows at depths (k + ½)Δx behind the points `surface`, each row
    offset along the same normals, and those normals (into the granular side).

    The rows line up along the normals (each particle has its outer neighbour exactly Δx away along
    its normal), so the core's leak counter, which calls a wall particle interior when a particle
    of its wall sits at x_w + Δx n_w, marks every row but the surface row on a curve too; rows
    resampled independently (:func:`polyline_wall`) would miss that point by up to Δx/2 there.
    """
    if layers < 1:
        raise ValueError(f"layers = {layers} must be >= 1")
    surface, normals = np.asarray(surface, float), np.asarray(normals, float)
    rows = [surface - (k + 0.5) * spacing * normals for k in range(layers)]
    return np.concatenate(rows), np.tile(normals, (layers, 1))


def convex_hull(points: np.ndarray) -> np.ndarray:
    """The convex hull of `points`, counter-clockwise (Andrew's monotone chain; the points rounded to
    1e-12, collinear ones dropped)."""
    ordered = sorted(set(map(tuple, np.round(points, 12))))

    def half(sequence: list[tuple[float, float]]) -> list[tuple[float, float]]:
        chain: list[tuple[float, float]] = []
        for p in sequence:
            while len(chain) >= 2 and ((chain[-1][0] - chain[-2][0]) * (p[1] - chain[-2][1])
                                       - (chain[-1][1] - chain[-2][1]) * (p[0] - chain[-2][0])) <= 0:
                chain.pop()
            chain.append(p)
        return chain

    lower, upper = half(ordered), half(ordered[::-1])
    return np.array(lower[:-1] + upper[:-1])
