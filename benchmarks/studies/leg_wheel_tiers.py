"""The three tiers of docs/rft.md at the surrogate's protocol: the six leg-wheels of chapter 4, each at
one shared condition inside the validity range of the shipped LSTM ``leg-wheel-ch4``, on the SPH, on
RFT with the generic map, on RFT with the SPH-calibrated map, and predicted by the LSTM.

    OMP_NUM_THREADS=1 python benchmarks/studies/leg_wheel_tiers.py RUNS_DIR [--load 4.9] [--omega 1.5]

The SPH runs take the fixed settings of benchmarks/studies/sweep_leg_wheel_ch4.yaml (fast tier,
Δx = 1.67 mm, a 0.3 s pause, 1.5 s driven, series every 10 ms) with the bed's defaults (μ1 = 23°,
dry) and a constant ω after the pause; each is written to ``RUNS_DIR/sph-<wheel>.h5`` and reused
when a completed run of the same configuration is there (~130 s each on one idle core; the script
runs the missing ones itself, on the threads OMP_NUM_THREADS allows).

What is compared is what the LSTM predicts: the dataset series of terrasph.surrogate.robot_dataset
(the driven phase resampled to the model's Δt = 0.02 s, 76 samples: per-sample slip clipped to
[−1, 1], sinkage, forward speed v_x), the same function of each tier's ``robot/wheel`` series. Per
wheel and tier: the series' mean over the driven phase, its difference from the SPH's mean, and the
RMSE of the series against the SPH's. Cost per simulated second: the SPH's wall time (the run
file's ``/run`` wall_time, 1.8 s simulated), the RFT run's CPU time (the whole ``run_leg_wheel``
without an output file: building the robot, stepping, recording; 1.8 s simulated), the LSTM's
wall time for the 1.5 s driven phase (the median of repeated predictions in the C++ engine in
float32, as docs/surrogate.md times it; the predictions shown are float64's, ``terrasph predict``'s
default, and the largest difference between the two is printed).

A second table gives the robot summary's means for SPH and RFT (``mean_slip`` is Eq. 4.8 of the
mean speed and spin over the samples after the pause where the spin has reached half the command;
the dataset's slip is the mean of the per-sample slip over the whole driven phase, spin-up included).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import statistics
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import yaml
from terrasph.scenes.leg_wheel import WHEELS, LegWheel, run_leg_wheel
from terrasph.surrogate.inference import read_inputs
from terrasph.surrogate.registry import Pretrained, pretrained
from terrasph.surrogate.robot_dataset import TARGETS, driven_phase_run
from terrasph.surrogate.validity import run_conditions

SPEC = Path(__file__).with_name("sweep_leg_wheel_ch4.yaml")
CALIBRATED = Path(__file__).resolve().parents[1] / "results" / "rft_glass_beads_sph.json"
MODEL = "leg-wheel-ch4"
#: how each target is shown: label, factor from SI, format
SHOWN = {"slip": ("slip", 1.0, "{:.3f}"), "sinkage": ("sinkage (mm)", 1e3, "{:.1f}"),
         "forward_speed": ("v_x (mm/s)", 1e3, "{:.1f}")}
LSTM_REPEATS = 2000


@dataclasses.dataclass(frozen=True)
class Tier:
    """One tier's prediction of one wheel: its dataset series (target → samples of the driven phase)
    and its cost in seconds of computing per simulated second."""

    series: Mapping[str, np.ndarray]
    cost: float


def comparison(truth: Mapping[str, np.ndarray], tier: Mapping[str, np.ndarray],
               targets: Sequence[str] = TARGETS) -> dict[str, dict[str, float]]:
    """Per target: the tier's mean over the samples, its difference from the mean of `truth` and the
    RMSE of its samples against those of `truth` (the same samples, same order)."""
    out = {}
    for target in targets:
        ours, theirs = np.asarray(tier[target], dtype=float), np.asarray(truth[target], dtype=float)
        if ours.shape != theirs.shape:
            raise ValueError(f"{target}: {ours.shape[0]} samples against the SPH's {theirs.shape[0]}")
        out[target] = {"mean": float(ours.mean()), "error": float(ours.mean() - theirs.mean()),
                       "rmse": float(np.sqrt(np.mean((ours - theirs) ** 2)))}
    return out


def tier_table(results: Mapping[str, Mapping[str, Tier]], reference: str = "SPH") -> str:
    """Markdown table, one row per wheel and tier: each target's mean (the `reference` tier) or mean,
    error of the mean and RMSE against the reference, then the cost per simulated second."""
    head = ["wheel", "tier"] + [SHOWN[t][0] + (": mean / error / RMSE") for t in TARGETS] + ["cost per simulated s"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for wheel, tiers in results.items():
        truth = tiers[reference].series
        for name, tier in tiers.items():
            compared = comparison(truth, tier.series)
            cells = []
            for target in TARGETS:
                _, factor, fmt = SHOWN[target]
                values = compared[target]
                if name == reference:
                    cells.append(fmt.format(factor * values["mean"]))
                else:
                    cells.append(" / ".join([fmt.format(factor * values["mean"]),
                                             ("+" + fmt if values["error"] >= 0 else fmt).format(factor * values["error"]),
                                             fmt.format(factor * values["rmse"])]))
            lines.append(f"| {wheel} | {name} | " + " | ".join(cells) + f" | {_duration(tier.cost)} |")
    return "\n".join(lines)


def _duration(seconds: float) -> str:
    """A cost in s, ms or µs."""
    if seconds >= 1:
        return f"{seconds:.0f} s"
    if seconds >= 1e-3:
        return f"{1e3 * seconds:.1f} ms"
    return f"{1e6 * seconds:.1f} µs"


def sph_config(wheel: str, load: float, omega: float) -> LegWheel:
    """The SPH run of `wheel`: the sweep SPEC's fixed settings, the load and a constant ω."""
    fixed = yaml.safe_load(SPEC.read_text())["fixed"]
    return LegWheel(wheel=wheel, load=load, omega=omega, **fixed)


