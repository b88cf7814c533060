"""``terrasph animate RUN.h5``: a movie (MP4 or GIF) of any run file with frames.

Grains are coloured by their speed |v| or their pressure on one colour scale for the whole movie,
fixed walls are grey, and the particles of each body (leg, plate, leg-wheel, rover wheel) are drawn
in a colour of their own by body index; for a coupled robot run, each coupled body's reference
point (the axle) is marked from ``/series/robot/<body>/reference``. A run on a terrain without
grains (resistive force theory, docs/rft.md) has frames of its bodies only: its flat free surface
(``config_json``'s ``terrain.surface``) is drawn as sand below that level (a robot on the 3D RFT
terrain seen from the side: its bodies' surface points in x–z). A 3D run (granular SPH in 3D,
docs/sph3d.md) is shown as a slice seen from the side (−y): the grains and fixed walls within 3/4 of a
spacing of the plane y = y_c through the middle of the grains (the first frame's y extent; one or
two layers), with every body particle projected onto the x–z plane over them, so a body off the
slice is still seen. Each picture is a matplotlib figure (no pyplot) rendered with Agg and encoded
by imageio: MP4 through imageio-ffmpeg (which ships the ffmpeg encoder on PyPI), GIF through
imageio's pillow plugin.
"""

from __future__ import annotations

import argparse
import json
import math
import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from terrasph.cli_common import add_force_option, check_output_file, positive_int

__all__ = ["COLOURINGS", "FORMATS", "animate_run", "register"]

#: what the grains can be coloured by: frame field and colour-bar label
COLOURINGS = {"velocity": "speed |v| (m/s)", "pressure": "pressure (Pa)"}
#: output suffixes and the imageio plugin that writes each
FORMATS = {".mp4": "FFMPEG", ".gif": "GIF"}
_WALL_COLOUR = "0.6"
_SAND_COLOUR = "#e3c98f"
_BODY_COLOURS = ("tab:red", "tab:orange", "tab:purple", "tab:brown", "tab:pink", "tab:cyan")
_AXES_WIDTH_PX = 780
_MIN_AXES_HEIGHT_PX = 160
_MAX_AXES_HEIGHT_PX = 900
_MARGINS_PX = (80, 110, 56, 40)  # left, right (colour bar), bottom, top (time stamp)
_DPI = 100
_MACRO_BLOCK = 16  # H.264 wants frame sides divisible by 16


@dataclass(frozen=True)
class Section:
    """The slice of a 3D run that its movie shows: the particles with |y − `centre`| ≤ `half_width` (m)."""

    centre: float
    half_width: float

    @classmethod
    def of(cls, file: h5py.File, spacing: float) -> Section | None:
        """The slice through the middle of the first frame's grains (of its bodies, without grains),
        three quarters of a spacing either side: the one or two lattice layers nearest the middle, a
        quarter spacing clear of the next (so grains do not flicker in and out); None for a planar run."""
        points = file["frames/position"][0] if has_grains(file) else file["frames/body_position"][0]
        if points.shape[-1] != 3:
            return None
        return cls(0.5 * float(points[:, 1].min() + points[:, 1].max()), 0.75 * spacing)

    def inside(self, points: np.ndarray) -> np.ndarray:
        """Which of the (N, 3) `points` lie in the slice."""
        return np.abs(points[:, 1] - self.centre) <= self.half_width

    def describe(self) -> str:
        """The slice, for the pictures' time stamp."""
        return f"slice |y − {round(self.centre, 9) + 0.0:.3g}| ≤ {self.half_width:.2g} m"


@dataclass(frozen=True)
class Picture:
    """One frame's particles as drawn: grains with their colour values, walls, bodies, axles."""

    time: float
    grains: np.ndarray  #: (N, 2) m
    values: np.ndarray  #: (N,) speed in m/s or pressure in Pa
    walls: np.ndarray  #: (M, 2) m, fixed walls present at `time`
    bodies: np.ndarray  #: (B, 2) m
    axles: np.ndarray  #: (R, 2) m, reference points of a robot's coupled bodies


# -- reading a run file ------------------------------------------------------------------------

