"""Cell-ordered storage (numerics.cell_order): at each neighbour build the core gathers
both particle sets into the order of the cells, and nothing a user reads changes.

References: the same run without reordering. The storage order changes the neighbour-list order
and so the summation order of every pair sum, hence "equal" is to round-off: 1e-9 relative after
60 steps of the flowing coarse column collapse (as for test_ids' permuted run; measured ~1e-13).
Errors and leak reports name the same ids. With reordering on, runs stay bitwise identical for
1, 2 and 3 threads and across a checkpoint and restore (np.array_equal, no tolerance).
"""

from __future__ import annotations

import numpy as np
import pytest
import terrasph
from terrasph import _core
from terrasph.checkpoint import read_checkpoint
from terrasph.scenes.column_collapse import ColumnCollapse, build_column_collapse
from terrasph.simulation import Simulation


def collapse(cell_order: bool) -> Simulation:
    scene, material, numerics = build_column_collapse(
        ColumnCollapse(resolution="coarse", numerics={"cell_order": cell_order}))
    return Simulation(scene, material, numerics)


def storage_ids(sim: Simulation, part: str = "granular") -> np.ndarray:
    return np.asarray(sim.core.state()[part]["id"])


def test_storage_is_reordered_but_accessors_follow_the_plain_run() -> None:
    plain, ordered = collapse(False), collapse(True)
    for sim in (plain, ordered):
        sim.advance(1.0, max_steps=60)
    # the reordering happened: rows are no longer in id order, and every id is there once
    assert not np.array_equal(storage_ids(ordered), np.sort(storage_ids(ordered)))
    assert np.array_equal(np.sort(storage_ids(ordered)), storage_ids(plain))
    assert not np.array_equal(storage_ids(ordered, "walls"), np.sort(storage_ids(ordered, "walls")))
    assert ordered.core.neighbour_builds >= 2
    for name in ("position", "velocity", "density", "pressure", "stress"):
        a, b = np.asarray(getattr(plain, name)), np.asarray(getattr(ordered, name))
        assert np.abs(a - b).max() <= 1e-9 * max(np.abs(a).max(), 1e-3), name
    assert np.array_equal(plain.core.wall_id, ordered.core.wall_id)
    assert np.array_equal(plain.core.wall_position, ordered.core.wall_position)
    assert plain.time == pytest.approx(ordered.time, rel=1e-12)
    assert np.abs(plain.velocity).max() > 0.05  # the column is flowing


def test_errors_and_leak_reports_name_the_same_ids() -> None:
    sim = collapse(True)
    sim.advance(1.0, max_steps=20)
    velocity = sim.velocity.copy()
    velocity[123, 1] = np.nan  # particle id 123, wherever the cells put it
    sim.velocity = velocity
    with pytest.raises(terrasph.InstabilityError) as caught:
        sim.advance(1.0, max_steps=5)
    assert caught.value.particle == 123

    leaky = collapse(True)
    position = leaky.position.copy()
    floor = np.asarray(leaky.core.wall_position)[np.asarray(leaky.core.wall_interior).astype(bool)]
    position[42] = floor[np.argmin(floor[:, 1])] + [0.0, 0.1 * leaky.scene.spacing]
    leaky.position = position
    leaky.refresh()
    assert leaky.core.leaked_ids == [42]


def run_state(threads: int, steps: int) -> dict:
    _core.set_num_threads(threads)
    sim = collapse(True)
    sim.advance(1.0, max_steps=steps)
    return sim.core.state()


def assert_states_equal(a: dict, b: dict) -> None:
    for part in ("granular", "walls"):
        for name in a[part]:
            assert np.array_equal(a[part][name], b[part][name]), f"{part} field {name} differs"
    assert a["counters"]["step"] == b["counters"]["step"] and a["counters"]["time"] == b["counters"]["time"]


def test_bitwise_identical_with_one_two_and_three_threads(restore_threads) -> None:
    one = run_state(1, 200)
    for threads in (2, 3):
        assert_states_equal(one, run_state(threads, 200))


def test_restart_with_cell_order_is_bitwise_identical(tmp_path) -> None:
    straight = collapse(True)
    straight.advance(1.0, max_steps=80)
    first_half = collapse(True)
    first_half.advance(1.0, max_steps=40)
    path = first_half.checkpoint(tmp_path / "half.h5")
    resumed = collapse(True)
    resumed.restore(path)
    resumed.advance(1.0, max_steps=40)
    assert_states_equal(straight.core.state(), resumed.core.state())
    saved, _, _ = read_checkpoint(path)
    assert not np.array_equal(saved["granular"]["id"], np.sort(saved["granular"]["id"]))  # saved in cell order
