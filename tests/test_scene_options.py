"""Scene options defined once (terrasph.options) and the size guard (terrasph.size_guard)."""

from __future__ import annotations

import argparse
import dataclasses
import time

import pytest
from terrasph.cli import build_parser, main
from terrasph.options import OPTION, config_values
from terrasph.scenes import SCENES


def _scene_parser(name: str) -> argparse.ArgumentParser:
    parser = build_parser()
    run = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices["run"]
    return next(a for a in run._actions if isinstance(a, argparse._SubParsersAction)).choices[name]


@pytest.mark.parametrize("scene", list(SCENES))
def test_every_scene_spells_the_shared_options_the_same_way(scene: str) -> None:
    options = {s for a in _scene_parser(scene)._actions for s in a.option_strings}
    assert {"--spacing", "--t-end", "--out", "--threads", "--numerics", "--force", "--yes"} <= options
    assert "--settle" not in options and "--duration" not in options
    if scene != "column-collapse":  # the only scene without a pause
        assert "--settle-time" in options


def _required(scene: str) -> dict[str, str]:
    """The required arguments of a scene (the mjcf scene's model file: gymnasium's hopper)."""
    if scene != "mjcf":
        return {}
    import os

    gymnasium = pytest.importorskip("gymnasium")
    return {"model": os.path.join(os.path.dirname(gymnasium.__file__), "envs", "mujoco", "assets", "hopper.xml")}


@pytest.mark.parametrize("scene", list(SCENES))
def test_no_options_give_the_configurations_own_defaults(scene: str) -> None:
    """Options left out are not passed: the configuration from no options (but the required
    arguments) is the default one."""
    entry, required = SCENES[scene], _required(scene)
    args = _scene_parser(scene).parse_args(list(required.values()))
    assert entry.config_from(config_values(args, entry.config_type)) == entry.config_type(**required)


def test_options_reach_the_fields_they_are_generated_from() -> None:
    entry = SCENES["plate-intrusion"]
    args = _scene_parser("plate-intrusion").parse_args(
        ["--settle-time", "0.05", "--max-depth", "0.02", "--resolution", "fine", "--t-end", "0.3", "--geostatic"])
    config = entry.config_from(config_values(args, entry.config_type))
    from terrasph.scenes.plate_intrusion import RESOLUTIONS

    assert (config.settle_time, config.max_depth, config.spacing, config.end_time, config.geostatic) == \
        (0.05, 0.02, RESOLUTIONS["fine"], 0.3, True)
    column = SCENES["column-collapse"]
    args = _scene_parser("column-collapse").parse_args(["--mu2-deg", "35", "--bed-axes", "0.3", "0.1"])
    config = column.config_from(config_values(args, column.config_type))
    assert config.friction_angles_deg == (21.0, 35.0) and config.bed_axes == (0.3, 0.1)


def test_each_offered_field_is_one_option() -> None:
    """Every field with option metadata appears in its scene's parser, under one name."""
    for name, entry in SCENES.items():
        dests = {a.dest for a in _scene_parser(name)._actions}
        for f in dataclasses.fields(entry.config_type):
            if OPTION in f.metadata:
                assert any(d == f"config__{f.name}" or d.startswith(f"config__{f.name}__") for d in dests), f.name


def test_a_spacing_too_fine_is_refused_in_one_line_within_seconds(tmp_path, capsys) -> None:
    """A user's `--spacing 1e-4` (85 s build, then a traceback) and 1e-5 on a 1 x 0.3 m bed."""
    out = tmp_path / "r.h5"
    for argv, reason in ((["--spacing", "1e-4"], "--yes"),
                         (["--spacing", "1e-5", "--bed-width", "1", "--bed-depth", "0.3"], "memory")):
        start = time.perf_counter()
        with pytest.raises(SystemExit) as exit_info:
            main(["run", "leg-wheel", *argv, "--out", str(out), "--no-progress"])
        err = capsys.readouterr().err
        assert exit_info.value.code == 2 and len(err.splitlines()) == 1 and reason in err, err
        assert time.perf_counter() - start < 5.0
        assert list(tmp_path.iterdir()) == []


