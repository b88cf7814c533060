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
    # argparse's default type is str
    value_type = "str" if action.type is None else getattr(action.type, "__name__", repr(action.type))
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


#: tiny beds of every scene on the glass beads, to build (not run) with another material
TINY_BEDS = {
    "leg-rotation": {"bed_width": 0.14, "bed_depth": 0.07},
    "plate-intrusion": {"bed_width": 0.06, "bed_depth": 0.04, "plate_length": 0.02, "max_depth": 0.006},
    "plate-drag": {"bed_width": 0.14, "bed_depth": 0.08, "spacing": 0.005, "plate_length": 0.04, "start_depth": 0.03,
                   "travel": 0.004},
    "leg-wheel": {"spacing": 0.005, "thickness": 0.015, "leg_length": 0.04, "bed_width": 0.2, "bed_depth": 0.04,
                  "start_x": 0.08},
    "rover": {"spacing": 0.005, "thickness": 0.015, "leg_length": 0.04, "bed_width": 0.3, "bed_depth": 0.04,
              "start_x": 0.12},
}


@pytest.mark.parametrize("scene", sorted(SCENES))
def test_every_scene_with_grains_offers_its_material(scene) -> None:
    names = {name for action in _scene_parsers()[scene]._actions for name in action.option_strings}
    assert {"--mu1-deg", "--mu2-deg", "--water-content"} <= names


@pytest.mark.parametrize("scene", sorted(TINY_BEDS))
def test_the_material_options_reach_the_bed(scene) -> None:
    """μ1 = 20°, μ2 = 30°, w = 0.5 % given to the scene: the simulation it builds has that bed
    (μ = tan of the angle, Eq. 2.31; wet density × (1 + w)), and without them the chapter 3 beads."""
    import math

    from terrasph.config import glass_beads
    from terrasph.terrain import Terrain

    entry = SCENES[scene]
    build = getattr(__import__(entry.module, fromlist=["_"]), f"build_{entry.config_key}")

    def material(**changes):
        built = build(entry.config_from({**TINY_BEDS[scene], **changes}))
        if isinstance(built, Terrain):  # a robot scene's terrain: its coupling holds the simulation
            built = built.coupling
        sim = built[0] if isinstance(built, tuple) else built.sim  # (scene, material, numerics) or coupled
        return built[1] if isinstance(built, tuple) else sim.material

    wet = material(mu1_deg=20.0, mu2_deg=30.0, water_content=0.005)
    assert wet.mu1 == math.tan(math.radians(20.0)) and wet.mu2 == math.tan(math.radians(30.0))
    assert wet.water_content == 0.005 and wet.grain_density == pytest.approx(2600.0 * 1.005, rel=1e-12)
    beads = material()
    assert (beads.mu1, beads.mu2, beads.water_content) == (glass_beads().mu1, glass_beads().mu2, 0.0)
