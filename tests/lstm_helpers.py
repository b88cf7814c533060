"""Shared helpers of the LSTM tests: seeded PyTorch fixtures and the C++ engine."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

FEATURES = ["omega_cmd", "load", "soil_k", "mu"]
TARGETS = ["slip", "sinkage"]


def core_lstm() -> Any:
    """``terrasph._core.lstm``, or skip the test if the extension is not built."""
    core = pytest.importorskip("terrasph._core")
    if not hasattr(core, "lstm"):
        pytest.skip("terrasph._core has no lstm submodule (extension built without it)")
    return core.lstm


def make_net(cell: str, hidden: int, layers: int, seed: int, n_in: int = len(FEATURES),
             n_out: int = len(TARGETS), dtype: Any = None, normalise: bool = False) -> Any:
    """A seeded, untrained SurrogateNet (torch's own initialisation), optionally with a random
    non-trivial normalisation."""
    import torch
    from terrasph.surrogate.model import ModelConfig, SurrogateNet

    torch.manual_seed(seed)
    net = SurrogateNet(ModelConfig(cell, n_in, hidden, layers, n_out))
    if normalise:
        rng = np.random.default_rng(seed)
        net.set_normalisation(rng.normal(size=n_in), rng.uniform(0.5, 2.0, n_in),
                              rng.normal(size=n_out), rng.uniform(0.5, 2.0, n_out))
    if dtype is not None:
        net = net.to(dtype)
    net.eval()
    return net


def model_bytes(net: Any, n_in: int = len(FEATURES), n_out: int = len(TARGETS)) -> bytes:
    """Export ``net`` to the bytes of a model file."""
    from terrasph.surrogate.export import from_torch, model_to_bytes

    names_in = (FEATURES if n_in == len(FEATURES) else [f"x{j}" for j in range(n_in)])
    names_out = (TARGETS if n_out == len(TARGETS) else [f"y{j}" for j in range(n_out)])
    return model_to_bytes(from_torch(net, names_in, names_out, {"test": True}))


def torch_predict(net: Any, x: np.ndarray) -> np.ndarray:
    """Raw-unit prediction of PyTorch for x (B, T, I) in the net's own dtype."""
    import torch

    dtype = next(net.parameters()).dtype
    with torch.no_grad():
        return net(torch.from_numpy(x).to(dtype)).double().numpy()


def inputs(seed: int, batch: int, steps: int, n_in: int = len(FEATURES)) -> np.ndarray:
    """Random smooth-ish input sequences (B, T, I): a random walk plus noise, scale ~1."""
    rng = np.random.default_rng(seed)
    walk = np.cumsum(rng.normal(scale=0.05, size=(batch, steps, n_in)), axis=1)
    return np.clip(walk, -3, 3) + rng.normal(scale=0.3, size=(batch, steps, n_in))


@pytest.fixture
def one_thread() -> Any:
    """Train on one torch thread (fast for these small models; reproducible per thread count)."""
    import torch

    old = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(old)
