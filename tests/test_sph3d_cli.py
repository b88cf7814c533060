"""Granular SPH in 3D from the command line (docs/sph3d.md): ``terrasph run mjcf ROBOT.xml --terrain
sph3d`` puts any MuJoCo model on the 3D bed of ``terrasph.terrain.attach`` and writes the output
contract of every run; ``terrasph animate`` draws a slice of it.

* gymnasium's ``ant.xml``, unmodified, stands on the coarse bed (Δx = 5 cm): the grains carry its
  weight (Newton's first law for a body at rest: lift / weight within 2 %, as the attach test
  measures through Python) with no grain leaked (slow; a tiny run of the same path is fast);
* the run file's grain frames are read back by meshio (ParaView's XDMF, an independent reader) as
  3D points equal to the file's;
* the coupled run is bitwise the same on 1, 2 and 3 threads (the core's determinism).

The contract itself (status, results, checkpoint, ``terrasph resume`` bitwise after ``--until`` and
after an interrupt, an unstable run recorded) is checked for ``mjcf on sph3d`` and
``plate-intrusion-3d`` with every other scene in tests/test_output_contract.py.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import h5py
import numpy as np
import pytest
from terrasph.cli import main

ANT = os.path.join(os.path.dirname(__import__("gymnasium").__file__), "envs", "mujoco", "assets", "ant.xml")


def run_ant(out: Path, t_end: float, *extra: str) -> Path:
    """``terrasph run mjcf ant.xml --terrain sph3d`` (every body coupled: its hips stand 0.75 m high)
    to `t_end` into `out`."""
    argv = ["run", "mjcf", ANT, "--terrain", "sph3d", "--couple-below", "1", "--t-end", str(t_end),
            "--out", str(out), "--no-progress", *extra]
    assert main(argv) == 0
    return out


@pytest.fixture(scope="module")
def tiny_ant(tmp_path_factory) -> tuple[Path, dict]:
    """The ant's first 0.04 s on the bed from the command line, frames every 0.01 s, one thread."""
    out = tmp_path_factory.mktemp("ant") / "ant.h5"
    run_ant(out, 0.04, "--settle-time", "0", "--frame-interval", "0.01", "--threads", "1")
    with h5py.File(out) as file:
        summary = dict(file["results"].attrs)
    return out, summary


def test_a_tiny_ant_run_writes_the_contract(tiny_ant) -> None:
    out, summary = tiny_ant
    with h5py.File(out) as file:
        status = dict(file["run"].attrs)
        config = json.loads(file.attrs["config_json"])
        position = file["frames/position"]
        assert position.ndim == 3 and position.shape[0] == 5 and position.shape[2] == 3
        assert file["frames/body_position"].shape[2] == 3
        assert set(file["series/robot"]) >= {"torso", "left_ankle", "actuators"}
        grains = position.shape[1]
    assert status["status"] == "completed" and status["granular_particles"] == grains > 1000
    assert status["leaked_particles"] == 0 == summary["leaked_particles"]
    assert config["terrain"]["kind"] == "sph3d" and config["spacing"] == 0.05
    assert summary["terrain"] == "sph3d" and len(summary["coupled_bodies"]) == 13
    for beside in (".xdmf", ".grains.xdmf", ".bodies.xdmf", ".walls.xdmf", ".png", ".checkpoint.h5"):
        assert out.with_name(out.stem + beside).is_file(), beside


def test_paraview_reads_the_3d_frames(tiny_ant) -> None:
    """meshio's TimeSeriesReader (XDMF 3, as ParaView reads it) gives every frame's grains as XYZ
    points and velocities equal to the run file's, matched by id."""
    meshio = pytest.importorskip("meshio")
    out, _ = tiny_ant
    with h5py.File(out) as file:
        times, ids = file["frames/time"][()], file["static/granular/id"][()]
        velocity = file["frames/velocity"][()]
        first = file["frames/position"][0]
    with meshio.xdmf.TimeSeriesReader(out.with_suffix(".grains.xdmf")) as reader:
        points, _ = reader.read_points_cells()
        assert reader.num_steps == len(times) and points.shape == first.shape
        for k in range(reader.num_steps):
            time, data, _ = reader.read_data(k)
            order = np.argsort(data["id"])
            assert time == times[k] and np.array_equal(data["id"][order], np.sort(ids))
            for axis, name in enumerate("xyz"):
                np.testing.assert_array_equal(data[f"velocity_{name}"][order], velocity[k][np.argsort(ids), axis])
        np.testing.assert_array_equal(points[order], first[np.argsort(ids)])


