"""Dataset of runs for the surrogate: HDF5 body time series, feature/target selection,
normalisation and splits by run.

HDF5 layout read and written here (one run per file; the body series of the run files that
``terrasph.io.RunWriter`` writes, see docs/lstm.md)::

    /                              attrs: config_json (run configuration, JSON text) and others
    /series/bodies/<body>/         group of one body; attrs: fixed run parameters of this body
    /series/bodies/<body>/time     (T,) float64, seconds, uniformly sampled
    /series/bodies/<body>/<name>   (T,) float64 series: commanded inputs (e.g. omega_cmd) and
                                   targets (e.g. slip, sinkage); attr "units" optional

(``/bodies/<body>/`` is accepted as well.) A feature name resolves to a series of the body
(varies in time), else to a numeric scalar attribute of the body group, of the root, or a
numeric leaf of ``config_json`` named by its dotted path (e.g. ``material.mu1``): a fixed run
parameter, repeated at every step. Targets must be series.
"""

from __future__ import annotations

import contextlib
import json
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

BODY_GROUPS = ("series/bodies", "bodies")  # where body time series live, first match wins


@dataclass
class Run:
    """One run: time, series and fixed parameters of one body.

    Attributes:
        name: identifier (file stem).
        time: (T,) sample times in seconds, strictly increasing.
        series: name -> (T,) array (commanded inputs and targets).
        params: name -> float, fixed run parameters.
        units: optional name -> unit string.
    """

    name: str
    time: np.ndarray
    series: dict[str, np.ndarray]
    params: dict[str, float]
    units: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.time = np.asarray(self.time, dtype=np.float64)
        if self.time.ndim != 1 or self.time.size < 1:
            raise ValueError(f"run {self.name!r}: time must be a non-empty 1-D array")
        if self.time.size > 1 and not np.all(np.diff(self.time) > 0):
            raise ValueError(f"run {self.name!r}: time must be strictly increasing")
        for key, value in list(self.series.items()):
            arr = np.asarray(value, dtype=np.float64)
            if arr.shape != self.time.shape:
                raise ValueError(
                    f"run {self.name!r}: series {key!r} has shape {arr.shape}, "
                    f"expected {self.time.shape} like time"
                )
            self.series[key] = arr

    @property
    def length(self) -> int:
        """Number of time steps T."""
        return int(self.time.size)

    def column(self, name: str) -> np.ndarray:
        """Series ``name`` or the parameter ``name`` repeated over time, as (T,) float64."""
        if name in self.series:
            return self.series[name]
        if name in self.params:
            return np.full(self.length, float(self.params[name]))
        params = sorted(self.params)
        raise KeyError(
            f"run {self.name!r} has no series or numeric parameter {name!r}; series: "
            f"{sorted(self.series)}; {len(params)} parameters"
            + (f" ({', '.join(params[:5])}, …)" if len(params) > 5 else f" {params}")
        )

    def matrix(self, names: Sequence[str]) -> np.ndarray:
        """Stack the columns ``names`` into a (T, len(names)) float64 array."""
        return np.stack([self.column(n) for n in names], axis=1)


def _numeric_attrs(attrs: Any) -> dict[str, float]:
    out: dict[str, float] = {}
    for key, value in attrs.items():
        arr = np.asarray(value)
        if arr.shape == () and np.issubdtype(arr.dtype, np.number) and not np.issubdtype(
            arr.dtype, np.bool_
        ):
            out[str(key)] = float(arr)
    return out


def _flatten(obj: Any, prefix: str = "") -> dict[str, float]:
    """Numeric leaves of a JSON value keyed by dotted path."""
    out: dict[str, float] = {}
    if isinstance(obj, dict):
        for key, value in obj.items():
            out.update(_flatten(value, f"{prefix}{key}."))
    elif isinstance(obj, (int, float)) and not isinstance(obj, bool):
        out[prefix[:-1]] = float(obj)
    return out


def write_run(path: str | Path, run: Run, body: str = "wheel",
              config: dict[str, Any] | None = None) -> Path:
    """Write one run: series under ``/series/bodies/<body>``, parameters as that group's attrs,
    ``config`` (JSON-able) as the root attribute ``config_json``."""
    import h5py

    path = Path(path)
    with h5py.File(path, "w") as f:
        f.attrs["config_json"] = json.dumps(config or {}, sort_keys=True)
        f.attrs["units"] = "SI"
        g = f.create_group(f"{BODY_GROUPS[0]}/{body}")
        for key, param in run.params.items():
            g.attrs[key] = float(param)
        d = g.create_dataset("time", data=run.time)
        d.attrs["units"] = "s"
        for key, values in run.series.items():
            d = g.create_dataset(key, data=values)
            if key in run.units:
                d.attrs["units"] = run.units[key]
    return path


