"""terrasph.terrain.attach(..., terrain="sph3d"): a 3D MuJoCo model on a 3D SPH bed of glass beads
(docs/sph3d.md, docs/terrain.md). The MJCF geoms become particle shells where MuJoCo places them;
gymnasium's ``ant.xml``, unmodified, at rest on a coarse bed is carried by the grains (Newton's
first law: the bodies' vertical loads sum to m g) with no grain lost; a saved state continues bit
for bit; what the terrain cannot take is refused by name before the model is touched."""

from __future__ import annotations

import pathlib

import mujoco
import numpy as np
import pytest
from terrasph.config import ConfigError
from terrasph.geometry import wall_layers_needed
from terrasph.robots import LEG_WHEEL3D
from terrasph.terrain import attach

gymnasium_assets = pytest.importorskip("gymnasium.envs.mujoco").__file__
ANT = pathlib.Path(gymnasium_assets).parent / "assets" / "ant.xml"

#: one body with a geom of each filled type, each moved and turned within the body, the body turned too
SHAPES_XML = """
<mujoco>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="probe" pos="0.1 -0.05 0.45" euler="20 10 35">
      <freejoint/>
      <geom name="ball" type="sphere" size="0.06" pos="0.15 0 0"/>
      <geom name="pill" type="capsule" size="0.05 0.08" pos="-0.1 0.05 0" euler="0 70 10"/>
      <geom name="can" type="cylinder" size="0.05 0.06" pos="0 -0.15 0.02" euler="40 0 0"/>
      <geom name="brick" type="box" size="0.08 0.06 0.05" pos="0 0.15 -0.05" euler="0 0 30"/>
      <geom name="egg" type="ellipsoid" size="0.07 0.05 0.04" pos="0.05 0.05 0.1" euler="10 20 30"/>
    </body>
  </worldbody>
</mujoco>
"""


def _local(data: mujoco.MjData, geom: int, points: np.ndarray) -> np.ndarray:
    """World points in the geom's frame as MuJoCo places it (geom_xpos, geom_xmat)."""
    return (points - data.geom_xpos[geom]) @ data.geom_xmat[geom].reshape(3, 3)


def test_each_geom_is_a_shell_where_mujoco_places_it() -> None:
    """The body's particles, at the body's pose in the bed, each lie inside one of its geoms as
    MuJoCo's own forward kinematics places them, within the wall layers' thickness of its surface
    (the geom's solid distance function: sphere, capsule, cylinder, box), and each geom holds about
    its shell's volume / Δx³ particles (within 15 %: the lattice cuts a 5 cm solid at Δx = 1 cm; the
    ellipsoid's inner surface taken as the ellipsoid of semi-axes less the layers)."""
    model = mujoco.MjModel.from_xml_string(SHAPES_XML)
    data = mujoco.MjData(model)
    spacing = 0.01
    sand = attach(model, data, "sph3d", spacing=spacing, bed_depth=0.05)
    core = sand.coupling.core
    points = np.asarray(core.wall_position)[np.asarray(core.wall_body) == 0]
    layers = wall_layers_needed(sand.coupling.numerics.h_factor) * spacing
    ids = {name: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, name) for name in ("ball", "pill", "can", "brick")}
    size = {name: model.geom_size[g] for name, g in ids.items()}
    depth = {}
    p = _local(data, ids["ball"], points)
    depth["ball"] = size["ball"][0] - np.linalg.norm(p, axis=1)
    p = _local(data, ids["pill"], points)
    axis = np.column_stack([np.zeros((len(p), 2)), np.clip(p[:, 2], -size["pill"][1], size["pill"][1])])
    depth["pill"] = size["pill"][0] - np.linalg.norm(p - axis, axis=1)
    p = _local(data, ids["can"], points)
    depth["can"] = np.minimum(size["can"][0] - np.linalg.norm(p[:, :2], axis=1), size["can"][1] - np.abs(p[:, 2]))
    p = _local(data, ids["brick"], points)
    depth["brick"] = (size["brick"][:3] - np.abs(p)).min(axis=1)
    egg = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "egg")
    scaled = np.linalg.norm(_local(data, egg, points) / model.geom_size[egg], axis=1)
    # a lower bound of the depth below an ellipsoid's surface: (1 − F) × its smallest semi-axis
    depth["egg"] = (1.0 - scaled) * model.geom_size[egg].min()
    slack = 1e-9
    inside = {name: (d >= -slack) & (d < layers + slack) for name, d in depth.items()}
    inside["egg"] = (depth["egg"] >= -slack) & (depth["egg"] < layers + 0.5 * spacing)
    assert np.all(np.any(np.column_stack(list(inside.values())), axis=1))
    r, half = size["ball"][0], None
    volumes = {"ball": 4 / 3 * np.pi * (r**3 - max(r - layers, 0.0) ** 3)}
    r, half = size["pill"][0], size["pill"][1]
    inner = max(r - layers, 0.0)
    volumes["pill"] = np.pi * (r**2 - inner**2) * 2 * half + 4 / 3 * np.pi * (r**3 - inner**3)
    r, half = size["can"][0], size["can"][1]
    volumes["can"] = np.pi * r**2 * 2 * half - np.pi * max(r - layers, 0) ** 2 * max(2 * half - 2 * layers, 0)
    b = size["brick"][:3]
    volumes["brick"] = np.prod(2 * b) - np.prod(np.clip(2 * b - 2 * layers, 0, None))
    a = model.geom_size[egg]
    volumes["egg"] = 4 / 3 * np.pi * (np.prod(a) - np.prod(a - layers))
    for name, volume in volumes.items():
        alone = inside[name] & ~np.any(np.column_stack([v for k, v in inside.items() if k != name]), axis=1)
        assert inside[name].sum() >= alone.sum()
        assert inside[name].sum() == pytest.approx(volume / spacing**3, rel=0.15), name


