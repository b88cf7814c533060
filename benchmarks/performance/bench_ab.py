"""Interleaved A/B of two builds of terrasph on the throughput benchmark, in one run on one machine.

    python benchmarks/performance/bench_ab.py --a-path DIR_A --b-path DIR_B [--rounds 3] [--sizes 20000 80000]
        [--threads 1 2] [--steps 200] [--a-numerics NAME=VALUE ...] [--b-numerics NAME=VALUE ...]

DIR_A and DIR_B are folders that each contain an importable ``terrasph`` package (for instance a
copy of an installed build's site-packages/terrasph saved before a change); an empty string means
the installed one. --a-numerics / --b-numerics pass numerics options to each side's bed (the same
build with a lever off and on: give one path twice). Each round runs ``bench_sph.py throughput`` once with A and once with B, in
alternating order, each in its own process; the table gives every round's M particle-steps/s,
the median of each, the ratio B/A and the bytes per particle of each. Absolute figures move with
the machine's load: compare only the ratio, measured side by side.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

HERE = Path(__file__).resolve().parent


def run(path: str, sizes: list[int], threads: list[int], steps: int, numerics: list[str]) -> dict[tuple[int, int], tuple[float, float]]:
    """{(size, threads): (M particle-steps/s, bytes per particle)} from one bench_sph process."""
    env = dict(os.environ)
    if path:
        env["PYTHONPATH"] = os.pathsep.join([path, str(HERE)])
    command = [sys.executable, str(HERE / "bench_sph.py"), "throughput", "--steps", str(steps), "--sizes",
               *map(str, sizes), "--threads", *map(str, threads), "--numerics", *numerics]
    out = subprocess.run(command, env=env, cwd=HERE, check=True, capture_output=True, text=True).stdout
    results: dict[tuple[int, int], tuple[float, float]] = {}
    for line in out.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 7 and cells[0].isdigit():
            results[(int(cells[0]), int(cells[2]))] = (float(cells[3]), float(cells[6].split("–")[0]))
    return results


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--a-path", required=True)
    parser.add_argument("--b-path", required=True)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--sizes", type=int, nargs="+", default=[20000, 80000])
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--a-numerics", nargs="*", default=[], metavar="NAME=VALUE")
    parser.add_argument("--b-numerics", nargs="*", default=[], metavar="NAME=VALUE")
    args = parser.parse_args()
    rates: dict[str, dict[tuple[int, int], list[float]]] = {"A": defaultdict(list), "B": defaultdict(list)}
    memory: dict[str, dict[tuple[int, int], float]] = {"A": {}, "B": {}}
    for round_index in range(args.rounds):
        order = ("A", "B") if round_index % 2 == 0 else ("B", "A")
        for label in order:
            path, numerics = (args.a_path, args.a_numerics) if label == "A" else (args.b_path, args.b_numerics)
            for key, (rate, bytes_per) in run(path, args.sizes, args.threads, args.steps, numerics).items():
                rates[label][key].append(rate)
                memory[label][key] = bytes_per
    print("| granular (approx.) | threads | A M p-steps/s (rounds) | B M p-steps/s (rounds) | B/A (medians) | "
          "A bytes/particle | B bytes/particle |")
    print("|---|---|---|---|---|---|---|")
    for key in sorted(rates["A"]):
        a, b = rates["A"][key], rates["B"][key]
        print(f"| {key[0]} | {key[1]} | {' '.join(f'{x:.2f}' for x in a)} | {' '.join(f'{x:.2f}' for x in b)} | "
              f"{statistics.median(b) / statistics.median(a):.3f} | {memory['A'][key]:.0f} | {memory['B'][key]:.0f} |")


if __name__ == "__main__":
    main()
