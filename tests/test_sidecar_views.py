"""The sidecars' views made beside a run by a child interpreter (terrasph.sidecar_views): the files a
run leaves are those written at its end alone, whether it finishes, ends early, is interrupted or its
helper fails; the helper is used where it should be; nothing is left running when the run returns.

The leg-wheel on the RFT terrain (bodies only, frames every 0.05 s) with the helper forced on
(``MIN_VIEWS`` 1), against the sidecars written again by :func:`terrasph.io.write_xdmf` alone from
a copy of the same run file.
"""

from __future__ import annotations

import dataclasses
import glob
import os
import shutil
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
from terrasph import io, run_loop, sidecar_views
from terrasph.run_loop import END_OF_BED
from terrasph.scenes.leg_wheel import LegWheel, run_leg_wheel

CONFIG = LegWheel(terrain="rft", t_end=2.5)  #: 51 frames, the pause and half a turn
SIDECARS = (".xdmf", ".grains.xdmf", ".bodies.xdmf", ".walls.xdmf")


def force_helper(monkeypatch, wait: bool) -> list[int]:
    """The helper forced on whatever the run's size and the cores; with `wait`, the run lets it end
    by itself (all planned frames made) before it finishes; the frames it made, per run."""
    monkeypatch.setattr(sidecar_views, "MIN_VIEWS", 1)
    monkeypatch.setattr("terrasph.threads.available_cores", lambda: 2)
    made: list[int] = []
    finish = sidecar_views.SidecarViews.finish

    def counted(self) -> int:
        if wait and self._process is not None:
            self._process.wait()
        made.append(finish(self))
        return made[-1]

    monkeypatch.setattr(sidecar_views.SidecarViews, "finish", counted)
    return made


@pytest.fixture
def helper_used(monkeypatch) -> list[int]:
    """The helper forced on, left to make every planned frame."""
    return force_helper(monkeypatch, wait=True)


def children() -> list[str]:
    """The pids of this process's live children that are sidecar helpers (Linux; other tests of the
    same session may leave children of their own, a Dask cluster's say, which are not asked about)."""
    found = []
    for path in glob.glob(f"/proc/{os.getpid()}/task/*/children"):
        for pid in Path(path).read_text().split():
            try:
                command = Path(f"/proc/{pid}/cmdline").read_bytes()
            except OSError:  # ended meanwhile
                continue
            if b"terrasph.sidecar_views" in command:
                found.append(pid)
    return found


def side_contents(path: Path) -> dict[str, tuple]:
    """Every dataset of a side file: its values, shape and, for a view, the slice of the run file it maps."""
    contents = {}
    with h5py.File(path, "r") as file:
        def visit(name: str, item: object) -> None:
            if isinstance(item, h5py.Dataset):
                sources = tuple((source.file_name, source.dset_name, source.src_space.get_select_bounds())
                                for source in item.virtual_sources()) if item.is_virtual else ()
                contents[name] = (item[()].tobytes(), item.shape, sources)
        file.visititems(visit)
    return contents


def assert_sidecars_as_written_at_the_end(out: Path, tmp_path: Path) -> None:
    """The sidecars beside `out` equal those write_xdmf writes from a copy of `out` alone."""
    alone = tmp_path / "alone" / out.name
    alone.parent.mkdir()
    shutil.copy(out, alone)
    io.write_xdmf(alone)
    for suffix in SIDECARS:
        assert out.with_suffix(suffix).is_file() == alone.with_suffix(suffix).is_file(), suffix
        if out.with_suffix(suffix).is_file():
            assert out.with_suffix(suffix).read_text() == alone.with_suffix(suffix).read_text(), suffix
    assert side_contents(io.side_file(out.with_suffix(".xdmf"))) == side_contents(io.side_file(alone.with_suffix(".xdmf")))


def test_a_finished_runs_sidecars_made_beside_it_are_those_written_at_its_end(tmp_path, helper_used) -> None:
    out = tmp_path / "run.h5"
    run_leg_wheel(CONFIG, out, plot=False)
    frames = len(io.read_run(out).times)
    assert helper_used == [frames] and frames == 51  # the helper made every frame's views, as planned
    assert not children()
    assert_sidecars_as_written_at_the_end(out, tmp_path)
    meshio = pytest.importorskip("meshio")
    with meshio.xdmf.TimeSeriesReader(out.with_suffix(".bodies.xdmf")) as reader:
        reader.read_points_cells()
        assert reader.num_steps == frames
        _, data, _ = reader.read_data(frames - 1)
        np.testing.assert_array_equal(data["position_x"], io.read_run(out).fields["body_position"][-1, :, 0])


