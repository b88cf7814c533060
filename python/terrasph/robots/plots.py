"""Figures of robot runs (matplotlib without pyplot, as terrasph.plotting): trajectory, slip and
sinkage against time per coupled body (like the dissertation's Fig. 4.3–4.4), in the plane or, for
a robot on the 3D RFT terrain, its track seen from above, heights and loads."""

from __future__ import annotations

import os
from collections.abc import Sequence

import numpy as np
from matplotlib.figure import Figure

__all__ = ["plot_robot", "plot_robot_3d"]


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


def plot_robot_3d(series: dict[str, dict[str, np.ndarray]], bodies: Sequence[str],
                  path: str | os.PathLike[str] | None = None, *, settle_time: float | None = None,
                  title: str = "", weight: float | None = None) -> Figure:
    """Six panels for the coupled `bodies` of a run on the 3D RFT terrain
    (:class:`terrasph.robots.rft3d_terrain.RobotLoads3D`'s series): the track seen from above (each
    body's frame origin and, with actuators, the robot's centre of mass, dashed), their heights,
    each body's sinkage, the terrain's total vertical load (with the robot's `weight`, N, dashed if
    given), its total horizontal load, and each wheel's slip (Eq. 4.8). A dotted line marks the end
    of the pause (`settle_time`)."""
    figure = Figure(figsize=(10.0, 9.0), layout="constrained")
    (track, height), (sink_ax, lift_ax), (drag_ax, slip_ax) = figure.subplots(3, 2)
    actuators = series.get("robot/actuators")
    if actuators is not None:
        com = actuators["com"] * 100
        track.plot(com[:, 0], com[:, 1], "k--", label="centre of mass")
        height.plot(actuators["time"], com[:, 2], "k--", label="centre of mass")
    total = np.zeros((len(series[f"robot/{bodies[0]}"]["time"]), 3))
    wheels = False
    for name in bodies:
        body = series[f"robot/{name}"]
        track.plot(body["position"][:, 0] * 100, body["position"][:, 1] * 100, label=name)
        height.plot(body["time"], body["position"][:, 2] * 100, label=name)
        sink_ax.plot(body["time"], body["sinkage"] * 100, label=name)
        total = total + body["force"]
        if "slip" in body:
            slip_ax.plot(body["time"], body["slip"], label=name)
            wheels = True
    time = series[f"robot/{bodies[0]}"]["time"]
    lift_ax.plot(time, total[:, 2], label="terrain on the coupled bodies")
    if weight is not None:
        lift_ax.axhline(weight, color="k", linestyle="--", linewidth=1, label="robot's weight")
    drag_ax.plot(time, total[:, 0], label="F_x")
    drag_ax.plot(time, total[:, 1], label="F_y")
    track.set(xlabel="x (cm)", ylabel="y (cm)", title=title or "track, seen from above", aspect="equal",
              adjustable="datalim")
    height.set(xlabel="t (s)", ylabel="height z (cm)", title="frame origins' height")
    sink_ax.set(xlabel="t (s)", ylabel="sinkage (cm)")
    lift_ax.set(xlabel="t (s)", ylabel="vertical load (N)")
    drag_ax.set(xlabel="t (s)", ylabel="horizontal load (N)")
    slip_ax.set(xlabel="t (s)", ylabel="slip (Eq. 4.8)", ylim=(-1.05, 1.05))
    if not wheels:
        slip_ax.text(0.5, 0.5, "no coupled body on a single hinge (a wheel)", ha="center", va="center",
                     transform=slip_ax.transAxes)
    for ax in (track, height, sink_ax, lift_ax, drag_ax, *([slip_ax] if wheels else [])):
        ax.legend(fontsize="small")
    if settle_time is not None:
        for ax in (height, sink_ax, lift_ax, drag_ax, slip_ax):
            ax.axvline(settle_time, color="0.5", linestyle=":", linewidth=1)
    if path is not None:
        figure.savefig(path, dpi=120)
    return figure
