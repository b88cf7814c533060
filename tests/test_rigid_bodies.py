"""Rigid bodies in the terrain (docs/design.md §3.6, Eq. 3.24–3.25).

A 0.12 m × 0.05 m bed at Δx = 5 mm (240 particles) in a rough box. References, all exact or
physical laws, with their tolerances:

* Momentum over a run: when every wall is a body, the change of the grains' momentum (from their
  velocities) equals the impulse of gravity less the bodies' impulses, with the integrator's
  end-point correction, to round-off (1e-9 of M g T) while a plate is driven through the bed.
* A body held still in a settled bed leaves it at rest: the mean speed decays steadily and is
  below 2.5e-4 m/s after 0.4 s [1.8e-4] (the grains around the hole cut for the plate creep into
  place more slowly than a plain bed settles, test_settling.py), and the box and plate then carry
  the bed's weight, F_z = −M g within 1 % [0.001 %].
* Prescribed motion is followed exactly: body particles sit at c + R(θ) r with θ from the
  schedule, and move with v = ω J R r, to 1e-12 m and 1e-12 m/s.
* Loads are in N for the body's real width (docs/design.md §2): a box carries the real sample's weight.
* Leak counter: zero in a settled bed; a grain pressed onto a wall's surface row is not counted, a
  grain on the second layer is.
* Bad input (a negative duration, a body through a wall, a body thinner than its wall layers,
  a shape sampled at another spacing) is refused with the parameter named.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from terrasph import _core
from terrasph.bodies import BodyShape, plate
from terrasph.config import ConfigError, Material, Numerics
from terrasph.geometry import polyline_wall, wall_layers_needed
from terrasph.motion import Hold, Motion, Move, Rotate, hold_then_rotate
from terrasph.scene import Scene
from terrasph.simulation import Simulation

DX = 0.005
WIDTH = 0.12
HEIGHT = 0.05
G = 9.81
NUMERICS = Numerics(spacing=DX)
LAYERS = wall_layers_needed(NUMERICS.h_factor)


def box_vertices(top: float) -> list[tuple[float, float]]:
    return [(0.0, top), (0.0, 0.0), (WIDTH, 0.0), (WIDTH, top)]


def box_shape(top: float) -> BodyShape:
    """The container as a body shape (reference point at the origin)."""
    position, normal = polyline_wall(box_vertices(top), DX, LAYERS)
    return BodyShape("box", position, normal, DX, LAYERS * DX, 1.0, WIDTH)


def bed_scene(*, box_is_body: bool, plate_motion: Motion | None = None, plate_depth: float = 0.02) -> Scene:
    scene = Scene(spacing=DX)
    scene.add_block(0.0, 0.0, WIDTH, HEIGHT)
    top = HEIGHT + 6 * DX
    if box_is_body:
        scene.add_body("box", box_shape(top), reference=(0.0, 0.0), width=1.0, clear_granular=False)
    else:
        scene.add_wall("box", box_vertices(top), layers=LAYERS, no_slip=True)
    if plate_motion is not None:
        shape = plate(0.04, 3 * DX, 1.0, DX)
        scene.add_body("plate", shape, reference=(0.5 * WIDTH, HEIGHT - plate_depth), motion=plate_motion, width=1.0)
    return scene


def grain_momentum(sim: Simulation) -> np.ndarray:
    """Σ m_i v_i of the grains, per metre of depth (kg m/s per m)."""
    return np.asarray(sim.mass) @ np.asarray(sim.velocity)

def _moved(position: np.ndarray, particle: int, to: list[float]) -> np.ndarray:
    """A copy of `position` with one particle moved to `to`."""
    moved = position.copy()
    moved[particle] = to
    return moved

def test_body_loads_balance_the_grains_momentum_over_a_run() -> None:
    """Every wall is a body (box and a plate driven down into the bed), so the only external forces
    on the grains are gravity and the bodies' reactions. Over a run with a fixed step dt, the
    kick–drift–kick integrator changes the grains' momentum by Σ_n dt/2 (F^n + F^{n+1}), and the
    bodies accumulate dt Σ_n F_b^{n+1}: so ΔP = M g T − Σ_b [I_b − dt/2 (F_b(T) − F_b(0))], with
    ΔP from the velocities alone. Round-off bound: 1e-9 of M g T [4e-14; without the end-point
    correction the balance misses by 8e-5]."""
    motion = Motion((Move(math.inf, (0.0, -0.05)),))
    dt = 1.5e-5
    numerics = dataclasses.replace(NUMERICS, fixed_dt=dt)
    sim = Simulation(bed_scene(box_is_body=True, plate_motion=motion), Material(), numerics)
    sim.reset_body_means()
    start_momentum, start_time = grain_momentum(sim), sim.time
    start_loads = {b.name: sim.body_state(b.name)["force_now"] for b in sim.bodies}
    sim.advance(0.06)
    duration = sim.time - start_time
    weight = float(np.sum(sim.mass)) * G
    impulse = np.zeros(2)
    for body in sim.bodies:
        state = sim.body_state(body.name)
        assert state["averaged_over"] == pytest.approx(duration, rel=1e-12)
        impulse += state["force"] * duration - 0.5 * dt * (state["force_now"] - start_loads[body.name])
    expected = np.array([0.0, -weight * duration]) - impulse
    assert np.abs(grain_momentum(sim) - start_momentum - expected).max() < 1e-9 * weight * duration
    plate_load = sim.body_state("plate")["force_now"]
    assert plate_load[1] > 0.01 * weight  # the beads resist the plate: a real load


def test_body_held_still_leaves_the_bed_at_rest() -> None:
    sim = Simulation(bed_scene(box_is_body=True, plate_motion=Motion()), Material(), NUMERICS)
    mean_speed = []
    for t in (0.2, 0.4):
        sim.advance(t)
        mean_speed.append(float(np.hypot(*np.asarray(sim.velocity).T).mean()))
    # the grains around the hole cut for the plate creep into place and slow down steadily
    assert mean_speed[1] < 2.5e-4  # [1.8e-4]; √(g H) = 0.7 m/s is the speed scale of a collapse
    assert mean_speed[1] < 0.7 * mean_speed[0]  # [0.55]
    weight = float(np.sum(sim.mass)) * G
    loads = sim.body_state("box")["force_now"] + sim.body_state("plate")["force_now"]
    assert loads[1] == pytest.approx(-weight, rel=0.01)  # container + plate carry the bed
    assert abs(loads[0]) < 0.01 * weight
    assert sim.leaked_particles == 0


def test_prescribed_motion_is_followed_exactly() -> None:
    omega, hold = 2.0, 0.01
    motion = Motion((Hold(hold), Rotate(math.inf, omega)))
    scene = bed_scene(box_is_body=False, plate_motion=motion, plate_depth=-0.03)  # above the bed
    sim = Simulation(scene, Material(), NUMERICS)
    group = scene.bodies[0]
    mask = np.asarray(sim.core.wall_group) == group.group_id
    centre = np.asarray(group.reference)
    for t in (0.005, 0.03, 0.06):
        sim.advance(t)
        angle = omega * max(t - hold, 0.0)
        c, s = math.cos(angle), math.sin(angle)
        rotation = np.array([[c, s], [-s, c]])  # clockwise
        arm = (group.shape.position @ rotation.T)
        position = np.asarray(sim.core.wall_position)[mask]
        velocity = np.asarray(sim.core.wall_velocity)[mask]
        spin = omega if t >= hold else 0.0
        assert np.abs(position - (centre + arm)).max() < 1e-12
        assert np.abs(velocity - spin * np.column_stack([arm[:, 1], -arm[:, 0]])).max() < 1e-12
        state = sim.body_state("plate")
        assert state["angle"] == pytest.approx(angle, abs=1e-12)
        assert state["omega"] == spin


def test_a_body_container_carries_the_real_weight_of_its_bed() -> None:
    """Loads are in newtons for the body's real out-of-plane width (docs/design.md §2): a settled bed in a
    box (a body of width W) loads it with the weight of the real sample, ρ_bulk · area · W · g,
    where the bulk density is the mean of the particles' densities over the block's area
    (independent of the per-metre masses the core integrates). Tolerance 1 % [0.02 %]."""
    width = 0.07
    scene = Scene(spacing=DX)
    scene.add_block(0.0, 0.0, WIDTH, HEIGHT)
    scene.add_body("box", dataclasses.replace(box_shape(HEIGHT + 6 * DX), width=width), reference=(0.0, 0.0),
                   width=width, clear_granular=False)
    sim = Simulation(scene, Material(), NUMERICS, width=width)
    sim.advance(0.3)
    sim.reset_body_means()
    sim.advance(0.35)
    sample_weight = float(np.mean(sim.density)) * WIDTH * HEIGHT * width * G
    load = sim.body_state("box")["force"]
    assert load[1] == pytest.approx(-sample_weight, rel=0.01)
    assert abs(load[0]) < 0.01 * sample_weight


def test_leak_counter_counts_a_grain_inside_a_wall() -> None:
    sim = Simulation(bed_scene(box_is_body=False), Material(), NUMERICS)
    sim.advance(0.01)
    assert sim.leaked_particles == 0
    # along the left wall, the row at x = −Δx/2 is the surface; the rows behind it are interior
    interior = np.asarray(sim.core.wall_interior).astype(bool)
    x, z = np.asarray(sim.core.wall_position).T
    side = (z > 2 * DX) & (z < HEIGHT) & (x < 0)
    assert side.sum() > 0
    assert np.array_equal(interior[side], x[side] < -DX)
    corner = int(np.argmin(np.asarray(sim.position).sum(axis=1)))  # the grain in the bottom-left corner
    sim.set_field("position", _moved(sim.position, corner, [-0.5 * DX, 0.5 * DX]))  # onto the surface row: no leak
    sim.refresh()
    assert sim.core.penetrating_particles == 0
    sim.set_field("position", _moved(sim.position, corner, [-1.5 * DX, 0.5 * DX]))  # second layer: past it
    sim.refresh()
    assert sim.core.penetrating_particles == 1
    assert sim.leaked_particles == 1


def test_contact_barrier_pushes_a_grain_out_of_a_wall() -> None:
    """A grain centre put 0.2Δx inside the left wall's surface, within 0.75Δx of one wall particle
    only, gets the barrier's push on top of the pair forces: K (1 − r/r0)² x_iw/r with K = c²/h,
    r0 = 0.75Δx (docs/design_decisions.md)."""
    def pushed(barrier: float) -> tuple[np.ndarray, np.ndarray, float]:
        sim = Simulation(bed_scene(box_is_body=False), Material(), dataclasses.replace(NUMERICS, wall_barrier=barrier))
        corner = int(np.argmin(np.asarray(sim.position).sum(axis=1)))
        sim.position = _moved(sim.position, corner, [-0.2 * DX, 2.5 * DX])
        sim.refresh()
        params = sim.core.params
        c = max(params.artificial_sound_speed, params.eos_sound_speed)
        offsets = np.asarray(sim.position[corner]) - np.asarray(sim.core.wall_position)
        return np.array(sim.core.acceleration[corner]), offsets, c * c / sim.core.smoothing_length

    with_barrier, offsets, strength = pushed(1.0)
    without, _, _ = pushed(0.0)
    distance = np.hypot(*offsets.T)
    assert np.sum(distance < 0.75 * DX) == 1
    k = int(np.argmin(distance))
    expected = strength * (1 - distance[k] / (0.75 * DX)) ** 2 * offsets[k] / distance[k]
    assert np.allclose(with_barrier - without, expected, rtol=1e-9, atol=1e-9 * strength)
    assert with_barrier[0] > 0  # out of the wall


def test_motion_schedules_refuse_bad_pieces() -> None:
    with pytest.raises(ConfigError, match=r"motion\[0\].duration"):
        Motion((Hold(-1.0),))
    with pytest.raises(ConfigError, match=r"motion\[0\].duration"):
        Motion((Rotate(math.inf, 1.0), Hold(1.0)))  # only the last piece may last for ever
    with pytest.raises(ConfigError, match=r"motion\[0\].omega"):
        Motion((Rotate(1.0, math.nan),))
    with pytest.raises(ConfigError, match="omega"):
        hold_then_rotate(1.0, -0.2, 1.0)
    assert hold_then_rotate(2.0, 0.2, math.pi / 2).duration == pytest.approx(2.0 + math.pi / 2 / 0.2)


def test_scene_refuses_bad_bodies() -> None:
    with pytest.raises(ConfigError, match="intersects another wall"):
        scene = bed_scene(box_is_body=False, plate_motion=Motion(), plate_depth=HEIGHT + 0.002)  # through the floor
        scene.validate(NUMERICS)
    with pytest.raises(ConfigError, match="below the minimum"):
        scene = Scene(spacing=DX)
        scene.add_block(0.0, 0.0, WIDTH, HEIGHT)
        scene.add_body("sheet", plate(0.04, 2 * DX, 1.0, DX), reference=(0.06, 0.03))
        scene.validate(NUMERICS)
    with pytest.raises(ConfigError, match="spacing"):
        Scene(spacing=DX).add_body("plate", plate(0.04, 0.012, 1.0, 0.004), reference=(0.0, 0.0))
    with pytest.raises(ValueError, match="no particles"):
        sim = Simulation(bed_scene(box_is_body=False), Material(), NUMERICS)
        sim.core.add_body(7, np.zeros(2), 0.0, [])


def test_body_state_is_the_same_for_one_and_two_threads(restore_threads) -> None:
    def final_state(threads: int) -> tuple[np.ndarray, np.ndarray, float]:
        _core.set_num_threads(threads)
        motion = Motion((Move(math.inf, (0.0, -0.05)),))
        sim = Simulation(bed_scene(box_is_body=True, plate_motion=motion), Material(), NUMERICS)
        sim.advance(1.0, max_steps=300)
        state = sim.body_state("plate")
        return np.array(sim.position), state["force_now"], state["torque_now"]

    one, two = final_state(1), final_state(2)
    assert np.array_equal(one[0], two[0])
    assert np.array_equal(one[1], two[1])
    assert one[2] == two[2]
