"""Checkpoints: the whole State of a simulation in one HDF5 file, written atomically.

A checkpoint holds every registered particle field of both particle sets in the core's storage
order (so the restored run sums in the same order), the counters, the bodies' state and motion,
the wall-removal schedule, the tracked fixed-wall loads, the configuration the state belongs to,
and the run loop's progress.
A restored simulation continues bit for bit like the one that never stopped: nothing is
recomputed on restore, and the neighbour lists are rebuilt at the positions they were built at.

The file is written to ``<path>.tmp`` and renamed over ``path``, so a crash during a write leaves
the previous checkpoint intact. A SHA-256 of the content detects truncation and bit flips.
"""

from __future__ import annotations

import hashlib
import json
import os
import pathlib
from collections.abc import Mapping
from typing import Any

import h5py
import numpy as np

from terrasph.config import ConfigError

__all__ = ["FORMAT", "FORMAT_VERSION", "CheckpointError", "configuration_differences", "read_checkpoint",
           "restore_core", "write_checkpoint"]

FORMAT = "terrasph-checkpoint"
#: Bumped whenever the State's layout changes; a checkpoint of another version is refused.
FORMAT_VERSION = 1
_PARTICLE_SETS = ("granular", "walls")


class CheckpointError(ConfigError):
    """A checkpoint that cannot be used: missing, corrupted, truncated, of another version, or of
    another configuration."""


def _json(value: Any) -> str:
    """Exact JSON text (floats by repr round-trip exactly) of counters, bodies and configuration."""

    def default(item: Any) -> Any:
        if isinstance(item, np.ndarray):
            return item.tolist()
        if isinstance(item, np.generic):
            return item.item()
        raise TypeError(f"cannot store {type(item).__name__} in a checkpoint")

    return json.dumps(value, sort_keys=True, default=default)


def _digest(arrays: Mapping[str, np.ndarray], texts: Mapping[str, str]) -> str:
    """SHA-256 over the arrays (name, dtype, shape, bytes) and texts, in sorted name order."""
    h = hashlib.sha256()
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(f"{name}|{a.dtype.str}|{a.shape}".encode())
        h.update(a.tobytes())
    for name in sorted(texts):
        h.update(f"{name}|".encode())
        h.update(texts[name].encode())
    return h.hexdigest()


def grain_free_state(steps: int) -> dict[str, Any]:
    """The core ``state()`` of a terrain without grains (RFT): no particles, walls, bodies or removals,
    only the step counter, so that its checkpoints share the SPH's format."""
    return {"granular": {}, "walls": {}, "counters": {"steps": int(steps)}, "bodies": [], "removals": [],
            "wall_loads": {"tracked": False}}


def write_checkpoint(path: str | os.PathLike[str], state: Mapping[str, Any], config: Mapping[str, Any],
                     progress: Mapping[str, Any] | None = None) -> pathlib.Path:
    """Writes a core ``state()`` with the configuration it belongs to and the run loop's
    ``progress`` (plain data) to ``path``, atomically; returns the path."""
    from terrasph import __version__

    target = pathlib.Path(path)
    arrays = {f"{part}/{name}": np.asarray(values)
              for part in _PARTICLE_SETS for name, values in state[part].items()}
    texts = {"counters": _json(state["counters"]), "bodies": _json(state["bodies"]),
             "removals": _json(state["removals"]), "wall_loads": _json(state["wall_loads"]),
             "config": _json(config), "progress": _json(progress or {})}
    tmp = target.with_name(target.name + ".tmp")
    with h5py.File(tmp, "w") as file:
        file.attrs["format"] = FORMAT
        file.attrs["format_version"] = FORMAT_VERSION
        file.attrs["terrasph_version"] = __version__
        for name, text in texts.items():
            file.attrs[name] = text
        for name, values in arrays.items():
            file.create_dataset(name, data=values)
        file.attrs["sha256"] = _digest(arrays, texts)
    os.replace(tmp, target)
    return target


def read_checkpoint(path: str | os.PathLike[str]) -> tuple[dict[str, Any], dict[str, Any], dict[str, Any]]:
    """Reads and verifies a checkpoint: returns (state for the core's ``restore``, configuration,
    run-loop progress). Raises :class:`CheckpointError` with the reason for anything unusable."""
    source = pathlib.Path(path)
    if not source.is_file():
        raise CheckpointError(f"checkpoint {source} does not exist")
    try:
        with h5py.File(source, "r") as file:
            if file.attrs.get("format") != FORMAT:
                raise CheckpointError(f"{source} is not a terrasph checkpoint")
            version = int(file.attrs.get("format_version", -1))
            if version != FORMAT_VERSION:
                raise CheckpointError(f"checkpoint {source} has format version {version}; this terrasph reads "
                                      f"version {FORMAT_VERSION} (written by terrasph "
                                      f"{file.attrs.get('terrasph_version', '?')})")
            texts = {name: str(file.attrs[name]) for name in ("counters", "bodies", "removals", "config", "progress")}
            if "wall_loads" in file.attrs:  # absent from checkpoints written before wall loads were kept
                texts["wall_loads"] = str(file.attrs["wall_loads"])
            arrays: dict[str, np.ndarray] = {}
            for part in _PARTICLE_SETS:  # a state without particles (the RFT terrain's) has no groups
                for name, dataset in file.get(part, {}).items():
                    arrays[f"{part}/{name}"] = dataset[()]
            stored = str(file.attrs["sha256"])
    except CheckpointError:
        raise
    except (OSError, KeyError, ValueError) as error:
        raise CheckpointError(f"checkpoint {source} is unreadable (truncated or corrupted): {error}") from error
    if _digest(arrays, texts) != stored:
        raise CheckpointError(f"checkpoint {source} is corrupted: its content does not match its SHA-256")
    state: dict[str, Any] = {part: {} for part in _PARTICLE_SETS}
    for key, values in arrays.items():
        part, name = key.split("/", 1)
        state[part][name] = values
    state["counters"] = json.loads(texts["counters"])
    state["bodies"] = json.loads(texts["bodies"])
    state["removals"] = [tuple(r) for r in json.loads(texts["removals"])]
    state["wall_loads"] = json.loads(texts.get("wall_loads", '{"tracked": false}'))
    return state, json.loads(texts["config"]), json.loads(texts["progress"])


def configuration_differences(saved: Mapping[str, Any], current: Mapping[str, Any], prefix: str = "") -> list[str]:
    """Dotted names of the entries where two configurations differ (for a clear refusal)."""
    differences: list[str] = []
    for key in sorted(set(saved) | set(current)):
        name = f"{prefix}{key}"
        if key not in saved or key not in current:
            differences.append(name)
        elif isinstance(saved[key], Mapping) and isinstance(current[key], Mapping):
            differences.extend(configuration_differences(saved[key], current[key], f"{name}."))
        elif _json(saved[key]) != _json(current[key]):
            differences.append(name)
    return differences


def restore_core(core: Any, path: str | os.PathLike[str], description: Mapping[str, Any]) -> dict[str, Any]:
    """Restores the core State of a simulation described by `description` from the checkpoint at
    `path` and returns the run loop's progress saved with it; CheckpointError naming the entries of
    another configuration, or saying why the State does not fit."""
    state, config, progress = read_checkpoint(path)
    differences = configuration_differences(config, description)
    if differences:
        raise CheckpointError(f"checkpoint {path} belongs to another configuration; it differs in: "
                              f"{', '.join(differences)}")
    try:
        core.restore(state)
    except (ValueError, TypeError, KeyError) as error:
        raise CheckpointError(f"checkpoint {path} does not fit this simulation: {error}") from error
    return progress
