"""Stable particle ids: everything a user reads is keyed by id, whatever order the core
stores particles in, and nothing handed out can dangle.

The storage order is permuted through the core's debug hook (the way cell-ordered storage will
permute it). References: the accessors, frames' fields, error messages and leak reports before
and after the permutation — equal exactly (np.array_equal) at the moment of the permutation; after
further steps equal to round-off only, because the neighbour lists, and so the summation order,
follow the storage order (bound 1e-9 relative after 30 steps of a settling bed, measured
~1e-13). Arrays handed out are read-only copies, so writing into one raises instead of silently
doing nothing, and a copy taken before a wall removal keeps its values.
"""

from __future__ import annotations

import numpy as np
import pytest
import terrasph
from terrasph.scenes.column_collapse import ColumnCollapse, build_column_collapse
from terrasph.simulation import Simulation


def collapse(**numerics) -> Simulation:
    scene, material, numerics_obj = build_column_collapse(ColumnCollapse(resolution="coarse", numerics=numerics))
    return Simulation(scene, material, numerics_obj)


def every_field(sim: Simulation) -> dict[str, np.ndarray]:
    fields = {f"granular/{n}": sim.field(n) for n in sim.core.field_names("granular")}
    fields.update({f"walls/{n}": sim.field(n, "walls") for n in sim.core.field_names("walls")})
    return fields


def permute(sim: Simulation, seed: int) -> None:
    rng = np.random.default_rng(seed)
    sim.core.permute_storage("granular", rng.permutation(len(sim.mass)).tolist())
    sim.core.permute_storage("walls", rng.permutation(len(sim.core.wall_position)).tolist())


def test_ids_are_stable_and_accessors_ignore_the_storage_order() -> None:
    sim = collapse()
    sim.advance(1.0, max_steps=40)
    before = every_field(sim)
    assert np.array_equal(before["granular/id"], np.arange(len(sim.mass)))
    permute(sim, 7)
    after = every_field(sim)
    assert before.keys() == after.keys()
    for name in before:
        assert np.array_equal(before[name], after[name]), name
    assert np.array_equal(sim.core.kernel_sum(), sim.core.kernel_sum())


def test_a_permuted_run_follows_the_unpermuted_one_to_round_off() -> None:
    plain, permuted = collapse(), collapse()
    for sim in (plain, permuted):
        sim.advance(1.0, max_steps=10)
    permute(permuted, 11)
    for sim in (plain, permuted):
        sim.advance(1.0, max_steps=30)
    scale = np.abs(plain.position).max()
    assert np.abs(plain.position - permuted.position).max() <= 1e-9 * scale
    assert np.abs(plain.velocity - permuted.velocity).max() <= 1e-9 * max(np.abs(plain.velocity).max(), 1e-3)
    assert plain.time == pytest.approx(permuted.time, rel=1e-12)


def test_errors_and_leak_reports_name_ids_not_storage_rows() -> None:
    sim = collapse()
    sim.advance(1.0, max_steps=5)
    permute(sim, 3)
    velocity = sim.velocity.copy()
    velocity[123, 1] = np.nan  # particle id 123, wherever it is stored
    sim.velocity = velocity
    with pytest.raises(terrasph.InstabilityError) as caught:
        sim.advance(1.0, max_steps=5)
    assert caught.value.particle == 123
    assert "particle id 123" in str(caught.value)

    leaky = collapse()
    permute(leaky, 5)
    position = leaky.position.copy()
    floor = np.asarray(leaky.core.wall_position)[np.asarray(leaky.core.wall_interior).astype(bool)]
    deep = floor[np.argmin(floor[:, 1])]  # a wall particle two layers below the floor surface
    position[42] = deep + [0.0, 0.1 * leaky.scene.spacing]
    leaky.position = position
    leaky.refresh()
    assert leaky.core.leaked_ids == [42]


def test_handed_out_arrays_are_read_only_copies_that_never_dangle() -> None:
    sim = collapse()
    position = sim.position
    with pytest.raises(ValueError):
        position[0, 0] = 1.0  # a copy: writing into it must not pass for editing the state
    walls = sim.core.wall_position
    groups = sim.core.wall_group
    ids = sim.core.wall_id
    sim.advance(1.0, max_steps=3)  # removes the gate (scheduled at t = 0): the wall storage shrinks
    kept = np.isin(ids, sim.core.wall_id)
    assert kept.sum() == len(sim.core.wall_id) < len(ids)
    assert np.array_equal(walls[kept], sim.core.wall_position)  # fixed walls did not move
    assert np.array_equal(groups[kept], sim.core.wall_group)
    gate = sorted(set(groups.tolist()) - set(sim.core.wall_group.tolist()))
    assert len(gate) == 1  # exactly one group (the gate) went


def test_restored_state_reads_the_same_by_id(tmp_path) -> None:
    sim = collapse()
    sim.advance(1.0, max_steps=20)
    permute(sim, 9)
    path = sim.checkpoint(tmp_path / "c.h5")
    other = collapse()
    other.restore(path)
    expected, got = every_field(sim), every_field(other)
    for name in expected:
        assert np.array_equal(expected[name], got[name]), name


def test_set_field_refuses_a_wrong_shape_by_name() -> None:
    sim = collapse()
    with pytest.raises(ValueError, match="velocity"):
        sim.velocity = np.zeros((3, 2))
    with pytest.raises(IndexError, match="no particle field named 'speed'"):
        sim.field("speed")
