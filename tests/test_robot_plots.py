"""Robot figures that do not mislead at a glance: slip (Eq. 4.8) is drawn only where it is defined
(not in the pause, ω = 0, nor while the wheel spins up), a model with many coupled bodies (the
ant's 13) gets one legend below its panels instead of legends over its data, and unnamed bodies
get readable names instead of ``#4``."""

from __future__ import annotations

import os

import numpy as np
import pytest
from terrasph.mjcf.model import body_name, coupled_body_id, load_model
from terrasph.robots.plots import plot_robot, plot_robot_3d

SETTLE = 0.2
TIME = np.linspace(0.0, 1.0, 101)


def _wheel(phase: float) -> dict[str, np.ndarray]:
    """A wheel held for the pause, spun up over 0.1 s to 2 rad/s, rolling with 20 % slip."""
    omega = np.clip((TIME - SETTLE) / 0.1, 0.0, 1.0) * 2.0
    speed = 0.8 * 0.05 * omega
    with np.errstate(divide="ignore", invalid="ignore"):
        slip = np.clip(np.where(omega > 0, 1 - speed / (0.05 * omega), -1.0), -1, 1)
    slip[(TIME > SETTLE) & (TIME < SETTLE + 0.03)] = -0.8  # the spin-up's noise
    return {"time": TIME, "omega": omega, "spin": omega, "slip": slip, "sinkage": 0.01 + 0 * TIME,
            "reference": np.column_stack([speed.cumsum() * 0.01 + phase, 0.05 + 0 * TIME]),
            "position": np.column_stack([speed.cumsum() * 0.01 + phase, phase + 0 * TIME, 0.05 + 0 * TIME]),
            "force": np.column_stack([0 * TIME, 0 * TIME, 1 + 0 * TIME])}


def test_slip_is_drawn_only_where_defined() -> None:
    figure = plot_robot({"robot/wheel": _wheel(0.0)}, ["wheel"], settle_time=SETTLE)
    slip_line = figure.axes[1].get_lines()[0]
    t, s = slip_line.get_xdata(), np.asarray(slip_line.get_ydata(), dtype=float)
    assert np.all(np.isnan(s[t <= SETTLE]))  # the pause: ω = 0
    assert np.all(np.isnan(s[(t > SETTLE) & (t < SETTLE + 0.05)]))  # below half the spin
    assert np.allclose(s[t > SETTLE + 0.1], 0.2)  # the driven phase as it is


def test_many_bodies_share_one_legend_outside_the_panels() -> None:
    names = [f"leg_{i}" for i in range(13)]
    series = {f"robot/{name}": _wheel(0.01 * i) for i, name in enumerate(names)}
    figure = plot_robot_3d(series, names, settle_time=SETTLE)
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(figure)
    canvas.draw()
    renderer = canvas.get_renderer()
    assert len(figure.legends) == 1 and len(figure.legends[0].get_texts()) == 13
    box = figure.legends[0].get_window_extent(renderer)
    for ax in figure.axes:
        assert not box.overlaps(ax.get_window_extent(renderer)), ax.get_ylabel()
        legend = ax.get_legend()
        assert legend is None or len(legend.get_texts()) <= 2  # the load panels' own few lines


def test_unnamed_bodies_get_readable_names() -> None:
    gymnasium = pytest.importorskip("gymnasium")
    ant = load_model(os.path.join(os.path.dirname(gymnasium.__file__), "envs", "mujoco", "assets", "ant.xml"))
    names = [body_name(ant, b) for b in range(1, ant.nbody)]
    assert len(set(names)) == len(names) == 13
    assert not any(name.startswith("#") for name in names)
    assert "left_ankle" in names and coupled_body_id(ant, "left_ankle") == names.index("left_ankle") + 1
