"""The MuJoCo engine plugin ``terrasph.rft`` (terrasph.mujoco_plugin, cpp/plugin/rft_plugin.cpp): it
loads and registers; its load on bodies of every solid geom kind is terrasph.terrain.rft3d's (the elements
built in Python by terrasph.mjcf.geoms, the wrench assembled in numpy) and enters qfrc_passive as
Jᵀ W; a body resting on the sand carries its weight; its implicit correction steps as terrasph's 3D RFT
stepper does (terrasph.terrain.rft3d_coupling); runs and copies are deterministic; bad configuration
fails in one line naming the attribute; gymnasium's ant with the plugin stands and walks; the package's
entry point registers the plugin when mujoco is imported; threads stepping their own data and a model
saved to a binary file step alike."""

from __future__ import annotations

import concurrent.futures
import os
import pathlib
import re
import shutil
import subprocess
import sys

import mujoco
import numpy as np
import pytest
from terrasph import mujoco_plugin
from terrasph.terrain import rft, rft3d
from terrasph.terrain.rft3d_coupling import Body3D, RFT3DCoupling, Robot3D

gymnasium = pytest.importorskip("gymnasium")

ANT = pathlib.Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / "ant.xml"

#: a body of each solid geom kind, and one of two overlapping geoms (the union's inside dropped)
BODIES = {
    "sphere": '<geom type="sphere" size="0.04"/>',
    "capsule": '<geom type="capsule" size="0.02 0.05" euler="30 60 0"/>',
    "cylinder": '<geom type="cylinder" size="0.03 0.02" euler="0 80 10"/>',
    "ellipsoid": '<geom type="ellipsoid" size="0.05 0.03 0.02" euler="10 0 40"/>',
    "box": '<geom type="box" size="0.04 0.03 0.02" euler="0 20 0"/>',
    "mesh": '<geom type="mesh" mesh="wedge"/>',
    "union": '<geom type="box" size="0.04 0.02 0.02"/><geom type="sphere" size="0.025" pos="0.04 0 0"/>',
}
WEDGE = '<mesh name="wedge" vertex="0 0 0  0.06 0 0  0 0.05 0  0 0 0.04  0.06 0 0.04  0 0.05 0.04"/>'


@pytest.fixture(scope="module", autouse=True)
def plugin() -> pathlib.Path:
    return mujoco_plugin.load()


def sand(config: dict[str, str] | None = None) -> str:
    """The <extension> block naming the plugin with `config`."""
    keys = "".join(f'<config key="{k}" value="{v}"/>' for k, v in (config or {}).items())
    return (f'<extension><plugin plugin="{mujoco_plugin.PLUGIN_NAME}"><instance name="sand">{keys}</instance>'
            '</plugin></extension>')


def scattered_bodies(config: dict[str, str] | None = None) -> str:
    """Each of BODIES on a free joint, side by side, their centres at z = 0.01 (half in the sand)."""
    bodies = "".join(f'<body name="{name}" pos="{0.2 * k} 0 0.01"><freejoint/>{geom}</body>'
                     for k, (name, geom) in enumerate(BODIES.items()))
    return f'<mujoco><asset>{WEDGE}</asset>{sand(config)}<worldbody>{bodies}</worldbody></mujoco>'


def reference_wrench(model: mujoco.MjModel, data: mujoco.MjData, body: int, surface: float,
                     table: rft.RFTCoefficients, regularisation: float = rft.REGULARISATION_SPEED) -> np.ndarray:
    """terrasph.terrain.rft3d's wrench (F, τ about the centre of mass) on `body` at the data's state: the
    elements from the Python geoms (BodyElements.from_body), the assembly in numpy."""
    twist = np.zeros(6)
    mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_BODY, body, twist, 0)
    force, torque = rft3d.body_wrench(rft3d.BodyElements.from_body(model, body), data.xpos[body],
                                      data.xmat[body].reshape(3, 3), data.xipos[body], twist[3:], twist[:3],
                                      surface, table, regularisation)
    return np.concatenate([force, torque])


