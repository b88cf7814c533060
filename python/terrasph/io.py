"""HDF5 output of a run (one file per run) and its ParaView (XDMF) sidecar.

The layout is documented in ``docs/hdf5_schema.md``. In short::

    /                      attrs: config_json, terrasph_schema, created_utc, units, version_<name>
    /static/<name>         arrays written once (e.g. "granular/mass", "walls/position")
    /frames/time, /step    (n_frames,)
    /frames/<field>        (n_frames, N, ...) one chunk per frame, compressed
    /series/<group>/<name> (n_rows,) or (n_rows, k), one row per append
    /<any group>           attrs set with :meth:`RunWriter.set_attrs` (e.g. "/results")

Units are SI; 2D scenes are plane strain in the x–z plane with z up. Forces are in newtons for
the body's real out-of-plane width, masses and energies per the run's width as documented.

Every call that writes frames or series rows ends with ``h5py.File.flush``, so a run whose process
dies between two calls leaves a readable file holding every frame written so far (the run loop,
terrasph.run_loop, writes its frames and rows in batches: :data:`terrasph.run_loop.SERIES_WRITE_SECONDS`).
"""

from __future__ import annotations

import datetime
import json
import math
import os
import pathlib
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from types import TracebackType
from typing import Any, NamedTuple

import h5py
import numpy as np

__all__ = ["RAW_FRAME_BYTES", "SCHEMA_VERSION", "UNITS", "RunData", "RunWriter", "defined_values", "read_run", "write_results", "write_xdmf",
           "write_xdmf_sets"]

SCHEMA_VERSION = 1
UNITS = "SI; 2D plane strain, forces in N for the body's real width"
_COMPRESSIONS = ("gzip", "lzf", "none")
#: a frame (all its fields) smaller than this (bytes) is stored without compression: a robot's frames
#: on the RFT terrain (its bodies' drawing, ~20 kB) shrink by 16 % under gzip with shuffle (lzf: 13 %)
#: for ten times the wall of writing them raw, more than the RFT steps between two frames cost
#: (benchmarks/performance/bench_run_overhead.py); a frame of grains, far larger and seconds of
#: stepping apart, is compressed
RAW_FRAME_BYTES = 64 * 1024
_SERIES_CHUNK_ROWS = 256
_RESERVED_FRAME_NAMES = ("time", "step")


