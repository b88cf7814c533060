"""``terrasph animate``: a movie of a run's frames, and its bad input.

The movie is read back with imageio: it must hold one picture per frame of the run, show
something (not a blank picture), and draw the run's body in its body colour and the walls in grey.
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest
from terrasph import animate, bodies
from terrasph.cli import main
from terrasph.config import Material, Numerics
from terrasph.io import RunWriter
from terrasph.scene import Scene
from terrasph.simulation import Simulation

imageio = pytest.importorskip("imageio.v2")

DX = 0.004
BODY_RED = np.array([214, 39, 40])  # matplotlib's tab:red, the colour of body 0
WALL_GREY = np.array([153, 153, 153])  # "0.6"


@pytest.fixture(scope="module")
def run_file(tmp_path_factory) -> Path:
    """A tiny run with a plate held above a bed in a box: a few frames of grains, walls and a body."""
    scene = Scene(spacing=DX)
    scene.add_block(0.0, 0.0, 0.08, 0.03)
    scene.add_wall("box", [(0, 0.08), (0, 0), (0.08, 0), (0.08, 0.08)], layers=3)
    scene.add_body("plate", bodies.plate(0.03, 3 * DX, 0.1, DX), reference=(0.04, 0.05))
    path = tmp_path_factory.mktemp("animate") / "run.h5"
    Simulation(scene, Material(), Numerics(spacing=DX)).run(0.003, output=path, frame_interval=0.001, progress=False)
    return path


def pictures(path: Path) -> list[np.ndarray]:
    """Every picture of a movie (iterated: an MP4 reader reports no length)."""
    return [np.asarray(picture)[..., :3] for picture in imageio.get_reader(path)]


def pixels_near(picture: np.ndarray, colour: np.ndarray, tolerance: float = 30.0) -> int:
    return int((np.linalg.norm(picture.astype(float) - colour, axis=-1) < tolerance).sum())


@pytest.mark.parametrize("suffix", [".gif", ".mp4"])
def test_one_picture_per_frame_that_shows_the_run(run_file: Path, tmp_path: Path, suffix: str) -> None:
    with h5py.File(run_file) as file:
        frames = file["frames/time"].shape[0]
    assert frames >= 4
    out = animate.animate_run(run_file, tmp_path / f"movie{suffix}", colouring="pressure", fps=10)
    movie = pictures(out)
    assert len(movie) == frames
    height, width, _ = movie[0].shape
    assert height % 16 == 0 and width % 16 == 0  # H.264 macro blocks: no rescaling by the encoder
    for picture in movie:
        assert picture.std() > 20  # not a blank picture
        if suffix == ".gif":  # lossless palette: the body and wall colours are there as drawn
            assert pixels_near(picture, BODY_RED) > 100
            assert pixels_near(picture, WALL_GREY) > 100


def test_default_output_is_an_mp4_beside_the_run(run_file: Path, tmp_path: Path) -> None:
    copy = tmp_path / "copy.h5"
    copy.write_bytes(run_file.read_bytes())
    assert main(["animate", str(copy), "--fps", "5"]) == 0
    assert len(pictures(tmp_path / "copy.mp4")) >= 4


def test_body_index_of_a_robot_run_comes_from_the_wall_groups(tmp_path: Path) -> None:
    """A robot run writes no /static/bodies/index: each body particle's index is that of the body
    named like its wall group (here two wheels after a container)."""
    config = {"spacing": DX, "walls": [{"name": "container"}, {"name": "front"}, {"name": "rear"}],
              "bodies": [{"name": "rear"}, {"name": "front"}]}
    groups = np.array([0, 0, 0, 1, 1, 2, 2, 2, 0], dtype=np.int32)
    path = tmp_path / "robot.h5"
    with RunWriter(path, config) as writer:
        writer.write_static("walls/group", groups)
        writer.write_frame(0.0, 0, {"position": np.zeros((2, 2)), "body_position": np.zeros((5, 2)),
                                    "wall_position": np.arange(18.0).reshape(9, 2)})
    with h5py.File(path) as file:
        assert animate.body_index(file).tolist() == [1, 1, 0, 0, 0]
        walls = animate.fixed_walls(file, 0, 0.0)
    assert walls.tolist() == np.arange(18.0).reshape(9, 2)[groups == 0].tolist()


def test_a_removed_wall_is_not_drawn_after_its_removal(tmp_path: Path) -> None:
    config = {"walls": [{"name": "floor", "remove_at": None}, {"name": "gate", "remove_at": 0.5}]}
    path = tmp_path / "gate.h5"
    with RunWriter(path, config) as writer:
        writer.write_static("walls/position", np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]))
        writer.write_static("walls/group", np.array([0, 0, 1]))
        writer.write_frame(0.0, 0, {"position": np.zeros((2, 2))})
    with h5py.File(path) as file:
        assert len(animate.fixed_walls(file, 0, 0.4)) == 3
        assert animate.fixed_walls(file, 0, 0.5).tolist() == [[0.0, 0.0], [1.0, 0.0]]


SAND = np.array([0xE3, 0xC9, 0x8F])  # the flat surface of a terrain without grains


def test_a_run_on_the_rft_terrain_shows_its_robot_over_the_flat_sand(tmp_path: Path) -> None:
    """An RFT run's frames hold the robot's bodies only: one picture per frame, the wheel in its body
    colour over the sand below the surface, and the wheel moves (its pixels differ between the first
    picture and the last)."""
    from terrasph.scenes.leg_wheel import LegWheel, run_leg_wheel

    run = tmp_path / "lw.h5"
    run_leg_wheel(LegWheel(terrain="rft", settle_time=0.05, t_end=0.45, frame_interval=0.1), run, plot=False)
    with h5py.File(run) as file:
        frames = file["frames/time"].shape[0]
        assert "frames/position" not in file and frames == 6  # every 0.1 s and the end
    movie = pictures(animate.animate_run(run, tmp_path / "lw.gif", fps=5))
    assert len(movie) == frames
    for picture in movie:
        assert pixels_near(picture, BODY_RED) > 500 and pixels_near(picture, SAND) > 10_000
    first, last = (np.linalg.norm(movie[k].astype(float) - BODY_RED, axis=-1) < 30 for k in (0, -1))
    assert (first != last).sum() > 100


def test_a_robot_on_the_3d_rft_terrain_is_drawn_from_the_side_over_the_sand(tmp_path: Path) -> None:
    """A non-planar robot on the 3D RFT terrain: its frames hold its bodies' surface points seen from
    the side (x–z); the movie draws the chassis (body 0) over the sand, and the rover falls onto it."""
    from terrasph.robots import ROVER4
    from terrasph.scenes.mjcf_scene import MjcfScene, run_mjcf

    run = tmp_path / "rover.h5"
    run_mjcf(MjcfScene(model=str(ROVER4), terrain="rft", element_length=0.03, settle_time=0.0, t_end=0.06,
                       frame_interval=0.02), run, plot=False)
    with h5py.File(run) as file:
        frames = file["frames/time"].shape[0]
        assert "frames/position" not in file and frames == 4 and file["frames/body_position"].shape[2] == 2
    movie = pictures(animate.animate_run(run, tmp_path / "rover.gif", fps=5))
    assert len(movie) == frames
    for picture in movie:
        assert pixels_near(picture, BODY_RED) > 500 and pixels_near(picture, SAND) > 10_000
    first, last = (np.linalg.norm(movie[k].astype(float) - BODY_RED, axis=-1) < 30 for k in (0, -1))
    assert (first != last).sum() > 100


@pytest.fixture(scope="module")
def bad_files(run_file: Path, tmp_path_factory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("animate_bad")
    no_frames = root / "no_frames.h5"
    with RunWriter(no_frames, {"scene": "empty"}):
        pass
    text = root / "notes.txt"
    text.write_text("not a run\n")
    existing = root / "existing.mp4"
    existing.write_bytes(b"precious")
    return {"root": root, "run": run_file, "no_frames": no_frames, "text": text, "existing": existing}


BAD_INPUT = [
    ("missing-file", ["{root}/nothing.h5", "--out", "{root}/m.gif"], "nothing.h5"),
    ("text-file", ["{text}", "--out", "{root}/m.gif"], "notes.txt"),
    ("file-without-frames", ["{no_frames}", "--out", "{root}/m.gif"], "no frames"),
    ("bad-color", ["{run}", "--color", "density", "--out", "{root}/m.gif"], "--color"),
    ("fps-0", ["{run}", "--fps", "0", "--out", "{root}/m.gif"], "--fps"),
    ("out-exists", ["{run}", "--out", "{existing}"], "--force"),
    ("out-unknown-format", ["{run}", "--out", "{root}/m.avi"], ".avi"),
    ("out-in-missing-dir", ["{run}", "--out", "{root}/no/dir/m.gif"], "does not exist"),
]


@pytest.mark.parametrize("argv, names", [pytest.param(argv, names, id=case) for case, argv, names in BAD_INPUT])
def test_bad_input_is_one_line_and_status_2(bad_files, capsys, argv: list[str], names: str) -> None:
    before = sorted(p.name for p in bad_files["root"].rglob("*"))
    with pytest.raises(SystemExit) as exit_info:
        main(["animate", *(arg.format(**{k: str(v) for k, v in bad_files.items()}) for arg in argv)])
    err = capsys.readouterr().err
    assert exit_info.value.code == 2, err
    assert "Traceback" not in err
    errors = [line for line in err.splitlines() if "error:" in line]
    assert len(errors) == 1 and names in errors[0], err
    assert sorted(p.name for p in bad_files["root"].rglob("*")) == before, "output left behind"
    assert bad_files["existing"].read_bytes() == b"precious"
