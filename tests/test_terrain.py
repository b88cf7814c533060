"""terrasph.terrain.attach: a user's own compiled MuJoCo model and data on the sand, stepped in the
user's own loop (docs/terrain.md). gymnasium's ``ant.xml`` (3D RFT) and ``walker2d.xml`` (planar
RFT), unmodified: at rest the sand carries the robot's weight (Newton's first law: the loads per
body sum to m g), a saved state continues bit for bit, the step advances the time ``mj_step``
would, and a model the terrain cannot carry is refused, naming the item, before the model is
touched."""

from __future__ import annotations

import logging
import pathlib

import mujoco
import numpy as np
import pytest
from terrasph.config import ConfigError
from terrasph.terrain import SPH_BED, attach

gymnasium_assets = pytest.importorskip("gymnasium.envs.mujoco").__file__
ASSETS = pathlib.Path(gymnasium_assets).parent / "assets"


def _model(name: str) -> tuple[mujoco.MjModel, mujoco.MjData]:
    model = mujoco.MjModel.from_xml_path(str(ASSETS / name))
    return model, mujoco.MjData(model)


@pytest.mark.parametrize(("name", "terrain"), [("ant.xml", "rft3d"), ("walker2d.xml", "rft")])
def test_a_robot_at_rest_on_the_sand_is_carried_by_its_loads(name: str, terrain: str, caplog) -> None:
    """Dropped with its actuators idle, the robot comes to rest (2.5 s) on the sand; then the
    vertical loads of its coupled bodies sum to its weight (measured: within 1e-4 for both) and
    some body is below the surface. The floor's contacts are off and the log says so."""
    model, data = _model(name)
    with caplog.at_level(logging.WARNING):
        sand = attach(model, data, terrain)
    floor = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "floor")
    assert model.geom_contype[floor] == 0 and model.geom_conaffinity[floor] == 0
    assert "'floor'" in caplog.text and "switched off" in caplog.text
    steps = round(2.5 / model.opt.timestep)
    sand.step(steps)
    assert data.time == pytest.approx(steps * model.opt.timestep, rel=1e-9)
    sand.step(10)
    loads = sand.loads()
    assert list(loads) == list(sand.bodies) and all(load.shape == (6,) for load in loads.values())
    weight = float(model.body_subtreemass[0]) * 9.81
    assert sum(load[2] for load in loads.values()) == pytest.approx(weight, rel=0.02)
    assert np.abs(data.qvel).max() < 0.05
    assert max(sand.sinkage().values()) > 0.0
    assert model.opt.timestep == _model(name)[0].opt.timestep  # the model's own step, as its users read it


@pytest.mark.parametrize(("name", "terrain"), [("ant.xml", "rft3d"), ("walker2d.xml", "rft"), ("walker2d.xml", "sph")])
def test_a_saved_state_continues_bit_for_bit(name: str, terrain: str) -> None:
    model, data = _model(name)
    sand = attach(model, data, terrain)
    rng = np.random.default_rng(7)
    actions = rng.uniform(-1.0, 1.0, (12 if terrain == "sph" else 40, model.nu))  # the SPH's steps cost more

    def run(segment: np.ndarray) -> list[np.ndarray]:
        trace = []
        for action in segment:
            data.ctrl[:] = action
            sand.step(4)
            trace.append(np.concatenate([data.qpos, data.qvel, *sand.loads().values()]))
        return trace

    half = len(actions) // 2
    run(actions[:half])
    saved = sand.state()
    first = run(actions[half:])
    sand.restore(saved)
    again = run(actions[half:])
    assert all(np.array_equal(a, b) for a, b in zip(first, again))
    assert not np.array_equal(first[0], first[-1])  # the robot moved in between


