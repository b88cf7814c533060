"""docs/hdf5_schema.md against the files the scenes write (the page named
/results keys the files did not have).

Each table of the page lists names in its first column; for every table, the names it documents
must be exactly the names a real file holds. The files come from tiny versions of the three scenes
(a few seconds each): a 0.02 s column collapse, a shallow plate intrusion, and a 0.23 rad sweep of
the C-leg in a narrow bed.
"""

from __future__ import annotations

import re
from pathlib import Path

import h5py
import pytest
from terrasph.scenes.column_collapse import ColumnCollapse, run_column_collapse
from terrasph.scenes.leg_rotation import LegRotation, run_leg_rotation
from terrasph.scenes.plate_intrusion import PlateIntrusion, run_plate_intrusion

DOC = Path(__file__).resolve().parent.parent / "docs" / "hdf5_schema.md"
#: names shared by every scene's /results table ("as above" row)
COMMON_RESULTS = {"status", "time", "steps", "wall_time", "granular_particles"}


def documented(heading: str) -> set[str]:
    """Backticked names in the first column of the table(s) under `heading` (up to the next heading)."""
    text = DOC.read_text()
    start = text.index(f"\n{heading}\n")
    following = re.search(r"\n#+ ", text[start + len(heading) + 2:])
    section = text[start:start + len(heading) + 2 + (following.start() if following else len(text))]
    names: set[str] = set()
    for row in re.findall(r"^\|([^|\n]*)\|", section, re.M):
        names.update(re.findall(r"`([^`]+)`", row))
    return names


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Path]:
    out = tmp_path_factory.mktemp("schema")
    paths = {name: out / f"{name}.h5" for name in ("column-collapse", "plate-intrusion", "leg-rotation")}
    run_column_collapse(ColumnCollapse(t_end=0.02), output=paths["column-collapse"], progress=False, plot=False)
    plate = run_plate_intrusion(PlateIntrusion(bed_width=0.06, bed_depth=0.04, plate_length=0.02, max_depth=0.006,
                                               speed=0.1, settle_time=0.0),
                                output=paths["plate-intrusion"], progress=False, plot=False)
    paths["plate-result"] = plate
    run_leg_rotation(LegRotation(bed_width=0.14, bed_depth=0.07, omega=6.0, settle_time=0.0,
                                 end_angle=-0.55), output=paths["leg-rotation"], progress=False, plot=False)
    return paths


def scene_files(files) -> list[Path]:
    return [files[name] for name in ("column-collapse", "plate-intrusion", "leg-rotation")]


def test_root_attributes(files) -> None:
    with h5py.File(files["column-collapse"], "r") as f:
        names = {"version_<name>" if key.startswith("version_") else key for key in f.attrs}
    assert names == documented("## Root attributes")


def test_static_and_frame_fields(files) -> None:
    for path in scene_files(files):
        with h5py.File(path, "r") as f:
            static = set()
            f["static"].visititems(lambda name, item: static.add(f"static/{name}")  # noqa: B023 (called here)
                                   if isinstance(item, h5py.Dataset) else None)
            with_bodies = "bodies" in f["series"]
            body_names = {"static/bodies/index", "static/bodies/id", "body_position", "body_velocity"}
            expected = documented("### `/static`") | documented("### `/frames`")
            if not with_bodies:
                expected -= body_names
            frames = {f"frames/{name}" for name in f["frames"]} - {"frames/time", "frames/step"}
            assert static | {n.split("/", 1)[1] for n in frames} == expected, path.name
            assert with_bodies == (path.stem != "column-collapse")


def test_series(files) -> None:
    for path in scene_files(files):
        with h5py.File(path, "r") as f:
            assert set(f["series/diagnostics"]) == documented("#### `series/diagnostics`"), path.name
            for body in f["series"].get("bodies", {}).values():
                assert set(body) == documented("#### `series/bodies/<name>`"), path.name


def test_run_attributes_of_a_finished_run(files) -> None:
    rows = re.findall(r"^\| `(\w+)`\s*\| ([^|]+)\|", DOC.read_text().split("### `/run`")[1].split("###")[0], re.M)
    finished = {name for name, when in rows
                if when.strip() in ("every run", "finished runs", "every run but an unstable or failed one")}
    assert len(rows) == 14
    for path in scene_files(files):
        with h5py.File(path, "r") as f:
            assert set(f["run"].attrs) == finished, path.name