def test_the_step_estimate_matches_the_cores_first_step() -> None:
    """Steps = t_end / (cfl h sqrt(f) / c0): the core's own stable step at rest (no flow speed yet,
    the reference) is the estimate's, within 1 %."""
    from terrasph.scenes.plate_intrusion import PlateIntrusion, build_plate_intrusion
    from terrasph.simulation import Simulation
    from terrasph.size_guard import estimate

    config = PlateIntrusion(spacing=0.004, bed_width=0.12, bed_depth=0.05, plate_length=0.03, max_depth=0.01)
    sim = Simulation(*build_plate_intrusion(config))
    sim.advance(1.0, max_steps=1)
    size = estimate(config.footprint())
    assert config.end_time / size.steps == pytest.approx(sim.core.last_dt, rel=0.01)
    assert size.particles == pytest.approx(len(sim.position) + len(sim.core.wall_position), rel=0.25)


def test_old_field_names_still_read() -> None:
    """Run files and SPECs written before the rename (duration → t_end) give the same configuration."""
    from sweep_helpers import TINY_FIXED
    from terrasph.sweeps.spec import parse_spec

    entry = SCENES["leg-wheel"]
    assert entry.config_from({"duration": 0.5, "settle_time": 0.1}) == entry.config_from({"t_end": 0.5,
                                                                                          "settle_time": 0.1})
    old = {**{k: v for k, v in TINY_FIXED.items() if k != "t_end"}, "duration": 0.3}
    design = {"method": "grid", "vary": {"load": {"values": [2.0]}}}
    spec = parse_spec({"scene": "leg-wheel", "fixed": old, "design": design})
    assert spec.cases[0].config["t_end"] == 0.3


def test_the_leg_shapes_have_one_set_of_names() -> None:
    """leg-rotation's flat leg is flat-leg as in leg-wheel; the old name reads as the new."""
    from terrasph.scenes.leg_rotation import LEGS, LegRotation
    from terrasph.scenes.leg_wheel import WHEELS

    assert set(LEGS) <= set(WHEELS)
    assert LegRotation(leg="flat") == LegRotation(leg="flat-leg")


def test_your_own_robot_reaches_the_rover_and_a_missing_file_is_refused(tmp_path, monkeypatch, capsys) -> None:
    from terrasph.robots import ROVER
    from terrasph.scenes import rover

    seen = {}

    class Stop(Exception):
        pass

    def planar_robot(mjcf, *args, **kwargs):
        seen["mjcf"] = mjcf
        raise Stop

    monkeypatch.setattr(rover, "PlanarRobot", planar_robot)
    mine = tmp_path / "my_rover.xml"
    mine.write_text(ROVER.read_text())
    with pytest.raises(Stop):
        main(["run", "rover", "--model", str(mine), "--spacing", "0.005", "--thickness", "0.015",
              "--out", str(tmp_path / "r.h5"), "--no-progress"])
    assert seen["mjcf"] == str(mine)
    with pytest.raises(SystemExit) as exit_info:
        main(["run", "rover", "--model", str(tmp_path / "missing.xml"), "--out", str(tmp_path / "r.h5")])
    err = capsys.readouterr().err
    assert exit_info.value.code == 2 and len(err.splitlines()) == 1 and "missing.xml" in err, err


def test_a_bad_value_is_refused_naming_its_option_and_range(tmp_path, capsys) -> None:
    """The configuration's own check judges the value; the one line names the option beside it."""
    with pytest.raises(SystemExit) as exit_info:
        main(["run", "leg-rotation", "--settle-time", "-1", "--out", str(tmp_path / "r.h5")])
    err = capsys.readouterr().err
    assert exit_info.value.code == 2 and len(err.splitlines()) == 1, err
    assert "(--settle-time)" in err and ">= 0" in err
    assert list(tmp_path.iterdir()) == []
