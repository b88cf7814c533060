"""Wall sampling along polylines (docs/design.md §3.5): layers on the wall side only, corners filled."""

import numpy as np
import pytest
from terrasph.geometry import polyline_wall, wall_layers_needed


@pytest.mark.parametrize("closed_right", [False, True])
def test_container_walls_stay_outside_and_fill_the_outer_corners(closed_right: bool) -> None:
    dx, width, height = 0.002, 0.1, 0.05
    vertices = [(0.0, height), (0.0, 0.0), (width, 0.0)] + ([(width, height)] if closed_right else [])
    layers = wall_layers_needed(1.3)
    points, normals = polyline_wall(np.array(vertices), dx, layers)
    right = width if closed_right else np.inf
    inside = (points[:, 0] > 0) & (points[:, 1] > 0) & (points[:, 0] < right)
    assert not inside.any(), f"wall particles on the granular side: {points[inside][:3]}"
    # the outer (bottom-left) corner within the layers' depth is covered (a round join): every point
    # of the quarter disc there is within Δx of a wall particle, so a grain at the corner has a full
    # kernel support
    grid = np.stack(np.meshgrid(np.linspace(-layers * dx, 0, 9), np.linspace(-layers * dx, 0, 9)), -1).reshape(-1, 2)
    grid = grid[np.linalg.norm(grid, axis=1) <= layers * dx]
    nearest = np.min(np.linalg.norm(grid[:, None, :] - points[None, :, :], axis=2), axis=1)
    assert nearest.max() < dx
    assert np.allclose(np.linalg.norm(normals, axis=1), 1.0)