def test_what_the_3d_terrain_cannot_take_is_refused_before_the_model_is_touched() -> None:
    """A mesh (not filled), bad bed options and an RFT table, each named, the floor still on."""
    xml = SHAPES_XML.replace('<worldbody>', '<asset><mesh name="tetra" vertex="0 0 0 0.1 0 0 0 0.1 0 0 0 0.1"/></asset>'
                             '<worldbody>').replace('type="sphere" size="0.06"', 'type="mesh" mesh="tetra"')
    cases = [(xml, {}, "'ball' .* is a mesh"), (SHAPES_XML, {"spacing": -0.01}, "spacing"),
             (SHAPES_XML, {"bed_size": (1.0,)}, "bed_size"), (SHAPES_XML, {"bed_depth": float("nan")}, "bed_depth"),
             (SHAPES_XML, {"table": "sand"}, "table"), (SHAPES_XML, {"fidelity": "best"}, "best"),
             (SHAPES_XML, {"element_length": 0.01}, "element_length"),
             (SHAPES_XML, {"spacing": 0.04}, "thickness")]
    for text, options, named in cases:
        model = mujoco.MjModel.from_xml_string(text)
        data = mujoco.MjData(model)
        with pytest.raises(ConfigError, match=named):
            attach(model, data, "sph3d", **{"spacing": 0.01, **options})
        assert model.geom_contype[0] == 1 and model.geom_conaffinity[0] == 1


#: a slab whose centre of mass is 8.5 cm off its frame's origin
SLAB_XML = """
<mujoco>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="slab" pos="0 0 0.05">
      <freejoint/>
      <inertial pos="0.08 0.03 0" mass="5" diaginertia="0.05 0.05 0.08"/>
      <geom type="box" size="0.15 0.15 0.05" mass="0"/>
    </body>
  </worldbody>
</mujoco>
"""


def test_the_load_is_about_the_centre_of_mass() -> None:
    """A slab with its centre of mass 8.5 cm off its frame's origin, laid on the bed from MuJoCo's
    floor, comes to rest: the sand's load then balances gravity acting at the centre of mass, so its
    torque about the centre of mass (what xfrc_applied takes) vanishes — below 5 % of m g × the
    offset (measured 0.12 %; about the frame's origin it would be 100 %) — and its force is m g
    within 2 % (measured 0.002 %)."""
    model = mujoco.MjModel.from_xml_string(SLAB_XML)
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, 100)
    sand = attach(model, data, "sph3d", spacing=0.025, bed_depth=0.1, bed_margin=0.1)
    sand.step(75)
    sand.step(25)  # the mean over its last 0.05 s
    load = sand.loads()["slab"]
    weight = 5.0 * 9.81
    assert load[2] == pytest.approx(weight, rel=0.02)
    assert np.hypot(load[3], load[4]) < 0.05 * weight * np.hypot(0.08, 0.03)
    assert sand.leaked_grains == 0