def _json_default(value: Any) -> Any:
    """Make numpy scalars/arrays and paths JSON-serialisable (used by ``json.dumps``)."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    raise TypeError(f"object of type {type(value).__name__} is not JSON serialisable")


def _attr_value(key: str, value: Any) -> Any:
    """Convert ``value`` to something h5py stores as an attribute; mappings become JSON text."""
    if isinstance(value, Mapping):
        return json.dumps(value, sort_keys=True, default=_json_default)
    if isinstance(value, (str, bool, int, float, np.generic)):
        return value
    array = np.asarray(value)
    if array.dtype.kind not in "biuf":
        raise ValueError(
            f"attribute {key!r}: unsupported value of type {type(value).__name__}; "
            "allowed: str, bool, int, float, numeric arrays, or a JSON-serialisable mapping"
        )
    return array


def _decode_attr(value: Any) -> Any:
    """Return an HDF5 attribute value as a plain Python object where it is a scalar."""
    if isinstance(value, bytes):
        return value.decode("utf-8")
    if isinstance(value, np.generic):
        return value.item()
    return value


class RunWriter:
    """One HDF5 file per run (h5py). Frames are flushed as written, so an interrupted run leaves a readable file.

    Parameters
    ----------
    path:
        File to create.
    config:
        The run's validated configuration; stored as JSON text (``sort_keys=True``) in the root
        attribute ``config_json``. numpy scalars and arrays are converted to JSON numbers/lists.
    versions:
        Optional software versions (e.g. ``{"terrasph": "0.1.0", "numpy": "2.1"}``), stored as
        root attributes ``version_<name>``.
    compression:
        ``"gzip"`` (with byte shuffle), ``"lzf"`` or ``"none"``; applies to static arrays and to
        frames of at least :data:`RAW_FRAME_BYTES` (smaller frames are stored raw).
    overwrite:
        Replace an existing file; if False an existing ``path`` raises ``FileExistsError``.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        config: Mapping[str, Any],
        *,
        versions: Mapping[str, str] | None = None,
        compression: str = "gzip",
        overwrite: bool = True,
    ) -> None:
        if compression not in _COMPRESSIONS:
            raise ValueError(f"compression must be one of {_COMPRESSIONS}, got {compression!r}")
        if not isinstance(config, Mapping):
            raise TypeError(f"config must be a mapping, got {type(config).__name__}")
        config_json = json.dumps(dict(config), sort_keys=True, default=_json_default)
        self.path = pathlib.Path(path)
        self._filters: dict[str, Any] = (
            {} if compression == "none" else {"compression": compression, "shuffle": True}
        )
        self._frame_shapes: dict[str, tuple[tuple[int, ...], np.dtype]] | None = None
        self._frame_datasets: dict[str, h5py.Dataset] | None = None  # the frames' datasets, looked up once
        self._series_shapes: dict[str, dict[str, tuple[tuple[int, ...], np.dtype]]] = {}
        self._file = h5py.File(self.path, "w" if overwrite else "w-")
        attrs = self._file.attrs
        attrs["config_json"] = config_json
        attrs["terrasph_schema"] = SCHEMA_VERSION
        attrs["created_utc"] = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
        attrs["units"] = UNITS
        for name, version in (versions or {}).items():
            attrs[f"version_{name}"] = str(version)
        self._file.create_group("static")
        frames = self._file.create_group("frames")
        frames.create_dataset("time", shape=(0,), maxshape=(None,), dtype="f8", chunks=(_SERIES_CHUNK_ROWS,))
        frames.create_dataset("step", shape=(0,), maxshape=(None,), dtype="i8", chunks=(_SERIES_CHUNK_ROWS,))
        self._file.create_group("series")
        self._file.flush()

    @classmethod
    def reopen(cls, path: str | os.PathLike[str], *, frames: int, series_rows: Mapping[str, int],
               compression: str = "gzip") -> RunWriter:
        """Reopens a run's file to continue it from a checkpoint: frames past the first `frames`,
        series rows past `series_rows[group]` and series groups it does not name (all written
        after the checkpoint) are dropped, so the continued run writes each once."""
        if compression not in _COMPRESSIONS:
            raise ValueError(f"compression must be one of {_COMPRESSIONS}, got {compression!r}")
        writer = cls.__new__(cls)
        writer.path = pathlib.Path(path)
        writer._filters = {} if compression == "none" else {"compression": compression, "shuffle": True}
        writer._file = h5py.File(writer.path, "r+")
        writer._frame_datasets = None
        if "run" in writer._file:  # the earlier run's status and checkpoint name no longer hold
            writer._file["run"].attrs.clear()
        if "results" in writer._file:  # nor a finished run's results: the scene writes them anew
            del writer._file["results"]
        frame_group = writer._file["frames"]
        for dataset in frame_group.values():
            dataset.resize(frames, axis=0)
        fields = [name for name in frame_group if name not in _RESERVED_FRAME_NAMES]
        writer._frame_shapes = ({name: (frame_group[name].shape[1:], frame_group[name].dtype) for name in fields}
                                if fields else None)
        writer._series_shapes = {}
        series = writer._file["series"]
        for group in _datasets_groups(series):
            if group not in series_rows:
                del series[group]
                continue
            datasets = series[group]
            for dataset in datasets.values():
                dataset.resize(series_rows[group], axis=0)
            writer._series_shapes[group] = {name: (d.shape[1:], d.dtype) for name, d in datasets.items()}
        writer._file.flush()
        return writer

    # -- context manager -------------------------------------------------------------------
    def __enter__(self) -> RunWriter:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    @property
    def closed(self) -> bool:
        """True once :meth:`close` has been called."""
        return not self._file.id.valid

    def close(self) -> None:
        """Flush and close the file; calling it again does nothing."""
        if not self.closed:
            self._file.close()

    def _open_file(self) -> h5py.File:
        if self.closed:
            raise ValueError(f"RunWriter for {self.path} is closed")
        return self._file

    # -- writing ---------------------------------------------------------------------------
    @property
    def frame_shapes(self) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
        """Each frame field's shape (of one frame) and dtype, as the first frame set them (empty
        before it)."""
        return dict(self._frame_shapes or {})

    @property
    def n_frames(self) -> int:
        """Number of frames written so far."""
        return int(self._open_file()["frames/time"].shape[0])

    def write_static(self, name: str, array: np.ndarray) -> None:
        """Store an array written once per run as ``/static/<name>`` (``name`` may contain ``/``)."""
        file = self._open_file()
        if not name or name.startswith("/"):
            raise ValueError(f"name must be a non-empty relative path like 'walls/position', got {name!r}")
        if name in file["static"]:
            raise ValueError(f"static dataset {name!r} already exists")
        data = np.asarray(array)
        if data.dtype.kind not in "biuf":
            raise ValueError(f"array for static {name!r} must be numeric, got dtype {data.dtype}")
        filters = self._filters if data.ndim > 0 and data.size > 0 else {}
        file["static"].create_dataset(name, data=data, **filters)
        file.flush()

    def write_frame(self, time: float, step: int, fields: Mapping[str, np.ndarray]) -> None:
        """Append one frame of per-particle fields, then flush (:meth:`write_frames` of one frame).

        The first frame fixes the field names, per-frame shapes and dtypes; every later frame must
        match them (``ValueError`` naming the field otherwise). ``time`` is in s, ``step`` the
        integrator step count.
        """
        self.write_frames([(time, step, fields)])

    def write_frames(self, frames: Sequence[tuple[float, int, Mapping[str, np.ndarray]]]) -> None:
        """Append `frames`, each (time s, step count, {field: per-particle array}), with one resize
        and one write per dataset and one flush for all of them (each frame still its own chunk).

        Every frame is checked against the first frame's fields (:meth:`write_frame`) before any of
        `frames` is written, so a bad frame leaves the file as it was.
        """
        file = self._open_file()
        if not frames:
            return
        batch = []
        for time, _, fields in frames:
            if not np.isfinite(time):
                raise ValueError(f"time must be finite, got {time!r}")
            arrays = {name: np.asarray(value) for name, value in fields.items()}
            if not arrays:
                raise ValueError("fields must hold at least one array")
            if self._frame_shapes is None:
                self._frame_shapes = self._create_frame_datasets(file["frames"], arrays)
            self._check_frame(arrays)
            batch.append(arrays)
        assert self._frame_shapes is not None  # set by the first frame, of this batch or an earlier one
        if self._frame_datasets is None:  # h5py looks a dataset up by name anew on every access
            group = file["frames"]
            self._frame_datasets = {name: group[name] for name in (*self._frame_shapes, "step", "time")}
        datasets = self._frame_datasets
        index, count = datasets["time"].shape[0], len(frames)
        columns: dict[str, np.ndarray] = {name: np.stack([arrays[name] for arrays in batch]) for name in batch[0]}
        columns["step"] = np.array([int(step) for _, step, _ in frames], dtype=np.int64)
        columns["time"] = np.array([float(time) for time, _, _ in frames])
        for name, data in columns.items():  # time last: a reader counts the frames whose time is written
            dataset = datasets[name]
            dataset.resize(index + count, axis=0)
            dataset[index:] = data
        file.flush()

    def _create_frame_datasets(
        self, frames: h5py.Group, arrays: Mapping[str, np.ndarray]
    ) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
        """Create one resizable dataset per field from the first frame; return shapes/dtypes."""
        for name, data in arrays.items():
            if name in _RESERVED_FRAME_NAMES or not name or "/" in name:
                raise ValueError(f"frame field name {name!r} is not allowed (reserved, empty or contains '/')")
            if data.ndim == 0 or data.shape[0] == 0 or data.dtype.kind not in "biuf":
                raise ValueError(
                    f"frame field {name!r} must be a numeric array with at least one particle, "
                    f"got shape {data.shape} and dtype {data.dtype}"
                )
        shapes: dict[str, tuple[tuple[int, ...], np.dtype]] = {}
        filters = self._filters if sum(data.nbytes for data in arrays.values()) >= RAW_FRAME_BYTES else {}
        for name, data in arrays.items():
            frames.create_dataset(
                name,
                shape=(0, *data.shape),
                maxshape=(None, *data.shape),
                chunks=(1, *data.shape),
                dtype=data.dtype,
                **filters,
            )
            shapes[name] = (data.shape, data.dtype)
        return shapes

    def _check_frame(self, arrays: Mapping[str, np.ndarray]) -> None:
        """Raise ``ValueError`` naming the first field that differs from the first frame."""
        assert self._frame_shapes is not None
        expected = self._frame_shapes
        for name in sorted(set(expected) ^ set(arrays)):
            state = "missing from" if name in expected else "not in the first frame, unexpected in"
            raise ValueError(f"frame field {name!r} is {state} this frame; fields are {sorted(expected)}")
        for name, data in arrays.items():
            shape, dtype = expected[name]
            if data.shape != shape:
                raise ValueError(f"frame field {name!r} has shape {data.shape}, expected {shape}")
            if not np.can_cast(data.dtype, dtype, casting="same_kind"):
                raise ValueError(f"frame field {name!r} has dtype {data.dtype}, expected {dtype}")

    def append_series(self, group: str, values: Mapping[str, float | np.ndarray]) -> None:
        """Append one row to the time series ``/series/<group>/<name>`` for each entry, then flush
        (:meth:`append_series_rows` of one row)."""
        self.append_series_rows(group, [values])

    def append_series_rows(self, group: str, rows: Sequence[Mapping[str, float | np.ndarray]]) -> None:
        """Append `rows` to the time series ``/series/<group>/<name>``, one resize per dataset and
        one flush for all of them.

        Scalars make 1-D datasets, vectors of shape (k,) make (n_rows, k) datasets. The first row
        of a group fixes its names and shapes; later rows must match (``ValueError`` naming the
        entry otherwise, before anything of `rows` is written). Example groups: ``"diagnostics"``
        (time, step, dt, kinetic_energy, …) and ``"bodies/<name>"`` (time, position, force, torque,
        slip, sinkage, …).
        """
        file = self._open_file()
        if not group or group.startswith("/"):
            raise ValueError(f"group must be a non-empty relative path like 'diagnostics', got {group!r}")
        if not rows:
            return
        if any(not row for row in rows):
            raise ValueError(f"values for series group {group!r} must hold at least one entry")
        if group not in self._series_shapes:
            first = {name: np.asarray(value) for name, value in rows[0].items()}
            self._series_shapes[group] = self._create_series(file["series"], group, first)
        expected = self._series_shapes[group]
        columns = self._series_columns(group, expected, rows)
        series = file["series"][group]
        for name, column in columns.items():
            dataset = series[name]
            index = dataset.shape[0]
            dataset.resize(index + len(column), axis=0)
            dataset[index:] = column
        file.flush()

    @classmethod
    def _series_columns(cls, group: str, expected: Mapping[str, tuple[tuple[int, ...], np.dtype]],
                        rows: Sequence[Mapping[str, Any]]) -> dict[str, np.ndarray]:
        """`rows` as one array per entry of the group (rows × the entry's shape), each checked once
        against the group's first row; a mismatch is named by :meth:`_check_series_row` (row by row,
        only then)."""
        columns: dict[str, np.ndarray] = {}
        for name, (shape, dtype) in expected.items():
            try:
                column = np.asarray([row[name] for row in rows])
            except (KeyError, ValueError):  # an entry missing, or of another shape than its others
                break
            if column.shape[1:] != shape or column.dtype.kind not in "biuf" or \
                    not np.can_cast(column.dtype, dtype, casting="same_kind"):
                break
            columns[name] = column
        if len(columns) < len(expected) or any(len(row) != len(expected) for row in rows):
            for row in rows:
                cls._check_series_row(group, expected, {name: np.asarray(value) for name, value in row.items()})
            raise ValueError(f"series {group!r}: rows that do not stack into the first row's shapes {dict(expected)}")
        return columns

    @staticmethod
    def _check_series_row(group: str, expected: Mapping[str, tuple[tuple[int, ...], np.dtype]],
                          row: Mapping[str, np.ndarray]) -> None:
        """Raise ``ValueError`` naming the first entry of `row` that differs from the group's first row."""
        for name in sorted(set(expected) ^ set(row)):
            raise ValueError(f"series {group!r}: entry {name!r} does not match the first row's entries {sorted(expected)}")
        for name, data in row.items():
            shape, dtype = expected[name]
            if data.shape != shape or not np.can_cast(data.dtype, dtype, casting="same_kind"):
                raise ValueError(
                    f"series {group!r}: entry {name!r} has shape {data.shape} dtype {data.dtype}, "
                    f"expected shape {shape} dtype {dtype}"
                )

    @staticmethod
    def _create_series(
        series: h5py.Group, group: str, rows: Mapping[str, np.ndarray]
    ) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
        """Create resizable datasets for a series group from its first row; return shapes/dtypes."""
        for name, data in rows.items():
            if data.ndim > 1 or data.dtype.kind not in "biuf" or not name or "/" in name:
                raise ValueError(
                    f"series {group!r}: entry {name!r} must be a numeric scalar or 1-D vector "
                    f"with a name without '/', got shape {data.shape} dtype {data.dtype}"
                )
        target = series.require_group(group)
        shapes: dict[str, tuple[tuple[int, ...], np.dtype]] = {}
        for name, data in rows.items():
            dtype = np.dtype("f8") if data.dtype.kind == "f" else np.dtype("i8") if data.dtype.kind in "iu" else data.dtype
            target.create_dataset(
                name,
                shape=(0, *data.shape),
                maxshape=(None, *data.shape),
                chunks=(_SERIES_CHUNK_ROWS, *data.shape),
                dtype=dtype,
            )
            shapes[name] = (data.shape, dtype)
        return shapes

    def set_attrs(self, path: str, attrs: Mapping[str, Any]) -> None:
        """Set attributes on the group ``path`` (created if needed), e.g. ``"/results"``, then flush.

        Values may be str, bool, int, float, numeric arrays, or mappings (stored as JSON text).
        """
        file = self._open_file()
        if not path:
            raise ValueError("path must name a group, e.g. '/results'")
        target = file if path == "/" else file.require_group(path)
        converted = {key: _attr_value(key, value) for key, value in attrs.items()}
        for key, value in converted.items():
            target.attrs[key] = value
        file.flush()