def open_run(path: str | os.PathLike[str]) -> h5py.File:
    """The run file at `path`, checked to hold at least one frame of grain or body positions.

    Raises FileNotFoundError, OSError (not HDF5) or ValueError (no frames), each naming the file.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such run file")
    try:
        file = h5py.File(path, "r")
    except OSError as error:
        raise OSError(f"{path}: not a readable terrasph run file ({error})") from None
    position = file.get("frames/position", file.get("frames/body_position"))
    if "config_json" not in file.attrs or position is None or position.shape[0] == 0:
        file.close()
        raise ValueError(f"{path}: no frames to animate (a run file with frames has /frames/position "
                         "or /frames/body_position)")
    return file


def frame_count(file: h5py.File) -> int:
    """Complete frames in the file (an interrupted run may have one field longer than the others)."""
    return min(dataset.shape[0] for dataset in file["frames"].values())


def has_grains(file: h5py.File) -> bool:
    """Whether the frames hold grains (a terrain without them, RFT, writes its bodies only)."""
    return "frames/position" in file


def colour_values(file: h5py.File, k: int, colouring: str) -> np.ndarray:
    """Per-grain colour values of frame `k`: |v| (m/s) or pressure (Pa); none without grains."""
    if not has_grains(file):
        return np.zeros(0)
    if colouring == "velocity":
        return np.linalg.norm(file["frames/velocity"][k], axis=1)
    return np.asarray(file["frames/pressure"][k], dtype=float)


def colour_limits(file: h5py.File, colouring: str) -> tuple[float, float]:
    """One colour scale for the whole movie: 0 to the largest 99th percentile over the frames (so a
    few fast splashes do not wash out the bed)."""
    if not has_grains(file):
        return 0.0, 1.0
    top = max(float(np.percentile(colour_values(file, k, colouring), 99)) for k in range(frame_count(file)))
    return 0.0, top if top > 0 else 1.0


def _config(file: h5py.File) -> dict[str, Any]:
    return json.loads(file.attrs["config_json"])


def _wall_groups(file: h5py.File) -> np.ndarray | None:
    group = file.get("static/walls/group")
    return None if group is None else group[()]


def body_index(file: h5py.File) -> np.ndarray:
    """Body index of each row of ``/frames/body_position``: ``/static/bodies/index`` when written;
    for a robot run (which lacks it) from the wall groups named after the configuration's bodies."""
    if "frames/body_position" not in file:
        return np.zeros(0, dtype=int)
    count = file["frames/body_position"].shape[1]
    if "static/bodies/index" in file:
        return file["static/bodies/index"][()].astype(int)
    config, groups = _config(file), _wall_groups(file)
    bodies = [body["name"] for body in config.get("bodies", [])]
    walls = [wall["name"] for wall in config.get("walls", [])]
    if groups is not None and walls and bodies:
        on_body = [walls[g] in bodies if g < len(walls) else False for g in groups]
        index = np.array([bodies.index(walls[g]) for g, hit in zip(groups, on_body) if hit], dtype=int)
        if index.shape == (count,):
            return index
    return np.zeros(count, dtype=int)


def fixed_walls(file: h5py.File, k: int, time: float) -> np.ndarray:
    """Fixed wall particles present at frame `k` (a wall with ``remove_at`` is gone from then on):
    ``/static/walls/position``, or the non-body rows of a robot run's ``/frames/wall_position``."""
    config, groups = _config(file), _wall_groups(file)
    walls = config.get("walls", [])
    if "static/walls/position" in file:
        position = file["static/walls/position"][()]
        if groups is None or groups.shape[0] != position.shape[0]:
            return position
        removed = {i for i, wall in enumerate(walls) if wall.get("remove_at") is not None and time >= wall["remove_at"]}
        return position[~np.isin(groups, list(removed))]
    if "frames/wall_position" in file:
        position = file["frames/wall_position"][k]
        bodies = {body["name"] for body in config.get("bodies", [])}
        if groups is None or groups.shape[0] != position.shape[0]:
            return position
        on_body = np.array([g < len(walls) and walls[g]["name"] in bodies for g in groups], dtype=bool)
        return position[~on_body]
    return np.zeros((0, 2))


def robot_axles(file: h5py.File, time: float) -> np.ndarray:
    """Reference points (axles) of a planar robot run's coupled bodies at `time`, interpolated in their
    ``/series/robot/<body>/reference`` series; none for other runs."""
    robot = file.get("series/robot")
    points = []
    for group in (robot.values() if robot is not None else []):
        if isinstance(group, h5py.Group) and "reference" in group and "time" in group and group["time"].shape[0]:
            times, reference = group["time"][()], group["reference"][()]
            rows = min(len(times), len(reference))
            points.append([np.interp(time, times[:rows], reference[:rows, axis]) for axis in (0, 1)])
    return np.array(points, dtype=float).reshape(-1, 2)


