"""C++ inference of exported surrogate models from Python (no PyTorch needed).

The engine lives in ``terrasph._core.lstm`` (``cpp/lstm/include/terrasph/lstm.hpp``):
``Model32``/``Model64`` predict whole sequences or batches, ``model.stream(batch)`` gives a
streaming object that takes one time step per call and keeps its state until ``reset()``.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

DTYPES = ("float32", "float64")


def core_lstm() -> Any:
    """The compiled ``terrasph._core.lstm`` submodule."""
    from terrasph import _core

    return _core.lstm


def load_model(path: str | Path, dtype: str = "float64") -> Any:
    """Load a model file into the C++ engine in ``dtype`` ("float32" or "float64").

    Raises:
        ValueError: for a bad dtype; ``_core.lstm.LstmFormatError`` (a ValueError) for a
            malformed file.
    """
    if dtype not in DTYPES:
        raise ValueError(f"dtype must be one of {DTYPES}, got {dtype!r}")
    lstm = core_lstm()
    cls = lstm.Model32 if dtype == "float32" else lstm.Model64
    return cls(str(path))


def read_sequences(path: str | Path, feature_names: Sequence[str],
                   body: str | None = None) -> list[tuple[str, np.ndarray]]:
    """Read input sequences for prediction as (name, (T, I) array) pairs.

    ``path`` may be an HDF5 run file or a directory of them (features looked up by the model's
    feature names), a ``.npy`` file holding (T, I) or (B, T, I), or a ``.csv`` file with one time
    step per row (a header row naming the features is allowed and then used to order columns).
    """
    from terrasph.surrogate.dataset import load_runs, read_run

    path = Path(path)
    n = len(feature_names)
    if path.is_dir():
        return [(r.name, r.matrix(feature_names)) for r in load_runs(path, body=body)]
    suffix = path.suffix.lower()
    if suffix in (".h5", ".hdf5"):
        run = read_run(path, body=body)
        return [(run.name, run.matrix(feature_names))]
    if suffix == ".npy":
        arr = np.load(path, allow_pickle=False)
        if arr.ndim == 2:
            arr = arr[None]
        if arr.ndim != 3 or arr.shape[2] != n:
            raise ValueError(f"{path}: array must have shape (T, {n}) or (B, T, {n}), "
                             f"got {arr.shape}")
        return [(f"{path.stem}[{b}]", np.asarray(arr[b], dtype=np.float64))
                for b in range(arr.shape[0])]
    if suffix == ".csv":
        with open(path, encoding="utf-8") as fh:
            first = fh.readline().strip()
        cells = [c.strip() for c in first.split(",")]
        has_header = any(not _is_number(c) for c in cells)
        data = np.loadtxt(path, delimiter=",", skiprows=1 if has_header else 0, ndmin=2)
        if has_header:
            missing = [f for f in feature_names if f not in cells]
            if missing:
                raise ValueError(f"{path}: header lacks the model's features {missing}")
            data = data[:, [cells.index(f) for f in feature_names]]
        if data.shape[1] != n:
            raise ValueError(f"{path}: expected {n} columns {list(feature_names)}, "
                             f"got {data.shape[1]}")
        return [(path.stem, data)]
    raise ValueError(f"{path}: unsupported input (use .h5, a directory of .h5, .npy or .csv)")


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def predict_sequences(model: Any, sequences: Sequence[tuple[str, np.ndarray]]
                      ) -> list[tuple[str, np.ndarray]]:
    """Predict every (name, x) sequence with the C++ model; returns (name, y) pairs in order.

    Sequences of equal length are stacked and advanced together as one batch (the engine's
    batched path, bit for bit equal to predicting them one by one).

    Raises:
        ValueError: if a sequence is not a (T, input_size) array (the message names it).
    """
    dtype = np.float32 if model.dtype == "float32" else np.float64
    n_in = model.input_size
    by_length: dict[int, list[int]] = {}
    for k, (name, x) in enumerate(sequences):
        shape = np.shape(x)
        if len(shape) != 2 or shape[1] != n_in:
            raise ValueError(f"sequence {name!r}: x must have shape (T, {n_in}), got {shape}")
        by_length.setdefault(shape[0], []).append(k)
    out: list[tuple[str, np.ndarray]] = list(sequences)
    for members in by_length.values():
        batch = np.stack([np.asarray(sequences[k][1], dtype=dtype) for k in members])
        for k, y in zip(members, model.predict(batch)):
            out[k] = (sequences[k][0], y)
    return out
