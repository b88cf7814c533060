"""Command line: ``terrasph --help`` and ``terrasph run column-collapse``.

The LSTM commands (``train``, ``predict``) are tested in test_lstm_*.py; here they only have to
be listed. The real run is 0.05 s of the coarse collapse (~3 500 steps, a few seconds).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys

import pytest
from terrasph.cli import build_parser, main
from terrasph.io import read_run
from terrasph.scenes import SCENES


def run_cli(*args: str, timeout: float = 300) -> subprocess.CompletedProcess:
    """`python -m terrasph.cli ARGS` in a subprocess, with this interpreter and sys.path."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p)
    return subprocess.run([sys.executable, "-m", "terrasph.cli", *args], capture_output=True, text=True,
                          timeout=timeout, env=env)


def test_top_level_help_lists_commands(capsys) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["--help"])
    assert exit_info.value.code == 0
    out = capsys.readouterr().out
    for command in ("run", "train", "predict"):
        assert f"    {command} " in out or f"    {command}\n" in out, f"'{command}' missing from --help"


def test_no_command_is_an_error(capsys) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main([])
    assert exit_info.value.code == 2
    assert "COMMAND" in capsys.readouterr().err


def test_run_column_collapse_help(capsys) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["run", "column-collapse", "--help"])
    assert exit_info.value.code == 0
    out = capsys.readouterr().out
    for option in ("--resolution", "--out", "--t-end", "--no-progress", "--mu1-deg", "--threads"):
        assert option in out
    assert "coarse" in out


def test_run_lists_its_scenes(capsys) -> None:
    with pytest.raises(SystemExit):
        build_parser().parse_args(["run", "--help"])
    assert "column-collapse" in capsys.readouterr().out


def test_bad_choices_are_refused(capsys) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["run", "column-collapse", "--resolution", "ultra"])
    assert exit_info.value.code == 2
    assert "--resolution" in capsys.readouterr().err


def test_bad_friction_is_refused_naming_the_parameter(tmp_path) -> None:
    out = tmp_path / "never.h5"
    result = run_cli("run", "column-collapse", "--mu1-deg", "40", "--mu2-deg", "33", "--out", str(out),
                     "--no-progress", timeout=120)
    assert result.returncode == 2  # a usage error, as argparse reports one
    assert "friction_angles_deg" in result.stderr
    assert "Traceback" not in result.stderr  # one clear line, not a stack trace
    assert not out.exists()  # refused before any work


def test_short_real_run_writes_h5_and_png(tmp_path) -> None:
    out = tmp_path / "short.h5"
    result = run_cli("run", "column-collapse", "--resolution", "coarse", "--t-end", "0.05", "--out", str(out),
                     "--no-progress", "--threads", "1")
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout)
    assert summary["output"] == str(out)
    assert summary["status"] == "completed"
    assert summary["time"] == pytest.approx(0.05)
    assert summary["granular_particles"] == pytest.approx(475, rel=0.05)
    assert out.exists()
    png = out.with_suffix(".png")
    assert summary["plot"] == str(png)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    run = read_run(out)
    assert run.group_attrs["/run"]["status"] == "completed"
    assert run.n_frames >= 2
    assert run.times[-1] == pytest.approx(0.05)
    assert run.frame(-1)["position"].shape == (summary["granular_particles"], 2)
    assert "runout_normalised" in run.group_attrs["/results"]


@pytest.mark.skipif(shutil.which("terrasph") is None, reason="console script not installed (pip install .)")
def test_console_script_help() -> None:
    result = subprocess.run(["terrasph", "--help"], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0
    assert "run" in result.stdout and "train" in result.stdout and "predict" in result.stdout


def test_run_leg_rotation_refuses_bad_input_before_work(tmp_path) -> None:
    out = tmp_path / "never.h5"
    result = run_cli("run", "leg-rotation", "--omega", "-0.2", "--out", str(out), "--no-progress", timeout=120)
    assert result.returncode == 2
    assert "omega" in result.stderr
    assert "Traceback" not in result.stderr
    assert not out.exists()


def test_short_leg_rotation_writes_body_series_and_plot(tmp_path) -> None:
    """A fast sweep (ω = 20 rad/s, no pause, 7 cm bed: ~2 400 steps, ~10 s) through the real command.

    At this speed (toe at 1.5 m/s) a couple of grains are pressed onto the leg's surface and are
    counted by the leak counter; the slow sweeps of test_leg_rotation.py must have none."""
    out = tmp_path / "leg.h5"
    result = run_cli("run", "leg-rotation", "--leg", "flat-leg", "--omega", "20", "--settle-time", "0",
                     "--bed-depth", "0.07",
                     "--out", str(out), "--no-progress", "--threads", "1")
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout)
    assert out.with_suffix(".png").stat().st_size > 0
    run = read_run(out)
    assert summary["leaked_particles"] == run.group_attrs["/run"]["leaked_particles"]
    series = run.series["bodies/leg"]
    assert series["angle"][0] == pytest.approx(-0.7854, abs=1e-3)
    assert series["angle"][-1] == pytest.approx(0.7854, abs=1e-3)
    assert series["force"].shape == (len(series["time"]), 2)
    assert summary["peak_thrust"] > 0


def test_leg_that_would_hit_the_floor_is_refused(tmp_path) -> None:
    result = run_cli("run", "leg-rotation", "--bed-depth", "0.04", "--out", str(tmp_path / "never.h5"),
                     "--no-progress", timeout=120)
    assert result.returncode == 2
    assert "bed_depth" in result.stderr


