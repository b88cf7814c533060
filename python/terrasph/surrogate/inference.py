"""C++ inference of exported surrogate models from Python (no PyTorch needed).

The engine lives in ``terrasph._core.lstm`` (``cpp/lstm/include/terrasph/lstm.hpp``):
``Model32``/``Model64`` predict whole sequences or batches, ``model.stream(batch)`` gives a
streaming object that takes one time step per call and keeps its state until ``reset()``.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from terrasph.surrogate.dataset import Run

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


def read_inputs(path: str | Path, feature_names: Sequence[str], dt: float = float("nan"),
                body: str | None = None, legs: int | None = None) -> list[tuple[Run, dict[str, Any] | None]]:
    """Read the runs to predict, each with its leg-wheel configuration (None when the input does not
    hold one).

    ``path`` may be a run file of the leg-wheel scene (its driven phase resampled to the model's
    `dt`, as the robot dataset does: terrasph.surrogate.robot_dataset.robot_run, with the SPH's
    slip, sinkage and forward speed as series), a dataset HDF5 run file or a directory of them
    (features looked up by name), a ``.npy`` file holding (T, I) or (B, T, I), or a ``.csv`` file
    with one time step per row (a header row naming the features is allowed and then used to order
    columns). Rows of a .npy or .csv are taken as steps of `dt`. A CSV header may leave out the
    legs' phase columns (terrasph.surrogate.validity.PHASE_FEATURES): they are then derived from its
    ``omega_cmd`` for a robot of `legs` legs, as the robot dataset derives them.
    """
    from terrasph.surrogate.dataset import load_runs, read_run
    from terrasph.surrogate.robot_dataset import BED_PARAMETERS, is_leg_wheel_run, leg_wheel_fields, robot_run
    from terrasph.surrogate.validity import MORPHOLOGY_PREFIX

    path = Path(path)
    n = len(feature_names)
    if path.is_dir():
        return [(run, None) for run in load_runs(path, body=body)]
    suffix = path.suffix.lower()
    if suffix in (".h5", ".hdf5"):
        if not is_leg_wheel_run(path):
            return [(read_run(path, body=body), None)]
        if not dt > 0:
            raise ValueError(f"{path}: a leg-wheel run is resampled to the model's time step, and this model "
                             "records none (its metadata has no 'dt'); give the inputs as .csv or .npy")
        wheels = [f.removeprefix(MORPHOLOGY_PREFIX) for f in feature_names if f.startswith(MORPHOLOGY_PREFIX)]
        bed = [f for f in feature_names if f in BED_PARAMETERS]
        return [(robot_run(path, dt, wheels, bed), leg_wheel_fields(path))]
    if suffix == ".npy":
        arr = np.load(path, allow_pickle=False)
        if arr.ndim == 2:
            arr = arr[None]
        if arr.ndim != 3 or arr.shape[2] != n:
            raise ValueError(f"{path}: array must have shape (T, {n}) or (B, T, {n}), "
                             f"got {arr.shape}")
        return [(_input_run(f"{path.stem}[{b}]", arr[b], feature_names, dt), None) for b in range(arr.shape[0])]
    if suffix == ".csv":
        with open(path, encoding="utf-8") as fh:
            first = fh.readline().strip()
        cells = [c.strip() for c in first.split(",")]
        has_header = any(not _is_number(c) for c in cells)
        data = np.loadtxt(path, delimiter=",", skiprows=1 if has_header else 0, ndmin=2)
        if has_header and _derives_phase(feature_names, cells, dt, legs):
            data, cells = _with_phase(data, cells, dt, legs)
        if has_header:
            missing = [f for f in feature_names if f not in cells]
            if missing:
                raise ValueError(f"{path}: header lacks the model's features {missing}")
            data = data[:, [cells.index(f) for f in feature_names]]
        if data.shape[1] != n:
            raise ValueError(f"{path}: expected {n} columns {list(feature_names)}, "
                             f"got {data.shape[1]}")
        return [(_input_run(path.stem, data, feature_names, dt), None)]
    raise ValueError(f"{path}: unsupported input (use .h5, a directory of .h5, .npy or .csv)")


def _derives_phase(feature_names: Sequence[str], cells: Sequence[str], dt: float, legs: int | None) -> bool:
    """Whether the model takes the legs' phase and a CSV header (`cells`) leaves it to be derived."""
    from terrasph.surrogate.validity import PHASE_FEATURES

    wanted = all(f in feature_names for f in PHASE_FEATURES) and not any(f in cells for f in PHASE_FEATURES)
    if wanted and not (dt > 0 and legs and "omega_cmd" in cells):
        raise ValueError("the legs' phase columns are derived from an omega_cmd column at the model's dt "
                         "for its number of legs, and this model or input lacks one of them")
    return wanted


def _with_phase(data: np.ndarray, cells: list[str], dt: float, legs: int | None) -> tuple[np.ndarray, list[str]]:
    """The CSV rows with the phase columns derived from their omega_cmd appended."""
    from terrasph.surrogate.robot_dataset import commanded_phase

    phase = commanded_phase(data[:, cells.index("omega_cmd")], dt, int(legs or 0))
    return np.column_stack([data, *phase.values()]), [*cells, *phase]


def _input_run(name: str, x: np.ndarray, feature_names: Sequence[str], dt: float) -> Run:
    """Rows of inputs (T, I) as a run of steps `dt` (1 if the model records none)."""
    from terrasph.surrogate.dataset import Run

    step = dt if dt > 0 else 1.0
    return Run(name=name, time=step * np.arange(len(x)), series={f: np.asarray(x[:, j], dtype=np.float64)
                                                                 for j, f in enumerate(feature_names)}, params={})


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
