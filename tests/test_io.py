"""Tests of terrasph.io: HDF5 round trip, robustness to a killed writer, XDMF sidecar."""

from __future__ import annotations

import json
import os
import pathlib
import signal
import subprocess
import sys
import textwrap
import xml.etree.ElementTree as ET

import h5py
import numpy as np
import pytest
from terrasph import io

N = 12  # particles per frame
CONFIG = {"scene": "column_collapse", "spacing": 0.002, "mu1": float(np.tan(np.radians(21.0))), "walls": [0, 1]}


def frame_fields(k: int) -> dict[str, np.ndarray]:
    """Deterministic frame k with the fields the run loop writes."""
    rng = np.random.default_rng(k)
    return {
        "position": rng.uniform(0.0, 0.1, (N, 2)),
        "velocity": rng.normal(size=(N, 2)),
        "density": np.full(N, 1500.0 + k),
        "pressure": rng.uniform(0.0, 1e3, N),
        "stress": rng.normal(size=(N, 2, 2)),
    }


def write_run(path: pathlib.Path, n_frames: int = 3) -> None:
    """A small complete run file."""
    with io.RunWriter(path, CONFIG, versions={"terrasph": "0.1.0"}) as writer:
        writer.write_static("granular/mass", np.full(N, 6.0e-3))
        writer.write_static("walls/position", np.zeros((4, 2)))
        writer.write_static("walls/group", np.arange(4, dtype=np.int32))
        for k in range(n_frames):
            writer.write_frame(0.05 * k, 100 * k, frame_fields(k))
            writer.append_series(
                "diagnostics", {"time": 0.05 * k, "step": 100 * k, "dt": 1e-5, "kinetic_energy": 1.0 / (k + 1)}
            )
            writer.append_series("bodies/leg", {"time": 0.05 * k, "force": np.array([0.1 * k, -2.0])})
        writer.set_attrs("/results", {"runout_normalised": 1.25, "final_height_normalised": 0.55})


def test_round_trip(tmp_path: pathlib.Path) -> None:
    path = tmp_path / "run.h5"
    write_run(path)
    run = io.read_run(path)
    assert run.config == CONFIG
    assert run.attrs["terrasph_schema"] == io.SCHEMA_VERSION
    assert run.attrs["version_terrasph"] == "0.1.0"
    assert run.attrs["units"] == io.UNITS
    assert "created_utc" in run.attrs
    assert run.n_frames == 3
    np.testing.assert_array_equal(run.times, [0.0, 0.05, 0.1])
    np.testing.assert_array_equal(run.steps, [0, 100, 200])
    for k in range(3):
        for name, expected in frame_fields(k).items():
            np.testing.assert_array_equal(run.frame(k)[name], expected)  # bit-exact float64
    assert run.fields["stress"].shape == (3, N, 2, 2)
    np.testing.assert_array_equal(run.static["granular/mass"], np.full(N, 6.0e-3))
    assert run.static["walls/group"].dtype == np.int32
    np.testing.assert_array_equal(run.series["diagnostics"]["kinetic_energy"], [1.0, 0.5, 1.0 / 3.0])
    assert run.series["diagnostics"]["step"].dtype == np.int64
    np.testing.assert_array_equal(run.series["bodies/leg"]["force"], [[0.0, -2.0], [0.1, -2.0], [0.2, -2.0]])
    assert run.group_attrs["/results"] == {"runout_normalised": 1.25, "final_height_normalised": 0.55}
    with pytest.raises(IndexError):
        run.frame(3)


def test_frames_are_chunked_per_frame_and_compressed(tmp_path: pathlib.Path) -> None:
    path = tmp_path / "run.h5"
    write_run(path)
    with h5py.File(path, "r") as file:
        stress = file["frames/stress"]
        assert stress.chunks == (1, N, 2, 2)
        assert stress.compression is None  # a frame of 12 particles is far below RAW_FRAME_BYTES: raw
        assert stress.maxshape == (None, N, 2, 2)
        assert json.loads(file.attrs["config_json"]) == CONFIG