def test_walker2d_stands_on_the_sph_bed_with_its_loads_per_body_and_no_grain_lost() -> None:
    """gymnasium's walker2d.xml dropped on a coarse (1 cm) SPH bed of glass beads: after 0.2 s its
    feet carry it (their vertical loads are upward and the other bodies, above the bed, feel none),
    the MuJoCo clock is the bed's, and no grain has left the domain."""
    model, data = _model("walker2d.xml")
    sand = attach(model, data, "sph")
    assert sand.surface == pytest.approx(SPH_BED["bed_depth"], abs=SPH_BED["spacing"])
    sand.step(100)
    loads = sand.loads()
    assert list(loads) == list(sand.bodies) and all(np.isfinite(load).all() for load in loads.values())
    assert loads["foot"][2] > 0 and loads["foot_left"][2] > 0 and loads["torso"][2] == 0.0
    assert data.time == pytest.approx(100 * model.opt.timestep, abs=sand.time_step)
    assert sand.leaked_grains == 0


@pytest.mark.parametrize("terrain", ["rft", "sph"])
def test_a_non_planar_model_on_a_planar_terrain_is_refused_naming_its_joint_before_any_change(terrain: str) -> None:
    model, data = _model("ant.xml")
    contacts = model.geom_contype.copy()
    with pytest.raises(ConfigError, match=rf"joint 'root' is a free joint.*terrain '{terrain}'.*terrain 'rft3d'"):
        attach(model, data, terrain)
    assert np.array_equal(model.geom_contype, contacts)  # the floor still on


@pytest.mark.parametrize(("change", "kwargs", "message"), [
    ("gravity", {}, r"'gravity' = \[1.0, 0.0, -9.81\] is invalid"),
    (None, {"terrain": "mud"}, r"'terrain' = 'mud' is invalid: allowed one of rft3d, rft"),
    (None, {"couple_below": 1e-3}, r"no body of the model has a collision geom lower than couple_below = 0.001"),
    (None, {"couple_below": -1.0}, r"'couple_below' = -1.0 is invalid"),
    (None, {"bodies": ["paw"]}, r"coupled body 'paw' is not a body of the MJCF model"),
    (None, {"spacing": 0.01}, r"'spacing' is not an option of terrain 'rft3d'"),
    (None, {"time_step": 0.0}, r"'time_step' = 0.0 is invalid"),
    (None, {"table": "marmalade"}, r"marmalade"),
    (None, {"terrain": "sph", "time_step": 1e-3}, r"'time_step' is not an option of terrain 'sph'"),
    ("massless", {"bodies": ["torso"]}, r"coupled body 'torso' has no mass"),
])
def test_bad_input_is_refused_in_one_line_naming_it(change: str | None, kwargs: dict, message: str) -> None:
    model, data = _model("ant.xml")
    if change == "gravity":
        model.opt.gravity[:] = (1.0, 0.0, -9.81)
    if change == "massless":
        model.body_mass[1] = 0.0
    contacts = model.geom_contype.copy()
    with pytest.raises(ConfigError, match=message) as refused:
        attach(model, data, **kwargs)
    assert "\n" not in str(refused.value)
    assert np.array_equal(model.geom_contype, contacts)


def test_a_body_too_light_for_the_sph_coupling_is_refused_naming_it() -> None:
    """The explicit SPH coupling throws a body lighter than MIN_MASS_RATIO × the grains it displaces
    off the bed (docs/robots.md): a walker whose left foot weighs a gram is refused before any step."""
    model, data = _model("walker2d.xml")
    model.body_mass[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "foot_left")] = 1e-3
    with pytest.raises(ConfigError, match=r"coupled body 'foot_left' is too light for the coupling"):
        attach(model, data, "sph")
    assert data.time == 0.0


