"""Surrogates by name and their validity range: a model trained on leg-wheel runs records what its
training runs covered (terrasph.surrogate.validity) in its file; ``terrasph predict`` refuses a run
outside it in one line (exit 2) unless --extrapolate; shipped models are found by name.

One tiny SPH leg-wheel run (Δx = 1 cm, 0.1 s pause + 0.3 s driven, ~2 s) is the run predicted; the
training runs whose range a model records are that run with its load, ω(t) or configuration
changed: the validity is a function of the runs' inputs and configurations only."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from lstm_helpers import core_lstm, make_net
from sweep_helpers import TINY_FIXED
from terrasph.cli import main
from terrasph.config import ConfigError
from terrasph.surrogate import available, pretrained, pretrained_path
from terrasph.surrogate.dataset import Run, write_run
from terrasph.surrogate.export import export_model, read_model_file
from terrasph.surrogate.robot_dataset import TARGETS, commanded_phase, features_of, leg_wheel_fields, robot_run
from terrasph.surrogate.validity import PHASE_FEATURES, Validity, training_validity

pytest.importorskip("torch")

DT = 0.02
FEATURES = list(features_of(["c-leg", "wheel"]))  # omega_cmd, leg_phase_sin/cos, load, wheel:c-leg, wheel:wheel
#: the inputs a user writes in a CSV: the legs' phase is derived from omega_cmd
CSV_FEATURES = [f for f in FEATURES if f not in PHASE_FEATURES]
SCHEDULE = ((0.0, 1.0), (0.15, 1.0), (0.15, 2.0))  # a step from 1 to 2 rad/s


@pytest.fixture(scope="module")
def run_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from terrasph.scenes import run_case

    path = tmp_path_factory.mktemp("leg_wheel") / "run.h5"
    run_case("leg-wheel", {**TINY_FIXED, "t_end": 0.4, "load": 3.0, "wheel": "c-leg", "omega_schedule": SCHEDULE},
             path)
    return path


@pytest.fixture(scope="module")
def base(run_file: Path) -> tuple[Run, dict]:
    """The run file as a dataset run of the model's inputs, and its configuration."""
    return robot_run(run_file, DT, ["c-leg", "wheel"]), leg_wheel_fields(run_file)


def variant(base: tuple[Run, dict], name: str, omega_scale: float = 1.0, **config) -> tuple[Run, dict]:
    """The base run with its load (a parameter and the configuration's) or configuration changed and
    its commanded ω scaled."""
    run, saved = base
    series = {**run.series, "omega_cmd": run.series["omega_cmd"] * omega_scale}
    params = {**run.params, **{k: v for k, v in config.items() if k in run.params}}
    return dataclasses.replace(run, name=name, series=series, params=params), {**saved, **config}


def model_for(tmp_path: Path, runs: list[tuple[Run, dict]], name: str = "model") -> tuple[Path, Validity]:
    """An (untrained) model of the leg-wheel inputs whose metadata records the validity of `runs`."""
    validity = training_validity([r for r, _ in runs], FEATURES, [c for _, c in runs])
    path = export_model(make_net("standard", 4, 1, seed=1, n_in=len(FEATURES), n_out=len(TARGETS)),
                        tmp_path / f"{name}.tslstm", FEATURES, TARGETS, {"validity": validity.to_json(), "dt": DT})
    return path, validity


def refusal(capsys, argv: list[str]) -> str:
    """The one error line of a command that must end with exit status 2."""
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    err = capsys.readouterr().err
    assert exit_info.value.code == 2, err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    return err


def test_training_on_a_robot_dataset_records_its_validity(base, tmp_path, capsys) -> None:
    """`terrasph train` on a dataset of leg-wheel runs writes, in the model file's metadata, the range
    of each input over the training split (the loads of the runs the split names, from dataset.json),
    the runs' shared configuration, morphology, Δt and driven phase; the Python reader and the C++
    engine read the same JSON, and it round-trips through Validity."""
    data = tmp_path / "data"
    data.mkdir()
    loads = {f"r{k}": load for k, load in enumerate((4.0, 5.0, 6.5, 8.0, 9.0))}
    for name, load in loads.items():
        run, config = variant(base, name, load=load)
        write_run(data / f"{name}.h5", run, body="wheel", config=config)
    (data / "dataset.json").write_text(json.dumps({"features": FEATURES, "targets": list(TARGETS), "dt": DT,
                                                   "runs": {n: {"load": v} for n, v in loads.items()}}))
    model = tmp_path / "m.tslstm"
    assert main(["train", str(data), "--out", str(model), "--epochs", "2", "--hidden", "4", "--no-progress"]) == 0
    capsys.readouterr()

    metadata = read_model_file(model).metadata
    assert json.loads(core_lstm().Model64(str(model)).metadata) == metadata
    validity = Validity.from_metadata(metadata)
    assert Validity.from_json(json.loads(json.dumps(validity.to_json()))) == validity
    trained = [loads[name] for name in metadata["splits"]["train"]]
    assert validity.ranges["load"] == (min(trained), max(trained))
    assert validity.ranges["omega_cmd"] == (1.0, 2.0)  # the schedule's ω over the driven phase
    assert validity.morphologies == ("c-leg",) and validity.runs == len(trained)
    assert validity.fixed["spacing"] == TINY_FIXED["spacing"] and validity.fixed["thickness"] == TINY_FIXED["thickness"]
    assert validity.dt == pytest.approx(DT) and validity.duration == pytest.approx(0.3)
    assert "load" not in validity.fixed and "t_end" not in validity.fixed