def test_frames_of_at_least_raw_frame_bytes_are_compressed_smaller_ones_raw(tmp_path: pathlib.Path) -> None:
    """The frames' compression follows their size (io.RAW_FRAME_BYTES): a frame of that many bytes
    is gzip-compressed with shuffle, one a particle smaller is stored raw; both read back bit for bit."""
    large = io.RAW_FRAME_BYTES // 16  # particles of an (N, 2) float64 field: exactly RAW_FRAME_BYTES
    rng = np.random.default_rng(1)
    for count, compression in ((large, "gzip"), (large - 1, None)):
        values = rng.normal(size=(count, 2))
        path = tmp_path / f"frames{count}.h5"
        with io.RunWriter(path, CONFIG) as writer:
            writer.write_frame(0.0, 0, {"position": values})
        with h5py.File(path, "r") as file:
            assert file["frames/position"].compression == compression
        np.testing.assert_array_equal(io.read_run(path).frame(0)["position"], values)


def test_frame_mismatch_names_the_field(tmp_path: pathlib.Path) -> None:
    with io.RunWriter(tmp_path / "run.h5", CONFIG) as writer:
        writer.write_frame(0.0, 0, frame_fields(0))
        bad = frame_fields(1) | {"pressure": np.zeros(N + 1)}
        with pytest.raises(ValueError, match="'pressure'"):
            writer.write_frame(0.1, 1, bad)
        missing = {name: value for name, value in frame_fields(1).items() if name != "velocity"}
        with pytest.raises(ValueError, match="'velocity'"):
            writer.write_frame(0.1, 1, missing)
        with pytest.raises(ValueError, match="'density'"):
            writer.write_frame(0.1, 1, frame_fields(1) | {"density": np.zeros(N, dtype=complex)})
        writer.append_series("diagnostics", {"dt": 1e-5})
        with pytest.raises(ValueError, match="'dt'"):
            writer.append_series("diagnostics", {"dt": np.ones(2)})
        assert writer.n_frames == 1  # the rejected frames wrote nothing


def test_rows_in_one_batch_are_the_rows_one_by_one(tmp_path: pathlib.Path) -> None:
    """append_series_rows writes what as many append_series calls write (scalars and vectors, after
    earlier rows); a batch with one bad row is refused naming the entry and writes none of its rows."""
    rng = np.random.default_rng(3)
    rows = [{"time": 0.01 * k, "force": rng.normal(size=2), "step": k} for k in range(7)]
    with io.RunWriter(tmp_path / "one.h5", CONFIG) as one, io.RunWriter(tmp_path / "batch.h5", CONFIG) as batch:
        for row in rows:
            one.append_series("bodies/leg", row)
        batch.append_series("bodies/leg", rows[0])
        batch.append_series_rows("bodies/leg", rows[1:])
        bad = [rows[0], {**rows[1], "force": np.ones(3)}]
        with pytest.raises(ValueError, match="'force'"):
            batch.append_series_rows("bodies/leg", bad)
    with h5py.File(tmp_path / "one.h5") as a, h5py.File(tmp_path / "batch.h5") as b:
        for name in ("time", "force", "step"):
            np.testing.assert_array_equal(a[f"series/bodies/leg/{name}"][()], b[f"series/bodies/leg/{name}"][()])
        assert b["series/bodies/leg/force"].shape == (7, 2)


def test_bad_arguments_are_rejected(tmp_path: pathlib.Path) -> None:
    with pytest.raises(ValueError, match="compression"):
        io.RunWriter(tmp_path / "a.h5", CONFIG, compression="zip")
    write_run(tmp_path / "b.h5", n_frames=1)
    with pytest.raises(FileExistsError):
        io.RunWriter(tmp_path / "b.h5", CONFIG, overwrite=False)
    writer = io.RunWriter(tmp_path / "c.h5", CONFIG)
    with pytest.raises(ValueError, match="'time'"):
        writer.write_frame(0.0, 0, {"time": np.zeros(3)})
    writer.close()
    with pytest.raises(ValueError, match="closed"):
        writer.write_static("x", np.zeros(3))


def test_writer_closes_on_exception(tmp_path: pathlib.Path) -> None:
    path = tmp_path / "run.h5"
    with pytest.raises(RuntimeError), io.RunWriter(path, CONFIG) as writer:
        writer.write_frame(0.0, 0, frame_fields(0))
        raise RuntimeError("simulated blow-up")
    assert writer.closed
    assert io.read_run(path).n_frames == 1


