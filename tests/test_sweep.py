"""``terrasph sweep`` on a Dask LocalCluster with tiny leg-wheel runs (tests/sweep_helpers.py):
failures recorded while the sweep goes on, a killed sweep resumed running each case exactly once,
partial or corrupted run files never taken as finished; then the whole chain sweep → dataset →
train → export → C++ prediction equal to PyTorch's within the parity bounds of test_lstm_parity."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml
from sweep_helpers import tiny_spec
from terrasph.sweeps.runner import is_finished, run_sweep
from terrasph.sweeps.spec import parse_spec

pytestmark = pytest.mark.slow


def _events(out: Path) -> list[dict]:
    return [json.loads(line) for line in (out / "events.jsonl").read_text().splitlines()]


@pytest.fixture(scope="module")
def tiny_sweep(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """8 cases on 2 workers: 2 morphologies × 2 input kinds, each with the adaptive step (runs) and
    with a fixed step of 1 ms, 6× the stable bound at Δx = 1 cm (fails at its first step)."""
    spec = tiny_spec(method="grid", vary={"wheel": {"values": ["c-leg", "wheel"]},
                                          "numerics.fixed_dt": {"values": [0.0, 1e-3]}},
                     input={"parameter": "omega_schedule", "kinds": ["step", "random"], "range": [0.5, 3.0]})
    del spec["design"]["runs"]
    out = tmp_path_factory.mktemp("sweep")
    run_sweep(parse_spec(spec), out, workers=2, progress=False)
    return out


def test_failing_cases_are_recorded_and_the_sweep_goes_on(tiny_sweep: Path) -> None:
    manifest = json.loads((tiny_sweep / "manifest.json").read_text())
    assert manifest["counts"] == {"completed": 4, "failed": 4, "pending": 0}
    for case in manifest["cases"]:
        run = tiny_sweep / "runs" / f"{case['case_id']}.h5"
        unstable = case["config"]["numerics"].get("fixed_dt", 0.0) > 0
        assert case["status"] == ("failed" if unstable else "completed")
        if unstable:
            assert "InstabilityError" in case["error"] and "fixed_dt" in case["error"] and not run.exists()
        else:
            assert is_finished(run) and case["wall_time"] > 0 and "terrasph" in case["versions"]
    assert not list((tiny_sweep / "runs").glob("*partial*"))  # no staging left, no partial names
    assert not list((tiny_sweep / "runs").glob("*.checkpoint.h5"))


def test_a_killed_sweep_resumes_running_each_case_once_and_never_trusts_a_broken_file(tmp_path: Path) -> None:
    spec_file = tmp_path / "spec.yaml"
    spec_file.write_text(yaml.safe_dump(tiny_spec(runs=4)))
    out = tmp_path / "out"
    command = [sys.executable, "-m", "terrasph.cli", "sweep", str(spec_file), "--out", str(out), "--no-progress"]
    sweep = subprocess.Popen(command, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 300
    while not (out / "events.jsonl").exists() or not any(e["event"] == "finished" for e in _events(out)):
        assert time.monotonic() < deadline and sweep.poll() is None, "no case finished"
        time.sleep(0.1)
    os.killpg(sweep.pid, signal.SIGKILL)  # the client, its LocalCluster and the workers, mid-run
    sweep.wait()
    spec = parse_spec(tiny_spec(runs=4))
    finished_first = {e["case"] for e in _events(out) if e["event"] == "finished"}
    assert finished_first == {p.stem for p in (out / "runs").glob("*.h5") if not p.name.endswith(".xdmf.h5")}
    assert 1 <= len(finished_first) < 4, "the kill came too late to test a resume"
    unfinished = [c.case_id for c in spec.cases if c.case_id not in finished_first]
    (out / "runs" / f"{unfinished[0]}.h5").write_bytes(b"\x89HDF\r\n\x1a\n truncated")  # corrupted
    if len(unfinished) > 1:
        with h5py.File(out / "runs" / f"{unfinished[1]}.h5", "w") as f:  # valid HDF5, run never finished
            f.create_group("run").attrs["status"] = "running"
    run_sweep(spec, out, workers=1, progress=False)
    events = _events(out)
    sessions = list(dict.fromkeys(e["session"] for e in events))
    assert len(sessions) == 2
    finished = [e["case"] for e in events if e["event"] == "finished"]
    assert sorted(finished) == sorted(c.case_id for c in spec.cases)  # each case finished exactly once
    for event in ("submitted", "started"):  # the finished ones skipped, the broken files run again
        assert {e["case"] for e in events if e["event"] == event and e["session"] == sessions[1]} == set(unfinished)
    assert all(is_finished(out / "runs" / f"{c.case_id}.h5") for c in spec.cases)


def test_sweep_to_dataset_to_training_to_cpp_prediction(tiny_sweep: Path, tmp_path: Path) -> None:
    torch = pytest.importorskip("torch")
    from terrasph.scenes import SCENES
    from terrasph.surrogate.dataset import load_runs
    from terrasph.surrogate.export import export_model
    from terrasph.surrogate.inference import load_model
    from terrasph.surrogate.robot_dataset import build_robot_dataset
    from terrasph.surrogate.train import TrainConfig, train

    description = build_robot_dataset(tiny_sweep, tmp_path / "data", dt=0.02)
    assert len(description["runs"]) == 4 and len(description["skipped_failed"]) == 4
    runs = load_runs(tmp_path / "data")
    manifest = {c["case_id"]: c for c in json.loads((tiny_sweep / "manifest.json").read_text())["cases"]}
    for run in runs:
        config = SCENES["leg-wheel"].config_from(manifest[run.name]["config"])
        assert np.allclose(np.diff(run.time), 0.02) and run.time[-1] == pytest.approx(0.5)
        assert np.allclose(run.series["omega_cmd"], config.commanded_omega(run.time + config.settle_time),
                           rtol=1e-12, atol=0)  # the schedule, evaluated on the driven phase's clock
        assert np.all(np.abs(run.series["slip"]) <= 1) and run.params[f"wheel:{config.wheel}"] == 1.0
    torch.set_num_threads(1)
    features = tuple(description["features"])
    for cell in ("standard", "peephole"):
        result = train(runs, TrainConfig(features=features, targets=("slip", "sinkage"), cell=cell, hidden_size=8,
                                         epochs=5, patience=5), progress=False, splits=([0, 1], [2], [3]))
        path = export_model(result.net, tmp_path / f"{cell}.tslstm", features, ("slip", "sinkage"), result.metadata())
        x = np.stack([run.matrix(features) for run in runs])
        with torch.no_grad():
            expected32 = result.net(torch.from_numpy(x.astype(np.float32))).numpy()
            expected64 = result.net.double()(torch.from_numpy(x)).numpy()
        assert np.max(np.abs(load_model(path, "float32").predict(x.astype(np.float32)) - expected32)) <= 1e-5
        assert np.max(np.abs(load_model(path, "float64").predict(x) - expected64)) <= 1e-10
