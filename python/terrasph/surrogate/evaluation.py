"""Held-out error of a surrogate against simple baselines, and predicted-vs-SPH plots (Fig. 4.4).

Predictors of a target series y(t) of a held-out run, given its inputs u(t):

* ``lstm``: the trained network, run over the whole input sequence (no target values seen);
* ``persistence``: the run's first sample y(0) held over the run (what is known before driving);
* ``persistence (one step)``: y(t − Δt) of the SPH itself, an oracle one step behind that a
  surrogate predicting a commanded trajectory does not have (the error floor of "no change");
* ``mean trajectory``: the mean over the training runs of the same morphology of y at each step;
* ``memoryless``: least squares y(t) ≈ β₀ + βᵀu(t) on the training runs' current inputs (no state).

Per target: RMSE over all held-out steps, RMSE/std (std of the target over those steps), and the
worst run (largest per-run RMSE). :func:`learning_curve` gives the held-out error of the LSTM against
the number of training runs.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from terrasph.surrogate.dataset import Run

if TYPE_CHECKING:
    from terrasph.surrogate.train import TrainConfig, TrainResult

__all__ = ["BASELINES", "INPUT_ONLY_BASELINES", "baseline_predictors", "error_table", "format_table",
           "learning_curve", "learning_curve_splits", "plot_learning_curve", "plot_predictions"]

BASELINES = ("persistence", "persistence (one step)", "mean trajectory", "memoryless")
#: the baselines that, like the surrogate, know only the commanded inputs and what is known before driving
INPUT_ONLY_BASELINES = ("persistence", "mean trajectory", "memoryless")

Predictor = Callable[[Run], np.ndarray]


def _morphology(run: Run) -> str:
    return next((name for name, value in run.params.items() if name.startswith("wheel:") and value == 1.0), "")


def baseline_predictors(train_runs: Sequence[Run], features: Sequence[str],
                        targets: Sequence[str]) -> dict[str, Predictor]:
    """The baselines (module docstring) fitted on `train_runs`; each maps a run to (T, O) predictions."""
    by_wheel: dict[str, list[np.ndarray]] = {}
    for run in train_runs:
        by_wheel.setdefault(_morphology(run), []).append(run.matrix(targets))
    length = min(min(len(y) for y in ys) for ys in by_wheel.values())
    mean_of = {wheel: np.mean([y[:length] for y in ys], axis=0) for wheel, ys in by_wheel.items()}
    overall = np.mean([y[:length] for ys in by_wheel.values() for y in ys], axis=0)

    def mean_trajectory(run: Run) -> np.ndarray:
        mean = np.asarray(mean_of.get(_morphology(run), overall))
        return np.concatenate([mean, np.repeat(mean[-1:], max(run.length - length, 0), axis=0)])[: run.length]

    design = np.concatenate([np.column_stack([np.ones(r.length), r.matrix(features)]) for r in train_runs])
    coefficients, *_ = np.linalg.lstsq(design, np.concatenate([r.matrix(targets) for r in train_runs]), rcond=None)

    def memoryless(run: Run) -> np.ndarray:
        return np.column_stack([np.ones(run.length), run.matrix(features)]) @ coefficients

    def persistence(run: Run) -> np.ndarray:
        return np.repeat(run.matrix(targets)[:1], run.length, axis=0)

    def one_step(run: Run) -> np.ndarray:
        y = run.matrix(targets)
        return np.concatenate([y[:1], y[:-1]])

    return {"persistence": persistence, "persistence (one step)": one_step, "mean trajectory": mean_trajectory,
            "memoryless": memoryless}


def error_table(predictors: dict[str, Predictor], runs: Sequence[Run],
                targets: Sequence[str]) -> dict[str, dict[str, dict[str, Any]]]:
    """predictor → target → {rmse, nrmse, worst_run, worst_rmse} over the held-out `runs`."""
    truth = [run.matrix(targets) for run in runs]
    std = np.concatenate(truth).std(axis=0)
    table: dict[str, dict[str, dict[str, Any]]] = {}
    for name, predict in predictors.items():
        errors = [predict(run) - y for run, y in zip(runs, truth)]
        per_run = np.array([np.sqrt(np.mean(e**2, axis=0)) for e in errors])
        rmse = np.sqrt(np.mean(np.concatenate(errors) ** 2, axis=0))
        table[name] = {target: {"rmse": float(rmse[j]), "nrmse": float(rmse[j] / std[j]) if std[j] > 0 else float("nan"),
                                "worst_run": runs[int(np.argmax(per_run[:, j]))].name,
                                "worst_rmse": float(per_run[:, j].max())}
                       for j, target in enumerate(targets)}
    return table


def format_table(table: dict[str, dict[str, dict[str, Any]]], title: str = "") -> str:
    """Markdown table: one row per predictor and target."""
    lines = [f"**{title}**", ""] if title else []
    lines += ["| predictor | target | RMSE | RMSE/std | worst run (RMSE) |", "|---|---|---|---|---|"]
    for name, per_target in table.items():
        for target, m in per_target.items():
            lines.append(f"| {name} | {target} | {m['rmse']:.4g} | {m['nrmse']:.3f} | "
                         f"{m['worst_run']} ({m['worst_rmse']:.3g}) |")
    return "\n".join(lines)


def plot_predictions(runs: Sequence[Run], predictors: dict[str, Predictor], targets: Sequence[str],
                     path: Any = None) -> Any:
    """Predicted vs SPH series of `runs` (one column each) per target (rows), the commanded ω on top
    (as Fig. 4.4); saved to `path` if given; returns the figure."""
    import matplotlib.pyplot as plt
    from matplotlib.figure import Figure

    fig = Figure(figsize=(3.2 * len(runs), 1.9 * (len(targets) + 1)), layout="constrained")
    axes = fig.subplots(len(targets) + 1, len(runs), sharex=True, squeeze=False)
    styles = ["-", "--", ":", "-."]
    for col, run in enumerate(runs):
        axes[0, col].plot(run.time, run.column("omega_cmd"), color="k")
        axes[0, col].set_title(f"{run.name}\n{_morphology(run).removeprefix('wheel:')}, {run.params['load']:.2g} N",
                               fontsize=8)
        predictions = {name: predict(run) for name, predict in predictors.items()}
        for row, target in enumerate(targets, start=1):
            ax = axes[row, col]
            ax.plot(run.time, run.column(target), color="k", lw=2, label="SPH")
            for k, (name, y) in enumerate(predictions.items()):
                ax.plot(run.time, y[:, row - 1], styles[k % len(styles)], label=name)
            if col == 0:
                ax.set_ylabel(target)
    axes[0, 0].set_ylabel("ω command (rad/s)")
    for ax in axes[-1]:
        ax.set_xlabel("t after the pause (s)")
    axes[1, 0].legend(fontsize=7)
    if path is not None:
        fig.savefig(path, dpi=110)
    plt.close("all")
    return fig


def learning_curve_splits(splits: Mapping[str, Sequence[int]], sizes: Sequence[int], test: str = "interpolation",
                          seed: int = 0) -> dict[int, tuple[list[int], list[int], list[int]]]:
    """n → (train, validation, test) run indices for each n of `sizes` (capped at the training
    split): the first n of a `seed`-ed permutation of ``splits["train"]`` (nested subsets), the same
    ``splits["val"]`` and ``splits[test]`` for all."""
    order = [int(k) for k in np.random.default_rng(seed).permutation(list(splits["train"]))]
    counts = sorted({min(int(n), len(order)) for n in sizes if n >= 1})
    return {n: (sorted(order[:n]), list(splits["val"]), list(splits[test])) for n in counts}


def learning_curve(runs: Sequence[Run], splits: Mapping[str, Sequence[int]], sizes: Sequence[int],
                   config: TrainConfig, test: str = "interpolation", seed: int = 0) -> dict[int, TrainResult]:
    """The surrogate trained (`config`) on n training runs for each n of `sizes`
    (:func:`learning_curve_splits`): n → its TrainResult, whose ``report["test"]`` is the held-out
    error per target (RMSE, RMSE/std)."""
    from terrasph.surrogate.train import train

    return {n: train(runs, config, progress=False, splits=subset)
            for n, subset in learning_curve_splits(splits, sizes, test, seed).items()}


def plot_learning_curve(curves: Mapping[str, Mapping[int, Mapping[str, Mapping[str, float]]]],
                        targets: Sequence[str], path: Any = None) -> Any:
    """Held-out RMSE/std against the number of training runs: `curves` maps a label (e.g. the cell)
    to n → target → {"nrmse", …}; one panel per target; saved to `path` if given; returns the figure."""
    import matplotlib.pyplot as plt
    from matplotlib.figure import Figure

    fig = Figure(figsize=(3.2 * len(targets), 2.8), layout="constrained")
    axes = fig.subplots(1, len(targets), squeeze=False)[0]
    counts = sorted({n for curve in curves.values() for n in curve})
    for ax, target in zip(axes, targets):
        for label, curve in curves.items():
            ax.plot(sorted(curve), [curve[n][target]["nrmse"] for n in sorted(curve)], "o-", label=label)
        ax.set_xscale("log")
        ax.set_xticks(counts, [str(n) for n in counts], minor=False)
        ax.set_xticks([], minor=True)
        ax.set_ylim(bottom=0.0)
        ax.set_xlabel("training runs")
        ax.set_title(target, fontsize=9)
    axes[0].set_ylabel("held-out RMSE / std")
    axes[0].legend(fontsize=7)
    if path is not None:
        fig.savefig(path, dpi=110)
    plt.close("all")
    return fig
