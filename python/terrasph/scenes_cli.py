"""``terrasph run SCENE``: run a ready-made scene with a progress bar, HDF5 output and a plot.

The scenes offered are those of the registry (:data:`terrasph.scenes.SCENES`), each with its own
options (:data:`SCENE_OPTIONS`); every one runs through :func:`terrasph.scenes.run_case`, the entry
point the sweeps and the tests share."""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from typing import Any

from terrasph.cli_common import (add_force_option, add_numerics_option, add_threads_option, check_output_file,
                                 numerics_overrides)
from terrasph.config import parameter
from terrasph.robots.cli import add_terrain_options, register_leg_wheel, register_rover
from terrasph.scenes import SCENES, leg_rotation, plate_intrusion, run_case, scene_entry
from terrasph.scenes.column_collapse import BEDS, RESOLUTIONS, ColumnCollapse
from terrasph.scenes.plate_intrusion import PlateIntrusion

__all__ = ["SCENE_OPTIONS", "register"]

#: A scene's command-line options: adds ``run NAME`` with its options to the scenes' sub-parsers and
#: returns it; the parser's default ``scene_values`` turns the parsed options into the scene's
#: configuration values (its fields by name).
SceneOptions = Callable[[argparse._SubParsersAction], argparse.ArgumentParser]


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Adds the ``run`` command with every registered scene, and ``resume``."""
    run = subparsers.add_parser("run", help="run a ready-made scene", description="Run a ready-made scene.")
    scenes = run.add_subparsers(dest="scene", required=True, metavar="SCENE")
    missing = [name for name in SCENES if name not in SCENE_OPTIONS]
    unknown = [name for name in SCENE_OPTIONS if name not in SCENES]
    if missing or unknown:  # a programming error: the registry and the options must agree
        raise LookupError(f"terrasph run: registered scenes without options {missing}, options of "
                          f"unregistered scenes {unknown}")
    for name, add_options in SCENE_OPTIONS.items():  # the order `terrasph run --help` lists them in
        add_options(scenes).set_defaults(handler=_run_scene)
    _register_resume(subparsers)


def _run_scene(args: argparse.Namespace) -> int:
    """Runs the chosen scene through run_case: its configuration from the options (checked), then
    ``--out`` and ``--threads``, then the run; prints its summary."""
    config = scene_entry(args.scene).config_from(args.scene_values(args))
    _prepare(args)
    summary = run_case(args.scene, config, args.out, progress=not args.no_progress)
    return _print_summary(summary, args.out, summary.plot)


def _register_column(scenes: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    """Adds ``run column-collapse``."""
    column = scenes.add_parser("column-collapse", help="granular column collapse (dissertation ch. 2)",
                               description="Dry or wet granular column collapse on a rough floor.")
    column.add_argument("--resolution", choices=list(RESOLUTIONS), default="coarse",
                        help="about 475/1036/2310/4620/9240 interior particles (default coarse)")
    column.add_argument("--spacing", type=float, default=None, help="particle spacing in m (overrides --resolution)")
    column.add_argument("--mu1-deg", type=float, default=21.0,
                        help=f"friction angle atan(mu1) in degrees (default 21); {parameter('material.mu1').doc}")
    column.add_argument("--mu2-deg", type=float, default=33.0,
                        help=f"friction angle atan(mu2) in degrees (default 33); {parameter('material.mu2').doc}")
    water = parameter("material.water_content")
    column.add_argument("--water-content", type=float, default=water.default, help=water.help())
    default_column = ColumnCollapse()
    column.add_argument("--bed", choices=list(BEDS), default="flat",
                        help="bed under the column: flat floor, or a circular or elliptical trough whose lowest "
                             "point is at the left wall (Fig. 2.7-2.8; default flat)")
    column.add_argument("--bed-radius", type=float, default=default_column.bed_radius,
                        help="radius of the circular trough in m (default %(default)s)")
    column.add_argument("--bed-axes", type=float, nargs=2, metavar=("A", "B"), default=default_column.bed_axes,
                        help="semi-axes of the elliptical trough in m, along x then z (default %(default)s)")
    model = parameter("material.model")
    column.add_argument("--model", choices=list(model.choices), default=default_column.model,
                        help=f"constitutive model (default {default_column.model}); {model.doc}")
    column.add_argument("--t-end", type=float, default=1.0,
                        help="simulated time limit in s; the run stops earlier once at rest (default %(default)s)")
    _add_run_options(column, default_output="column_collapse.h5")
    column.set_defaults(scene_values=_column_values)
    return column


def _column_values(args: argparse.Namespace) -> dict[str, Any]:
    return {"resolution": args.resolution, "spacing": args.spacing,
            "friction_angles_deg": (args.mu1_deg, args.mu2_deg), "water_content": args.water_content,
            "t_end": args.t_end, "bed": args.bed, "bed_radius": args.bed_radius, "bed_axes": tuple(args.bed_axes),
            "model": args.model, "numerics": numerics_overrides(args.numerics)}


def _add_run_options(parser: argparse.ArgumentParser, default_output: str) -> None:
    """Adds the options every scene shares: ``--out``, ``--force``, ``--threads``, ``--no-progress``."""
    parser.add_argument("--out", default=default_output,
                        help="HDF5 output file; an XDMF sidecar and a PNG are written beside it (default %(default)s)")
    add_force_option(parser)
    add_threads_option(parser)
    add_numerics_option(parser)
    parser.add_argument("--no-progress", action="store_true", help="hide the progress bar")


def _prepare(args: argparse.Namespace) -> None:
    """Checks ``--out`` and applies ``--threads`` before any work."""
    check_output_file(args.out, args.force)
    _apply_threads(args)


def _apply_threads(args: argparse.Namespace) -> None:
    """Applies ``--threads`` (process-wide OpenMP setting) when given."""
    if args.threads is not None:
        from terrasph import _core

        _core.set_num_threads(args.threads)


def _print_summary(summary: dict[str, Any], output: str, plot: str | None) -> int:
    """Prints a run's summary as JSON with the paths of its files; the command's exit code."""
    print(json.dumps({**summary, "output": output, "plot": plot}, indent=2))
    return 0


def _register_plate(scenes: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    """Adds ``run plate-intrusion``."""
    default = PlateIntrusion()
    plate = scenes.add_parser("plate-intrusion", help="horizontal plate pushed into a bed and pulled out",
                              description="A horizontal plate pushed down into a settled bed of glass beads at "
                                          "constant speed, then pulled up; vertical force against depth.")
    plate.add_argument("--resolution", choices=list(plate_intrusion.RESOLUTIONS), default="coarse",
                       help="dx = " + "/".join(f"{dx * 1e3:g}" for dx in plate_intrusion.RESOLUTIONS.values())
                            + " mm (default coarse)")
    plate.add_argument("--spacing", type=float, default=None,
                       help=f"particle spacing in m (overrides --resolution; default {default.spacing:g})")
    plate.add_argument("--speed", type=float, default=default.speed,
                       help=f"plate speed in m/s, down then up (default {default.speed:g})")
    plate.add_argument("--settle", type=float, default=default.settle_time,
                       help=f"settling pause before the plate moves, in s (default {default.settle_time:g})")
    plate.add_argument("--depth", type=float, default=default.max_depth,
                       help=f"deepest depth of the plate underside below the surface in m (default {default.max_depth:g})")
    plate.add_argument("--buried", type=float, default=None, metavar="H",
                       help="start buried instead, the plate's top face H m below the surface, and only pull "
                            "it up (a strip anchor); default: start above the surface")
    plate.add_argument("--pull", type=float, default=default.pull_distance,
                       help=f"with --buried: upward travel of the plate in m (default {default.pull_distance:g})")
    model = parameter("material.model")
    plate.add_argument("--model", choices=list(model.choices), default=default.model,
                       help=f"constitutive model of the beads (default {default.model}); {model.doc}")
    _add_run_options(plate, default_output="plate_intrusion.h5")
    plate.set_defaults(scene_values=_plate_values)
    return plate


def _plate_values(args: argparse.Namespace) -> dict[str, Any]:
    spacing = args.spacing if args.spacing is not None else plate_intrusion.RESOLUTIONS[args.resolution]
    return {"spacing": spacing, "speed": args.speed, "max_depth": args.depth, "settle_time": args.settle,
            "model": args.model, "buried_depth": args.buried, "pull_distance": args.pull,
            "numerics": numerics_overrides(args.numerics)}


def _register_plate_drag(scenes: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    """Adds ``run plate-drag``."""
    from terrasph.scenes.plate_drag import PlateDrag

    default = PlateDrag()
    drag = scenes.add_parser("plate-drag", help="a buried plate at attack angle beta dragged in direction gamma (RFT)",
                             description="Li et al.'s (2013) resistive-force experiment: a plate at attack angle "
                                         "beta, buried in a bed of glass beads, moved in direction gamma; the "
                                         "stress per unit depth alpha_x, alpha_z (docs/rft.md).")
    drag.add_argument("--attack-angle", type=float, default=default.attack_angle,
                      help="beta in rad, [-pi/2, pi/2], counter-clockwise (default %(default)s)")
    drag.add_argument("--direction", type=float, default=default.direction,
                      help="gamma in rad, [-pi/2, pi/2], pi/2 = straight down (default %(default)s)")
    drag.add_argument("--spacing", type=float, default=default.spacing, help="particle spacing in m (default %(default)s)")
    drag.add_argument("--travel", type=float, default=default.travel, help="stroke length in m (default %(default)s)")
    drag.add_argument("--start-depth", type=float, default=default.start_depth,
                      help="depth of the plate centre at the start in m (default %(default)s)")
    _add_run_options(drag, default_output="plate_drag.h5")
    drag.set_defaults(scene_values=lambda args: {
        "attack_angle": args.attack_angle, "direction": args.direction, "spacing": args.spacing,
        "travel": args.travel, "start_depth": args.start_depth, "numerics": numerics_overrides(args.numerics)})
    return drag


def _register_leg(scenes: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    """Adds ``run leg-rotation``."""
    default = leg_rotation.LegRotation()
    leg = scenes.add_parser("leg-rotation", help="robot leg rotated through glass beads (dissertation ch. 3)",
                            description="A leg held for a settling pause in a 24 × 15 cm bed of 3 mm glass beads, "
                                        "then rotated clockwise about its hip from -pi/4 to pi/4; lift and thrust "
                                        "against the leg angle.")
    leg.add_argument("--leg", choices=leg_rotation.LEGS, default=default.leg, help="leg shape (default c-leg)")
    leg.add_argument("--omega", type=float, default=default.omega, help="angular velocity in rad/s (default 0.2)")
    leg.add_argument("--foot-ratio", type=float, default=default.foot_ratio,
                     help="foot/leg length ratio fl of the L-legs (default 0.33)")
    leg.add_argument("--resolution", choices=list(leg_rotation.RESOLUTIONS), default=default.resolution,
                     help="3/4/5 particle rows across the 6.4 mm leg: dx = 2.13/1.60/1.28 mm (default coarse)")
    leg.add_argument("--settle", type=float, default=default.settle_time, help="settling pause in s (default 2)")
    leg.add_argument("--bed-depth", type=float, default=default.bed_depth, help="bed depth in m (default 0.15)")
    add_terrain_options(leg, default.terrain, default.rft_table)
    _add_run_options(leg, default_output="leg_rotation.h5")
    leg.set_defaults(scene_values=_leg_values)
    return leg


def _leg_values(args: argparse.Namespace) -> dict[str, Any]:
    return {"leg": args.leg, "omega": args.omega, "foot_ratio": args.foot_ratio, "resolution": args.resolution,
            "settle_time": args.settle, "bed_depth": args.bed_depth, "numerics": numerics_overrides(args.numerics),
            "terrain": args.terrain, "rft_table": args.rft_table}


#: The options of every registered scene, by name, in the order ``terrasph run --help`` lists them.
SCENE_OPTIONS: dict[str, SceneOptions] = {
    "column-collapse": _register_column,
    "plate-intrusion": _register_plate,
    "plate-drag": _register_plate_drag,
    "leg-rotation": _register_leg,
    "leg-wheel": register_leg_wheel,
    "rover": register_rover,
}


def _register_resume(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Adds ``terrasph resume RUN.h5``."""
    resume = subparsers.add_parser(
        "resume", help="continue an interrupted or finished scene run from its checkpoint",
        description="Continue a scene run from the checkpoint beside its file (RUN.checkpoint.h5, written every "
                    "10 minutes of wall time and on Ctrl-C or SIGTERM) into the same file: frames and series "
                    "written after the checkpoint are replaced, so each appears once, and the result is bitwise "
                    "the run that never stopped.")
    resume.add_argument("run_file", metavar="RUN.h5", help="the run's HDF5 file")
    resume.add_argument("--until", type=float, default=None,
                        help="simulated end time in s (default: the scene's own end time)")
    add_threads_option(resume)
    resume.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    resume.set_defaults(handler=_resume)


def _resume(args: argparse.Namespace) -> int:
    import h5py

    from terrasph.config import ConfigError
    from terrasph.scenes import scene_of_run

    _apply_threads(args)
    try:
        with h5py.File(args.run_file, "r") as file:
            config_json = str(file.attrs["config_json"])
    except (OSError, KeyError) as error:
        raise ConfigError(f"{args.run_file} is not a readable terrasph run file: {error}") from error
    entry, config = scene_of_run(config_json)
    result = entry.run(config, output=args.run_file, progress=not args.no_progress, resume=True, until=args.until)
    return _print_summary(result.summary(), args.run_file, result.plot)