def test_killed_writer_leaves_a_readable_file(tmp_path: pathlib.Path) -> None:
    # The child writes frames, reports each one after write_frame returned, and is SIGKILLed
    # while it still holds the file open, after at least 3 frames.
    path = tmp_path / "killed.h5"
    script = textwrap.dedent(
        f"""
        import sys, time
        import numpy as np
        from terrasph import io
        writer = io.RunWriter({str(path)!r}, {{"scene": "killed"}})
        for k in range(5):
            writer.write_frame(0.1 * k, k, {{"position": np.full((50, 2), float(k)), "pressure": np.zeros(50)}})
            writer.append_series("diagnostics", {{"time": 0.1 * k}})
            print(k + 1, flush=True)
        time.sleep(60)
        """
    )
    child = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True, env=os.environ.copy())
    try:
        flushed = 0
        while flushed < 3:
            line = child.stdout.readline()
            assert line, f"writer exited early with code {child.wait()}"
            flushed = int(line)
    finally:
        child.send_signal(signal.SIGKILL)
        child.wait(timeout=10)
    assert child.returncode == -signal.SIGKILL
    run = io.read_run(path)
    assert run.n_frames >= flushed
    assert run.config == {"scene": "killed"}
    for k in range(run.n_frames):
        np.testing.assert_array_equal(run.frame(k)["position"], np.full((50, 2), float(k)))
    assert run.series["diagnostics"]["time"].size >= flushed


def test_xdmf_parses_and_references_existing_datasets(tmp_path: pathlib.Path) -> None:
    path = tmp_path / "run.h5"
    write_run(path, n_frames=4)
    xdmf = io.write_xdmf(path)
    assert xdmf == tmp_path / "run.xdmf"
    root = ET.parse(xdmf).getroot()
    assert root.get("Version") == "3.0"  # meshio refused XDMF 2 ("Unknown XDMF version 2.0")
    steps = root.findall("./Domain/Grid/Grid")
    assert len(steps) == 4
    assert [float(step.find("Time").get("Value")) for step in steps] == pytest.approx([0.0, 0.05, 0.1, 0.15])
    assert [grid.get("Name") for grid in steps[0].findall("Grid")] == ["grains", "walls"]
    grids = steps[0].findall("Grid")
    assert grids[0].find("Geometry").get("GeometryType") == "XY"
    names = {attribute.get("Name") for attribute in grids[0].findall("Attribute")}
    assert names == {"density", "pressure", "velocity_x", "velocity_z", "stress_xx", "stress_xz", "stress_zx", "stress_zz"}
    references = [item for item in root.iter("DataItem") if item.get("Format") == "HDF"]
    assert references
    with h5py.File(path, "r") as file:
        for item in references:
            filename, dataset = item.text.strip().split(":")
            assert (xdmf.parent / filename).resolve() == path.resolve()
            assert dataset in file
            assert tuple(map(int, item.get("Dimensions").split())) == file[dataset].shape


def test_frames_in_one_batch_are_the_frames_one_by_one(tmp_path: pathlib.Path) -> None:
    """write_frames writes what as many write_frame calls write (after earlier frames, each frame its
    own chunk); a batch with one bad frame is refused naming the field and writes none of its frames."""
    frames = [(0.05 * k, 100 * k, frame_fields(k)) for k in range(6)]
    with io.RunWriter(tmp_path / "one.h5", CONFIG) as one, io.RunWriter(tmp_path / "batch.h5", CONFIG) as batch:
        for frame in frames:
            one.write_frame(*frame)
        batch.write_frame(*frames[0])
        batch.write_frames(frames[1:])
        bad = [frames[0], (0.5, 500, {**frame_fields(1), "pressure": np.zeros(N + 1)})]
        with pytest.raises(ValueError, match="'pressure'"):
            batch.write_frames(bad)
    with h5py.File(tmp_path / "one.h5") as a, h5py.File(tmp_path / "batch.h5") as b:
        assert sorted(a["frames"]) == sorted(b["frames"])
        for name in a["frames"]:
            np.testing.assert_array_equal(a[f"frames/{name}"][()], b[f"frames/{name}"][()])
            assert a[f"frames/{name}"].chunks == b[f"frames/{name}"].chunks
        assert b["frames/time"].shape == (6,)