def _settled_ant(time_step: float | None) -> tuple[float, float]:
    """gymnasium's ant dropped on the 3D RFT sand and settled 2 s at substeps of `time_step` (None: attach's
    default): its ankles' mean sinkage (m) and the sand's lift over its weight, in the last 0.5 s."""
    model, data = _model("ant.xml")
    sand = attach(model, data, "rft3d", **({} if time_step is None else {"time_step": time_step}))
    sand.step(round(1.5 / model.opt.timestep))
    sand.step(round(0.5 / model.opt.timestep))
    lift = sum(load[2] for load in sand.loads().values()) / (float(model.body_subtreemass[0]) * 9.81)
    sinkage = sand.sinkage()
    return float(np.mean([sinkage[name] for name in sand.bodies if name.endswith("ankle")])), lift


def test_ant_at_the_default_substep_rests_where_the_converged_substep_puts_it() -> None:
    """Ant at attach's default substep (RFT3D_SUBSTEP, 5 ms) against the same drop at 0.25 ms, the
    converged reference of benchmarks/studies/sand_substeps.py: at rest the sand carries its weight
    (measured 1.0000 over the last 0.5 s; with Newton's 6 halvings it never came to rest, its lift
    swinging 0.78–1.07 × the weight) and its ankles sink within 0.3 mm of the reference's 13 mm
    (measured 0.17 mm at 5 ms, 0.02 mm at 1 ms: the error shrinks with the substep)."""
    reference, _ = _settled_ant(2.5e-4)
    default, lift = _settled_ant(None)
    fine, _ = _settled_ant(1e-3)
    assert lift == pytest.approx(1.0, abs=1e-3)
    assert abs(default - reference) < 3e-4
    assert abs(fine - reference) < 0.5 * abs(default - reference)


@pytest.mark.parametrize("scene", ["leg-wheel", "mjcf"])
def test_a_scene_of_terrasph_stands_on_the_same_terrain_as_attach_gives(scene: str) -> None:
    """terrasph's own robot scenes build their terrain by the construction attach uses
    (terrasph.terrain.interface.couple): the leg-wheel on planar RFT and the four-wheeled rover on 3D
    RFT are Terrains a user's loop steps like attach's; at rest (1 s, motors idle) the sand carries
    each robot's weight (Newton's first law; measured within 1e-6 for both)."""
    from terrasph.robots import ROVER4
    from terrasph.scenes.leg_wheel import LegWheel, build_leg_wheel
    from terrasph.scenes.mjcf_scene import MjcfScene, build_mjcf
    from terrasph.terrain.interface import RFTTerrain

    if scene == "leg-wheel":
        sand, kind, root = build_leg_wheel(LegWheel(terrain="rft")), "rft", 1  # the rig's chassis carries the load
    else:
        sand, kind, root = build_mjcf(MjcfScene(model=str(ROVER4), terrain="rft", element_length=0.03)), "rft3d", 0
    assert isinstance(sand, RFTTerrain) and sand.kind == kind
    sand.step(round(1.0 / sand.model.opt.timestep))
    sand.step(5)
    weight = float(sand.model.body_subtreemass[root]) * -float(sand.model.opt.gravity[2])
    assert sum(load[2] for load in sand.loads().values()) == pytest.approx(weight, rel=1e-4)
    assert np.abs(sand.data.qvel).max() < 0.01 and max(sand.sinkage().values()) > 0.0


def test_a_run_and_a_loop_step_the_same_sph_terrain_in_turn() -> None:
    """Terrain.advance (a run's stepping) and Terrain.step (a user's) on one SPH terrain of the
    leg-wheel scene: after advancing to t the next step(1) ends one model step later, to within
    one SPH step, as step alone would."""
    from terrasph.scenes.leg_wheel import LegWheel, build_leg_wheel

    sand = build_leg_wheel(LegWheel(wheel="c-leg", spacing=0.005, thickness=0.015, leg_length=0.04, bed_width=0.2,
                                    bed_depth=0.04, start_x=0.08, load=2.0))
    taken = sand.advance(0.004)
    assert taken > 0 and sand.coupling.time >= 0.004
    sand.step(1)
    assert sand.coupling.time == pytest.approx(0.004 + sand.model.opt.timestep, abs=sand.time_step)
    assert sand.leaked_grains == 0
