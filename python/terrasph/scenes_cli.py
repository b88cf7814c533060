"""``terrasph run SCENE``: run a ready-made scene with a progress bar, HDF5 output and a plot."""

from __future__ import annotations

import argparse
import json

from terrasph.scenes.column_collapse import RESOLUTIONS, ColumnCollapse, run_column_collapse

__all__ = ["register"]


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Adds the ``run`` command and its scenes."""
    run = subparsers.add_parser("run", help="run a ready-made scene", description="Run a ready-made scene.")
    scenes = run.add_subparsers(dest="scene", required=True, metavar="SCENE")
    column = scenes.add_parser("column-collapse", help="granular column collapse (dissertation ch. 2)",
                               description="Dry or wet granular column collapse on a rough floor.")
    column.add_argument("--resolution", choices=list(RESOLUTIONS), default="coarse",
                        help="about 475/1036/2310/4620/9240 interior particles (default coarse)")
    column.add_argument("--spacing", type=float, default=None, help="particle spacing in m (overrides --resolution)")
    column.add_argument("--mu1-deg", type=float, default=21.0, help="quasi-static friction angle (deg)")
    column.add_argument("--mu2-deg", type=float, default=33.0, help="dynamic friction angle (deg)")
    column.add_argument("--water-content", type=float, default=0.0, help="gravimetric water content w")
    column.add_argument("--t-end", type=float, default=1.0, help="simulated time limit (s)")
    column.add_argument("--out", default="column_collapse.h5", help="HDF5 output file (a PNG is written beside it)")
    column.add_argument("--threads", type=int, default=None, help="OpenMP threads (default: all cores)")
    column.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    column.set_defaults(handler=_run_column)


def _run_column(args: argparse.Namespace) -> int:
    if args.threads is not None:
        from terrasph import _core

        _core.set_num_threads(args.threads)
    config = ColumnCollapse(resolution=args.resolution, spacing=args.spacing,
                            friction_angles_deg=(args.mu1_deg, args.mu2_deg),
                            water_content=args.water_content, t_end=args.t_end)
    result = run_column_collapse(config, output=args.out, progress=not args.no_progress)
    summary = result.summary()
    summary["output"] = args.out
    summary["plot"] = result.plot
    print(json.dumps(summary, indent=2))
    return 0
