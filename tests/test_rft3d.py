"""3D resistive force theory (terrasph.terrain.rft3d) and its MuJoCo stepper (terrasph.terrain.rft3d_coupling):
the planar law recovered for motion in the x–z plane, invariance under a turn about the vertical,
the geoms' surface areas, a plate's hand-computed load and a resting box's equilibrium depth; the
compiled law's Jacobian, the native step's momentum balance, its checkpoint and its control rate."""

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest
import terrasph
from terrasph import _core
from terrasph.config import ConfigError
from terrasph.mjcf.geoms import body_shape, geom_surface
from terrasph.terrain import rft, rft3d, rft_coupling
from terrasph.terrain.rft3d_coupling import RFT3D_TIME_STEP, RFT3DCoupling, rft_robot

ROVER = Path(terrasph.__file__).parent / "robots" / "models" / "rover4.xml"


def _model(geom: str, joint: str = "<freejoint/>") -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_string(f'<mujoco><worldbody><body name="b" pos="0 0 0.2">{joint}{geom}'
                                          '</body></worldbody></mujoco>')


@pytest.mark.parametrize("velocity,omega", [((0.1, -0.05), 0.0), ((-0.02, -0.1), 0.0), ((0.0, -0.1), 0.0),
                                            ((0.05, 0.02), 1.5), ((0.0, 0.1), 0.0)])
def test_extruded_box_in_the_plane_is_the_planar_load(velocity, omega):
    # a tilted box 10 cm wide in y moving in x–z: 3D RFT is the planar map's load times the width
    model = _model('<geom type="box" size="0.03 0.05 0.01" euler="0 20 0"/>')
    elements = rft3d.BodyElements.from_body(model, 1, 0.002)
    planar = rft.SurfaceElements.from_shape(body_shape(model, 1, 0.002), 0.001, 0.1)
    expected = rft.body_load(planar, 0.0, (0.0, 0.0), np.array(velocity), omega, 0.02, rft.GENERIC)
    force, torque = rft3d.body_wrench(elements, np.zeros(3), np.eye(3), np.zeros(3),
                                      np.array([velocity[0], 0.0, velocity[1]]), np.array([0.0, omega, 0.0]), 0.02,
                                      rft.GENERIC)
    scale = np.abs(expected.force).max()
    assert np.abs(force[[0, 2]] - expected.force).max() < 2e-3 * scale  # exact without spin; discretisation with it
    assert abs(force[1]) < 1e-9 * scale
    assert torque[1] == pytest.approx(expected.torque, rel=1e-2, abs=1e-3 * scale * 0.03)


def test_load_turns_with_body_and_motion_about_the_vertical():
    model = _model('<geom type="capsule" size="0.02 0.05" euler="30 60 0"/><geom type="box" size="0.04 0.02 0.02"/>')
    elements = rft3d.BodyElements.from_body(model, 1, 0.004)
    linear, angular = np.array([0.07, -0.03, -0.05]), np.array([0.4, -1.1, 0.8])
    force, torque = rft3d.body_wrench(elements, np.zeros(3), np.eye(3), np.zeros(3), linear, angular, 0.03, rft.GENERIC)
    for yaw in (0.7, 2.0, -2.9):
        c, s = math.cos(yaw), math.sin(yaw)
        turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        f, t = rft3d.body_wrench(elements, np.zeros(3), turn, np.zeros(3), turn @ linear, turn @ angular, 0.03,
                                 rft.GENERIC)
        assert np.allclose(f, turn @ force, atol=1e-9 * np.abs(force).max())
        assert np.allclose(t, turn @ torque, atol=1e-9 * np.abs(force).max())


@pytest.mark.parametrize("geom,area", [
    ('<geom type="sphere" size="0.03"/>', 4 * math.pi * 0.03**2),
    ('<geom type="capsule" size="0.02 0.05"/>', 4 * math.pi * 0.02**2 + 2 * math.pi * 0.02 * 0.1),
    ('<geom type="cylinder" size="0.03 0.02"/>', 2 * math.pi * 0.03**2 + 2 * math.pi * 0.03 * 0.04),
    ('<geom type="box" size="0.01 0.02 0.03"/>', 8 * (0.01 * 0.02 + 0.02 * 0.03 + 0.01 * 0.03)),
])
def test_geom_surface_areas_and_outward_normals(geom, area):
    model = _model(geom)
    centre, normal, patches = geom_surface(model, 0, 0.004)
    assert patches.sum() == pytest.approx(area, rel=1e-12)
    assert np.allclose(np.linalg.norm(normal, axis=1), 1.0)
    assert np.all(np.sum(centre * normal, axis=1) > 0)  # convex geoms centred on the origin: outward
    # the divergence theorem: the closed surface's Σ n dA vanishes
    assert np.abs((normal * patches[:, None]).sum(axis=0)).max() < 1e-12


