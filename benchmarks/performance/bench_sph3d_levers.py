"""Numerics levers on the 3D bed's cost, interleaved in one process.

    python benchmarks/performance/bench_sph3d_levers.py [--side 30] [--threads 1] [--rounds 5] [--steps 20]
        [--variant NAME=VALUE,NAME=VALUE ...] [--output benchmarks/results/sph3d_levers.json]

The bed is bench_sph3d.py's 3D cube (side³ grains at rest in its walled box, Δx = 2 mm), built once
with the default numerics and once per variant (each a comma-separated list of numerics settings),
all in this process; each round advances every bed by `steps` steps in turn (the order reversed
every other round), timing the process's CPU seconds per grain-step. The figure is the median over
rounds of the defaults' time over the variant's (its speed-up): a change of the machine's speed
falls on every bed alike. Only the cost: a variant that changes the resolution (h_factor) needs its
accuracy measured apart. Writes a JSON file with its provenance, one row per bed and the columns
docs/sph3d.md shows of them (``<!-- results: sph3d_levers -->``).
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path

import numpy as np
from bench_sph import parse_numerics
from bench_sph3d import SPACING, provenance
from terrasph import _core
from terrasph.config import Material, Numerics
from terrasph.sph3d import bed_simulation, geostatic_bed

ROOT = Path(__file__).resolve().parents[2]
DEFAULT_VARIANTS = ["symmetric_pairs=false", "cell_order=false", "neighbour_skin=0.05", "h_factor=1.2",
                    "h_factor=1.2,neighbour_skin=0.02"]


def bed(side: int, numerics: Numerics) -> _core.Simulation3D:
    """bench_sph3d.py's cube of side³ grains at rest in its walled box, with `numerics`."""
    shape = geostatic_bed((side * SPACING,) * 3, Material(), SPACING, h_factor=numerics.h_factor)
    lower, upper = np.full(3, -0.1), np.array([side * SPACING + 0.1] * 2 + [2 * side * SPACING + 0.1])
    return bed_simulation(shape, Material(), numerics, lower, upper)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--side", type=int, default=30)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--variant", nargs="+", default=DEFAULT_VARIANTS, metavar="NAME=VALUE,...")
    parser.add_argument("--output", type=Path, default=ROOT / "benchmarks" / "results" / "sph3d_levers.json")
    args = parser.parse_args()
    if args.side < 2 or args.threads < 1 or args.rounds < 1 or args.steps < 1:
        parser.error("--side >= 2, --threads, --rounds and --steps >= 1 are required")
    _core.set_num_threads(args.threads)
    settings = {"defaults": {}} | {text: parse_numerics(text.split(",")) for text in args.variant}
    beds = {name: bed(args.side, Numerics(spacing=SPACING, **values)) for name, values in settings.items()}
    for sim in beds.values():
        sim.advance(1e9, 5)
    seconds: dict[str, list[float]] = {name: [] for name in beds}
    for index in range(args.rounds):
        for name in beds if index % 2 == 0 else list(beds)[::-1]:
            sim = beds[name]
            start = time.process_time()
            sim.advance(1e9, args.steps)
            seconds[name].append((time.process_time() - start) / (args.steps * len(sim.mass)))
    rows = []
    for name, times in seconds.items():
        speedups = [a / b for a, b in zip(seconds["defaults"], times)]
        rows.append({"variant": name, "us_per_grain_step_3d": 1e6 * statistics.median(times),
                     "speedup": statistics.median(speedups), "speedup_spread": [min(speedups), max(speedups)]})
        print(f"{name}: {rows[-1]['us_per_grain_step_3d']:.3f} µs CPU per grain-step, speed-up "
              f"{rows[-1]['speedup']:.2f} [{min(speedups):.2f}, {max(speedups):.2f}]", flush=True)
    args.output.write_text(json.dumps({
        "provenance": provenance("bench_sph3d_levers.py", str(args.threads)),
        "columns": [["variant", "numerics", "{}"], ["us_per_grain_step_3d", "3D CPU µs per grain-step", "{:.3f}"],
                    ["speedup", "speed-up against the defaults (median over rounds)", "{:.2f}"]],
        "side": args.side, "rounds": args.rounds, "steps": args.steps, "rows": rows}, indent=2) + "\n")


if __name__ == "__main__":
    main()
