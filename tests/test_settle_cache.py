"""Settle once (terrasph.settle_cache): a leg-wheel run that starts from the cached state at the end of
its pause equals, bit for bit, the run that settles itself (the independent reference: the same
configuration run with ``cache=False``, never touching the cache); the key changes with every field
that acts before the drive and not with the drive's; two processes after the same entry settle it once
and both start from it; a sweep of cases differing only in ω(t) settles once, by its event log."""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
from pathlib import Path

import h5py
import mujoco
import numpy as np
import pytest
from robot_helpers import assert_same_series
from terrasph.cli import main
from terrasph.io import read_run
from terrasph.scenes.leg_wheel import LegWheel, build_leg_wheel, run_leg_wheel
from terrasph.scenes.rover import Rover, run_rover
from terrasph.settle_cache import (
    CACHE_ENV,
    SettleCache,
    cache_key,
    key_text,
    model_digest,
)
from terrasph.simulation import versions

#: a coarse, short leg-wheel on the SPH bed (~1 s a run): 0.1 s pause, 0.1 s driven
TINY = LegWheel(wheel="c-leg", spacing=0.005, thickness=0.015, leg_length=0.04, bed_width=0.2, bed_depth=0.04,
                start_x=0.06, settle_time=0.1, t_end=0.2, load=2.0, fidelity="fast")


def _same_run_files(a: Path, b: Path) -> None:
    """Every frame, series (but wall time) and result of two run files bitwise equal."""
    x, y = read_run(a), read_run(b)
    assert np.array_equal(x.times, y.times) and np.array_equal(x.steps, y.steps) and set(x.fields) == set(y.fields)
    for name in x.fields:
        assert x.fields[name].tobytes() == y.fields[name].tobytes(), name
    assert_same_series(x, y)
    assert x.group_attrs["/results"] == y.group_attrs["/results"]


def _settled_state(path: Path) -> dict[str, str]:
    with h5py.File(path, "r") as file:
        return {k: str(v) for k, v in file.attrs.items() if k.startswith("settled_state_")}


def test_a_cached_start_equals_the_run_that_settles_itself(tmp_path: Path) -> None:
    cache = SettleCache(tmp_path / "cache")
    itself = run_leg_wheel(TINY, tmp_path / "itself.h5", plot=False, cache=False)
    settled = run_leg_wheel(TINY, tmp_path / "settled.h5", plot=False, cache=cache)
    cached = run_leg_wheel(TINY, tmp_path / "cached.h5", plot=False, cache=cache)
    assert not _settled_state(tmp_path / "itself.h5")
    first, second = _settled_state(tmp_path / "settled.h5"), _settled_state(tmp_path / "cached.h5")
    assert first["settled_state_event"] == "settled" and second["settled_state_event"] == "from_cache"
    assert first["settled_state_key"] == second["settled_state_key"]
    assert Path(second["settled_state_path"]).is_dir() and len(cache.entries()) == 1
    for run, path in ((settled, "settled.h5"), (cached, "cached.h5")):
        _same_run_files(tmp_path / "itself.h5", tmp_path / path)
        assert json.dumps(run.values) == json.dumps(itself.values)  # floats by repr: bit for bit
        assert_same_series(itself, run)
    assert read_run(tmp_path / "cached.h5").config["leg_wheel"] == json.loads(json.dumps(dataclasses.asdict(TINY)))
    assert itself.values["mean_forward_speed"] > 0  # the run did drive past its pause


def test_a_run_with_another_omega_starts_from_the_same_pause_and_equals_its_own_settled_run(tmp_path: Path) -> None:
    """The drive is not part of the key: ω and its schedule change, the pause is found; the run equals,
    bit for bit, the same ω settled by itself, and not the first ω's run (the drive does act)."""
    cache = SettleCache(tmp_path / "cache")
    run_leg_wheel(TINY, tmp_path / "first.h5", plot=False, cache=cache)
    faster = dataclasses.replace(TINY, omega_schedule=((0.0, 3.0), (0.05, 3.0), (0.05, 1.0)))
    cached = run_leg_wheel(faster, tmp_path / "faster.h5", plot=False, cache=cache)
    itself = run_leg_wheel(faster, tmp_path / "itself.h5", plot=False, cache=False)
    assert _settled_state(tmp_path / "faster.h5")["settled_state_event"] == "from_cache"
    _same_run_files(tmp_path / "itself.h5", tmp_path / "faster.h5")
    assert cached.values["motor_work"] == itself.values["motor_work"]
    assert cached.values["mean_omega"] != pytest.approx(TINY.omega, rel=0.05)