def random_motion(model: mujoco.MjModel, data: mujoco.MjData, seed: int) -> None:
    """A random pose near the surface and random velocities (some slow: the regularisation's ramp)."""
    rng = np.random.default_rng(seed)
    for j in range(model.njnt):
        q, v = model.jnt_qposadr[j], model.jnt_dofadr[j]
        quaternion = rng.normal(size=4)
        data.qpos[q + 2] += rng.uniform(-0.01, 0.01)
        data.qpos[q + 3:q + 7] = quaternion / np.linalg.norm(quaternion)
        data.qvel[v:v + 6] = rng.normal(scale=[0.2, 0.2, 0.2, 3.0, 3.0, 3.0]) * (1e-3 if j % 3 == 0 else 1.0)
    mujoco.mj_forward(model, data)


def test_load_is_idempotent_and_registers_the_plugin():
    assert mujoco_plugin.load() == mujoco_plugin.load() == mujoco_plugin.library_path()
    model = mujoco.MjModel.from_xml_string(scattered_bodies())
    assert model.nplugin == 1
    assert mujoco_plugin.coupled_bodies(model, "sand") == list(range(1, len(BODIES) + 1))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_wrench_is_the_python_rft3d_law_on_every_geom_kind(seed):
    model = mujoco.MjModel.from_xml_string(scattered_bodies({"surface": "0.005"}))
    data = mujoco.MjData(model)
    random_motion(model, data, seed)
    loads = mujoco_plugin.body_wrenches(model, data)
    loaded = 0
    for name, wrench in loads.items():
        body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
        expected = reference_wrench(model, data, body, 0.005, rft.GENERIC)
        scale = np.abs(expected).max()
        loaded += scale > 0
        assert np.abs(wrench - expected).max() <= 1e-11 * scale, name  # round-off: the elements' sums' order
    assert loaded >= len(BODIES) - 1  # nearly every body meets the sand (a random pose may lift one out)


def test_passive_force_is_the_wrench_through_the_jacobian():
    model = mujoco.MjModel.from_xml_string(scattered_bodies())
    data = mujoco.MjData(model)
    random_motion(model, data, 3)
    expected = np.zeros(model.nv)
    for name, wrench in mujoco_plugin.body_wrenches(model, data).items():
        body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
        linear, angular = np.zeros((3, model.nv)), np.zeros((3, model.nv))
        mujoco.mj_jacBodyCom(model, data, linear, angular, body)
        expected += linear.T @ wrench[:3] + angular.T @ wrench[3:]
    assert np.abs(expected).max() > 1.0  # the sand loads the bodies
    assert np.abs(data.qfrc_passive - expected).max() <= 1e-12 * np.abs(expected).max()  # no springs, no damping


def test_table_file_and_coefficients_give_their_map(tmp_path):
    softer = rft.GENERIC.with_zeta(1.2e5)
    path = rft.save_coefficients(softer, tmp_path / "soft.json")
    terms = " ".join(f"{k}={v!r}" for k, v in rft.GENERIC.coefficients.items())
    for config in ({"table": str(path)}, {"coefficients": terms, "zeta": "1.2e5"}, {"zeta": "1.2e5"}):
        model = mujoco.MjModel.from_xml_string(scattered_bodies(config))
        data = mujoco.MjData(model)
        random_motion(model, data, 4)
        wrench = mujoco_plugin.body_wrenches(model, data)["box"]
        expected = reference_wrench(model, data, 5, 0.0, softer)
        assert np.abs(expected).max() > 0
        assert np.abs(wrench - expected).max() <= 1e-11 * np.abs(expected).max(), config


def resting(geom: str, integrator: str, dt: float, implicit: bool, t_end: float) -> tuple[np.ndarray, float]:
    """The vertical load (N) per step on a body dropped onto the sand, and its weight (N)."""
    xml = (f'<mujoco><option timestep="{dt}" integrator="{integrator}"/>{sand({"implicit": str(implicit).lower()})}'
           f'<worldbody><body name="b" pos="0 0 0.03"><freejoint/>{geom}</body></worldbody></mujoco>')
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    load = np.empty(round(t_end / dt))
    for k in range(len(load)):
        mujoco.mj_step(model, data)
        load[k] = mujoco_plugin.body_wrenches(model, data)["b"][2]
    return load, float(model.body_subtreemass[1] * -model.opt.gravity[2])


@pytest.mark.parametrize("geom", ['<geom type="sphere" size="0.05" density="2000"/>',
                                  '<geom type="box" size="0.05 0.04 0.02" density="2000"/>'])
