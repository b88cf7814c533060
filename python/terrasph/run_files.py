"""``terrasph info RUN.h5`` and ``terrasph plot RUN.h5``: what a run file holds, and its figures
and ParaView sidecar regenerated from it — for finished, interrupted and unstable runs alike."""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from terrasph.cli_common import add_force_option, check_output_file, positive_float, positive_int
from terrasph.io import RunData, read_run, write_xdmf
from terrasph.run_loop import END_OF_BED, FINISHED_STATUSES

__all__ = ["describe_run", "plot_fields", "plot_profiles_over_time", "plot_run", "register"]


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Adds the ``info`` and ``plot`` commands."""
    info = subparsers.add_parser("info", help="configuration, status, time reached and results of a run file",
                                 description="Print what a run file holds: scene, status (completed, at_rest, "
                                             "end_of_bed, interrupted, unstable), time and steps reached, frames, "
                                             "reason, results.")
    info.add_argument("run", metavar="RUN.h5", type=Path)
    info.add_argument("--json", action="store_true", help="print the same as JSON")
    info.set_defaults(handler=_cmd_info)
    plot = subparsers.add_parser("plot", help="write a run's figure (PNG) and XDMF sidecar from its file",
                                 description="Write RUN.png (the scene's figure: the surface profile of a collapse, "
                                             "body loads of a leg or plate, trajectory, slip and sinkage of a "
                                             "robot, else the last frame) and RUN.xdmf "
                                             "beside RUN.h5 (replacing them only with --force); works for "
                                             "interrupted and unstable runs too.")
    plot.add_argument("run", metavar="RUN.h5", type=Path)
    plot.add_argument("--profiles", type=positive_int, metavar="N",
                      help="also write RUN.profiles.png: the grains' free surface at N frames spread evenly over "
                           "the run, the first and the last included (Fig. 2.3's profiles over time)")
    plot.add_argument("--fields", action="store_true",
                      help="also write RUN.fields.png: speed, pressure and the von Mises shear strain since the "
                           "first frame, at the frame nearest --time")
    plot.add_argument("--time", type=positive_float, metavar="T",
                      help="simulated time (s) of the --fields frame; default: the last frame")
    add_force_option(plot)
    plot.set_defaults(handler=_cmd_plot)


def _read(path: str | os.PathLike[str]) -> RunData:
    """The run file at `path`; FileNotFoundError naming it if there is none."""
    if not Path(path).is_file():
        raise FileNotFoundError(f"{os.fspath(path)}: no such run file")
    try:
        return read_run(path)
    except OSError as error:  # h5py names neither the file nor the problem in terms a user knows
        raise OSError(f"{os.fspath(path)}: not a readable terrasph run file ({error})") from None


def describe_run(path: str | os.PathLike[str]) -> dict[str, Any]:
    """A run file's scene, status, time and steps reached, frames, bodies, results and the message or
    reason of a run that did not end at its end time (plain data)."""
    run = _read(path)
    status = run.group_attrs.get("/run", {})
    reached_time = float(run.times[-1]) if run.n_frames else 0.0
    reached_step = int(run.steps[-1]) if run.n_frames else 0
    info = {
        "file": os.fspath(path),
        "scene": run.config.get("scene", "custom"),
        "status": status.get("status", "running or killed (no status written)"),
        "time": float(status.get("time", reached_time)),
        "steps": int(status.get("steps", status.get("step", reached_step))),
        "frames": run.n_frames,
        "granular_particles": int(run.fields["position"].shape[1]) if "position" in run.fields else 0,
        "bodies": sorted(name.split("/", 1)[1] for name in run.series if name.startswith("bodies/")),
        "results": {k: _plain(v) for k, v in run.group_attrs.get("/results", {}).items()},
        "versions": {k: v for k, v in run.attrs.items() if k.startswith("version")},
    }
    for key in ("message", "reason", "checkpoint"):
        if key in status:
            info[key] = str(status[key])
    if "first_leak_time" in status:
        info["first_leak_time"] = float(status["first_leak_time"])
    if "settled_state_key" in run.attrs:  # started from a cached pause (terrasph.settle_cache)
        info["settled_state"] = {key: str(run.attrs[f"settled_state_{key}"]) for key in ("key", "path", "event")}
    return info


def _plain(value: Any) -> Any:
    """A JSON-able form of an HDF5 attribute value."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def _cmd_info(args: argparse.Namespace) -> int:
    info = describe_run(args.run)
    if args.json:
        print(json.dumps(info, indent=2, default=str))
        return 0
    print(f"{info['file']}: {info['scene']} run, status {info['status']}")
    print(f"  reached t = {info['time']:.6g} s after {info['steps']} steps; {info['frames']} frames of "
          f"{info['granular_particles']} grains")
    if "message" in info:
        print(f"  message: {info['message']}")
    if "reason" in info:
        print(f"  ended early: {info['reason']}")
    if "first_leak_time" in info:
        print(f"  grains leaked into a wall or body from t = {info['first_leak_time']:.4g} s on "
              f"(leaked_particles in /run)")
    if info["bodies"]:
        print(f"  bodies: {', '.join(info['bodies'])} (series in /series/bodies/<name>)")
    if "settled_state" in info:
        settled = info["settled_state"]
        how = "settled its pause and cached it" if settled["event"] == "settled" else "started from the cached pause"
        print(f"  {how}: {settled['key'][:16]} in {settled['path']}")
    for key, value in info["results"].items():
        print(f"  {key} = {value}")
    if info["status"] not in FINISHED_STATUSES:
        next_step = (f"`terrasph resume {info['file']}` continues it from {info['checkpoint']}"
                     if "checkpoint" in info else "to go further, run the scene again")
        print(f"  the run did not finish: its frames up to the time reached are readable and "
              f"`terrasph plot {info['file']}` draws them; {next_step}")
    elif info["status"] == END_OF_BED:
        print("  the robot reached the end of its bed: a longer run needs a longer bed (or a start farther back)")
    elif "checkpoint" in info:
        print(f"  `terrasph resume {info['file']} --until T` continues it to a later time T from {info['checkpoint']}")
    return 0


