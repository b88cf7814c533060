"""Checkpoint and restart: a run stopped and continued equals, bit for bit, the run that
never stopped.

References, all exact: 2N steps straight against N steps, a checkpoint, a restore **in a new
Python process** and N more steps — every registered field of both particle sets (np.array_equal),
the counters, and the bodies' state — for the column collapse (with the gate removal scheduled
between the two halves), the rotating leg, the plate intrusion and a buried plate pulled up with
Coulomb wall friction on. A Ctrl-C (SIGINT) in the middle
of ``terrasph run`` followed by ``terrasph resume`` gives the same frames and series as the run that
was never interrupted, each frame once and in order. Unusable checkpoints are refused with a
:class:`CheckpointError` that says why, never a crash.
"""

from __future__ import annotations

import dataclasses
import json
import os
import signal
import subprocess
import sys
import time

import h5py
import numpy as np
import pytest
from terrasph.checkpoint import CheckpointError, read_checkpoint
from terrasph.run_loop import checkpoint_path
from terrasph.scenes import SCENES, ColumnCollapse, LegRotation, PlateIntrusion
from terrasph.simulation import Simulation

STEPS = 120

# Small configurations of the three scenes; the collapse's gate goes between the two halves.
CASES = {
    "column-collapse": ColumnCollapse(resolution="coarse", settle_time=0.03),
    "leg-rotation": LegRotation(settle_time=0.002, omega=2.0, bed_depth=0.07, bed_width=0.12),
    "plate-intrusion": PlateIntrusion(spacing=0.005, bed_width=0.12, bed_depth=0.07, settle_time=0.002,
                                      speed=0.2, max_depth=0.02),
    # Coulomb wall friction (its regularisation reads the last step's dt, a saved counter) on a
    # buried plate that is pulled up: the friction acts on the floor, the walls and the body
    "plate-intrusion, buried, wall friction": PlateIntrusion(
        spacing=0.005, bed_width=0.12, bed_depth=0.07, settle_time=0.002, speed=0.2, buried_depth=0.02,
        pull_distance=0.01, numerics={"wall_friction_coefficient": 0.4}),
    # the density advanced in the first pair pass (its rate is not needed again after a restart)
    "leg-rotation, symplectic density": LegRotation(settle_time=0.002, omega=2.0, bed_depth=0.07, bed_width=0.12,
                                                    numerics={"symplectic_density": True, "cfl": 0.5}),
    # each pair evaluated once (half lists and strips, rebuilt from the restored positions)
    "leg-rotation, symmetric pairs": LegRotation(settle_time=0.002, omega=2.0, bed_depth=0.07, bed_width=0.12,
                                                 numerics={"symmetric_pairs": True, "cell_order": True}),
}


def scene_name(case: str) -> str:
    """The registered scene a case configures (the case name up to its first comma)."""
    return case.split(",")[0]

_BUILDERS = {"column-collapse": "build_column_collapse", "leg-rotation": "build_leg_rotation",
             "plate-intrusion": "build_plate_intrusion"}

# Restores a checkpoint in a fresh interpreter, takes N steps and checkpoints again.
_CONTINUE = f"""
import json, sys
import terrasph.scenes as scenes
from terrasph.simulation import Simulation
name, config_json, source, target, steps = sys.argv[1:6]
entry = scenes.SCENES[name]
config = entry.config_from(json.loads(config_json))
scene, material, numerics = getattr(scenes, {_BUILDERS!r}[name])(config)
sim = Simulation(scene, material, numerics, width=config.width)
sim.restore(source)
sim.advance(1e9, max_steps=int(steps))
sim.checkpoint(target)
"""


def build(name: str) -> Simulation:
    import terrasph.scenes as scenes

    config = CASES[name]
    scene, material, numerics = getattr(scenes, _BUILDERS[scene_name(name)])(config)
    return Simulation(scene, material, numerics, width=config.width)


def assert_states_equal(a: dict, b: dict) -> None:
    for part in ("granular", "walls"):
        assert sorted(a[part]) == sorted(b[part]), part
        for name in a[part]:
            assert np.array_equal(a[part][name], b[part][name]), f"{part} field {name} differs"
    assert a["counters"] == b["counters"]
    assert json.dumps(a["bodies"], sort_keys=True, default=np.ndarray.tolist) == \
        json.dumps(b["bodies"], sort_keys=True, default=np.ndarray.tolist)
    assert [tuple(r) for r in a["removals"]] == [tuple(r) for r in b["removals"]]


@pytest.mark.parametrize("name", list(CASES))
def test_restart_in_a_new_process_is_bitwise_identical(tmp_path, name) -> None:
    straight = build(name)
    straight.advance(1e9, max_steps=2 * STEPS)
    first_half = build(name)
    first_half.advance(1e9, max_steps=STEPS)
    if name == "column-collapse":  # the gate is still there: its removal must survive the restart
        assert first_half.core.state()["removals"]
    first_half.checkpoint(tmp_path / "half.h5")
    config_json = json.dumps(dataclasses.asdict(CASES[name]))
    subprocess.run([sys.executable, "-c", _CONTINUE, scene_name(name), config_json, str(tmp_path / "half.h5"),
                    str(tmp_path / "end.h5"), str(STEPS)], check=True)
    continued, _, _ = read_checkpoint(tmp_path / "end.h5")
    reference = straight.core.state()
    # the states hold time and step count, so equal states mean the same 2N steps were taken
    assert continued["counters"]["step"] == 2 * STEPS
    assert_states_equal(reference, continued)
    assert np.abs(straight.velocity).max() > 0  # something moved


