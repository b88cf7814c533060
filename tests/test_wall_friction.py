"""Coulomb friction on walls (numerics.wall_friction_coefficient μ_w).

A single row of ten grains (Δx = 5 mm, no overburden: P ≈ 0, the grains of a column's toe) rests on
a smooth floor and is set sliding at v0 = 0.3 m/s. With μ_w the only tangential force is the
Coulomb friction μ_w N, N = g per unit mass, so the row decelerates at μ_w g and stops after
v0²/(2 μ_w g) = 11.47 mm for μ_w = 0.4 (Amontons–Coulomb; stated tolerance 5 % [measured
11.49 mm, +0.2 %]); it then stays at rest: the regularised law drives no grain at rest (mean
|v_x| ≤ 1e-4 m/s over the next 0.2 s [0], no grain moving more than Δx/50 [0.03 mm: the end grains
of the row spread a little]). While it slides, the floor carries the reaction,
F_x = μ_w g Σm (tracked wall loads, Eq. 3.24, within 2 %). Without friction the smooth floor
transmits no shear and the row keeps ≥ 99 % of its speed. Bad values are refused by name.
"""

from __future__ import annotations

import numpy as np
import pytest
from terrasph.config import ConfigError, Material, Numerics
from terrasph.geometry import wall_layers_needed
from terrasph.scene import GRAVITY, Scene
from terrasph.simulation import Simulation

DX = 0.005
V0 = 0.3


def sliding_row(mu_w: float) -> Simulation:
    """Ten grains in one row on a smooth floor, settled for 0.02 s, then set sliding at V0."""
    scene = Scene(spacing=DX)
    scene.granular.append(np.array([[0.02 + (i + 0.5) * DX, 0.5 * DX] for i in range(10)]))
    scene.add_wall("floor", [(-0.05, 0.0), (0.5, 0.0)], layers=wall_layers_needed(1.3), no_slip=False)
    scene.domain_lower, scene.domain_upper = (-0.06, -0.05), (0.51, 0.1)
    sim = Simulation(scene, Material(), Numerics(spacing=DX, wall_friction_coefficient=mu_w))
    sim.advance(0.02)
    sim.velocity = sim.velocity + [V0, 0.0]
    sim.refresh()
    return sim


def test_a_sliding_row_stops_within_the_coulomb_distance() -> None:
    mu_w = 0.4
    sim = sliding_row(mu_w)
    sim.track_wall_loads()
    start, t0 = sim.position[:, 0].mean(), sim.time
    sim.reset_wall_load_means()
    sim.advance(t0 + 0.02)  # still sliding (it stops after v0/(μ_w g) = 0.076 s)
    reaction = sim.wall_loads()["floor"]["force"][0]
    assert reaction == pytest.approx(mu_w * GRAVITY * sim.mass.sum(), rel=0.02)
    sim.advance(t0 + 0.2)
    distance = sim.position[:, 0].mean() - start
    assert distance == pytest.approx(V0**2 / (2 * mu_w * GRAVITY), rel=0.05)
    stopped = sim.position[:, 0].copy()
    sim.advance(t0 + 0.4)
    assert np.abs(sim.velocity[:, 0]).mean() <= 1e-4
    assert np.abs(sim.position[:, 0] - stopped).max() <= DX / 50  # [0.03 mm: the end grains spread]
    assert sim.leaked_particles == 0


def test_without_friction_the_smooth_floor_lets_the_row_slide() -> None:
    sim = sliding_row(0.0)
    sim.advance(sim.time + 0.2)
    assert sim.velocity[:, 0].mean() >= 0.99 * V0


@pytest.mark.parametrize("value", [-0.1, float("nan"), float("inf")])
def test_bad_wall_friction_is_refused_by_name(value: float) -> None:
    with pytest.raises(ConfigError, match="wall_friction_coefficient"):
        Numerics(wall_friction_coefficient=value)
