"""An open-loop gait searched for on the rigid floor and on sand: gymnasium's Walker2d (planar RFT) and Ant
(3D RFT) with a sinusoidal gait of a few parameters, tuned by the cross-entropy method (CEM) to
the environment's own reward.

A gait drives every actuator with ``bias + amplitude · sin(2π f t + phase)`` (clipped to the action
range [-1, 1]); a few parameters set all of them (:data:`GAITS`): Walker2d's legs mirror each other
half a period apart, Ant trots (diagonal legs together). The search, for each floor: a Gaussian over
the parameters, `iterations` rounds of `population` gaits drawn from it, each rolled out for `steps`
environment steps from the same `resets` resets (seeded), scored by the mean of the episodes' return
(Walker2d; its episode ends when it falls) or travel (Ant: :data:`GAITS`); the Gaussian refitted to the best `elite` of each round.
Deterministic: the same seed gives the same gaits and the same scores.

Then each environment's hand-set gait (the search's starting mean), the best rigid-floor gait and
the best sand gait roll out on both floors, with random actions beside them, each from
:data:`HELD_OUT_RESETS` resets the search did not see (the same measurements as
``examples/sand_vs_rigid.py``: travel, foot sinkage, foot slip, time upright). Prints the best
parameters and the cross-floor rollouts, writes benchmarks/results/gait_search.json (machine, date, commit inside)
and the figure docs/img/gait_search.png.

    OMP_NUM_THREADS=1 python examples/gait_search.py [--seed 0] [--population 16] [--iterations 8] [--resets 3]
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import json
import logging
import os
import pathlib
import platform
import subprocess
import time as clock
from collections.abc import Callable

import gymnasium
import mujoco
import numpy as np
from matplotlib.figure import Figure
from sand_vs_rigid import CASES, Policy, episode, make, random_policy, rollouts

ROOT = pathlib.Path(__file__).resolve().parents[1]
RESULT = ROOT / "benchmarks" / "results" / "gait_search.json"
FIGURE = ROOT / "docs" / "img" / "gait_search.png"
#: the resets each gait is rolled out from after the search, none of them the search's: an open-loop
#: gait tuned to some starts may fall from another
HELD_OUT_RESETS = 4


@dataclasses.dataclass(frozen=True)
class Gait:
    """An open-loop gait family: its parameters' names, the hand-set gait the search starts from,
    the search's starting spread and the parameters' bounds, and the actions at a time."""

    names: tuple[str, ...]
    start: tuple[float, ...]
    spread: tuple[float, ...]
    lower: tuple[float, ...]
    upper: tuple[float, ...]
    actions: Callable[[np.ndarray, float], np.ndarray]
    score: str

    def policy(self, parameters: np.ndarray) -> Policy:
        """The gait with `parameters` as a policy (actions at a time)."""
        return lambda time: np.clip(self.actions(parameters, time), -1.0, 1.0)

    def clip(self, parameters: np.ndarray) -> np.ndarray:
        """`parameters` within the bounds."""
        return np.clip(parameters, self.lower, self.upper)


def _walker(p: np.ndarray, time: float) -> np.ndarray:
    """Walker2d's actuators (thigh, leg, foot; the same of the left leg): each leg's hip, knee and
    ankle on one sine, the knee and the ankle shifted by their phase; the left leg half a period behind."""
    frequency, hip, knee, ankle, knee_phase, ankle_phase, hip_bias, knee_bias = p
    angle = 2.0 * np.pi * frequency * time
    leg = [(hip_bias, hip, 0.0), (knee_bias, knee, knee_phase), (0.0, ankle, ankle_phase)]
    return np.array([b + a * np.sin(angle + phase + half) for half in (0.0, np.pi) for b, a, phase in leg])


def _ant(p: np.ndarray, time: float) -> np.ndarray:
    """Ant's actuators (hip and ankle of legs 4, 1, 2, 3): a trot, legs 4 and 2 together, 1 and 3 half
    a period behind; each ankle shifted from its hip by the ankle's phase."""
    frequency, hip, ankle, ankle_phase = p
    angle = 2.0 * np.pi * frequency * time
    return np.array([a * np.sin(angle + phase + half) for half in (0.0, np.pi, 0.0, np.pi)
                     for a, phase in ((hip, 0.0), (ankle, ankle_phase))])