@pytest.mark.parametrize("changes, named", [
    ({"load": 5.0}, "parameter 'load' = 3 is outside the model's validity range [5, 6]"),
    ({"omega_scale": 0.5}, "input 'omega_cmd' reaches 2, outside the model's validity range [0.5, 1]"),
    ({"spacing": 0.005}, "parameter 'spacing' = 0.01 differs from the model's 0.005"),
    ({"wheel": "wheel"}, "parameter 'wheel' = 'c-leg' is outside the model's morphologies wheel"),
    ({"mu1_deg": 20.0}, "parameter 'mu1_deg' = 23 differs from the model's 20"),
])
def test_predict_refuses_a_run_outside_the_range(base, run_file, tmp_path, capsys, changes, named) -> None:
    """A model trained on runs that differ from the SPH run in one respect refuses it, naming the
    parameter, the run's value and the model's range, in one line with exit status 2; with
    --extrapolate it predicts every step and reports the RMSE against the run's own series."""
    scale = changes.pop("omega_scale", 1.0)
    # two training runs: the changed one and one more 20 % further (a range, for the load)
    runs = [variant(base, "a", scale, **changes),
            variant(base, "b", scale, **{k: v * 1.2 if k == "load" else v for k, v in changes.items()})]
    model, _ = model_for(tmp_path, runs)
    err = refusal(capsys, ["predict", str(model), str(run_file)])
    assert named in err and "--extrapolate" in err

    assert main(["predict", str(model), str(run_file), "--extrapolate"]) == 0
    captured = capsys.readouterr()
    rows = captured.out.strip().splitlines()
    assert rows[0] == "sequence,step," + ",".join(TARGETS) and len(rows) == 1 + base[0].length
    assert "RMSE against its series" in captured.err and all(t in captured.err for t in TARGETS)