def test_resting_body_carries_its_weight(geom):
    # the implicit correction: at rest, backward Euler's balance is exact to the Newton tolerance (1e-8)
    load, weight = resting(geom, "Euler", 1e-3, True, 1.0)
    assert np.abs(load[-300:] / weight - 1).max() < 1e-6
    # the explicit load (Euler, one evaluation per step) flips between none and about twice the weight
    # from step to step; its mean over 0.3 s carries the weight (momentum; measured within 0.1 % for both
    # bodies with Euler and implicitfast at 1e-3 and 5e-4 s)
    load, weight = resting(geom, "Euler", 1e-3, False, 1.0)
    assert load[-300:].mean() / weight == pytest.approx(1.0, abs=0.005)


def test_implicit_correction_steps_as_the_rft3d_stepper():
    # a box thrown sideways and spinning onto the sand: the plugin's correction (in a plain mj_step loop)
    # and terrasph's native 3D stepper (loads through xfrc_applied) on the same elements agree to round-off
    body = ('<body name="b" pos="0 0 0.04"><freejoint/><geom type="box" size="0.05 0.03 0.02" density="1500"/>'
            '<geom type="capsule" size="0.01 0.03" pos="0 0.03 -0.02" euler="0 90 0" density="1500"/></body>')
    xml = '<mujoco><option timestep="1e-3" integrator="Euler"/>{}<worldbody>' + body + '</worldbody></mujoco>'
    model = mujoco.MjModel.from_xml_string(xml.format(sand()))
    data = mujoco.MjData(model)
    plain = mujoco.MjModel.from_xml_string(xml.format(""))
    plain_data = mujoco.MjData(plain)
    for d in (data, plain_data):
        d.qvel[:] = [0.3, 0.1, -0.2, 1.0, -2.0, 3.0]
    mujoco.mj_forward(plain, plain_data)
    stepper = RFT3DCoupling(Robot3D(plain, plain_data, [Body3D("b", 1, rft3d.BodyElements.from_body(plain, 1))], 0.0),
                            time_step=1e-3)
    for _ in range(400):
        mujoco.mj_step(model, data)
        stepper.step()
    assert data.qpos[2] < 0.02  # it sank into the sand
    assert np.abs(data.qpos - plain_data.qpos).max() < 1e-10
    assert np.abs(data.qvel - plain_data.qvel).max() < 1e-8


