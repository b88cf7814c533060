"""One option, one meaning across the scenes of ``terrasph run``: an option name that several
scenes offer takes the same kind of value in each (a number is a number everywhere; a repeated
NAME=VALUE option has its own name), and the pause before the motion is ``--settle-time`` in every
scene (the column's gate included)."""

from __future__ import annotations

import argparse

import pytest
from terrasph.cli import build_parser
from terrasph.scenes import SCENES


def _scene_parsers() -> dict[str, argparse.ArgumentParser]:
    run = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction)).choices["run"]
    scenes = next(a for a in run._actions if isinstance(a, argparse._SubParsersAction))
    return dict(scenes.choices)


def _kind(action: argparse.Action) -> tuple:
    """What an option takes: its action (store, append, a switch), its value type and count."""
    value_type = "str" if action.type is None else getattr(action.type, "__name__", repr(action.type))  # argparse's default
    return type(action).__name__, value_type, action.nargs


def test_each_option_name_has_one_kind_of_value_in_every_scene() -> None:
    kinds: dict[str, dict[tuple, list[str]]] = {}
    for scene, parser in _scene_parsers().items():
        for action in parser._actions:
            for name in action.option_strings:
                kinds.setdefault(name, {}).setdefault(_kind(action), []).append(scene)
    mixed = {name: by_kind for name, by_kind in kinds.items() if len(by_kind) > 1}
    assert not mixed


@pytest.mark.parametrize("scene", sorted(SCENES))
def test_every_scene_has_settle_time_and_t_end(scene) -> None:
    names = {name for action in _scene_parsers()[scene]._actions for name in action.option_strings}
    assert {"--settle-time", "--t-end"} <= names