def test_predict_accepts_a_run_inside_the_range(base, run_file, tmp_path, capsys) -> None:
    """Training runs at 2 and 4 N with ω scaled by 0.5 and 1.5 around the run (3 N, ω 1-2 rad/s): the
    run is predicted without --extrapolate, as the engine predicts its inputs, and the RMSE reported
    is that of the prediction against the run's SPH series."""
    model, _ = model_for(tmp_path, [variant(base, "a", 0.5, load=2.0), variant(base, "b", 1.5, load=4.0)])
    out = tmp_path / "y.csv"
    assert main(["predict", str(model), str(run_file), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    got = np.loadtxt(out, delimiter=",", skiprows=1, usecols=(2, 3, 4))
    run = base[0]
    expected = core_lstm().Model64(str(model)).predict(run.matrix(FEATURES))
    np.testing.assert_array_equal(got, expected)
    rmse_slip = np.sqrt(np.mean((expected[:, 0] - run.series["slip"]) ** 2))
    assert f"slip {rmse_slip:.4g}" in printed


def test_a_new_schedule_from_csv_is_checked_too(base, tmp_path, capsys) -> None:
    """A user's ω(t) as CSV rows of the inputs: inside the range it is predicted; a schedule reaching
    beyond the training runs' ω, or columns that are not one morphology, are refused naming them."""
    model, _ = model_for(tmp_path, [variant(base, "a", 0.5, load=2.0), variant(base, "b", 1.5, load=4.0)])
    steps = base[0].length
    omega = np.linspace(0.5, 3.0, steps)
    header = ",".join(CSV_FEATURES)
    inside = tmp_path / "inside.csv"
    np.savetxt(inside, np.column_stack([omega, np.full(steps, 3.0), np.ones(steps), np.zeros(steps)]),
               delimiter=",", header=header, comments="")
    assert main(["predict", str(model), str(inside)]) == 0
    assert len(capsys.readouterr().out.strip().splitlines()) == 1 + steps
    beyond = tmp_path / "beyond.csv"
    np.savetxt(beyond, np.column_stack([omega * 1.5, np.full(steps, 3.0), np.ones(steps), np.zeros(steps)]),
               delimiter=",", header=header, comments="")
    assert "input 'omega_cmd' reaches 4.5" in refusal(capsys, ["predict", str(model), str(beyond)])
    mixed = tmp_path / "mixed.csv"
    np.savetxt(mixed, np.column_stack([omega, np.full(steps, 3.0), np.ones(steps), np.ones(steps)]),
               delimiter=",", header=header, comments="")
    assert "must be one-hot" in refusal(capsys, ["predict", str(model), str(mixed)])


def test_the_legs_phase_is_the_integral_of_the_commanded_spin(base) -> None:
    """legs·θ with θ = ∫ω_cmd dt: for a constant ω the unwrapped phase is legs·ω·t exactly; for the run's
    step from 1 to 2 rad/s at 0.15 s (between samples) it ends within the trapezoid's error
    legs·Δω·dt/2 of the exact legs·(1·0.15 + 2·(T − 0.15)), and both columns lie on the unit circle."""
    t = np.arange(50) * DT
    phase = commanded_phase(np.full(50, 1.7), DT, 3)
    np.testing.assert_allclose(np.unwrap(np.arctan2(phase["leg_phase_sin"], phase["leg_phase_cos"])),
                               3 * 1.7 * t, atol=1e-12)
    run, config = base
    assert config["legs"] == 3
    sin, cos = run.series["leg_phase_sin"], run.series["leg_phase_cos"]
    np.testing.assert_allclose(sin ** 2 + cos ** 2, 1.0, atol=1e-12)
    end = run.time[-1]
    exact = 3 * (1.0 * 0.15 + 2.0 * (end - 0.15))
    got = np.unwrap(np.arctan2(sin, cos))[-1]
    assert abs(got - exact) <= 3 * 1.0 * DT / 2 + 1e-12


def test_a_csv_without_the_phase_predicts_as_the_run_file(base, run_file, tmp_path, capsys) -> None:
    """The run's own inputs written as CSV without the phase columns: `terrasph predict` derives them
    from omega_cmd and predicts bit for bit what it predicts from the run file."""
    model, _ = model_for(tmp_path, [variant(base, "a", 0.5, load=2.0), variant(base, "b", 1.5, load=4.0)])
    from_run, from_csv = tmp_path / "run.csv", tmp_path / "schedule.csv"
    assert main(["predict", str(model), str(run_file), "--out", str(from_run)]) == 0
    csv = tmp_path / "inputs.csv"
    np.savetxt(csv, base[0].matrix(CSV_FEATURES), delimiter=",", header=",".join(CSV_FEATURES), comments="")
    assert main(["predict", str(model), str(csv), "--out", str(from_csv)]) == 0
    capsys.readouterr()
    np.testing.assert_array_equal(np.loadtxt(from_run, delimiter=",", skiprows=1, usecols=(2, 3, 4)),
                                  np.loadtxt(from_csv, delimiter=",", skiprows=1, usecols=(2, 3, 4)))


def test_pretrained_by_name(base, run_file, tmp_path, capsys) -> None:
    """A models directory is searched by name: the model loads into the C++ engine with its metadata;
    an unknown name is refused listing the names there are (Python: ConfigError; command line: one
    line, exit 2)."""
    models = tmp_path / "models"
    models.mkdir()
    path, validity = model_for(models, [variant(base, "a", load=2.0), variant(base, "b", load=4.0)], "tiny-wheel")
    assert available(models) == ["tiny-wheel"] and pretrained_path("tiny-wheel", models) == path
    model = pretrained("tiny-wheel", models_dir=models)
    assert model.validity == validity and model.feature_names == FEATURES and model.target_names == list(TARGETS)
    x = base[0].matrix(FEATURES)
    np.testing.assert_array_equal(model.engine.predict(x), core_lstm().Model64(str(path)).predict(x))
    with pytest.raises(ConfigError, match="unknown model 'tiny-whel': the models there are: tiny-wheel"):
        pretrained("tiny-whel", models_dir=models)
    with pytest.raises(ConfigError, match="the models there are: none"):
        pretrained_path("tiny-wheel", tmp_path / "empty")
    err = refusal(capsys, ["predict", "no-such-model", str(run_file)])
    assert "unknown model 'no-such-model': the models there are: " in err
