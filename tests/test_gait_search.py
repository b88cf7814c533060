"""examples/gait_search.py, the open-loop gait search on the rigid floor and on sand (docs/tutorials/sand_gym.md):
a tiny cross-entropy search is deterministic (the same seed gives the same gaits and scores, another seed
other gaits), and the same open-loop gait from the same reset travels differently on sand than on MuJoCo's
rigid floor."""

from __future__ import annotations

import logging
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")
pytest.importorskip("gymnasium.envs.mujoco")
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "examples"))
import gait_search  # the example, importable from examples/

WALKER_FEET = ("foot", "foot_left")


@pytest.fixture(scope="module")
def walker_on_sand() -> Iterator[gymnasium.Env]:
    """Walker2d on planar RFT, built once (attaching the terrain takes seconds), reset by each episode."""
    logging.disable(logging.WARNING)
    try:
        yield gait_search.make("Walker2d-v5", "rft")
    finally:
        logging.disable(logging.NOTSET)


def _tiny_search(env: gymnasium.Env, seed: int) -> dict[str, object]:
    return gait_search.search(env, WALKER_FEET, gait_search.GAITS["Walker2d-v5"], seed, population=4, iterations=2,
                              elite=2, steps=60, resets=1)


def test_a_tiny_search_is_deterministic(walker_on_sand: gymnasium.Env) -> None:
    first = _tiny_search(walker_on_sand, 3)
    other = _tiny_search(walker_on_sand, 4)
    again = _tiny_search(walker_on_sand, 3)
    assert first == again  # the same seed after another search: the same gaits, scores and rounds
    assert first["parameters"] != other["parameters"]  # the seed draws the gaits


#: a Walker2d gait (examples/gait_search.py's best on the rigid floor, rounded): it rocks and tips
#: forwards on the rigid floor within about 2 s
ROCKING_GAIT = np.array([0.93, 0.63, 0.44, 0.07, 0.83, -0.85, 0.27, 0.32])


@pytest.mark.parametrize("reset", [0, 1])
def test_a_gait_travels_differently_on_sand(walker_on_sand: gymnasium.Env, reset: int) -> None:
    """The same open-loop gait from the same reset for 2 s: on planar RFT sand the feet sink some
    centimetres and the walker's travel differs from the rigid floor's by tenths of a metre
    (measured over resets 0-3: differences 0.38-0.75 m, foot sinkage 94-97 mm; the bands well inside)."""
    gait = gait_search.GAITS["Walker2d-v5"]
    rigid, sand = (gait_search.episode(env, WALKER_FEET, gait.policy(ROCKING_GAIT), reset, 250)
                   for env in (gait_search.make("Walker2d-v5", "rigid"), walker_on_sand))
    assert abs(rigid["distance"] - sand["distance"]) > 0.2
    assert 0.05 < sand["sinkage"] < 0.15
