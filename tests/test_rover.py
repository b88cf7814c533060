"""Smoke run of the ``rover`` scene at a tiny size through the CLI: the example
MJCF rover stands on its two leg-wheels, both turn at the commanded ω after the pause, it moves
forward, no grain leaks; bad parameters are refused by name."""

from __future__ import annotations

import json

import numpy as np
import pytest
from terrasph.cli import main
from terrasph.config import ConfigError
from terrasph.io import read_run
from terrasph.scenes.rover import Rover

TINY = ["--spacing", "0.005", "--thickness", "0.015", "--leg-length", "0.04", "--bed-width", "0.3",
        "--bed-depth", "0.04", "--start-x", "0.12", "--settle-time", "0.08", "--t-end", "0.2", "--omega", "2.0",
        "--no-progress"]


def test_rover_cli_smoke(tmp_path, capsys) -> None:
    out = tmp_path / "rover.h5"
    assert main(["run", "rover", "--wheel", "c-leg", *TINY, "--out", str(out)]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["leaked_particles"] == 0
    assert (tmp_path / "rover.png").is_file()
    series = read_run(out).series
    for name in ("rear_wheel", "front_wheel"):
        wheel = series[f"robot/{name}"]
        assert wheel["omega"][wheel["time"] >= 0.15] == pytest.approx(2.0, rel=0.1)
        assert np.isfinite(wheel["sinkage"]).all()
    assert summary["distance"] > 0


@pytest.mark.parametrize(("key", "value"), [("wheel", "square"), ("leg_length", 0.07), ("start_x", 0.05)])
def test_bad_rover_parameters_are_named(key: str, value: object) -> None:
    with pytest.raises(ConfigError, match=key):
        Rover(**{key: value})
