"""Tests of terrasph.plotting: figures are built headless, labelled, and saved when asked."""

from __future__ import annotations

import pathlib

import numpy as np
import pytest
from matplotlib.figure import Figure
from terrasph import plotting

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def block(nx: int = 10, nz: int = 8, spacing: float = 0.002) -> np.ndarray:
    x, z = np.meshgrid((np.arange(nx) + 0.5) * spacing, (np.arange(nz) + 0.5) * spacing)
    return np.column_stack((x.ravel(), z.ravel()))


def assert_png(path: pathlib.Path) -> None:
    assert path.read_bytes()[:8] == PNG_SIGNATURE


def test_plot_particles_with_values_and_walls(tmp_path: pathlib.Path) -> None:
    position = block()
    walls = np.column_stack((np.full(5, -0.001), np.arange(5) * 0.002))
    path = tmp_path / "particles.png"
    figure = plotting.plot_particles(position, position[:, 1] * 1e3, walls=walls, label="pressure (Pa)", path=path)
    assert isinstance(figure, Figure)
    axes, colorbar = figure.axes
    assert axes.get_aspect() == 1.0
    assert (axes.get_xlabel(), axes.get_ylabel()) == ("x (m)", "z (m)")
    assert colorbar.get_ylabel() == "pressure (Pa)"
    assert len(axes.collections) == 2  # walls + particles
    assert_png(path)


def test_plot_particles_into_given_axes() -> None:
    figure = Figure()
    ax = figure.add_subplot()
    assert plotting.plot_particles(block(), ax=ax, s=4.0) is figure
    assert ax.collections[0].get_sizes()[0] == pytest.approx(4.0)


def test_plot_profiles_series_convergence(tmp_path: pathlib.Path) -> None:
    x = np.linspace(0.0, 0.1, 11)
    figure = plotting.plot_profiles(
        [(x, 0.08 * (1 - x / 0.1), "t = 0.2 s"), (x, 0.04 * (1 - x / 0.1), "t = 0.6 s")],
        initial=(np.array([0.0, 0.07, 0.07]), np.array([0.08, 0.08, 0.0])),
        path=tmp_path / "profiles.png",
    )
    assert [text.get_text() for text in figure.axes[0].get_legend().get_texts()] == ["initial", "t = 0.2 s", "t = 0.6 s"]
    assert_png(tmp_path / "profiles.png")

    time = np.linspace(0.0, 1.0, 20)
    figure = plotting.plot_series(time, {"kinetic energy": np.exp(-time)}, ylabel="energy (J)", logy=True)
    assert figure.axes[0].get_yscale() == "log"
    assert figure.axes[0].get_xlabel() == "time (s)"

    table = [{"spacing (m)": 0.004, "L* error": 0.2}, {"spacing (m)": 0.002, "L* error": 0.08}]
    figure = plotting.plot_convergence(table, "spacing (m)", ["L* error"], path=tmp_path / "conv.png")
    assert figure.axes[0].get_xscale() == "log"
    np.testing.assert_array_equal(figure.axes[0].lines[0].get_xdata(), [0.002, 0.004])  # sorted by x
    assert_png(tmp_path / "conv.png")


def test_plot_yield_locus_reports_the_fit() -> None:
    p = np.linspace(0.0, 1000.0, 10)
    figure = plotting.plot_yield_locus(p, 0.5 * p + 20.0)
    legend = [text.get_text() for text in figure.axes[0].get_legend().get_texts()]
    assert "μ = 0.500" in legend[1] and "c = 20 Pa" in legend[1]
    assert figure.axes[0].get_xlabel() == "pressure p (Pa)"


@pytest.mark.parametrize(
    ("call", "argument"),
    [
        (lambda: plotting.plot_particles(np.zeros((4, 3))), "position"),
        (lambda: plotting.plot_particles(np.zeros((4, 2)), np.zeros(3)), "values"),
        (lambda: plotting.plot_particles(np.zeros((4, 2)), walls=np.zeros(4)), "walls"),
        (lambda: plotting.plot_profiles([]), "profiles"),
        (lambda: plotting.plot_series(np.zeros(3), {"e": np.zeros(4)}), "'e'"),
        (lambda: plotting.plot_convergence([{"a": 1.0}], "a", ["b"]), "'b'"),
        (lambda: plotting.plot_yield_locus(np.zeros(3), np.zeros(2)), "tau"),
    ],
)
def test_bad_input_names_the_argument(call, argument: str) -> None:
    with pytest.raises(ValueError, match=argument):
        call()


def test_yield_locus_draws_the_material_yield_lines_and_the_particles() -> None:
    """Each (label, μ, c) of yield_lines is the line τ = μp + c over [0, max p]; the particles are a
    scatter of their own."""
    from terrasph.plotting import plot_yield_locus

    p, tau = np.array([100.0, 400.0, 900.0]), np.array([50.0, 170.0, 360.0])
    figure = plot_yield_locus(p, tau, fit=False, particles=(p * 0.9, tau * 0.5),
                              yield_lines=[("mu1P + c", 0.38, 115.0), ("mu2P + c", 0.65, 115.0)])
    axes = figure.axes[0]
    lines = [line for line in axes.get_lines() if line.get_linestyle() == "--"]
    assert len(lines) == 2
    for line, (mu, c) in zip(lines, [(0.38, 115.0), (0.65, 115.0)]):
        x, y = line.get_data()
        assert list(x) == [0.0, 900.0] and np.allclose(y, mu * np.asarray(x) + c)
    assert len(axes.collections) == 2  # particles and locus points


def test_profiles_draw_the_bed_when_given() -> None:
    from terrasph.plotting import plot_profiles

    x = np.linspace(0.0, 0.2, 5)
    bed_z = 0.35 - np.sqrt(0.35**2 - x**2)
    figure = plot_profiles([(x, bed_z + 0.01, "deposit")], bed=(x, bed_z))
    labels = [line.get_label() for line in figure.axes[0].get_lines()]
    assert labels == ["bed", "deposit"]
    assert np.allclose(figure.axes[0].get_lines()[0].get_ydata(), bed_z)
