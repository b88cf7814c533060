"""MkDocs hook: the command-line reference, generated from the argument parsers.

A page line ``<!-- cli-reference -->`` becomes one section per command (and per scene of
``terrasph run``) holding that command's ``--help`` exactly as the installed ``terrasph`` prints it,
so the reference cannot drift from the code (terrasph.cli.build_parser is the one definition).
"""

from __future__ import annotations

import argparse
import os

MARKER = "<!-- cli-reference -->"


def _subcommands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    """The sub-command parsers of `parser`, by name, in the order they were added."""
    for action in parser._actions:  # argparse keeps its sub-parsers only here
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def _help(parser: argparse.ArgumentParser) -> str:
    """The parser's help at a fixed width (argparse wraps at $COLUMNS)."""
    columns = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = "100"
    try:
        return parser.format_help()
    finally:
        if columns is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = columns


def _section(level: int, title: str, parser: argparse.ArgumentParser) -> list[str]:
    """A heading and the help of one parser, then its sub-commands' sections."""
    lines = [f"{'#' * level} `{title}`", "", "```text", _help(parser).rstrip(), "```", ""]
    for name, child in _subcommands(parser).items():
        lines += _section(level + 1, f"{title} {name}", child)
    return lines


def cli_reference() -> str:
    """Markdown of every command's help."""
    from terrasph.cli import build_parser

    parser = build_parser()
    return "\n".join(_section(2, "terrasph", parser))


def on_page_markdown(markdown: str, page, config, files) -> str:
    """Replace the marker line by the generated reference."""
    return markdown.replace(f"\n{MARKER}\n", f"\n{cli_reference()}\n")