def test_a_plane_geom_cannot_be_loaded():
    model = mujoco.MjModel.from_xml_string('<mujoco><worldbody><geom name="ground" type="plane" size="1 1 0.1"/>'
                                           '</worldbody></mujoco>')
    with pytest.raises(ConfigError, match="geom 'ground' is a plane"):
        geom_surface(model, 0, 0.01)


def test_horizontal_plate_pushed_down_meets_zeta_area_depth():
    # only the bottom leads (the sides move along themselves): F_z = ζ α̂_z(0, π/2) A d = ζ A d
    model = _model('<geom type="box" size="0.04 0.03 0.005"/>')
    elements = rft3d.BodyElements.from_body(model, 1, 0.01)
    depth = 0.012  # of the bottom face, 5 mm below the centre
    force, torque = rft3d.body_wrench(elements, np.array([0.0, 0.0, -depth + 0.005]), np.eye(3), np.zeros(3),
                                      np.array([0.0, 0.0, -0.05]), np.zeros(3), 0.0, rft.GENERIC)
    assert force[2] == pytest.approx(rft.GENERIC.zeta * 0.08 * 0.06 * depth, rel=1e-12)
    assert np.abs(force[:2]).max() < 1e-9 * force[2] and np.abs(torque).max() < 1e-9 * force[2]


def test_box_dropped_on_the_sand_stops_where_the_resistance_took_its_energy():
    # a 2 kg box 8 x 6 cm, its bottom dropped from h = 1 mm: RFT resists only while it moves and does not
    # push back, so it stops at the depth d where the work of ζ A x equals that of gravity,
    # ζ A d²/2 = m g (d + h) (d = 34.5 mm, twice the static m g/(ζ A) and more), then rests there carrying its weight
    model = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><geom name="floor" type="plane" size="1 1 0.1"/><body name="b" pos="0 0 0.011">'
        '<freejoint/><geom type="box" size="0.04 0.03 0.01" mass="2"/></body></worldbody></mujoco>')
    robot = rft_robot(model, element_length=0.01)
    stepper = RFT3DCoupling(robot)
    stepper.advance(0.5)
    stepper.reset_body_means()
    stepper.advance(0.6)
    stiffness, weight = rft.GENERIC.zeta * 0.08 * 0.06, 2 * 9.81
    expected = (weight + math.sqrt(weight**2 + 2 * stiffness * weight * 0.001)) / stiffness
    assert -(robot.data.qpos[2] - 0.01) == pytest.approx(expected, rel=0.02)
    assert stepper.body_sample(0)["force"][2] == pytest.approx(weight, rel=0.01)
    assert np.abs(robot.data.qvel).max() < 1e-3


@pytest.mark.parametrize("speed", [0.2, 3e-4, 5e-5])  # the plane of motion; blended with the normal's; ramped
def test_element_jacobian_matches_finite_differences(speed):
    # the analytic ∂F/∂v of the compiled law (the native stepper's Newton matrix) against central differences
    rng = np.random.default_rng(7)
    normal = rng.normal(size=(400, 3))
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    direction = rng.normal(size=(400, 3))
    velocity = speed * direction / np.linalg.norm(direction, axis=1)[:, None]
    depth, area = rng.uniform(0.001, 0.05, 400), rng.uniform(1e-5, 1e-4, 400)
    table = rft.GENERIC

    def forces(v):
        return _core.rft3d_element_loads(normal, v, depth, area, table.terms, table.zeta,
                                         rft.REGULARISATION_SPEED)[0]

    force, analytic = _core.rft3d_element_loads(normal, velocity, depth, area, table.terms, table.zeta,
                                                rft.REGULARISATION_SPEED, True)
    assert np.array_equal(force, rft3d.element_forces(normal, velocity, depth, area, table))
    h = 1e-6 * speed
    numeric = np.stack([(forces(velocity + h * e) - forces(velocity - h * e)) / (2 * h) for e in np.eye(3)], axis=2)
    # a kink (n·v = v_ε, |v_h| = v_ε or n·v = 0) within h of an element spoils its difference: leave those out
    normal_speed, horizontal = np.sum(normal * velocity, axis=1), np.hypot(velocity[:, 0], velocity[:, 1])
    smooth = (np.abs(normal_speed - rft.REGULARISATION_SPEED) > 10 * h) & (np.abs(horizontal - rft.REGULARISATION_SPEED)
                                                                          > 10 * h) & (np.abs(normal_speed) > 10 * h)
    loaded = smooth & (np.abs(force).max(axis=1) > 0)
    assert loaded.sum() > 100
    scale = np.abs(numeric[loaded]).max(axis=(1, 2))[:, None, None]
    assert np.all(np.abs(analytic[loaded] - numeric[loaded]) <= 1e-5 * scale)