def picture(file: h5py.File, k: int, colouring: str, section: Section | None = None) -> Picture:
    """Everything drawn for frame `k`; of a 3D run, its `section` (x–z coordinates)."""
    time = float(file["frames/time"][k])
    bodies = file["frames/body_position"][k] if "frames/body_position" in file else np.zeros((0, 2))
    grains = file["frames/position"][k] if has_grains(file) else np.zeros((0, 2))
    values, walls = colour_values(file, k, colouring), fixed_walls(file, k, time)
    if section is not None:
        kept = section.inside(grains)
        grains, values = grains[kept][:, [0, 2]], values[kept]
        walls = walls[section.inside(walls)][:, [0, 2]]
        bodies = bodies[:, [0, 2]]
    return Picture(time=time, grains=grains, values=values, walls=walls, bodies=bodies,
                   axles=robot_axles(file, time))


def flat_surface(file: h5py.File) -> float | None:
    """The free surface z (m) of a run on a terrain without grains (``config_json``'s
    ``terrain.surface`` of a planar or 3D RFT run); None for a run whose grains are the terrain."""
    terrain = _config(file).get("terrain")
    grain_free = isinstance(terrain, dict) and terrain.get("kind") in ("rft", "rft3d")
    return float(terrain["surface"]) if grain_free else None


def view_points(file: h5py.File, first: Picture, section: Section | None = None) -> np.ndarray:
    """The points the view must hold: the first frame's walls, grains and bodies; without grains (the
    bed does not frame the picture) the bodies of every frame, so a travelling robot stays in view
    (of a 3D run, with its `section`, in x–z)."""
    if has_grains(file) or "frames/body_position" not in file:
        return np.concatenate([first.grains, first.walls, first.bodies])
    frames = file["frames/body_position"][:frame_count(file)]
    return np.concatenate([first.walls, *(frames[..., [0, 2]] if section else frames)])


def view_box(points: np.ndarray, spacing: float) -> tuple[float, float, float, float]:
    """x and z limits that hold `points` (:func:`view_points`), with a margin of 3 Δx and 10 %
    headroom above for grains and bodies that rise (splashes, a climbing wheel)."""
    low, high = points.min(axis=0) - 3 * spacing, points.max(axis=0) + 3 * spacing
    headroom = 0.1 * (high[1] - low[1])
    return float(low[0]), float(high[0]), float(low[1]), float(high[1] + headroom)


# -- drawing -----------------------------------------------------------------------------------

class Canvas:
    """A figure whose artists are updated frame by frame and rendered to RGB arrays."""

    def __init__(self, box: tuple[float, float, float, float], spacing: float, colouring: str,
                 limits: tuple[float, float], body_index: np.ndarray, surface: float | None = None,
                 caption: str = "") -> None:
        (x0, x1, z0, z1), (width_px, height_px), axes_frame = layout(box)
        self.figure = Figure(figsize=(width_px / _DPI, height_px / _DPI), dpi=_DPI)
        FigureCanvasAgg(self.figure)
        axes = self.figure.add_axes(axes_frame)
        axes.set_xlim(x0, x1)
        axes.set_ylim(z0, z1)
        axes.set_xlabel("x (m)")
        axes.set_ylabel("z (m)")
        size = marker_area(spacing, x1 - x0, width_px * axes_frame[2])
        empty = np.zeros((0, 2))
        if surface is not None:  # a terrain without grains: its flat sand, the same in every picture
            axes.axhspan(z0, surface, color=_SAND_COLOUR, linewidth=0)
            axes.axhline(surface, color="k", linewidth=0.8)
        self.walls = axes.scatter(*empty.T, s=size, c=_WALL_COLOUR, marker="s", linewidths=0)
        self.grains = axes.scatter(*empty.T, s=size, c=[], cmap="viridis", vmin=limits[0], vmax=limits[1],
                                   linewidths=0)
        body_colours = [_BODY_COLOURS[i % len(_BODY_COLOURS)] for i in body_index]
        self.bodies = axes.scatter(*np.zeros((len(body_index), 2)).T, s=size, c=body_colours or "tab:red",
                                   marker="s", linewidths=0)
        self.axles = axes.scatter(*empty.T, s=80, c="k", marker="+", linewidths=1.5)
        if surface is None:
            bar_frame = (axes_frame[0] + axes_frame[2] + 16 / width_px, axes_frame[1], 16 / width_px, axes_frame[3])
            self.figure.colorbar(self.grains, cax=self.figure.add_axes(bar_frame),
                                 label=COLOURINGS[colouring])
        self.stamp = axes.set_title("")
        self.caption = caption  # after the time stamp: a 3D run's slice
        self.axes = axes
        # blitting: axes, ticks, labels and colour bar are drawn once; each frame only the particles
        # and the time stamp (drawing the axes took two thirds of a frame's time)
        self.changing = (self.walls, self.grains, self.bodies, self.axles, self.stamp)
        for artist in self.changing:
            artist.set_animated(True)
        self.figure.canvas.draw()
        self.background = self.figure.canvas.copy_from_bbox(self.figure.bbox)

    def render(self, frame: Picture) -> np.ndarray:
        """The figure of `frame` as an (H, W, 3) uint8 array."""
        self.walls.set_offsets(frame.walls)
        self.grains.set_offsets(frame.grains)
        self.grains.set_array(frame.values)
        self.bodies.set_offsets(frame.bodies)
        self.axles.set_offsets(frame.axles)
        self.stamp.set_text(f"t = {frame.time:.3f} s" + (f", {self.caption}" if self.caption else ""))
        self.figure.canvas.restore_region(self.background)
        for artist in self.changing:
            self.axes.draw_artist(artist)
        return np.asarray(self.figure.canvas.buffer_rgba())[..., :3].copy()


