"""PyTorch models of the surrogate: a stacked LSTM (standard or peephole cell) with a dense head.

The peephole cell follows the dissertation, chapter 4, Eq. 4.9-4.13:

    i_t = σ(W_ui u_t + W_hi h_{t-1} + W_ci c_{t-1} + b_i)        (4.9)
    f_t = σ(W_uf u_t + W_hf h_{t-1} + W_cf c_{t-1} + b_f)        (4.10)
    c_t = f_t ∘ c_{t-1} + i_t ∘ tanh(W_uc u_t + W_hc h_{t-1} + b_c)   (4.11)
    o_t = σ(W_uo u_t + W_ho h_{t-1} + W_co c_t + b_o)            (4.12)
    h_t = o_t ∘ tanh(c_t)                                        (4.13)

The peephole weights W_ci, W_cf, W_co are full H×H matrices, as the equations write them (the
diagonal peepholes of Gers et al. are the special case of diagonal matrices). The input and
recurrent weights are stored exactly like ``torch.nn.LSTM``: ``weight_ih`` (4H, I) and
``weight_hh`` (4H, H) with gate blocks in the order i, f, g (cell candidate), o, plus
``bias_ih`` and ``bias_hh``; with zero peephole matrices the cell equals ``torch.nn.LSTMCell``.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import torch
from torch import nn

CELL_TYPES = ("standard", "peephole")


@dataclass(frozen=True)
class ModelConfig:
    """Architecture of a surrogate network.

    Attributes:
        cell: ``"standard"`` (torch.nn.LSTM) or ``"peephole"`` (Eq. 4.9-4.13).
        input_size: number of input features per time step, >= 1.
        hidden_size: hidden units per LSTM layer, >= 1.
        num_layers: number of stacked LSTM layers, >= 1.
        output_size: number of predicted targets per time step, >= 1.
    """

    cell: str
    input_size: int
    hidden_size: int
    num_layers: int
    output_size: int

    def __post_init__(self) -> None:
        if self.cell not in CELL_TYPES:
            raise ValueError(f"cell must be one of {CELL_TYPES}, got {self.cell!r}")
        for name in ("input_size", "hidden_size", "num_layers", "output_size"):
            value = getattr(self, name)
            if not isinstance(value, int) or not 1 <= value <= 65536:
                raise ValueError(f"{name} must be an integer in [1, 65536], got {value!r}")
        if self.num_layers > 64:
            raise ValueError(f"num_layers must be in [1, 64], got {self.num_layers}")

    def to_dict(self) -> dict[str, Any]:
        """Return the configuration as a plain dictionary."""
        return asdict(self)


class PeepholeLSTMCell(nn.Module):
    """One peephole LSTM cell, Eq. 4.9-4.13, with PyTorch's parameter layout plus peepholes."""

    def __init__(self, input_size: int, hidden_size: int) -> None:
        super().__init__()
        self.input_size = input_size
        self.hidden_size = hidden_size
        h = hidden_size
        self.weight_ih = nn.Parameter(torch.empty(4 * h, input_size))
        self.weight_hh = nn.Parameter(torch.empty(4 * h, h))
        self.bias_ih = nn.Parameter(torch.empty(4 * h))
        self.bias_hh = nn.Parameter(torch.empty(4 * h))
        self.weight_ci = nn.Parameter(torch.empty(h, h))
        self.weight_cf = nn.Parameter(torch.empty(h, h))
        self.weight_co = nn.Parameter(torch.empty(h, h))
        self.reset_parameters()

    def reset_parameters(self) -> None:
        """Input/recurrent weights and biases ~ U(-1/sqrt(H), 1/sqrt(H)) as torch.nn.LSTM;
        peephole matrices ~ U(-1/H, 1/H).

        The smaller peephole range keeps the untrained cell close to the standard one: with
        full H×H peepholes at the torch range, the positive feedback c -> f -> c can make the
        cell state of an untrained network grow without bound over long sequences.
        """
        bound = 1.0 / math.sqrt(self.hidden_size)
        for name, p in self.named_parameters():
            b = 1.0 / self.hidden_size if name in ("weight_ci", "weight_cf", "weight_co") else bound
            nn.init.uniform_(p, -b, b)

    def forward(
        self, u: torch.Tensor, state: tuple[torch.Tensor, torch.Tensor]
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """Advance one step: u (B, I), state (h, c) each (B, H) -> new (h, c)."""
        h_prev, c_prev = state
        hs = self.hidden_size
        gates = u @ self.weight_ih.T + self.bias_ih + h_prev @ self.weight_hh.T + self.bias_hh
        gi, gf, gg, go = gates.split(hs, dim=1)
        i = torch.sigmoid(gi + c_prev @ self.weight_ci.T)  # Eq. 4.9
        f = torch.sigmoid(gf + c_prev @ self.weight_cf.T)  # Eq. 4.10
        c = f * c_prev + i * torch.tanh(gg)  # Eq. 4.11
        o = torch.sigmoid(go + c @ self.weight_co.T)  # Eq. 4.12 (uses c_t)
        h = o * torch.tanh(c)  # Eq. 4.13
        return h, c


class PeepholeLSTM(nn.Module):
    """Stack of peephole cells unrolled in Python; batch-first like ``nn.LSTM(batch_first=True)``."""

    def __init__(self, input_size: int, hidden_size: int, num_layers: int) -> None:
        super().__init__()
        self.hidden_size = hidden_size
        self.num_layers = num_layers
        self.cells = nn.ModuleList(
            PeepholeLSTMCell(input_size if k == 0 else hidden_size, hidden_size)
            for k in range(num_layers)
        )

    def forward(
        self,
        x: torch.Tensor,
        state: tuple[torch.Tensor, torch.Tensor] | None = None,
    ) -> tuple[torch.Tensor, tuple[torch.Tensor, torch.Tensor]]:
        """Run x (B, T, I) -> outputs (B, T, H) and final (h_n, c_n) of shape (L, B, H)."""
        b, t_len, _ = x.shape
        if state is None:
            zeros = x.new_zeros(self.num_layers, b, self.hidden_size)
            state = (zeros, zeros)
        hs = [state[0][k] for k in range(self.num_layers)]
        cs = [state[1][k] for k in range(self.num_layers)]
        outputs = []
        for t in range(t_len):
            inp = x[:, t, :]
            for k, cell in enumerate(self.cells):
                hs[k], cs[k] = cell(inp, (hs[k], cs[k]))
                inp = hs[k]
            outputs.append(inp)
        out = torch.stack(outputs, dim=1) if outputs else x.new_zeros(b, 0, self.hidden_size)
        return out, (torch.stack(hs), torch.stack(cs))


class SurrogateNet(nn.Module):
    """Stacked LSTM + linear head, with the normalisation of inputs and targets as buffers.

    ``forward`` maps raw inputs (B, T, I) to raw targets (B, T, O); training works on
    normalised data through ``forward_normalised``.
    """

    input_mean: torch.Tensor
    input_scale: torch.Tensor
    output_mean: torch.Tensor
    output_scale: torch.Tensor

    def __init__(self, config: ModelConfig) -> None:
        super().__init__()
        self.config = config
        if config.cell == "standard":
            self.rnn: nn.Module = nn.LSTM(
                config.input_size, config.hidden_size, config.num_layers, batch_first=True
            )
        else:
            self.rnn = PeepholeLSTM(config.input_size, config.hidden_size, config.num_layers)
        self.head = nn.Linear(config.hidden_size, config.output_size)
        self.register_buffer("input_mean", torch.zeros(config.input_size))
        self.register_buffer("input_scale", torch.ones(config.input_size))
        self.register_buffer("output_mean", torch.zeros(config.output_size))
        self.register_buffer("output_scale", torch.ones(config.output_size))

    def set_normalisation(
        self,
        input_mean: Any,
        input_scale: Any,
        output_mean: Any,
        output_scale: Any,
    ) -> None:
        """Set x_n = (x - input_mean) / input_scale and y = y_n * output_scale + output_mean."""
        for name, value in (
            ("input_mean", input_mean),
            ("input_scale", input_scale),
            ("output_mean", output_mean),
            ("output_scale", output_scale),
        ):
            buf = getattr(self, name)
            t = torch.as_tensor(value, dtype=buf.dtype).reshape(buf.shape)
            if not torch.isfinite(t).all():
                raise ValueError(f"{name} must be finite")
            if name.endswith("scale") and not (t > 0).all():
                raise ValueError(f"{name} must be > 0")
            buf.copy_(t)

    def forward_normalised(self, xn: torch.Tensor) -> torch.Tensor:
        """Normalised inputs (B, T, I) -> normalised targets (B, T, O)."""
        out, _ = self.rnn(xn)
        return self.head(out)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """Raw inputs (B, T, I) -> raw targets (B, T, O)."""
        xn = (x - self.input_mean) / self.input_scale
        return self.forward_normalised(xn) * self.output_scale + self.output_mean


def layer_parameters(net: SurrogateNet) -> list[dict[str, torch.Tensor]]:
    """Return, per layer, the tensors ``weight_ih, weight_hh, bias_ih, bias_hh`` (and for the
    peephole cell ``weight_ci, weight_cf, weight_co``) in PyTorch gate order i, f, g, o."""
    layers: list[dict[str, torch.Tensor]] = []
    if isinstance(net.rnn, nn.LSTM):
        for k in range(net.config.num_layers):
            layers.append(
                {
                    name: getattr(net.rnn, f"{name}_l{k}").detach()
                    for name in ("weight_ih", "weight_hh", "bias_ih", "bias_hh")
                }
            )
    else:
        assert isinstance(net.rnn, PeepholeLSTM)
        for cell in net.rnn.cells:
            layers.append({name: p.detach() for name, p in cell.named_parameters()})
    return layers
