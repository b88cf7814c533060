"""A robot that reaches the end of its bed ends its run there (status ``end_of_bed``, a finished
status, with the reason in ``/run`` and in the summary), on every robot scene and terrain: the
leg-wheel on the SPH bed and on RFT, the rover, an MJCF model; one that starts too close to an end
is refused before any step. The default leg-wheel run stays on its bed."""

from __future__ import annotations

import json
import os

import h5py
import numpy as np
import pytest
from terrasph.cli import main
from terrasph.config import ConfigError
from terrasph.io import read_run
from terrasph.robots.run import BED_END_MARGIN, BedEnds
from terrasph.run_loop import FINISHED_STATUSES
from terrasph.scenes.leg_wheel import SPH_BED_WIDTH, LegWheel, run_leg_wheel
from terrasph.scenes.mjcf_scene import MjcfScene, build_mjcf, run_mjcf
from terrasph.scenes.rover import Rover, run_rover

gymnasium = pytest.importorskip("gymnasium")
HOPPER = os.path.join(os.path.dirname(gymnasium.__file__), "envs", "mujoco", "assets", "hopper.xml")

#: the tiny C-leg wheel of tests/test_leg_wheel.py (4 cm legs, Δx = 5 mm, 20 × 4 cm bed), started
#: 4 cm from the bed's far end and driven fast, so it reaches the end within a few tenths of a second
NEAR_THE_END = ["--spacing", "0.005", "--thickness", "0.015", "--leg-length", "0.04", "--bed-width", "0.2",
                "--bed-depth", "0.04", "--start-x", "0.12", "--settle-time", "0.05", "--t-end", "1.5",
                "--omega", "4", "--load", "2.0", "--no-progress"]


def _run_status(path) -> dict:
    with h5py.File(path, "r") as file:
        return {k: (v.decode() if isinstance(v, bytes) else v) for k, v in file["run"].attrs.items()}


def _far_extent(series: dict, leg_length: float) -> np.ndarray:
    """The wheel's farthest x (m) at each sample: the axle plus at most its tip radius."""
    return series["robot/wheel"]["reference"][:, 0] + leg_length


def test_a_leg_wheel_reaching_the_end_of_its_bed_ends_its_run_there(tmp_path, capsys) -> None:
    out = tmp_path / "lw.h5"
    assert main(["run", "leg-wheel", *NEAR_THE_END, "--out", str(out)]) == 0
    summary = json.loads(capsys.readouterr().out)
    status = _run_status(out)
    assert status["status"] == "end_of_bed" and "end_of_bed" in FINISHED_STATUSES
    assert "far end of the bed" in status["reason"] and summary["end_of_bed"] == status["reason"]
    assert status["time"] < 1.5  # ended before its end time
    series = read_run(out).series
    # the series end where the run ended; the wheel (axle + tip radius) never passed the bed's end
    assert series["robot/wheel"]["time"][-1] == pytest.approx(status["time"])
    assert _far_extent(series, 0.04).max() < 0.2 + 0.5 * 0.005
    # and it did reach the margin: its axle had come within a tip radius + margin + Δx of the end
    assert series["robot/wheel"]["reference"][-1, 0] > 0.2 - 0.04 - BED_END_MARGIN - 0.005
    assert summary["final_sinkage"] == pytest.approx(series["robot/wheel"]["sinkage"][-1])


def test_the_leg_wheel_on_rft_ends_at_a_bed_end_given() -> None:
    config = LegWheel(terrain="rft", start_x=0.3, settle_time=0.1, t_end=6.0, bed_width=SPH_BED_WIDTH)
    run = run_leg_wheel(config, plot=False)
    wheel = run.series["robot/wheel"]
    assert run.summary()["end_of_bed"] is not None and wheel["time"][-1] < 6.0
    # the C-leg's tips are on a circle of 8 cm: the axle stops within 8 cm + margin + a frame's travel
    assert 0.5 - 0.08 - BED_END_MARGIN - 0.02 < wheel["reference"][-1, 0] < 0.5 - BED_END_MARGIN


