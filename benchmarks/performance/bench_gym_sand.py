"""Environment steps per second of gymnasium MuJoCo environments on sand (terrasph.gym.OnSand) against
the same environments on MuJoCo's rigid floor, one thread, interleaved rounds (CONTRIBUTING.md, the
A/B protocol): in each round every variant runs the same number of random-action steps (resets
included) after its warm-up, one after the other, and the ratio sand/rigid is taken within the
round. Absolute steps/s drift with the machine's load; the ratios are the result.

    OMP_NUM_THREADS=1 OMP_WAIT_POLICY=passive python benchmarks/performance/bench_gym_sand.py [--rounds 5] [--steps 400]

writes benchmarks/results/gym_sand_speed.json (machine, date, commit, each round's steps/s, the
ratios' median and range) and prints a table.
"""

from __future__ import annotations

import argparse
import datetime
import json
import logging
import os
import pathlib
import platform
import statistics
import subprocess
import time

import gymnasium
import numpy as np
import terrasph
from terrasph.gym import OnSand

#: (name, environment, terrain or None for the rigid floor, the terrain's options): each at attach's defaults,
#: and Ant also at the accurate 1 ms substeps (docs/terrain.md, "Substeps")
VARIANTS = (("Walker2d-v5 rigid", "Walker2d-v5", None, {}), ("Walker2d-v5 rft", "Walker2d-v5", "rft", {}),
            ("Ant-v5 rigid", "Ant-v5", None, {}), ("Ant-v5 rft3d", "Ant-v5", "rft3d", {}),
            ("Ant-v5 rft3d 1 ms", "Ant-v5", "rft3d", {"time_step": 1e-3}))
RATIOS = (("Walker2d-v5 rft", "Walker2d-v5 rigid"), ("Ant-v5 rft3d", "Ant-v5 rigid"),
          ("Ant-v5 rft3d 1 ms", "Ant-v5 rigid"))
RESULT = pathlib.Path(__file__).resolve().parents[1] / "results" / "gym_sand_speed.json"
#: the table docs/terrain.md shows (docs/hooks/generated_tables.py): key, heading, format
COLUMNS = [["environment", "environment on sand", "{}"], ["substeps", "substeps per env step", "{}"],
           ["substep_ms", "substep (ms)", "{:g}"], ["median", "sand / rigid steps per second, median", "{:.2f}"],
           ["min", "lowest round", "{:.2f}"], ["max", "highest round", "{:.2f}"]]


def _environment(env_id: str, terrain: str | None, options: dict[str, float]) -> gymnasium.Env:
    env = gymnasium.make(env_id)
    return env if terrain is None else OnSand(env, terrain=terrain, **options)


def _steps_per_second(env: gymnasium.Env, steps: int, seed: int) -> float:
    """Steps/s of `steps` random-action steps from reset(seed), resets included (wall clock)."""
    env.reset(seed=seed)
    actions = np.random.default_rng(seed).uniform(-1.0, 1.0, (steps, *env.action_space.shape))
    start = time.perf_counter()
    for action in actions:
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            env.reset()
    return steps / (time.perf_counter() - start)


def _machine() -> dict[str, object]:
    model = next((line.split(":", 1)[1].strip() for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines()
                  if line.startswith("model name")), platform.processor()) if pathlib.Path("/proc/cpuinfo").exists() \
        else platform.processor()
    return {"cpu": model, "logical_cpus": os.cpu_count(), "platform": platform.platform(),
            "python": platform.python_version(), "load_average_1min": os.getloadavg()[0],
            "omp_num_threads": os.environ.get("OMP_NUM_THREADS")}


def _commit() -> str:
    root = pathlib.Path(__file__).resolve().parents[2]
    try:
        head = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True,
                              check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + ("+dirty" if dirty else "")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--steps", type=int, default=400, help="timed steps per variant and round")
    parser.add_argument("--warmup", type=int, default=50, help="untimed steps per variant before the rounds")
    parser.add_argument("--out", type=pathlib.Path, default=RESULT)
    args = parser.parse_args()
    logging.disable(logging.WARNING)  # the floor's one line per environment
    environments = {name: _environment(env_id, terrain, options) for name, env_id, terrain, options in VARIANTS}
    for env in environments.values():
        _steps_per_second(env, args.warmup, 0)
    rounds: list[dict[str, float]] = []
    for k in range(args.rounds):
        row = {name: _steps_per_second(env, args.steps, k + 1) for name, env in environments.items()}
        rounds.append(row)
        print(f"round {k + 1}: " + ", ".join(f"{name} {rate:.0f}/s" for name, rate in row.items()), flush=True)
    ratios, rows = {}, []
    for sand, rigid in RATIOS:
        values = [row[sand] / row[rigid] for row in rounds]
        ratios[f"{sand} / {rigid}"] = {"median": statistics.median(values), "min": min(values), "max": max(values),
                                       "rounds": values}
        env = environments[sand]
        rows.append({"environment": f"{sand.split()[0]} on {env.terrain.kind}",
                     "substeps": round(env.unwrapped.dt / env.terrain.time_step),
                     "substep_ms": 1e3 * env.terrain.time_step, "median": statistics.median(values),
                     "min": min(values), "max": max(values)})
    command = (f"OMP_NUM_THREADS=1 OMP_WAIT_POLICY=passive python benchmarks/performance/bench_gym_sand.py "
               f"--rounds {args.rounds} --steps {args.steps}")
    machine = _machine()
    result = {"benchmark": "benchmarks/performance/bench_gym_sand.py", "command": command,
              "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
              "commit": _commit(), "machine": machine,
              "provenance": {"date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
                             "terrasph": terrasph.__version__, "commit": _commit(), "cpu": machine["cpu"],
                             "threads": machine["omp_num_threads"], "cores": machine["logical_cpus"],
                             "command": command, "load_average_1min": machine["load_average_1min"]},
              "columns": COLUMNS, "rows": rows,
              "steps_per_round": args.steps, "steps_per_second": rounds, "ratios": ratios,
              "note": "interleaved rounds on a shared machine: the ratios within a round are the result, "
                      "absolute steps/s drift with the load"}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2) + "\n")
    for name, ratio in ratios.items():
        print(f"{name}: {ratio['median']:.3f} (range {ratio['min']:.3f}-{ratio['max']:.3f})")


if __name__ == "__main__":
    main()
