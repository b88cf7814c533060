"""Malformed model files and inputs give clear errors (never a crash); loader fuzzing.

The C++ loader must raise ``LstmFormatError`` (a ValueError) or ValueError for every bad file,
and the engine ValueError for bad inputs; a crash would abort this test process.
"""

from __future__ import annotations

import struct
import zlib

import numpy as np
import pytest
from lstm_helpers import core_lstm, make_net, model_bytes

torch = pytest.importorskip("torch")

from terrasph.surrogate.export import (
    ModelFileError,
    from_torch,
    model_to_bytes,
    read_model_bytes,
)

OFF_VERSION, OFF_HIDDEN0 = 8, 28  # byte offsets in format version 1 (docs/lstm_format.md)


def with_crc(body: bytes) -> bytes:
    """Replace the trailing CRC-32 so a deliberate edit reaches the structural checks."""
    return body[:-4] + struct.pack("<I", zlib.crc32(body[:-4]) & 0xFFFFFFFF)


@pytest.fixture(scope="module")
def good() -> bytes:
    return model_bytes(make_net("peephole", 6, 2, seed=5, normalise=True))


def load_both(data: bytes) -> None:
    """Load with both precisions (must raise for a bad file)."""
    lstm = core_lstm()
    lstm.Model32.from_bytes(data)
    lstm.Model64.from_bytes(data)


def test_good_file_loads(good: bytes) -> None:
    core_lstm().Model64.from_bytes(good)
    assert read_model_bytes(good).cell == "peephole"


@pytest.mark.parametrize("cut", [0, 3, 8, 12, 40, 100, -9, -5, -1])
def test_truncated_file(good: bytes, cut: int) -> None:
    lstm = core_lstm()
    data = good[:cut]
    with pytest.raises(lstm.LstmFormatError, match=r"too short|truncated|magic"):
        load_both(data)
    with pytest.raises(ModelFileError):
        read_model_bytes(data)


def test_truncated_with_valid_crc_names_the_missing_bytes(good: bytes) -> None:
    """Dropping weights but fixing the CRC is caught by the byte budget of the declared sizes."""
    lstm = core_lstm()
    data = with_crc(good[:-44] + b"\0\0\0\0")
    with pytest.raises(lstm.LstmFormatError, match="truncated or sizes corrupted"):
        load_both(data)