#: each environment's gait family and what its search maximises (a key of :func:`sand_vs_rigid.episode`'s
#: result): Walker2d's the episode's return, the sum of the environment's rewards (forward speed, a
#: reward per step while upright, less the control cost: scored by the travel alone every gait fell
#: backwards within a second); Ant's its travel (its return is mostly the reward for not tipping over
#: less the control cost: the search shrank the gait to a twitch)
GAITS = {
    "Walker2d-v5": Gait(("frequency", "hip", "knee", "ankle", "knee_phase", "ankle_phase", "hip_bias", "knee_bias"),
                        start=(1.0, 0.5, 0.5, 0.3, -1.5, 0.0, 0.0, 0.0),
                        spread=(0.3, 0.25, 0.25, 0.25, 1.0, 1.0, 0.2, 0.2),
                        lower=(0.2, 0.0, 0.0, 0.0, -np.pi, -np.pi, -0.5, -0.5),
                        upper=(3.0, 1.0, 1.0, 1.0, np.pi, np.pi, 0.5, 0.5), actions=_walker, score="return"),
    "Ant-v5": Gait(("frequency", "hip", "ankle", "ankle_phase"), start=(1.0, 0.3, 0.3, 0.5 * np.pi),
                   spread=(0.3, 0.25, 0.25, 1.0), lower=(0.2, 0.0, 0.0, -np.pi), upper=(3.0, 1.0, 1.0, np.pi),
                   actions=_ant, score="distance"),
}


def search(env: gymnasium.Env, feet: tuple[str, ...], gait: Gait, seed: int, population: int, iterations: int,
           elite: int, steps: int, resets: int) -> dict[str, object]:
    """The cross-entropy method over `gait`'s parameters on `env` (module docstring), each gait scored
    by its mean score (:data:`GAITS`) from `resets` resets (seeds `seed`, `seed` + 1, ...): the best gait
    found (its parameters and score) and each round's best and mean score."""
    rng = np.random.default_rng(seed)
    mean, spread = np.array(gait.start), np.array(gait.spread)
    best, best_score, rounds = mean, -np.inf, []
    for _ in range(iterations):
        candidates = [gait.clip(mean + spread * rng.standard_normal(mean.size)) for _ in range(population)]
        scores = np.array([np.mean([episode(env, feet, gait.policy(c), seed + k, steps)[gait.score] for k in range(resets)])
                           for c in candidates])
        order = np.argsort(-scores, kind="stable")
        if scores[order[0]] > best_score:
            best, best_score = candidates[order[0]], float(scores[order[0]])
        chosen = np.array([candidates[i] for i in order[:elite]])
        mean, spread = chosen.mean(axis=0), chosen.std(axis=0) + 0.02 * np.array(gait.spread)  # a floor on the spread
        rounds.append({"best": float(scores[order[0]]), "mean": float(scores.mean())})
    return {"parameters": dict(zip(gait.names, best.tolist())), gait.score: best_score, "rounds": rounds}


def _provenance(command: str) -> dict[str, object]:
    commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True, text=True,
                            check=True).stdout.strip()
    return {"example": "examples/gait_search.py", "command": command, "commit": commit,
            "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
            "machine": {"platform": platform.platform(), "logical_cpus": os.cpu_count(),
                        "python": platform.python_version(), "mujoco": mujoco.__version__,
                        "gymnasium": gymnasium.__version__, "omp_num_threads": os.environ.get("OMP_NUM_THREADS")}}


def study(env_id: str, terrain: str, feet: tuple[str, ...], seed: int, population: int, iterations: int,
          elite: int, steps: int, resets: int) -> dict[str, object]:
    """One environment: the search on either floor, then the hand-set gait, both best gaits and
    random actions rolled out on both floors, each from :data:`HELD_OUT_RESETS` resets the search did
    not see (seeds `seed` + `resets`, ...)."""
    gait = GAITS[env_id]
    floors = ("rigid", terrain)
    envs = {floor: make(env_id, floor) for floor in floors}
    searches = {floor: search(envs[floor], feet, gait, seed, population, iterations, elite, steps, resets)
                for floor in floors}
    gaits = {"hand-set gait": np.array(gait.start),
             **{f"best on {floor}": np.array(list(searches[floor]["parameters"].values())) for floor in floors}}
    held_out = range(seed + resets, seed + resets + HELD_OUT_RESETS)
    policies = {"random actions": random_policy,
                **{name: lambda env, reset, p=parameters: gait.policy(p) for name, parameters in gaits.items()}}
    return {"environment": env_id, "terrain": terrain, "steps": steps,
            "duration": steps * envs["rigid"].unwrapped.dt, "search": searches,
            "rollouts": rollouts(envs, feet, policies, held_out, steps)}


