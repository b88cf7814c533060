"""Figures for runs and studies (matplotlib, no pyplot).

Figures are built as :class:`matplotlib.figure.Figure` objects without pyplot, so nothing is
registered globally, no window opens, and any backend (Agg on headless machines) works. Each
function returns its Figure and also saves it when ``path`` is given. Axes carry SI units.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure, SubFigure

from terrasph.analysis import fit_line

__all__ = [
    "plot_convergence",
    "plot_fields",
    "plot_leg_loads",
    "plot_particles",
    "plot_profiles",
    "plot_series",
    "plot_yield_locus",
]

PathLike = str | os.PathLike[str]
_DPI = 150


def _new_axes(ax: Axes | None = None, size: tuple[float, float] = (6.4, 4.0)) -> tuple[Figure, Axes]:
    """Return ``ax`` and its figure, or a fresh pyplot-free figure with one axes."""
    if ax is not None:
        return _root_figure(ax), ax
    figure = Figure(figsize=size, layout="constrained")
    return figure, figure.add_subplot()


def _root_figure(ax: Axes) -> Figure:
    """The top-level Figure that holds ``ax`` (also when ``ax`` lies in a SubFigure)."""
    figure = ax.get_figure()
    while isinstance(figure, SubFigure):
        figure = figure.figure
    if not isinstance(figure, Figure):
        raise TypeError("ax must belong to a matplotlib Figure")
    return figure


def _finish(figure: Figure, path: PathLike | None) -> Figure:
    """Save ``figure`` to ``path`` when given; return it."""
    if path is not None:
        figure.savefig(path, dpi=_DPI)
    return figure


def _xz(name: str, value: np.ndarray) -> np.ndarray:
    """Validate an (N, 2) array of (x, z) positions."""
    array = np.asarray(value, dtype=float)
    if array.ndim != 2 or array.shape[1] != 2:
        raise ValueError(f"{name} must have shape (N, 2), got {array.shape}")
    return array


def _curve(name: str, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Validate two 1-D arrays of equal length."""
    xs, ys = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if xs.ndim != 1 or xs.shape != ys.shape:
        raise ValueError(f"{name} must be two 1-D arrays of equal length, got shapes {xs.shape} and {ys.shape}")
    return xs, ys


def _marker_size(position: np.ndarray, ax: Axes) -> float:
    """Marker area (points²) so that markers roughly tile the particles' bounding box."""
    extent = np.ptp(position, axis=0)
    span = max(float(extent.max()), 1e-12)
    area = float(extent[0] * extent[1])
    spacing = np.sqrt(area / len(position)) if area > 0 else span / len(position)
    axes_points = 0.8 * min(_root_figure(ax).get_size_inches()) * 72.0
    diameter = axes_points * spacing / max(span, spacing)
    return float(np.clip(diameter**2, 0.5, 60.0))


def plot_particles(
    position: np.ndarray,
    values: np.ndarray | None = None,
    *,
    walls: np.ndarray | None = None,
    label: str = "",
    ax: Axes | None = None,
    path: PathLike | None = None,
    s: float | None = None,
    cmap: str = "viridis",
) -> Figure:
    """Scatter plot of particles in the x–z plane at equal aspect.

    ``values`` (N,) colours the particles with a colour bar labelled ``label`` (include units,
    e.g. ``"pressure (Pa)"``); ``walls`` (M, 2) are drawn in grey. ``s`` is the marker area in
    points² (default: sized from the particle count and extent).
    """
    points = _xz("position", position)
    figure, axes = _new_axes(ax)
    size = _marker_size(points, axes) if s is None else float(s)
    if walls is not None:
        wall_points = _xz("walls", walls)
        axes.scatter(wall_points[:, 0], wall_points[:, 1], s=size, c="0.6", marker="s", linewidths=0, label="walls")
    if values is None:
        axes.scatter(points[:, 0], points[:, 1], s=size, c="tab:orange", linewidths=0)
    else:
        colours = np.asarray(values, dtype=float)
        if colours.shape != (points.shape[0],):
            raise ValueError(f"values must have shape ({points.shape[0]},), one per particle, got {colours.shape}")
        mappable = axes.scatter(points[:, 0], points[:, 1], s=size, c=colours, cmap=cmap, linewidths=0)
        figure.colorbar(mappable, ax=axes, label=label)
    axes.set_aspect("equal")
    axes.set_xlabel("x (m)")
    axes.set_ylabel("z (m)")
    return _finish(figure, path)


