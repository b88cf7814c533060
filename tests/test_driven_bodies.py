"""Bodies driven from outside (docs/design.md §3.6; the core side of the multibody coupling).

References: a driven body's particles sit at c + R(θ) r with the pose last set (1e-12 m); their
velocity is v_c + ω J R r (1e-12); their acceleration, which enters the wall pressure (Eq. 3.31),
is a_c + α J R r − ω² R r, checked against the second time derivative of the particle positions
along a trajectory with constant a_c and α, taken by central differences of the pose formula
(independent of the core; bound 1e-6 relative). A prescribed body cannot be driven, a driven one
cannot also have a schedule, and the driven state survives a checkpoint bit for bit.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from terrasph.bodies import plate
from terrasph.config import ConfigError, Material, Numerics
from terrasph.geometry import wall_layers_needed
from terrasph.motion import Motion, Rotate
from terrasph.scene import Scene
from terrasph.simulation import Simulation

DX = 0.005
A_C = np.array([0.3, -1.2])  # m/s²
ALPHA = 2.5  # rad/s², clockwise
V0, OMEGA0 = np.array([0.05, 0.0]), 0.4
C0, THETA0 = np.array([0.1, 0.12]), 0.2


def pose(t: float) -> tuple[np.ndarray, float, np.ndarray, float]:
    """Reference point, angle, velocity and spin under constant a_c and α."""
    return C0 + V0 * t + 0.5 * A_C * t * t, THETA0 + OMEGA0 * t + 0.5 * ALPHA * t * t, V0 + A_C * t, OMEGA0 + ALPHA * t


def rotate_clockwise(r: np.ndarray, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return r @ np.array([[c, -s], [s, c]])


def driven_scene() -> tuple[Scene, np.ndarray]:
    scene = Scene(spacing=DX)
    scene.add_block(0.0, 0.0, 0.2, 0.03)
    scene.add_wall("floor", [(0.0, 0.1), (0.0, 0.0), (0.2, 0.0), (0.2, 0.1)], layers=wall_layers_needed(1.3))
    shape = plate(0.04, 3 * DX, 0.05, DX)
    scene.add_body("wheel", shape, reference=tuple(C0), angle=THETA0, driven=True, width=0.05)
    scene.domain_lower, scene.domain_upper = (-0.2, -0.2), (0.6, 0.5)
    return scene, shape.position


def test_driven_body_follows_the_kinematics_it_is_given() -> None:
    scene, body_frame = driven_scene()
    sim = Simulation(scene, Material(), Numerics(spacing=DX))
    mask = sim.core.wall_body == 0
    t = 0.0
    for _ in range(5):
        dt = 0.8 * sim.core.stable_time_step()
        c, theta, v, omega = pose(t + dt)
        sim.set_body_kinematics("wheel", c, theta, v, omega, A_C, ALPHA)
        sim.advance(t + dt, max_steps=1)
        t = sim.time
    arm = rotate_clockwise(body_frame, pose(t)[1])
    positions = sim.field("position", "walls")[mask]
    expected = (pose(t)[0] + arm)
    assert np.abs(np.sort(positions, axis=0) - np.sort(expected, axis=0)).max() < 1e-12
    # velocity and acceleration of each wall particle against the pose formula's derivatives
    offsets = positions - pose(t)[0]
    turned = np.column_stack([offsets[:, 1], -offsets[:, 0]])
    velocity = sim.field("velocity", "walls")[mask]
    assert np.abs(velocity - (pose(t)[2] + pose(t)[3] * turned)).max() < 1e-12

    def particle_position(time: float, offset_now: np.ndarray) -> np.ndarray:
        c, theta = pose(time)[:2]
        body = rotate_clockwise(offset_now, -pose(t)[1])  # back to the body frame
        return c + rotate_clockwise(body, theta)

    step = 1e-4
    numeric = (particle_position(t + step, offsets) - 2 * particle_position(t, offsets)
               + particle_position(t - step, offsets)) / step**2
    acceleration = sim.field("acceleration", "walls")[mask]
    assert np.abs(acceleration - numeric).max() < 1e-6 * np.abs(numeric).max()


def test_driving_needs_a_driven_body() -> None:
    scene, _ = driven_scene()
    shape = plate(0.04, 3 * DX, 0.05, DX)
    scene.add_body("pusher", shape, reference=(0.15, 0.12), motion=Motion((Rotate(math.inf, 1.0),)))
    sim = Simulation(scene, Material(), Numerics(spacing=DX))
    with pytest.raises(ConfigError, match="pusher"):
        sim.set_body_kinematics("pusher", (0.15, 0.12), 0.0, (0.0, 0.0), 0.0)
    with pytest.raises(ConfigError, match="driven"):
        scene.add_body("both", shape, reference=(0.05, 0.15), motion=Motion(), driven=True)


def test_driven_state_survives_a_checkpoint(tmp_path) -> None:
    scene, _ = driven_scene()
    sim = Simulation(scene, Material(), Numerics(spacing=DX))
    c, theta, v, omega = pose(1e-5)
    sim.set_body_kinematics("wheel", c, theta, v, omega, A_C, ALPHA)
    sim.advance(1e-5, max_steps=1)
    path = sim.checkpoint(tmp_path / "driven.h5")
    other = Simulation(driven_scene()[0], Material(), Numerics(spacing=DX))
    other.restore(path)
    for key in ("reference", "velocity", "acceleration", "force"):
        assert np.array_equal(sim.body_state("wheel")[key], other.body_state("wheel")[key])
    assert other.body_state("wheel")["angular_acceleration"] == ALPHA