def _frames(path) -> int:
    """Frames written so far to a file another process is writing (0 while it is unreadable)."""
    try:
        with h5py.File(path, "r", locking=False) as file:
            return int(file["frames/time"].shape[0])
    except (OSError, KeyError):
        return 0


def test_sigint_then_resume_equals_the_uninterrupted_run(tmp_path) -> None:
    command = ["terrasph", "run", "column-collapse", "--resolution", "coarse", "--t-end", "0.15",
               "--threads", "1", "--no-progress"]
    stopped = tmp_path / "stopped.h5"
    process = subprocess.Popen([*command, "--out", str(stopped)], stdout=subprocess.DEVNULL,
                               stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    # the run loop writes the first frame at once, later ones in batches a second of wall time apart
    # (terrasph.run_loop.SERIES_WRITE_SECONDS), longer than this run: its first frame says it is under way
    while _frames(stopped) < 1 and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    assert process.poll() is None, "the run ended before it could be interrupted"
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=120)
    assert process.returncode == 130 and "interrupted" in err
    with h5py.File(stopped, "r") as file:
        assert file["run"].attrs["status"] == "interrupted"
        interrupted_at = float(file["run"].attrs["time"])
    assert 0 < interrupted_at < 0.15  # stopped between its first and its last frame

    subprocess.run(["terrasph", "resume", str(stopped), "--threads", "1", "--no-progress"], check=True,
                   stdout=subprocess.DEVNULL)
    straight = tmp_path / "straight.h5"
    subprocess.run([*command, "--out", str(straight)], check=True, stdout=subprocess.DEVNULL)
    with h5py.File(stopped, "r") as a, h5py.File(straight, "r") as b:
        times = a["frames/time"][:]
        assert np.all(np.diff(times) > 0)  # every frame once, in order
        assert a["run"].attrs["status"] == b["run"].attrs["status"]
        for name in b["frames"]:
            assert np.array_equal(a["frames"][name][:], b["frames"][name][:]), f"frame field {name} differs"
        for name in b["series/diagnostics"]:
            if name != "wall_time":
                assert np.array_equal(a["series/diagnostics"][name][:], b["series/diagnostics"][name][:]), name
        assert a["results"].attrs["runout_normalised"] == b["results"].attrs["runout_normalised"]


@pytest.fixture
def saved(tmp_path):
    """A checkpoint of the column collapse after a few steps, and its path."""
    sim = build("column-collapse")
    sim.advance(1e9, max_steps=10)
    return sim.checkpoint(tmp_path / "saved.h5")


def test_a_corrupted_checkpoint_is_refused(saved) -> None:
    with h5py.File(saved, "r+") as file:
        velocity = file["granular/velocity"]
        values = velocity[()]
        values[5, 0] = np.nextafter(values[5, 0], 1.0)  # one bit of one number
        velocity[...] = values
    with pytest.raises(CheckpointError, match="corrupted"):
        build("column-collapse").restore(saved)


def test_a_truncated_checkpoint_is_refused(saved) -> None:
    size = os.path.getsize(saved)
    with open(saved, "r+b") as file:
        file.truncate(size // 2)
    with pytest.raises(CheckpointError, match="unreadable"):
        build("column-collapse").restore(saved)


def test_a_checkpoint_of_another_version_is_refused(saved) -> None:
    with h5py.File(saved, "r+") as file:
        file.attrs["format_version"] = 999
    with pytest.raises(CheckpointError, match="version 999"):
        build("column-collapse").restore(saved)


def test_a_checkpoint_of_another_configuration_is_refused(saved, tmp_path) -> None:
    import terrasph.scenes as scenes

    config = dataclasses.replace(CASES["column-collapse"], numerics={"xsph": 0.1})
    scene, material, numerics = scenes.build_column_collapse(config)
    other = Simulation(scene, material, numerics, width=config.width)
    with pytest.raises(CheckpointError, match=r"numerics\.xsph"):
        other.restore(saved)
    with pytest.raises(CheckpointError, match="does not exist"):
        other.restore(tmp_path / "missing.h5")
    (tmp_path / "text.h5").write_text("not a checkpoint")
    with pytest.raises(CheckpointError, match="unreadable"):
        other.restore(tmp_path / "text.h5")


def test_resume_of_a_file_without_checkpoint_is_a_one_line_error(tmp_path) -> None:
    out = tmp_path / "done.h5"
    subprocess.run(["terrasph", "run", "column-collapse", "--resolution", "coarse", "--t-end", "0.01",
                    "--no-progress", "--threads", "1", "--out", str(out)], check=True, stdout=subprocess.DEVNULL)
    checkpoint_path(out).unlink()  # a finished run keeps one (tests/test_output_contract.py): gone
    # continued past its end (resuming a finished run to its own end is refused before the checkpoint is looked for)
    result = subprocess.run(["terrasph", "resume", str(out), "--until", "0.02"], capture_output=True, text=True)
    assert result.returncode == 2
    assert "checkpoint" in result.stderr and "Traceback" not in result.stderr


def test_scene_registry_round_trips_every_scene_configuration() -> None:
    for name, config in CASES.items():
        entry = SCENES[scene_name(name)]
        restored = entry.config_from(json.loads(json.dumps(dataclasses.asdict(config))))
        assert restored == config
