"""Surrogates shipped with the package, by name: ``terrasph/surrogate/models/NAME.tslstm``.

    model = pretrained("leg-wheel-ch4")          # the C++ engine with its metadata and validity
    y = model.engine.predict(x)                   # x (T, I) or (B, T, I) in model.feature_names' order
    path = pretrained_path("leg-wheel-ch4")       # the file itself, for C++ (terrasph::lstm::Model::load)

The files are written by ``benchmarks/studies/surrogate_study.py --ship NAME`` (docs/surrogate.md).
Every function takes the directory to look in (`models_dir`, default the package's own).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from terrasph.config import ConfigError
from terrasph.surrogate.export import FILE_SUFFIX
from terrasph.surrogate.inference import load_model
from terrasph.surrogate.validity import Validity

__all__ = ["MODELS_DIR", "Pretrained", "available", "open_model", "pretrained", "pretrained_path", "resolve_model"]

#: the package's directory of shipped models
MODELS_DIR = Path(__file__).resolve().parent / "models"


@dataclass(frozen=True)
class Pretrained:
    """A model file loaded into the C++ engine.

    Attributes:
        name: the file's stem (the name it is found by).
        path: the model file.
        engine: ``terrasph._core.lstm.Model64`` or ``Model32`` (``predict``, ``stream``).
        metadata: the file's metadata (training configuration, report, splits, validity).
    """

    name: str
    path: Path
    engine: Any
    metadata: dict[str, Any]

    @property
    def feature_names(self) -> list[str]:
        """The input columns, in order."""
        return list(self.engine.feature_names)

    @property
    def target_names(self) -> list[str]:
        """The predicted columns, in order."""
        return list(self.engine.target_names)

    @property
    def validity(self) -> Validity | None:
        """What the training runs covered (terrasph.surrogate.validity), None if the file has no record of it."""
        return Validity.from_metadata(self.metadata)


def available(models_dir: str | Path | None = None) -> list[str]:
    """Names of the models in `models_dir` (default: the package's), sorted."""
    directory = Path(models_dir) if models_dir is not None else MODELS_DIR
    return sorted(p.stem for p in directory.glob(f"*{FILE_SUFFIX}")) if directory.is_dir() else []


def pretrained_path(name: str, models_dir: str | Path | None = None) -> Path:
    """The file of the model `name`; ConfigError listing the names there are for an unknown one."""
    names = available(models_dir)
    if name not in names:
        listed = ", ".join(names) if names else "none"
        raise ConfigError(f"unknown model {name!r}: the models there are: {listed}")
    return (Path(models_dir) if models_dir is not None else MODELS_DIR) / f"{name}{FILE_SUFFIX}"


def open_model(path: str | Path, dtype: str = "float64") -> Pretrained:
    """The model file `path` in the C++ engine (`dtype` "float64" or "float32") with its metadata."""
    engine = load_model(path, dtype)
    return Pretrained(name=Path(path).stem, path=Path(path), engine=engine, metadata=json.loads(engine.metadata or "{}"))


def pretrained(name: str, dtype: str = "float64", models_dir: str | Path | None = None) -> Pretrained:
    """The shipped model `name` (:func:`available` lists them) in the C++ engine, with its metadata."""
    return open_model(pretrained_path(name, models_dir), dtype)


def resolve_model(name_or_path: str | Path, models_dir: str | Path | None = None) -> Path:
    """A model given as a file (an existing path, or anything ending in .tslstm or holding a
    directory) or as the name of a shipped model."""
    text = str(name_or_path)
    if Path(text).exists() or text.endswith(FILE_SUFFIX) or "/" in text or "\\" in text:
        return Path(text)
    return pretrained_path(text, models_dir)
