"""``terrasph sweep SPEC``: the cases of a sweep SPEC on Dask (terrasph.sweeps)."""

from __future__ import annotations

import argparse
import json
from typing import Any

from terrasph.cli_common import positive_int

__all__ = ["register"]


def register(subparsers: Any) -> None:
    """Adds the ``sweep`` command."""
    p = subparsers.add_parser(
        "sweep", help="run a parameter sweep of a scene on Dask (resumable)",
        description="Run every case of the sweep SPEC (YAML or TOML: scene, fixed parameters, seeded "
                    "design; docs/surrogate.md) on a Dask LocalCluster, or on the cluster of --scheduler. "
                    "Finished runs in OUT are skipped, so the same command resumes a sweep; failed cases "
                    "are recorded in OUT/manifest.json with their error and run again next time.")
    p.add_argument("spec", metavar="SPEC", help="sweep specification (.yaml, .yml or .toml)")
    p.add_argument("--out", required=True, help="sweep directory (runs/, manifest.json, events.jsonl)")
    p.add_argument("--workers", type=positive_int, default=1,
                   help="process workers of the LocalCluster, one run each at a time (default %(default)s)")
    p.add_argument("--threads-per-worker", type=positive_int, default=1,
                   help="OpenMP threads of each run (default %(default)s)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="address of an existing Dask scheduler (e.g. tcp://host:8786) instead of a LocalCluster")
    p.add_argument("--dry-run", action="store_true", help="validate SPEC and list its cases without running")
    p.add_argument("--yes", action="store_true",
                   help="run even cases the size guard estimates at more than terrasph.size_guard.CONFIRM_HOURS "
                        "hours (default: refuse the sweep)")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    p.set_defaults(handler=_cmd_sweep)


def _cmd_sweep(args: argparse.Namespace) -> int:
    from terrasph.config import ConfigError
    from terrasph.scenes import scene_entry
    from terrasph.size_guard import check_size
    from terrasph.sweeps.runner import run_sweep
    from terrasph.sweeps.spec import load_spec

    spec = load_spec(args.spec)
    entry = scene_entry(spec.scene)
    for case in spec.cases:  # the size guard, before any run: every case, as one run of a worker
        try:
            check_size(entry.config_from(case.config), confirmed=args.yes, threads=args.threads_per_worker)
        except ConfigError as error:
            raise ConfigError(f"sweep case {case.case_id}: {error}") from None
    if args.dry_run:
        for case in spec.cases:
            print(case.case_id, json.dumps(case.varied, sort_keys=True))
        return 0
    manifest = run_sweep(spec, args.out, workers=args.workers, threads_per_worker=args.threads_per_worker,
                         scheduler=args.scheduler, progress=not args.no_progress)
    print(json.dumps({"out": args.out, **manifest["counts"]}))
    return 0 if manifest["counts"]["failed"] == 0 else 1
