"""Any planar MJCF model on the bed (scene ``mjcf``): gymnasium's hopper and half-cheetah, as the
suite ships them, from Python and the command line; the floor replaced, the bodies near it
coupled, bad models refused before any step naming the item.

Physical references: a robot at rest is carried by the grains (vertical load = its weight, Newton's
first law); positions against the numbers of the MJCF files themselves."""

from __future__ import annotations

import json
import logging
import os

import mujoco
import numpy as np
import pytest
from robot_helpers import assert_same_series, run_interrupted
from terrasph.cli import main
from terrasph.config import ConfigError
from terrasph.io import read_run
from terrasph.mjcf.model import load_model
from terrasph.mjcf.terrain_robot import terrain_robot
from terrasph.scenes.mjcf_scene import MjcfScene, build_mjcf, run_mjcf

gymnasium = pytest.importorskip("gymnasium")
ASSETS = os.path.join(os.path.dirname(gymnasium.__file__), "envs", "mujoco", "assets")
HOPPER = os.path.join(ASSETS, "hopper.xml")
CHEETAH = os.path.join(ASSETS, "half_cheetah.xml")
DX = 0.02
#: the hopper's motors hold its joints at their start angles (PD, N·m/rad and N·m·s/rad)
HOLD = tuple(f"{joint}=hold:2000,100" for joint in ("thigh_joint", "leg_joint", "foot_joint"))


def test_the_floor_is_replaced_by_the_bed_and_the_bodies_near_it_coupled(caplog) -> None:
    surface, x = 0.1, 0.4
    with caplog.at_level(logging.WARNING):
        robot = terrain_robot(HOPPER, DX, surface, x)
    assert "floor (geom 'floor') is replaced by the terrain" in caplog.text
    floor = mujoco.mj_name2id(robot.model, mujoco.mjtObj.mjOBJ_GEOM, "floor")
    assert robot.model.geom_contype[floor] == 0 and robot.model.geom_conaffinity[floor] == 0
    # hopper.xml: the foot capsule (radius 0.06) at z = 0.1 and the leg (0.04, half-length 0.25) at
    # z = 0.35 reach down to 0.04 and 0.06 m, under the default 0.15 m; thigh and torso do not
    assert [b.name for b in robot.coupled] == ["leg", "foot"]
    foot = robot.coupled[1]
    (outline,) = foot.shape.transformed_outline(robot.wrapped_angle(foot), tuple(robot.reference(foot)))
    assert outline[:, 1].min() == pytest.approx(surface + 0.04, abs=1e-6)
    assert robot.data.subtree_com[0][0] == pytest.approx(x, abs=1e-12)
    assert foot.width == pytest.approx(0.12)  # the foot capsule's diameter across the plane
    named = terrain_robot(HOPPER, DX, surface, x, bodies=("foot",), widths={"foot": 0.2})
    assert [(b.name, b.width) for b in named.coupled] == [("foot", 0.2)]


def test_a_hopper_left_standing_is_carried_by_the_bed() -> None:
    """gymnasium's hopper dropped 4 cm onto the bed, its joints held by its motors: once at rest
    (0.8–1.0 s) the grains carry its weight within 2 % (measured 0.9996 at this Δx, 0.9999 at 1 cm
    over 1.6–2 s: docs/mjcf.md), no grain leaks and the foot has sunk in."""
    config = MjcfScene(model=HOPPER, bed_width=0.8, bed_depth=0.1, spacing=DX, settle_time=0.0, t_end=1.0,
                       ctrl=HOLD)
    run = run_mjcf(config)
    actuators = run.series["robot/actuators"]
    rest = actuators["time"] >= 0.8
    assert np.ptp(actuators["com"][rest, 1]) < 1e-3  # at rest: the centre of mass within 1 mm
    assert run.summary()["lift_over_weight"] == pytest.approx(1.0, abs=0.02)
    assert run.summary()["leaked_particles"] == 0
    assert run.summary()["foot_final_sinkage"] > 0