def _tumbling_box(element_length: float = 0.005):
    # a 1 kg box, its centre of mass at its frame, half in the sand, moving sideways and down and turning
    model = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><geom name="floor" type="plane" size="1 1 0.1"/><body name="b" pos="0 0 0.005" '
        'euler="10 -20 15"><freejoint/><geom type="box" size="0.04 0.03 0.02" mass="1"/></body></worldbody>'
        '</mujoco>')
    robot = rft_robot(model, element_length=element_length)
    robot.data.qvel[:] = [0.2, 0.1, -0.3, 1.0, -2.0, 0.5]
    return robot, RFT3DCoupling(robot)


def test_native_step_is_backward_euler_in_the_rft_force():
    # one step of the native stepper: m (v_{n+1} − v_n) = dt (m g + F) with F the RFT force at the step's end
    # velocities and its start pose, recomputed here by terrasph.terrain.rft3d.body_wrench (numpy sums of the law)
    robot, stepper = _tumbling_box()
    model, data = robot.model, robot.data
    mujoco.mj_forward(model, data)
    position, rotation = data.xpos[1].copy(), data.xmat[1].reshape(3, 3).copy()
    start = data.qvel.copy()
    stepper.reset_body_means()
    dt = stepper.step()
    end = data.qvel.copy()
    sample = stepper.body_sample(0)
    force, torque = rft3d.body_wrench(robot.coupled[0].elements, position, rotation, position, end[:3],
                                      rotation @ end[3:], robot.surface, stepper.table)
    assert np.linalg.norm(force) > 5.0  # well loaded: ~ its weight and more
    assert np.allclose(sample["force"], force, rtol=0, atol=1e-10 * np.linalg.norm(force))
    assert np.allclose(sample["torque"], torque, rtol=0, atol=1e-10 * np.linalg.norm(force) * 0.05)
    balance = model.body_mass[1] * (end[:3] - start[:3]) - dt * (model.body_mass[1] * model.opt.gravity + force)
    assert np.abs(balance).max() < 1e-7 * dt * np.linalg.norm(force)


def test_rft3d_checkpoint_continues_bit_for_bit(tmp_path):
    # the rover driven on the sand, checkpointed and continued by a fresh stepper restored from the file,
    # ends where the uninterrupted one does, bit for bit (MuJoCo's state and the load means)
    def rover():
        robot = rft_robot(ROVER, element_length=0.013)
        robot.data.ctrl[:] = 3.0
        return RFT3DCoupling(robot)

    whole = rover()
    whole.advance(0.06)
    whole.checkpoint(tmp_path / "c.h5")
    whole.advance(0.12)
    resumed = rover()
    resumed.restore(tmp_path / "c.h5")
    assert resumed.step_count == 60
    resumed.advance(0.12)
    assert np.array_equal(whole.robot.data.qpos, resumed.robot.data.qpos)
    assert np.array_equal(whole.robot.data.qvel, resumed.robot.data.qvel)
    for k in range(len(whole.robot.coupled)):
        assert np.array_equal(whole.body_sample(k)["force"], resumed.body_sample(k)["force"])
        assert np.array_equal(whole.body_sample(k)["torque"], resumed.body_sample(k)["torque"])


def test_rft3d_stepper_calls_its_controller_at_the_control_rate():
    # the native stepper takes a control interval's steps per call; the controller is called at its multiples
    _, stepper = _tumbling_box(0.01)
    calls = []
    taken = stepper.advance(0.05, control=lambda run: calls.append((run.time, run.control_span())))
    interval = rft_coupling.RFT_CONTROL_INTERVAL
    assert taken == stepper.step_count == round(0.05 / RFT3D_TIME_STEP)
    assert np.allclose([t for t, _ in calls], interval * np.arange(round(0.05 / interval)), rtol=0, atol=1e-12)
    assert all(span == pytest.approx(interval) for _, span in calls)
