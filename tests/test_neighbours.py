"""Cell-linked-list neighbour search (docs/design.md §3.2) against an O(N²) brute force.

``_core.neighbour_lists(points, radius)`` returns CSR (offsets, indices) of the points strictly
closer than `radius` (|x_i − x_j|² < radius²), self excluded. The brute force below uses the same
strict inequality on the same squared distance, so the sets must be *equal*, including pairs at
exactly the radius (lattice spacings that divide the radius) and points on cell borders.
"""

from __future__ import annotations

import numpy as np
import pytest
from terrasph import _core


def brute_force(points: np.ndarray, radius: float) -> list[np.ndarray]:
    """Sorted neighbour indices of every point, by all-pairs distances."""
    dx = points[:, None, 0] - points[None, :, 0]
    dz = points[:, None, 1] - points[None, :, 1]
    close = dx * dx + dz * dz < radius * radius
    np.fill_diagonal(close, False)
    return [np.flatnonzero(row) for row in close]


def rows(offsets: np.ndarray, indices: np.ndarray) -> list[np.ndarray]:
    """Per-point neighbour rows of a CSR list, each sorted (the list order is by cell, not index)."""
    return [np.sort(indices[offsets[i]:offsets[i + 1]]) for i in range(len(offsets) - 1)]


def assert_equal_to_brute_force(points: np.ndarray, radius: float) -> int:
    offsets, indices = _core.neighbour_lists(points, radius)
    assert offsets.shape == (len(points) + 1,) and offsets[0] == 0 and offsets[-1] == len(indices)
    assert np.all(np.diff(offsets) >= 0)
    found = rows(offsets, indices)
    expected = brute_force(points, radius)
    for i, (a, b) in enumerate(zip(found, expected)):
        assert np.array_equal(a, b), f"point {i}: cell list {a.tolist()} != brute force {b.tolist()}"
    # no duplicates and no self
    for i in range(len(points)):
        row = indices[offsets[i]:offsets[i + 1]]
        assert len(np.unique(row)) == len(row) and i not in row
    return len(indices)


@pytest.mark.parametrize("n, radius", [(500, 0.05), (2000, 0.013), (300, 0.7)])
def test_random_points(rng, n, radius) -> None:
    points = rng.uniform(-0.3, 0.5, (n, 2))
    pairs = assert_equal_to_brute_force(points, radius)
    assert pairs > 0


def test_clustered_points_and_duplicates(rng) -> None:
    """Dense clusters, coincident points (distance 0 < radius) and an isolated far point."""
    centres = rng.uniform(0.0, 1.0, (5, 2))
    points = np.concatenate([c + 0.01 * rng.normal(size=(60, 2)) for c in centres])
    points = np.concatenate([points, points[:10], [[25.0, -30.0]]])
    assert_equal_to_brute_force(points, 0.02)


@pytest.mark.parametrize("radius_in_spacings", [1.0, 2.0, 2.6, 3.0])
def test_lattice_with_pairs_on_cell_borders(radius_in_spacings) -> None:
    """Square lattice with spacing s: for radius = k·s every cell border passes through lattice
    points and many pairs sit exactly at the radius (excluded, strict <)."""
    s = 0.25  # a power of two: lattice coordinates and distances are exact in binary
    xs = np.arange(24) * s
    grid_x, grid_z = np.meshgrid(xs, xs)
    points = np.column_stack([grid_x.ravel(), grid_z.ravel()])
    radius = radius_in_spacings * s
    pairs = assert_equal_to_brute_force(points, radius)
    if radius_in_spacings == 1.0:
        assert pairs == 0  # nearest neighbours sit exactly at the radius
    if radius_in_spacings == 2.0:
        # an interior point sees the lattice offsets k ≠ 0 with |k|² < 4: (±1,0), (0,±1), (±1,±1)
        offsets, _ = _core.neighbour_lists(points, radius)
        counts = np.diff(offsets).reshape(24, 24)
        assert counts[10, 10] == 8


def test_domain_corners_and_edges() -> None:
    """Points at the four corners of the bounding box, on its edges and near them."""
    corners = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    near = np.concatenate([corners + d for d in ([0.05, 0.0], [0.0, 0.05], [-0.05, 0.0], [0.0, -0.05],
                                                   [0.1, 0.1], [-0.1, -0.1])])
    near = near[np.all((near >= 0.0) & (near <= 1.0), axis=1)]
    edges = np.column_stack([np.linspace(0, 1, 11), np.zeros(11)])
    points = np.concatenate([corners, near, edges, edges[:, ::-1], 1.0 - edges])
    points = np.unique(points, axis=0)
    for radius in (0.05, 0.1, 0.1000001, 0.5, 1.0, 2.0):
        assert_equal_to_brute_force(points, radius)


def test_single_point_and_far_apart_points() -> None:
    offsets, indices = _core.neighbour_lists(np.array([[0.3, 0.4]]), 0.1)
    assert offsets.tolist() == [0, 0] and len(indices) == 0
    far = np.array([[0.0, 0.0], [1e3, 0.0], [0.0, -1e3]])
    offsets, indices = _core.neighbour_lists(far, 1.0)
    assert offsets.tolist() == [0, 0, 0, 0]


def test_bad_radius_is_refused() -> None:
    with pytest.raises(ValueError, match="radius"):
        _core.neighbour_lists(np.zeros((3, 2)), 0.0)
    with pytest.raises(ValueError, match="shape"):
        _core.neighbour_lists(np.zeros((3, 3)), 1.0)


def test_list_order_is_deterministic_and_thread_independent(rng, restore_threads) -> None:
    """The same input gives the same CSR arrays (order included) on repeat and with 1 or 2 threads."""
    points = rng.uniform(0.0, 1.0, (3000, 2))
    _core.set_num_threads(1)
    one = _core.neighbour_lists(points, 0.04)
    again = _core.neighbour_lists(points, 0.04)
    _core.set_num_threads(2)
    two = _core.neighbour_lists(points, 0.04)
    for a, b, c in zip(one, again, two):
        assert np.array_equal(a, b) and np.array_equal(a, c)
