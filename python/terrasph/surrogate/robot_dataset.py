"""Dataset of leg-wheel runs (a ``terrasph sweep`` directory) for the surrogate.

Per finished run of the sweep's manifest, from ``/series/robot/wheel`` and the run's
configuration (``config_json``), over the driven phase t ∈ [settle_time, duration] shifted to
start at 0 and resampled to a stated Δt (linear interpolation of the SPH samples):

* inputs: ``omega_cmd`` the commanded spin ω(t) (rad/s, the schedule itself, not the measured
  spin), the legs' commanded phase ``leg_phase_sin``, ``leg_phase_cos`` (:func:`commanded_phase`:
  where the legs strike, which ω alone cannot tell; docs/surrogate.md §8), and the run's fixed parameters: ``load`` (N), the bed's ``mu1_deg``, ``mu2_deg`` (friction
  angles, degrees) and ``water_content`` when the sweep varies them, and one indicator
  ``wheel:<morphology>`` per morphology of the sweep (1 for the run's own, else 0);
* targets: ``slip`` (Eq. 4.8, clipped to [−1, 1]: it leaves that interval only while the axle is
  pushed backwards), ``sinkage`` (m), and ``forward_speed`` v_x (m/s).

Splits are by run, never by time step; :func:`split_held_out` keeps the runs whose parameter (e.g.
the load) or input series (e.g. the commanded ω at any step) leaves a range apart as extrapolation
tests, one per range, and splits the rest into train, validation and the interpolation test
(:func:`split_by_range`: one parameter's range).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from terrasph.schedules import evaluate
from terrasph.surrogate.dataset import Run, split_runs, write_run
from terrasph.surrogate.validity import PHASE_FEATURES, Validity, training_validity

__all__ = ["BED_PARAMETERS", "TARGETS", "build_robot_dataset", "commanded_phase", "dataset_validity", "driven_phase_run", "features_of", "is_leg_wheel_run", "leg_wheel_fields",
           "robot_run", "split_by_range", "split_held_out"]

TARGETS = ("slip", "sinkage", "forward_speed")
#: the leg-wheel's bed parameters that become inputs of a dataset whose runs differ in them
BED_PARAMETERS = ("mu1_deg", "mu2_deg", "water_content")
_UNITS = {"omega_cmd": "rad/s", "leg_phase_sin": "1", "leg_phase_cos": "1", "slip": "1", "sinkage": "m", "forward_speed": "m/s"}


def features_of(wheels: Sequence[str], bed: Sequence[str] = ()) -> tuple[str, ...]:
    """Input columns of a dataset whose runs use the morphologies `wheels` and differ in the bed
    parameters `bed` (of BED_PARAMETERS)."""
    return ("omega_cmd", *PHASE_FEATURES, "load", *bed, *(f"wheel:{w}" for w in sorted(wheels)))


def commanded_phase(omega_cmd: np.ndarray, dt: float, legs: int) -> dict[str, np.ndarray]:
    """The legs' commanded phase at the samples `omega_cmd` (rad/s, steps of `dt` from the end of
    the pause): sin and cos of legs·θ, θ = ∫₀ᵗ ω_cmd dt′ (trapezoidal on the samples, so a run file
    and a CSV of the same samples give the same columns); legs·θ repeats at every leg strike."""
    omega = np.asarray(omega_cmd, dtype=np.float64)
    theta = np.concatenate([[0.0], np.cumsum(0.5 * dt * (omega[1:] + omega[:-1]))])
    return dict(zip(PHASE_FEATURES, (np.sin(legs * theta), np.cos(legs * theta))))


def _bed_value(config: dict[str, Any], name: str) -> float:
    """A bed parameter of a leg-wheel configuration (its default in runs made before it existed)."""
    from terrasph.scenes.leg_wheel import LegWheel

    return float(config.get(name, LegWheel.__dataclass_fields__[name].default))


def _driven_phase(config: dict[str, Any]) -> float:
    config = _leg_wheel_config(config)
    return float(config["t_end"]) - float(config["settle_time"])


def _leg_wheel_config(saved: dict[str, Any]) -> dict[str, Any]:
    """A saved leg-wheel configuration (run file, manifest) under the current field names."""
    from terrasph.scenes import SCENES

    return SCENES["leg-wheel"].current_names(saved)


def leg_wheel_fields(path: str | Path) -> dict[str, Any]:
    """Every configuration field of the leg-wheel run in `path`, a run file of the scene or a file of
    a dataset (:func:`build_robot_dataset`), under the current names with the defaults filled in."""
    import dataclasses

    import h5py

    from terrasph.scenes import SCENES

    with h5py.File(path, "r") as f:
        saved = json.loads(f.attrs["config_json"])
    if "scene" in saved:
        if saved["scene"] != "leg-wheel":
            raise ValueError(f"{path} is not a leg-wheel run (its scene is {saved['scene']!r})")
        saved = saved["leg_wheel"]
    return dataclasses.asdict(SCENES["leg-wheel"].config_from(saved))


def is_leg_wheel_run(path: str | Path) -> bool:
    """Whether `path` is an HDF5 run file written by the leg-wheel scene (not a dataset file)."""
    import h5py

    try:
        with h5py.File(path, "r") as f:
            return "series/robot/wheel" in f and json.loads(f.attrs.get("config_json", "{}")).get("scene") == "leg-wheel"
    except (OSError, ValueError):
        return False


def _check_dt(dt: float, driven: float, where: str | Path) -> None:
    if not (isinstance(dt, (int, float)) and 0 < dt <= driven / 2):
        raise ValueError(f"parameter 'dt' = {dt!r} is invalid: allowed in (0, {driven / 2:g}] s "
                         f"(at least 3 samples of the {driven:g} s driven phase of {where})")


def robot_run(path: str | Path, dt: float, wheels: Sequence[str], bed: Sequence[str] = ()) -> Run:
    """The driven phase of the leg-wheel run file `path` resampled to `dt` (module docstring); the
    bed parameters `bed` are inputs beside the load."""
    import h5py

    with h5py.File(path, "r") as f:
        saved = json.loads(f.attrs["config_json"])
        if saved.get("scene") != "leg-wheel":
            raise ValueError(f"{path} is not a leg-wheel run (its scene is {saved.get('scene')!r})")
        config = _leg_wheel_config(saved["leg_wheel"])  # the scene's own (terrasph.scenes.SCENES' config_key)
        group = f["series/robot/wheel"]
        wheel = {name: group[name][()] for name in ("time", "slip", "sinkage", "velocity")}
    return driven_phase_run(Path(path).stem, config, wheel, dt, wheels, bed, where=path)


def driven_phase_run(name: str, config: dict[str, Any], wheel: dict[str, np.ndarray], dt: float,
                     wheels: Sequence[str], bed: Sequence[str] = (), where: str | Path = "the run") -> Run:
    """The driven phase of a leg-wheel run resampled to `dt` (module docstring): `config` its
    configuration (a saved one or ``dataclasses.asdict`` of a :class:`terrasph.scenes.leg_wheel.LegWheel`),
    `wheel` its ``robot/wheel`` series (at least time, slip, sinkage, velocity; a run file's or
    :func:`terrasph.scenes.leg_wheel.run_leg_wheel`'s), `where` named in the message of a bad `dt`."""
    settle, duration = float(config["settle_time"]), float(config["t_end"])
    _check_dt(dt, duration - settle, where)
    grid = np.arange(0.0, duration - settle + 1e-9 * dt, dt)
    schedule = tuple(tuple(k) for k in config.get("omega_schedule") or ()) or ((0.0, float(config["omega"])),)
    series = {"omega_cmd": evaluate(schedule, grid)}
    series.update(commanded_phase(series["omega_cmd"], dt, int(config["legs"])))
    time = np.asarray(wheel["time"])
    sampled = {"slip": wheel["slip"], "sinkage": wheel["sinkage"], "forward_speed": np.asarray(wheel["velocity"])[:, 0]}
    for target, values in sampled.items():
        values = np.asarray(values)
        finite = np.isfinite(values)
        series[target] = np.interp(grid + settle, time[finite], values[finite])
    series["slip"] = np.clip(series["slip"], -1.0, 1.0)
    params = {"load": float(config["load"]), **{b: _bed_value(config, b) for b in bed},
              **{f"wheel:{w}": float(config["wheel"] == w) for w in wheels}}
    return Run(name=name, time=grid, series=series, params=params, units=dict(_UNITS))


def build_robot_dataset(sweep_dir: str | Path, out_dir: str | Path, dt: float = 0.02,
                        replace: bool = False) -> dict[str, Any]:
    """Writes one dataset file per finished run of the sweep in `sweep_dir` (its manifest names them)
    into `out_dir` (terrasph.surrogate.dataset layout, body "wheel") and ``dataset.json`` (Δt,
    features, targets, and each run's parameters and drawn input kind); returns that description.
    The manifest, its scene and `dt` (at most half of every run's driven phase) are checked before
    anything is written; ``replace=True`` then removes the run files and description of an earlier
    dataset in `out_dir`, so that it holds exactly this one."""
    sweep_dir, out_dir = Path(sweep_dir), Path(out_dir)
    if not (sweep_dir / "manifest.json").is_file():
        raise FileNotFoundError(f"{sweep_dir}: no manifest.json (not a `terrasph sweep` directory)")
    manifest = json.loads((sweep_dir / "manifest.json").read_text())
    if manifest["spec"]["scene"] != "leg-wheel":
        raise ValueError(f"{sweep_dir}: a sweep of {manifest['spec']['scene']!r}; the robot dataset needs leg-wheel runs")
    finished = [c for c in manifest["cases"] if c["status"] == "completed"]
    if not finished:
        raise ValueError(f"{sweep_dir}: no finished runs in the manifest")
    shortest = min(finished, key=lambda c: _driven_phase(c["config"]))
    _check_dt(dt, _driven_phase(shortest["config"]), f"run {shortest['case_id']}")
    wheels = sorted({c["config"]["wheel"] for c in finished})
    bed = [name for name in BED_PARAMETERS if len({_bed_value(c["config"], name) for c in finished}) > 1]
    out_dir.mkdir(parents=True, exist_ok=True)
    for stale in [*out_dir.glob("*.h5"), out_dir / "dataset.json"] if replace else ():
        stale.unlink(missing_ok=True)
    runs = {}
    for case in finished:
        run = robot_run(sweep_dir / "runs" / f"{case['case_id']}.h5", dt, wheels, bed)
        write_run(out_dir / f"{run.name}.h5", run, body="wheel", config=case["config"])
        runs[run.name] = {"load": case["config"]["load"], "wheel": case["config"]["wheel"],
                          **{name: run.params[name] for name in bed},
                          "input_kind": case["varied"].get("input_kind", "constant")}
    description = {"dt": dt, "features": list(features_of(wheels, bed)), "targets": list(TARGETS), "wheels": wheels,
                   "skipped_failed": [c["case_id"] for c in manifest["cases"] if c["status"] == "failed"],
                   "runs": runs}
    (out_dir / "dataset.json").write_text(json.dumps(description, indent=1, sort_keys=True))
    return description


def split_held_out(runs: Sequence[Run], train_ranges: dict[str, tuple[float, float]], seed: int = 0,
                   fractions: tuple[float, float, float] = (0.7, 0.15, 0.15)) -> dict[str, list[int]]:
    """Run indices by split. For each column (a run parameter or an input series) of `train_ranges`,
    ``extrapolation: <column>`` holds the runs whose values leave its [low, high] (a series at any
    step; a run outside two ranges is in both); the runs inside every range are split by run into
    ``train``, ``val`` and ``interpolation`` (seeded `fractions`)."""
    def outside(run: Run, column: str) -> bool:
        values = run.column(column)
        low, high = train_ranges[column]
        return bool(values.min() < low or values.max() > high)

    held = {column: [k for k, run in enumerate(runs) if outside(run, column)] for column in train_ranges}
    out_any = {k for members in held.values() for k in members}
    inside = [k for k in range(len(runs)) if k not in out_any]
    train, val, test = split_runs(len(inside), fractions, seed)
    return {"train": [inside[k] for k in train], "val": [inside[k] for k in val],
            "interpolation": [inside[k] for k in test],
            **{f"extrapolation: {column}": members for column, members in held.items()}}


def split_by_range(runs: Sequence[Run], parameter: str, low: float, high: float, seed: int = 0,
                   fractions: tuple[float, float, float] = (0.7, 0.15, 0.15)) -> dict[str, list[int]]:
    """Run indices by split: ``extrapolation`` the runs whose `parameter` lies outside [`low`, `high`];
    the others split by run into ``train``, ``val`` and ``interpolation`` (seeded `fractions`)."""
    splits = split_held_out(runs, {parameter: (low, high)}, seed, fractions)
    splits["extrapolation"] = splits.pop(f"extrapolation: {parameter}")
    return splits


def dataset_validity(dataset_dir: str | Path, runs: Sequence[Run], features: Sequence[str]) -> Validity:
    """:func:`terrasph.surrogate.validity.training_validity` of `runs` of the robot dataset in
    `dataset_dir` (written by ``terrasph dataset``), their configurations read from its files."""
    return training_validity(runs, features, [leg_wheel_fields(Path(dataset_dir) / f"{run.name}.h5") for run in runs])
