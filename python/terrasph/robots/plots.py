"""Figures of robot runs (matplotlib without pyplot, as terrasph.plotting): trajectory, slip and
sinkage against time per coupled body (like the dissertation's Fig. 4.3–4.4)."""

from __future__ import annotations

import os
from collections.abc import Sequence

import numpy as np
from matplotlib.figure import Figure

__all__ = ["plot_robot"]


def plot_robot(series: dict[str, dict[str, np.ndarray]], bodies: Sequence[str],
               path: str | os.PathLike[str] | None = None, *, settle_time: float | None = None,
               title: str = "") -> Figure:
    """Three panels for the coupled `bodies` of a run's ``series`` (``/series/robot/<body>``): the
    path of each body origin (axle), slip (Eq. 4.8) and sinkage against time. A dotted line marks
    the end of the pause (`settle_time`), before which a wheel does not turn and Eq. 4.8 gives −1."""
    figure = Figure(figsize=(6.4, 7.5), layout="constrained")
    trajectory, slip_ax, sink_ax = figure.subplots(3, 1)
    for name in bodies:
        body = series[f"robot/{name}"]
        trajectory.plot(body["reference"][:, 0] * 100, body["reference"][:, 1] * 100, label=name)
        slip_ax.plot(body["time"], body["slip"], label=name)
        sink_ax.plot(body["time"], body["sinkage"] * 100, label=name)
    trajectory.set(xlabel="axle x (cm)", ylabel="axle z (cm)", title=title or "trajectory")
    slip_ax.set(xlabel="t (s)", ylabel="slip (Eq. 4.8)", ylim=(-1.05, 1.05))
    sink_ax.set(xlabel="t (s)", ylabel="sinkage (cm)")
    if settle_time is not None:
        for ax in (slip_ax, sink_ax):
            ax.axvline(settle_time, color="0.5", linestyle=":", linewidth=1)
    trajectory.legend()
    if path is not None:
        figure.savefig(path, dpi=120)
    return figure
