"""Command line: ``terrasph run SCENE``, ``info``, ``plot``, ``animate``, ``train``, ``predict``, ``make-synthetic-dataset``, ``dataset``, ``sweep``, ``cache``.

Every expected error — bad configuration (:class:`terrasph.config.ConfigError`), a malformed file
or model file (``ValueError`` and its subclasses ``ModelFileError``/``LstmFormatError``), a missing
key in a file (``KeyError``), and I/O (``OSError``: missing, existing or unreadable files) — ends in
:func:`main` with one line ``terrasph: error: …`` and exit status 2, as argparse reports a bad option.
"""

from __future__ import annotations

import argparse
import gc
import sys
from collections.abc import Sequence
from typing import NoReturn

from terrasph import __version__

#: errors a user can cause with their input; anything else is a bug and keeps its traceback
EXPECTED_ERRORS = (ValueError, KeyError, OSError)


class Parser(argparse.ArgumentParser):
    """An ArgumentParser whose sub-commands report their own errors on an unknown option, in one
    line that names the command and where its options are listed (not the whole usage)."""

    def error(self, message: str) -> NoReturn:  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message} (`{self.prog} --help` lists the options)\n")

    def parse_args(self, args=None, namespace=None):  # type: ignore[override]
        namespace, extras = self.parse_known_args(args, namespace)
        if extras:
            failing = getattr(namespace, "parser_of_command", self)
            failing.error(f"unrecognized arguments: {' '.join(extras)}")
        return namespace


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """Return the top-level parser with one sub-command per job; for the arguments `argv` of a
    scene's run (``run SCENE …`` without ``--help``), only that scene's sub-command (the same
    parsing and errors, a third of the time: ~300 options are the whole command line's)."""
    parser = Parser(
        prog="terrasph",
        description="SPH simulation of robots on granular terrain and LSTM surrogates.",
    )
    parser.add_argument("--version", action="version", version=f"terrasph {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND", parser_class=Parser)
    from terrasph import animate, rft_cli, run_files, scenes_cli, settle_cache_cli
    from terrasph.surrogate import cli as surrogate_cli
    from terrasph.sweeps import cli as sweep_cli

    words = list(argv or ())
    if words[:1] == ["run"] and len(words) > 1 and scenes_cli.is_scene(words[1]) and \
            not {"-h", "--help"} & set(words):
        scenes_cli.register(sub, only=words[1])
        _remember_leaf_parsers(parser)
        return parser
    scenes_cli.register(sub)
    run_files.register(sub)
    animate.register(sub)
    surrogate_cli.register(sub)
    sweep_cli.register(sub)
    rft_cli.register(sub)
    settle_cache_cli.register(sub)
    _remember_leaf_parsers(parser)
    return parser


def _remember_leaf_parsers(parser: argparse.ArgumentParser) -> None:
    """Every (sub-)command stores its own parser, so errors found after parsing print its usage."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for child in action.choices.values():
                child.set_defaults(parser_of_command=child)
                _remember_leaf_parsers(child)


def error_message(error: BaseException) -> str:
    """The one line shown for an expected error."""
    if isinstance(error, KeyError) and error.args:
        return str(error.args[0])
    if isinstance(error, OSError) and error.filename is not None and error.strerror:
        return f"{error.filename}: {error.strerror}"
    return str(error) or type(error).__name__


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``terrasph`` command.

    Bad input ends with a one-line message and exit status 2 (as argparse does); a run that goes
    unstable ends with its step, time and particle and status 3; Ctrl-C with status 130. Output
    written so far stays readable.
    """
    from terrasph import InstabilityError

    parser = build_parser(sys.argv[1:] if argv is None else argv)
    args = parser.parse_args(argv)
    # what is loaded so far (the package, numpy, matplotlib, MuJoCo: objects that live as long as the
    # process) is left out of Python's garbage collections from here on: a run's collections then
    # look at what the run makes only (they took ~15 % of a short robot run's wall, bench_run_overhead.py)
    gc.freeze()
    try:
        return int(args.handler(args) or 0)
    except InstabilityError as error:
        figures = _figures_of_unfinished_run(args)
        _exit(parser, 3, f"terrasph: the run went unstable: {error}{figures}")
    except EXPECTED_ERRORS as error:
        _exit(parser, 2, f"terrasph: error: {error_message(error)}")
    except KeyboardInterrupt:
        _exit(parser, 130, _interrupted_message(args))


def _interrupted_message(args: argparse.Namespace) -> str:
    """What Ctrl-C left and how to go on: a sweep is rerun by the same command (its finished cases
    are kept), a scene run is continued from its checkpoint."""
    from pathlib import Path

    if getattr(args, "command", None) == "sweep":
        return (f"terrasph: sweep interrupted; its finished cases are kept in {args.out}: rerun `terrasph sweep "
                f"{args.spec} --out {args.out}` to run the others")
    figures = _figures_of_unfinished_run(args)
    out = getattr(args, "out", None) or getattr(args, "run_file", None)
    if getattr(args, "command", None) in ("run", "resume") and out is not None and Path(out).is_file():
        return (f"terrasph: interrupted; {out} is closed and readable{figures}; `terrasph resume {out}` "
                "continues it")
    return "terrasph: interrupted"


def _figures_of_unfinished_run(args: argparse.Namespace) -> str:
    """Writes the PNG (and XDMF) of a scene run that stopped early; a note for the exit message."""
    from pathlib import Path

    from terrasph.run_files import plot_run

    out = getattr(args, "out", None) or getattr(args, "run_file", None)
    if getattr(args, "command", None) not in ("run", "resume") or out is None or not Path(out).is_file():
        return ""
    try:
        png, _ = plot_run(out)
    except EXPECTED_ERRORS as error:  # e.g. no frame yet: the exit message says why there is no figure
        return f"; no figure ({error_message(error)})"
    return f"; wrote {png}"


def _exit(parser: argparse.ArgumentParser, status: int, message: str) -> NoReturn:
    parser.exit(status, " ".join(message.split("\n")[0:1]) + "\n")


if __name__ == "__main__":
    sys.exit(main())
