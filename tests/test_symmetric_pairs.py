"""Each granular pair evaluated once (numerics.symmetric_pairs): the two pair passes
add every pair's terms to both grains from a half neighbour list, the grains dealt to threads in
strips of two parities. Each pair's terms are the gather's to the bit (the terms for j are those
for i with x_ij, v_ij and ∇W turned round), so only the order of the sums changes.

References:
* the flowing coarse column collapse (475 grains, 300 steps) with each combination of the optional
  terms the passes sum (δ-SPH, XSPH, the density in the ∇v pass, the kernel gradient correction,
  under which the ∇v pass keeps its gather) is the gather's state within round-off: positions
  within 1e-12 m and velocities within 1e-9 of the largest speed (a reordered sum differs in its
  last bits, ~1e-16 relative, and a flow of a few hundred steps grows that by a few decades, not
  by seven);
* with the active domain on (frozen grains whose pairs with awake grains still count for those),
  a bed with a plate pushed into it (test_active_domain.py's): the same frozen set as the gather's
  before the push, the far part of the bed (frozen) bitwise unchanged through it, every grain
  within the round-off tolerances above of the gather's, no leak;
* determinism at 1, 2 and 3 threads and a restart in a new process are in test_determinism.py and
  test_restart.py.
"""

from __future__ import annotations

import numpy as np
import pytest
from terrasph.scenes.column_collapse import ColumnCollapse, build_column_collapse
from terrasph.simulation import Simulation
from test_active_domain import PUSH_START, PUSH_TIME, bed_with_plate


def collapse_state(numerics: dict, steps: int = 300) -> dict[str, np.ndarray]:
    scene, material, numerics_obj = build_column_collapse(ColumnCollapse(resolution="coarse", numerics=numerics))
    sim = Simulation(scene, material, numerics_obj)
    sim.advance(1.0, max_steps=steps)
    return {name: np.array(getattr(sim, name)) for name in ("position", "velocity", "density")}


@pytest.mark.parametrize("numerics", [
    {},
    {"delta_sph": 0.0, "xsph": 0.0},
    {"symplectic_density": True, "cell_order": True},
    {"kernel_gradient_correction": True},
])
def test_the_sums_are_the_gathers_within_round_off(numerics: dict) -> None:
    gather = collapse_state({**numerics, "symmetric_pairs": False})
    once = collapse_state({**numerics, "symmetric_pairs": True})
    speed = np.abs(gather["velocity"]).max()
    assert speed > 0.05  # the column is flowing
    assert np.abs(once["position"] - gather["position"]).max() < 1e-12
    assert np.abs(once["velocity"] - gather["velocity"]).max() < 1e-9 * speed
    assert not np.array_equal(once["velocity"], gather["velocity"])  # the sums did change order


def test_frozen_grains_stay_as_they_were_and_their_awake_neighbours_as_the_gathers() -> None:
    active = {"freeze_speed": 5e-3, "freeze_steps": 100, "active_radius": 0.1}
    gather = bed_with_plate(**active)
    once = bed_with_plate(**active, symmetric_pairs=True)
    for sim in (gather, once):
        sim.advance(PUSH_START)
    frozen = np.asarray(once.field("frozen")).astype(bool)
    assert np.array_equal(frozen, np.asarray(gather.field("frozen")).astype(bool))
    assert 0.2 < frozen.mean() < 0.9
    far = np.asarray(once.position)[:, 0] > 0.3  # 25 cm from the plate, frozen before it moves
    assert frozen[far].all()
    kept = ("position", "velocity", "density", "acceleration", "density_rate", "stress")  # rates too
    before = {name: np.array(getattr(once.core, name))[far] for name in kept}
    for sim in (gather, once):
        sim.advance(PUSH_START + PUSH_TIME)
    for name, values in before.items():
        assert np.array_equal(np.array(getattr(once.core, name))[far], values), name
    assert np.abs(np.array(once.position) - np.array(gather.position)).max() < 1e-12
    speed = np.abs(np.array(gather.velocity)).max()
    assert np.abs(np.array(once.velocity) - np.array(gather.velocity)).max() < 1e-9 * speed
    assert once.core.leaked_ids == []
