"""``terrasph run leg-wheel``: the hybrid leg-wheel scene of chapter 4 from the command line."""

from __future__ import annotations

import argparse
import json
import pathlib

from terrasph.robots.leg_wheel import WHEELS, LegWheel, plot_leg_wheel, run_leg_wheel

__all__ = ["register_leg_wheel"]


def register_leg_wheel(scenes: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Adds ``leg-wheel`` to the scenes of ``terrasph run``."""
    parser = scenes.add_parser("leg-wheel", help="hybrid leg-wheel driven through glass beads (dissertation ch. 4)",
                               description="One leg-wheel, free in x and z, carrying a load, paused and then "
                                           "driven clockwise by a motor through a bed of 3 mm glass beads "
                                           "(MuJoCo coupled with the SPH terrain; docs/robots.md).")
    defaults = LegWheel()
    parser.add_argument("--wheel", choices=WHEELS, default=defaults.wheel, help="morphology (Fig. 4.2) or plain wheel")
    parser.add_argument("--legs", type=int, default=defaults.legs, help="legs of a leg-wheel")
    parser.add_argument("--omega", type=float, default=defaults.omega, help="spin after the pause (rad/s, clockwise)")
    parser.add_argument("--load", type=float, default=defaults.load, help="vertical load (N)")
    parser.add_argument("--spacing", type=float, default=defaults.spacing, help="particle spacing Δx (m)")
    parser.add_argument("--thickness", type=float, default=defaults.thickness, help="leg thickness (m), >= 3Δx")
    parser.add_argument("--leg-length", type=float, default=defaults.leg_length, help="hip-to-toe length (m)")
    parser.add_argument("--bed-width", type=float, default=defaults.bed_width, help="bed width (m)")
    parser.add_argument("--bed-depth", type=float, default=defaults.bed_depth, help="bed depth (m)")
    parser.add_argument("--start-x", type=float, default=defaults.start_x, help="axle x at start (m)")
    parser.add_argument("--settle-time", type=float, default=defaults.settle_time, help="pause before the spin (s)")
    parser.add_argument("--t-end", type=float, default=defaults.duration, help="simulated time (s)")
    parser.add_argument("--out", default="leg_wheel.h5", help="HDF5 output file (a PNG is written beside it)")
    parser.add_argument("--threads", type=int, default=None, help="OpenMP threads (default: all cores)")
    parser.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    parser.set_defaults(handler=_run)


def _run(args: argparse.Namespace) -> int:
    if args.threads is not None:
        from terrasph import _core

        _core.set_num_threads(args.threads)
    config = LegWheel(wheel=args.wheel, legs=args.legs, omega=args.omega, load=args.load, spacing=args.spacing,
                      thickness=args.thickness, leg_length=args.leg_length, bed_width=args.bed_width,
                      bed_depth=args.bed_depth, start_x=args.start_x, settle_time=args.settle_time,
                      duration=args.t_end)
    result = run_leg_wheel(config, args.out, progress=not args.no_progress)
    plot = str(pathlib.Path(args.out).with_suffix(".png"))
    plot_leg_wheel(result["series"], plot, label=config.wheel, settle_time=config.settle_time)
    print(json.dumps({**result["summary"], "output": args.out, "plot": plot}, indent=2))
    return 0
