"""LSTM surrogates of slip and sinkage: dataset, PyTorch training, export and C++ inference.

Modules:
    dataset    HDF5 runs (body time series), feature/target selection, normalisation, splits.
    synthetic  a driven wheel with a known slip-sinkage law (training data until robot runs).
    model      PyTorch networks: torch.nn.LSTM or the peephole cell (Eq. 4.9-4.13) + dense head.
    train      seeded training with early stopping and a per-target error report.
    export     the versioned model file (docs/lstm_format.md), writer and reader.
    inference  the C++ engine (terrasph._core.lstm) from Python.
    cli        ``terrasph train``, ``terrasph predict``, ``terrasph make-synthetic-dataset``.

Modules that need PyTorch (model, train) import it lazily; inference does not need it.
"""

from terrasph.surrogate.export import FORMAT_VERSION, ModelFileError

__all__ = ["FORMAT_VERSION", "ModelFileError"]
