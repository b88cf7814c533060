"""Benchmark of LSTM inference: C++ engine (terrasph._core.lstm) versus PyTorch eager.

Same weights for both (a seeded SurrogateNet exported to the model file), float32, hidden
16/32/64/128, batch 1 and 64, same sequence length, in one run. PyTorch (a CPU build) runs
once with ``torch.set_num_threads(1)`` (like the single-threaded C++ engine) and once with its
default thread count; every repeat times C++, PyTorch 1-thread and PyTorch default in turn
(interleaved A/B, so load from other processes hits all three alike). Reports

* streaming latency per step: C++ timed inside C++ (what robot code pays), C++ called from
  Python once per step (``Stream.step_into``), and PyTorch eager (``nn.LSTM`` on one step with
  the carried state + head + normalisation, under ``torch.no_grad``); at batch > 1 the C++
  step advances all sequences together (one matrix-matrix product per weight matrix);
* whole-sequence throughput in time steps per second (batch x T / wall time): C++
  ``Model.predict`` versus the PyTorch forward pass.

Each figure is the best of ``--repeats`` timings. Usage::

    python benchmarks/performance/bench_lstm.py [--steps 2000] [--seq-len 1000] [--repeats 5]
                                    [--hidden 16 32 64 128] [--batch 1 64] [--cell standard]
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


def with_threads(n: int, fn: Callable[..., float], *args: Any) -> float:
    """``fn(*args)`` with torch on ``n`` threads (the previous count restored)."""
    old = torch.get_num_threads()
    torch.set_num_threads(n)
    try:
        return fn(*args)
    finally:
        torch.set_num_threads(old)


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
    args = ap.parse_args()
    n_default = torch.get_num_threads()
    settings = (1, n_default)

    print(f"# terrasph LSTM inference benchmark: {args.cell} cell, {args.layers} layer(s), "
          f"float32, {N_IN} inputs, {N_OUT} outputs")
    print(f"# {platform.processor() or platform.machine()}, torch {torch.__version__} "
          f"(threads: 1 and default {n_default}), C++ engine single-threaded"
          f", {make_models(4, 1, 'standard')[1].kernel_isa} kernels")
    print(f"# streaming: >= {args.steps} steps/timing; throughput: T = {args.seq_len}; "
          f"best of {args.repeats}, C++ / torch 1 thread / torch {n_default} threads interleaved")
    tn = f"t{n_default}"
    head = (f"{'hidden':>6} {'batch':>5} | {'C++':>8} {'C++ Py':>8} {'torch t1':>9} "
            f"{'torch ' + tn:>9} {'x t1':>6} {'x ' + tn:>6} | {'C++':>9} {'torch t1':>9} "
            f"{'torch ' + tn:>9} {'x t1':>6} {'x ' + tn:>6}")
    print(f"{'':>12} | {'streaming step [µs]; speed-up C++/torch':<55}| "
          f"whole sequences [steps/s]; speed-up")
    print(head)
    print("-" * len(head))
    for hidden in args.hidden:
        net, model = make_models(hidden, args.layers, args.cell)
        for batch in args.batch:
            x1 = np.random.default_rng(1).normal(size=(batch, N_IN)).astype(np.float32)
            stream = model.stream(batch)
            xin = x1[0] if batch == 1 else x1
            n_cpp = max(args.steps, 20000 // batch)
            seq_len = args.seq_len if args.cell == "standard" else min(args.seq_len, 200)
            x = np.random.default_rng(2).normal(size=(batch, seq_len, N_IN)).astype(np.float32)
            xt = torch.from_numpy(x)
            step = {"cpp": np.inf, "py": np.inf, **dict.fromkeys(settings, np.inf)}
            seq = {"cpp": np.inf, **dict.fromkeys(settings, np.inf)}
            for _ in range(args.repeats):
                step["cpp"] = min(step["cpp"], stream.time_steps(xin, n_cpp))
                step["py"] = min(step["py"], cpp_step_latency_python(model, batch, args.steps))
                seq["cpp"] = min(seq["cpp"], cpp_sequence_time(model, x))
                for n in settings:
                    step[n] = min(step[n], with_threads(n, torch_step_latency, net, batch,
                                                        args.steps))
                    seq[n] = min(seq[n], with_threads(n, torch_sequence_time, net, xt))
            tp = {k: batch * seq_len / v for k, v in seq.items()}
            print(f"{hidden:>6} {batch:>5} | {step['cpp'] * 1e6:>8.3f} {step['py'] * 1e6:>8.3f} "
                  f"{step[1] * 1e6:>9.1f} {step[n_default] * 1e6:>9.1f} "
                  f"{step[1] / step['cpp']:>6.1f} {step[n_default] / step['cpp']:>6.1f} | "
                  f"{tp['cpp']:>9.3g} {tp[1]:>9.3g} {tp[n_default]:>9.3g} "
                  f"{tp['cpp'] / tp[1]:>6.2f} {tp['cpp'] / tp[n_default]:>6.2f}", flush=True)


if __name__ == "__main__":
    main()