@dataclass
class RunData:
    """Everything in a run file, loaded eagerly into numpy arrays (no open h5py handles).

    Attributes
    ----------
    config:
        The run configuration (parsed from the ``config_json`` root attribute).
    attrs:
        The other root attributes (schema version, creation time, units, versions).
    times, steps:
        Frame times (s) and step counts, shape (n_frames,).
    fields:
        Frame fields, ``fields[name]`` shaped (n_frames, N, ...).
    static:
        Static arrays keyed by their path below ``/static`` (e.g. ``"walls/position"``).
    series:
        ``series[group][name]`` arrays, group being the path below ``/series`` (e.g.
        ``"diagnostics"``, ``"bodies/leg"``).
    group_attrs:
        Attributes of every other group that has some, keyed by absolute path (e.g. ``"/results"``).

    Loading is eager: fine for the 2D runs of the dissertation (10⁴ particles × 10² frames is tens
    of MB); for larger runs, open the file with h5py and slice ``/frames/<field>`` directly.
    """

    config: dict[str, Any]
    attrs: dict[str, Any]
    times: np.ndarray
    steps: np.ndarray
    fields: dict[str, np.ndarray] = field(default_factory=dict)
    static: dict[str, np.ndarray] = field(default_factory=dict)
    series: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)
    group_attrs: dict[str, dict[str, Any]] = field(default_factory=dict)

    @property
    def n_frames(self) -> int:
        """Number of complete frames in the file."""
        return int(self.times.shape[0])

    def frame(self, k: int) -> dict[str, np.ndarray]:
        """Fields of frame ``k`` (negative indices count from the end) as ``{name: (N, ...) array}``."""
        if not -self.n_frames <= k < self.n_frames:
            raise IndexError(f"frame index {k} out of range for {self.n_frames} frames")
        return {name: values[k] for name, values in self.fields.items()}