def test_corrupted_byte_fails_crc(good: bytes) -> None:
    lstm = core_lstm()
    data = bytearray(good)
    data[len(data) // 2] ^= 0x40
    with pytest.raises(lstm.LstmFormatError, match="CRC-32"):
        load_both(bytes(data))
    with pytest.raises(ModelFileError, match="CRC-32"):
        read_model_bytes(bytes(data))


def test_wrong_magic(good: bytes) -> None:
    lstm = core_lstm()
    with pytest.raises(lstm.LstmFormatError, match="magic"):
        load_both(b"NOTLSTM!" + good[8:])


@pytest.mark.parametrize("version", [0, 2, 7, 2**32 - 1])
def test_wrong_version(good: bytes, version: int) -> None:
    lstm = core_lstm()
    data = with_crc(good[:OFF_VERSION] + struct.pack("<I", version) + good[OFF_VERSION + 4:])
    with pytest.raises(lstm.LstmFormatError, match=f"version {version}.*supports version 1"):
        load_both(data)
    with pytest.raises(ModelFileError, match="version"):
        read_model_bytes(data)


@pytest.mark.parametrize("hidden,match", [(0, "hidden_size.*allowed range"),
                                          (7, "bytes of weights"),
                                          (5, "bytes of weights"),
                                          (70000, "hidden_size.*allowed range")])
def test_wrong_shapes_declared(good: bytes, hidden: int, match: str) -> None:
    """A hidden size that disagrees with the stored weights is rejected before allocation."""
    lstm = core_lstm()
    data = with_crc(good[:OFF_HIDDEN0] + struct.pack("<I", hidden) + good[OFF_HIDDEN0 + 4:])
    with pytest.raises(lstm.LstmFormatError, match=match):
        load_both(data)


def test_non_finite_weight_rejected(good: bytes) -> None:
    lstm = core_lstm()
    data = bytearray(good)
    data[-12:-4] = struct.pack("<d", float("nan"))  # last head bias
    with pytest.raises(lstm.LstmFormatError, match="non-finite value in 'head bias'"):
        load_both(with_crc(bytes(data)))


def test_writer_rejects_wrong_shapes() -> None:
    mf = from_torch(make_net("standard", 4, 1, seed=0), ["a", "b", "c", "d"], ["s", "z"])
    mf.layers[0].weight_hh = mf.layers[0].weight_hh[:, :3]
    with pytest.raises(ValueError, match=r"layer 0 weight_hh must have shape \(16, 4\)"):
        model_to_bytes(mf)
    mf = from_torch(make_net("standard", 4, 1, seed=0), ["a", "b", "c", "d"], ["s", "z"])
    mf.input_scale = np.array([1.0, 0.0, 1.0, 1.0])
    with pytest.raises(ValueError, match="input_scale must be > 0"):
        model_to_bytes(mf)


def test_missing_file_is_a_format_error(tmp_path) -> None:
    lstm = core_lstm()
    with pytest.raises(lstm.LstmFormatError, match="cannot open"):
        lstm.Model64(str(tmp_path / "missing.tslstm"))


@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_bad_inputs(good: bytes, dtype: str) -> None:
    """NaN/inf and wrong shapes raise ValueError naming the problem; the state is untouched."""
    lstm = core_lstm()
    m = (lstm.Model32 if dtype == "float32" else lstm.Model64).from_bytes(good)
    x = np.zeros((5, 4), dtype=dtype)
    x[3, 2] = np.nan
    with pytest.raises(ValueError, match=r"time step 3, feature 2 \('soil_k'\)"):
        m.predict(x)
    with pytest.raises(ValueError, match="input_size = 4"):
        m.predict(np.zeros((5, 3), dtype=dtype))
    with pytest.raises(ValueError, match="input_size = 4"):
        m.predict(np.zeros(4, dtype=dtype))
    s = m.stream()
    y0 = s.step(np.ones(4, dtype=dtype))
    s.reset()
    with pytest.raises(ValueError, match="non-finite"):
        s.step(np.array([1.0, np.inf, 0.0, 0.0], dtype=dtype))
    with pytest.raises(ValueError, match=r"shape \(input_size,\)"):
        s.step(np.ones(5, dtype=dtype))
    np.testing.assert_array_equal(s.step(np.ones(4, dtype=dtype)), y0)  # state unchanged
    with pytest.raises(ValueError, match="batch must be in"):
        m.stream(batch=0)
    with pytest.raises(ValueError, match="out must hold"):
        s.step_into(np.ones(4, dtype=dtype), np.empty(3, dtype=dtype))


def _mutate(rng: np.random.Generator, data: bytes) -> bytes:
    b = bytearray(data)
    kind = rng.integers(5)
    n = int(rng.integers(1, 9))
    if kind == 0:  # flip random bits
        for _ in range(n):
            i = int(rng.integers(len(b)))
            b[i] ^= 1 << int(rng.integers(8))
    elif kind == 1:  # overwrite random bytes
        for _ in range(n):
            b[int(rng.integers(len(b)))] = int(rng.integers(256))
    elif kind == 2:  # truncate
        del b[int(rng.integers(len(b))):]
    elif kind == 3:  # delete a slice
        i = int(rng.integers(len(b)))
        del b[i:i + n]
    else:  # insert random bytes
        i = int(rng.integers(len(b) + 1))
        b[i:i] = rng.integers(0, 256, n, dtype=np.uint8).tobytes()
    return bytes(b)


@pytest.mark.parametrize("fix_crc", [False, True])
def test_fuzz_loader(good: bytes, fix_crc: bool) -> None:
    """400 seeded random mutations per mode (bit flips, overwrites, truncation, deletion,
    insertion). Header mutations are concentrated on by mutating the first 64 bytes in half of
    the cases. With fix_crc the CRC is recomputed, so the structural checks are exercised.
    Every case must load (then predict finitely) or raise LstmFormatError / ValueError."""
    lstm = core_lstm()
    rng = np.random.default_rng(1234 + int(fix_crc))
    x = np.zeros((3, 4))
    outcomes = {"loaded": 0, "rejected": 0}
    for case in range(400):
        if case % 2:
            data = _mutate(rng, good[:64]) + good[64:]
        else:
            data = _mutate(rng, good)
        if fix_crc and len(data) >= 4:
            data = with_crc(data)
        try:
            m = lstm.Model64.from_bytes(data)
        except ValueError as exc:  # LstmFormatError is a ValueError
            assert str(exc), "error message must not be empty"
            outcomes["rejected"] += 1
            with pytest.raises(ModelFileError):
                read_model_bytes(data)
            continue
        outcomes["loaded"] += 1
        assert np.isfinite(m.predict(x)).all()
    assert outcomes["rejected"] > 0
    if not fix_crc:
        assert outcomes["loaded"] == 0, "CRC-32 must catch every mutation"
