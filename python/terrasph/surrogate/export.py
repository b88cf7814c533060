"""Write and read the terrasph LSTM model file (format version 1, see docs/lstm_format.md).

The file is little-endian binary: a header with magic, version, cell type and sizes, the feature
and target names, a JSON metadata text, the normalisation, the per-layer weights in float64 and
PyTorch's gate order (i, f, g, o) with the two biases summed, the dense head, and a CRC-32 of all
preceding bytes. The C++ reader is ``cpp/lstm/include/terrasph/lstm_format.hpp``.
"""

from __future__ import annotations

import json
import struct
import zlib
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

MAGIC = b"TSPHLSTM"
FORMAT_VERSION = 1
FILE_SUFFIX = ".tslstm"
CELL_CODES = {"standard": 0, "peephole": 1}
MAX_SIZE = 1 << 16
MAX_LAYERS = 64


class ModelFileError(ValueError):
    """Raised by :func:`read_model_bytes` for a malformed or unsupported model file."""


@dataclass
class LayerWeights:
    """Weights of one recurrent layer (float64, PyTorch layout and gate order i, f, g, o).

    ``bias`` is ``bias_ih + bias_hh``. The peephole matrices are ``None`` for the standard cell.
    """

    weight_ih: np.ndarray
    weight_hh: np.ndarray
    bias: np.ndarray
    weight_ci: np.ndarray | None = None
    weight_cf: np.ndarray | None = None
    weight_co: np.ndarray | None = None

    @property
    def hidden_size(self) -> int:
        """Number of hidden units H."""
        return int(self.weight_hh.shape[0]) // 4

    @property
    def input_size(self) -> int:
        """Number of inputs of this layer."""
        return int(self.weight_ih.shape[1])


@dataclass
class ModelFile:
    """Everything a model file holds."""

    cell: str
    feature_names: list[str]
    target_names: list[str]
    input_mean: np.ndarray
    input_scale: np.ndarray
    output_mean: np.ndarray
    output_scale: np.ndarray
    layers: list[LayerWeights]
    head_weight: np.ndarray
    head_bias: np.ndarray
    metadata: dict[str, Any] = field(default_factory=dict)
    version: int = FORMAT_VERSION

    @property
    def input_size(self) -> int:
        """Number of input features."""
        return len(self.feature_names)

    @property
    def output_size(self) -> int:
        """Number of targets."""
        return len(self.target_names)


def _f64(a: Any, shape: tuple[int, ...], name: str) -> np.ndarray:
    arr = np.asarray(a, dtype=np.float64)
    if arr.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {arr.shape}")
    if not np.isfinite(arr).all():
        raise ValueError(f"{name} must be finite")
    return np.ascontiguousarray(arr)


def model_to_bytes(m: ModelFile) -> bytes:
    """Serialise a :class:`ModelFile`; validates every shape against the declared sizes."""
    if m.cell not in CELL_CODES:
        raise ValueError(f"cell must be one of {tuple(CELL_CODES)}, got {m.cell!r}")
    ni, no, nl = m.input_size, m.output_size, len(m.layers)
    if not 1 <= ni <= MAX_SIZE or not 1 <= no <= MAX_SIZE:
        raise ValueError(f"input and output sizes must be in [1, {MAX_SIZE}], got {ni}, {no}")
    if not 1 <= nl <= MAX_LAYERS:
        raise ValueError(f"number of layers must be in [1, {MAX_LAYERS}], got {nl}")
    out = bytearray(MAGIC)
    out += struct.pack("<IIIII", FORMAT_VERSION, CELL_CODES[m.cell], ni, no, nl)
    for layer in m.layers:
        out += struct.pack("<I", layer.hidden_size)
    for name in list(m.feature_names) + list(m.target_names):
        raw = name.encode("utf-8")
        if len(raw) > 4096:
            raise ValueError(f"feature/target name longer than 4096 bytes: {name[:40]!r}...")
        out += struct.pack("<I", len(raw)) + raw
    meta = json.dumps(m.metadata, sort_keys=True).encode("utf-8")
    out += struct.pack("<I", len(meta)) + meta
    for name, arr, n in (
        ("input_mean", m.input_mean, ni),
        ("input_scale", m.input_scale, ni),
        ("output_mean", m.output_mean, no),
        ("output_scale", m.output_scale, no),
    ):
        a = _f64(arr, (n,), name)
        if name.endswith("scale") and not (a > 0).all():
            raise ValueError(f"{name} must be > 0")
        out += a.astype("<f8").tobytes()
    n_in = ni
    for k, layer in enumerate(m.layers):
        h = layer.hidden_size
        out += _f64(layer.weight_ih, (4 * h, n_in), f"layer {k} weight_ih").astype("<f8").tobytes()
        out += _f64(layer.weight_hh, (4 * h, h), f"layer {k} weight_hh").astype("<f8").tobytes()
        out += _f64(layer.bias, (4 * h,), f"layer {k} bias").astype("<f8").tobytes()
        if m.cell == "peephole":
            for pname in ("weight_ci", "weight_cf", "weight_co"):
                arr = getattr(layer, pname)
                if arr is None:
                    raise ValueError(f"layer {k} {pname} missing for the peephole cell")
                out += _f64(arr, (h, h), f"layer {k} {pname}").astype("<f8").tobytes()
        n_in = h
    out += _f64(m.head_weight, (no, n_in), "head_weight").astype("<f8").tobytes()
    out += _f64(m.head_bias, (no,), "head_bias").astype("<f8").tobytes()
    out += struct.pack("<I", zlib.crc32(bytes(out)) & 0xFFFFFFFF)
    return bytes(out)