def _datasets_groups(group: h5py.Group) -> list[str]:
    """Relative names of the groups below `group` that hold datasets (series groups)."""
    names: list[str] = []

    def visit(name: str, item: h5py.HLObject) -> None:
        if isinstance(item, h5py.Group) and any(isinstance(child, h5py.Dataset) for child in item.values()):
            names.append(name)

    group.visititems(visit)
    return names


def _datasets_below(group: h5py.Group) -> dict[str, h5py.Dataset]:
    """All datasets below ``group`` keyed by their path relative to it."""
    found: dict[str, h5py.Dataset] = {}

    def visit(name: str, item: h5py.HLObject) -> None:
        if isinstance(item, h5py.Dataset):
            found[name] = item

    group.visititems(visit)
    return found


def _group_attrs(file: h5py.File) -> dict[str, dict[str, Any]]:
    """Attributes of every non-root group that has any, keyed by absolute path."""
    found: dict[str, dict[str, Any]] = {}

    def visit(name: str, item: h5py.HLObject) -> None:
        if isinstance(item, h5py.Group) and len(item.attrs) > 0:
            found["/" + name] = {key: _decode_attr(value) for key, value in item.attrs.items()}

    file.visititems(visit)
    return found


def _read_series(series: h5py.Group) -> dict[str, dict[str, np.ndarray]]:
    """Read ``/series`` as ``{group: {name: array}}``, trimming each group to its complete rows."""
    grouped: dict[str, dict[str, np.ndarray]] = {}
    for path, dataset in _datasets_below(series).items():
        group, _, name = path.rpartition("/")
        grouped.setdefault(group, {})[name] = dataset[()]
    for group, columns in grouped.items():
        rows = min(values.shape[0] for values in columns.values())
        grouped[group] = {name: values[:rows] for name, values in columns.items()}
    return grouped


def defined_values(summary: Mapping[str, Any]) -> dict[str, Any]:
    """`summary` with every value that is not a finite number where a number is expected (NaN,
    ±inf: a quantity the run did not define, say a slip before the robot moved) as None, so it
    prints as valid JSON (``null``)."""
    return {key: None if isinstance(value, (float, np.floating)) and not math.isfinite(value) else value
            for key, value in summary.items()}


def write_results(path: str | os.PathLike[str], summary: Mapping[str, Any],
                  arrays: Mapping[str, np.ndarray] | None = None) -> None:
    """Stores a finished run's results in its file: `summary` as attributes of ``/results`` (a
    value the run did not define, NaN or None, is left out: :func:`defined_values`) and `arrays`
    as datasets under it (replacing any of the same name)."""
    with h5py.File(path, "a") as file:
        group = file.require_group("results")
        for key, value in defined_values(summary).items():
            if value is not None:
                group.attrs[key] = value
        for key, value in (arrays or {}).items():
            if key in group:
                del group[key]
            group.create_dataset(key, data=value)