def sph_run(config: LegWheel, runs_dir: Path) -> Path:
    """The completed SPH run of `config` in `runs_dir`, run (and written there) if it is not."""
    path = runs_dir / f"sph-{config.wheel}.h5"
    if path.is_file():
        with h5py.File(path, "r") as file:
            saved = json.loads(file.attrs["config_json"]).get("leg_wheel")
            status = file["run"].attrs.get("status") if "run" in file else None
        if status == "completed" and saved == json.loads(json.dumps(dataclasses.asdict(config))):
            return path
        raise SystemExit(f"{path}: not a completed run of this configuration; remove it to run it again")
    run_leg_wheel(config, path, plot=False)
    return path


def rft_tier(config: LegWheel, table: str, dt: float) -> tuple[Tier, dict[str, Any]]:
    """`config` on the RFT terrain with the coefficient map `table`: its dataset series, its cost and
    the robot summary. The SPH bed's own settings (the tier, LegWheel.SPH_ONLY_FIELDS) go back to their
    defaults, which the RFT terrain requires: they have no meaning there."""
    defaults = {f.name: f.default for f in dataclasses.fields(LegWheel) if f.name in LegWheel.SPH_ONLY_FIELDS
                and f.default is not dataclasses.MISSING}
    rft = dataclasses.replace(config, terrain="rft", rft_table=table, **defaults)
    cpu = time.process_time()
    result = run_leg_wheel(rft, plot=False)
    cpu = time.process_time() - cpu
    run = driven_phase_run(rft.wheel, dataclasses.asdict(rft), result.series["robot/wheel"], dt, [rft.wheel])
    return Tier({t: run.series[t] for t in TARGETS}, cpu / rft.t_end), result.summary()


def lstm_tier(model: Pretrained, fast: Pretrained, sph_path: Path) -> tuple[Tier, Tier, float]:
    """The LSTM's prediction (`model`, float64) of the SPH run in `sph_path` from its inputs (checked
    against the model's validity range, as ``terrasph predict`` does), timed with `fast` (the same
    model in float32); the SPH's own dataset series; the largest difference of the two predictions."""
    validity = model.validity
    (run, config), = read_inputs(sph_path, model.feature_names, validity.dt, legs=validity.fixed.get("legs"))
    validity.check(run_conditions(run, model.feature_names, config), run.name)
    x = run.matrix(model.feature_names)
    y = model.engine.predict(x)
    x32 = x.astype(np.float32)
    times = []
    for _ in range(LSTM_REPEATS):
        start = time.perf_counter()
        y32 = fast.engine.predict(x32)
        times.append(time.perf_counter() - start)
    driven = float(run.time[-1] - run.time[0])
    predicted = {t: y[:, j] for j, t in enumerate(model.target_names)}
    return (Tier(predicted, statistics.median(times) / driven), Tier({t: run.series[t] for t in TARGETS}, 0.0),
            float(np.abs(y32 - y).max()))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs_dir", type=Path, help="where the SPH runs are (and are written)")
    parser.add_argument("--load", type=float, default=4.9, help="N (default 4.9)")
    parser.add_argument("--omega", type=float, default=1.5, help="constant spin after the pause, rad/s (default 1.5)")
    parser.add_argument("--wheels", nargs="+", default=list(WHEELS), choices=WHEELS)
    args = parser.parse_args()
    args.runs_dir.mkdir(parents=True, exist_ok=True)
    model, fast = pretrained(MODEL), pretrained(MODEL, dtype="float32")
    dt = model.validity.dt
    results: dict[str, dict[str, Tier]] = {}
    summaries = []
    float32_difference = 0.0
    for wheel in args.wheels:
        config = sph_config(wheel, args.load, args.omega)
        path = sph_run(config, args.runs_dir)
        lstm, sph, difference = lstm_tier(model, fast, path)
        float32_difference = max(float32_difference, difference)
        with h5py.File(path, "r") as file:
            wall = float(file["run"].attrs["wall_time"])
            summaries.append((wheel, "SPH", {k: file["results"].attrs[k] for k in
                                             ("mean_slip", "mean_sinkage", "mean_forward_speed")}))
        tiers = {"SPH": dataclasses.replace(sph, cost=wall / config.t_end)}
        for name, table in (("RFT generic", "generic"), ("RFT SPH-calibrated", str(CALIBRATED))):
            tiers[name], summary = rft_tier(config, table, dt)
            summaries.append((wheel, name, summary))
        tiers["LSTM"] = lstm
        results[wheel] = tiers
        print(f"{wheel} done", flush=True)
    print(f"\nload {args.load} N, ω = {args.omega} rad/s after the pause; the dataset series ({MODEL}'s "
          f"targets, Δt = {dt:.3g} s) over the driven phase: mean, mean − SPH's, RMSE against the SPH's\n")
    print(tier_table(results))
    print(f"\nLSTM in float32 against float64: largest difference {float32_difference:.2g} (any target, SI units)")
    print("\nthe robot summary: mean slip (Eq. 4.8) / mean sinkage (mm) / mean v_x (mm/s)\n")
    print("| wheel | tier | summary |\n|---|---|---|")
    for wheel, name, summary in summaries:
        print(f"| {wheel} | {name} | {summary['mean_slip']:.3f} / {1e3 * summary['mean_sinkage']:.1f} / "
              f"{1e3 * summary['mean_forward_speed']:.1f} |")


if __name__ == "__main__":
    main()
