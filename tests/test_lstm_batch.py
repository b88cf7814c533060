"""The batched C++ path (terrasph::lstm::Batch): B sequences advanced together, one
matrix-matrix product per weight matrix and step.

Bound: bit-for-bit equality with the sequences predicted one by one. Not a float tolerance,
because the summation order does not change: the one-sequence kernel and the batched tile both
compute every product element as y0 + w_0 z_0 + ... + w_{K-1} z_{K-1} in column order with one
multiply-add per term, and the gate nonlinearities apply the same vector instructions to every
element wherever it sits (cpp/lstm/include/terrasph/lstm_kernels.hpp). Batch sizes around the
tile width (6 sequences), hidden sizes that are not multiples of the vector width (slices of 1-4
vectors of rows with AVX-512, e.g. the 40-row W_co at hidden 40 takes 3) and more outputs than one
vector holds reach every edge of the tiles.
"""

from __future__ import annotations

import numpy as np
import pytest
from lstm_helpers import core_lstm, inputs, make_net, model_bytes, torch_predict

torch = pytest.importorskip("torch")

# (cell, layers, hidden, n_out)
MODELS = [
    ("standard", 1, 3, 2),
    ("standard", 2, 16, 11),
    ("standard", 1, 32, 2),  # 16 and 32: the single sequence's step compiled for that size
    ("standard", 1, 37, 2),
    ("standard", 1, 70, 3),
    ("peephole", 1, 5, 2),
    ("peephole", 2, 13, 9),
    ("peephole", 1, 40, 2),
]


def _model(cls, cell: str, layers: int, hidden: int, n_out: int, seed: int):
    net = make_net(cell, hidden, layers, seed, n_out=n_out, normalise=True)
    return cls.from_bytes(model_bytes(net, n_out=n_out))


@pytest.mark.parametrize("dtype", ["float32", "float64"])
@pytest.mark.parametrize("cell,layers,hidden,n_out", MODELS)
def test_batch_equals_one_by_one_bitwise(cell: str, layers: int, hidden: int, n_out: int,
                                         dtype: str) -> None:
    """predict on (B, T, I) == predict on each (T, I) alone, exactly, for B from 2 to 13."""
    lstm = core_lstm()
    cls = lstm.Model32 if dtype == "float32" else lstm.Model64
    model = _model(cls, cell, layers, hidden, n_out, seed=hidden)
    x = inputs(hidden, 13, 25).astype(dtype)
    singles = np.stack([model.predict(x[b]) for b in range(13)])
    for batch in (2, 5, 6, 7, 12, 13):
        np.testing.assert_array_equal(model.predict(x[:batch]), singles[:batch])


@pytest.mark.parametrize("dtype", ["float32", "float64"])
@pytest.mark.parametrize("cell", ["standard", "peephole"])
def test_batched_streaming_equals_single_streams_bitwise(cell: str, dtype: str) -> None:
    """A Stream of batch 7 stepped T times == 7 Streams of batch 1, exactly, with the state
    (h and c of every layer) equal too; a sequence's results do not depend on its neighbours
    (reversing the batch reverses the outputs exactly)."""
    lstm = core_lstm()
    cls = lstm.Model32 if dtype == "float32" else lstm.Model64
    model = _model(cls, cell, 2, 19, 2, seed=5)
    x = inputs(5, 7, 40).astype(dtype)
    batch, reverse = model.stream(batch=7), model.stream(batch=7)
    singles = [model.stream() for _ in range(7)]
    for t in range(x.shape[1]):
        xt = np.ascontiguousarray(x[:, t])
        y = batch.step(xt)
        np.testing.assert_array_equal(reverse.step(np.ascontiguousarray(xt[::-1])), y[::-1])
        for b, s in enumerate(singles):
            np.testing.assert_array_equal(s.step(xt[b]), y[b])
    for layer in range(2):
        np.testing.assert_array_equal(batch.hidden(layer),
                                      np.concatenate([s.hidden(layer) for s in singles]))
        np.testing.assert_array_equal(batch.cell(layer),
                                      np.concatenate([s.cell(layer) for s in singles]))


def test_batch_larger_than_one_chunk() -> None:
    """predict advances at most 256 sequences together; 300 sequences (a full chunk and a
    partial one) equal the one-by-one results exactly."""
    lstm = core_lstm()
    model = _model(lstm.Model32, "standard", 1, 6, 2, seed=2)
    x = inputs(2, 300, 8).astype(np.float32)
    got = model.predict(x)
    for b in (0, 255, 256, 299):
        np.testing.assert_array_equal(got[b], model.predict(x[b]))


@pytest.mark.parametrize("dtype", ["float32", "float64"])
@pytest.mark.parametrize("cell", ["standard", "peephole"])
def test_batch_64_parity_with_pytorch(cell: str, dtype: str) -> None:
    """Batch 64 (the benchmark's size) against PyTorch on the same weights: max |delta| <=
    1e-5 (float32) and <= 1e-10 (float64), the bounds of tests/test_lstm_parity.py."""
    lstm = core_lstm()
    old = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        tdtype = torch.float32 if dtype == "float32" else torch.float64
        net = make_net(cell, 48, 2, seed=64, dtype=tdtype, normalise=True)
        x = inputs(64, 64, 60).astype(dtype)
        ref = torch_predict(net, x)
        cls = lstm.Model32 if dtype == "float32" else lstm.Model64
        got = cls.from_bytes(model_bytes(net)).predict(x)
    finally:
        torch.set_num_threads(old)
    assert np.max(np.abs(got - ref)) <= (1e-5 if dtype == "float32" else 1e-10)