def read_run(path: str | os.PathLike[str]) -> RunData:
    """Load a run file written by :class:`RunWriter` (eagerly; see :class:`RunData`).

    A file from an interrupted run is read up to its last complete frame: the frame count is the
    shortest length among ``/frames/time``, ``/frames/step`` and the field datasets.
    """
    with h5py.File(path, "r") as file:
        attrs = {key: _decode_attr(value) for key, value in file.attrs.items()}
        if "config_json" not in attrs:
            raise ValueError(f"{path} is not a terrasph run file: root attribute 'config_json' is missing")
        config = json.loads(attrs.pop("config_json"))
        frames = file["frames"]
        n_frames = min(dataset.shape[0] for dataset in frames.values())
        fields = {
            name: dataset[:n_frames] for name, dataset in frames.items() if name not in _RESERVED_FRAME_NAMES
        }
        return RunData(
            config=config,
            attrs=attrs,
            times=frames["time"][:n_frames],
            steps=frames["step"][:n_frames],
            fields=fields,
            static={name: dataset[()] for name, dataset in _datasets_below(file["static"]).items()},
            series=_read_series(file["series"]),
            group_attrs=_group_attrs(file),
        )


#: names of the spatial axes of a run in 2D (plane strain: x, z) and 3D
AXIS_NAMES = {2: ("x", "z"), 3: ("x", "y", "z")}
#: XDMF geometry of positions in 2D and 3D
GEOMETRY_TYPES = {2: "XY", 3: "XYZ"}


def _component_suffixes(shape: tuple[int, ...], dim: int = 2) -> list[tuple[str, tuple[int, ...]]]:
    """Name suffixes and indices of the components of a per-particle value of ``shape`` in a run of
    dimension ``dim``.

    Axes of length ``dim`` are named by the spatial axes (2D: x, z, e.g. velocity_x, stress_xz; 3D:
    x, y, z); other lengths by index.
    """
    axes = [AXIS_NAMES[dim] if n == dim else tuple(str(i) for i in range(n)) for n in shape]
    suffixes: list[tuple[str, tuple[int, ...]]] = []
    for index in np.ndindex(*shape):
        suffixes.append(("_" + "".join(axes[a][i] for a, i in enumerate(index)), index))
    return suffixes


def _number_type(dtype: np.dtype) -> tuple[str, str]:
    """XDMF NumberType and Precision of a numpy dtype."""
    kinds = {"f": "Float", "i": "Int", "u": "UInt"}
    return kinds[dtype.kind], str(dtype.itemsize)


def _hyperslab(
    parent: ET.Element, h5_ref: str, dataset: h5py.Dataset | _Layout, start: tuple[int | str, ...],
    count: tuple[int, ...]
) -> None:
    """Append a HyperSlab DataItem selecting ``count`` entries from ``start`` of an HDF5 dataset."""
    number_type, precision = _number_type(dataset.dtype)
    dims = " ".join(map(str, count))
    slab = ET.SubElement(parent, "DataItem", ItemType="HyperSlab", Dimensions=dims, Type="HyperSlab")
    selection = ET.SubElement(slab, "DataItem", Dimensions=f"3 {len(start)}", Format="XML")
    selection.text = "\n".join(" ".join(map(str, row)) for row in (start, (1,) * len(start), count))
    source = ET.SubElement(
        slab,
        "DataItem",
        Dimensions=" ".join(map(str, dataset.shape)),
        NumberType=number_type,
        Precision=precision,
        Format="HDF",
    )
    source.text = f"{h5_ref}:{dataset.name}"


def write_xdmf(h5_path: str | os.PathLike[str], xdmf_path: str | os.PathLike[str] | None = None, *,
               views_made: int = 0) -> pathlib.Path:
    """Write an XDMF 3 sidecar so ParaView can open the frames of a run file; return its path.

    The sidecar is a Temporal collection with one Spatial collection per frame holding up to three
    Polyvertex grids: ``grains`` (geometry a hyperslab of ``/frames/position``; none on a terrain
    without grains), ``bodies`` (of ``/frames/body_position``, in scenes with bodies, with their
    ``body_index``) and ``walls`` (the
    fixed walls of ``/static/walls/position``, the same at every time). 2D positions are exposed as
    XY, so the simulation's z (up) is ParaView's Y; 3D positions as XYZ. Every other numeric per-particle field of a set
    becomes node-centred scalars: scalar fields as themselves, vector and tensor fields one scalar
    per component (``velocity_x``, ``velocity_z``, ``stress_xx``, …; a body field's ``body_`` prefix
    is dropped). The HDF5 file is referenced by its path relative to the sidecar (default:
    ``h5_path`` with suffix ``.xdmf``), so keep the two files together. The per-set files that
    meshio reads too are written beside it (:func:`write_xdmf_sets`, which says what `views_made` is).
    """
    h5_path = pathlib.Path(h5_path)
    out = pathlib.Path(xdmf_path) if xdmf_path is not None else h5_path.with_suffix(".xdmf")
    h5_ref = os.path.relpath(h5_path.resolve(), out.resolve().parent)
    root = ET.Element("Xdmf", Version="3.0")
    collection = ET.SubElement(
        ET.SubElement(root, "Domain"), "Grid", Name="particles", GridType="Collection", CollectionType="Temporal"
    )
    with h5py.File(h5_path, "r") as file:
        frames = file["frames"]
        sets = []
        for name, geometry, prefix in (("grains", "position", ""), ("bodies", "body_position", "body_")):
            if geometry in frames:
                data = frames[geometry]
                if data.ndim != 3 or data.shape[2] not in GEOMETRY_TYPES:
                    raise ValueError(f"/frames/{geometry} must be shaped (n_frames, N, 2 or 3), got {data.shape}")
                sets.append((name, _layout(data), [(label, _layout(field))
                                                   for label, field in _set_fields(frames, data, prefix=prefix)]))
        if not sets:
            raise ValueError(f"{h5_path} has neither /frames/position nor /frames/body_position; write frames "
                             "with grains or bodies first")
        n_frames = min(dataset.shape[0] for dataset in frames.values())
        static = file.get("static")
        walls = _layout(static["walls/position"]) if static is not None and "walls/position" in static else None
        body_index = _layout(static["bodies/index"]) if static is not None and "bodies/index" in static else None
        times = frames["time"][:n_frames]
        # one frame's XML with stand-ins for its index and time, repeated for every frame (_write_frames_xml)
        step = ET.SubElement(collection, "Grid", Name=f"frame_{_FRAME_INDEX}", GridType="Collection",
                             CollectionType="Spatial")
        ET.SubElement(step, "Time", Value=_FRAME_TIME)
        for name, geometry_data, fields in sets:
            count = geometry_data.shape[1]
            grid = _polyvertex_grid(step, name, count)
            dim = geometry_data.shape[2]
            _hyperslab(ET.SubElement(grid, "Geometry", GeometryType=GEOMETRY_TYPES[dim]), h5_ref, geometry_data,
                       (_FRAME_INDEX, 0, 0), (1, count, dim))
            for label, dataset in fields:
                trailing = dataset.shape[2:]
                for suffix, index in _component_suffixes(trailing, dim) if trailing else [("", ())]:
                    attribute = ET.SubElement(grid, "Attribute", Name=label + suffix, AttributeType="Scalar",
                                              Center="Node")
                    _hyperslab(attribute, h5_ref, dataset, (_FRAME_INDEX, 0, *index), (1, count, *(1 for _ in index)))
            if name == "bodies" and body_index is not None:
                _whole(ET.SubElement(grid, "Attribute", Name="body_index", AttributeType="Scalar",
                                     Center="Node"), h5_ref, body_index)
        if walls is not None and walls.shape[0] > 0:
            grid = _polyvertex_grid(step, "walls", walls.shape[0])
            _whole(ET.SubElement(grid, "Geometry", GeometryType=GEOMETRY_TYPES[walls.shape[1]]), h5_ref, walls)
    _write_frames_xml(root, collection, step, times, out)
    write_xdmf_sets(h5_path, out, views_made=views_made)
    return out


