"""The shipped surrogate's validity range as docs/surrogate.md states it is the model's own: every
stated range lies inside the range recorded in the model file (so a value taken from the docs is
accepted by ``terrasph predict``) and is that range rounded (within 1 % of its width), not the
sweep's wider design range."""

from __future__ import annotations

import re
from pathlib import Path

from terrasph.surrogate import pretrained

DOC = Path(__file__).resolve().parents[1] / "docs" / "surrogate.md"
#: "load 2.11–6.93 N, ω 0.51–2.68 rad/s, μ1 19.03–26.91°": the stated ranges of the shipped model
STATED = re.compile(r"load ([\d.]+)–([\d.]+) N, ω ([\d.]+)–([\d.]+)\s+rad/s, μ1 ([\d.]+)–([\d.]+)°")


def test_the_docs_state_the_shipped_models_validity_range() -> None:
    ranges = pretrained("leg-wheel-ch4").validity.ranges
    stated = STATED.findall(" ".join(DOC.read_text(encoding="utf-8").split()))
    assert len(stated) >= 2  # §8's study paragraph and the shipped file's
    for values in stated:
        for name, (low, high) in zip(("load", "omega_cmd", "mu1_deg"), zip(values[::2], values[1::2])):
            lo, hi = ranges[name]
            width = hi - lo
            assert lo <= float(low) <= lo + 0.01 * width, (name, low, lo)
            assert hi - 0.01 * width <= float(high) <= hi, (name, high, hi)
