"""A granular bed settling under gravity in a rough box (docs/design.md §3.5).

Setup: Δx = 5 mm, a 0.12 m × 0.05 m bed (240 particles) in a rough (no-slip) box drawn as one
polyline, released at the hydrostatic density (Simulation's default) and run for 0.2 s
(~11 000 steps, ~5 s wall time).

References and tolerances (measured values in brackets)
-------------------------------------------------------
* At rest: mean |v| < 1e-4 m/s [2.7e-5], max |v| < 2e-3 m/s [4.7e-4]; the kinetic energy is
  below 1e-7 of the bed's potential energy scale M g H [3e-9]. √(g H) = 0.7 m/s is the velocity
  scale of a collapse of this bed, so these are 4 orders of magnitude below it.
* Vertical stress σ_v = −σ_zz averaged in horizontal layers over the central 70 % of the width
  is linear in depth: a line fit has R² > 0.999 [0.99993], slope ρ g within 5 % [+2.1 %] with ρ the
  mean particle density, intercept below ρ g Δx (one layer's weight) [2.6 Pa vs 123 Pa].
  A 3–5 % agreement is what wall friction and the discrete free surface allow.
* No particle leaves the box: every x within (0, W) and z within (0, top) — the wall lines.
"""

from __future__ import annotations

import numpy as np
import pytest
from terrasph import analysis
from terrasph.config import Material, Numerics
from terrasph.geometry import wall_layers_needed
from terrasph.scene import Scene
from terrasph.simulation import Simulation

DX = 0.005
WIDTH = 0.12
HEIGHT = 0.05
T_END = 0.2
G = 9.81


@pytest.fixture(scope="module")
def settled() -> tuple[Simulation, float]:
    numerics = Numerics(spacing=DX)
    scene = Scene(spacing=DX)
    scene.add_block(0.0, 0.0, WIDTH, HEIGHT)
    top = HEIGHT + 6 * DX
    # one polyline: a box built from separate walls would leave gaps at the corners
    scene.add_wall("box", [(0.0, top), (0.0, 0.0), (WIDTH, 0.0), (WIDTH, top)],
                   layers=wall_layers_needed(numerics.h_factor), no_slip=True)
    assert scene.gravity == G
    sim = Simulation(scene, Material(), numerics)
    sim.advance(T_END)
    return sim, top


def test_bed_comes_to_rest(settled) -> None:
    sim, _ = settled
    assert sim.time == pytest.approx(T_END)
    speed = np.hypot(*sim.velocity.T)
    assert speed.mean() < 1e-4
    assert speed.max() < 2e-3
    potential_scale = float(sim.mass.sum()) * G * HEIGHT  # per metre of depth, like kinetic_energy()
    assert sim.kinetic_energy() < 1e-7 * potential_scale


def test_vertical_stress_is_lithostatic(settled) -> None:
    sim, _ = settled
    x = np.array(sim.position)
    z, sigma_v = analysis.vertical_stress_profile(x, np.array(sim.stress), DX, (0.15 * WIDTH, 0.85 * WIDTH))
    assert len(z) >= 8
    surface = x[:, 1].max() + 0.5 * DX
    depth = surface - z
    slope, intercept, r_squared = analysis.fit_line(depth, sigma_v)
    rho = float(np.mean(sim.density))
    assert r_squared > 0.999
    assert slope == pytest.approx(rho * G, rel=0.05)
    assert abs(intercept) < rho * G * DX
    # the deepest layer carries the bed's weight, again within 5 %
    assert sigma_v[np.argmax(depth)] == pytest.approx(rho * G * depth.max(), rel=0.05)


def test_no_particle_leaves_the_box(settled) -> None:
    sim, top = settled
    x = sim.position
    assert np.all(np.isfinite(x))
    assert np.all((x[:, 0] > 0.0) & (x[:, 0] < WIDTH))
    assert np.all((x[:, 1] > 0.0) & (x[:, 1] < top))
    # and the bed has not collapsed into the floor: its surface moved by less than a spacing
    assert x[:, 1].max() + 0.5 * DX == pytest.approx(HEIGHT, abs=DX)
