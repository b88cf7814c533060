"""Command line: ``terrasph run SCENE``, ``terrasph train``, ``terrasph predict``."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence


def build_parser() -> argparse.ArgumentParser:
    """Return the top-level parser with one sub-command per job."""
    parser = argparse.ArgumentParser(
        prog="terrasph",
        description="SPH simulation of robots on granular terrain and LSTM surrogates.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    from terrasph import scenes_cli
    from terrasph.surrogate import cli as surrogate_cli

    scenes_cli.register(sub)
    surrogate_cli.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``terrasph`` command.

    Bad input ends with a one-line message and exit status 2 (as argparse does); a run that goes
    unstable ends with its step, time and particle and status 3. Output written so far stays readable.
    """
    from terrasph import InstabilityError
    from terrasph.config import ConfigError

    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.handler(args) or 0)
    except ConfigError as error:
        parser.exit(2, f"terrasph: error: {error}\n")
    except InstabilityError as error:
        parser.exit(3, f"terrasph: the run went unstable: {error}\n")
    except KeyboardInterrupt:
        parser.exit(130, "terrasph: interrupted; the output file is closed and readable\n")


if __name__ == "__main__":
    sys.exit(main())