def plot_run(path: str | os.PathLike[str]) -> tuple[Path, Path]:
    """Writes the scene's figure (PNG) and the XDMF sidecar beside the run file; returns both paths."""
    from terrasph import analysis, plotting

    path = Path(path)
    run = _read(path)
    if run.n_frames == 0:
        raise ValueError(f"{path}: no frame written, nothing to plot")
    png = path.with_suffix(".png")
    scene = run.config.get("scene")
    bodies = [name for name in run.series if name.startswith("bodies/")]
    robot_parts = sorted(name.split("/", 1)[1] for name in run.series  # coupled bodies, not the actuators
                         if name.startswith("robot/") and "sinkage" in run.series[name])
    final = run.frame(-1).get("position")  # the grains; none on the RFT terrain
    title = f"{scene or 'run'}, {_status(run)} at t = {run.times[-1]:.3g} s"
    if scene == "column-collapse":
        dx = float(run.config["spacing"])
        initial = run.frame(0)["position"]
        results = run.group_attrs.get("/results", {})
        label = f"t = {run.times[-1]:.2f} s"
        if "runout_normalised" in results:  # the legend the run itself drew
            label += (f", L* = {float(results['runout_normalised']):.2f}, "
                      f"H* = {float(results['final_height_normalised']):.2f}")
        plotting.plot_profiles([(*analysis.surface_profile(final, dx), label)],
                               initial=analysis.surface_profile(initial, dx), path=png)
    elif scene == "leg-rotation" and "bodies/leg" in run.series:
        series = run.series["bodies/leg"]
        settle = float(run.config["leg_rotation"]["settle_time"])
        turning = series["time"] > settle + 1e-9
        plotting.plot_leg_loads([(series["angle"][turning], series["force"][turning, 1],
                                  series["force"][turning, 0], run.config["leg_rotation"]["leg"])],
                                path=png, title=title)
    elif robot_parts:  # a MuJoCo-coupled robot: the figure its run drew (trajectory, slip, sinkage)
        from terrasph.robots.plots import plot_robot, plot_robot_3d

        scene_config = run.config.get(str(scene).replace("-", "_"), {})
        three_d = "quaternion" in run.series[f"robot/{robot_parts[0]}"]  # the 3D RFT terrain's series
        (plot_robot_3d if three_d else plot_robot)(run.series, robot_parts, png,
                                                   settle_time=scene_config.get("settle_time"), title=title)
    elif bodies:
        series = run.series[bodies[0]]
        plotting.plot_series(series["time"], {"F_x (N)": series["force"][:, 0], "F_z (N)": series["force"][:, 1]},
                             path=png)
    else:
        plotting.plot_particles(final, run.frame(-1).get("pressure"), label="pressure (Pa)",
                                walls=run.static.get("walls/position"), path=png)
    return png, write_xdmf(path)