@pytest.mark.parametrize("integrator", ["Euler", "implicitfast", "RK4"])
def test_runs_and_copies_are_deterministic(integrator, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # RK4's warning goes to MuJoCo's log file in the working directory
    xml = scattered_bodies().replace("<asset>", f'<option timestep="1e-3" integrator="{integrator}"/><asset>', 1)
    model = mujoco.MjModel.from_xml_string(xml)
    first, second = mujoco.MjData(model), mujoco.MjData(model)
    for _ in range(100):
        mujoco.mj_step(model, first)
        mujoco.mj_step(model, second)
    copy = mujoco.MjData(model)
    mujoco.mj_copyData(copy, model, first)
    del first  # the copy owns its own elements
    for _ in range(100):
        mujoco.mj_step(model, copy)
        mujoco.mj_step(model, second)
    assert np.abs(second.qvel).max() > 0 and np.array_equal(copy.qpos, second.qpos)
    assert np.array_equal(copy.qvel, second.qvel) and np.array_equal(copy.plugin_state, second.plugin_state)


def test_threads_step_their_own_data_alike():
    # no state shared between mjData: two threads stepping two copies give the single thread's states
    model = mujoco.MjModel.from_xml_string(scattered_bodies().replace("<asset>", '<option integrator="Euler"/><asset>'))

    def run(_: int) -> np.ndarray:
        data = mujoco.MjData(model)
        random_motion(model, data, 6)
        for _ in range(100):
            mujoco.mj_step(model, data)
        return np.concatenate([data.qpos, data.qvel, data.plugin_state])

    alone = run(0)
    with concurrent.futures.ThreadPoolExecutor(2) as pool:
        together = list(pool.map(run, range(2)))
    assert all(np.array_equal(alone, state) for state in together)


def test_model_saved_and_loaded_keeps_the_sand(tmp_path):
    # the instance's configuration is part of the model: a binary model file steps as the original
    model = mujoco.MjModel.from_xml_string(scattered_bodies({"surface": "0.005", "zeta": "1.5e5"}))
    path = tmp_path / "sand.mjb"
    mujoco.mj_saveModel(model, str(path), None)
    loaded = mujoco.MjModel.from_binary_path(str(path))
    states = []
    for m in (model, loaded):
        data = mujoco.MjData(m)
        random_motion(m, data, 7)
        for _ in range(50):
            mujoco.mj_step(m, data)
        states.append(np.concatenate([data.qpos, data.plugin_state]))
    assert np.array_equal(*states)
    assert np.abs(states[0][model.nq:]).max() > 0  # the sand loaded the bodies


@pytest.mark.parametrize("config,message", [
    ({"table": "wet"}, "attribute 'table' = 'wet' is invalid"),
    ({"table": "/nonexistent/t.json"}, "attribute 'table' = '/nonexistent/t.json': the file cannot be read"),
    ({"coefficients": "A00=0.2 X11=1"}, "attribute 'coefficients': coefficient 'X11' is not a term's name"),
    ({"zeta": "-3"}, "attribute 'zeta' = '-3' is invalid: allowed a finite number > 0 (N/m^3)"),
    ({"surface": "low"}, "attribute 'surface' = 'low' is invalid: allowed a finite number (m)"),
    ({"element_length": "0"}, "attribute 'element_length' = '0' is invalid"),
    ({"regularisation": "fast"}, "attribute 'regularisation' = 'fast' is invalid"),
    ({"implicit": "yes"}, "attribute 'implicit' = 'yes' is invalid: allowed true or false"),
])
def test_bad_configuration_fails_naming_the_attribute(config, message):
    with pytest.raises(ValueError, match=re.escape("terrasph.rft: " + message)):
        mujoco.MjModel.from_xml_string(scattered_bodies(config))


def test_rk4_says_the_load_stays_explicit(tmp_path, monkeypatch):
    # MuJoCo's own warning channel (its log file in the working directory)
    monkeypatch.chdir(tmp_path)
    xml = scattered_bodies().replace("<asset>", '<option integrator="RK4"/><asset>', 1)
    mujoco.MjData(mujoco.MjModel.from_xml_string(xml))
    assert "terrasph.rft: with the RK4 integrator the sand's load is explicit" in (tmp_path / "MUJOCO_LOG.TXT").read_text()


def test_gravity_off_the_vertical_is_refused():
    xml = scattered_bodies().replace("<asset>", '<option gravity="0 -9.81 0"/><asset>', 1)
    with pytest.raises(ValueError, match=re.escape("terrasph.rft: option gravity = (0, -9.81, 0) is invalid for the "
                                                   "sand: allowed along -z")):
        mujoco.MjModel.from_xml_string(xml)


def test_sdf_geom_on_a_coupled_body_is_refused_by_name():
    # MuJoCo keeps planes and height fields on static bodies; a signed distance field (MuJoCo's own
    # torus plugin) may move, and the sand has no surface elements for it
    xml = ('<mujoco><extension><plugin plugin="mujoco.sdf.torus"><instance name="torus">'
           '<config key="radius1" value="0.1"/><config key="radius2" value="0.03"/></instance></plugin>'
           '<plugin plugin="terrasph.rft"><instance name="sand"/></plugin></extension>'
           '<asset><mesh name="torus"><plugin instance="torus"/></mesh></asset>'
           '<worldbody><body name="ring" pos="0 0 0.1"><freejoint/><geom name="tyre" type="sdf" mesh="torus">'
           '<plugin instance="torus"/></geom></body></worldbody></mujoco>')
    with pytest.raises(ValueError, match="geom 'tyre' of body 'ring' is not a solid the sand can load"):
        mujoco.MjModel.from_xml_string(xml)


def test_bodies_naming_the_instance_are_the_coupled_ones():
    xml = scattered_bodies().replace('<body name="box" pos="0.8 0 0.01"><freejoint/>',
                                     '<body name="box" pos="0.8 0 0.01"><freejoint/><plugin instance="sand"/>')
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    random_motion(model, data, 5)
    assert list(mujoco_plugin.body_wrenches(model, data)) == ["box"]


def test_gymnasium_ant_stands_and_walks_on_the_plugin_sand(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # RK4's warning goes to MuJoCo's log file in the working directory
    # ant.xml as gymnasium ships it (RK4 at 0.01 s), the plugin named in it and the floor's contacts off
    text = ANT.read_text()
    floor = '<geom conaffinity="1" condim="3" material="MatPlane" name="floor"'
    text = text.replace(floor, floor.replace('conaffinity="1"', 'contype="0" conaffinity="0"'))
    text = text.replace('<mujoco model="ant">', '<mujoco model="ant">' + sand(), 1)
    model = mujoco.MjModel.from_xml_string(text)
    data = mujoco.MjData(model)
    weight = float(model.body_subtreemass[1] * -model.opt.gravity[2])
    for _ in range(150):  # drops onto the sand and stands
        mujoco.mj_step(model, data)
    standing = data.qpos[2]
    rng = np.random.default_rng(0)
    load, lowest = [], np.inf
    for _ in range(60):  # 3 s of random actions, each held 0.05 s (Ant-v5's frame skip 5)
        data.ctrl[:] = rng.uniform(-1.0, 1.0, model.nu)
        for _ in range(5):
            mujoco.mj_step(model, data)
            load.append(sum(w[2] for w in mujoco_plugin.body_wrenches(model, data).values()))
            lowest = min(lowest, data.qpos[2])
    # stands: torso above its own radius (0.25 m) off the sand, legs carrying it (measured 0.39 m)
    assert 0.3 < standing < 0.6
    # walks: moved, never sank to the torso, no MuJoCo reset; the sand carries the weight on average
    # (momentum over 3 s; measured 0.94–1.06 over seeds 0–2 at 5 s)
    assert np.linalg.norm(data.qpos[:2]) > 0.2 and lowest > 0.2
    assert all(data.warning[w].number == 0 for w in (mujoco.mjtWarning.mjWARN_BADQACC, mujoco.mjtWarning.mjWARN_BADQVEL))
    assert np.mean(load) / weight == pytest.approx(1.0, abs=0.1)


def test_entry_point_registers_the_plugin_when_mujoco_is_imported(tmp_path):
    # pyproject's entry point, as an installed terrasph declares it: a fresh interpreter importing only
    # mujoco (no call of load()) compiles a model naming the plugin
    declared = (pathlib.Path(__file__).parents[1] / "pyproject.toml").read_text()
    target = re.search(r'\[project\.entry-points\."mujoco\.plugins"\]\nterrasph = "([^"]+)"', declared).group(1)
    info = tmp_path / "terrasph_entry-0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: terrasph-entry\nVersion: 0\n")
    (info / "entry_points.txt").write_text(f"[mujoco.plugins]\nterrasph = {target}\n")
    code = ("import mujoco, sys; m = mujoco.MjModel.from_xml_string(sys.argv[1]); "
            "print(m.nplugin, 'terrasph.mujoco_plugin' in sys.modules)")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), os.environ.get("PYTHONPATH", "")])}
    out = subprocess.run([sys.executable, "-c", code, scattered_bodies()], capture_output=True, text=True, env=env,
                         check=True)
    assert out.stdout.split() == ["1", "True"]