@pytest.mark.parametrize("scene", ["column-collapse", "leg-rotation", "plate-intrusion"])
def test_results_of_each_scene(files, scene: str) -> None:
    with h5py.File(files[scene], "r") as f:
        written = set(f["results"].attrs)
    assert written == documented(f"#### {scene}"), scene
    assert written >= COMMON_RESULTS


def test_plate_summary_fit_is_the_documented_one(files) -> None:
    """The plate's /results fit starts past the first contact (1 cm, or a quarter of a shallower
    stroke), the fit docs/benchmarks.md and the README quote; it used to start at the surface, so a
    fresh run printed other R² and α than the README."""
    from terrasph.scenes.plate_intrusion import FIT_FROM_DEPTH

    result = files["plate-result"]
    with h5py.File(files["plate-intrusion"], "r") as f:
        attrs = dict(f["results"].attrs)
    assert attrs["fit_from"] == pytest.approx(min(FIT_FROM_DEPTH, 0.25 * result.config.max_depth))
    slope, intercept, r_squared = result.fit(attrs["fit_from"])
    assert (attrs["slope"], attrs["intercept"], attrs["r_squared"]) == pytest.approx((slope, intercept, r_squared))
    assert attrs["alpha"] == pytest.approx(result.alpha(attrs["fit_from"]))


@pytest.mark.parametrize("scene", ["leg-wheel", "leg-rotation"])
def test_a_run_on_the_rft_terrain(tmp_path, scene: str) -> None:
    """The leg-wheel and the leg rotation on the RFT terrain: their /static and frame fields are the
    documented ones (the body, "wheel" or "leg", for <body>), no grains, and their diagnostics and
    the leg's series the ones the page names."""
    from terrasph.scenes.leg_wheel import LegWheel, run_leg_wheel

    path = tmp_path / "run.h5"
    if scene == "leg-wheel":
        run_leg_wheel(LegWheel(terrain="rft", settle_time=0.02, t_end=0.1, frame_interval=0.05), path, plot=False)
        body = "wheel"
    else:
        run_leg_rotation(LegRotation(terrain="rft", omega=6.0, settle_time=0.01, end_angle=-0.5, frame_interval=0.01),
                         output=path, progress=False, plot=False)
        body = "leg"
    with h5py.File(path, "r") as f:
        static = set()
        f["static"].visititems(lambda name, item: static.add(f"static/{name}".replace(f"/{body}/", "/<body>/"))
                               if isinstance(item, h5py.Dataset) else None)
        frames = set(f["frames"]) - {"time", "step"}
        assert static | frames == documented("### A terrain without grains (RFT)")
        assert set(f["series/diagnostics"]) == {"time", "step", "dt", "leaked_particles", "wall_time"}
        assert {f["run"].attrs[k] for k in ("granular_particles", "wall_particles", "leaked_particles")} == {0}
        if scene == "leg-rotation":
            assert set(f["series/bodies/leg"]) == {"time", "angle", "force", "torque"}


def test_a_robot_on_the_3d_rft_terrain(tmp_path) -> None:
    """The rover on the 3D RFT terrain: its /static and frame fields, and each coupled body's series
    (the wheels' with spin, forward speed and slip, the chassis' without), are the documented ones."""
    from terrasph.robots import ROVER4
    from terrasph.scenes.mjcf_scene import MjcfScene, run_mjcf

    path = tmp_path / "rover.h5"
    run_mjcf(MjcfScene(model=str(ROVER4), terrain="rft", element_length=0.03, settle_time=0.0, t_end=0.02,
                       ctrl=("front_left_motor=1",)), path, plot=False)
    wheel_only = {"spin", "forward_speed", "slip"}
    with h5py.File(path, "r") as f:
        names = {b for b in f["series/robot"] if b != "actuators"}
        static = set()
        f["static"].visititems(lambda name, item: static.add(
            "static/" + "/".join("<body>" if part in names else part for part in name.split("/")))
            if isinstance(item, h5py.Dataset) else None)
        assert static | (set(f["frames"]) - {"time", "step"}) == documented(
            "#### A robot on the 3D RFT terrain: `/static` and frames")
        series = documented("#### A robot on the 3D RFT terrain: `series/robot/<body>`")
        assert set(f["series/robot/front_left"]) == series and set(f["series/robot/chassis"]) == series - wheel_only
        assert f["series/robot/actuators/com"].shape[1] == 3
        assert {f["run"].attrs[k] for k in ("granular_particles", "wall_particles", "leaked_particles")} == {0}
