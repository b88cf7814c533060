"""examples/gait_search.py, the open-loop gait search on the rigid floor and on sand (docs/tutorials/sand_gym.md):
a tiny cross-entropy search is deterministic (the same seed gives the same gaits and scores, another seed
other gaits), and the same open-loop gait travels differently on sand than on MuJoCo's rigid floor."""

from __future__ import annotations

import logging
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("gymnasium")
pytest.importorskip("gymnasium.envs.mujoco")
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "examples"))
import gait_search  # the example, importable from examples/

WALKER_FEET = ("foot", "foot_left")


def _tiny_search(seed: int) -> dict[str, object]:
    env = gait_search.make("Walker2d-v5", "rft")
    return gait_search.search(env, WALKER_FEET, gait_search.GAITS["Walker2d-v5"], seed, population=4, iterations=2,
                              elite=2, steps=60, resets=1)


def test_a_tiny_search_is_deterministic() -> None:
    logging.disable(logging.WARNING)
    try:
        first, again, other = _tiny_search(3), _tiny_search(3), _tiny_search(4)
    finally:
        logging.disable(logging.NOTSET)
    assert first == again  # a fresh environment, the same seed: the same gaits, scores and rounds
    assert first["parameters"] != other["parameters"]  # the seed draws the gaits


def test_a_gait_travels_differently_on_sand() -> None:
    """Ant's hand-set trot for 2.5 s: on the rigid floor it walks forward (until it tips over, 1.95 s),
    on the 3D RFT sand its ankles sink some centimetres and it barely moves (measured 0.65 m against
    -0.07 m, ankle sinkage 42 mm; the bands well inside both)."""
    gait = gait_search.GAITS["Ant-v5"]
    feet = ("left_ankle", "right_ankle", "third_ankle", "fourth_ankle")
    logging.disable(logging.WARNING)
    try:
        rigid, sand = (gait_search.episode(gait_search.make("Ant-v5", floor), feet, gait.policy(np.array(gait.start)),
                                           0, 50) for floor in ("rigid", "rft3d"))
    finally:
        logging.disable(logging.NOTSET)
    assert abs(rigid["distance"] - sand["distance"]) > 0.3
    assert 0.01 < sand["sinkage"] < 0.1
