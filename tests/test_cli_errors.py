"""Bad input to every command ends in one line and exit status 2, before any work.

The table below is every CLI command × every kind of bad input a user met: broken model files,
inputs a model cannot read, output paths in missing directories or onto existing files, counts
and intervals out of range, thread counts < 1, and geometry the spacing cannot resolve. Each
row must exit with status 2 and print exactly one ``error:`` line naming the offending item,
without a traceback, and leave no output behind.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pytest
from terrasph.cli import main
from terrasph.robots import ROVER4

FEATURES = ["omega_cmd", "load", "soil_k", "mu"]
TARGETS = ["slip", "sinkage"]


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Path]:
    """A valid model, broken copies of it, a small dataset, a text file and an existing output."""
    torch = pytest.importorskip("torch")
    from terrasph.surrogate.export import from_torch, model_to_bytes
    from terrasph.surrogate.model import ModelConfig, SurrogateNet
    from terrasph.surrogate.synthetic import make_dataset

    root = tmp_path_factory.mktemp("cli_errors")
    torch.manual_seed(0)
    good = model_to_bytes(from_torch(SurrogateNet(ModelConfig("standard", 4, 4, 1, 2)), FEATURES, TARGETS, {}))
    other = model_to_bytes(from_torch(SurrogateNet(ModelConfig("standard", 3, 4, 1, 2)),
                                      ["x0", "x1", "x2"], TARGETS, {}))
    paths = {name: root / f"{name}.tslstm" for name in ("good", "truncated", "flipped", "empty", "other")}
    paths["good"].write_bytes(good)
    paths["truncated"].write_bytes(good[: len(good) // 2])
    flipped = bytearray(good)
    flipped[len(good) // 2] ^= 0x10
    paths["flipped"].write_bytes(bytes(flipped))
    paths["empty"].write_bytes(b"")
    paths["other"].write_bytes(other)
    paths["dataset"] = root / "dataset"
    make_dataset(paths["dataset"], n_runs=3, duration=0.2, dt=0.02)
    paths["run"] = paths["dataset"] / "wheel_0000.h5"
    paths["text"] = root / "notes.txt"
    paths["text"].write_text("not a run\n")
    paths["empty_dir"] = root / "empty_dir"
    paths["empty_dir"].mkdir()
    paths["existing"] = root / "existing.h5"
    paths["existing"].write_bytes(b"precious")
    paths["existing_csv"] = root / "existing.csv"
    paths["existing_csv"].write_text("precious")
    paths["bad_table"] = root / "bad_table.json"
    paths["bad_table"].write_text('{"format": "terrasph-rft-coefficients", "zeta": 1e5}\n')  # no coefficients
    paths["high_box"] = root / "high_box.xml"  # its one body 1 m above the floor: none near it
    paths["high_box"].write_text('<mujoco><worldbody><geom type="plane" size="1 1 0.1"/><body pos="0 0 1">'
                                 '<freejoint/><geom type="box" size="0.05 0.05 0.05"/></body></worldbody></mujoco>')
    ball = '<body pos="0 0 0.1"><freejoint/><geom type="sphere" size="0.1" mass="{mass}"/></body>'
    paths["light_ball"] = root / "light_ball.xml"  # 0.1 g displacing about 6 kg of beads
    paths["light_ball"].write_text(f'<mujoco><worldbody><geom type="plane" size="1 1 0.1"/>{ball.format(mass=1e-4)}'
                                   '</worldbody></mujoco>')
    paths["upward_gravity"] = root / "upward_gravity.xml"
    paths["upward_gravity"].write_text(f'<mujoco><option gravity="0 0 9.81"/><worldbody><geom type="plane" '
                                       f'size="1 1 0.1"/>{ball.format(mass=20)}</worldbody></mujoco>')
    paths["root"] = root
    return paths


# (id, argv with {placeholders} from `files`, text the error line must contain)
BAD_INPUT = [
    # predict: broken or missing model files
    ("predict-truncated-model", ["predict", "{truncated}", "{run}"], "truncated"),
    ("predict-bit-flipped-model", ["predict", "{flipped}", "{run}"], "CRC"),
    ("predict-empty-model", ["predict", "{empty}", "{run}"], "empty.tslstm"),
    ("predict-missing-model", ["predict", "{root}/missing.tslstm", "{run}"], "missing.tslstm"),
    # predict: inputs the model cannot read
    ("predict-text-input", ["predict", "{good}", "{text}"], "notes.txt"),
    ("predict-run-without-the-inputs", ["predict", "{other}", "{run}"], "'x0'"),
    ("predict-missing-input", ["predict", "{good}", "{root}/nothing.h5"], "nothing.h5"),
    # predict: output
    ("predict-out-in-missing-dir", ["predict", "{good}", "{run}", "--out", "{root}/no/dir/y.csv"], "does not exist"),
    ("predict-out-exists", ["predict", "{good}", "{run}", "--out", "{existing_csv}"], "--force"),
    # train
    ("train-empty-dir", ["train", "{empty_dir}", "--out", "{root}/m.tslstm", "--no-progress"], "no run files"),
    ("train-missing-dir", ["train", "{root}/nowhere", "--out", "{root}/m.tslstm", "--no-progress"], "nowhere"),
    ("train-epochs-0", ["train", "{dataset}", "--out", "{root}/m.tslstm", "--epochs", "0"], "--epochs"),
    ("train-hidden-0", ["train", "{dataset}", "--out", "{root}/m.tslstm", "--hidden", "0"], "--hidden"),
    ("train-threads-0", ["train", "{dataset}", "--out", "{root}/m.tslstm", "--torch-threads", "0"], "--torch-threads"),
    ("train-out-in-missing-dir", ["train", "{dataset}", "--out", "{root}/no/dir/m.tslstm"], "does not exist"),
    ("train-out-exists", ["train", "{dataset}", "--out", "{good}"], "--force"),
    # make-synthetic-dataset
    ("synthetic-runs-0", ["make-synthetic-dataset", "--out", "{root}/new0", "--runs", "0"], "--runs"),
    ("synthetic-dt-0", ["make-synthetic-dataset", "--out", "{root}/new1", "--dt", "0"], "--dt"),
    ("synthetic-dt-above-duration",
     ["make-synthetic-dataset", "--out", "{root}/new2", "--dt", "5", "--duration", "3"], "--dt"),
    ("synthetic-negative-duration",
     ["make-synthetic-dataset", "--out", "{root}/new3", "--duration", "-1"], "--duration"),
    ("synthetic-into-non-empty-dir", ["make-synthetic-dataset", "--out", "{dataset}", "--runs", "3"], "--force"),
    # run: threads, output, geometry
    *[(f"run-{scene}-threads-{n}", ["run", scene, "--threads", n, "--out", "{root}/r.h5"], "--threads")
      for scene in ("column-collapse", "leg-rotation", "plate-intrusion") for n in ("0", "-1")],
    *[(f"run-{scene}-out-in-missing-dir", ["run", scene, "--out", "{root}/no/dir/r.h5", "--no-progress"],
       "does not exist") for scene in ("column-collapse", "leg-rotation", "plate-intrusion")],
    *[(f"run-{scene}-out-exists", ["run", scene, "--out", "{existing}", "--no-progress"], "--force")
      for scene in ("column-collapse", "leg-rotation", "plate-intrusion")],
    ("run-column-spacing-beyond-the-column", ["run", "column-collapse", "--spacing", "1.0", "--out", "{root}/r.h5"],
     "'spacing'"),
    ("run-plate-spacing-beyond-the-plate", ["run", "plate-intrusion", "--spacing", "0.5", "--out", "{root}/r.h5"],
     "spacing"),
    ("run-unknown-option", ["run", "column-collapse", "--spacingg", "0.01"], "--spacingg"),
    ("run-column-ellipse-negative-axis", ["run", "column-collapse", "--bed", "elliptical", "--bed-axes", "0.3", "-0.1",
                                          "--out", "{root}/r.h5"], "'bed_axes'"),
    ("run-column-circle-zero-radius", ["run", "column-collapse", "--bed", "circular", "--bed-radius", "0",
                                       "--out", "{root}/r.h5"], "'bed_radius'"),
    ("run-column-water-beyond-pendular", ["run", "column-collapse", "--water-content", "0.2", "--out", "{root}/r.h5"],
     "'material.water_content'"),
    *[(f"run-{scene}-numerics-unknown-name", ["run", scene, "--numerics", "cfll=0.3", "--out", "{root}/r.h5"],
       "one of active_radius") for scene in ("column-collapse", "leg-rotation", "plate-intrusion", "leg-wheel")],
    ("run-column-numerics-out-of-range", ["run", "column-collapse", "--numerics", "cfl=1.5", "--out", "{root}/r.h5"],
     "'numerics.cfl'"),
    ("run-leg-wheel-unknown-fidelity", ["run", "leg-wheel", "--fidelity", "turbo", "--out", "{root}/r.h5"],
     "--fidelity"),
    ("run-leg-wheel-numerics-against-the-reference", ["run", "leg-wheel", "--fidelity", "reference", "--numerics",
                                                      "freeze_speed=0.001", "--out", "{root}/r.h5"],
     "contradicts fidelity 'reference'"),
    ("run-leg-wheel-numerics-not-a-number", ["run", "leg-wheel", "--numerics", "freeze_speed=fast",
                                             "--out", "{root}/r.h5"], "freeze_speed"),
    ("run-leg-wheel-active-radius-without-freeze-speed", ["run", "leg-wheel", "--numerics", "active_radius=0.1",
                                                          "--out", "{root}/r.h5"], "'numerics.active_radius'"),
    ("run-rover-numerics-spacing", ["run", "rover", "--numerics", "spacing=0.01", "--out", "{root}/r.h5"],
     "one of active_radius"),
    # the SPH bed's own settings on the RFT terrain, which has no use for them
    ("run-leg-wheel-rft-with-a-bed-friction", ["run", "leg-wheel", "--terrain", "rft", "--mu1-deg", "19",
                                               "--out", "{root}/r.h5"], "'mu1_deg'"),
    ("run-leg-wheel-rft-with-a-fidelity", ["run", "leg-wheel", "--terrain", "rft", "--fidelity", "reference",
                                           "--out", "{root}/r.h5"], "'fidelity'"),
    ("run-leg-rotation-rft-with-numerics", ["run", "leg-rotation", "--terrain", "rft", "--numerics", "cfl=0.3",
                                            "--out", "{root}/r.h5"], "'numerics'"),
    # the RFT's map on the SPH bed, which would ignore it
    ("run-leg-wheel-sph-with-an-rft-table", ["run", "leg-wheel", "--rft-table", "generic.json",
                                             "--out", "{root}/w.h5"], "invalid on the SPH terrain"),
    ("run-leg-rotation-sph-with-an-rft-table", ["run", "leg-rotation", "--rft-table", "sandy",
                                                "--out", "{root}/l.h5"], "invalid on the SPH terrain"),
    # any MJCF model on the 3D RFT terrain: the SPH's settings refused there, the RFT's on the SPH,
    # the table, the element length, a model with nothing near the floor
    ("run-mjcf-rft-with-a-spacing", ["run", "mjcf", str(ROVER4), "--terrain", "rft", "--spacing", "0.02",
                                     "--out", "{root}/r.h5"], "'spacing' (--spacing) = 0.02 is invalid on the RFT"),
    ("run-mjcf-rft-with-a-bed-width", ["run", "mjcf", str(ROVER4), "--terrain", "rft", "--bed-width", "2",
                                       "--out", "{root}/r.h5"], "'bed_width'"),
    ("run-mjcf-rft-with-numerics", ["run", "mjcf", str(ROVER4), "--terrain", "rft", "--numerics", "cfl=0.3",
                                    "--out", "{root}/r.h5"], "'numerics'"),
    ("run-mjcf-element-length-on-the-sph", ["run", "mjcf", str(ROVER4), "--element-length", "0.01",
                                            "--out", "{root}/r.h5"], "invalid on the SPH terrain"),
    ("run-mjcf-rft-unknown-table", ["run", "mjcf", str(ROVER4), "--terrain", "rft", "--rft-table", "sandy",
                                    "--out", "{root}/r.h5"], "'sandy'"),
    ("run-mjcf-rft-malformed-table", ["run", "mjcf", str(ROVER4), "--terrain", "rft", "--rft-table", "{bad_table}",
                                      "--out", "{root}/r.h5"], "bad_table.json' is malformed"),
    *[(f"run-mjcf-rft-element-length-{value}", ["run", "mjcf", str(ROVER4), "--terrain", "rft", "--element-length",
                                                 value, "--out", "{root}/r.h5"], "'element_length' (--element-length)")
      for value in ("0", "-0.01", "inf")],
    ("run-mjcf-rft-no-body-near-the-floor", ["run", "mjcf", "{high_box}", "--terrain", "rft", "--out", "{root}/r.h5",
                                             "--no-progress"], "couple_below"),
    ("run-mjcf-non-planar-on-the-sph", ["run", "mjcf", str(ROVER4), "--out", "{root}/r.h5", "--no-progress"],
     "joint 'root' is a free joint"),
    # a MuJoCo model on the 3D SPH bed: the checks of terrasph.terrain.attach, and the planar bed's settings
    ("run-mjcf-sph3d-no-body-near-the-floor", ["run", "mjcf", "{high_box}", "--terrain", "sph3d", "--out",
                                               "{root}/r.h5", "--no-progress"], "couple_below"),
    ("run-mjcf-sph3d-too-light", ["run", "mjcf", "{light_ball}", "--terrain", "sph3d", "--out", "{root}/r.h5",
                                  "--no-progress"], "too light"),
    ("run-mjcf-sph3d-gravity-up", ["run", "mjcf", "{upward_gravity}", "--terrain", "sph3d", "--out", "{root}/r.h5",
                                   "--no-progress"], "gravity"),
    ("run-mjcf-sph3d-with-a-bed-width", ["run", "mjcf", str(ROVER4), "--terrain", "sph3d", "--bed-width", "2",
                                         "--out", "{root}/r.h5"], "bed-width"),
    ("run-mjcf-sph-with-a-bed-margin", ["run", "mjcf", str(ROVER4), "--bed-margin", "0.5", "--out", "{root}/r.h5"],
     "bed-margin"),
    ("run-mjcf-unknown-terrain", ["run", "mjcf", str(ROVER4), "--terrain", "sph4d", "--out", "{root}/r.h5"],
     "--terrain"),
    ("run-plate-intrusion-3d-plate-too-wide", ["run", "plate-intrusion-3d", "--plate-length", "0.1", "--out",
                                               "{root}/r.h5"], "plate-length"),
    ("run-plate-intrusion-3d-spacing-too-fine", ["run", "plate-intrusion-3d", "--spacing", "1e-5", "--out",
                                                 "{root}/r.h5"], "spacing 1e-05 m"),
    # info and plot
    ("info-missing-file", ["info", "{root}/nothing.h5"], "nothing.h5"),
    ("info-text-file", ["info", "{text}"], "notes.txt"),
    ("plot-missing-file", ["plot", "{root}/nothing.h5"], "nothing.h5"),
]


@pytest.mark.parametrize("argv, names", [pytest.param(argv, names, id=case) for case, argv, names in BAD_INPUT])
def test_bad_input_is_one_line_and_status_2(files, capsys, argv: list[str], names: str) -> None:
    before = sorted(p.name for p in files["root"].rglob("*"))
    existing = files["existing"].read_bytes(), files["existing_csv"].read_text()
    with pytest.raises(SystemExit) as exit_info:
        main([arg.format(**{k: str(v) for k, v in files.items()}) for arg in argv])
    err = capsys.readouterr().err
    assert exit_info.value.code == 2, err
    assert "Traceback" not in err
    errors = [line for line in err.splitlines() if "error:" in line]
    assert len(errors) == 1, err
    assert names in errors[0], err
    assert sorted(p.name for p in files["root"].rglob("*")) == before, "output left behind"
    assert (files["existing"].read_bytes(), files["existing_csv"].read_text()) == existing


def test_force_replaces_an_existing_output(files, tmp_path, capsys) -> None:
    out = tmp_path / "y.csv"
    out.write_text("old")
    assert main(["predict", str(files["good"]), str(files["run"]), "--out", str(out), "--force"]) == 0
    header = out.read_text().splitlines()[0]
    assert header == "sequence,step," + ",".join(TARGETS)


def test_force_into_a_dataset_directory_leaves_exactly_the_new_runs(tmp_path) -> None:
    """--force removes the runs of an earlier, larger dataset instead of mixing the two."""
    out = tmp_path / "data"
    assert main(["make-synthetic-dataset", "--out", str(out), "--runs", "4", "--duration", "0.2"]) == 0
    assert main(["make-synthetic-dataset", "--out", str(out), "--runs", "2", "--duration", "0.2", "--force"]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["wheel_0000.h5", "wheel_0001.h5"]


def test_lattice_refuses_a_block_it_cannot_resolve() -> None:
    """From Python too: Scene(spacing=0.1).add_block of a 7 × 8 cm column used to place one grain
    whose cell reaches outside it; a block needs at least two particles across each side."""
    from terrasph.config import ConfigError
    from terrasph.geometry import MIN_PARTICLES_ACROSS, lattice_block
    from terrasph.scene import Scene

    with pytest.raises(ConfigError, match=r"'spacing'.*allowed spacing <= 0\.035"):
        Scene(spacing=0.1).add_block(0.0, 0.0, 0.07, 0.08)
    block = lattice_block(0.0, 0.0, 0.07, 0.08, 0.035)
    assert len(block) == MIN_PARTICLES_ACROSS**2
    # every particle's cell lies inside the requested rectangle, up to the Δx/2 rounding
    assert np.all(block - 0.0175 >= -1e-12) and np.all(block[:, 0] + 0.0175 <= 0.07 + 1e-12)


# -- help and options (item 9) ---------------------------------------------------------------------
def _leaf_parsers():
    """Every (sub-)command's parser."""
    from terrasph.cli import build_parser

    def leaves(parser):
        for action in parser._actions:
            if isinstance(action.choices, dict):
                for child in action.choices.values():
                    yield from leaves(child)
        yield parser

    return list(leaves(build_parser()))