def _key(config: LegWheel) -> str:
    built = build_leg_wheel(config)
    return cache_key(key_text("leg-wheel", config, built.coupling.describe(),
                              {**versions(), "mujoco": mujoco.__version__}, model_digest(built.model)))


@pytest.mark.parametrize("change", [{"load": 2.5}, {"spacing": 0.0045}, {"settle_time": 0.12}, {"wheel": "wheel"},
                                    {"series_interval": 0.02}, {"frame_interval": 0.04}, {"fidelity": "standard"},
                                    {"numerics": {"xsph": 0.1}}, {"mu1_deg": 20.0}, {"motor_gain": 10.0},
                                    {"start_x": 0.07}, {"bed_depth": 0.05}])
def test_the_key_changes_with_every_field_before_the_drive(change: dict) -> None:
    assert _key(dataclasses.replace(TINY, **change)) != _key(TINY)


def test_a_cached_rover_start_equals_the_rover_that_settles_itself(tmp_path: Path) -> None:
    """The rover (two coupled wheels, its MJCF's motors) likewise, and a rover with another ω starts
    from the same entry."""
    cache = SettleCache(tmp_path / "cache")
    rover = Rover(spacing=0.005, thickness=0.015, leg_length=0.04, bed_width=0.3, bed_depth=0.04, start_x=0.12,
                  settle_time=0.08, t_end=0.14, omega=2.0)
    run_rover(rover, tmp_path / "itself.h5", plot=False, cache=False)
    run_rover(dataclasses.replace(rover, omega=1.0), tmp_path / "other.h5", plot=False, cache=cache)
    cached = run_rover(rover, tmp_path / "cached.h5", plot=False, cache=cache)
    assert _settled_state(tmp_path / "cached.h5")["settled_state_event"] == "from_cache"
    _same_run_files(tmp_path / "itself.h5", tmp_path / "cached.h5")
    assert cached.values["distance"] != 0


def test_the_key_does_not_change_with_the_drive() -> None:
    """ω, its schedule and the end time act only after the pause (LegWheel.DRIVE_FIELDS)."""
    drives = [{"omega": 3.0}, {"omega_schedule": ((0.0, 0.5), (1.0, 2.0))}, {"t_end": 4.0}]
    assert {_key(dataclasses.replace(TINY, **change)) for change in drives} == {_key(TINY)}


RACER = """
import json, sys
from terrasph.scenes.leg_wheel import LegWheel, run_leg_wheel
from terrasph.settle_cache import SettleCache
config = LegWheel(**json.loads(sys.argv[1]))
run = run_leg_wheel(config, sys.argv[2], plot=False, cache=SettleCache(sys.argv[3]))
"""


@pytest.mark.slow  # two interpreters started: ~4 s idle, 15 s on the shared machine
def test_two_processes_after_the_same_pause_settle_it_once(tmp_path: Path) -> None:
    """Started together on one key: one settles and caches it, the other waits and starts from it;
    both equal the run that settled itself, and the cache holds one whole entry, no temporary left."""
    config = json.dumps(dataclasses.asdict(TINY), default=list)
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    racers = [subprocess.Popen([sys.executable, "-c", RACER, config, str(tmp_path / f"r{i}.h5"), str(tmp_path / "c")],
                               env=env) for i in range(2)]
    assert [racer.wait(timeout=300) for racer in racers] == [0, 0]
    events = sorted(_settled_state(tmp_path / f"r{i}.h5")["settled_state_event"] for i in range(2))
    assert events == ["from_cache", "settled"]
    run_leg_wheel(TINY, tmp_path / "itself.h5", plot=False, cache=False)
    for i in range(2):
        _same_run_files(tmp_path / "itself.h5", tmp_path / f"r{i}.h5")
    assert len(SettleCache(tmp_path / "c").entries()) == 1
    assert not [p for p in (tmp_path / "c").iterdir() if p.name.endswith(".tmp")]