def layout(box: tuple[float, float, float, float]) -> tuple[tuple[float, float, float, float], tuple[int, int],
                                                     tuple[float, float, float, float]]:
    """Axis limits, picture size in pixels (sides multiples of 16) and axes rectangle (figure
    fractions) that show `box` at equal scale in x and z: the axes are _AXES_WIDTH_PX wide, or less
    for a tall box whose height would pass _MAX_AXES_HEIGHT_PX; a limit is extended to fill them."""
    x0, x1, z0, z1 = box
    left, right, bottom, top = _MARGINS_PX
    axes_width = float(_AXES_WIDTH_PX)
    axes_height = axes_width * (z1 - z0) / (x1 - x0)
    if axes_height > _MAX_AXES_HEIGHT_PX:
        axes_height = float(_MAX_AXES_HEIGHT_PX)
        axes_width = axes_height * (x1 - x0) / (z1 - z0)
    width = _MACRO_BLOCK * math.ceil((axes_width + left + right) / _MACRO_BLOCK)
    height = _MACRO_BLOCK * math.ceil((max(axes_height, _MIN_AXES_HEIGHT_PX) + bottom + top) / _MACRO_BLOCK)
    axes_width, axes_height = width - left - right, height - bottom - top
    metres_per_px = max((x1 - x0) / axes_width, (z1 - z0) / axes_height)
    limits = (x0, x0 + metres_per_px * axes_width, z0, z0 + metres_per_px * axes_height)
    return limits, (width, height), (left / width, bottom / height, axes_width / width, axes_height / height)


def marker_area(spacing: float, data_width: float, axes_width_px: float) -> float:
    """Scatter marker area (points²) of a particle Δx across, so neighbouring particles touch."""
    diameter = spacing * axes_width_px / data_width * 72.0 / _DPI
    return float(max(diameter, 0.5) ** 2)


def pictures(file: h5py.File, colouring: str, section: Section | None = None) -> Iterator[Picture]:
    """The run's frames in order (of a 3D run, its `section`)."""
    for k in range(frame_count(file)):
        yield picture(file, k, colouring, section)


# -- writing -----------------------------------------------------------------------------------

def check_output(out: str | os.PathLike[str], force: bool) -> Path:
    """The output path, refused (before any work) for an unknown suffix, a missing directory, an
    existing file without `force`, or MP4 without the imageio-ffmpeg encoder."""
    out = Path(out)
    if out.suffix.lower() not in FORMATS:
        raise ValueError(f"--out {out}: unknown movie format {out.suffix!r}; allowed {', '.join(FORMATS)}")
    check_output_file(out, force)
    if out.suffix.lower() == ".mp4":
        try:
            import imageio_ffmpeg  # noqa: F401  (the ffmpeg binary imageio uses for MP4)
        except ImportError:
            raise ValueError(f"--out {out}: MP4 needs the imageio-ffmpeg package "
                             "(pip install imageio-ffmpeg), or write a .gif") from None
    return out


def _writer(out: Path, fps: int) -> Any:
    """An imageio writer of `out` at `fps` pictures per second."""
    import imageio.v2 as imageio

    if out.suffix.lower() == ".gif":
        return imageio.get_writer(out, format="GIF", mode="I", duration=1000.0 / fps, loop=0)
    return imageio.get_writer(out, format="FFMPEG", mode="I", fps=fps, codec="libx264", pixelformat="yuv420p",
                              macro_block_size=_MACRO_BLOCK, quality=8, ffmpeg_log_level="error")


