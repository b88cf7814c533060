"""A tiny leg-wheel sweep for the sweep and surrogate tests: Δx = 1 cm, 20 × 3 cm bed, 4 cm legs,
0.1 s pause then 0.5 s driven (a second or so per run on an idle core)."""

from __future__ import annotations

import copy
from typing import Any

TINY_FIXED = {"spacing": 0.01, "thickness": 0.03, "leg_length": 0.04, "bed_width": 0.2, "bed_depth": 0.03,
              "start_x": 0.08, "settle_time": 0.1, "t_end": 0.6, "frame_interval": 0.3}


def tiny_spec(**design: Any) -> dict[str, Any]:
    """A SPEC of the tiny leg-wheel; `design` replaces entries of the default 3-run Latin hypercube."""
    base = {"method": "latin-hypercube", "runs": 3,
            "vary": {"load": {"range": [2.0, 6.0]}, "wheel": {"values": ["c-leg", "wheel"]}},
            "input": {"parameter": "omega_schedule", "range": [0.5, 3.0]}}
    return {"scene": "leg-wheel", "seed": 1, "fixed": copy.deepcopy(TINY_FIXED), "design": {**base, **design}}