def read_run(path: str | Path, body: str | None = None) -> Run:
    """Read one run file. ``body`` defaults to the only body of the file.

    Raises:
        ValueError: if the file does not follow the layout (message names what is missing).
    """
    import h5py

    path = Path(path)
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise ValueError(f"{path}: cannot open as HDF5 ({exc})") from exc
    with f:
        base = next((b for b in BODY_GROUPS if isinstance(f.get(b), h5py.Group)), None)
        if base is None:
            raise ValueError(f"{path}: no '/series/bodies' (or '/bodies') group; "
                             "not a run file with body time series")
        bodies = sorted(f[base].keys())
        if body is None:
            if len(bodies) != 1:
                raise ValueError(f"{path}: choose a body among {bodies} (argument 'body')")
            body = bodies[0]
        if body not in bodies:
            raise ValueError(f"{path}: body {body!r} not found; bodies: {bodies}")
        g = f[base][body]
        if "time" not in g:
            raise ValueError(f"{path}: /{base}/{body}/time missing")
        time = np.asarray(g["time"][()], dtype=np.float64).reshape(-1)
        series: dict[str, np.ndarray] = {}
        units: dict[str, str] = {}
        for key, ds in g.items():
            if key == "time" or not isinstance(ds, h5py.Dataset) or ds.shape != time.shape:
                continue
            if ds.dtype.kind not in "biuf":
                continue
            series[key] = np.asarray(ds[()], dtype=np.float64)
            if "units" in ds.attrs:
                units[key] = str(ds.attrs["units"])
        params: dict[str, float] = {}
        if "config_json" in f.attrs:
            with contextlib.suppress(TypeError, ValueError):  # an unreadable configuration only hides its parameters
                params.update(_flatten(json.loads(f.attrs["config_json"])))
        params.update(_numeric_attrs(f.attrs))
        params.update(_numeric_attrs(g.attrs))
    return Run(name=path.stem, time=time, series=series, params=params, units=units)


def load_runs(directory: str | Path, body: str | None = None,
              pattern: str = "*.h5") -> list[Run]:
    """Read every run file matching ``pattern`` in ``directory``, sorted by file name."""
    directory = Path(directory)
    if not directory.is_dir():
        raise ValueError(f"dataset directory {directory} does not exist")
    files = sorted(directory.glob(pattern))
    if not files:
        raise ValueError(f"no run files matching {pattern!r} in {directory}")
    return [read_run(p, body) for p in files]


def split_runs(n_runs: int, fractions: tuple[float, float, float] = (0.7, 0.15, 0.15),
               seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Split run indices (never time steps) into train/validation/test, seeded.

    Each split gets at least one run; ``fractions`` must be positive and sum to 1.
    """
    if n_runs < 3:
        raise ValueError(f"n_runs must be >= 3 to split by run, got {n_runs}")
    fr = np.asarray(fractions, dtype=float)
    if fr.shape != (3,) or (fr <= 0).any() or abs(fr.sum() - 1.0) > 1e-9:
        raise ValueError(f"fractions must be three positive numbers summing to 1, got {fractions}")
    perm = np.random.default_rng(seed).permutation(n_runs)
    n_val = max(1, round(float(fr[1]) * n_runs))
    n_test = max(1, round(float(fr[2]) * n_runs))
    n_train = n_runs - n_val - n_test
    if n_train < 1:
        raise ValueError(f"too few runs ({n_runs}) for the fractions {fractions}")
    return (np.sort(perm[:n_train]), np.sort(perm[n_train:n_train + n_val]),
            np.sort(perm[n_train + n_val:]))


@dataclass(frozen=True)
class Normalisation:
    """Affine normalisation x_n = (x - mean) / scale of inputs and outputs."""

    input_mean: np.ndarray
    input_scale: np.ndarray
    output_mean: np.ndarray
    output_scale: np.ndarray

    @staticmethod
    def fit(inputs: Iterable[np.ndarray], outputs: Iterable[np.ndarray]) -> Normalisation:
        """Mean and standard deviation over all time steps of the given (T, n) arrays.

        A (near-)constant column gets scale 1 so it is centred but not blown up.
        """
        def stats(arrays: Iterable[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
            a = np.concatenate(list(arrays), axis=0)
            mean, std = a.mean(axis=0), a.std(axis=0)
            tiny = std <= 1e-12 * np.maximum(1.0, np.abs(mean))
            return mean, np.where(tiny, 1.0, std)

        im, isc = stats(inputs)
        om, osc = stats(outputs)
        return Normalisation(im, isc, om, osc)


@dataclass
class SequenceData:
    """Feature and target matrices of a list of runs."""

    feature_names: list[str]
    target_names: list[str]
    inputs: list[np.ndarray]   # each (T_r, I)
    targets: list[np.ndarray]  # each (T_r, O)
    run_names: list[str]


def select(runs: Sequence[Run], features: Sequence[str],
           targets: Sequence[str]) -> SequenceData:
    """Extract features (series or parameters) and targets (series) from each run.

    Raises ValueError naming the run and column if anything is missing or non-finite.
    """
    if not features or not targets:
        raise ValueError("features and targets must each name at least one column")
    ins, outs = [], []
    for run in runs:
        for t in targets:
            if t not in run.series:
                raise ValueError(f"run {run.name!r}: target {t!r} must be a time series; "
                                 f"series: {sorted(run.series)}")
        try:
            x, y = run.matrix(features), run.matrix(targets)
        except KeyError as exc:
            raise ValueError(str(exc.args[0])) from exc
        for arr, names in ((x, features), (y, targets)):
            bad = ~np.isfinite(arr).all(axis=0)
            if bad.any():
                raise ValueError(f"run {run.name!r}: non-finite values in "
                                 f"{[n for n, b in zip(names, bad) if b]}")
        ins.append(x)
        outs.append(y)
    return SequenceData(list(features), list(targets), ins, outs, [r.name for r in runs])


def common_time_step(runs: Sequence[Run], rtol: float = 1e-6) -> float:
    """The uniform sampling interval shared by all runs; ValueError if it differs."""
    dts = []
    for run in runs:
        if run.length < 2:
            continue
        d = np.diff(run.time)
        if np.ptp(d) > rtol * d.mean():
            raise ValueError(f"run {run.name!r} is not uniformly sampled; resample it first")
        dts.append(d.mean())
    if not dts:
        return float("nan")
    dts_a = np.asarray(dts)
    if np.ptp(dts_a) > rtol * dts_a.mean():
        raise ValueError(f"runs are sampled at different time steps {sorted(set(dts))}; "
                         "resample to one dt")
    return float(dts_a.mean())