class _Cursor:
    """Bounds-checked reader over bytes."""

    def __init__(self, data: bytes, end: int) -> None:
        self.data, self.pos, self.end = data, 0, end

    def take(self, n: int, what: str) -> bytes:
        if n < 0 or self.pos + n > self.end:
            raise ModelFileError(f"model file truncated: field {what!r} at offset {self.pos}")
        b = self.data[self.pos : self.pos + n]
        self.pos += n
        return b

    def u32(self, what: str, lo: int = 0, hi: int = 0xFFFFFFFF) -> int:
        (v,) = struct.unpack("<I", self.take(4, what))
        if not lo <= v <= hi:
            raise ModelFileError(f"model file: {what} = {v} outside the allowed range [{lo}, {hi}]")
        return int(v)

    def f64(self, shape: tuple[int, ...], what: str) -> np.ndarray:
        n = int(np.prod(shape))
        a = np.frombuffer(self.take(8 * n, what), dtype="<f8").astype(np.float64).reshape(shape)
        if not np.isfinite(a).all():
            raise ModelFileError(f"model file: non-finite value in {what}")
        return a


def read_model_bytes(data: bytes) -> ModelFile:
    """Parse a model file held in memory; raises :class:`ModelFileError` if malformed."""
    if len(data) < 16 or data[:8] != MAGIC:
        raise ModelFileError("not a terrasph LSTM model file (magic bytes 'TSPHLSTM' missing)")
    cur = _Cursor(data, len(data) - 4)
    cur.take(8, "magic")
    version = cur.u32("version")
    if version != FORMAT_VERSION:
        raise ModelFileError(
            f"model file has format version {version}; this reader supports {FORMAT_VERSION}"
        )
    (crc,) = struct.unpack("<I", data[-4:])
    if zlib.crc32(data[:-4]) & 0xFFFFFFFF != crc:
        raise ModelFileError("model file corrupted or truncated: CRC-32 mismatch")
    cell = {v: k for k, v in CELL_CODES.items()}[cur.u32("cell_type", 0, 1)]
    ni = cur.u32("input_size", 1, MAX_SIZE)
    no = cur.u32("output_size", 1, MAX_SIZE)
    nl = cur.u32("num_layers", 1, MAX_LAYERS)
    hidden = [cur.u32("hidden_size", 1, MAX_SIZE) for _ in range(nl)]

    def string(what: str, limit: int) -> str:
        n = cur.u32(what, 0, limit)
        try:
            return cur.take(n, what).decode("utf-8")
        except UnicodeDecodeError as exc:
            raise ModelFileError(f"model file: {what} is not valid UTF-8") from exc

    features = [string("feature_name", 4096) for _ in range(ni)]
    targets = [string("target_name", 4096) for _ in range(no)]
    meta_text = string("metadata", 1 << 24)
    try:
        metadata = json.loads(meta_text) if meta_text else {}
    except json.JSONDecodeError as exc:
        raise ModelFileError("model file: metadata is not valid JSON") from exc
    in_mean = cur.f64((ni,), "input_mean")
    in_scale = cur.f64((ni,), "input_scale")
    out_mean = cur.f64((no,), "output_mean")
    out_scale = cur.f64((no,), "output_scale")
    if not ((in_scale > 0).all() and (out_scale > 0).all()):
        raise ModelFileError("model file: normalisation scales must be > 0")
    layers = []
    n_in = ni
    for k, h in enumerate(hidden):
        lw = LayerWeights(
            weight_ih=cur.f64((4 * h, n_in), f"layer {k} weight_ih"),
            weight_hh=cur.f64((4 * h, h), f"layer {k} weight_hh"),
            bias=cur.f64((4 * h,), f"layer {k} bias"),
        )
        if cell == "peephole":
            lw.weight_ci = cur.f64((h, h), f"layer {k} weight_ci")
            lw.weight_cf = cur.f64((h, h), f"layer {k} weight_cf")
            lw.weight_co = cur.f64((h, h), f"layer {k} weight_co")
        layers.append(lw)
        n_in = h
    head_w = cur.f64((no, n_in), "head_weight")
    head_b = cur.f64((no,), "head_bias")
    if cur.pos != cur.end:
        raise ModelFileError(f"model file: {cur.end - cur.pos} unexpected bytes before the CRC")
    return ModelFile(
        cell=cell,
        feature_names=features,
        target_names=targets,
        input_mean=in_mean,
        input_scale=in_scale,
        output_mean=out_mean,
        output_scale=out_scale,
        layers=layers,
        head_weight=head_w,
        head_bias=head_b,
        metadata=metadata,
        version=version,
    )


