"""Planar MJCF robots (docs/design.md §3.6): MuJoCo's hinge sign against terrasph's
clockwise angle, the planar checks and their errors (also a body overlapping the bed or a wall at
start), the shape inertia helper, the slip metric.

References: terrasph.bodies.rotation_matrix (the clockwise rotation, x right, z up); the inertia
of a full rectangle of Lx × Lz, m(Lx² + Lz²)/12 (exact for a lattice of square cells); Eq. 4.8.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from robot_helpers import BEADS, DX, mjcf
from terrasph.bodies import plate, rotation_matrix, wheel
from terrasph.config import ConfigError, Numerics
from terrasph.geometry import wall_layers_needed
from terrasph.mjcf.model import PlanarRobot, shape_inertial
from terrasph.robots.metrics import sinkage, slip
from terrasph.scene import Scene
from terrasph.simulation import Simulation
from terrasph.terrain.sph_coupling import free_surface

PLATE = plate(0.04, 3 * DX, 0.05, DX)
ARM = '<body name="arm" pos="0.1 0 0.2">{joints}<geom type="box" size="0.02 0.01 0.005" mass="1"/>' \
      '<site name="tip" pos="0.05 0 0"/></body>'


def test_positive_hinge_about_y_is_clockwise() -> None:
    """qpos = +φ about +y moves a point of the body frame by terrasph's clockwise rotation by φ."""
    robot = PlanarRobot(mjcf(ARM, joints='<joint name="pitch" type="hinge" axis="0 1 0"/>'), {"arm": PLATE})
    phi = 0.3
    robot.data.qpos[0] = phi
    robot.data.qvel[0] = 1.7
    mujoco.mj_forward(robot.model, robot.data)
    tip = robot.data.site_xpos[0][[0, 2]] - np.array([0.1, 0.2])
    assert np.abs(tip - rotation_matrix(phi) @ np.array([0.05, 0.0])).max() < 1e-15
    assert tip[1] < 0  # the tip on +x went down: clockwise with x right, z up
    body = robot.coupled[0]
    assert robot.wrapped_angle(body) == pytest.approx(phi, abs=1e-15)
    assert robot.velocity(body)[1] == pytest.approx(1.7, abs=1e-15)


def test_clockwise_torque_turns_the_body_clockwise_and_is_moved_to_the_centre_of_mass() -> None:
    """A clockwise granular torque τ about the body origin (here the hinge) gives q̈ = τ/I_hinge > 0;
    a force through the origin gives no q̈ although MuJoCo applies it at the offset centre of mass."""
    arm = ('<body name="arm" pos="0.1 0 0.2">{joints}<inertial pos="0.05 0 0" mass="2" '
           'diaginertia="0.001 0.003 0.0025"/></body>')
    robot = PlanarRobot(mjcf(arm, joints='<joint name="pitch" type="hinge" axis="0 1 0"/>'), {"arm": PLATE})
    body = robot.coupled[0]
    hinge_inertia = 0.003 + 2.0 * 0.05**2  # parallel axes
    gravity_torque = 2.0 * 9.81 * 0.05  # weight on the centre of mass at +x: clockwise
    robot.apply_load(body, np.array([0.0, 0.0]), 0.25)
    mujoco.mj_forward(robot.model, robot.data)
    assert robot.data.qacc[0] == pytest.approx((0.25 + gravity_torque) / hinge_inertia, rel=1e-12)
    robot.apply_load(body, np.array([0.3, -5.0]), 0.0)
    mujoco.mj_forward(robot.model, robot.data)
    assert robot.data.qacc[0] == pytest.approx(gravity_torque / hinge_inertia, rel=1e-12)


@pytest.mark.parametrize(("joints", "item"), [
    ('<joint name="sideways" type="slide" axis="0 1 0"/>', "sideways"),
    ('<joint name="roll" type="hinge" axis="1 0 0"/>', "roll"),
    ('<joint name="loose" type="ball"/>', "loose"),
    ('<freejoint name="free"/>', "free"),
])
def test_non_planar_joints_are_refused_by_name(joints: str, item: str) -> None:
    with pytest.raises(ConfigError, match=f"joint '{item}'"):
        PlanarRobot(mjcf(ARM, joints=joints), {"arm": PLATE})