def test_a_run_stopping_its_helper_at_once_makes_the_rest_itself(tmp_path, monkeypatch) -> None:
    """The run finishes before the helper has made its frames (a short run): the helper stops after
    its chunk, the run makes the views it did not, the files are the same."""
    made = force_helper(monkeypatch, wait=False)
    out = tmp_path / "run.h5"
    run_leg_wheel(CONFIG, out, plot=False)
    assert len(made) == 1 and 0 <= made[0] <= 51 and made[0] % sidecar_views.CHUNK_FRAMES in (0, 51 % sidecar_views.CHUNK_FRAMES)
    assert not children()
    assert_sidecars_as_written_at_the_end(out, tmp_path)


def test_a_run_ending_early_drops_the_views_of_frames_it_did_not_reach(tmp_path, helper_used) -> None:
    """On a bed 0.3 m long the wheel reaches its end well before the 6 s planned (121 frames)."""
    out = tmp_path / "run.h5"
    run_leg_wheel(dataclasses.replace(CONFIG, bed_width=0.3, t_end=6.0), out, plot=False)
    data = io.read_run(out)
    assert data.group_attrs["/run"]["status"] == END_OF_BED and len(data.times) < 121
    assert helper_used == [121]  # made for the plan, then trimmed
    with h5py.File(io.side_file(out.with_suffix(".xdmf"))) as side:
        assert len(side["bodies"]) == len(data.times) + 1  # each frame's views and the connectivity
    assert not children()
    assert_sidecars_as_written_at_the_end(out, tmp_path)


def test_an_interrupted_run_stops_its_helper_and_writes_its_sidecars(tmp_path, helper_used, monkeypatch) -> None:
    class StopLater(run_loop.StopRequest):  # Ctrl-C after 100 calls into the stepper (1 s simulated)
        checks = 0

        @property
        def requested(self) -> bool:
            StopLater.checks += 1
            return StopLater.checks > 100

        @requested.setter
        def requested(self, value: bool) -> None:
            """Only the count stops the run."""

    monkeypatch.setattr(run_loop, "StopRequest", StopLater)
    out = tmp_path / "run.h5"
    with pytest.raises(KeyboardInterrupt):
        run_leg_wheel(CONFIG, out, plot=False)
    assert io.read_run(out).group_attrs["/run"]["status"] == "interrupted"
    assert helper_used == [] and not children()  # stopped, not waited for
    assert_sidecars_as_written_at_the_end(out, tmp_path)


@pytest.mark.parametrize("interpreter, said", [
    ("missing", r"the sidecars' helper cannot start \(No such file or directory\); the run writes them at its end"),
    ("false", r"the sidecars' helper failed \(exit status 1\); the run writes them instead")])
def test_a_helper_that_fails_is_said_in_one_line_and_the_run_writes_the_sidecars(tmp_path, helper_used, monkeypatch,
                                                                                  interpreter, said) -> None:
    command = sys.executable + "-missing" if interpreter == "missing" else shutil.which("false")
    if command is None:
        pytest.skip("no 'false' command")
    monkeypatch.setattr(sys, "executable", command)
    out = tmp_path / "run.h5"
    with pytest.warns(RuntimeWarning, match=said):
        run_leg_wheel(CONFIG, out, plot=False)
    assert helper_used == ([] if interpreter == "missing" else [0]) and not children()
    assert io.read_run(out).group_attrs["/run"]["status"] == "completed"
    assert_sidecars_as_written_at_the_end(out, tmp_path)


def test_a_resumed_runs_helper_makes_the_views_of_all_its_frames(tmp_path, helper_used) -> None:
    """A run continued from its checkpoint plans its earlier frames and its new ones alike."""
    out = tmp_path / "run.h5"
    run_leg_wheel(CONFIG, out, plot=False, until=1.5)
    run_leg_wheel(CONFIG, out, plot=False, resume=True, until=2.5)
    frames = len(io.read_run(out).times)
    assert frames == 51 and helper_used[-1] >= frames and not children()
    assert_sidecars_as_written_at_the_end(out, tmp_path)