def draw(results: list[dict[str, object]]) -> Figure:
    """Per environment: each floor's search (best and mean score per round) and the travel of the
    two best gaits on both floors."""
    fig = Figure(figsize=(10, 3.4 * len(results)), layout="constrained")
    axes = fig.subplots(len(results), 2, squeeze=False)
    for (progress, cross), result in zip(axes, results):
        floors = list(result["search"])
        for floor, colour in zip(floors, ("tab:grey", "tab:orange")):
            rounds = result["search"][floor]["rounds"]
            progress.plot([r["best"] for r in rounds], "o-", color=colour, label=f"{floor}: best")
            progress.plot([r["mean"] for r in rounds], "--", color=colour, label=f"{floor}: mean")
        progress.set(xlabel="CEM round", ylabel=f"mean {GAITS[result['environment']].score} of a gait", title=f"{result['environment']}: the search")
        progress.legend(fontsize=8)
        gaits = [f"best on {floor}" for floor in floors]
        for k, (floor, colour) in enumerate(zip(floors, ("tab:grey", "tab:orange"))):
            rows = [next(r for r in result["rollouts"] if r["policy"] == g and r["floor"] == floor) for g in gaits]
            at = np.arange(len(gaits)) + 0.4 * k - 0.2
            cross.bar(at, [r["distance"] for r in rows], 0.4, color=colour, label=f"on {floor}")
            for x, row in zip(at, rows):  # each reset's travel
                cross.plot([x] * len(row["episodes"]), [e["distance"] for e in row["episodes"]], "k.", ms=4)
        cross.set_xticks(range(len(gaits)), [f"gait found on {floor}" for floor in floors])
        cross.set(ylabel="travel (m): mean, dots each reset", title=f"{result['environment']}: each best gait on both floors")
        cross.axhline(0.0, color="k", lw=0.5)
        cross.legend(fontsize=8)
    return fig


def figure(results: list[dict[str, object]], path: pathlib.Path) -> None:
    """:func:`draw` saved to `path`."""
    path.parent.mkdir(parents=True, exist_ok=True)
    draw(results).savefig(path, dpi=110)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--population", type=int, default=16)
    parser.add_argument("--iterations", type=int, default=8)
    parser.add_argument("--elite", type=int, default=4)
    parser.add_argument("--resets", type=int, default=3, help="the resets each gait of the search is scored from")
    parser.add_argument("--walker-steps", type=int, default=500, help="Walker2d's episode (steps of 8 ms)")
    parser.add_argument("--ant-steps", type=int, default=100, help="Ant's episode (steps of 50 ms)")
    parser.add_argument("--environments", nargs="+", default=[case[0] for case in CASES], choices=[c[0] for c in CASES])
    parser.add_argument("--out", type=pathlib.Path, default=RESULT)
    parser.add_argument("--figure", type=pathlib.Path, default=FIGURE)
    args = parser.parse_args()
    logging.disable(logging.WARNING)  # the floor's one line per environment
    steps = {"Walker2d-v5": args.walker_steps, "Ant-v5": args.ant_steps}
    results = []
    for env_id, terrain, feet in CASES:
        if env_id not in args.environments:
            continue
        began = clock.perf_counter()
        result = study(env_id, terrain, feet, args.seed, args.population, args.iterations, args.elite, steps[env_id],
                       args.resets)
        result["wall_time"] = clock.perf_counter() - began
        results.append(result)
        print(f"{env_id}: {args.iterations} rounds x {args.population} gaits x {args.resets} resets x {steps[env_id]} steps "
              f"({result['duration']:.1f} s) per floor, {result['wall_time']:.0f} s")
        for floor, found in result["search"].items():
            print(f"  best on {floor:<6}: " + ", ".join(f"{k} {v:.2f}" for k, v in found["parameters"].items()))
        print(f"  {'policy':<15} {'floor':<6} {'travel (m)':>10} {'upright (s)':>11} {'foot sinkage (mm)':>18} "
              f"{'foot slip (m/s)':>16}  travel from each reset (m)")
        for row in result["rollouts"]:
            others = " ".join(f"{e['distance']:.2f}" for e in row["episodes"])
            print(f"  {row['policy']:<15} {row['floor']:<6} {row['distance']:>10.3f} {row['length']:>11.2f} "
                  f"{1000 * row['sinkage']:>18.1f} {row['slip']:>16.3f}  {others}")
    command = "OMP_NUM_THREADS=1 python examples/gait_search.py " + " ".join(
        f"--{k.replace('_', '-')} {v if not isinstance(v, list) else ' '.join(v)}" for k, v in vars(args).items()
        if k not in ("out", "figure"))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({**_provenance(command), "population": args.population,
                                    "iterations": args.iterations, "elite": args.elite, "seed": args.seed,
                                    "resets": args.resets, "held_out_resets": HELD_OUT_RESETS,
                                    "results": results}, indent=2) + "\n")
    figure(results, args.figure)


if __name__ == "__main__":
    main()
