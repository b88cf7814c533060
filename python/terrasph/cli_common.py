"""What every ``terrasph`` sub-command shares: validated option types, the ``--threads`` and
``--force`` options and the check of an output path before any work starts.

Bad option values are argparse errors (one line, exit status 2) that name the option, so no
library default or internal parameter name leaks into the message.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
from collections.abc import Callable
from pathlib import Path

__all__ = ["add_force_option", "add_numerics_option", "add_threads_option", "check_output_dir", "check_output_file",
           "nonnegative_int", "numerics_overrides", "positive_float", "positive_int", "setting_value"]


def _int_at_least(minimum: int) -> Callable[[str], int]:
    """argparse type: an integer ≥ `minimum`."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be an integer >= {minimum}, got {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be an integer >= {minimum}, got {value}")
        return value

    return parse


positive_int = _int_at_least(1)  #: argparse type: an integer ≥ 1
nonnegative_int = _int_at_least(0)  #: argparse type: an integer ≥ 0


def positive_float(text: str) -> float:
    """argparse type: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number > 0, got {text!r}") from None
    if not (value > 0 and math.isfinite(value)):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
    return value


def add_threads_option(parser: argparse.ArgumentParser) -> None:
    """Adds ``--threads N``: OpenMP threads of the SPH core, in every command (N ≥ 1; default:
    terrasph.threads.default_threads() when the run starts). Apply it with
    :func:`terrasph.threads.use_threads`."""
    parser.add_argument("--threads", type=positive_int, default=None, metavar="N",
                        help="OpenMP threads of the SPH core, >= 1 (default: the cores not busy with other work "
                             "when the run starts, see terrasph.threads.default_threads; results do not depend on it)")


def add_force_option(parser: argparse.ArgumentParser) -> None:
    """Adds ``--force``: replace existing output instead of refusing."""
    parser.add_argument("--force", action="store_true", help="replace existing output (default: refuse)")


def setting_value(raw: str) -> bool | int | float:
    """The value of a ``NAME=VALUE`` setting: ``true``/``false``, else an integer, else a float
    (ValueError if none). The one parser of such values, for the command line and the benchmarks."""
    if raw.lower() in ("true", "false"):
        return raw.lower() == "true"
    try:
        return int(raw)
    except ValueError:
        return float(raw)


def numerics_setting(text: str) -> tuple[str, bool | int | float]:
    """argparse type: one ``NAME=VALUE`` of terrasph.Numerics (e.g. ``cfl=0.9``),
    checked against the parameter's type and range at once (the rules that link parameters are
    checked by :func:`numerics_overrides`). The spacing is a scene option."""
    from terrasph.config import ConfigError, Numerics, parameter

    name, sep, raw = text.partition("=")
    allowed = sorted(f.name for f in dataclasses.fields(Numerics) if f.name != "spacing")
    if not sep or name not in allowed:
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE with NAME one of {', '.join(allowed)}; got {text!r}")
    try:
        value = setting_value(raw)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{name}: expected a number or true/false, got {raw!r}") from None
    entry = parameter(f"numerics.{name}")
    try:
        value = entry.coerce(value)
    except ConfigError as error:
        raise argparse.ArgumentTypeError(str(error)) from None
    if entry.kind in ("double", "int"):
        above = value >= entry.lower if entry.lower_inclusive else value > entry.lower
        below = value <= entry.upper if entry.upper_inclusive else value < entry.upper
        if not (above and below):
            raise argparse.ArgumentTypeError(f"parameter '{entry.qualified_name}' = {value!r} is invalid: "
                                             f"allowed {entry.allowed}")
    return name, value


def add_numerics_option(parser: argparse.ArgumentParser) -> None:
    """Adds ``--numerics NAME=VALUE ...``: overrides of the scene's numerical options (the speed
    settings of docs/fidelity.md, e.g. ``cfl=0.9``)."""
    parser.add_argument("--numerics", type=numerics_setting, nargs="+", default=[], metavar="NAME=VALUE",
                        help="numerical options over the scene's fidelity tier (terrasph.Numerics, e.g. cfl=0.9 "
                             "freeze_speed=0.001 active_radius=0.1; docs/fidelity.md gives each tier's error; default: the "
                             "scene's own)")


def numerics_overrides(settings: list[tuple[str, bool | int | float]]) -> dict[str, bool | int | float]:
    """The ``--numerics`` settings as a mapping (a later setting of a name wins), checked together
    against the rules that link parameters (e.g. active_radius needs freeze_speed): ConfigError
    naming the parameter, before any work."""
    from terrasph.config import Numerics

    overrides = dict(settings)
    Numerics(**overrides)
    return overrides


def check_output_file(path: str | os.PathLike, force: bool, option: str = "--out") -> Path:
    """Refuses an output file whose directory is missing, or that exists without ``force``.

    Raises:
        FileNotFoundError / FileExistsError naming the option (the CLI reports them in one line).
    """
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise FileNotFoundError(f"{option} {path}: directory {parent} does not exist")
    if path.is_dir():
        raise IsADirectoryError(f"{option} {path}: is a directory, expected a file")
    if path.exists() and not force:
        raise FileExistsError(f"{option} {path}: file exists (use --force to replace it)")
    return path


def check_output_dir(path: str | os.PathLike, force: bool, option: str = "OUT_DIR") -> Path:
    """Refuses an output directory that is a file, or that holds files, without ``force``."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise NotADirectoryError(f"{option} {path}: is a file, expected a directory")
    if path.is_dir() and any(path.iterdir()) and not force:
        raise FileExistsError(f"{option} {path}: directory is not empty (use --force to write into it)")
    return path
