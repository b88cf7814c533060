"""LSTM surrogates of slip and sinkage: dataset, PyTorch training, export and C++ inference.

Modules:
    dataset: HDF5 runs (body time series), feature/target selection, normalisation, splits.
    synthetic: a driven wheel with a known slip-sinkage law (training data until robot runs).
    robot_dataset: leg-wheel sweeps as datasets; held-out splits by range.
    model: PyTorch networks: torch.nn.LSTM or the peephole cell (Eq. 4.9-4.13) + dense head.
    train: seeded training with early stopping and a per-target error report.
    evaluation: held-out error against baselines, learning curve, figures.
    export: the versioned model file (docs/lstm_format.md), writer and reader.
    validity: the range of a model's training runs, recorded in its file and checked.
    registry: the models shipped with the package, by name (``pretrained``).
    inference: the C++ engine (terrasph._core.lstm) from Python.
    cli: ``terrasph train``, ``terrasph predict``, ``terrasph make-synthetic-dataset``.

Modules that need PyTorch (model, train) import it lazily; inference and the registry do not need it.
"""

from terrasph.surrogate.export import FORMAT_VERSION, ModelFileError
from terrasph.surrogate.registry import available, pretrained, pretrained_path

__all__ = ["FORMAT_VERSION", "ModelFileError", "available", "pretrained", "pretrained_path"]
