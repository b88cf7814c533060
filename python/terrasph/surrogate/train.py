"""Training of the surrogate LSTM in PyTorch: seeded, early stopping, per-target error report."""

from __future__ import annotations

import copy
import json
import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from terrasph.surrogate.dataset import (
    Normalisation,
    Run,
    SequenceData,
    common_time_step,
    load_runs,
    select,
    split_runs,
)

SPLITS = ("train", "val", "test")


@dataclass(frozen=True)
class TrainConfig:
    """Hyper-parameters of one training run (all validated on construction).

    Attributes:
        features: input columns (series or run parameters).
        targets: predicted series.
        cell: "standard" or "peephole".
        hidden_size: units per layer, in [1, 1024].
        num_layers: stacked layers, in [1, 8].
        epochs: maximum number of epochs, >= 1.
        patience: epochs without validation improvement before stopping, >= 1.
        lr: Adam learning rate, > 0.
        batch_size: runs per optimisation step, >= 1.
        grad_clip: gradient-norm clip, > 0.
        split: train/validation/test fractions of the runs.
        seed: seeds the split, initialisation and shuffling.
    """

    features: tuple[str, ...]
    targets: tuple[str, ...]
    cell: str = "standard"
    hidden_size: int = 32
    num_layers: int = 1
    epochs: int = 300
    patience: int = 30
    lr: float = 1e-2
    batch_size: int = 8
    grad_clip: float = 1.0
    split: tuple[float, float, float] = (0.7, 0.15, 0.15)
    seed: int = 0

    def __post_init__(self) -> None:
        object.__setattr__(self, "features", tuple(self.features))
        object.__setattr__(self, "targets", tuple(self.targets))
        object.__setattr__(self, "split", tuple(float(v) for v in self.split))
        checks = [
            ("cell", self.cell in ("standard", "peephole"), "'standard' or 'peephole'"),
            ("hidden_size", 1 <= self.hidden_size <= 1024, "[1, 1024]"),
            ("num_layers", 1 <= self.num_layers <= 8, "[1, 8]"),
            ("epochs", self.epochs >= 1, ">= 1"),
            ("patience", self.patience >= 1, ">= 1"),
            ("lr", self.lr > 0 and math.isfinite(self.lr), "> 0"),
            ("batch_size", self.batch_size >= 1, ">= 1"),
            ("grad_clip", self.grad_clip > 0, "> 0"),
            ("features", len(self.features) >= 1, "at least one name"),
            ("targets", len(self.targets) >= 1, "at least one name"),
        ]
        for name, ok, allowed in checks:
            if not ok:
                raise ValueError(f"{name} must be {allowed}, got {getattr(self, name)!r}")


@dataclass
class TrainResult:
    """Outcome of :func:`train`: the best network (by validation loss) and its report."""

    net: Any
    config: TrainConfig
    normalisation: Normalisation
    split_runs: dict[str, list[str]]
    history: list[dict[str, float]]
    best_epoch: int
    report: dict[str, dict[str, dict[str, float]]] = field(default_factory=dict)
    dt: float = float("nan")

    def metadata(self) -> dict[str, Any]:
        """JSON-able description stored in the exported model file."""
        import torch

        return {
            "config": asdict(self.config),
            "best_epoch": self.best_epoch,
            "epochs_run": len(self.history),
            "splits": self.split_runs,
            "report": self.report,
            "dt": self.dt,
            "torch_version": torch.__version__,
        }


def _pad(arrays: Sequence[np.ndarray], dtype: Any) -> tuple[Any, Any]:
    """Stack (T_r, n) arrays into a zero-padded (B, T_max, n) tensor and a (B, T_max) mask."""
    import torch

    t_max = max(a.shape[0] for a in arrays)
    n = arrays[0].shape[1]
    out = torch.zeros(len(arrays), t_max, n, dtype=dtype)
    mask = torch.zeros(len(arrays), t_max, dtype=dtype)
    for b, a in enumerate(arrays):
        out[b, : a.shape[0]] = torch.from_numpy(a)
        mask[b, : a.shape[0]] = 1.0
    return out, mask


def error_report(net: Any, data: SequenceData) -> dict[str, dict[str, float]]:
    """Per-target RMSE, MAE (target units) and RMSE / std of the target over ``data``."""
    import torch

    with torch.no_grad():
        preds = [net(torch.from_numpy(x)[None].to(torch.float32))[0].double().numpy()
                 for x in data.inputs]
    y = np.concatenate(data.targets)
    p = np.concatenate(preds)
    out: dict[str, dict[str, float]] = {}
    for j, name in enumerate(data.target_names):
        err = p[:, j] - y[:, j]
        std = float(y[:, j].std())
        rmse = float(np.sqrt(np.mean(err**2)))
        out[name] = {
            "rmse": rmse,
            "mae": float(np.mean(np.abs(err))),
            "nrmse": rmse / std if std > 0 else float("nan"),
        }
    return out