def _run_subparser_choices() -> dict:
    """The scenes `terrasph run` offers: its sub-parsers by name."""
    import argparse

    run = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction)).choices["run"]
    return next(a for a in run._actions if isinstance(a, argparse._SubParsersAction)).choices


def test_run_offers_every_registered_scene_through_run_case(tmp_path, monkeypatch) -> None:
    """`terrasph run` lists exactly the registry's scenes, and each one's command reaches run_case with
    a configuration of that scene's type and the --out path (run_case replaced by a recorder)."""
    from terrasph import scenes_cli
    from terrasph.scenes import SCENES, CaseSummary

    assert sorted(_run_subparser_choices()) == sorted(SCENES)
    calls = []

    def recorder(scene, config, out, *, progress=False):
        calls.append((scene, config, out, progress))
        summary = CaseSummary({"status": "completed", "scene": scene})
        summary.plot = f"{out}.png"
        return summary

    monkeypatch.setattr(scenes_cli, "run_case", recorder)
    model = tmp_path / "robot.xml"  # the mjcf scene's one required argument, a model file
    model.write_text('<mujoco><worldbody><body><joint type="slide" axis="0 0 1"/><geom size="0.1"/></body>'
                     '</worldbody></mujoco>')
    required = {"mjcf": [str(model)]}
    for name, entry in SCENES.items():
        out = str(tmp_path / f"{name}.h5")
        assert main(["run", name, *required.get(name, []), "--out", out, "--no-progress"]) == 0
        scene, config, called_out, progress = calls[-1]
        assert (scene, called_out, progress) == (name, out, False)
        assert type(config) is entry.config_type
    assert len(calls) == len(SCENES)


def _h5_contents(path) -> dict:
    """Every dataset (bytes) and attribute of an HDF5 file by path, without the run's wall-clock
    records (wall time series and attributes, timestamps, the run's own host and process)."""
    import h5py
    import numpy as np

    clock = ("wall", "timestamp", "created", "started", "finished", "date", "host", "pid")
    items: dict = {}

    def visit(name, obj) -> None:
        if isinstance(obj, h5py.Dataset) and not any(word in name.split("/")[-1].lower() for word in clock):
            data = obj[()]
            items[f"{name}:data"] = (data.dtype.str, data.shape, np.ascontiguousarray(data).tobytes()) \
                if isinstance(data, np.ndarray) else data
        for key, value in obj.attrs.items():
            if not any(word in key.lower() for word in clock):
                items[f"{name}@{key}"] = value.tobytes() if isinstance(value, np.ndarray) else value

    with h5py.File(path, "r") as f:
        visit("/", f)
        f.visititems(visit)
    return items


def test_cli_run_and_run_case_write_the_same_file(tmp_path) -> None:
    """0.02 s of the coarse collapse, once by `terrasph run` and once by run_case on the
    configuration the run file records: the same file content (datasets bit for bit, attributes,
    the configuration) apart from wall-clock records, and the same summary."""
    (tmp_path / "cli").mkdir(), (tmp_path / "case").mkdir()  # one name: /run names the checkpoint beside it
    via_cli, via_case = tmp_path / "cli" / "run.h5", tmp_path / "case" / "run.h5"
    result = run_cli("run", "column-collapse", "--t-end", "0.02", "--out", str(via_cli), "--no-progress",
                     "--threads", "1")
    assert result.returncode == 0, result.stderr
    cli_summary = json.loads(result.stdout)
    code = ("import json, sys; from terrasph import _core; from terrasph.scenes import run_case; "
            "_core.set_num_threads(1); config = json.loads(sys.argv[1]); "
            "print(json.dumps({**run_case('column-collapse', config, sys.argv[2]), 'plot': None}))")
    import h5py

    with h5py.File(via_cli, "r") as f:
        config = json.loads(str(f.attrs["config_json"]))["column_collapse"]
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p)
    case = subprocess.run([sys.executable, "-c", code, json.dumps(config), str(via_case)], capture_output=True,
                          text=True, timeout=300, env=env)
    assert case.returncode == 0, case.stderr
    case_summary = json.loads(case.stdout)
    cli_items, case_items = _h5_contents(via_cli), _h5_contents(via_case)
    assert sorted(cli_items) == sorted(case_items)
    assert any(key.endswith(":data") for key in cli_items)
    different = [key for key in cli_items if not _same(cli_items[key], case_items[key])]
    assert different == []
    for summary in (cli_summary, case_summary):
        summary.pop("wall_time"), summary.pop("output", None), summary.pop("plot")
    assert cli_summary == case_summary


def _same(a, b) -> bool:
    import numpy as np

    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.array_equal(a, b)
    return bool(a == b)


@pytest.mark.parametrize("scene", sorted(SCENES))
def test_a_scenes_own_parser_reads_its_arguments_as_the_whole_command_line_does(scene) -> None:
    """``terrasph run SCENE …`` is parsed by a parser holding that scene alone (build_parser(argv)):
    the same values, defaults included, as the whole command line's parser gives."""
    argv = ["run", scene, *(["robot.xml"] if scene == "mjcf" else []), "--out", "x.h5", "--force", "--no-progress"]
    narrow, whole = build_parser(argv).parse_args(argv), build_parser().parse_args(argv)
    assert {k: v for k, v in vars(narrow).items() if k != "parser_of_command"} == \
        {k: v for k, v in vars(whole).items() if k != "parser_of_command"}
    with_help = build_parser([*argv, "--help"])  # the whole command line, for the help to list every command
    assert "resume" in next(a for a in with_help._actions if isinstance(a, argparse._SubParsersAction)).choices
