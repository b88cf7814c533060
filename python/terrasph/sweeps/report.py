"""What a finished sweep shows: its cases' summaries as a table, and a quantity by morphology."""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["finished_cases", "plot_by_morphology"]


def finished_cases(out_dir: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """The finished cases of the sweep in `out_dir` (its manifest): varied values, configuration,
    summary and wall time of each."""
    manifest = json.loads((Path(out_dir) / "manifest.json").read_text())
    return [case for case in manifest["cases"] if case["status"] == "completed"]


def plot_by_morphology(cases: Sequence[dict[str, Any]], quantities: Sequence[str] = (
        "mean_slip", "final_sinkage", "mean_forward_speed"), path: Any = None) -> Any:
    """Each summary quantity of the cases (one panel each) against the wheel morphology: every
    run as a dot, the mean as a bar; saved to `path` if given; returns the figure."""
    from matplotlib.figure import Figure

    wheels = sorted({case["config"]["wheel"] for case in cases})
    fig = Figure(figsize=(3.4 * len(quantities), 3.0), layout="constrained")
    axes = fig.subplots(1, len(quantities), squeeze=False)[0]
    for ax, quantity in zip(axes, quantities):
        for k, wheel in enumerate(wheels):
            values = np.array([c["summary"][quantity] for c in cases if c["config"]["wheel"] == wheel], dtype=float)
            ax.bar(k, np.nanmean(values), color="0.85", edgecolor="0.4")
            ax.plot(np.full(values.size, k), values, "o", color="C0", ms=4)
        ax.set_xticks(range(len(wheels)), wheels, rotation=30, ha="right")
        ax.set_title(quantity.replace("_", " "))
    if path is not None:
        fig.savefig(path, dpi=110)
    return fig