def test_every_option_has_help_that_states_its_default() -> None:
    """Every option has help, and every option with a default value says it in its help text."""
    checked = 0
    for parser in _leaf_parsers():
        formatter = parser._get_formatter()
        for action in parser._actions:
            if (not action.option_strings or action.default in (None, False)
                    or isinstance(action, (argparse._HelpAction, argparse._VersionAction))):
                continue  # a scene option's default is SUPPRESS: its configuration's default applies
            assert action.help, f"{parser.prog} {action.option_strings[0]} has no help"
            assert "default" in formatter._expand_help(action), f"{parser.prog} {action.option_strings[0]}"
            checked += 1
    assert checked >= 30  # the scenes' and the surrogate commands' options


def test_unknown_option_names_the_sub_command_in_one_line(capsys) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["run", "leg-rotation", "--omegaa", "1"])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("terrasph run leg-rotation: error:") and len(err.splitlines()) == 1
    assert "--omegaa" in err


def test_version(capsys) -> None:
    from terrasph import __version__

    with pytest.raises(SystemExit) as exit_info:
        main(["--version"])
    assert exit_info.value.code == 0
    assert capsys.readouterr().out.strip() == f"terrasph {__version__}"


def test_plate_resolution_sets_the_spacing(monkeypatch) -> None:
    """--resolution fine runs the plate scene at RESOLUTIONS['fine'] (the run itself is replaced)."""
    from terrasph import scenes_cli
    from terrasph.scenes.plate_intrusion import RESOLUTIONS

    seen = {}

    def fake_run_case(scene, config, out, *, progress=False):
        seen["spacing"] = config.spacing
        raise KeyboardInterrupt

    monkeypatch.setattr(scenes_cli, "run_case", fake_run_case)
    with pytest.raises(SystemExit):
        main(["run", "plate-intrusion", "--resolution", "fine", "--out", "unused.h5"])
    assert seen["spacing"] == RESOLUTIONS["fine"] != RESOLUTIONS["coarse"]


