"""Random actions on rigid floor and on sand: gymnasium's Walker2d (planar RFT) and Ant (3D RFT).

For each environment and floor, a few episodes of uniform random actions (the same seeds on both
floors) and, per episode: the distance the torso travelled along x, the feet's deepest sinkage
below the sand's surface, and the feet's slip: their mean horizontal speed while they bear load
(the vertical part of ``cfrc_ext``, the floor's contact force on rigid ground and the sand's load
on sand, above 1 N).

    OMP_NUM_THREADS=1 python examples/sand_vs_rigid.py [--episodes 3] [--steps 200]
"""

from __future__ import annotations

import argparse
import logging
from collections.abc import Callable

import gymnasium
import mujoco
import numpy as np
from terrasph.gym import OnSand
from terrasph.mjcf.model import body_name

#: environment, the terrain for it, its feet (the bodies' names in terrasph: Ant's lower legs are
#: unnamed bodies, named by their geoms)
CASES = (("Walker2d-v5", "rft", ("foot", "foot_left")),
         ("Ant-v5", "rft3d", ("left_ankle", "right_ankle", "third_ankle", "fourth_ankle")))
#: a foot bears load when its vertical external force is above this (N)
LOADED = 1.0
#: a policy: the action at a time (s) since the episode's start
Policy = Callable[[float], np.ndarray]


def _body_ids(model: mujoco.MjModel, names: tuple[str, ...]) -> list[int]:
    return [body for body in range(model.nbody) if body_name(model, body) in names]


def random_policy(env: gymnasium.Env, seed: int) -> Policy:
    """Uniform random actions in [-1, 1], drawn from a generator seeded with `seed`."""
    rng = np.random.default_rng(seed)
    return lambda time: rng.uniform(-1.0, 1.0, env.action_space.shape)


def episode(env: gymnasium.Env, feet: tuple[str, ...], policy: Policy, seed: int, steps: int) -> dict[str, float]:
    """One episode of `policy` from reset(seed), at most `steps` long (shorter if the environment
    ends it: gymnasium's Walker2d when it falls): the torso's travel along x (m), the feet's deepest
    sinkage (m, 0 on the rigid floor), their slip (m/s), the episode's return (the sum of the
    environment's rewards) and its length (s)."""
    env.reset(seed=seed)
    model, data = env.unwrapped.model, env.unwrapped.data
    ids = _body_ids(model, feet)
    start, sinkage, speeds, total = float(data.qpos[0]), 0.0, [], 0.0
    twist = np.zeros(6)
    time0 = float(data.time)
    for _ in range(steps):
        _, reward, terminated, truncated, _ = env.step(policy(float(data.time) - time0))
        total += float(reward)
        for foot in ids:
            if data.cfrc_ext[foot, 5] > LOADED:
                mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_BODY, foot, twist, 0)
                speeds.append(float(np.hypot(twist[3], twist[4])))
        if isinstance(env, OnSand):
            sinkage = max(sinkage, *(env.terrain.sinkage()[name] for name in feet))
        if terminated or truncated:
            break
    return {"distance": float(data.qpos[0]) - start, "sinkage": sinkage,
            "slip": float(np.mean(speeds)) if speeds else float("nan"), "return": total,
            "length": float(data.time) - time0}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--episodes", type=int, default=3)
    parser.add_argument("--steps", type=int, default=200)
    args = parser.parse_args()
    logging.disable(logging.WARNING)  # the floor's one line per environment
    print(f"{'environment':<13} {'floor':<6} {'distance (m)':>13} {'foot sinkage (mm)':>18} {'foot slip (m/s)':>16}")
    for env_id, terrain, feet in CASES:
        for floor in ("rigid", terrain):
            env = gymnasium.make(env_id)
            if floor != "rigid":
                env = OnSand(env, terrain=terrain)
            rows = [episode(env, feet, random_policy(env, seed), seed, args.steps)
                    for seed in range(args.episodes)]
            mean = {key: np.nanmean([row[key] for row in rows]) for key in rows[0]}
            print(f"{env_id:<13} {floor:<6} {mean['distance']:>13.3f} {1000 * mean['sinkage']:>18.1f} "
                  f"{mean['slip']:>16.3f}")


if __name__ == "__main__":
    main()