def test_a_body_turned_out_of_the_plane_is_refused() -> None:
    tilted = ARM.replace('pos="0.1 0 0.2"', 'pos="0.1 0 0.2" euler="20 0 0"')
    with pytest.raises(ConfigError, match="body 'arm'"):
        PlanarRobot(mjcf(tilted), {"arm": PLATE})


def test_an_actuator_on_a_missing_joint_is_named() -> None:
    with pytest.raises(ConfigError, match="spin"):
        PlanarRobot(mjcf(ARM, actuators='<velocity name="spin" joint="axle" kv="1"/>'), {"arm": PLATE})


def test_couplings_must_name_a_body_with_a_shape() -> None:
    with pytest.raises(ConfigError, match=r"coupled body 'ghost'.*not a body"):
        PlanarRobot(mjcf(ARM), {"ghost": PLATE})
    with pytest.raises(ConfigError, match="coupled body 'arm' has no shape"):
        PlanarRobot(mjcf(ARM), {"arm": None})
    with pytest.raises(ConfigError, match="gravity"):
        PlanarRobot(mjcf(ARM).replace('gravity="0 0 -9.81"', 'gravity="0 0 -9.8"'), {"arm": PLATE})


def test_shape_inertia_of_a_plate_is_that_of_its_rectangle() -> None:
    """A plate is a full lattice rectangle of Lx × Lz cells: m = ρ Lx Lz w, I_yy = m (Lx² + Lz²)/12,
    I_xx = m (Lz² + w²)/12, about its centre; MuJoCo takes the MJCF element as given."""
    density, width = 2700.0, 0.05
    inertial = shape_inertial(PLATE, density, width)
    lx = np.ptp(PLATE.position[:, 0]) + DX
    lz = np.ptp(PLATE.position[:, 1]) + DX
    mass = density * lx * lz * width
    assert inertial.mass == pytest.approx(mass, rel=1e-12)
    assert inertial.inertia[1, 1] == pytest.approx(mass * (lx**2 + lz**2) / 12, rel=1e-12)
    assert inertial.inertia[0, 0] == pytest.approx(mass * (lz**2 + width**2) / 12, rel=1e-12)
    assert abs(inertial.inertia[0, 2]) < 1e-12 * inertial.inertia[1, 1]
    model = mujoco.MjModel.from_xml_string(
        mjcf('<body name="arm" pos="0 0 0.2">{joints}' + inertial.mjcf() + "</body>"))
    assert model.body_mass[1] == pytest.approx(mass, rel=1e-12)
    assert sorted(model.body_inertia[1]) == pytest.approx(sorted(np.diag(inertial.inertia)), rel=1e-9)


def test_ring_inertia_approaches_the_thin_ring() -> None:
    """A wheel rim of radius R and thickness t ≪ R: I_yy → m (R² + (R − t)²)/2 within the lattice's
    sampling of the annulus (5 %)."""
    rim = wheel(0.04, 2 * DX, 0.05, DX)
    inertial = shape_inertial(rim, 1000.0)
    outer, inner = 0.04, 0.04 - 2 * DX
    assert inertial.inertia[1, 1] == pytest.approx(inertial.mass * (outer**2 + inner**2) / 2, rel=0.05)
    assert np.hypot(*inertial.centre) < 1e-3 * outer


def test_slip_follows_eq_4_8() -> None:
    radius, omega = 0.04, 1.5
    rolling = radius * omega
    assert slip(0.0, omega, radius) == 1.0  # spinning in place
    assert slip(rolling, omega, radius) == 0.0  # pure rolling
    assert slip(0.5 * rolling, omega, radius) == pytest.approx(0.5)
    assert slip(2.0 * rolling, omega, radius) == pytest.approx(-0.5)  # skidding
    assert slip(0.1, 0.0, radius) == -1.0  # sliding without turning
    assert math.isnan(float(slip(0.0, 0.0, radius)))
    assert np.all(np.abs(slip(np.linspace(0, 1, 11), omega, radius)) <= 1.0)