class _Layout(NamedTuple):
    """What an XDMF DataItem says of an HDF5 dataset: its path in its file, shape and dtype. Read
    once per dataset (each of h5py's property reads asks HDF5 again) and used for every frame."""

    name: str
    shape: tuple[int, ...]
    dtype: np.dtype


def _layout(dataset: h5py.Dataset) -> _Layout:
    return _Layout(dataset.name, dataset.shape, dataset.dtype)


#: stand-ins for a frame's index and time in the XML of one frame, repeated for every frame
#: (:func:`_write_frames_xml`); NUL, in no file path and no other text of a sidecar, sets them apart
_FRAME_INDEX, _FRAME_TIME = "\x00k\x00", "\x00t\x00"


def _write_frames_xml(root: ET.Element, collection: ET.Element, template: ET.Element, times: np.ndarray,
                      path: pathlib.Path) -> None:
    """Writes `root` to `path` with `template`, the one child of `collection`, written with the
    stand-ins _FRAME_INDEX and _FRAME_TIME, repeated for every frame of `times` with its index and
    time put in: the text :func:`_write_xml` writes of a tree with one element per frame (byte for
    byte), in a fraction of its time (ElementTree builds, indents and serialises one frame only)."""
    if len(times) == 0:
        collection.remove(template)
        _write_xml(root, path)
        return
    ET.indent(root)
    text = ET.tostring(root, encoding="unicode")
    last = ET.tostring(template, encoding="unicode")  # with its tail, the indent of the collection's end
    head, found, end = text.partition(last)
    assert found, "the frame's template is not in its document"
    element = last[:len(last) - len(template.tail or "")]
    between = collection.text or ""  # what ET.indent puts before each child
    frames = between.join(element.replace(_FRAME_INDEX, str(k)).replace(_FRAME_TIME, repr(float(time)))
                          for k, time in enumerate(times))
    path.write_text('<?xml version="1.0" ?>\n' + head + frames + (template.tail or "") + end + "\n")


def _write_xml(root: ET.Element, path: pathlib.Path) -> None:
    ET.indent(root)
    path.write_text('<?xml version="1.0" ?>\n' + ET.tostring(root, encoding="unicode") + "\n")