def animate_run(run: str | os.PathLike[str], out: str | os.PathLike[str] | None = None, *,
                colouring: str = "velocity", fps: int = 20, force: bool = False, progress: bool = False) -> Path:
    """Writes a movie of the frames of `run` to `out` (default: the run file with suffix ``.mp4``);
    returns its path. One picture per frame, played at `fps` pictures per second; `progress` shows
    a progress bar over the frames.

    Raises (before any work): ValueError for a bad `colouring`, `fps` < 1, an unknown suffix or a
    file without frames; FileNotFoundError / FileExistsError for a missing run file, a missing
    output directory or an existing output without `force`.
    """
    if colouring not in COLOURINGS:
        raise ValueError(f"colouring {colouring!r} is invalid: allowed {', '.join(COLOURINGS)}")
    if isinstance(fps, bool) or not isinstance(fps, int) or fps < 1:
        raise ValueError(f"fps = {fps!r} is invalid: allowed an integer >= 1")
    out = check_output(Path(run).with_suffix(".mp4") if out is None else out, force)
    with open_run(run) as file:
        field = "frames/velocity" if colouring == "velocity" else "frames/pressure"
        if has_grains(file) and field not in file:
            raise ValueError(f"{run}: no {field} to colour by {colouring}")
        first = picture(file, 0, colouring)
        spacing = float(_config(file).get("spacing")
                        or (_typical_spacing(first.grains) if has_grains(file) else _lattice_spacing(first.bodies)))
        section = Section.of(file, spacing)
        first = picture(file, 0, colouring, section)
        canvas = Canvas(view_box(view_points(file, first, section), spacing), spacing, colouring,
                        colour_limits(file, colouring), body_index(file), flat_surface(file),
                        section.describe() if section else "")
        from tqdm.auto import tqdm

        try:
            with _writer(out, fps) as writer:
                for frame in tqdm(pictures(file, colouring, section), total=frame_count(file), unit="frame",
                                  disable=not progress, mininterval=0.5, desc=out.name):
                    writer.append_data(canvas.render(frame))
        except BaseException:
            out.unlink(missing_ok=True)  # no half-written movie left behind
            raise
    return out


def _typical_spacing(position: np.ndarray) -> float:
    """Δx estimated from the grains' bounding box and count (for files whose config lacks it)."""
    extent = np.ptp(position, axis=0)
    return float(np.sqrt(max(extent[0] * extent[1], 1e-12) / len(position)))


def _lattice_spacing(points: np.ndarray, samples: int = 64) -> float:
    """Δx of particles on a lattice (a body's, at any pose): the median distance from up to `samples`
    of them, spread over the array, to their nearest neighbour."""
    chosen = points[np.linspace(0, len(points) - 1, min(samples, len(points))).astype(int)]
    distance = np.linalg.norm(chosen[:, None, :] - points[None, :, :], axis=-1)
    distance[distance == 0] = np.inf
    return float(np.median(distance.min(axis=1)))


# -- command line ------------------------------------------------------------------------------

def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Adds the ``animate`` command."""
    parser = subparsers.add_parser(
        "animate", help="write a movie (MP4 or GIF) of a run's frames",
        description="Write a movie of the frames of RUN.h5: grains coloured by speed or pressure, walls grey, "
                    "each body in its own colour, a robot's axles marked, the time in the title. MP4 is "
                    "encoded by imageio-ffmpeg, GIF by imageio's pillow plugin.")
    parser.add_argument("run", metavar="RUN.h5", type=Path)
    parser.add_argument("--out", type=Path, default=None,
                        help="movie file, .mp4 or .gif (default: RUN with suffix .mp4)")
    parser.add_argument("--color", choices=tuple(COLOURINGS), default="velocity",
                        help="colour the grains by speed |v| or by pressure (default %(default)s)")
    parser.add_argument("--fps", type=positive_int, default=20,
                        help="pictures per second, one picture per frame (default %(default)s)")
    add_force_option(parser)
    parser.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    parser.set_defaults(handler=_cmd_animate)


def _cmd_animate(args: argparse.Namespace) -> int:
    out = animate_run(args.run, args.out, colouring=args.color, fps=args.fps, force=args.force,
                      progress=not args.no_progress)
    print(f"wrote {out}")
    return 0
