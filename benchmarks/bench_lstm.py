"""Benchmark of LSTM inference: C++ engine (terrasph._core.lstm) versus PyTorch eager.

Same weights for both (a seeded SurrogateNet exported to the model file), float32, standard
cell, hidden 16/32/64/128, batch 1 and 64, in one run. Reports

* streaming latency per step: C++ timed inside C++ (what robot code pays), C++ called from
  Python once per step (``Stream.step_into``), and PyTorch eager (``nn.LSTM`` on one step with
  the carried state + head + normalisation, under ``torch.no_grad``);
* whole-sequence throughput in time steps per second (batch × T / wall time): C++
  ``Model.predict`` versus the PyTorch forward pass.

Each figure is the best of ``--repeats`` timings. Usage::

    python benchmarks/bench_lstm.py [--steps 2000] [--seq-len 1000] [--repeats 5]
                                    [--torch-threads 1]
"""

from __future__ import annotations

import argparse
import platform
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import torch
from terrasph import _core
from terrasph.surrogate.export import from_torch, model_to_bytes
from terrasph.surrogate.model import ModelConfig, SurrogateNet

N_IN, N_OUT = 4, 2


def best_of(repeats: int, fn: Callable[..., float], *args: Any) -> float:
    """Minimum over ``repeats`` calls of ``fn(*args)``, a function returning seconds."""
    return min(fn(*args) for _ in range(repeats))


def cpp_sequence_time(model: Any, x: np.ndarray) -> float:
    """Seconds for C++ whole-sequence prediction of x (B, T, I)."""
    t0 = time.perf_counter()
    model.predict(x)
    return time.perf_counter() - t0


def torch_sequence_time(net: Any, xt: Any) -> float:
    """Seconds for the PyTorch forward pass on xt (B, T, I)."""
    with torch.no_grad():
        t0 = time.perf_counter()
        net(xt)
        return time.perf_counter() - t0


def make_models(hidden: int, layers: int, cell: str) -> tuple[Any, Any]:
    """A seeded torch net (float32) and the C++ Model32 with the same weights."""
    torch.manual_seed(hidden)
    net = SurrogateNet(ModelConfig(cell, N_IN, hidden, layers, N_OUT)).eval()
    data = model_to_bytes(from_torch(net, [f"x{j}" for j in range(N_IN)], ["y0", "y1"]))
    return net, _core.lstm.Model32.from_bytes(data)


def torch_step_latency(net: Any, batch: int, steps: int) -> float:
    """Seconds per streaming step in PyTorch eager (state carried between calls)."""
    x = torch.randn(batch, 1, N_IN)
    h = torch.zeros(net.config.num_layers, batch, net.config.hidden_size)
    state: Any = (h, h.clone()) if net.config.cell == "standard" else None
    with torch.no_grad():
        for _ in range(10):  # warm-up
            out, state = net.rnn((x - net.input_mean) / net.input_scale, state)
        t0 = time.perf_counter()
        for _ in range(steps):
            out, state = net.rnn((x - net.input_mean) / net.input_scale, state)
            y = net.head(out) * net.output_scale + net.output_mean
        dt = time.perf_counter() - t0
    assert torch.isfinite(y).all()
    return dt / steps


def cpp_step_latency_python(model: Any, batch: int, steps: int) -> float:
    """Seconds per streaming step when Python calls the C++ stream once per step."""
    stream = model.stream(batch)
    x = np.random.default_rng(0).normal(size=(batch, N_IN)).astype(np.float32)
    if batch == 1:
        x = x[0]
    out = np.empty(batch * N_OUT, dtype=np.float32)
    step = stream.step_into
    t0 = time.perf_counter()
    for _ in range(steps):
        step(x, out)
    return (time.perf_counter() - t0) / steps


def main() -> None:
    """Run the benchmark and print the table."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--steps", type=int, default=2000, help="streaming steps per timing")
    ap.add_argument("--seq-len", type=int, default=1000, help="sequence length for throughput")
    ap.add_argument("--repeats", type=int, default=5, help="timings per figure (best kept)")
    ap.add_argument("--layers", type=int, default=1)
    ap.add_argument("--cell", choices=("standard", "peephole"), default="standard")
    ap.add_argument("--hidden", type=int, nargs="+", default=[16, 32, 64, 128])
    ap.add_argument("--batch", type=int, nargs="+", default=[1, 64])
    ap.add_argument("--torch-threads", type=int, default=1,
                    help="torch CPU threads (1: like the single-threaded C++ engine)")
    args = ap.parse_args()
    torch.set_num_threads(args.torch_threads)

    print(f"# terrasph LSTM inference benchmark: {args.cell} cell, {args.layers} layer(s), "
          f"float32, {N_IN} inputs, {N_OUT} outputs")
    print(f"# {platform.processor() or platform.machine()}, torch {torch.__version__} "
          f"({torch.get_num_threads()} threads), C++ engine single-threaded")
    print(f"# streaming: {args.steps} steps/timing; throughput: T = {args.seq_len}; "
          f"best of {args.repeats}")
    head = (f"{'hidden':>6} {'batch':>5} | {'C++ step':>10} {'C++ via Py':>10} "
            f"{'torch step':>10} {'speed-up':>8} | {'C++ seq':>11} {'torch seq':>11} "
            f"{'speed-up':>8}")
    print(head)
    print(f"{'':>6} {'':>5} | {'[µs]':>10} {'[µs]':>10} {'[µs]':>10} {'C++/torch':>8} | "
          f"{'[steps/s]':>11} {'[steps/s]':>11} {'C++/torch':>8}")
    print("-" * len(head))
    for hidden in args.hidden:
        net, model = make_models(hidden, args.layers, args.cell)
        for batch in args.batch:
            x1 = np.random.default_rng(1).normal(size=(batch, N_IN)).astype(np.float32)
            stream = model.stream(batch)
            xin = x1[0] if batch == 1 else x1
            n_cpp = max(args.steps, 20000 // batch)
            cpp_step = best_of(args.repeats, stream.time_steps, xin, n_cpp)
            cpp_py = best_of(args.repeats, cpp_step_latency_python, model, batch, args.steps)
            t_step = best_of(args.repeats, torch_step_latency, net, batch, args.steps)

            seq_len = args.seq_len if args.cell == "standard" else min(args.seq_len, 200)
            x = np.random.default_rng(2).normal(size=(batch, seq_len, N_IN)).astype(np.float32)
            n = batch * seq_len
            cpp_tp = n / best_of(args.repeats, cpp_sequence_time, model, x)
            t_tp = n / best_of(args.repeats, torch_sequence_time, net, torch.from_numpy(x))
            print(f"{hidden:>6} {batch:>5} | {cpp_step * 1e6:>10.3f} {cpp_py * 1e6:>10.3f} "
                  f"{t_step * 1e6:>10.2f} {t_step / cpp_step:>8.1f} | {cpp_tp:>11.3g} "
                  f"{t_tp:>11.3g} {cpp_tp / t_tp:>8.2f}")


if __name__ == "__main__":
    main()
