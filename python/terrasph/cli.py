"""Command line: ``terrasph run SCENE``, ``terrasph train``, ``terrasph predict``."""

from __future__ import annotations

import argparse
import sys
from typing import Sequence


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
    """Entry point of the ``terrasph`` command."""
    parser = build_parser()
    args = parser.parse_args(argv)
    return int(args.handler(args) or 0)


if __name__ == "__main__":
    sys.exit(main())
