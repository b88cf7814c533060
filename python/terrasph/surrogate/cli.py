"""Sub-commands ``terrasph train``, ``terrasph predict``, ``terrasph make-synthetic-dataset`` and
``terrasph dataset``."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from terrasph.cli_common import (
    add_force_option,
    check_output_dir,
    check_output_file,
    positive_float,
    positive_int,
)


def register(subparsers: Any) -> None:
    """Add the surrogate sub-commands to the ``terrasph`` parser."""
    p = subparsers.add_parser(
        "train", help="train an LSTM surrogate on a directory of HDF5 runs and export it",
        description="Train a stacked LSTM (standard or peephole cell) on the runs in "
                    "DATASET_DIR (split by run), then write the model file (docs/lstm_format.md) "
                    "and a JSON report next to it.")
    p.add_argument("dataset_dir", metavar="DATASET_DIR", type=Path)
    p.add_argument("--out", required=True, type=Path,
                   help="model file to write (.tslstm), with a JSON report beside it")
    p.add_argument("--features", nargs="+", default=None,
                   help="input series or run parameters (default: those of DATASET_DIR/dataset.json, written by "
                        "`terrasph dataset`; else the synthetic wheel's omega_cmd load soil_k mu)")
    p.add_argument("--targets", nargs="+", default=None,
                   help="target series (default: those of DATASET_DIR/dataset.json; else slip sinkage)")
    p.add_argument("--body", default=None,
                   help="body group in /series/bodies (default: the only one)")
    p.add_argument("--cell", choices=("standard", "peephole"), default="standard",
                   help="LSTM cell, Eq. 4.9-4.13 for peephole (default: %(default)s)")
    p.add_argument("--hidden", type=positive_int, default=32,
                   help="hidden units per layer, 1-1024 (default: %(default)s)")
    p.add_argument("--layers", type=positive_int, default=1,
                   help="stacked LSTM layers, 1-8 (default: %(default)s)")
    p.add_argument("--epochs", type=positive_int, default=300, help="maximum epochs (default: %(default)s)")
    p.add_argument("--patience", type=positive_int, default=30,
                   help="early-stopping patience in epochs (default: %(default)s)")
    p.add_argument("--lr", type=positive_float, default=5e-3, help="Adam learning rate (default: %(default)s)")
    p.add_argument("--batch-size", type=positive_int, default=16,
                   help="runs per optimisation step (default: %(default)s)")
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the split, initial weights and batches (default: %(default)s)")
    p.add_argument("--torch-threads", type=positive_int, default=1, metavar="N",
                   help="PyTorch CPU threads, >= 1 (default: %(default)s; results are reproducible "
                        "per thread count)")
    add_force_option(p)
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    p.set_defaults(handler=_cmd_train)

    p = subparsers.add_parser(
        "predict", help="predict targets for input sequences with the C++ engine",
        description="Run a model (C++ engine, no PyTorch) on INPUT: a leg-wheel run file (its driven "
                    "phase at the model's time step, with the RMSE against its SPH series), an HDF5 "
                    "dataset run file or directory of runs, a .npy array (T, I) or (B, T, I), or a .csv "
                    "file with one time step per row (e.g. a new omega_cmd schedule). A run outside the "
                    "model's validity range (docs/lstm_format.md) is refused unless --extrapolate.")
    p.add_argument("model", metavar="MODEL",
                   help="a model file (.tslstm) or the name of a model shipped with terrasph")
    p.add_argument("input", metavar="INPUT", type=Path)
    p.add_argument("--out", type=Path, default=None,
                   help="write predictions to .npy (B, T, O) or .csv (default: CSV on stdout)")
    p.add_argument("--dtype", choices=("float32", "float64"), default="float64",
                   help="precision of the C++ engine (default: %(default)s)")
    p.add_argument("--body", default=None,
                   help="body group in /series/bodies for HDF5 input (default: the only one)")
    p.add_argument("--extrapolate", action="store_true",
                   help="predict runs outside the model's validity range too (refused by default)")
    add_force_option(p)
    p.set_defaults(handler=_cmd_predict)

    p = subparsers.add_parser(
        "make-synthetic-dataset", help="write driven-wheel runs with a known slip-sinkage law",
        description="Simulate the synthetic driven wheel (terrasph.surrogate.synthetic) and "
                    "write one HDF5 run file per run into the directory --out.")
    p.add_argument("--out", required=True, type=Path, metavar="DIR", help="dataset directory to write")
    p.add_argument("--runs", type=positive_int, default=120,
                   help="number of runs (files wheel_0000.h5, …) (default: %(default)s)")
    p.add_argument("--duration", type=positive_float, default=3.0,
                   help="simulated seconds per run (default: %(default)s)")
    p.add_argument("--dt", type=positive_float, default=0.02,
                   help="sampling interval in s, at most duration/2 (default: %(default)s)")
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the random drive, load and soil of each run (default: %(default)s)")
    add_force_option(p)
    p.set_defaults(handler=_cmd_synthetic)

    p = subparsers.add_parser(
        "dataset", help="build the surrogate dataset of a leg-wheel sweep's finished runs",
        description="Take the finished runs of the leg-wheel sweep in SWEEP_DIR (a `terrasph sweep` "
                    "directory with its manifest.json), resample their driven phase to --dt and write "
                    "one dataset file per run and dataset.json into --out (docs/surrogate.md §2), ready "
                    "for `terrasph train`. Failed cases are listed as skipped.")
    p.add_argument("sweep_dir", metavar="SWEEP_DIR", type=Path)
    p.add_argument("--out", required=True, type=Path, help="dataset directory to write")
    p.add_argument("--dt", type=positive_float, default=0.02,
                   help="sampling interval in s, at most half of every run's driven phase "
                        "(default: %(default)s)")
    add_force_option(p)
    p.set_defaults(handler=_cmd_dataset)


def _cmd_train(args: argparse.Namespace) -> int:
    import torch

    from terrasph.surrogate.train import TrainConfig, format_report, train_directory

    check_output_file(args.out, args.force)
    check_output_file(str(args.out) + ".json", args.force)
    torch.set_num_threads(args.torch_threads)
    features, targets = dataset_columns(args.dataset_dir)
    config = TrainConfig(
        features=tuple(args.features or features), targets=tuple(args.targets or targets), cell=args.cell,
        hidden_size=args.hidden, num_layers=args.layers, epochs=args.epochs,
        patience=args.patience, lr=args.lr, batch_size=args.batch_size, seed=args.seed)
    result = train_directory(args.dataset_dir, args.out, config, body=args.body,
                             progress=not args.no_progress)
    print(format_report(result.report))
    print(f"best epoch {result.best_epoch} of {len(result.history)}; wrote {args.out} "
          f"and {args.out}.json")
    return 0


def dataset_columns(dataset_dir: Path) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The features and targets a dataset directory was written with: its dataset.json's (``terrasph
    dataset``), else the synthetic wheel's (``terrasph make-synthetic-dataset``)."""
    import json

    from terrasph.surrogate.synthetic import DEFAULT_FEATURES, DEFAULT_TARGETS

    description = dataset_dir / "dataset.json"
    if not description.is_file():
        return DEFAULT_FEATURES, DEFAULT_TARGETS
    try:
        saved = json.loads(description.read_text())
        return tuple(saved["features"]), tuple(saved["targets"])
    except (ValueError, KeyError, TypeError) as error:
        raise ValueError(f"{description}: not a dataset description with features and targets ({error})") from None