def test_bad_batch_shapes_name_the_argument() -> None:
    """Wrong batch shapes raise ValueError naming the argument and the expected shape, before
    any state changes."""
    from terrasph.surrogate.inference import predict_sequences

    lstm = core_lstm()
    model = _model(lstm.Model64, "standard", 1, 8, 2, seed=1)
    with pytest.raises(ValueError, match=r"x must have shape .*input_size = 4, got \(3, 10, 5\)"):
        model.predict(np.zeros((3, 10, 5)))
    with pytest.raises(ValueError, match=r"x must have shape .*got \(2, 3, 10, 4\)"):
        model.predict(np.zeros((2, 3, 10, 4)))
    with pytest.raises(ValueError, match=r"batch must be in \[1, 1048576\], got 0"):
        model.stream(batch=0)
    s = model.stream(batch=3)
    with pytest.raises(ValueError, match=r"x must have shape .*\(batch, input_size\) = \(3, 4\), "
                                         r"got \(2, 4\)"):
        s.step(np.zeros((2, 4)))
    assert not np.any(s.hidden(0)) and not np.any(s.cell(0))
    with pytest.raises(ValueError, match=r"out must hold batch\*output_size = 6"):
        s.step_into(np.zeros((3, 4)), np.zeros(4))
    with pytest.raises(ValueError, match=r"sequence 'b': x must have shape \(T, 4\), got \(5, 3\)"):
        predict_sequences(model, [("a", np.zeros((5, 4))), ("b", np.zeros((5, 3)))])


def test_predict_sequences_batches_equal_lengths_and_keeps_order() -> None:
    """predict_sequences (the CLI's path) returns the names in input order with each sequence's
    own prediction, whether its length is shared (batched) or not."""
    from terrasph.surrogate.inference import predict_sequences

    lstm = core_lstm()
    model = _model(lstm.Model64, "peephole", 1, 8, 2, seed=4)
    x = inputs(4, 5, 30)
    seqs = [("a", x[0]), ("b", x[1, :12]), ("c", x[2]), ("d", x[3, :12]), ("e", x[4, :7])]
    got = predict_sequences(model, seqs)
    assert [name for name, _ in got] == ["a", "b", "c", "d", "e"]
    for (_, xs), (_, y) in zip(seqs, got):
        np.testing.assert_array_equal(y, model.predict(xs))


_VARIANT_SCRIPT = """
import json, sys
import numpy as np
sys.path.insert(0, sys.argv[1])
from lstm_helpers import inputs, make_net, model_bytes, torch_predict
from terrasph._core import lstm

report = []
for cell, layers, hidden in (("standard", 1, 16), ("standard", 1, 37), ("peephole", 2, 13), ("standard", 1, 70)):
    net = make_net(cell, hidden, layers, seed=hidden, normalise=True)
    for cls, dtype in ((lstm.Model32, "float32"), (lstm.Model64, "float64")):
        if dtype == "float64":
            net = net.double()
        model = cls.from_bytes(model_bytes(net))
        x = inputs(hidden, 13, 30).astype(dtype)
        batch = model.predict(x)
        singles = np.stack([model.predict(xb) for xb in x])
        report.append({"case": f"{cell}-{layers}x{hidden}-{dtype}", "isa": model.kernel_isa,
                       "bitwise": bool(np.array_equal(batch, singles)),
                       "err": float(np.max(np.abs(batch - torch_predict(net, x))))})
    net.float()
print(json.dumps(report))
"""


@pytest.mark.parametrize("cap", ["generic", "avx2", "avx512"])
def test_every_kernel_variant_batches_bitwise_within_parity(cap: str) -> None:
    """Each run-time kernel variant this CPU can run (the other tests run the widest; the
    environment variable TERRASPH_LSTM_ISA caps the choice): a batch of 13 equals its sequences
    one by one bit for bit, and matches PyTorch within the parity bounds (1e-5 float32, 1e-10
    float64), in a fresh process per variant."""
    import json
    import os
    import subprocess
    import sys
    from pathlib import Path

    lstm = core_lstm()
    widest = lstm.Model32.from_bytes(model_bytes(make_net("standard", 4, 1, 0))).kernel_isa
    if cap != "generic" and widest in ("generic", "avx2") and (cap, widest) != ("avx2", "avx2"):
        pytest.skip(f"this build or CPU runs at most the {widest!r} kernels")
    env = dict(os.environ, TERRASPH_LSTM_ISA=cap, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    tests = str(Path(__file__).resolve().parent)
    result = subprocess.run([sys.executable, "-c", _VARIANT_SCRIPT, tests], capture_output=True, text=True,
                            timeout=300, env=env)
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    # a capped choice runs that variant; a build without run-time choice runs its own ("generic")
    assert {r["isa"] for r in report} == ({"generic"} if widest == "generic" else {cap})
    for r in report:
        assert r["bitwise"], r
        assert r["err"] <= (1e-5 if r["case"].endswith("float32") else 1e-10), r
