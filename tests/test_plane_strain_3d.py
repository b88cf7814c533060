"""The planar scenes in a 3D slab between smooth side walls (terrasph.scenes.plane_strain_3d,
docs/sph3d.md#the-slab-against-the-planar-scenes).

References: the slab is the planar scene extruded, so each of its rows of grains across y holds
exactly the planar scene's grains (the leg's place cleared as the planar scene clears it), and each
row of the leg's particles the planar leg's particles. Plane strain: with smooth (free-slip) walls
facing ±y a plate pushed into the slab moves every row of grains across the breadth alike: the mean
vertical speed of the grains under the plate in each of the five rows within 25 % of their mean
[19 % measured: the second and fourth rows 20 % faster than the other three, with the contact
barrier's 3D reach Δx (9 % with its 2D reach 0.75Δx, which let grains into the plate)].
With rough walls (no_slip) in their place the rows next to the walls differ by a factor of ten
(measured while writing this test, with a plate ending at the walls: −0.044 against −0.005 m/s).
A rigid plate is impermeable: no grain is ever inside its volume. In 3D a grain between the plate's
layers sits in the middle of a square of four particles, Δx/√2 from each; with the contact
barrier's 2D reach 0.75Δx, grains got there (8 in the plate pushed 3 cm deep below, 21 in the slab
check's 4 cm stroke, whose resistance levelled off as they came in).
"""

from __future__ import annotations

import numpy as np
import pytest
from terrasph.scenes.leg_rotation import LegRotation, build_leg_rotation
from terrasph.scenes.plane_strain_3d import LegSlab, PlateSlab, build_leg_slab, build_plate_slab
from terrasph.scenes.plate_intrusion import PlateIntrusion


def _lattice_set(points: np.ndarray, spacing: float) -> set[tuple[int, ...]]:
    return set(map(tuple, np.round(2 * points / spacing).astype(int)))


def test_the_leg_slab_is_the_planar_leg_scene_extruded() -> None:
    config = LegRotation(omega=0.8, settle_time=0.3, bed_depth=0.08)
    dx = config.grid_spacing
    planar = build_leg_rotation(config)[0]
    slab = build_leg_slab(LegSlab(config))
    grains = np.asarray(slab.core.position)
    rows = np.round(grains[:, 1] / dx - 0.5).astype(int)
    assert rows.max() + 1 == round(config.width / dx)
    expected = _lattice_set(planar.granular_position, dx)
    for row in range(rows.max() + 1):
        assert _lattice_set(grains[rows == row][:, [0, 2]], dx) == expected
    on_body = np.asarray(slab.core.wall_body) >= 0
    leg = np.asarray(slab.core.wall_position)[on_body]
    one_row = np.abs(leg[:, 1] - leg[0, 1]) < 1e-12
    assert np.allclose(np.sort(leg[one_row][:, [0, 2]], axis=0), np.sort(planar.bodies[0].position, axis=0),
                       atol=1e-12)
    assert slab.body_state("leg")["orientation"][2] < 0  # turned back by start_angle = −π/4 about +y


def test_smooth_side_walls_keep_a_pushed_slab_in_plane_strain() -> None:
    config = PlateIntrusion(spacing=0.005, speed=0.1, settle_time=0.0, t_end=0.1)
    sim = build_plate_slab(PlateSlab(config))
    sim.advance(config.end_time, 10**6)
    x, v = np.asarray(sim.core.position), np.asarray(sim.core.velocity)
    under = (np.abs(x[:, 0] - 0.5 * sim.bed.size[0]) < 0.5 * config.plate_length) & (x[:, 2] > sim.bed.size[2] - 0.03)
    rows = np.round(x[:, 1] / config.spacing - 0.5).astype(int)
    speeds = np.array([v[under & (rows == row), 2].mean() for row in range(rows.max() + 1)])
    assert len(speeds) == 5 and np.all(speeds < -0.01)
    assert np.ptp(speeds) < 0.25 * np.abs(speeds).mean(), speeds
    assert sim.leaked_particles == 0


@pytest.mark.slow
def test_grains_do_not_enter_a_plate_pushed_into_the_slab() -> None:
    config = PlateIntrusion(spacing=0.005, speed=0.1, settle_time=0.0, bed_width=0.12, bed_depth=0.08, max_depth=0.03)
    sim = build_plate_slab(PlateSlab(config))
    half = 0.5 * config.spacing * round(config.plate_thickness / config.spacing)  # the plate's rows' half-height
    for k in range(1, 5):  # through the stroke, down to 3 cm
        sim.advance(k / 4 * config.stroke_time, 10**6)
        centre, x = sim.body_state("plate")["reference"], np.asarray(sim.core.position)
        inside = (np.abs(x[:, 0] - centre[0]) < 0.5 * config.plate_length) & (np.abs(x[:, 2] - centre[2]) < half)
        assert not inside.any(), (sim.time, x[inside] - centre)
