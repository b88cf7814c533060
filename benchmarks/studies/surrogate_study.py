"""The documented surrogate study of docs/surrogate.md: a leg-wheel sweep → dataset → both LSTM
cells → held-out error per target against the baselines (interpolation, and extrapolation in the
load and in the commanded ω kept apart) → learning curve (10, 20, 40, all training runs) →
predicted-vs-SPH figure → C++ prediction time of a 6 s trajectory against an SPH run's → optionally
the best cell shipped into the package with its validity range and measured error.

    terrasph sweep SPEC --out study --workers 2
    python benchmarks/studies/surrogate_study.py study [--dt 0.02] [--train-loads 2 5.2] [--train-omega-max W]
        [--sizes 10 20 40] [--jobs 2] [--figure F.png] [--curve-figure C.png] [--sph-wall-time S] [--report R.md]
        [--ship NAME]

Prints Markdown tables (and writes them to --report); the runs used are the sweep's finished ones
(its manifest). --ship NAME writes python/terrasph/surrogate/models/NAME.tslstm of this repository
(or --models-dir), found afterwards by ``terrasph.surrogate.pretrained(NAME)`` and
``terrasph predict NAME RUN.h5``.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import torch
from terrasph.surrogate.dataset import Run, load_runs
from terrasph.surrogate.evaluation import (
    INPUT_ONLY_BASELINES,
    baseline_predictors,
    error_table,
    format_table,
    learning_curve_splits,
    plot_learning_curve,
    plot_predictions,
)
from terrasph.surrogate.export import FILE_SUFFIX, export_model
from terrasph.surrogate.inference import load_model
from terrasph.surrogate.robot_dataset import TARGETS, build_robot_dataset, dataset_validity, split_held_out
from terrasph.surrogate.train import TrainConfig, TrainResult, train

CELLS = ("standard", "peephole")
REPOSITORY_MODELS = Path(__file__).resolve().parents[2] / "python" / "terrasph" / "surrogate" / "models"


def lstm_predictor(net, features):
    def predict(run):
        with torch.no_grad():
            return net(torch.from_numpy(run.matrix(features).astype(np.float32))[None])[0].double().numpy()
    return predict


def cpp_time_per_trajectory(path: Path, x: np.ndarray, repeats: int = 200) -> float:
    """Best time (s) of predicting the one trajectory x (T, I) with the C++ engine in float32."""
    model = load_model(path, "float32")
    batch = x.astype(np.float32)[None]
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        model.predict(batch)
        best = min(best, time.perf_counter() - start)
    return best


def trajectory_inputs(run: Run, features: tuple[str, ...], seconds: float, dt: float) -> np.ndarray:
    """The inputs of `run` over `seconds` (its last step held beyond its end): (T, I)."""
    x = run.matrix(features)
    steps = int(round(seconds / dt)) + 1
    return np.concatenate([x, np.repeat(x[-1:], max(steps - len(x), 0), axis=0)])[:steps]


def summary_table(tables: dict[str, dict], predictors: list[str]) -> str:
    """RMSE/std (RMSE) per predictor (rows) and held-out split × target (columns), as in the docs."""
    columns = [(split, target) for split in tables for target in TARGETS]
    lines = ["| predictor | " + " | ".join(f"{t} {s}" for s, t in columns) + " |",
             "|---|" + "---|" * len(columns)]
    for name in predictors:
        cells = [f"{tables[s][name][t]['nrmse']:.2f} ({tables[s][name][t]['rmse']:.2g})" for s, t in columns]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def curve_table(curves: dict[str, dict[int, TrainResult]]) -> str:
    """Held-out interpolation RMSE/std per training-set size (rows), cell × target (columns)."""
    counts = sorted({n for curve in curves.values() for n in curve})
    header = [f"{cell} {target}" for cell in curves for target in TARGETS]
    lines = ["| training runs | " + " | ".join(header) + " |", "|---|" + "---|" * len(header)]
    for n in counts:
        cells = [f"{curves[c][n].report['test'][t]['nrmse']:.3f}" if n in curves[c] else "" for c in curves
                 for t in TARGETS]
        lines.append(f"| {n} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def held_out_record(tables: dict[str, dict], predictor: str, splits: dict[str, list[int]]) -> dict:
    """The measured held-out error of `predictor` for the model's metadata (Validity.held_out_error)."""
    record = {split: {t: {"rmse": m["rmse"], "nrmse": m["nrmse"]} for t, m in table[predictor].items()}
              for split, table in tables.items()}
    record["runs"] = {split: len(members) for split, members in splits.items()}
    return record


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("sweep_dir", type=Path)
    parser.add_argument("--dt", type=float, default=0.02)
    parser.add_argument("--train-loads", type=float, nargs=2, default=(2.0, 5.2),
                        help="load range (N) of train/validation/interpolation runs; the rest: extrapolation in load")
    parser.add_argument("--train-omega-max", type=float, default=None,
                        help="runs whose commanded ω exceeds this (rad/s) at any step: extrapolation in ω")
    parser.add_argument("--sizes", type=int, nargs="+", default=(10, 20, 40),
                        help="training-set sizes of the learning curve (all the training runs are added)")
    parser.add_argument("--cells", nargs="+", choices=CELLS, default=CELLS)
    parser.add_argument("--jobs", type=int, default=1, help="trainings run at once, each in a process of its own")
    parser.add_argument("--hidden", type=int, default=32)
    parser.add_argument("--epochs", type=int, default=400)
    parser.add_argument("--patience", type=int, default=60)
    parser.add_argument("--lr", type=float, default=5e-3)
    parser.add_argument("--batch-size", type=int, default=8, help="runs per optimisation step")
    parser.add_argument("--figure", type=Path, default=None, help="predicted vs SPH on held-out runs (PNG)")
    parser.add_argument("--curve-figure", type=Path, default=None, help="the learning curve (PNG)")
    parser.add_argument("--trajectory", type=float, default=6.0, help="seconds of the timed C++ trajectory")
    parser.add_argument("--sph-wall-time", type=float, default=None,
                        help="wall time (s) of an SPH run of --trajectory seconds on this machine, for the ratio")
    parser.add_argument("--report", type=Path, default=None, help="also write the Markdown tables here")
    parser.add_argument("--ship", metavar="NAME", default=None,
                        help="write the best cell with its validity and held-out error as NAME.tslstm")
    parser.add_argument("--models-dir", type=Path, default=REPOSITORY_MODELS,
                        help="where --ship writes (default: the package's models directory of this repository)")
    args = parser.parse_args()
    torch.set_num_threads(1)
    out: list[str] = []

    def emit(text: str = "") -> None:
        print(text)
        out.append(text)

    data_dir = Path(tempfile.mkdtemp(prefix="surrogate_study_"))
    description = build_robot_dataset(args.sweep_dir, data_dir, dt=args.dt)
    features = tuple(description["features"])
    runs = load_runs(data_dir)
    train_ranges = {"load": tuple(args.train_loads)}
    if args.train_omega_max is not None:
        train_ranges["omega_cmd"] = (0.0, args.train_omega_max)
    splits = split_held_out(runs, train_ranges, seed=0)
    emit(f"{len(runs)} runs (failed and skipped: {len(description['skipped_failed'])}), dt = {args.dt} s, "
         f"{runs[0].length} steps each; features {', '.join(features)}")
    emit("runs per split: " + ", ".join(f"{k} {len(v)}" for k, v in splits.items()))

    subsets = learning_curve_splits(splits, [*args.sizes, len(splits["train"])])
    configs = {cell: TrainConfig(features=features, targets=TARGETS, cell=cell, hidden_size=args.hidden,
                                 epochs=args.epochs, patience=args.patience, lr=args.lr, batch_size=args.batch_size)
               for cell in args.cells}
    start = time.perf_counter()
    # each training (cell × size) in a process of its own, one torch thread each; the largest first
    with ProcessPoolExecutor(args.jobs, mp_context=multiprocessing.get_context("spawn"),
                             initializer=torch.set_num_threads, initargs=(1,)) as pool:
        futures = {(cell, n): pool.submit(train, runs, configs[cell], False, subset)
                   for n, subset in sorted(subsets.items(), reverse=True) for cell in args.cells}
        curves = {cell: {n: futures[cell, n].result() for n in subsets} for cell in args.cells}
    emit(f"{len(futures)} trainings ({args.jobs} at a time) in {time.perf_counter() - start:.0f} s")
    predictors = {}
    for cell in args.cells:
        final = curves[cell][max(subsets)]
        emit(f"{cell}: on all {len(splits['train'])} training runs best epoch {final.best_epoch} of "
             f"{len(final.history)}")
        predictors[f"LSTM {cell}"] = lstm_predictor(final.net, features)
    train_runs = [runs[k] for k in splits["train"]]
    predictors.update(baseline_predictors(train_runs, features, TARGETS))

    tables = {split: error_table(predictors, [runs[k] for k in members], TARGETS)
              for split, members in splits.items() if split not in ("train", "val") and members}
    emit("\n**RMSE/std (RMSE in target units) on the held-out runs**\n")
    emit(summary_table(tables, list(predictors)))
    for split, table in tables.items():
        emit()
        emit(format_table(table, f"{split}: {len(splits[split])} held-out runs"))
    emit("\n**Best input-only baseline / best LSTM, RMSE/std (≥ 2 is the target)**\n")
    lstm_names = [f"LSTM {cell}" for cell in args.cells]
    emit("| split | " + " | ".join(TARGETS) + " |\n|---|" + "---|" * len(TARGETS))
    for split, table in tables.items():
        ratios = [min(table[b][t]["nrmse"] for b in INPUT_ONLY_BASELINES)
                  / min(table[c][t]["nrmse"] for c in lstm_names) for t in TARGETS]
        emit(f"| {split} | " + " | ".join(f"{r:.2f}" for r in ratios) + " |")
    emit("\n**Learning curve: held-out interpolation RMSE/std against the number of training runs**\n")
    emit(curve_table(curves))
    if args.curve_figure is not None:
        plot_learning_curve({cell: {n: r.report["test"] for n, r in curve.items()} for cell, curve in curves.items()},
                            TARGETS, args.curve_figure)
        emit(f"\nlearning-curve figure: {args.curve_figure}")
    if args.figure is not None:
        shown = [runs[k] for k in splits["interpolation"][:2]]
        shown += [runs[members[0]] for split, members in splits.items() if split.startswith("extrapolation") and members]
        plot_predictions(shown, {k: predictors[k] for k in (*lstm_names, "memoryless")}, TARGETS[:2], args.figure)
        emit(f"\npredicted-vs-SPH figure: {args.figure}")

    interpolation = tables["interpolation"]
    best = min(args.cells, key=lambda c: np.mean([interpolation[f"LSTM {c}"][t]["nrmse"] for t in TARGETS]))
    result = curves[best][max(curves[best])]
    metadata = result.metadata()
    validity = dataset_validity(data_dir, train_runs, features)
    metadata["validity"] = {**validity.to_json(), "held_out_error": held_out_record(tables, f"LSTM {best}", splits)}
    metadata["sweep_spec"] = json.loads((args.sweep_dir / "manifest.json").read_text())["spec"]
    model_path = export_model(result.net, data_dir / f"{best}{FILE_SUFFIX}", features, TARGETS, metadata)

    x = trajectory_inputs(runs[0], features, args.trajectory, args.dt)
    cpp = cpp_time_per_trajectory(model_path, x)
    emit(f"\nC++ LSTM ({best}, H = {args.hidden}, float32, best of 200): one {len(x)}-step "
         f"({args.trajectory:g} s) trajectory in {cpp * 1e6:.1f} µs")
    if args.sph_wall_time is not None:
        emit(f"SPH run of {args.trajectory:g} s: {args.sph_wall_time:.4g} s of wall time: ratio "
             f"{args.sph_wall_time / cpp:.3g}")
    manifest = json.loads((args.sweep_dir / "manifest.json").read_text())
    wall = np.array([c["wall_time"] for c in manifest["cases"] if c["status"] == "completed"])
    emit(f"the sweep's SPH runs ({runs[0].length - 1} steps of {args.dt} s driven each): median wall "
         f"time {np.median(wall):.4g} s over {len(wall)} runs")
    if args.ship is not None:
        args.models_dir.mkdir(parents=True, exist_ok=True)
        shipped = args.models_dir / f"{args.ship}{FILE_SUFFIX}"
        shipped.write_bytes(model_path.read_bytes())
        emit(f"\nshipped: {shipped} ({best} cell, {shipped.stat().st_size / 1024:.0f} KiB)")
    if args.report is not None:
        args.report.write_text("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