@pytest.mark.parametrize(("model", "extra"), [(HOPPER, HOLD), (CHEETAH, ())])
def test_the_shipped_models_run_from_the_command_line(tmp_path, capsys, model: str, extra: tuple[str, ...]) -> None:
    out = tmp_path / "run.h5"
    ctrl = [arg for spec in extra for arg in ("--ctrl", spec)]
    assert main(["run", "mjcf", model, "--bed-width", "1.6", "--bed-depth", "0.06", "--spacing", str(DX),
                 "--t-end", "0.04", "--settle-time", "0.02", *ctrl, "--out", str(out), "--no-progress"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["leaked_particles"] == 0 and (tmp_path / "run.png").is_file()
    series = read_run(out).series
    assert series["robot/actuators"]["ctrl"].shape[1] == load_model(model).nu  # MuJoCo's warnings as Python's
    for name in summary["coupled_bodies"]:
        assert np.isfinite(series[f"robot/{name}"]["sinkage"]).all()


# -- bad models, refused before any step ---------------------------------------------------------

def _model(tmp_path, body: str, option: str = "") -> str:
    path = tmp_path / "robot.xml"
    path.write_text(f'<mujoco><option {option}/><worldbody><geom name="ground" type="plane" size="2 2 0.1"/>'
                    f'{body}</worldbody><actuator/></mujoco>')
    return str(path)


PLANAR = '<joint name="x" type="slide" axis="1 0 0"/><joint name="z" type="slide" axis="0 0 1"/>'
FOOT = ('<body name="foot" pos="0 0 {z}">' + PLANAR
        + '{joint}<geom type="capsule" size="{r} 0.1" euler="0 90 0" {mass}/></body>')


@pytest.mark.parametrize(("body", "option", "message"), [
    (FOOT.format(z=0.1, r=0.03, joint='<joint name="wrist" type="ball"/>', mass=""), "",
     "joint 'wrist' is a ball joint"),
    (FOOT.format(z=0.1, r=0.03, joint="", mass=""), 'gravity="0 0 -5"', "gravity"),
    (FOOT.format(z=0.1, r=0.03, joint="", mass='mass="1e-6"'), "", "coupled body 'foot' is too light"),
    (FOOT.format(z=0.0, r=0.03, joint="", mass=""), "", "coupled body 'foot' overlaps the bed"),
    (FOOT.format(z=0.1, r=0.02, joint="", mass=""), "", "body 'foot': thickness .* below the minimum"),
])
def test_bad_models_are_refused_naming_the_item(tmp_path, body: str, option: str, message: str) -> None:
    config = MjcfScene(model=_model(tmp_path, body, option), bed_width=0.4, bed_depth=0.06, spacing=DX)
    with pytest.raises(ConfigError, match=message):
        build_mjcf(config)


def test_a_bad_model_on_the_command_line_exits_with_status_2(tmp_path, capsys) -> None:
    bad = _model(tmp_path, FOOT.format(z=0.1, r=0.03, joint='<joint name="wrist" type="ball"/>', mass=""))
    with pytest.raises(SystemExit) as stopped:
        main(["run", "mjcf", bad, "--out", str(tmp_path / "x.h5"), "--no-progress"])
    assert stopped.value.code == 2
    assert "joint 'wrist' is a ball joint" in capsys.readouterr().err
    assert not (tmp_path / "x.h5").exists()


@pytest.mark.slow
def test_the_half_cheetah_is_slower_on_sand_than_on_the_rigid_floor() -> None:
    """gymnasium's half-cheetah, every body coupled, with an open-loop gait (each motor a sine of
    half its range, period 0.4 s, front and back legs half a period apart): on the bed its centre
    of mass advances at less than half the speed the same gait gives on MuJoCo's floor (measured
    0.089 of it here at Δx = 3 cm, 0.085 at 1.5 cm and 0.077 at 1 cm, docs/mjcf.md), and its feet
    sink in (18.9 and 18.5 cm here)."""
    from terrasph.scenes.mjcf_scene import rigid_floor_run

    gait = tuple(f"{name}=sin:0.5,0.4,{phase}" for name, phase in
                 (("bthigh", 0), ("bshin", 0), ("bfoot", 0), ("fthigh", 180), ("fshin", 180), ("ffoot", 180)))
    config = MjcfScene(model=CHEETAH, bed_width=2.5, bed_depth=0.3, spacing=0.03, start_x=0.9, settle_time=0.5,
                       t_end=2.5, ctrl=gait, couple_below=1.0)
    sand = run_mjcf(config).summary()
    rigid, _ = rigid_floor_run(CHEETAH, None, 2.5, 0.5, timestep=2.5 / sand["steps"], ctrl=gait)
    assert sand["leaked_particles"] == 0
    assert rigid["mean_speed"] > 0.2  # the gait runs forward on the rigid floor
    assert sand["mean_speed"] < 0.5 * rigid["mean_speed"]
    assert sand["bfoot_final_sinkage"] > 0.03 and sand["ffoot_final_sinkage"] > 0.03


def test_a_world_box_whose_top_is_at_the_floor_is_floor_too(tmp_path) -> None:
    """Without a plane the floor is at z = 0: a world box with its top there is switched off, a box
    standing on it (an obstacle, top at 0.1 m) keeps its contacts."""
    path = tmp_path / "boxes.xml"
    path.write_text('<mujoco><worldbody><geom name="slab" type="box" size="2 2 0.05" pos="0 0 -0.05"/>'
                    '<geom name="step" type="box" size="0.05 0.5 0.05" pos="1 0 0.05"/>'
                    + FOOT.format(z=0.1, r=0.03, joint="", mass="") + '</worldbody></mujoco>')
    robot = terrain_robot(str(path), DX, 0.06, 0.2)
    slab, step = (mujoco.mj_name2id(robot.model, mujoco.mjtObj.mjOBJ_GEOM, n) for n in ("slab", "step"))
    assert robot.model.geom_contype[slab] == 0 and robot.model.geom_contype[step] == 1
    assert [b.name for b in robot.coupled] == ["foot"]


def test_the_scene_configuration_round_trips_through_a_run_file() -> None:
    """`terrasph resume` rebuilds the configuration by name from the run file's JSON."""
    import dataclasses

    from terrasph.scenes import SCENES

    config = MjcfScene(model=HOPPER, ctrl=HOLD, bodies=("foot",), widths={"foot": 0.2}, start_x=0.3)
    assert SCENES["mjcf"].config_from(json.loads(json.dumps(dataclasses.asdict(config)))) == config


def test_an_uncoupled_body_reaching_the_bed_is_warned_of_by_name(tmp_path) -> None:
    """A ball that is not coupled, its lowest point 7 cm above the floor beside a coupled foot:
    nothing holds it (the floor being off), it goes below the bed's surface after
    sqrt(2·0.07 m/g) = 0.12 s of free fall and is named once."""
    ball = ('<body name="ball" pos="0.2 0 0.1"><joint type="slide" axis="0 0 1"/>'
            '<geom type="sphere" size="0.03"/></body>')
    config = MjcfScene(model=_model(tmp_path, FOOT.format(z=0.1, r=0.03, joint="", mass="") + ball),
                       bed_width=0.8, bed_depth=0.06, spacing=DX, settle_time=0.0, t_end=0.2, bodies=("foot",))
    with pytest.warns(RuntimeWarning, match="body 'ball' is not coupled and reached below the bed's surface") as caught:
        run = run_mjcf(config)
    assert len([w for w in caught if "ball" in str(w.message)]) == 1
    assert run.summary()["through_the_bed"]["ball"] == pytest.approx(np.sqrt(2 * 0.07 / 9.81), abs=0.005)


def test_an_interrupted_mjcf_run_resumes_bitwise(tmp_path, monkeypatch, capsys) -> None:
    """The hopper run stopped by SIGINT after 60 % of its coupled steps and finished by ``terrasph resume``
    (the scene found by name in the run file, its ctrl specs rebuilt) equals the run never stopped
    in every series but wall time, bit for bit."""
    from terrasph.simulation import checkpoint_path

    config = MjcfScene(model=HOPPER, bed_width=0.8, bed_depth=0.06, spacing=DX, settle_time=0.02, t_end=0.08,
                       ctrl=(*HOLD[:2], "foot_joint=sin:0.2,0.05"), series_interval=0.005)
    whole = run_mjcf(config, tmp_path / "whole.h5")
    stopped = tmp_path / "stopped.h5"
    run_interrupted(monkeypatch, lambda: run_mjcf(config, stopped), int(0.6 * whole.summary()["steps"]))
    assert checkpoint_path(stopped).is_file()
    assert 0.02 < read_run(stopped).series["diagnostics"]["time"][-1] < 0.08  # stopped while driven
    assert main(["resume", str(stopped), "--no-progress"]) == 0
    assert json.loads(capsys.readouterr().out)["leaked_particles"] == 0
    a, b = read_run(tmp_path / "whole.h5"), read_run(stopped)
    assert_same_series(a, b)


def test_mujoco_warnings_reach_python_and_no_log_file(tmp_path, monkeypatch) -> None:
    """gymnasium's half cheetah uses the deprecated compiler attribute settotalmass: MuJoCo's warning
    about it is a Python warning, MuJoCo's own handler (a MUJOCO_LOG.TXT in the working directory)
    is not used, and the handler is MuJoCo's default again afterwards (no process-wide change)."""
    from terrasph.mjcf.model import MujocoWarning, load_model

    monkeypatch.chdir(tmp_path)
    before = mujoco.get_mju_user_warning()
    with pytest.warns(MujocoWarning, match="settotalmass"):
        load_model(CHEETAH)
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()
    assert mujoco.get_mju_user_warning() is before


def test_a_missing_or_broken_model_is_one_clear_line(tmp_path, capsys) -> None:
    """`run mjcf /missing.xml` names the argument as it is typed (no option --ROBOT.xml); an XML
    parse error keeps MuJoCo's text (line and element); `resume` of a missing file says so."""
    broken = tmp_path / "broken.xml"
    broken.write_text("<mujoco>\n<worldbody>\n<body>\n</worldbody></mujoco>\n")
    for argv, words in ((["run", "mjcf", str(tmp_path / "missing.xml")], "'model' (ROBOT.xml)"),
                        (["run", "mjcf", str(broken)], "Line number=3"),
                        (["resume", str(tmp_path / "missing.h5")], "missing.h5: no such run file")):
        with pytest.raises(SystemExit) as refused:
            main([*argv, "--no-progress"])
        err = capsys.readouterr().err
        assert refused.value.code == 2 and words in err and "--ROBOT.xml" not in err, err
        assert len(err.strip().splitlines()) == 1
