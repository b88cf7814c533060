"""The progress bar of Simulation.run: it ends at 100 % when a run stops early at
rest, never overshoots its total (no "clamping frac" warning, no negative remaining time), and a
disabled bar prints nothing, notebook widgets or not."""

from __future__ import annotations

import warnings

import numpy as np
from terrasph.config import Material, Numerics
from terrasph.simulation import Simulation

DX = 0.002


def resting_block(free_block, gravity: float = 0.0) -> Simulation:
    """A 10 × 10 block without walls, at rest at the start."""
    scene, _ = free_block(DX, 10, 10)
    scene.gravity = gravity
    return Simulation(scene, Material(), Numerics(spacing=DX))


def last_bar_line(text: str) -> str:
    return [line for line in text.replace("\r", "\n").splitlines() if "simulated" in line][-1]


def test_bar_ends_at_100_percent_when_the_run_stops_at_rest(free_block, capsys) -> None:
    # falling freely for 2 ms (|v| ≈ 2 cm/s), the block counts as at rest for the threshold ½|v|² < g·Δx
    sim = resting_block(free_block, gravity=9.81)
    result = sim.run(1.0, frame_interval=0.001, stop_when_at_rest=1.0, min_time=0.002, progress=True)
    assert result.status == "at_rest" and result.time < 0.01
    line = last_bar_line(capsys.readouterr().err)
    assert "100%" in line, line


def test_bar_never_passes_its_total(free_block, capsys) -> None:
    """A t_end whose 9-digit rounding (the bar's total) lies below it, as the leg scene's 2 + π/2/0.2 s
    does: the simulated time reached exceeds the total; no clamping warning, no negative ETA."""
    t_end = 0.0123456781234
    assert round(t_end, 9) < t_end
    sim = resting_block(free_block)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a TqdmWarning fails the test
        sim.run(t_end, frame_interval=0.001, progress=True)
    line = last_bar_line(capsys.readouterr().err)
    assert "100%" in line and "<-" not in line, line
    assert np.isclose(sim.time, t_end)


def test_disabled_bar_prints_nothing(free_block, capsys) -> None:
    """(In a notebook without ipywidgets tqdm.auto warned "IProgress not found" even when disabled;
    tests/test_notebooks.py checks that in a kernel.)"""
    sim = resting_block(free_block)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sim.run(0.002, frame_interval=0.001, progress=False)
    assert capsys.readouterr().err == ""