def plot_fields(
    position: np.ndarray,
    fields: Sequence[tuple[np.ndarray, str]],
    *,
    walls: np.ndarray | None = None,
    title: str = "",
    path: PathLike | None = None,
) -> Figure:
    """One particle panel per (values, label) of ``fields``, stacked, e.g. the speed and the shear
    strain of a frame (labels with units, such as ``"|v| (m/s)"``); walls in grey on each panel."""
    if not fields:
        raise ValueError("fields must hold at least one (values, label) pair")
    figure = Figure(figsize=(6.4, 3.0 * len(fields)), layout="constrained")
    for axes, (values, label) in zip(figure.subplots(len(fields), 1, squeeze=False)[:, 0], fields, strict=True):
        plot_particles(position, values, walls=walls, label=label, ax=axes)
    if title:
        figure.suptitle(title)
    return _finish(figure, path)


def plot_profiles(
    profiles: Sequence[tuple[np.ndarray, np.ndarray, str]],
    *,
    initial: tuple[np.ndarray, np.ndarray] | None = None,
    bed: tuple[np.ndarray, np.ndarray] | None = None,
    path: PathLike | None = None,
    xlabel: str = "x (m)",
    ylabel: str = "z (m)",
    equal_aspect: bool = True,
) -> Figure:
    """Free-surface profiles (x, h, legend label), e.g. from :func:`terrasph.analysis.surface_profile`.

    ``initial`` (x, h) is drawn dashed in black as the initial column, ``bed`` (x, z) solid in grey
    as the bed surface (a curved bed). ``equal_aspect`` keeps x and z to the same scale (turn it
    off for normalised or exaggerated axes).
    """
    if not profiles:
        raise ValueError("profiles must hold at least one (x, h, label) tuple")
    figure, axes = _new_axes()
    if bed is not None:
        xb, zb = _curve("bed", *bed)
        axes.plot(xb, zb, color="0.5", label="bed")
    if initial is not None:
        x0, h0 = _curve("initial", *initial)
        axes.plot(x0, h0, "k--", label="initial")
    for x, h, name in profiles:
        xs, hs = _curve(f"profile {name!r}", x, h)
        axes.plot(xs, hs, drawstyle="steps-mid", label=name)
    if equal_aspect:
        axes.set_aspect("equal")
    axes.set_xlabel(xlabel)
    axes.set_ylabel(ylabel)
    axes.legend()
    return _finish(figure, path)


def plot_leg_loads(
    curves: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray, str]],
    *,
    path: PathLike | None = None,
    title: str | None = None,
) -> Figure:
    """Lift F_z and thrust F_x (N) against the leg angle θ (rad, clockwise), one panel each, as in
    Fig. 3.2–3.5 of the dissertation; ``curves`` holds (θ, F_z, F_x, label) tuples."""
    if not curves:
        raise ValueError("curves must hold at least one (theta, lift, thrust, label) tuple")
    figure = Figure(figsize=(9.0, 3.6), layout="constrained")
    lift_axes, thrust_axes = figure.subplots(1, 2, sharex=True)
    for theta, lift, thrust, name in curves:
        t, fz = _curve(f"lift {name!r}", theta, lift)
        _, fx = _curve(f"thrust {name!r}", theta, thrust)
        lift_axes.plot(t, fz, label=name)
        thrust_axes.plot(t, fx, label=name)
    for axes, label in ((lift_axes, "lift $F_z$ (N)"), (thrust_axes, "thrust $F_x$ (N)")):
        axes.set_xlabel(r"leg angle $\theta$ (rad, clockwise)")
        axes.set_ylabel(label)
        axes.axhline(0.0, color="0.6", lw=0.8)
        axes.set_xticks([-np.pi / 4, -np.pi / 8, 0, np.pi / 8, np.pi / 4],
                        [r"$-\pi/4$", r"$-\pi/8$", "0", r"$\pi/8$", r"$\pi/4$"])
    lift_axes.legend()
    if title:
        figure.suptitle(title)
    return _finish(figure, path)


