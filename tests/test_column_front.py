"""The column's reported runout is the front of its connected deposit (issue: a few detached grains
or a one-bin dip of a thin deposit's top moved it by 0.4 L0 between two water contents whose
deposits differ by 1 %).

Reference, independent of terrasph.analysis: the deposit's grains linked to each other within
1.5 Δx (brute-force distances, breadth-first search from the largest cluster), and its front, the
farthest of them plus Δx/2. For a wet column the deposit is several grains thick to its toe, so the
reported front (where it thins below four grain diameters) must lie within one spacing of it."""

from __future__ import annotations

import numpy as np
import pytest
from terrasph.scenes.column_collapse import ColumnCollapse, run_column_collapse


def _connected_front(position: np.ndarray, spacing: float) -> float:
    """x of the farthest grain of the largest cluster of grains linked within 1.5·spacing, + Δx/2."""
    linked = np.linalg.norm(position[:, None, :] - position[None, :, :], axis=2) < 1.5 * spacing
    unvisited, clusters = set(range(len(position))), []
    while unvisited:
        frontier = [unvisited.pop()]
        cluster = list(frontier)
        while frontier:
            found = [int(j) for i in frontier for j in np.flatnonzero(linked[i]) if int(j) in unvisited]
            unvisited.difference_update(found)
            frontier = list(dict.fromkeys(found))
            cluster += frontier
        clusters.append(cluster)
    main = max(clusters, key=len)
    return float(position[main, 0].max() + 0.5 * spacing)


@pytest.mark.parametrize("water_content", [0.005, 0.02])
def test_the_wet_columns_runout_is_its_connected_deposits_front(water_content: float) -> None:
    result = run_column_collapse(ColumnCollapse(resolution="coarse", water_content=water_content),
                                 output=None, progress=False, plot=False)
    assert result.run.status == "at_rest"
    front = result.initial_length * (1.0 + result.runout_normalised)
    assert front == pytest.approx(_connected_front(result.final_position, result.spacing), abs=result.spacing)