def test_cpp_program_loads_the_plugin(tmp_path):
    # cpp/examples/rft_plugin_step.cpp, linked to the mujoco wheel's library only: the plugin resolves
    # MuJoCo to the program's copy, and a ball resting on the sand carries its weight (implicit, Euler)
    compiler = shutil.which("g++") or pytest.skip("no C++ compiler")
    folder = pathlib.Path(mujoco.__file__).parent
    library = next(folder.glob("libmujoco.so.*"))
    program = tmp_path / "rft_plugin_step"
    subprocess.run([compiler, "-std=c++17", "-O1", f"-I{folder / 'include'}",
                    str(pathlib.Path(__file__).parents[1] / "cpp" / "examples" / "rft_plugin_step.cpp"), str(library),
                    f"-Wl,-rpath,{folder}", "-o", str(program)], check=True)
    model = tmp_path / "ball.xml"
    model.write_text(f'<mujoco><option timestep="1e-3" integrator="Euler"/>{sand()}<worldbody><body pos="0 0 0.05">'
                     '<freejoint/><geom type="sphere" size="0.05" density="2000"/></body></worldbody></mujoco>')
    out = subprocess.run([str(program), str(mujoco_plugin.library_path()), str(model), "800", "400"],
                         capture_output=True, text=True, check=True).stdout.split()
    weight = 2000 * 4 / 3 * np.pi * 0.05**3 * 9.81
    assert [float(v) for v in out[2::3]] == pytest.approx([weight, weight], rel=1e-6)