def test_the_leg_wheel_on_rft_without_a_bed_width_runs_as_long_as_asked(tmp_path, capsys) -> None:
    """The RFT terrain is a plane without ends: with no bed_width the same run goes on past the SPH
    bed's 0.5 m to its end time (the wheel, at about 10 cm/s, passes x = 0.5 m before t = 3 s)."""
    assert LegWheel(terrain="rft").bed_width is None and LegWheel().bed_width == SPH_BED_WIDTH
    out = tmp_path / "rft.h5"
    assert main(["run", "leg-wheel", "--terrain", "rft", "--start-x", "0.3", "--settle-time", "0.1", "--t-end", "3",
                 "--no-progress", "--out", str(out)]) == 0
    assert json.loads(capsys.readouterr().out)["end_of_bed"] is None
    assert _run_status(out)["status"] == "completed"
    wheel = read_run(out).series["robot/wheel"]
    assert wheel["time"][-1] == pytest.approx(3.0, abs=0.005)
    assert wheel["reference"][-1, 0] + LegWheel().leg_length > SPH_BED_WIDTH


def test_the_rover_ends_at_the_end_of_its_bed(tmp_path) -> None:
    config = Rover(spacing=0.005, thickness=0.015, leg_length=0.04, bed_width=0.3, bed_depth=0.04, start_x=0.17,
                   settle_time=0.05, t_end=1.5, omega=4.0)
    run = run_rover(config, tmp_path / "rover.h5", plot=False)
    assert _run_status(tmp_path / "rover.h5")["status"] == "end_of_bed"
    assert "front_wheel" in run.summary()["end_of_bed"]


def test_a_robot_that_starts_within_the_margin_of_an_end_is_refused_before_any_step() -> None:
    with pytest.raises(ConfigError, match=r"front_wheel.*bed's ends"):
        run_rover(Rover(spacing=0.005, thickness=0.015, leg_length=0.04, bed_width=0.3, bed_depth=0.04,
                        start_x=0.195, settle_time=0.05, t_end=0.2), plot=False)
    # the hopper's foot reaches 0.28 m ahead of its centre of mass: to 0.78 m, within 2 cm of the end
    config = MjcfScene(model=HOPPER, bed_width=0.8, bed_depth=0.06, spacing=0.02, start_x=0.5, settle_time=0.0,
                       t_end=0.1)
    with pytest.raises(ConfigError, match=r"'foot' starts .* bed's ends"):
        run_mjcf(config, plot=False)


def test_an_mjcf_robot_is_watched_against_its_bed_ends() -> None:
    """The extent the check reads is each coupled body's particles at its pose: the hopper stood
    mid-bed (its foot: in hopper.xml a capsule of radius 0.06 m and half-length 0.195 m lying along
    x) lies between the bed's ends, and the check stays silent there."""
    coupled = build_mjcf(MjcfScene(model=HOPPER, bed_width=0.8, bed_depth=0.06, spacing=0.02, settle_time=0.0,
                                   t_end=0.1)).coupling
    ends = BedEnds(coupled, coupled.sim.scene.bed_ends)
    extents = ends.extents()
    assert set(extents) == {"leg", "foot"} and ends() is None
    low, high = extents["foot"]
    # the capsule's length, less Δx (the particles are cell centres, Δx/2 inside each end), within Δx
    assert high - low == pytest.approx(2 * (0.195 + 0.06) - 0.02, abs=0.02)


def test_the_default_leg_wheel_run_stays_on_its_bed() -> None:
    """The default run's end time keeps the wheel on its bed: on the RFT terrain (the SPH's own default
    run takes minutes; its axle, measured, moves 9.6 cm/s after the pause against RFT's 9.7 cm/s) the
    run ends at its end time, the wheel's reach (axle + tip radius 8 cm) short of the bed's end by more
    than the margin."""
    config = LegWheel(terrain="rft", bed_width=SPH_BED_WIDTH)
    run = run_leg_wheel(config, plot=False)
    wheel = run.series["robot/wheel"]
    assert run.summary().get("end_of_bed") is None
    assert wheel["time"][-1] == pytest.approx(config.t_end, abs=0.005)  # its last 2 ms step may end past it
    assert wheel["reference"][-1, 0] + config.leg_length < SPH_BED_WIDTH - BED_END_MARGIN
