"""``terrasph plot RUN.h5 --profiles N --fields [--time T]``: free-surface
profiles over time and the speed, pressure and shear-strain fields of a frame, from any run file.

The run file is written here with the package's own writer: a block of grains on a lattice under
a simple shear x' = x + γ(t)z that grows with time, so the strain of every frame is known in
closed form (η = √(γ²/4 + γ⁴/12), tests/test_analysis.py).
"""

from __future__ import annotations

import numpy as np
import pytest
from terrasph import plotting
from terrasph.cli import main
from terrasph.io import RunWriter

SPACING = 0.002
TIMES = (0.0, 0.1, 0.2, 0.3)
RATE = 2.0  # γ = RATE·t


@pytest.fixture
def sheared_run(tmp_path):
    reference = np.mgrid[0:30, 0:15].reshape(2, -1).T.astype(float) * SPACING + 0.5 * SPACING
    path = tmp_path / "sheared.h5"
    with RunWriter(path, {"scene": "column-collapse", "spacing": SPACING}) as writer:
        for step, time in enumerate(TIMES):
            gamma = RATE * time
            position = reference + np.column_stack([gamma * reference[:, 1], np.zeros(len(reference))])
            velocity = np.column_stack([RATE * reference[:, 1], np.zeros(len(reference))])
            writer.write_frame(time, step, {"position": position, "velocity": velocity,
                                            "pressure": np.zeros(len(reference))})
    return path


def test_profiles_and_fields_are_written(sheared_run, capsys) -> None:
    assert main(["plot", str(sheared_run), "--force", "--profiles", "3", "--fields"]) == 0
    for suffix in (".png", ".profiles.png", ".fields.png"):
        assert sheared_run.with_suffix(suffix).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", suffix
    assert "sheared.fields.png" in capsys.readouterr().out


def test_fields_show_the_strain_of_the_frame_nearest_the_time(sheared_run, monkeypatch) -> None:
    drawn = {}

    def capture(position, fields, **kwargs):
        drawn.update(position=position, fields={label: values for values, label in fields}, **kwargs)

    monkeypatch.setattr(plotting, "plot_fields", capture)
    assert main(["plot", str(sheared_run), "--force", "--fields", "--time", "0.19"]) == 0  # nearest frame: t = 0.2
    gamma = RATE * 0.2
    strain = drawn["fields"]["shear strain η since t = 0"]
    assert np.allclose(strain, np.sqrt(gamma**2 / 4 + gamma**4 / 12), rtol=1e-9)
    assert np.allclose(drawn["fields"]["|v| (m/s)"], RATE * (drawn["position"][:, 1]), rtol=1e-12)
    assert "t = 0.2 s" in drawn["title"]


def test_time_without_fields_is_refused(sheared_run, capsys) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["plot", str(sheared_run), "--time", "0.1"])
    assert exit_info.value.code == 2
    assert "--fields" in capsys.readouterr().err


@pytest.mark.parametrize("option", [["--profiles", "0"], ["--time", "-1", "--fields"]])
def test_bad_values_are_refused_naming_the_option(sheared_run, option, capsys) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["plot", str(sheared_run), *option])
    assert exit_info.value.code == 2
    assert option[0] in capsys.readouterr().err


def test_a_robot_run_gets_its_trajectory_slip_and_sinkage_figure(tmp_path, monkeypatch) -> None:
    # `terrasph plot` of a coupled-robot run redraws the figure the run drew (plot_robot over the
    # coupled bodies), not a force series, and leaves the actuator series out
    from terrasph.robots import plots

    path = tmp_path / "robot.h5"
    with RunWriter(path, {"scene": "leg-wheel", "spacing": SPACING, "leg_wheel": {"settle_time": 0.2}}) as writer:
        writer.write_frame(0.0, 0, {"position": np.zeros((4, 2)), "velocity": np.zeros((4, 2))})
        for t in (0.0, 0.1):
            writer.append_series("robot/wheel", {"time": t, "reference": np.array([0.1 + t, 0.05]), "slip": 0.2,
                                                 "sinkage": 0.01})
            writer.append_series("robot/actuators", {"time": t, "power": 0.5})
    calls = []
    monkeypatch.setattr(plots, "plot_robot", lambda series, bodies, png, **kw: calls.append((list(bodies), kw)))
    assert main(["plot", str(path)]) == 0
    assert len(calls) == 1
    bodies, options = calls[0]
    assert bodies == ["wheel"] and options["settle_time"] == 0.2 and "leg-wheel" in options["title"]


def test_a_robot_run_on_the_rft_terrain_is_plotted_without_grains(tmp_path) -> None:
    """A leg-wheel on the RFT terrain: its frames hold no grains, and `terrasph plot` redraws its
    figure from the series all the same."""
    from terrasph.scenes.leg_wheel import LegWheel, run_leg_wheel

    path = tmp_path / "lw.h5"
    run_leg_wheel(LegWheel(terrain="rft", settle_time=0.02, t_end=0.1, frame_interval=0.05), path, plot=False)
    assert main(["plot", str(path), "--force"]) == 0 and path.with_suffix(".png").is_file()


def test_fields_leave_out_a_wall_removed_before_the_frame(sheared_run, monkeypatch) -> None:
    import h5py

    with h5py.File(sheared_run, "r+") as f:  # a floor (group 0) and a gate (group 1) removed at t = 0
        f["static/walls/position"] = np.array([[0.0, -0.001], [0.01, -0.001], [0.07, 0.01]])
        f["static/walls/group"] = np.array([0, 0, 1], dtype=np.int32)
        config = '{"scene": "column-collapse", "spacing": 0.002, "walls": [{"name": "floor", "remove_at": null}, ' \
                 '{"name": "gate", "remove_at": 0.0}]}'
        f.attrs["config_json"] = config
    drawn = {}
    monkeypatch.setattr(plotting, "plot_fields", lambda position, fields, **kw: drawn.update(kw))
    assert main(["plot", str(sheared_run), "--fields"]) == 0
    assert drawn["walls"].tolist() == [[0.0, -0.001], [0.01, -0.001]]


def test_plot_refuses_to_replace_the_runs_figure_without_force(sheared_run, capsys) -> None:
    """The figure beside the run is kept unless --force, and the refusal writes nothing."""
    png = sheared_run.with_suffix(".png")
    if not png.exists():
        assert main(["plot", str(sheared_run), "--force"]) == 0
    before = png.read_bytes()
    with pytest.raises(SystemExit) as exit_info:
        main(["plot", str(sheared_run)])
    assert exit_info.value.code == 2
    assert "--force" in capsys.readouterr().err
    assert png.read_bytes() == before
    assert main(["plot", str(sheared_run), "--force"]) == 0