def test_animate_draws_a_slice_of_the_bed(tiny_ant, tmp_path) -> None:
    """One picture per frame; the slice holds one layer of the bed's grains (a 3D bed shown whole would
    draw every layer on top of another)."""
    import imageio.v2 as imageio
    from terrasph import animate

    out, _ = tiny_ant
    movie = animate.animate_run(out, tmp_path / "ant.gif", fps=5)
    with h5py.File(out) as file:
        frames = file["frames/position"].shape[0]
        section = animate.Section.of(file, 0.05)
        drawn = animate.picture(file, 0, "velocity", section).grains
        layers = len(np.unique(np.round(file["frames/position"][0][:, 1], 6)))
        grains = file["frames/position"].shape[1]
    assert len(imageio.mimread(movie)) == frames
    assert drawn.shape[1] == 2 and 0 < len(drawn) <= 2 * grains / layers


@pytest.mark.slow  # about 40 s on one thread
def test_the_ant_stands_on_the_3d_bed_from_the_command_line(tmp_path) -> None:
    """3 s with its actuators idle: lift / weight over the last fifth (2.4–3 s) within 2 % of 1
    (measured 1.000), no grain leaked, the torso still."""
    out = run_ant(tmp_path / "ant.h5", 3.0, "--settle-time", "0", "--frame-interval", "0.5", "--threads", "1")
    with h5py.File(out) as file:
        summary = dict(file["results"].attrs)
        torso_speed = file["series/robot/torso/velocity"][-1]
    assert summary["lift_over_weight"] == pytest.approx(1.0, abs=0.02)
    assert summary["leaked_particles"] == 0
    assert np.linalg.norm(torso_speed) < 0.01


@pytest.mark.slow  # three runs of a few seconds each on a shared machine
def test_a_3d_coupled_run_is_the_same_on_1_2_and_3_threads(tmp_path) -> None:
    """The ant's first 0.04 s, one hip driven: every frame and robot series bitwise equal."""
    runs = []
    for threads in (1, 2, 3):
        out = run_ant(tmp_path / f"ant{threads}.h5", 0.04, "--settle-time", "0", "--ctrl", "hip_1=0.5",
                      "--frame-interval", "0.01", "--threads", str(threads))
        with h5py.File(out) as file:
            runs.append({name: file[f"frames/{name}"][()] for name in file["frames"]}
                        | {f"robot/{body}/{key}": file[f"series/robot/{body}/{key}"][()]
                           for body in file["series/robot"] for key in file[f"series/robot/{body}"]})
    for other in runs[1:]:
        assert set(other) == set(runs[0])
        for name, values in runs[0].items():
            assert np.array_equal(other[name], values, equal_nan=True), name


def test_bed_size_sets_the_3d_beds_length_and_breadth(tmp_path) -> None:
    """``--bed-size L B``: the 3D bed's grains fill L × B (to a spacing Δx, the lattice's cells
    centred inside it), centred under the coupled bodies, in place of the margin around them — here
    a bed long in x and narrow in y under the narrow leg-wheel, which no margin gives."""
    from terrasph.robots import LEG_WHEEL3D

    spacing, length, breadth = 0.005, 0.3, 0.1
    out = tmp_path / "lw.h5"
    argv = ["run", "mjcf", str(LEG_WHEEL3D), "--terrain", "sph3d", "--spacing", str(spacing), "--bed-size",
            str(length), str(breadth), "--bed-depth", "0.03", "--freeboard", "0.03", "--settle-time", "0",
            "--t-end", "0.001", "--frame-interval", "0.001", "--threads", "1", "--out", str(out), "--no-progress"]
    assert main(argv) == 0
    with h5py.File(out) as file:
        grains = file["frames/position"][0]
        bodies = file["frames/body_position"][0]
    span = grains.max(axis=0) - grains.min(axis=0)
    assert length - 2 * spacing < span[0] <= length and breadth - 2 * spacing < span[1] <= breadth, span
    middle = 0.5 * (grains.max(axis=0) + grains.min(axis=0))
    wheel = 0.5 * (bodies.max(axis=0) + bodies.min(axis=0))
    assert np.all(np.abs(middle[:2] - wheel[:2]) < spacing), (middle, wheel)
