"""The leg-wheel's bed parameters (friction angles, water content) varied by a sweep SPEC reach the
SPH material of each run, and ``terrasph dataset`` turns the sweep into a surrogate dataset that has
them as inputs; bad arguments are refused naming them before anything is written."""

from __future__ import annotations

import json
import math
from pathlib import Path

import h5py
import numpy as np
import pytest
from sweep_helpers import TINY_FIXED
from terrasph.cli import main
from terrasph.surrogate.dataset import load_runs
from terrasph.surrogate.validity import PHASE_FEATURES
from terrasph.sweeps.spec import parse_spec

BED = ("mu1_deg", "mu2_deg", "water_content")


def _bed_spec() -> dict:
    """Two tiny leg-wheel runs (0.1 s pause, 0.1 s driven) in a Latin hypercube over the bed."""
    fixed = {**TINY_FIXED, "t_end": 0.2, "series_interval": 0.01}
    vary = {"mu1_deg": {"range": [18.0, 26.0]}, "mu2_deg": {"range": [30.0, 36.0]},
            "water_content": {"range": [0.0, 0.02]}}
    return {"scene": "leg-wheel", "seed": 3, "fixed": fixed,
            "design": {"method": "latin-hypercube", "runs": 2, "vary": vary}}


@pytest.fixture(scope="module")
def bed_sweep(tmp_path_factory: pytest.TempPathFactory) -> Path:
    pytest.importorskip("distributed")
    from terrasph.sweeps.runner import run_sweep

    out = tmp_path_factory.mktemp("bed_sweep")
    manifest = run_sweep(parse_spec(_bed_spec()), out, workers=1, progress=False)
    assert manifest["counts"] == {"completed": 2, "failed": 0, "pending": 0}
    return out


def test_a_spec_varying_the_bed_runs_with_that_material(bed_sweep: Path) -> None:
    """Each run's SPH material (recorded in its file) is the glass beads with the case's friction
    angles (μ = tan φ) and water content (densities × (1 + w), Table 2.1)."""
    cases = json.loads((bed_sweep / "manifest.json").read_text())["cases"]
    assert len({c["config"]["water_content"] for c in cases}) == 2  # the design varied it
    for case in cases:
        with h5py.File(bed_sweep / "runs" / f"{case['case_id']}.h5", "r") as f:
            material = json.loads(f.attrs["config_json"])["material"]
        config = case["config"]
        assert material["mu1"] == pytest.approx(math.tan(math.radians(config["mu1_deg"])), rel=1e-15)
        assert material["mu2"] == pytest.approx(math.tan(math.radians(config["mu2_deg"])), rel=1e-15)
        assert material["water_content"] == config["water_content"]
        assert material["grain_density"] == pytest.approx(2600.0 * (1 + config["water_content"]), rel=1e-15)


def test_dataset_command_writes_the_bed_parameters_as_inputs(bed_sweep: Path, tmp_path: Path, capsys) -> None:
    out = tmp_path / "data"
    assert main(["dataset", str(bed_sweep), "--out", str(out), "--dt", "0.02"]) == 0
    assert "wrote 2 runs" in capsys.readouterr().out
    description = json.loads((out / "dataset.json").read_text())
    assert description["features"] == ["omega_cmd", *PHASE_FEATURES, "load", *BED, "wheel:c-leg"]
    cases = {c["case_id"]: c for c in json.loads((bed_sweep / "manifest.json").read_text())["cases"]}
    runs = load_runs(out)
    assert sorted(run.name for run in runs) == sorted(cases)
    for run in runs:
        assert {name: run.params[name] for name in BED} == {name: cases[run.name]["config"][name] for name in BED}
        np.testing.assert_allclose(run.time, np.arange(6) * 0.02, atol=1e-12)  # 0.1 s driven phase at Δt
        assert run.matrix(description["features"]).shape == (6, 8)


@pytest.mark.parametrize(("args", "message"), [
    (["--dt", "0.08"], "parameter 'dt' = 0.08 is invalid: allowed in (0, 0.05] s"),
    (["--dt", "0"], "--dt: must be a finite number > 0"),
])
def test_dataset_command_refuses_a_bad_dt_before_writing(bed_sweep: Path, tmp_path: Path, capsys,
                                                         args: list[str], message: str) -> None:
    out = tmp_path / "data"
    with pytest.raises(SystemExit) as stop:
        main(["dataset", str(bed_sweep), "--out", str(out), *args])
    assert stop.value.code == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_dataset_command_refuses_what_is_not_a_sweep_or_would_overwrite(bed_sweep: Path, tmp_path: Path,
                                                                        capsys) -> None:
    out = tmp_path / "data"
    with pytest.raises(SystemExit) as stop:
        main(["dataset", str(tmp_path), "--out", str(out)])
    assert stop.value.code == 2 and "no manifest.json" in capsys.readouterr().err
    out.mkdir()
    (out / "old.h5").write_text("an earlier dataset")
    with pytest.raises(SystemExit) as stop:
        main(["dataset", str(bed_sweep), "--out", str(out)])
    assert stop.value.code == 2 and "--out" in capsys.readouterr().err and (out / "old.h5").exists()
    assert main(["dataset", str(bed_sweep), "--out", str(out), "--force"]) == 0
    assert not (out / "old.h5").exists() and len(load_runs(out)) == 2  # exactly this dataset


@pytest.mark.slow
def test_sweep_dataset_train_predict_with_default_options(tmp_path: Path, capsys) -> None:
    """`terrasph sweep`, `dataset`, then `train` with no --features/--targets: the model takes the
    dataset's own inputs and targets (its dataset.json) and records its training run's range, and
    `terrasph predict` runs it on the runs (those outside that range with --extrapolate)."""
    pytest.importorskip("distributed")
    import yaml

    spec, sweep, data, model = tmp_path / "spec.yaml", tmp_path / "sweep", tmp_path / "data", tmp_path / "m.tslstm"
    bed = _bed_spec()
    spec.write_text(yaml.safe_dump({**bed, "design": {**bed["design"], "runs": 3}}))
    assert main(["sweep", str(spec), "--out", str(sweep), "--no-progress"]) == 0
    assert main(["dataset", str(sweep), "--out", str(data)]) == 0
    assert main(["train", str(data), "--out", str(model), "--epochs", "2", "--no-progress"]) == 0
    described = json.loads((data / "dataset.json").read_text())
    from terrasph.surrogate.inference import load_model

    engine = load_model(model, "float64")
    assert list(engine.feature_names) == described["features"]
    assert list(engine.target_names) == described["targets"]
    capsys.readouterr()
    with pytest.raises(SystemExit) as refused:  # one training run: the others' bed lies outside its range
        main(["predict", str(model), str(data)])
    assert refused.value.code == 2 and "outside the model's validity range" in capsys.readouterr().err
    assert main(["predict", str(model), str(data), "--extrapolate"]) == 0
    header = capsys.readouterr().out.splitlines()[0]
    assert header == ",".join(["sequence", "step", *described["targets"]])