def train(runs: Sequence[Run], config: TrainConfig, progress: bool = True,
          splits: Sequence[Sequence[int]] | None = None) -> TrainResult:
    """Train a surrogate on ``runs`` (split by run, never by time step: the seeded ``config.split``
    fractions, or ``splits``, the run indices of train, validation and test).

    Deterministic for a given seed, machine and thread count. Loss: mean squared error of the
    normalised targets; Adam; gradient clipping; early stopping on the validation loss (the
    weights of the best validation epoch are kept).
    """
    import torch

    if progress:
        from tqdm.auto import tqdm
    else:  # tqdm.auto warns about missing notebook widgets even for a disabled bar
        from tqdm import tqdm

    from terrasph.surrogate.model import ModelConfig, SurrogateNet

    dt = common_time_step(runs)
    i_tr, i_va, i_te = splits if splits is not None else split_runs(len(runs), config.split, config.seed)
    parts = {
        name: select([runs[i] for i in idx], config.features, config.targets)
        for name, idx in zip(SPLITS, (i_tr, i_va, i_te))
    }
    norm = Normalisation.fit(parts["train"].inputs, parts["train"].targets)

    torch.manual_seed(config.seed)
    gen = torch.Generator().manual_seed(config.seed)
    net = SurrogateNet(ModelConfig(config.cell, len(config.features), config.hidden_size,
                                   config.num_layers, len(config.targets)))
    net.set_normalisation(norm.input_mean, norm.input_scale, norm.output_mean, norm.output_scale)

    def normalised(d: SequenceData) -> tuple[list[np.ndarray], list[np.ndarray]]:
        xs = [((x - norm.input_mean) / norm.input_scale).astype(np.float32) for x in d.inputs]
        ys = [((y - norm.output_mean) / norm.output_scale).astype(np.float32) for y in d.targets]
        return xs, ys

    tr_x, tr_y = normalised(parts["train"])
    va_xs, va_ys = normalised(parts["val"])
    va_x, va_mask = _pad(va_xs, torch.float32)
    va_y, _ = _pad(va_ys, torch.float32)
    opt = torch.optim.Adam(net.parameters(), lr=config.lr)
    sched = torch.optim.lr_scheduler.ReduceLROnPlateau(opt, factor=0.5,
                                                       patience=max(1, config.patience // 3))

    def masked_mse(pred: Any, target: Any, mask: Any) -> Any:
        se = ((pred - target) ** 2).mean(dim=2)
        return (se * mask).sum() / mask.sum()

    history: list[dict[str, float]] = []
    best = (math.inf, 0, copy.deepcopy(net.state_dict()))
    bar = tqdm(range(config.epochs), desc=f"train {config.cell} LSTM", disable=not progress,
               unit="epoch")
    for epoch in bar:
        net.train()
        order = torch.randperm(len(tr_x), generator=gen).tolist()
        total, count = 0.0, 0
        for start in range(0, len(order), config.batch_size):
            idx = order[start : start + config.batch_size]
            xb, mask = _pad([tr_x[i] for i in idx], torch.float32)
            yb, _ = _pad([tr_y[i] for i in idx], torch.float32)
            opt.zero_grad()
            loss = masked_mse(net.forward_normalised(xb), yb, mask)
            loss.backward()
            torch.nn.utils.clip_grad_norm_(net.parameters(), config.grad_clip)
            opt.step()
            total += float(loss.detach()) * len(idx)
            count += len(idx)
        net.eval()
        with torch.no_grad():
            val = float(masked_mse(net.forward_normalised(va_x), va_y, va_mask))
        sched.step(val)
        history.append({"epoch": epoch, "train_loss": total / count, "val_loss": val})
        if val < best[0]:
            best = (val, epoch, copy.deepcopy(net.state_dict()))
        bar.set_postfix(train=f"{total / count:.3g}", val=f"{val:.3g}", best=f"{best[0]:.3g}")
        if epoch - best[1] >= config.patience:
            break
    bar.close()
    net.load_state_dict(best[2])
    net.eval()
    result = TrainResult(
        net=net,
        config=config,
        normalisation=norm,
        split_runs={k: parts[k].run_names for k in SPLITS},
        history=history,
        best_epoch=best[1],
        dt=dt,
    )
    result.report = {k: error_report(net, parts[k]) for k in SPLITS}
    return result


def format_report(report: dict[str, dict[str, dict[str, float]]]) -> str:
    """Text table of the per-target error report."""
    lines = [f"{'split':<6} {'target':<14} {'RMSE':>11} {'MAE':>11} {'RMSE/std':>9}"]
    for split, per_target in report.items():
        for name, m in per_target.items():
            lines.append(f"{split:<6} {name:<14} {m['rmse']:>11.4g} {m['mae']:>11.4g} "
                         f"{m['nrmse']:>9.4f}")
    return "\n".join(lines)


def train_directory(dataset_dir: str | Path, out: str | Path, config: TrainConfig,
                    body: str | None = None, progress: bool = True) -> TrainResult:
    """Load the runs of ``dataset_dir``, train, export to ``out`` and write ``out``.json report; a
    dataset of leg-wheel runs (with its dataset.json) records the training runs' validity range
    (terrasph.surrogate.validity) in the metadata."""
    from terrasph.surrogate.export import export_model
    from terrasph.surrogate.robot_dataset import dataset_validity

    runs = load_runs(dataset_dir, body=body)
    result = train(runs, config, progress=progress)
    meta = result.metadata()
    meta["dataset"] = str(Path(dataset_dir).resolve())
    if (Path(dataset_dir) / "dataset.json").is_file():  # leg-wheel runs (`terrasph dataset`): record their range
        trained_on = set(result.split_runs["train"])
        meta["validity"] = dataset_validity(dataset_dir, [r for r in runs if r.name in trained_on],
                                            config.features).to_json()
    export_model(result.net, out, config.features, config.targets, meta)
    Path(str(out) + ".json").write_text(json.dumps(meta, indent=2, sort_keys=True))
    return result
