"""The per-set XDMF 3 files that meshio reads ("meshio cannot read the XDMF").

meshio's TimeSeriesReader reads every particle set (grains, bodies) of a small run with a body, and
meshio.read the fixed walls; every frame's positions and fields must equal the run file's frames,
particle by particle matched by id, and still do after the files are moved together elsewhere.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
from terrasph import bodies, io
from terrasph.config import Material, Numerics
from terrasph.scene import Scene
from terrasph.simulation import Simulation

meshio = pytest.importorskip("meshio")

DX = 0.004


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    """A tiny run (grains in a box, a plate held above them), its sidecars moved to a new directory."""
    scene = Scene(spacing=DX)
    scene.add_block(0.0, 0.0, 0.06, 0.02)
    scene.add_wall("box", [(0, 0.06), (0, 0), (0.06, 0), (0.06, 0.06)], layers=3)
    scene.add_body("plate", bodies.plate(0.03, 3 * DX, 0.1, DX), reference=(0.03, 0.04))
    written = tmp_path_factory.mktemp("xdmf_written")
    Simulation(scene, Material(), Numerics(spacing=DX)).run(0.003, output=written / "run.h5", frame_interval=0.001,
                                                            progress=False)
    moved = tmp_path_factory.mktemp("xdmf_moved") / "copy"
    shutil.copytree(written, moved)  # references are relative: the files work wherever they are together
    shutil.rmtree(written)
    return moved


def by_id(ids: np.ndarray, values: np.ndarray) -> np.ndarray:
    return np.asarray(values)[np.argsort(ids, kind="stable")]


@pytest.mark.parametrize("particle_set, geometry, prefix, index",
                         [("grains", "position", "", "granular/id"), ("bodies", "body_position", "body_", "bodies/id")])
def test_meshio_reads_every_frame_of_a_set(run_dir: Path, particle_set: str, geometry: str, prefix: str,
                                           index: str) -> None:
    with h5py.File(run_dir / "run.h5") as file:
        times = file["frames/time"][()]
        ids = file[f"static/{index}"][()]
        of_set = [name for name in file["frames"] if name not in ("time", "step")
                  and (name.startswith(prefix) if prefix else not name.startswith("body_"))]
        frames = {name[len(prefix):]: file[f"frames/{name}"][()] for name in of_set}
        body_index = file["static/bodies/index"][()]
    assert len(times) >= 4 and len(ids) > 0
    with meshio.xdmf.TimeSeriesReader(run_dir / f"run.{particle_set}.xdmf") as reader:
        points, cells = reader.read_points_cells()
        assert reader.num_steps == len(times)
        assert cells[0].type == "vertex" and len(cells[0].data) == len(ids)
        checked = 0
        for k in range(reader.num_steps):
            time, point_data, _ = reader.read_data(k)
            assert time == times[k]
            order = np.argsort(point_data["id"])
            assert np.array_equal(point_data["id"][order], np.sort(ids))
            if k == 0:  # meshio keeps the first frame's points for the series
                np.testing.assert_array_equal(points[order], by_id(ids, frames["position"][0]))
            for name, values in frames.items():
                for suffix, component in io._component_suffixes(values.shape[2:]) if values.ndim > 2 else [("", ())]:
                    expected = values[(k, slice(None), *component)]
                    np.testing.assert_array_equal(point_data[name + suffix][order], by_id(ids, expected))
                    checked += 1
            if particle_set == "bodies":
                np.testing.assert_array_equal(point_data["body_index"][order], by_id(ids, body_index))
    # per frame: position and velocity (x, z each); grains also density, pressure and stress (4)
    assert checked == len(times) * (4 if particle_set == "bodies" else 10)


def test_meshio_reads_the_walls(run_dir: Path) -> None:
    with h5py.File(run_dir / "run.h5") as file:
        position, ids, group = (file[f"static/walls/{name}"][()] for name in ("position", "id", "group"))
    mesh = meshio.read(run_dir / "run.walls.xdmf")
    assert len(position) > 0
    np.testing.assert_array_equal(mesh.points, position)
    np.testing.assert_array_equal(mesh.point_data["id"], ids)
    np.testing.assert_array_equal(mesh.point_data["group"], group)
    assert len(mesh.cells_dict["vertex"]) == len(position)