@pytest.fixture(scope="module")
def ant_at_rest() -> dict:
    """gymnasium's ant.xml, unmodified, settled 2 s on MuJoCo's floor (its legs at their joint limits),
    then attached to a 3D SPH bed at Δx = 5 cm and run 1 s with its actuators idle: the mean vertical
    load over 0.5–1 s, and the terrain with its state at 1 s."""
    model = mujoco.MjModel.from_xml_path(str(ANT))
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, 200)
    sand = attach(model, data, "sph3d", spacing=0.05)
    step = model.opt.timestep
    sand.step(round(0.5 / step))
    lift = []
    for _ in range(10):
        sand.step(5)
        lift.append(sum(load[2] for load in sand.loads().values()))
    return {"model": model, "data": data, "sand": sand, "lift": float(np.mean(lift)),
            "weight": float(model.body_subtreemass[0]) * 9.81}


def test_the_ant_at_rest_is_carried_by_the_grains(ant_at_rest: dict, caplog) -> None:
    """Lift / weight within 2 % over 0.5–1 s (measured 1.002; Newton's first law for a body at rest),
    no grain leaked, the ant still, every body with a collision geom coupled; it stands on its four
    ankles (the only bodies touching MuJoCo's floor before): theirs the lowest particles, within a
    spacing of the surface (a body's particles are cell centres, half a spacing inside its geoms),
    and theirs the load."""
    sand, data = ant_at_rest["sand"], ant_at_rest["data"]
    assert ant_at_rest["lift"] / ant_at_rest["weight"] == pytest.approx(1.0, abs=0.02)
    assert sand.leaked_grains == 0
    assert abs(data.qvel[2]) < 0.05
    ankles = ("left_ankle", "right_ankle", "third_ankle", "fourth_ankle")
    sinkage = sand.sinkage()
    assert len(sand.bodies) == 13 and all(name in sand.bodies for name in ankles)
    assert min(sinkage[name] for name in ankles) > max(v for k, v in sinkage.items() if k not in ankles)
    assert all(abs(sinkage[name]) < 0.05 for name in ankles)
    loads = sand.loads()
    assert sum(loads[name][2] for name in ankles) == pytest.approx(sum(load[2] for load in loads.values()), rel=0.02)
    assert ant_at_rest["model"].opt.timestep == 0.01  # the model's own step, as its users read it


def test_a_saved_3d_state_continues_bit_for_bit(ant_at_rest: dict) -> None:
    """state() then a segment of random actions; restore() and the same segment: the same qpos,
    grains and loads to the bit."""
    sand, model, data = ant_at_rest["sand"], ant_at_rest["model"], ant_at_rest["data"]
    actions = np.random.default_rng(3).uniform(-1.0, 1.0, (8, model.nu))
    saved = sand.state()

    def run() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        for action in actions:
            data.ctrl[:] = action
            sand.step()
        loads = np.array(list(sand.loads().values()))
        return data.qpos.copy(), np.array(sand.coupling.core.position), loads

    first = run()
    sand.restore(saved)
    second = run()
    for a, b in zip(first, second):
        np.testing.assert_array_equal(a, b)


def test_a_run_advances_with_the_terrains_integrator(ant_at_rest: dict) -> None:
    """Terrain.advance (a run's stepping: terrasph.robots.run.run_coupled) integrates with the
    terrain's integrator, as Terrain.step does: attach's semi-implicit Euler in every coupled step
    of the Ant (RK4 in its file), the model's own integrator back when it returns."""
    sand, model = ant_at_rest["sand"], ant_at_rest["model"]
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4
    seen = []
    taken = sand.advance(sand.coupling.time + 0.01, control=lambda _: seen.append(int(model.opt.integrator)))
    assert taken == len(seen) > 0
    assert set(seen) == {int(mujoco.mjtIntegrator.mjINT_EULER)}
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4


