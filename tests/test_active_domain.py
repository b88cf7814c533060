"""Active domain (numerics.freeze_speed): settled grains far from every body and from
every unsettled grain are frozen (not updated) and woken when anything comes within their
neighbour radius.

Scene: a 0.4 m × 0.04 m bed of the packed glass beads (Δx = 5 mm) in a rough box, a plate held
1.75 cm above its left end (beyond the neighbour radius 2h(1 + skin/2) = 1.4 cm), then lowered to
0.5 cm above it. References:
* the right quarter of the bed, 25 cm from the plate, is frozen before the plate moves and stays
  bitwise unchanged (np.array_equal on position, velocity, density, stress) and never leaks;
* the grains under the plate were frozen before it came, and are awake and updated (their state
  changed) once it is within their neighbour radius;
* with numerics.active_radius, grains farther than it from every body are judged on their speed
  alone: at freeze_speed = 2 mm/s over 400 steps the bed's small settling waves (N·dt·|a| above
  2 mm/s) keep the strict criterion from freezing most far grains within 0.15 s [34 % of them
  frozen], while with a 10 cm radius every
  grain beyond 25 cm is frozen, none within 5 cm of the plate is, the far part stays bitwise
  unchanged while the plate is pushed down and no grain leaks;
* no grain within the radius of a body particle freezes, however slow (the strict criterion alone
  freezes grains under the plate at the same thresholds);
* the radius is measured to the body's particles, not to a circle about its reference point: with
  the reference 30 cm away from the plate, above the far part of the bed, that part still freezes;
* the proximity test (each body's distance field, particles visited near its contour only) gives
  brute force's answer about a turned leg-wheel, for scattered points and points 10⁻⁶ R either side
  of the contour;
* determinism (1, 2, 3 threads) and a checkpoint restart stay bitwise with the active domain and
  the cell-ordered storage both on (coarse column collapse with a high freeze speed, so that
  grains freeze and wake during the few hundred steps).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from terrasph import _core
from terrasph.bodies import leg_wheel, plate, rotation_matrix
from terrasph.config import Material, Numerics
from terrasph.geometry import wall_layers_needed
from terrasph.motion import Hold, Motion, Move
from terrasph.scene import Scene
from terrasph.scenes.column_collapse import ColumnCollapse, build_column_collapse
from terrasph.simulation import Simulation

DX = 0.005
WIDTH, HEIGHT = 0.4, 0.04
PLATE_HEIGHT = 0.025  # reference above the bed surface: 1.75 cm gap below the 1.5 cm thick plate
PUSH_START, PUSH_SPEED, PUSH_TIME = 0.15, 0.05, 0.25  # s, m/s, s: 1.25 cm down, to a 0.5 cm gap


def bed_with_plate(reference_shift: float = 0.0, **active_domain: float) -> Simulation:
    """The bed and the plate; `reference_shift` moves the plate's reference point that far to the
    right of the plate, which stays where it is."""
    numerics = Numerics(spacing=DX, **(active_domain or {"freeze_speed": 5e-3, "freeze_steps": 100}))
    scene = Scene(spacing=DX)
    scene.add_block(0.0, 0.0, WIDTH, HEIGHT)
    top = HEIGHT + 12 * DX
    scene.add_wall("box", [(0.0, top), (0.0, 0.0), (WIDTH, 0.0), (WIDTH, top)],
                   layers=wall_layers_needed(numerics.h_factor), no_slip=True)
    motion = Motion((Hold(PUSH_START), Move(PUSH_TIME, (0.0, -PUSH_SPEED))))
    shape = plate(0.04, 3 * DX, 1.0, DX)
    shape = dataclasses.replace(shape, position=shape.position - np.array([reference_shift, 0.0]))
    scene.add_body("plate", shape, reference=(0.05 + reference_shift, HEIGHT + PLATE_HEIGHT), motion=motion,
                   width=1.0)
    packed = Material(reference_density=0.6 * Material().grain_density)
    return Simulation(scene, packed, numerics)


def snapshot(sim: Simulation, mask: np.ndarray) -> dict[str, np.ndarray]:
    return {name: np.asarray(getattr(sim, name))[mask].copy() for name in ("position", "velocity", "density", "stress")}


def test_far_region_stays_bitwise_unchanged_and_an_approaching_body_wakes_grains() -> None:
    sim = bed_with_plate()
    start = np.asarray(sim.position)
    far = start[:, 0] > 0.3
    # the top row under the plate: within the neighbour radius 2h = 1.3 cm of the plate once it is
    # down to its 0.5 cm gap, so the rule wakes every one of them (the row below, 1.5 cm away, wakes
    # only through neighbours that move faster than freeze_speed)
    under_plate = (np.abs(start[:, 0] - 0.05) < 0.015) & (start[:, 1] > HEIGHT - DX)
    sim.advance(PUSH_START)
    frozen = np.asarray(sim.field("frozen")).astype(bool)
    assert frozen[far].all() and frozen[under_plate].all()  # the settled bed froze, plate still away
    before, near_before = snapshot(sim, far), snapshot(sim, under_plate)
    sim.advance(PUSH_START + PUSH_TIME + 0.05)
    after, near_after = snapshot(sim, far), snapshot(sim, under_plate)
    for name in before:
        assert np.array_equal(before[name], after[name]), name
    assert sim.leaked_particles == 0
    woken = ~np.asarray(sim.field("frozen")).astype(bool)
    assert woken[under_plate].all()
    # updated, not merely flagged: the plate's wall terms changed their rates, so their state moved
    assert not np.array_equal(near_before["velocity"], near_after["velocity"])
    assert not np.array_equal(near_before["stress"], near_after["stress"])


def test_far_from_bodies_speed_alone_decides() -> None:
    strict = {"freeze_speed": 2e-3, "freeze_steps": 400}
    start = np.asarray(bed_with_plate(**strict).position)
    far, near = start[:, 0] > 0.25, start[:, 0] < 0.1
    without = bed_with_plate(**strict)
    without.advance(PUSH_START)
    assert not np.asarray(without.field("frozen")).astype(bool)[far].all()
    sim = bed_with_plate(**strict, active_radius=0.1)
    sim.advance(PUSH_START)
    frozen = np.asarray(sim.field("frozen")).astype(bool)
    assert frozen[far].all() and not frozen[near].any()
    before = snapshot(sim, far)
    sim.advance(PUSH_START + PUSH_TIME)
    after = snapshot(sim, far)
    for name in before:
        assert np.array_equal(before[name], after[name]), name
    assert not np.asarray(sim.field("frozen")).astype(bool)[near].any()
    assert sim.leaked_particles == 0


def test_the_radius_is_measured_to_the_body_particles_not_to_its_reference_point() -> None:
    # the plate's reference 30 cm to its right, above the far part of the bed: a bounding circle
    # about the reference (radius 30 cm) would cover the whole bed and freeze nothing
    strict = {"freeze_speed": 2e-3, "freeze_steps": 400}
    sim = bed_with_plate(reference_shift=0.3, **strict, active_radius=0.1)
    start = np.asarray(sim.position)
    far, near = start[:, 0] > 0.25, start[:, 0] < 0.1
    sim.advance(PUSH_START)
    frozen = np.asarray(sim.field("frozen")).astype(bool)
    assert frozen[far].all() and not frozen[near].any()


def test_no_grain_within_the_radius_freezes_however_slow() -> None:
    # 5 cm/s is far above any speed of the settled bed: the strict criterion freezes grains under
    # the plate; within the radius (every grain at x < 0.1 is within 7 cm of a plate particle) none
    loose = {"freeze_speed": 0.05, "freeze_steps": 50}
    under_plate = np.asarray(bed_with_plate(**loose).position)[:, 0] < 0.1
    strict = bed_with_plate(**loose)
    strict.advance(PUSH_START)
    assert np.asarray(strict.field("frozen")).astype(bool)[under_plate].any()
    sim = bed_with_plate(**loose, active_radius=0.1)
    sim.advance(PUSH_START)
    assert not np.asarray(sim.field("frozen")).astype(bool)[under_plate].any()


def test_no_frozen_grain_lies_within_the_radius_of_a_body_particle() -> None:
    # the proximity test (BodyProximity, its cells and their boxes) against brute force over every
    # grain-plate pair, after the plate has pushed into the bed: no frozen grain within R, and frozen
    # grains close to R (within the neighbour radius 2h(1 + skin/2) = 1.4 cm, across which an awake
    # grain keeps its settled neighbours awake), so that the boundary is probed and not only the far
    # bed. The flags are the last step's, taken before the plate's last move (< 1 µm): the tolerance.
    radius = 0.05
    sim = bed_with_plate(freeze_speed=5e-3, freeze_steps=100, active_radius=radius)
    sim.advance(PUSH_START + PUSH_TIME)
    walls = sim.core.state()["walls"]
    plate_points = np.asarray(walls["position"])[np.asarray(walls["body"]) >= 0]
    grains = np.asarray(sim.position)
    nearest = np.sqrt(((grains[:, None, :] - plate_points[None, :, :]) ** 2).sum(axis=-1)).min(axis=1)
    frozen = np.asarray(sim.field("frozen")).astype(bool)
    assert frozen.any()
    assert nearest[frozen].min() > radius - 1e-6
    defaults = Numerics(spacing=DX)
    neighbour_radius = 2 * defaults.h_factor * DX * (1 + defaults.neighbour_skin / 2)
    assert nearest[frozen].min() < radius + neighbour_radius + DX


def test_an_active_radius_without_a_freeze_speed_is_refused() -> None:
    with pytest.raises(ValueError, match=r"numerics\.active_radius.*freeze_speed"):
        bed_with_plate(active_radius=0.1)


def collapse() -> Simulation:
    numerics = {"freeze_speed": 0.01, "freeze_steps": 20, "cell_order": True}
    scene, material, numerics_obj = build_column_collapse(ColumnCollapse(resolution="coarse", numerics=numerics))
    return Simulation(scene, material, numerics_obj)


def assert_states_equal(a: dict, b: dict) -> None:
    for part in ("granular", "walls"):
        for name in a[part]:
            assert np.array_equal(a[part][name], b[part][name]), f"{part} field {name} differs"
    assert a["counters"]["step"] == b["counters"]["step"] and a["counters"]["time"] == b["counters"]["time"]


def run_state(threads: int, steps: int) -> dict:
    _core.set_num_threads(threads)
    sim = collapse()
    sim.advance(1.0, max_steps=steps)
    return sim.core.state()


def test_bitwise_identical_with_one_two_and_three_threads(restore_threads) -> None:
    one = run_state(1, 300)
    frozen = np.asarray(one["granular"]["frozen"])
    assert 0 < frozen.sum() < len(frozen)  # some grains frozen, some flowing
    for threads in (2, 3):
        assert_states_equal(one, run_state(threads, 300))


def test_restart_with_the_active_domain_is_bitwise_identical(tmp_path) -> None:
    straight = collapse()
    straight.advance(1.0, max_steps=300)
    first_half = collapse()
    first_half.advance(1.0, max_steps=150)
    path = first_half.checkpoint(tmp_path / "half.h5")
    resumed = collapse()
    resumed.restore(path)
    resumed.advance(1.0, max_steps=150)
    assert_states_equal(straight.core.state(), resumed.core.state())


@pytest.mark.parametrize("angle", [0.7, -2.9, 40.3])
def test_the_proximity_test_agrees_with_brute_force_about_a_turned_leg_wheel(angle: float) -> None:
    # The active domain's "within R of a body particle?" (numerics.active_radius) is decided from
    # the body's distance field sampled on a grid of R/16 in its own frame, visiting particles only
    # near the contour d = R. Reference: the distance to every particle, for points scattered over
    # the whole field and points placed within 1e-6 R of the contour on both sides, at several
    # angles (one of them many turns).
    radius = 0.1
    shape = leg_wheel("c-leg", 3, 0.08, 0.005, 0.1, 0.005 / 3)
    offsets = np.asarray(shape.position)
    reference = np.array([0.21, 0.13])
    world = reference + offsets @ rotation_matrix(angle).T
    rng = np.random.default_rng(7)
    scattered = reference + rng.uniform(-0.35, 0.35, size=(20_000, 2))
    # points on rays from particles at distance R ± 1e-6 R, kept where that particle is the nearest
    source = world[rng.integers(len(world), size=20_000)]
    direction = rng.normal(size=(20_000, 2))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    contour = np.concatenate([source + (1 + s) * radius * direction for s in (-1e-6, 1e-6)])
    points = np.concatenate([scattered, contour])
    nearest = np.concatenate([np.sqrt(((chunk[:, None, :] - world[None]) ** 2).sum(axis=-1)).min(axis=1)
                              for chunk in np.array_split(points, 200)])
    near = _core.near_body(offsets, reference, angle, radius, points)
    assert np.array_equal(near, nearest <= radius)
    on_contour = np.abs(nearest[len(scattered):] / radius - 1) < 2e-6
    assert on_contour.sum() > 50 and near[len(scattered):][on_contour].any() and not near[len(scattered):][on_contour].all()