def plot_series(
    time: np.ndarray,
    series: Mapping[str, np.ndarray],
    *,
    path: PathLike | None = None,
    ylabel: str = "",
    logy: bool = False,
) -> Figure:
    """Time series sharing one axis (e.g. runout L*, kinetic energy); ``time`` in s."""
    if not series:
        raise ValueError("series must hold at least one named array")
    figure, axes = _new_axes()
    for name, values in series.items():
        t, y = _curve(f"series {name!r} (against time)", time, values)
        axes.plot(t, y, label=name)
    if logy:
        axes.set_yscale("log")
    axes.set_xlabel("time (s)")
    axes.set_ylabel(ylabel)
    axes.legend()
    return _finish(figure, path)


def plot_convergence(
    table: Sequence[Mapping[str, float]],
    x_key: str,
    y_keys: Sequence[str],
    *,
    path: PathLike | None = None,
    logx: bool = True,
    logy: bool = False,
) -> Figure:
    """Plot columns of a result table against one column, e.g. error and run time against spacing.

    ``table`` is a sequence of rows (mappings); ``x_key`` and each of ``y_keys`` must be in every
    row. Axis labels are the keys, so name them with units (``"spacing (m)"``).
    """
    if not table or not y_keys:
        raise ValueError("table and y_keys must both be non-empty")
    for key in (x_key, *y_keys):
        missing = [i for i, row in enumerate(table) if key not in row]
        if missing:
            raise ValueError(f"key {key!r} is missing from table rows {missing}")
    figure, axes = _new_axes()
    x = np.array([row[x_key] for row in table], dtype=float)
    order = np.argsort(x)
    for key in y_keys:
        y = np.array([row[key] for row in table], dtype=float)
        axes.plot(x[order], y[order], "o-", label=key)
    if logx:
        axes.set_xscale("log")
    if logy:
        axes.set_yscale("log")
    axes.set_xlabel(x_key)
    axes.set_ylabel(y_keys[0] if len(y_keys) == 1 else "value")
    axes.legend()
    return _finish(figure, path)


def plot_yield_locus(
    p: np.ndarray,
    tau: np.ndarray,
    *,
    fit: bool = True,
    particles: tuple[np.ndarray, np.ndarray] | None = None,
    yield_lines: Sequence[tuple[str, float, float]] = (),
    path: PathLike | None = None,
) -> Figure:
    """τ against p (Pa), e.g. from :func:`terrasph.analysis.yield_locus` (Fig. 2.4–2.6f, 2.7d, 2.8d).

    With ``fit``, the least-squares line τ = μp + c is drawn and its μ, c and R² given in the legend.
    ``particles`` = (p, τ) of every particle adds them as a grey scatter; each (label, μ, c) of
    ``yield_lines`` draws the line τ = μp + c (e.g. μ1P + c and μ2P + c of the material).
    """
    ps, taus = _curve("(p, tau)", p, tau)
    figure, axes = _new_axes()
    if particles is not None:
        all_p, all_tau = _curve("particles", *particles)
        axes.scatter(all_p, all_tau, s=3, color="0.7", label="particles")
    axes.scatter(ps, taus, s=12, label="locus points")
    line_range = np.array([0.0, ps.max()])
    for label, mu, cohesion in yield_lines:
        axes.plot(line_range, mu * line_range + cohesion, "--", label=f"{label}: τ = {mu:.3f}p + {cohesion:.3g} Pa")
    if fit:
        slope, intercept, r_squared = fit_line(ps, taus)
        line_p = np.array([ps.min(), ps.max()])
        axes.plot(
            line_p,
            slope * line_p + intercept,
            "k-",
            label=f"τ = μp + c: μ = {slope:.3f}, c = {intercept:.3g} Pa, R² = {r_squared:.3f}",
        )
    axes.set_xlabel("pressure p (Pa)")
    axes.set_ylabel("shear stress τ (Pa)")
    axes.legend()
    return _finish(figure, path)