def test_slip_of_one_sample_is_the_arrays_to_the_bit() -> None:
    """A sample's slip (numbers, computed in Python's floats) equals the array computation's at every
    pairing of signs, zeros (signed), tiny, huge, infinite and NaN speeds."""
    values = [0.0, -0.0, 1.0, -1.0, 0.3, -2.5, 1e-300, -1e-300, 5e-324, 1e300, math.inf, -math.inf, math.nan]
    for speed in values:
        for omega in values:
            for radius in (0.04, 1.0, 1e-300, 1e300):
                with np.errstate(over="ignore"):
                    expected = slip(np.array([speed]), np.array([omega]), radius)[0]
                got = slip(speed, omega, radius)
                assert np.array_equal(expected, got, equal_nan=True) and np.signbit(expected) == np.signbit(got), \
                    (speed, omega, radius, expected, got)


def test_sinkage_of_one_sample_is_the_arrays_to_the_bit() -> None:
    values = [0.0, -0.0, 0.031, -0.2, 1e-300, 1e300, math.inf, math.nan]
    for lowest in values:
        for surface in values:
            with np.errstate(invalid="ignore"):  # inf − inf
                expected = sinkage(np.array([lowest]), surface)[0]
            got = sinkage(lowest, surface)
            assert np.array_equal(expected, got, equal_nan=True) and np.signbit(expected) == np.signbit(got)


def test_bad_density_is_refused() -> None:
    with pytest.raises(ConfigError, match="density"):
        shape_inertial(PLATE, -1.0)


def test_a_coupled_body_overlapping_the_bed_or_a_wall_is_refused() -> None:
    def bed() -> Scene:
        scene = Scene(spacing=DX)
        scene.add_bed_in_container(0.2, 0.04, 0.05, layers=wall_layers_needed(1.3))
        return scene

    sunk = ARM.replace('pos="0.1 0 0.2"', 'pos="0.1 0 0.03"')
    with pytest.raises(ConfigError, match="coupled body 'arm' overlaps the bed"):
        PlanarRobot(mjcf(sunk), {"arm": PLATE}).add_to_scene(bed())
    in_the_wall = ARM.replace('pos="0.1 0 0.2"', 'pos="0.0 0 0.07"')
    scene = bed()
    PlanarRobot(mjcf(in_the_wall), {"arm": PLATE}).add_to_scene(scene)
    with pytest.raises(ConfigError, match="body 'arm' intersects another wall"):
        Simulation(scene, BEADS, Numerics(spacing=DX))


def test_free_surface_is_the_undisturbed_columns_level() -> None:
    """A lattice bed whose top grains sit at z = 0.0375 (cells reach 0.04), with a rut and a pile in
    x ∈ [0.10, 0.14] beside a body at [0.11, 0.13] and one grain thrown up far away: the level is
    the flat bed's 0.04 exactly (the pile is within the margin, the thrown grain one column of many
    in the median); with the margin reaching past the whole bed, NaN."""
    dx = 0.005
    x, z = np.meshgrid((np.arange(60) + 0.5) * dx, (np.arange(8) + 0.5) * dx)
    grains = np.column_stack([x.ravel(), z.ravel()])
    rut = (grains[:, 0] > 0.11) & (grains[:, 0] < 0.13) & (grains[:, 1] > 0.02)
    pile = np.array([[0.1025, 0.0425], [0.1025, 0.0475], [0.1375, 0.0425]])
    grains = np.vstack([grains[~rut], pile, [[0.2525, 0.09]]])
    assert free_surface(grains, dx, [(0.11, 0.13)], 0.01) == pytest.approx(0.04, abs=1e-15)
    assert free_surface(grains, dx, [], 0.0) == pytest.approx(0.04, abs=1e-15)  # 8 of 60 columns differ
    assert math.isnan(free_surface(grains, dx, [(0.11, 0.13)], 0.2))