def read_model_file(path: str | Path) -> ModelFile:
    """Read a model file from disk; raises :class:`ModelFileError` if malformed."""
    return read_model_bytes(Path(path).read_bytes())


def from_torch(
    net: Any,
    feature_names: Sequence[str],
    target_names: Sequence[str],
    metadata: dict[str, Any] | None = None,
) -> ModelFile:
    """Collect the weights of a :class:`~terrasph.surrogate.model.SurrogateNet` (float64)."""
    import torch

    from terrasph.surrogate.model import layer_parameters

    cfg = net.config
    if len(feature_names) != cfg.input_size:
        raise ValueError(
            f"feature_names has {len(feature_names)} entries, the model takes {cfg.input_size}"
        )
    if len(target_names) != cfg.output_size:
        raise ValueError(
            f"target_names has {len(target_names)} entries, the model gives {cfg.output_size}"
        )

    def np64(t: Any) -> np.ndarray:
        return t.detach().cpu().to(dtype=torch.float64).numpy().copy()

    layers = []
    for p in layer_parameters(net):
        lw = LayerWeights(
            weight_ih=np64(p["weight_ih"]),
            weight_hh=np64(p["weight_hh"]),
            bias=np64(p["bias_ih"]) + np64(p["bias_hh"]),
        )
        if cfg.cell == "peephole":
            lw.weight_ci = np64(p["weight_ci"])
            lw.weight_cf = np64(p["weight_cf"])
            lw.weight_co = np64(p["weight_co"])
        layers.append(lw)
    return ModelFile(
        cell=cfg.cell,
        feature_names=list(feature_names),
        target_names=list(target_names),
        input_mean=np64(net.input_mean),
        input_scale=np64(net.input_scale),
        output_mean=np64(net.output_mean),
        output_scale=np64(net.output_scale),
        layers=layers,
        head_weight=np64(net.head.weight),
        head_bias=np64(net.head.bias),
        metadata=dict(metadata or {}),
    )


def export_model(
    net: Any,
    path: str | Path,
    feature_names: Sequence[str],
    target_names: Sequence[str],
    metadata: dict[str, Any] | None = None,
) -> Path:
    """Write a trained :class:`SurrogateNet` to ``path`` (format version 1); returns the path."""
    path = Path(path)
    path.write_bytes(model_to_bytes(from_torch(net, feature_names, target_names, metadata)))
    return path


def to_torch(m: ModelFile) -> Any:
    """Rebuild a :class:`SurrogateNet` (float64) from a :class:`ModelFile`.

    The summed bias is put in ``bias_ih`` and ``bias_hh`` is zero. All layers must share one
    hidden size (as the PyTorch modules require).
    """
    import torch

    from terrasph.surrogate.model import ModelConfig, PeepholeLSTM, SurrogateNet

    sizes = {lw.hidden_size for lw in m.layers}
    if len(sizes) != 1:
        raise ValueError(f"to_torch needs one hidden size for all layers, got {sorted(sizes)}")
    cfg = ModelConfig(m.cell, m.input_size, sizes.pop(), len(m.layers), m.output_size)
    net = SurrogateNet(cfg).double()
    with torch.no_grad():
        for k, lw in enumerate(m.layers):
            if isinstance(net.rnn, PeepholeLSTM):
                cell = net.rnn.cells[k]
                params = {n: getattr(cell, n) for n in ("weight_ih", "weight_hh", "bias_ih",
                                                         "bias_hh", "weight_ci", "weight_cf",
                                                         "weight_co")}
            else:
                params = {n: getattr(net.rnn, f"{n}_l{k}") for n in ("weight_ih", "weight_hh",
                                                                     "bias_ih", "bias_hh")}
            params["weight_ih"].copy_(torch.from_numpy(lw.weight_ih))
            params["weight_hh"].copy_(torch.from_numpy(lw.weight_hh))
            params["bias_ih"].copy_(torch.from_numpy(lw.bias))
            params["bias_hh"].zero_()
            if m.cell == "peephole":
                for n in ("weight_ci", "weight_cf", "weight_co"):
                    params[n].copy_(torch.from_numpy(getattr(lw, n)))
        net.head.weight.copy_(torch.from_numpy(m.head_weight))
        net.head.bias.copy_(torch.from_numpy(m.head_bias))
    net.set_normalisation(m.input_mean, m.input_scale, m.output_mean, m.output_scale)
    return net