def _cmd_predict(args: argparse.Namespace) -> int:
    from terrasph.surrogate.inference import predict_sequences, read_inputs
    from terrasph.surrogate.registry import open_model, resolve_model
    from terrasph.surrogate.validity import run_conditions

    if args.out is not None:
        if args.out.suffix not in (".npy", ".csv"):
            raise ValueError(f"--out {args.out}: use a .npy or .csv file")
        check_output_file(args.out, args.force)
    model = open_model(resolve_model(args.model), args.dtype)
    validity = model.validity
    inputs = read_inputs(args.input, model.feature_names, validity.dt if validity else model.metadata.get("dt", np.nan),
                         body=args.body, legs=validity.fixed.get("legs") if validity else None)
    if validity is not None and not args.extrapolate:
        for run, config in inputs:
            validity.check(run_conditions(run, model.feature_names, config), run.name)
    results = predict_sequences(model.engine, [(run.name, run.matrix(model.feature_names)) for run, _ in inputs])
    targets = model.target_names
    summary = [_error_line(run, y, targets) for (run, _), (_, y) in zip(inputs, results)
               if all(t in run.series for t in targets)]
    if args.out is not None and args.out.suffix == ".npy":
        lengths = {y.shape[0] for _, y in results}
        if len(lengths) != 1:
            raise ValueError("--out: the sequences differ in length; use a .csv output")
        np.save(args.out, np.stack([y for _, y in results]))
    else:
        lines = [",".join(["sequence", "step"] + targets)]
        for name, y in results:
            for t, row in enumerate(y):
                lines.append(",".join([name, str(t)] + [repr(float(v)) for v in row]))
        text = "\n".join(lines) + "\n"
        if args.out is None:
            sys.stdout.write(text)
        else:
            args.out.write_text(text)
    # the CSV on stdout stays machine-readable: the errors then go to stderr
    for line in summary:
        print(line, file=sys.stdout if args.out is not None else sys.stderr)
    return 0


