"""``terrasph run leg-wheel`` and ``terrasph run rover``: the robot scenes' options on the command line.

Each scene's parser stores, as ``scene_values``, the function that turns its parsed options into the
scene's configuration values; ``terrasph run`` then runs the scene through
:func:`terrasph.scenes.run_case` (terrasph.scenes_cli)."""

from __future__ import annotations

import argparse
from typing import Any

from terrasph.cli_common import (add_force_option, add_numerics_option, add_threads_option, check_output_file,
                                 numerics_overrides, positive_float)
from terrasph.robots.leg_wheel import WHEELS, LegWheel
from terrasph.robots.rover import Rover

__all__ = ["add_terrain_options", "register_leg_wheel", "register_rover"]


def _add_common(parser: argparse.ArgumentParser, defaults: LegWheel | Rover, output: str) -> None:
    """Options both robot scenes share."""
    parser.add_argument("--wheel", choices=WHEELS, default=defaults.wheel,
                        help="morphology (Fig. 4.2) or plain wheel (default %(default)s)")
    parser.add_argument("--legs", type=int, default=defaults.legs, help="legs of a leg-wheel (default %(default)s)")
    parser.add_argument("--omega", type=float, default=defaults.omega,
                        help="spin after the pause, rad/s clockwise (default %(default)s)")
    parser.add_argument("--spacing", type=positive_float, default=defaults.spacing,
                        help="particle spacing dx in m (default %(default)s)")
    parser.add_argument("--thickness", type=positive_float, default=defaults.thickness,
                        help="leg thickness in m, >= 3 dx (default %(default)s)")
    parser.add_argument("--leg-length", type=positive_float, default=defaults.leg_length,
                        help="hip-to-toe length in m (default %(default)s)")
    parser.add_argument("--bed-width", type=positive_float, default=defaults.bed_width,
                        help="bed width in m (default %(default)s)")
    parser.add_argument("--bed-depth", type=positive_float, default=defaults.bed_depth,
                        help="bed depth in m (default %(default)s)")
    parser.add_argument("--start-x", type=float, default=defaults.start_x, help="robot x at start in m (default %(default)s)")
    parser.add_argument("--settle-time", type=float, default=defaults.settle_time,
                        help="pause before the spin in s (default %(default)s)")
    parser.add_argument("--t-end", type=positive_float, default=defaults.duration,
                        help="simulated time in s (default %(default)s)")
    parser.add_argument("--out", default=output,
                        help="HDF5 output file; a PNG is written beside it (default %(default)s)")
    add_force_option(parser)
    add_threads_option(parser)
    add_numerics_option(parser)
    parser.add_argument("--no-progress", action="store_true", help="hide the progress bar")


def _common_values(args: argparse.Namespace) -> dict[str, Any]:
    """The configuration values both robot scenes take from the options; checks ``--out`` and
    applies ``--threads`` first."""
    check_output_file(args.out, args.force)
    if args.threads is not None:
        from terrasph import _core

        _core.set_num_threads(args.threads)
    return {"wheel": args.wheel, "legs": args.legs, "omega": args.omega, "spacing": args.spacing,
            "thickness": args.thickness, "leg_length": args.leg_length, "bed_width": args.bed_width,
            "bed_depth": args.bed_depth, "start_x": args.start_x, "settle_time": args.settle_time,
            "duration": args.t_end, "numerics": numerics_overrides(args.numerics)}


def register_leg_wheel(scenes: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    """Adds ``run leg-wheel``."""
    parser = scenes.add_parser("leg-wheel", help="hybrid leg-wheel driven through glass beads (dissertation ch. 4)",
                               description="One leg-wheel, free in x and z, carrying a load, paused and then "
                                           "driven clockwise by a motor through a bed of 3 mm glass beads "
                                           "(MuJoCo coupled with the SPH terrain; docs/robots.md).")
    defaults = LegWheel()
    _add_common(parser, defaults, "leg_wheel.h5")
    parser.add_argument("--load", type=positive_float, default=defaults.load, help="vertical load in N (default %(default)s)")
    add_terrain_options(parser, defaults.terrain, defaults.rft_table)
    parser.set_defaults(scene_values=_leg_wheel_values)
    return parser


def _leg_wheel_values(args: argparse.Namespace) -> dict[str, Any]:
    return {**_common_values(args), "load": args.load, "terrain": args.terrain, "rft_table": args.rft_table}


def add_terrain_options(parser: argparse.ArgumentParser, terrain: str, table: str) -> None:
    """``--terrain`` and ``--rft-table``: the SPH bed or resistive force theory (terrasph.rft)."""
    from terrasph.rft import TERRAINS

    parser.add_argument("--terrain", choices=TERRAINS, default=terrain,
                        help="the SPH bed or resistive force theory on a flat surface (default %(default)s)")
    parser.add_argument("--rft-table", default=table,
                        help="with --terrain rft: 'generic' (Li et al. 2013) or a JSON coefficient table "
                             "(terrasph rft-calibrate) (default %(default)s)")


def register_rover(scenes: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    """Adds ``run rover``."""
    parser = scenes.add_parser("rover", help="planar rover with two driven leg-wheels crossing a bed",
                               description="The example MJCF rover (terrasph.robots.ROVER): a chassis and two "
                                           "leg-wheels on driven hinges, paused and then driven clockwise across "
                                           "a bed of 3 mm glass beads (docs/robots.md).")
    _add_common(parser, Rover(), "rover.h5")
    parser.set_defaults(scene_values=_common_values)
    return parser