@pytest.mark.parametrize("scene", ["column-collapse", "leg-wheel"])
def test_numerics_reach_the_scene(monkeypatch, scene: str) -> None:
    """--numerics NAME=VALUE ... lands in the scene configuration's numerics (the run is replaced)."""
    from terrasph import scenes_cli

    seen = {}

    def fake_run_case(scene, config, out, *, progress=False):
        seen["numerics"] = config.numerics
        raise KeyboardInterrupt

    monkeypatch.setattr(scenes_cli, "run_case", fake_run_case)
    with pytest.raises((SystemExit, KeyboardInterrupt)):
        main(["run", scene, "--numerics", "cfl=0.9", "freeze_speed=0.005", "--out", "unused.h5"])
    assert seen["numerics"] == {"cfl": 0.9, "freeze_speed": 0.005}


def test_plate_model_reaches_the_scene(monkeypatch) -> None:
    """run plate-intrusion --material-model drucker_prager builds the beads with that model (the run is replaced)."""
    from terrasph import scenes_cli

    seen = {}

    def fake_run_case(scene, config, out, *, progress=False):
        seen["model"] = config.material().model
        raise KeyboardInterrupt

    monkeypatch.setattr(scenes_cli, "run_case", fake_run_case)
    with pytest.raises((SystemExit, KeyboardInterrupt)):
        main(["run", "plate-intrusion", "--material-model", "drucker_prager", "--out", "unused.h5"])
    assert seen["model"] == "drucker_prager"
