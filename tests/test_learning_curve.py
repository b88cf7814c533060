"""The learning curve (terrasph.surrogate.evaluation.learning_curve) on the synthetic driven wheel,
whose slip and sinkage follow a known law with memory (terrasph.surrogate.synthetic): nested
training sets, one validation and test set, and more runs lowering the held-out error by more than
the seed-to-seed scatter."""

from __future__ import annotations

import pytest
from lstm_helpers import one_thread  # noqa: F401 (a fixture)
from terrasph.surrogate.dataset import load_runs, split_runs
from terrasph.surrogate.evaluation import learning_curve
from terrasph.surrogate.synthetic import DEFAULT_FEATURES, DEFAULT_TARGETS, make_dataset
from terrasph.surrogate.train import TrainConfig

pytest.importorskip("torch")


def test_more_training_runs_lower_the_held_out_error(tmp_path, one_thread) -> None:
    """40 synthetic runs of 1 s (Δt = 0.05 s): 24 for training, 8 validation, 8 test. Trained on 3
    then 24 runs (H = 8, 100 epochs, seed 0), the test RMSE/std falls by more than 0.25 on both
    targets. Measured over the seeds 0-7 (development): the fall was 0.55-0.90 on slip (mean 0.72,
    sd 0.12) and 0.37-0.87 on sinkage (mean 0.59, sd 0.15); 0.25 is 2 sd below either mean and 0
    would mean no gain at all. The smaller training set is part of the larger one; validation and
    test runs are the same for both."""
    make_dataset(tmp_path, n_runs=40, seed=0, duration=1.0, dt=0.05)
    runs = load_runs(tmp_path)
    train, val, test = split_runs(len(runs), (0.6, 0.2, 0.2), 0)
    splits = {"train": list(train), "val": list(val), "interpolation": list(test)}
    config = TrainConfig(DEFAULT_FEATURES, DEFAULT_TARGETS, hidden_size=8, epochs=100, patience=100, lr=1e-2,
                         batch_size=8, seed=0)
    curve = learning_curve(runs, splits, [3, 24, 1000], config)
    assert sorted(curve) == [3, 24]  # sizes capped at the training split
    small, large = curve[3], curve[24]
    assert set(small.split_runs["train"]) < set(large.split_runs["train"])
    assert small.split_runs["test"] == large.split_runs["test"] == [runs[k].name for k in test]
    assert small.split_runs["val"] == large.split_runs["val"]
    for target in DEFAULT_TARGETS:
        fall = small.report["test"][target]["nrmse"] - large.report["test"][target]["nrmse"]
        assert fall > 0.25, f"{target}: held-out RMSE/std fell by {fall:.3f} from 3 to 24 training runs"


def test_held_out_splits_by_load_and_by_omega() -> None:
    """split_held_out: a run whose load leaves the range is in the load extrapolation test, one whose
    commanded ω exceeds the bound at any step in the ω test (a run outside both in both); the others
    are split, each exactly once, into train, validation and interpolation."""
    import numpy as np
    from terrasph.surrogate.dataset import Run
    from terrasph.surrogate.robot_dataset import split_held_out

    time = np.linspace(0.0, 1.0, 11)
    loads = [2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 3.5, 4.5, 2.5, 7.5]
    peaks = [1.0, 2.0, 3.2, 1.5, 2.9, 3.5, 1.2, 2.2, 1.8, 1.1]  # ω ramps from 0.5 to these
    runs = [Run(f"r{k}", time, {"omega_cmd": np.linspace(0.5, peak, time.size)}, {"load": load})
            for k, (load, peak) in enumerate(zip(loads, peaks))]
    splits = split_held_out(runs, {"load": (2.0, 6.0), "omega_cmd": (0.0, 3.0)}, seed=0)
    assert splits["extrapolation: load"] == [5, 9]
    assert splits["extrapolation: omega_cmd"] == [2, 5]
    inside = splits["train"] + splits["val"] + splits["interpolation"]
    assert sorted(inside) == [0, 1, 3, 4, 6, 7, 8] and len(set(inside)) == len(inside)
