"""The documented surrogate study of docs/surrogate.md: a leg-wheel sweep → dataset → both LSTM
cells → held-out error per target against the baselines (interpolation and extrapolation in the
load kept apart) → predicted-vs-SPH figure → C++ trajectory prediction time vs the SPH's.

    terrasph sweep benchmarks/studies/sweep_leg_wheel_study.yaml --out study --workers 2
    python benchmarks/studies/surrogate_study.py study [--dt 0.02] [--train-loads 2 5.2] [--figure F.png]

Prints Markdown tables; the runs used are the sweep's finished ones (its manifest).
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np
import torch
from terrasph.surrogate.dataset import load_runs
from terrasph.surrogate.evaluation import (
    baseline_predictors,
    error_table,
    format_table,
    plot_predictions,
)
from terrasph.surrogate.export import export_model
from terrasph.surrogate.inference import load_model
from terrasph.surrogate.robot_dataset import build_robot_dataset, split_by_range
from terrasph.surrogate.train import TrainConfig, train

TARGETS = ("slip", "sinkage", "forward_speed")


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


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("sweep_dir", type=Path)
    parser.add_argument("--dt", type=float, default=0.02)
    parser.add_argument("--train-loads", type=float, nargs=2, default=(2.0, 5.2),
                        help="load range (N) of train/validation/interpolation runs; the rest: extrapolation")
    parser.add_argument("--hidden", type=int, default=32)
    parser.add_argument("--epochs", type=int, default=400)
    parser.add_argument("--figure", type=Path, default=None)
    args = parser.parse_args()
    torch.set_num_threads(1)
    data_dir = Path(tempfile.mkdtemp(prefix="surrogate_study_"))
    description = build_robot_dataset(args.sweep_dir, data_dir, dt=args.dt)
    FEATURES = tuple(description["features"])
    runs = load_runs(data_dir)
    splits = split_by_range(runs, "load", *args.train_loads, seed=0)
    print(f"{len(runs)} runs (failed and skipped: {len(description['skipped_failed'])}), dt = {args.dt} s, "
          f"{runs[0].length} steps each; features {FEATURES}")
    print({k: len(v) for k, v in splits.items()})
    train_runs = [runs[k] for k in splits["train"]]
    predictors = {}
    for cell in ("standard", "peephole"):
        start = time.perf_counter()
        result = train(runs, TrainConfig(features=FEATURES, targets=TARGETS, cell=cell, hidden_size=args.hidden,
                                         epochs=args.epochs, patience=60, lr=5e-3, batch_size=8),
                       progress=False, splits=(splits["train"], splits["val"], splits["interpolation"]))
        print(f"{cell}: best epoch {result.best_epoch} of {len(result.history)}, "
              f"{time.perf_counter() - start:.0f} s training")
        predictors[f"LSTM {cell}"] = lstm_predictor(result.net, FEATURES)
        model_path = export_model(result.net, data_dir / f"{cell}.tslstm", FEATURES, TARGETS, result.metadata())
    predictors.update(baseline_predictors(train_runs, FEATURES, TARGETS))
    for split in ("interpolation", "extrapolation"):
        held_out = [runs[k] for k in splits[split]]
        if held_out:
            print()
            print(format_table(error_table(predictors, held_out, TARGETS),
                               f"{split}: {len(held_out)} held-out runs"))
    if args.figure is not None:
        shown = [runs[k] for k in (splits["interpolation"][:2] + splits["extrapolation"][:1])]
        plot_predictions(shown, {k: predictors[k] for k in ("LSTM peephole", "LSTM standard", "memoryless")},
                         TARGETS[:2], args.figure)
        print(f"\nfigure: {args.figure}")
    manifest = json.loads((args.sweep_dir / "manifest.json").read_text())
    sph = np.array([c["wall_time"] for c in manifest["cases"] if c["status"] == "completed"])
    cpp = cpp_time_per_trajectory(model_path, runs[0].matrix(FEATURES))
    print(f"\nSPH run (whole run incl. pause, wall): median {np.median(sph):.1f} s over {len(sph)} runs; "
          f"C++ LSTM (peephole, H={args.hidden}, float32) one {runs[0].length}-step trajectory: {cpp * 1e6:.1f} µs; "
          f"ratio {np.median(sph) / cpp:.3g}")