def _error_line(run: Any, predicted: np.ndarray, targets: Sequence[str]) -> str:
    """RMSE and RMSE/std of the prediction of `run` against its own (SPH) series, one line."""
    from terrasph.surrogate.evaluation import error_table

    errors = error_table({"model": lambda _: predicted}, [run], targets)["model"]
    parts = [f"{t} {errors[t]['rmse']:.4g} ({errors[t]['nrmse']:.3f} of its std)" for t in targets]
    return f"{run.name}: RMSE against its series over {run.length} steps: " + ", ".join(parts)


def _cmd_synthetic(args: argparse.Namespace) -> int:
    from terrasph.surrogate.synthetic import make_dataset

    if args.dt > args.duration / 2:
        raise ValueError(f"--dt {args.dt:g} is invalid: allowed at most --duration/2 = "
                         f"{args.duration / 2:g} s (a run needs at least 3 samples)")
    check_output_dir(args.out, args.force, "--out")
    for stale in sorted(args.out.glob("wheel_*.h5")) if args.force else ():
        stale.unlink()  # --force: the directory then holds exactly this dataset, no runs of an earlier one
    paths = make_dataset(args.out, n_runs=args.runs, seed=args.seed,
                         duration=args.duration, dt=args.dt)
    print(f"wrote {len(paths)} runs to {args.out}")
    return 0


def _cmd_dataset(args: argparse.Namespace) -> int:
    from terrasph.surrogate.robot_dataset import build_robot_dataset

    if not args.sweep_dir.is_dir():
        raise FileNotFoundError(f"SWEEP_DIR {args.sweep_dir}: no such directory")
    if args.out.resolve() == args.sweep_dir.resolve():
        raise ValueError(f"--out {args.out}: is SWEEP_DIR; write the dataset to a directory of its own")
    check_output_dir(args.out, args.force, "--out")
    description = build_robot_dataset(args.sweep_dir, args.out, dt=args.dt, replace=args.force)
    print(f"wrote {len(description['runs'])} runs to {args.out} (dt {args.dt:g} s; skipped "
          f"{len(description['skipped_failed'])} failed); features {' '.join(description['features'])}; "
          f"targets {' '.join(description['targets'])}")
    return 0
