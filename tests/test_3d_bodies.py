"""Rigid bodies in 3D (``Simulation3D``): a quaternion pose, a vector angular velocity, the wrench
of the grains about the reference point (docs/sph3d.md).

References, each independent of the core: a prescribed body turning at constant ω about a fixed
axis sits at c0 + v t + R(n, |ω| t)(x0 − c0) with R from Rodrigues' formula (1e-12 m), whatever
its starting orientation, and its particles move with v + ω × (x − c) (1e-12); turning about +y it
moves as the planar body turning clockwise in the x–z plane. A driven body's particles sit at
c + R(q) r, their velocity and acceleration match the first and second central differences of
that pose formula along a trajectory of constant a and α (1e-6 relative). A bed at rest on a
floor body: the floor and the sides carry the grains' weight (within 0.1 % [3e-5 %], the residual
of the bed's motion), and the floor's torque about a corner is the moment (c − p) × F of its force
acting at the bed's axis of symmetry (within 1e-6 |c − p||F| [1e-15]: the lattice bed is
mirror-symmetric). A run with a body turning and sinking into the bed is bitwise the same with 1,
2 and 3 threads and when saved and continued.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from sph3d_helpers import (
    BODY,
    FLOOR,
    SIDES,
    G,
    box_body,
    box_walls,
    lithostatic_bed,
    params,
    quaternion_matrix,
    rotation_matrix,
    with_body,
)
from terrasph import _core

DX = 0.004
BED = (6, 6, 4)
SURFACE = BED[2] * DX
BODY_CENTRE = np.array([3 * DX, 3 * DX, SURFACE + 1.5 * DX])  # bottom row half a spacing above the grains
IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


def bed_with_body(counts: tuple[int, int, int] = BED) -> tuple[_core.Simulation3D, np.ndarray]:
    """The lithostatic bed in its box with a 2 × 2 × 2 cell box body resting on its surface."""
    p = params(DX)
    position, normal = box_body(BODY_CENTRE, (2, 2, 2), DX)
    walls = with_body(box_walls(counts, DX), position, normal, DX)
    return _core.Simulation3D(p, lithostatic_bed(p, counts, DX), walls), position


def body_rows(walls_group: np.ndarray) -> np.ndarray:
    return walls_group == BODY


def turning_sinking_run(steps: int, restart_after: int | None = None) -> dict[str, np.ndarray]:
    """The body sinks at 5 cm/s and turns at 3 rad/s about an oblique axis into the bed."""
    sim, _ = bed_with_body()
    motion = [[math.inf, 0.0, 0.01, -0.05, 1.0, 2.0, 2.0]]
    sim.add_body(BODY, BODY_CENTRE, IDENTITY, motion)
    if restart_after is not None:
        sim.advance(1.0, restart_after)
        saved = sim.state()
        sim, _ = bed_with_body()
        sim.add_body(BODY, BODY_CENTRE, IDENTITY, motion)
        sim.restore(saved)
        sim.advance(1.0, steps - restart_after)
    else:
        sim.advance(1.0, steps)
    assert sim.step == steps
    state = {name: np.array(getattr(sim, name)) for name in ("position", "velocity", "density", "stress")}
    state["walls"] = sim.wall_position
    load = sim.body_state(0)
    for key in ("force", "torque", "mean_force", "mean_torque", "orientation", "reference"):
        state[key] = np.asarray(load[key])
    return state


@pytest.mark.parametrize("start_axis, start_angle", [((0.0, 0.0, 1.0), 0.0), ((1.0, -1.0, 0.5), 0.7)])
def test_a_prescribed_body_turns_rigidly_about_a_fixed_axis(start_axis, start_angle) -> None:
    sim, x0 = bed_with_body()
    axis0 = np.asarray(start_axis) / np.linalg.norm(start_axis)
    q0 = np.concatenate([[math.cos(start_angle / 2)], math.sin(start_angle / 2) * axis0])
    v, omega = np.array([0.02, -0.01, -0.03]), np.array([1.0, 2.0, 2.0])  # m/s, rad/s (|ω| = 3)
    sim.add_body(BODY, BODY_CENTRE, q0, [[math.inf, *v, *omega]])
    sim.advance(1.0, 20)
    t = sim.time
    turn = rotation_matrix(omega / 3.0, 3.0 * t)
    rows = body_rows(sim.wall_group)
    x = sim.wall_position[rows]
    centre = BODY_CENTRE + v * t
    assert np.abs(x - (centre + (x0 - BODY_CENTRE) @ turn.T)).max() < 1e-12
    assert np.abs(sim.wall_velocity[rows] - (v + np.cross(omega, x - centre))).max() < 1e-12
    state = sim.body_state(0)
    assert np.abs(quaternion_matrix(state["orientation"]) - turn @ quaternion_matrix(q0)).max() < 1e-12
    assert np.allclose(state["angular_velocity"], omega, rtol=0, atol=0)


def test_turning_about_y_is_the_planar_clockwise_turn() -> None:
    sim, x0 = bed_with_body()
    spin = 2.0  # rad/s about +y
    sim.add_body(BODY, BODY_CENTRE, IDENTITY, [[math.inf, 0.0, 0.0, 0.0, 0.0, spin, 0.0]])
    sim.advance(1.0, 10)
    theta = spin * sim.time
    r = x0 - BODY_CENTRE
    # the 2D core's clockwise turn in the x–z plane: (x, z) ↦ (x cos θ + z sin θ, −x sin θ + z cos θ)
    planar = np.column_stack([r[:, 0] * math.cos(theta) + r[:, 2] * math.sin(theta), r[:, 1],
                              -r[:, 0] * math.sin(theta) + r[:, 2] * math.cos(theta)])
    assert np.abs(sim.wall_position[body_rows(sim.wall_group)] - (BODY_CENTRE + planar)).max() < 1e-12


def test_a_driven_body_moves_with_the_pose_it_is_given() -> None:
    sim, x0 = bed_with_body()
    sim.add_driven_body(BODY, BODY_CENTRE, IDENTITY)
    axis = np.array([2.0, -1.0, 2.0]) / 3.0
    a_c, v0 = np.array([0.3, 0.1, -1.2]), np.array([0.05, 0.0, -0.02])
    theta0, omega0, alpha = 0.0, 0.4, 2.5

    def pose(time: float) -> tuple[np.ndarray, np.ndarray, float]:
        return (BODY_CENTRE + v0 * time + 0.5 * a_c * time**2, v0 + a_c * time,
                theta0 + omega0 * time + 0.5 * alpha * time**2)

    t = 0.0
    for _ in range(5):
        dt = 0.8 * sim.stable_time_step()
        c, v, theta = pose(t + dt)
        q = np.concatenate([[math.cos(theta / 2)], math.sin(theta / 2) * axis])
        sim.set_body_kinematics(0, c, q, v, (omega0 + alpha * (t + dt)) * axis, a_c, alpha * axis)
        sim.advance(t + dt, 1)
        t = sim.time

    def particle(time: float) -> np.ndarray:
        c, _, theta = pose(time)
        return c + (x0 - BODY_CENTRE) @ rotation_matrix(axis, theta).T

    rows = body_rows(sim.wall_group)
    assert np.abs(sim.wall_position[rows] - particle(t)).max() < 1e-12
    step = 1e-4
    velocity = (particle(t + step) - particle(t - step)) / (2 * step)
    assert np.abs(sim.wall_velocity[rows] - velocity).max() < 1e-6 * np.abs(velocity).max()
    acceleration = (particle(t + step) - 2 * particle(t) + particle(t - step)) / step**2
    assert np.abs(sim.field("acceleration", "walls")[rows] - acceleration).max() < 1e-6 * np.abs(acceleration).max()


def test_the_floor_body_carries_the_weight_with_its_moment() -> None:
    counts = (6, 6, 5)
    p = params(DX)
    grains = lithostatic_bed(p, counts, DX)
    sim = _core.Simulation3D(p, grains, box_walls(counts, DX))
    corner = np.array([-3 * DX, -3 * DX, 0.0])
    sim.add_body(FLOOR, corner, IDENTITY, [])
    sim.track_wall_loads(corner)
    sim.advance(1.0, 300)
    sim.reset_body_means()
    sim.reset_wall_load_means()
    sim.advance(1.0, 300)
    assert np.linalg.norm(sim.velocity, axis=1).mean() < 1e-3  # at rest
    weight = grains["mass"].sum() * G
    floor = sim.body_state(0)
    total = floor["mean_force"] + sim.wall_loads()[SIDES]["mean_force"]
    assert abs(total[2] + weight) < 1e-3 * weight
    axis_point = np.array([counts[0] * DX / 2, counts[1] * DX / 2, -1.5 * DX])  # the bed's axis, in the floor
    arm = axis_point - corner
    expected = np.cross(arm, floor["mean_force"])
    assert np.abs(floor["mean_torque"] - expected).max() < 1e-6 * np.linalg.norm(arm) * np.linalg.norm(floor["mean_force"])


def test_bitwise_with_one_two_and_three_threads(restore_threads) -> None:
    states = []
    for threads in (1, 2, 3):
        _core.set_num_threads(threads)
        states.append(turning_sinking_run(60))
    assert np.abs(states[0]["force"]).max() > 0.0  # the body touches the grains
    for other in states[1:]:
        for name, value in states[0].items():
            assert np.array_equal(value, other[name]), name


def test_a_saved_and_continued_run_is_bitwise_the_one_that_never_stopped() -> None:
    whole = turning_sinking_run(60)
    resumed = turning_sinking_run(60, restart_after=25)
    for name, value in whole.items():
        assert np.array_equal(value, resumed[name]), name


def test_bad_body_input_is_refused() -> None:
    sim, _ = bed_with_body()
    with pytest.raises(ValueError, match="quaternion"):
        sim.add_body(BODY, BODY_CENTRE, np.array([2.0, 0.0, 0.0, 0.0]), [])
    with pytest.raises(ValueError, match="motion row"):
        sim.add_body(BODY, BODY_CENTRE, IDENTITY, [[1.0, 0.0, 0.0, 0.0, 1.0]])
