"""``terrasph run SCENE``: run a ready-made scene with a progress bar, HDF5 output and a plot.

The scenes offered are those of the registry (:data:`terrasph.scenes.SCENES`); each scene's options
are generated from its configuration dataclass (:mod:`terrasph.options`), so every scene spells
the same thing the same way (``--spacing``, ``--settle-time``, ``--t-end``, ``--out FILE``), and
every one runs through :func:`terrasph.scenes.run_case`, the entry point the sweeps and the tests
share, after the size guard (:mod:`terrasph.size_guard`) has accepted it."""

from __future__ import annotations

import argparse
import json
import pathlib
from typing import Any

from terrasph.cli_common import add_force_option, add_numerics_option, add_threads_option, numerics_overrides
from terrasph.config import ConfigError
from terrasph.io import defined_values
from terrasph.options import add_config_options, config_values, with_option_names
from terrasph.run_loop import (
    FINISHED_STATUSES,
    building_scene,
    check_end_time,
    claimed_output,
    output_lock,
    recorded_end,
)
from terrasph.scenes import SCENES, SceneEntry, run_case, scene_entry
from terrasph.threads import use_threads

__all__ = ["register"]


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser], only: str | None = None) -> None:
    """Adds the ``run`` command with every registered scene, and ``resume``; with `only` (a scene's
    name: :func:`is_scene`), ``run`` with that scene alone."""
    run = subparsers.add_parser("run", help="run a ready-made scene", description="Run a ready-made scene.")
    scenes = run.add_subparsers(dest="scene", required=True, metavar="SCENE")
    if only is not None:
        _register_scene(scenes, scene_entry(only))
        return
    for entry in SCENES.values():
        _register_scene(scenes, entry)
    _register_resume(subparsers)


def is_scene(name: str) -> bool:
    """Whether `name` is a registered scene's name (``terrasph run NAME``)."""
    return name in SCENES


def _register_scene(scenes: argparse._SubParsersAction[argparse.ArgumentParser], entry: SceneEntry) -> None:
    """Adds ``run NAME``: the scene's configuration options, then those every run shares."""
    parser = scenes.add_parser(entry.name, help=entry.help, description=entry.description)
    add_config_options(parser, entry.config_type)
    parser.add_argument("--out", default=f"{entry.config_key}.h5", metavar="FILE",
                        help="HDF5 output file; a PNG (and an XDMF sidecar) is written beside it (default %(default)s)")
    add_force_option(parser)
    add_threads_option(parser)
    add_numerics_option(parser)
    parser.add_argument("--yes", action="store_true",
                        help="run even when the size guard estimates more than "
                             "terrasph.size_guard.CONFIRM_HOURS hours (default: refuse)")
    parser.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    parser.set_defaults(handler=_run_scene)


def _run_scene(args: argparse.Namespace) -> int:
    """Runs the chosen scene through run_case: its configuration from the options (checked), then
    ``--out`` (claimed for this run alone), the size guard and ``--threads``, then the run; prints its
    summary."""
    from terrasph.size_guard import check_size

    entry = scene_entry(args.scene)
    try:
        config = entry.config_from({**config_values(args, entry.config_type),
                                    "numerics": numerics_overrides(args.numerics)})
    except ConfigError as error:
        raise ConfigError(with_option_names(str(error), entry.config_type)) from None
    # a second run into the same file refuses, before any work, even with --force while the first writes;
    # Ctrl-C or SIGTERM while the scene is built stops it at once and removes the empty claim
    with claimed_output(args.out, args.force):
        check_size(config, confirmed=args.yes, threads=args.threads)
        use_threads(args.threads)
        with building_scene(not args.no_progress, f"the {args.scene} scene"):
            summary = run_case(args.scene, config, args.out, progress=not args.no_progress)
    return _print_summary(summary, args.out, summary.plot)


def _print_summary(summary: dict[str, Any], output: str, plot: str | None) -> int:
    """Prints a run's summary as JSON with the paths of its files; the command's exit code."""
    print(json.dumps(defined_values({**summary, "output": output, "plot": plot}), indent=2, allow_nan=False))
    return 0


def _register_resume(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Adds ``terrasph resume RUN.h5``."""
    resume = subparsers.add_parser(
        "resume", help="continue an interrupted or finished scene run from its checkpoint",
        description="Continue a scene run, interrupted or finished, from the checkpoint beside its file "
                    "(RUN.checkpoint.h5, written every 10 minutes of wall time, on Ctrl-C or SIGTERM and when the "
                    "run ends) into the same file: frames and series written after the checkpoint are replaced, "
                    "so each appears once, and the result is bitwise the run that never stopped.")
    resume.add_argument("run_file", metavar="RUN.h5", help="the run's HDF5 file")
    resume.add_argument("--until", type=float, default=None,
                        help="simulated end time in s, after the time the run reached (default: the end time the run "
                             "aimed at, its scene's or the last --until; a run that reached it needs a later one)")
    add_threads_option(resume)
    resume.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    resume.set_defaults(handler=_resume)


def _resume(args: argparse.Namespace) -> int:
    """Continues the run in ``RUN.h5`` (held by its lock, so a run still writing it is named and
    left alone) from its checkpoint; prints its summary."""
    import h5py

    from terrasph.config import ConfigError
    from terrasph.scenes import scene_of_run

    if not pathlib.Path(args.run_file).is_file():
        raise FileNotFoundError(f"{args.run_file}: no such run file")
    use_threads(args.threads)
    with output_lock(args.run_file):
        try:
            with h5py.File(args.run_file, "r") as file:
                config_json = str(file.attrs["config_json"])
            status, reached, aimed = recorded_end(args.run_file)
        except (OSError, KeyError) as error:
            raise ConfigError(f"{args.run_file} is not a readable terrasph run file: {error}") from error
        entry, config = scene_of_run(config_json)
        until = args.until if args.until is not None else aimed  # None: the scene's own end time
        if reached is not None:
            if args.until is None and status in FINISHED_STATUSES:
                raise ConfigError(f"{args.run_file} already ran to its end (status {status}, t = {reached:.6g} s); "
                                  f"--until T with T > {reached:.6g} continues it")
            if until is not None:
                check_end_time(until, reached, "until")
        with building_scene(not args.no_progress, f"the {entry.name} scene"):
            result = entry.run(config, output=args.run_file, progress=not args.no_progress, resume=True, until=until)
    return _print_summary(result.summary(), args.run_file, result.plot)
