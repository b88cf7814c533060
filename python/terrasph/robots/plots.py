"""Figures of robot runs (matplotlib without pyplot, as terrasph.plotting): trajectory, slip and
sinkage against time per coupled body (like the dissertation's Fig. 4.3–4.4), in the plane or, for
a robot on the 3D RFT terrain, its track seen from above, heights and loads."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

__all__ = ["LEGEND_INSIDE_BODIES", "body_legend", "defined_slip", "plot_robot", "plot_robot_3d"]

#: up to this many labelled lines a panel keeps its legend inside; more (the ant's 13 bodies) get one
#: legend for the whole figure, below its panels, so no legend covers data
LEGEND_INSIDE_BODIES = 4


def defined_slip(body: Mapping[str, np.ndarray], settle_time: float | None) -> np.ndarray:
    """A body's slip (Eq. 4.8, s = 1 − v/(Rω)) where it is defined, NaN (not drawn) elsewhere: during
    the pause (the wheel held, ω = 0: s reads −1 or clips) and while the wheel spins up after it,
    below half its median spin after the pause (Rω near 0: any creep reads as a large slip)."""
    slip = np.array(body["slip"], dtype=float)
    time = np.asarray(body["time"])
    spin = np.abs(np.asarray(body["omega"] if "omega" in body else body["spin"], dtype=float))
    after = time > settle_time if settle_time is not None else np.ones(time.shape, dtype=bool)
    spinning = spin >= 0.5 * np.median(spin[after]) if after.any() else after
    driven = after & spinning & (spin > 0)
    slip[~driven] = np.nan
    return slip


def body_legend(figure: Figure, axes: Sequence[Axes], bodies: Sequence[str]) -> None:
    """The legend of the per-body panels `axes`: each its own for a few bodies, or, for more than
    LEGEND_INSIDE_BODIES, one for the figure below its panels (the first panel's lines)."""
    if len(bodies) <= LEGEND_INSIDE_BODIES:
        for ax in axes:
            ax.legend(fontsize="small")
        return
    handles, labels = axes[0].get_legend_handles_labels()
    figure.legend(handles, labels, loc="outside lower center", ncols=min(5, len(labels)), fontsize="small")


def plot_robot(series: dict[str, dict[str, np.ndarray]], bodies: Sequence[str],
               path: str | os.PathLike[str] | None = None, *, settle_time: float | None = None,
               title: str = "") -> Figure:
    """Three panels for the coupled `bodies` of a run's ``series`` (``/series/robot/<body>``): the
    path of each body origin (axle), slip (Eq. 4.8, where defined: :func:`defined_slip`) and sinkage
    against time. A dotted line marks the end of the pause (`settle_time`). Up to
    LEGEND_INSIDE_BODIES bodies, whose legend is inside, the panels' margins are fixed (the
    constrained layout's search of them took 1.4x the figure's wall); more get it, for their legend
    below the panels."""
    inside = len(bodies) <= LEGEND_INSIDE_BODIES
    figure = Figure(figsize=(6.4, 7.5), layout=None if inside else "constrained")
    if inside:
        figure.subplots_adjust(left=0.11, right=0.97, top=0.96, bottom=0.06, hspace=0.3)
    trajectory, slip_ax, sink_ax = figure.subplots(3, 1)
    for name in bodies:
        body = series[f"robot/{name}"]
        trajectory.plot(body["reference"][:, 0] * 100, body["reference"][:, 1] * 100, label=name)
        slip_ax.plot(body["time"], defined_slip(body, settle_time), label=name)
        sink_ax.plot(body["time"], body["sinkage"] * 100, label=name)
    trajectory.set(xlabel="axle x (cm)", ylabel="axle z (cm)", title=title or "trajectory")
    slip_ax.set(xlabel="t (s)", ylabel="slip (Eq. 4.8)", ylim=(-1.05, 1.05))
    sink_ax.set(xlabel="t (s)", ylabel="sinkage (cm)")
    if settle_time is not None:
        for ax in (slip_ax, sink_ax):
            ax.axvline(settle_time, color="0.5", linestyle=":", linewidth=1)
    body_legend(figure, [trajectory], bodies)
    if path is not None:
        figure.savefig(path, dpi=120)
    return figure


def plot_robot_3d(series: dict[str, dict[str, np.ndarray]], bodies: Sequence[str],
                  path: str | os.PathLike[str] | None = None, *, settle_time: float | None = None,
                  title: str = "", weight: float | None = None) -> Figure:
    """Six panels for the coupled `bodies` of a run on the 3D RFT terrain
    (:class:`terrasph.robots.run.RobotLoads3D`'s series): the track seen from above (each
    body's frame origin and, with actuators, the robot's centre of mass, dashed), their heights,
    each body's sinkage, the terrain's total vertical load (with the robot's `weight`, N, dashed if
    given), its total horizontal load, and each wheel's slip (Eq. 4.8, where defined:
    :func:`defined_slip`). A dotted line marks the end of the pause (`settle_time`); many bodies share
    one legend below the panels (:func:`body_legend`)."""
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
            slip_ax.plot(body["time"], defined_slip(body, settle_time), label=name)
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
    body_legend(figure, [track, height, sink_ax, *([slip_ax] if wheels else [])], bodies)
    for ax in (lift_ax, drag_ax):
        ax.legend(fontsize="small")
    if settle_time is not None:
        for ax in (height, sink_ax, lift_ax, drag_ax, slip_ax):
            ax.axvline(settle_time, color="0.5", linestyle=":", linewidth=1)
    if path is not None:
        figure.savefig(path, dpi=120)
    return figure