def test_every_frame_of_the_xdmf_selects_its_own_frame(tmp_path: pathlib.Path) -> None:
    """Each frame's grid of the sidecar carries that frame's time and slabs starting at its index."""
    path = tmp_path / "run.h5"
    write_run(path)
    root = ET.parse(io.write_xdmf(path)).getroot()
    with h5py.File(path, "r") as file:
        times = file["frames/time"][()]
    frames = root.findall("./Domain/Grid/Grid")
    assert len(frames) == len(times) > 2
    for k, (frame, time) in enumerate(zip(frames, times)):
        assert frame.get("Name") == f"frame_{k}" and float(frame.find("Time").get("Value")) == time
        starts = [int(item.text.split()[0]) for item in frame.iter("DataItem") if item.get("Format") == "XML"]
        assert starts and all(start == k for start in starts)


def test_xdmf_slab_selects_the_right_values(tmp_path: pathlib.Path) -> None:
    # Apply the hyperslab of frame 2's velocity_z by hand: it must equal velocity[2, :, 1].
    path = tmp_path / "run.h5"
    write_run(path)
    (tmp_path / "sub").mkdir()
    root = ET.parse(io.write_xdmf(path, tmp_path / "sub" / "view.xmf")).getroot()
    grid = root.findall("./Domain/Grid/Grid")[2].find("Grid[@Name='grains']")
    attribute = next(a for a in grid.findall("Attribute") if a.get("Name") == "velocity_z")
    selection, source = attribute.find("DataItem").findall("DataItem")
    start, stride, count = (np.array(row.split(), dtype=int) for row in selection.text.strip().splitlines())
    filename, dataset = source.text.strip().split(":")
    assert filename == os.path.join("..", "run.h5")
    with h5py.File(path, "r") as file:
        data = file[dataset][...]
    index = tuple(slice(b, b + c * s, s) for b, s, c in zip(start, stride, count))
    np.testing.assert_array_equal(data[index].ravel(), frame_fields(2)["velocity"][:, 1])


def test_xdmf_shows_bodies_with_their_index_and_the_walls(tmp_path: pathlib.Path) -> None:
    """A body (leg, plate) is a particle set of its own in every frame of the
    sidecar, with its particles' body index; the fixed walls are shown at every time."""
    path = tmp_path / "run.h5"
    with io.RunWriter(path, CONFIG) as writer:
        writer.write_static("walls/position", np.zeros((4, 2)))
        writer.write_static("bodies/index", np.array([0, 0, 1], dtype=np.int32))
        for k in range(2):
            writer.write_frame(0.1 * k, k, {**frame_fields(k), "body_position": np.full((3, 2), float(k)),
                                            "body_velocity": np.ones((3, 2))})
    root = ET.parse(io.write_xdmf(path)).getroot()
    for k, step in enumerate(root.findall("./Domain/Grid/Grid")):
        bodies = step.find("Grid[@Name='bodies']")
        assert bodies.find("Topology").get("NumberOfElements") == "3"
        names = {a.get("Name") for a in bodies.findall("Attribute")}
        assert names == {"velocity_x", "velocity_z", "body_index"}
        selection = bodies.find("Geometry/DataItem/DataItem").text.split()
        assert selection[0] == str(k)  # frame k's slab of /frames/body_position
        grains = step.find("Grid[@Name='grains']")
        assert "body_index" not in {a.get("Name") for a in grains.findall("Attribute")}
        assert step.find("Grid[@Name='walls']/Geometry/DataItem").text.endswith(":/static/walls/position")


def test_frames_of_bodies_only_are_written_read_and_shown(tmp_path: pathlib.Path) -> None:
    """A terrain without grains (RFT) writes frames of its bodies only: the file reads back with
    those frames, and the sidecar holds a bodies grid per frame and no grains grid."""
    path = tmp_path / "run.h5"
    with io.RunWriter(path, {"terrain": {"kind": "rft", "surface": 0.0}}) as writer:
        writer.write_static("bodies/index", np.zeros(3, dtype=np.int32))
        for k in range(2):
            writer.write_frame(0.1 * k, k, {"body_position": np.full((3, 2), float(k)), "body_velocity": np.ones((3, 2))})
    run = io.read_run(path)
    assert run.n_frames == 2 and set(run.fields) == {"body_position", "body_velocity"}
    assert run.frame(1)["body_position"].tolist() == [[1.0, 1.0]] * 3
    root = ET.parse(io.write_xdmf(path)).getroot()
    steps = root.findall("./Domain/Grid/Grid")
    assert len(steps) == 2
    for step in steps:
        assert [grid.get("Name") for grid in step.findall("Grid")] == ["bodies"]
    assert path.with_suffix(".bodies.xdmf").is_file() and not path.with_suffix(".grains.xdmf").exists()
