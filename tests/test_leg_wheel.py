"""Smoke run of the ``leg-wheel`` scene (issue 11 item 5) at a tiny size, through the CLI: the file
holds the robot series, the wheel turns at the commanded ω after the pause and not before, it
sinks, no grain leaks; the rig weighs load + the wheel's shape at its density; bad parameters are
refused by name."""

from __future__ import annotations

import json

import numpy as np
import pytest
from terrasph.cli import main
from terrasph.config import ConfigError
from terrasph.io import read_run
from terrasph.robots import shape_inertial
from terrasph.robots.leg_wheel import LegWheel, build_leg_wheel

TINY = ["--spacing", "0.005", "--thickness", "0.015", "--leg-length", "0.04", "--bed-width", "0.2",
        "--bed-depth", "0.04", "--start-x", "0.08", "--settle-time", "0.1", "--t-end", "0.16", "--omega", "1.5",
        "--load", "2.0", "--no-progress"]


def test_leg_wheel_cli_smoke(tmp_path, capsys) -> None:
    out = tmp_path / "lw.h5"
    assert main(["run", "leg-wheel", "--wheel", "reversed-c-leg", *TINY, "--out", str(out)]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["leaked_particles"] == 0
    assert (tmp_path / "lw.png").is_file()
    wheel = read_run(out).series["robot/wheel"]
    paused, driven = wheel["time"] <= 0.1, wheel["time"] >= 0.13
    assert np.abs(wheel["omega"][paused]).max() < 0.05
    assert wheel["omega"][driven] == pytest.approx(1.5, rel=0.05)
    assert np.isfinite(wheel["sinkage"]).all() and wheel["sinkage"][-1] > 0
    # motor work against the series: ∫ max(P, 0) dt from the sampled power, within the sampling error
    power = read_run(out).series["robot/actuators"]["power"]
    sampled = np.sum(np.clip(power[1:], 0, None) * np.diff(read_run(out).series["robot/actuators"]["time"]))
    assert summary["motor_work"] == pytest.approx(sampled, rel=0.2)  # measured 6 %
    assert summary["cost_of_transport"] > 0


def test_the_rig_carries_the_load_and_the_wheel() -> None:
    config = LegWheel(wheel="reversed-c-leg", spacing=0.005, thickness=0.015, leg_length=0.04, bed_width=0.2,
                      bed_depth=0.04, start_x=0.08, load=2.0)
    rig = build_leg_wheel(config)
    wheel_mass = shape_inertial(config.shape(), config.wheel_density, config.width).mass
    assert rig.robot.model.body_subtreemass[1] * 9.81 == pytest.approx(2.0 + wheel_mass * 9.81, rel=1e-12)


@pytest.mark.parametrize(("key", "value"), [("wheel", "square"), ("legs", 0), ("omega", -1.0), ("start_x", 0.01)])
def test_bad_leg_wheel_parameters_are_named(key: str, value: object) -> None:
    with pytest.raises(ConfigError, match=key):
        LegWheel(**{key: value})