def write_xdmf_sets(h5_path: str | os.PathLike[str], xdmf_path: str | os.PathLike[str] | None = None, *,
                    views_made: int = 0) -> list[pathlib.Path]:
    """Write one XDMF 3 file per particle set that both meshio and ParaView read; return their paths.

    meshio's XDMF readers take whole HDF5 datasets only (no hyperslabs), one Uniform grid per time
    step, and the points of the first step for the whole series. So beside `xdmf_path` (default:
    ``h5_path`` with suffix ``.xdmf``), named after its stem:

    * ``<stem>.xdmf.h5`` holds HDF5 virtual datasets, one per frame, set and field component, each
      mapping a slice of the run file's ``/frames/<field>`` (no particle data is copied; the run
      file is referenced by its relative path, so keep the files together), and each set's
      Polyvertex connectivity;
    * ``<stem>.grains.xdmf`` and, in scenes with bodies, ``<stem>.bodies.xdmf``: a Temporal
      collection of Uniform grids, one per frame, each with that frame's positions as geometry
      (ParaView moves the particles) and as the point data ``position_x``, ``position_z`` (meshio's
      ``TimeSeriesReader`` keeps the first frame's points), the fields split into components as in
      :func:`write_xdmf`, and the particles' ``id`` (bodies: also ``body_index``) when the file has them;
    * ``<stem>.walls.xdmf``: the fixed walls of ``/static/walls/position`` as one static grid
      (``meshio.read``) with their ``id`` and ``group`` (wall index).

    `views_made` > 0: the side file already holds the sets' connectivity and the virtual datasets of
    frames 0 … views_made − 1 (made while the run stepped, :class:`terrasph.sidecar_views.SidecarViews`);
    it is completed rather than written anew: the frames the run did not reach are dropped, those
    past them made. The files are the same either way.
    """
    h5_path = pathlib.Path(h5_path)
    base = pathlib.Path(xdmf_path) if xdmf_path is not None else h5_path.with_suffix(".xdmf")
    side = side_file(base)
    run_ref = os.path.relpath(h5_path.resolve(), base.resolve().parent)
    side_ref = os.path.relpath(side.resolve(), base.resolve().parent)
    written = []
    with h5py.File(h5_path, "r") as file, h5py.File(side, "r+" if views_made else "w") as views:
        frames, static = file["frames"], file.get("static", {})
        n_frames = min(dataset.shape[0] for dataset in frames.values())
        times = frames["time"][:n_frames]
        sets = frame_views({name: _layout(dataset) for name, dataset in frames.items()})
        if views_made:
            for name, _, _ in sets:  # frames the run did not reach (an early end)
                for k in range(n_frames, views_made):
                    del views[f"{name}/frame_{k}"]
        else:
            for name, count, _ in sets:
                _connectivity(views, name, count)
        make_frame_views(views, source_reference(h5_path, side), sets, range(views_made, n_frames))
        static_fields = {"grains": {"id": "granular/id"}, "bodies": {"id": "bodies/id", "body_index": "bodies/index"}}
        for name, count, components in sets:
            constant = {label: _layout(static[path]) for label, path in static_fields[name].items()
                        if path in static and static[path].shape[:1] == (count,)}
            root, collection = _xdmf_root(name, temporal=True)
            dim = components[0][1].shape[2]
            # one frame's XML with stand-ins for its index and time, repeated for every frame (_write_frames_xml)
            grid = ET.SubElement(collection, "Grid", Name=f"frame_{_FRAME_INDEX}", GridType="Uniform")
            ET.SubElement(grid, "Time", Value=_FRAME_TIME)
            _polyvertex(grid, count, side_ref, _layout(views[f"{name}/connectivity"]))
            if n_frames:
                for label, dataset, index in components:
                    view = _Layout(_view_name(name, _FRAME_INDEX, label), _view_shape(dataset.shape, index), dataset.dtype)
                    if label == _GEOMETRY:
                        _whole(ET.SubElement(grid, "Geometry", GeometryType=GEOMETRY_TYPES[dim]), side_ref, view)
                    else:
                        _node_attribute(grid, label, side_ref, view)
            for label, dataset in constant.items():
                _node_attribute(grid, label, run_ref, dataset)
            _write_frames_xml(root, collection, grid, times, base.with_suffix(f".{name}.xdmf"))
            written.append(base.with_suffix(f".{name}.xdmf"))
        walls = static.get("walls/position")
        if walls is not None and walls.shape[0] > 0:
            root, grid = _xdmf_root("walls", temporal=False)
            _polyvertex(grid, walls.shape[0], side_ref, _connectivity(views, "walls", walls.shape[0]))
            _whole(ET.SubElement(grid, "Geometry", GeometryType=GEOMETRY_TYPES[walls.shape[1]]), run_ref, walls)
            for label in ("id", "group"):
                if f"walls/{label}" in static and static[f"walls/{label}"].shape[:1] == walls.shape[:1]:
                    _node_attribute(grid, label, run_ref, static[f"walls/{label}"])
            written.append(base.with_suffix(".walls.xdmf"))
            _write_xml(root, written[-1])
    return written


def side_file(xdmf_path: str | os.PathLike[str]) -> pathlib.Path:
    """The HDF5 file of the virtual datasets of the per-set sidecars of `xdmf_path`: ``run.xdmf`` →
    ``run.xdmf.h5`` (:func:`write_xdmf_sets`)."""
    return pathlib.Path(xdmf_path).with_suffix(".xdmf.h5")


def source_reference(h5_path: str | os.PathLike[str], side: str | os.PathLike[str]) -> str:
    """The run file `h5_path` as the side file `side`'s virtual datasets name it: relative to the
    side file's folder, so the files work wherever they are together."""
    return os.path.relpath(pathlib.Path(h5_path).resolve(), pathlib.Path(side).resolve().parent)


#: the label of a set's positions whole, the geometry of each frame's grid (:func:`frame_views`)
_GEOMETRY = "position"
#: a frame's virtual dataset of a set: ``/<set>/frame_<k>/<label>``
_VIEW_NAME = "/{set}/frame_{frame}/{label}"


def _view_name(particle_set: str, frame: int | str, label: str) -> str:
    return _VIEW_NAME.format(set=particle_set, frame=frame, label=label)


def _view_shape(shape: tuple[int, ...], index: tuple[int, ...]) -> tuple[int, ...]:
    """The shape of one frame's view of a frame dataset of `shape` (n_frames, N, …) at component `index`."""
    return (shape[1], *shape[2 + len(index):])


def frame_views(frames: Mapping[str, _Layout]) -> list[tuple[str, int, list[tuple[str, _Layout, tuple[int, ...]]]]]:
    """The per-frame virtual datasets of the per-set sidecars (:func:`write_xdmf_sets`) of a run
    whose ``/frames`` datasets are `frames` (name → layout): for each particle set with frames (grains
    of ``position``, bodies of ``body_position``), its name, particle count and views, each a label,
    the frame dataset it slices and the component index within a particle's value: the positions
    whole (the geometry), then each field's components, positions first."""
    sets = []
    for name, geometry, prefix in (("grains", "position", ""), ("bodies", "body_position", "body_")):
        if geometry not in frames:
            continue
        positions = frames[geometry]
        dim = positions.shape[2]
        fields = [(label, dataset) for label, dataset in _set_fields(frames, positions, prefix)]
        components: list[tuple[str, _Layout, tuple[int, ...]]] = [(_GEOMETRY, positions, ())]
        for label, dataset in [("position", positions), *fields]:
            trailing = dataset.shape[2:]
            components += [(label + suffix, dataset, index)
                           for suffix, index in (_component_suffixes(trailing, dim) if trailing else [("", ())])]
        sets.append((name, positions.shape[1], components))
    return sets


def make_frame_views(views: h5py.File, source_ref: str,
                     sets: list[tuple[str, int, list[tuple[str, _Layout, tuple[int, ...]]]]],
                     frames: range) -> None:
    """The virtual datasets of :func:`frame_views`' `sets` for `frames` in the side file `views`, each
    a slice of the run file `source_ref` (relative to the side file's folder)."""
    virtual_slice = _VirtualSlices(views, source_ref)
    for name, _, components in sets:
        for k in frames:
            for label, dataset, index in components:
                virtual_slice(_view_name(name, k, label), dataset, (k, slice(None), *index))


