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
from collections.abc import Callable, Sequence
from typing import Any

import gymnasium
import mujoco
import numpy as np
from matplotlib.figure import Figure
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


def make(env_id: str, floor: str) -> gymnasium.Env:
    """`env_id` on MuJoCo's rigid floor (`floor` ``"rigid"``) or on the terrain `floor`."""
    env = gymnasium.make(env_id)
    return env if floor == "rigid" else OnSand(env, terrain=floor)


def rollouts(envs: dict[str, gymnasium.Env], feet: tuple[str, ...],
             policies: dict[str, Callable[[gymnasium.Env, int], Policy]], resets: Sequence[int],
             steps: int) -> list[dict[str, Any]]:
    """Each policy on each floor (`envs`: floor → environment), one :func:`episode` from each reset:
    per floor and policy, the episodes and their means. A policy is made per environment and reset
    (``policies[name](env, reset)``)."""
    rows = []
    for floor, env in envs.items():
        for name, policy in policies.items():
            episodes = [episode(env, feet, policy(env, reset), reset, steps) for reset in resets]
            rows.append({"policy": name, "floor": floor, "resets": list(resets), "episodes": episodes,
                         **{key: float(np.nanmean([e[key] for e in episodes])) for key in episodes[0]}})
    return rows


def draw(results: dict[str, list[dict[str, Any]]]) -> Figure:
    """Travel, foot sinkage and foot slip of :func:`rollouts`' rows (`results`: environment → rows),
    a group of bars per environment and policy, one bar per floor, each reset's value a dot."""
    figure = Figure(figsize=(11.0, 3.6), layout="constrained")
    panels = figure.subplots(1, 3)
    groups = [(env_id, name) for env_id, rows in results.items() for name in dict.fromkeys(r["policy"] for r in rows)]
    for panel, (key, label, scale) in zip(panels, (("distance", "travel (m)", 1.0),
                                                   ("sinkage", "foot sinkage (mm)", 1000.0),
                                                   ("slip", "foot slip (m/s)", 1.0))):
        for k, (env_id, name) in enumerate(groups):
            rows = [r for r in results[env_id] if r["policy"] == name]
            for j, row in enumerate(rows):
                at = k + 0.8 * (j + 0.5) / len(rows) - 0.4
                colour = "tab:grey" if row["floor"] == "rigid" else "tab:orange"
                panel.bar(at, scale * row[key], 0.8 / len(rows), color=colour,
                          label=("rigid floor" if row["floor"] == "rigid" else "sand") if k == 0 else None)
                panel.plot([at] * len(row["episodes"]), [scale * e[key] for e in row["episodes"]], "k.", ms=3)
        panel.set_xticks(range(len(groups)), [f"{env_id.split('-')[0]}: {name}" for env_id, name in groups],
                         fontsize=7, rotation=30, ha="right")
        panel.set_ylabel(label)
        panel.axhline(0.0, color="k", lw=0.5)
    panels[0].legend(fontsize=8)
    return figure


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--episodes", type=int, default=3)
    parser.add_argument("--steps", type=int, default=200)
    args = parser.parse_args()
    logging.disable(logging.WARNING)  # the floor's one line per environment
    print(f"{'environment':<13} {'floor':<6} {'distance (m)':>13} {'foot sinkage (mm)':>18} {'foot slip (m/s)':>16}")
    for env_id, terrain, feet in CASES:
        envs = {floor: make(env_id, floor) for floor in ("rigid", terrain)}
        for row in rollouts(envs, feet, {"random actions": random_policy}, range(args.episodes), args.steps):
            print(f"{env_id:<13} {row['floor']:<6} {row['distance']:>13.3f} {1000 * row['sinkage']:>18.1f} "
                  f"{row['slip']:>16.3f}")


if __name__ == "__main__":
    main()
