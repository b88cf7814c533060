"""Smoke run of the ``leg-wheel`` scene at a tiny size, through the CLI: the file
holds the robot series, the wheel turns at the commanded ω after the pause and not before, it
sinks, no grain leaks; the rig weighs load + the wheel's shape at its density; bad parameters are
refused by name."""

from __future__ import annotations

import json

import numpy as np
import pytest
from robot_helpers import assert_same_series, run_interrupted
from terrasph.cli import main
from terrasph.config import ConfigError
from terrasph.io import read_run
from terrasph.mjcf.model import shape_inertial
from terrasph.scenes.leg_wheel import LegWheel, build_leg_wheel, run_leg_wheel
from terrasph.simulation import checkpoint_path

TINY = ["--spacing", "0.005", "--thickness", "0.015", "--leg-length", "0.04", "--bed-width", "0.2",
        "--bed-depth", "0.04", "--start-x", "0.08", "--settle-time", "0.1", "--t-end", "0.16", "--omega", "1.5",
        "--load", "2.0", "--no-progress"]


def test_leg_wheel_cli_smoke(tmp_path, capsys) -> None:
    out = tmp_path / "lw.h5"
    # the series sampled at every step (dt ≈ 1e-5 s here), so the motor work can be checked against it
    assert main(["run", "leg-wheel", "--wheel", "reversed-c-leg", *TINY, "--series-interval", "1e-5",
                 "--out", str(out)]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["leaked_particles"] == 0
    assert (tmp_path / "lw.png").is_file()
    wheel = read_run(out).series["robot/wheel"]
    paused, driven = wheel["time"] <= 0.1, wheel["time"] >= 0.13
    assert np.abs(wheel["omega"][paused]).max() < 0.05
    assert wheel["omega"][driven] == pytest.approx(1.5, rel=0.05)
    assert np.isfinite(wheel["sinkage"]).all() and wheel["sinkage"][-1] > 0
    assert summary["mean_sinkage"] > 0  # sunk while driven
    # motor work against the series: ∫ max(P, 0) dt of the power sampled at every step, each sample
    # held over the step after it. The servo's power alternates from step to step, so sampled every
    # 0.01 s the same sum was 10.6 % low (8.7 % at 5 ms, 5.1 % at 1 ms: aliasing, not an error);
    # at every step it agrees to 1e-15, so a band of 1e-9 catches any change of the bookkeeping
    actuators = read_run(out).series["robot/actuators"]
    sampled = np.sum(np.clip(actuators["power"][:-1], 0, None) * np.diff(actuators["time"]))
    assert summary["motor_work"] == pytest.approx(sampled, rel=1e-9)
    assert summary["cost_of_transport"] > 0


def tiny_wheel_summary(cfl: float) -> tuple[dict[str, float], np.ndarray]:
    """The small C-leg wheel (4 cm legs, Δx = 5 mm, 20 × 4 cm bed, 2 N) at 1.5 rad/s for 1 s after
    a 0.3 s pause, the step at the wave speed with the density advanced first: its summary and its
    spin ω over the last 0.5 s."""
    numerics = {"symplectic_density": True, "cfl": cfl}
    config = LegWheel(wheel="c-leg", spacing=0.005, thickness=0.015, leg_length=0.04, bed_width=0.2,
                      bed_depth=0.04, start_x=0.08, settle_time=0.3, t_end=1.3, load=2.0, series_interval=0.002,
                      frame_interval=10.0, numerics=numerics)
    run = run_leg_wheel(config, plot=False)
    wheel = run.series["robot/wheel"]
    return run.summary(), wheel["omega"][wheel["time"] > 0.8]


def test_a_torque_limited_servo_stiffer_than_the_step_holds_its_command() -> None:
    """The wheel's servo (kv = 20 N·m·s/rad, 5 N·m) on a wheel of M = 2.9e-4 kg·m² has kv·dt/M = 6
    at the default step and 19 at C = 0.8 on the wave speed: held at its torque limit, MuJoCo's step
    of it is explicit and jumps ω by τ_max·dt/M = 4.6 rad/s. Measured before the coupling gave a
    servo at its limit its force (terrain/sph_coupling.py): at C = 0.8 ω swung between −2.4 and +2.4 rad/s
    every step and the slip was 0.99, against 0.45 at C = 0.25. Now ω holds the command and the slip
    is that of the 3.2× finer step within 2 % (measured within 0.4 % from C = 0.25 to 1)."""
    fine, _ = tiny_wheel_summary(0.25)
    coarse, omega = tiny_wheel_summary(0.8)
    assert np.abs(omega - 1.5).max() < 0.05, (omega.min(), omega.max())
    assert coarse["mean_slip"] == pytest.approx(fine["mean_slip"], rel=0.02)


def test_the_rig_carries_the_load_and_the_wheel() -> None:
    config = LegWheel(wheel="reversed-c-leg", spacing=0.005, thickness=0.015, leg_length=0.04, bed_width=0.2,
                      bed_depth=0.04, start_x=0.08, load=2.0)
    rig = build_leg_wheel(config)
    wheel_mass = shape_inertial(config.shape(), config.wheel_density, config.width).mass
    assert rig.model.body_subtreemass[1] * 9.81 == pytest.approx(2.0 + wheel_mass * 9.81, rel=1e-12)


@pytest.mark.parametrize(("key", "value"), [("wheel", "square"), ("legs", 0), ("omega", -1.0), ("start_x", 0.01)])
def test_bad_leg_wheel_parameters_are_named(key: str, value: object) -> None:
    with pytest.raises(ConfigError, match=key):
        LegWheel(**{key: value})


def test_an_interrupted_leg_wheel_run_resumes_bitwise(tmp_path, monkeypatch, capsys) -> None:
    """A tiny leg-wheel run stopped by SIGINT after 70 % of its coupled steps (past the pause: the
    motor is turning) checkpoints the SPH State and MuJoCo's qpos/qvel/act/ctrl/time; ``terrasph resume``
    (through the scene registry) finishes it into the same file. Every series (robot, actuators,
    diagnostics but wall time) and every frame equals that of a run never stopped, bit for bit,
    and the motor work summed across the stop is the same. The stopped run settles its pause itself
    (``cache=False``: its steps are counted from the start); the whole one starts from the cached
    pause (terrasph.settle_cache), which it equals bit for bit."""
    config = LegWheel(wheel="c-leg", spacing=0.005, thickness=0.015, leg_length=0.04, bed_width=0.2,
                      bed_depth=0.04, start_x=0.08, settle_time=0.03, t_end=0.07, load=2.0,
                      series_interval=0.005, frame_interval=0.02)
    whole = run_leg_wheel(config, tmp_path / "whole.h5")
    stopped = tmp_path / "stopped.h5"
    run_interrupted(monkeypatch, lambda: run_leg_wheel(config, stopped, cache=False), int(0.7 * whole.summary()["steps"]))
    assert checkpoint_path(stopped).is_file()
    assert read_run(stopped).group_attrs["/run"]["status"] == "interrupted"
    assert 0.03 < read_run(stopped).series["diagnostics"]["time"][-1] < 0.07
    assert main(["resume", str(stopped), "--no-progress"]) == 0
    resumed = json.loads(capsys.readouterr().out)
    a, b = read_run(tmp_path / "whole.h5"), read_run(stopped)
    assert_same_series(a, b)
    assert np.array_equal(a.times, b.times) and set(a.fields) == set(b.fields)
    for name in a.fields:
        assert np.array_equal(a.fields[name], b.fields[name]), name
    assert resumed["motor_work"] == whole.summary()["motor_work"] > 0
    assert resumed["leaked_particles"] == 0
    assert resumed["plot"] == str(stopped.with_suffix(".png")) and stopped.with_suffix(".png").is_file()


def test_the_robot_progress_bar_ends_at_its_total(tmp_path, capsys) -> None:
    """The coupled loop's last step ends past t_end (its dt is the SPH's stable bound): the bar stops
    at 100 %, with no tqdm clamping warning and no negative remaining time."""
    import warnings

    config = LegWheel(wheel="c-leg", spacing=0.005, thickness=0.015, leg_length=0.04, bed_width=0.2,
                      bed_depth=0.04, start_x=0.08, settle_time=0.005, t_end=0.0123456781234, load=2.0,
                      series_interval=0.005, frame_interval=0.01)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a TqdmWarning fails the test
        run_leg_wheel(config, tmp_path / "bar.h5", progress=True, plot=False)
    bar_lines = [line for line in capsys.readouterr().err.replace("\r", "\n").splitlines() if "simulated" in line]
    assert "100%" in bar_lines[-1] and "<-" not in bar_lines[-1], bar_lines[-1]


def test_the_surrogate_dataset_reads_a_leg_wheel_run(tmp_path) -> None:
    """terrasph.surrogate.robot_dataset takes the driven phase of a leg-wheel run file (the scene's
    configuration under its registry key): the commanded input is the run's ω schedule, the
    targets are the file's series at settle_time + t, and a run of another scene is refused."""
    from terrasph.surrogate.robot_dataset import robot_run

    config = LegWheel(wheel="c-leg", spacing=0.005, thickness=0.015, leg_length=0.04, bed_width=0.2,
                      bed_depth=0.04, start_x=0.08, settle_time=0.01, t_end=0.05, load=2.0,
                      omega_schedule=((0.0, 1.0), (0.02, 2.0)), series_interval=0.002, frame_interval=0.05)
    run_leg_wheel(config, tmp_path / "lw.h5", plot=False)
    run = robot_run(tmp_path / "lw.h5", dt=0.01, wheels=("c-leg", "flat-leg"))
    np.testing.assert_allclose(run.time, [0.0, 0.01, 0.02, 0.03, 0.04], atol=1e-12)
    np.testing.assert_allclose(run.series["omega_cmd"], [1.0, 1.5, 2.0, 2.0, 2.0], atol=1e-12)
    wheel = read_run(tmp_path / "lw.h5").series["robot/wheel"]
    np.testing.assert_allclose(run.series["sinkage"], np.interp(run.time + 0.01, wheel["time"], wheel["sinkage"]))
    assert run.params == {"load": 2.0, "wheel:c-leg": 1.0, "wheel:flat-leg": 0.0}
    import h5py

    with h5py.File(tmp_path / "column.h5", "w") as f:
        f.attrs["config_json"] = json.dumps({"scene": "column-collapse"})
    with pytest.raises(ValueError, match="not a leg-wheel run"):
        robot_run(tmp_path / "column.h5", dt=0.01, wheels=("c-leg",))


def test_the_dataset_series_of_a_run_in_memory_are_those_of_its_file(tmp_path) -> None:
    """driven_phase_run of the series run_leg_wheel returns (no file needed: how the tiers of
    docs/rft.md compare the RFT terrain with the SPH and the LSTM) is robot_run of the run's file,
    bit for bit (here on the RFT terrain, a driven phase with a ramp of ω)."""
    import dataclasses

    from terrasph.surrogate.robot_dataset import driven_phase_run, robot_run

    config = LegWheel(terrain="rft", settle_time=0.1, t_end=0.5, omega_schedule=((0.0, 1.0), (0.4, 2.0)))
    result = run_leg_wheel(config, tmp_path / "lw.h5", plot=False)
    from_file = robot_run(tmp_path / "lw.h5", dt=0.02, wheels=("c-leg", "wheel"), bed=("mu1_deg",))
    in_memory = driven_phase_run("lw", dataclasses.asdict(config), result.series["robot/wheel"], 0.02,
                                 ("c-leg", "wheel"), ("mu1_deg",))
    assert np.array_equal(from_file.time, in_memory.time) and from_file.params == in_memory.params
    assert set(from_file.series) == set(in_memory.series)
    for name, values in from_file.series.items():
        assert np.array_equal(values, in_memory.series[name]), name
    assert in_memory.series["forward_speed"].std() > 0 and in_memory.series["omega_cmd"][-1] == 2.0