def test_an_entry_left_incomplete_is_settled_again(tmp_path: Path) -> None:
    """A crash between the copy and the rename leaves no entry.json: that directory is not a start."""
    cache = SettleCache(tmp_path / "cache")
    key = _key(TINY)
    (cache.entry(key)).mkdir(parents=True)
    (cache.entry(key) / "pause.h5").write_bytes(b"half a file")
    run_leg_wheel(TINY, tmp_path / "run.h5", plot=False, cache=cache)
    assert _settled_state(tmp_path / "run.h5")["settled_state_event"] == "settled"
    run_leg_wheel(TINY, tmp_path / "again.h5", plot=False, cache=cache)
    _same_run_files(tmp_path / "run.h5", tmp_path / "again.h5")


def test_cache_list_and_clear(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture) -> None:
    monkeypatch.setenv(CACHE_ENV, str(tmp_path))
    assert main(["run", "leg-wheel", "--wheel", "c-leg", "--spacing", "0.005", "--thickness", "0.015",
                 "--leg-length", "0.04", "--bed-width", "0.2", "--bed-depth", "0.04", "--start-x", "0.06",
                 "--settle-time", "0.1", "--t-end", "0.15", "--fidelity", "fast", "--no-progress", "--threads", "1",
                 "--out", str(tmp_path / "run.h5")]) == 0
    capsys.readouterr()
    assert main(["info", str(tmp_path / "run.h5")]) == 0
    assert "settled its pause and cached it" in capsys.readouterr().out
    assert main(["cache", "list", "--json"]) == 0
    listed = json.loads(capsys.readouterr().out)
    assert [entry["key"] for entry in listed["entries"]] == [_settled_state(tmp_path / "run.h5")["settled_state_key"]]
    assert listed["entries"][0]["scene"] == "leg-wheel" and listed["entries"][0]["bytes"] > 0
    assert main(["cache", "clear"]) == 0
    assert "removed 1" in capsys.readouterr().out
    assert SettleCache(tmp_path / "settled").entries() == []


@pytest.mark.slow  # a Dask cluster of two workers and 2 × 4 tiny runs: ~30 s
def test_a_sweep_over_omega_settles_once_and_a_second_sweep_settles_nothing(tmp_path: Path,
                                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    """Four cases differing only in ω(t) (step schedules) on two workers: one ``settled`` line in the
    event log, three ``started_from_cache``, one key; a second sweep of the same bed and robot (other
    ω values) settles nothing."""
    from sweep_helpers import TINY_FIXED
    from terrasph.sweeps.runner import run_sweep
    from terrasph.sweeps.spec import parse_spec

    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "cache"))  # the workers inherit it

    def sweep(out: Path, omega_range: list[float]) -> list[dict]:
        spec = {"scene": "leg-wheel", "seed": 3, "fixed": dict(TINY_FIXED),
                "design": {"method": "latin-hypercube", "runs": 4, "vary": {},
                           "input": {"parameter": "omega_schedule", "kinds": ["step"], "range": omega_range}}}
        run_sweep(parse_spec(spec), out, workers=2, progress=False)
        return [json.loads(line) for line in (out / "events.jsonl").read_text().splitlines()]

    first = sweep(tmp_path / "first", [0.5, 3.0])
    starts = [e for e in first if e["event"] in ("settled", "started_from_cache")]
    assert sorted(e["event"] for e in starts) == ["settled"] + ["started_from_cache"] * 3
    assert len({e["key"] for e in starts}) == 1 and sum(e["event"] == "finished" for e in first) == 4
    second = sweep(tmp_path / "second", [1.0, 2.0])
    assert [e["event"] for e in second if e["event"] in ("settled", "started_from_cache")] == ["started_from_cache"] * 4