def _xdmf_root(name: str, temporal: bool) -> tuple[ET.Element, ET.Element]:
    """An XDMF 3 document with one grid named `name` in its domain: a Temporal collection or a
    Uniform grid (meshio reads exactly one grid per domain)."""
    root = ET.Element("Xdmf", Version="3.0")
    domain = ET.SubElement(root, "Domain")
    if temporal:
        return root, ET.SubElement(domain, "Grid", Name=name, GridType="Collection", CollectionType="Temporal")
    return root, ET.SubElement(domain, "Grid", Name=name, GridType="Uniform")


def _connectivity(views: h5py.File, name: str, count: int) -> h5py.Dataset:
    """Polyvertex connectivity 0 … count−1 of a set, stored in the side file (meshio needs it)."""
    return views.create_dataset(f"{name}/connectivity", data=np.arange(count, dtype=np.int64).reshape(count, 1))


def _polyvertex(grid: ET.Element, count: int, side_ref: str, connectivity: h5py.Dataset | _Layout) -> None:
    topology = ET.SubElement(grid, "Topology", TopologyType="Polyvertex", NumberOfElements=str(count),
                             NodesPerElement="1")
    _whole(topology, side_ref, connectivity)


def _node_attribute(grid: ET.Element, name: str, h5_ref: str, dataset: h5py.Dataset | _Layout) -> None:
    attribute = ET.SubElement(grid, "Attribute", Name=name, AttributeType="Scalar", Center="Node")
    _whole(attribute, h5_ref, dataset)


class _VirtualSlices:
    """Makes the side file's virtual datasets, each a slice of a run file's dataset (no copy); HDF5's
    own calls, as h5py's VirtualLayout makes them (a hyperslab of the source mapped onto the whole
    virtual dataset), without its selection objects, and with the link property list, the types and
    the virtual dataspaces made once rather than per dataset: a sidecar has one per frame, set and
    component."""

    def __init__(self, views: h5py.File, source_ref: str) -> None:
        self.views, self.source_ref = views, source_ref.encode()
        self.links = h5py.h5p.create(h5py.h5p.LINK_CREATE)
        self.links.set_create_intermediate_group(True)
        self.types: dict[np.dtype, Any] = {}
        self.spaces: dict[tuple[int, ...], Any] = {}

    def __call__(self, name: str, dataset: _Layout, index: tuple[int | slice, ...]) -> _Layout:
        """A virtual dataset `name` that is ``dataset[index]`` of the run file; `index` holds
        integers and whole slices, its first an integer, the frame. The source's extent is given as
        the frames up to that one, whatever the run file's frame count: the view of a frame is the
        same whenever it is made (before the run has written it, say: :mod:`terrasph.sidecar_views`)."""
        start = tuple(i if isinstance(i, int) else 0 for i in index) + (0,) * (len(dataset.shape) - len(index))
        count = tuple(1 if isinstance(i, int) else n for i, n in zip(index, dataset.shape)) + dataset.shape[len(index):]
        shape = tuple(n for axis, n in enumerate(dataset.shape)
                      if axis >= len(index) or not isinstance(index[axis], int))
        frame = index[0]
        assert isinstance(frame, int), "a view's first index is its frame"
        source = h5py.h5s.create_simple((frame + 1, *dataset.shape[1:]))
        source.select_hyperslab(start, count)
        if shape not in self.spaces:
            self.spaces[shape] = h5py.h5s.create_simple(shape)
            self.spaces[shape].select_all()
        if dataset.dtype not in self.types:
            self.types[dataset.dtype] = h5py.h5t.py_create(dataset.dtype, logical=True)
        virtual = self.spaces[shape]
        creation = h5py.h5p.create(h5py.h5p.DATASET_CREATE)
        creation.set_virtual(virtual, self.source_ref, dataset.name.encode(), source)
        h5py.h5d.create(self.views.id, name.encode(), self.types[dataset.dtype], virtual, dcpl=creation,
                        lcpl=self.links).close()
        return _Layout(f"/{name.lstrip('/')}", shape, dataset.dtype)


def _set_fields(frames: Mapping[str, h5py.Dataset | _Layout], geometry: h5py.Dataset | _Layout,
                prefix: str) -> list[tuple[str, Any]]:
    """(label, dataset) of the numeric per-particle frame fields of one particle set: the fields named
    with `prefix` (grains: no prefix, and not a body field) with as many particles as its geometry."""
    fields = []
    for name, dataset in sorted(frames.items()):
        if name in _RESERVED_FRAME_NAMES or dataset.name == geometry.name or dataset.dtype.kind not in "iuf":
            continue
        if len(dataset.shape) < 2 or dataset.shape[1] != geometry.shape[1]:
            continue
        if prefix and name.startswith(prefix):
            fields.append((name[len(prefix):], dataset))
        elif not prefix and not name.startswith("body_"):
            fields.append((name, dataset))
    return fields


def _polyvertex_grid(parent: ET.Element, name: str, count: int) -> ET.Element:
    """A Uniform grid of `count` unconnected points."""
    grid = ET.SubElement(parent, "Grid", Name=name, GridType="Uniform")
    ET.SubElement(grid, "Topology", TopologyType="Polyvertex", NumberOfElements=str(count), NodesPerElement="1")
    return grid


def _whole(parent: ET.Element, h5_ref: str, dataset: h5py.Dataset | _Layout) -> None:
    """Append a DataItem holding a whole HDF5 dataset."""
    number_type, precision = _number_type(dataset.dtype)
    item = ET.SubElement(parent, "DataItem", Dimensions=" ".join(map(str, dataset.shape)), NumberType=number_type,
                         Precision=precision, Format="HDF")
    item.text = f"{h5_ref}:{dataset.name}"