#: Neighbourhood of the least-squares deformation gradient of shear_strain, in lattice spacings:
#: 2.5Δx holds the 20 nearest lattice neighbours (Falk & Langer 1998 use ~2.5 diameters).
STRAIN_RADIUS_SPACINGS = 2.5


def plot_profiles_over_time(path: str | os.PathLike[str], count: int) -> Path:
    """Writes RUN.profiles.png, the grains' free surface at `count` frames spread evenly over the
    run (first and last included), with the bed of a curved-bed column; returns its path."""
    from terrasph import analysis, plotting

    path = Path(path)
    run = _frames_of(path)
    dx = float(run.config["spacing"])
    frames = sorted({round(k) for k in np.linspace(0, run.n_frames - 1, min(count, run.n_frames))})
    profiles = [(*analysis.surface_profile(run.frame(k)["position"], dx), f"t = {run.times[k]:.2f} s")
                for k in frames]
    png = path.with_suffix(".profiles.png")
    plotting.plot_profiles(profiles, path=png)
    return png


def plot_fields(path: str | os.PathLike[str], time: float | None = None) -> Path:
    """Writes RUN.fields.png at the frame nearest `time` (default: the last): the grains' speed,
    pressure and von Mises shear strain since the first frame (:func:`terrasph.analysis.shear_strain`
    over STRAIN_RADIUS_SPACINGS lattice spacings); returns its path."""
    from terrasph import analysis, plotting

    path = Path(path)
    run = _frames_of(path)
    k = run.n_frames - 1 if time is None else int(np.argmin(np.abs(np.asarray(run.times) - time)))
    frame = run.frame(k)
    dx = float(run.config["spacing"])
    strain = analysis.shear_strain(run.frame(0)["position"], frame["position"], STRAIN_RADIUS_SPACINGS * dx)
    fields = [(np.linalg.norm(frame["velocity"], axis=1), "|v| (m/s)")]
    if "pressure" in frame:
        fields.append((frame["pressure"], "pressure (Pa)"))
    fields.append((strain, "shear strain η since t = 0"))
    walls = frame.get("wall_position", _fixed_walls_at(run, float(run.times[k])))
    png = path.with_suffix(".fields.png")
    plotting.plot_fields(frame["position"], fields, walls=walls, path=png,
                         title=f"{run.config.get('scene', 'run')} at t = {run.times[k]:.3g} s")
    return png


def _fixed_walls_at(run: RunData, time: float) -> np.ndarray | None:
    """Positions of the static wall particles still in place at `time` (a gate removed at t0 is
    gone after it); group k of /static/walls/group is the k-th wall of the configuration."""
    position, group = run.static.get("walls/position"), run.static.get("walls/group")
    if position is None or group is None:
        return position
    removed = [k for k, wall in enumerate(run.config.get("walls", []))
               if wall.get("remove_at") is not None and wall["remove_at"] <= time]
    return position[~np.isin(group, removed)]


def _frames_of(path: Path) -> RunData:
    """The run file at `path`, which must hold a frame; ValueError naming it if it holds none."""
    run = _read(path)
    if run.n_frames == 0:
        raise ValueError(f"{path}: no frame written, nothing to plot")
    return run


def _status(run: RunData) -> str:
    return str(run.group_attrs.get("/run", {}).get("status", "running"))


def _cmd_plot(args: argparse.Namespace) -> int:
    if args.time is not None and not args.fields:
        raise ValueError("--time chooses the frame of --fields: give --fields too")
    figures = [".png", ".xdmf", *([".profiles.png"] if args.profiles else []),
               *([".fields.png"] if args.fields else [])]
    for suffix in figures:  # all checked before any is written
        check_output_file(args.run.with_suffix(suffix), args.force, option="plot")
    png, xdmf = plot_run(args.run)
    written = [png, xdmf]
    if args.profiles:
        written.append(plot_profiles_over_time(args.run, args.profiles))
    if args.fields:
        written.append(plot_fields(args.run, args.time))
    print(f"wrote {', '.join(map(str, written[:-1]))} and {written[-1]}")
    return 0