def test_the_coupled_3d_run_is_the_same_on_one_two_and_three_threads(restore_threads) -> None:
    """The slab of the torque test dropped 2 cm onto the bed and rocked by random pushes (0.1 s):
    the same qpos, grains and loads to the bit whatever the thread count."""
    from terrasph import _core

    results = []
    pushes = np.random.default_rng(5).normal(0.0, 20.0, (10, 6))
    for threads in (1, 2, 3):
        _core.set_num_threads(threads)
        model = mujoco.MjModel.from_xml_string(SLAB_XML.replace('pos="0 0 0.05"', 'pos="0 0 0.07"'))
        data = mujoco.MjData(model)
        sand = attach(model, data, "sph3d", spacing=0.025, bed_depth=0.1, bed_margin=0.2)
        for push in pushes:
            data.qfrc_applied[:] = push
            sand.step(5)
        results.append((data.qpos.copy(), np.array(sand.coupling.core.position), sand.loads()["slab"]))
    assert results[0][2][2] > 0.0  # the slab is on the grains
    for other in results[1:]:
        for a, b in zip(results[0], other):
            np.testing.assert_array_equal(a, b)


def test_a_body_reaching_the_beds_side_stops_the_run_by_name() -> None:
    """The slab pushed sideways along the sand toward the near side of a narrow bed: the step that
    brings it within a kernel support and a spacing of the side wall raises InstabilityError naming
    the body, before its particles reach the wall's inner face."""
    from terrasph import InstabilityError

    model = mujoco.MjModel.from_xml_string(SLAB_XML)
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, 100)
    sand = attach(model, data, "sph3d", spacing=0.025, bed_depth=0.1, bed_margin=0.15)
    sand.step(25)
    data.qvel[0] = 1.0  # 1 m/s toward +x, the side 15 cm away
    with pytest.raises(InstabilityError, match="'slab' reached a side of the 3D bed"):
        sand.step(150)
    core = sand.coupling.core
    body_x = np.asarray(core.wall_position)[np.asarray(core.wall_body) == 0, 0]
    assert body_x.max() < sand.coupling.sides[1][0]


@pytest.mark.slow
def test_the_four_wheeled_rover_drives_on_the_3d_bed() -> None:
    """terrasph's rover4.xml (a chassis on four wheels, velocity servos) settled 0.3 s on a bed 10 cm
    deep at Δx = 1.5 cm, then its wheels commanded 3 rad/s for 0.5 s: it rolls forward with slip
    between 0 and 1 (travel 0 < x < ω R t = 9 cm), the grains carry its weight over the drive within
    5 % on average (a body rolling steadily: Newton's first law vertically), no grain leaks."""
    model = mujoco.MjModel.from_xml_path(str(pathlib.Path(__file__).parents[1] / "python" / "terrasph" / "robots"
                                             / "models" / "rover4.xml"))
    data = mujoco.MjData(model)
    sand = attach(model, data, "sph3d", spacing=0.015, bed_depth=0.1, bed_margin=0.25)
    sand.step(150)
    x0 = float(data.qpos[0])
    data.ctrl[:] = 3.0
    lift = []
    for _ in range(10):
        sand.step(25)
        lift.append(sum(load[2] for load in sand.loads().values()))
    travel = float(data.qpos[0]) - x0
    assert 0.01 < travel < 3.0 * 0.06 * 0.5
    assert np.mean(lift) == pytest.approx(float(model.body_subtreemass[0]) * 9.81, rel=0.05)
    assert sand.leaked_grains == 0


@pytest.mark.slow
def test_the_narrow_leg_wheel_rests_on_the_3d_bed() -> None:
    """terrasph's leg_wheel3d.xml (chapter 4's rig: a chassis sliding in x and z over three C-legs of
    box geoms, 5 cm wide) dropped 5 mm onto a bed 3 cm deep and 10 cm broad at Δx = 5 mm (its legs
    three particle rows thick), its servo holding the wheel: over 0.25–0.4 s the grains carry the
    rig's weight within 3 % (Newton's first law for a body at rest; measured 1.001, single 0.05 s
    windows within 2.3 %), the rig is still, the wheel stands in the sand but above the floor, no
    grain leaks."""
    model = mujoco.MjModel.from_xml_path(str(LEG_WHEEL3D))
    data = mujoco.MjData(model)
    sand = attach(model, data, "sph3d", spacing=0.005, bed_size=(0.24, 0.1), bed_depth=0.03, freeboard=0.03)
    weight = float(model.body_subtreemass[1]) * 9.81
    sand.step(250)
    lift = []
    for _ in range(3):
        sand.step(50)
        lift.append(float(sand.loads()["wheel"][2]))
    assert np.mean(lift) == pytest.approx(weight, rel=0.03)
    assert abs(data.qvel[1]) < 0.02
    assert 0.0 < sand.sinkage()["wheel"] < 0.03
    assert sand.leaked_grains == 0
