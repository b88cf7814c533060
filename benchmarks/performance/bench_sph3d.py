"""The cost of granular SPH in 3D beside 2D: CPU time per grain-step and bytes per particle.

    python benchmarks/performance/bench_sph3d.py [--side 30] [--size-2d 27000] [--threads 1 2]
        [--h-factor-3d 1.3] [--skin-3d 0.15] [--steps 40] [--rounds 3] [--output benchmarks/results/sph3d_cost.json]

Both scenes are beds of the default material at rest in a walled box at Δx = 2 mm, walls as thick
as the kernel support: in 3D a cube of side³ grains (terrasph.sph3d.geostatic_bed), in 2D a box 2:1
wide:tall of about size-2d grains (bench_sph.bed), both at the core's default numerics unless
--h-factor-3d / --skin-3d (numerics.h_factor and neighbour_skin of the 3D bed) say otherwise. Each
round steps the 2D bed, then the 3D bed, for `steps` steps after a warm-up, per thread count,
timing the process's CPU seconds
(time.process_time: the sum over threads, so a count of 2 costs its overhead, not its speed-up);
the quoted figure is the 3D/2D ratio of CPU seconds per grain-step per round (interleaved, its
spread over rounds beside it: absolute times on a shared machine drift). Memory is the core's own
count (Simulation.memory_bytes: fields, neighbour lists, pair caches) per particle, grains and
walls; each phase's share of the step (phase_seconds) shows where the time goes. Writes a JSON file
with the machine, date and commit (``provenance``), one row per thread count and the columns
docs/sph3d.md shows of them (``<!-- results: sph3d_cost -->``).
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import terrasph
from bench_sph import bed as bed_2d
from terrasph import _core
from terrasph.config import Material, Numerics
from terrasph.sph3d import bed_simulation, geostatic_bed

SPACING = 0.002
ROOT = Path(__file__).resolve().parents[2]


def bed_3d(side: int, h_factor: float = Numerics().h_factor,
           skin: float = Numerics().neighbour_skin) -> _core.Simulation3D:
    """A cube of side³ grains at rest in its walled box, smoothing length h_factor·Δx, neighbour-list
    skin `skin` (a fraction of h)."""
    bed = geostatic_bed((side * SPACING,) * 3, Material(), SPACING, h_factor=h_factor)
    lower, upper = np.full(3, -0.1), np.array([side * SPACING + 0.1] * 2 + [2 * side * SPACING + 0.1])
    return bed_simulation(bed, Material(), Numerics(spacing=SPACING, h_factor=h_factor, neighbour_skin=skin), lower,
                          upper)


def cpu_per_grain_step(advance, grains: int, steps: int) -> float:
    """CPU seconds (all threads) per grain-step over `steps` steps after a warm-up of 5."""
    advance(5)
    start = time.process_time()
    advance(steps)
    return (time.process_time() - start) / (steps * grains)


def phase_shares(core) -> dict[str, float]:
    """Each phase's share of the wall time of the steps so far (the core's phase_seconds)."""
    seconds = dict(core.phase_seconds)
    total = sum(seconds.values())
    return {name: value / total for name, value in seconds.items()}


def commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True,
                              check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def provenance(script: str, threads: str) -> dict[str, object]:
    """When, on what and by which command (`script`, this process's arguments) a 3D cost result
    was measured, with the threads it ran on and their wait policy (the 3D benchmarks' results)."""
    return {"date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
            "terrasph": terrasph.__version__, "commit": commit(),
            "cpu": platform.processor() or platform.machine(), "cores": os.cpu_count(),
            "threads": f"{threads} (OMP_WAIT_POLICY={os.environ.get('OMP_WAIT_POLICY')})",
            "load_average": os.getloadavg(),
            "command": " ".join(["python", f"benchmarks/performance/{script}", *sys.argv[1:]])}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--side", type=int, default=30, help="3D bed: grains along each side")
    parser.add_argument("--size-2d", type=int, default=27000, help="2D bed: about this many grains")
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--h-factor-3d", type=float, default=Numerics().h_factor,
                        help="h/Δx of the 3D bed (default: Numerics' default; the 2D bed always keeps it)")
    parser.add_argument("--skin-3d", type=float, default=Numerics().neighbour_skin,
                        help="neighbour_skin of the 3D bed (default: Numerics' default; the 2D bed always keeps it)")
    parser.add_argument("--steps", type=int, default=40)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--output", type=Path, default=ROOT / "benchmarks" / "results" / "sph3d_cost.json")
    args = parser.parse_args()

    sim2 = bed_2d(args.size_2d, Material(), Numerics(spacing=SPACING))
    sim3 = bed_3d(args.side, args.h_factor_3d, args.skin_3d)
    grains2, walls2 = len(sim2.mass), len(sim2.core.wall_position)
    grains3, walls3 = len(sim3.mass), len(sim3.wall_position)
    rows = []
    for threads in args.threads:
        _core.set_num_threads(threads)
        seconds2, seconds3 = [], []
        for _ in range(args.rounds):
            seconds2.append(cpu_per_grain_step(lambda n: sim2.advance(1e9, max_steps=n), grains2, args.steps))
            seconds3.append(cpu_per_grain_step(lambda n: sim3.advance(1e9, n), grains3, args.steps))
        ratios = [b / a for a, b in zip(seconds2, seconds3)]
        row = {"threads": threads, "rounds": args.rounds,
               "us_per_grain_step_2d": 1e6 * statistics.median(seconds2),
               "us_per_grain_step_3d": 1e6 * statistics.median(seconds3),
               "ratio_spread_text": f"{min(ratios):.2f}–{max(ratios):.2f}",
               "cpu_us_per_grain_step_2d": [1e6 * s for s in seconds2],
               "cpu_us_per_grain_step_3d": [1e6 * s for s in seconds3],
               "ratio_3d_2d": statistics.median(ratios), "ratio_spread": [min(ratios), max(ratios)],
               "grain_steps_per_cpu_second_2d": 1.0 / statistics.median(seconds2),
               "grain_steps_per_cpu_second_3d": 1.0 / statistics.median(seconds3)}
        rows.append(row)
        print(f"threads {threads}: 2D {1e6 * statistics.median(seconds2):.3f} µs, 3D "
              f"{1e6 * statistics.median(seconds3):.3f} µs CPU per grain-step, 3D/2D {row['ratio_3d_2d']:.2f} "
              f"[{min(ratios):.2f}, {max(ratios):.2f}]", flush=True)
    bytes2 = sim2.core.memory_bytes / (grains2 + walls2)
    bytes3 = sim3.memory_bytes / (grains3 + walls3)
    for row in rows:
        row.update(grains_2d=grains2, walls_2d=walls2, grains_3d=grains3, walls_3d=walls3,
                   bytes_per_particle_2d=bytes2, bytes_per_particle_3d=bytes3)
    result = {
        "provenance": provenance("bench_sph3d.py", ", ".join(map(str, args.threads))),
        "columns": [["threads", "threads", "{}"], ["rounds", "rounds", "{}"],
                    ["us_per_grain_step_2d", "2D CPU µs per grain-step", "{:.3f}"],
                    ["us_per_grain_step_3d", "3D CPU µs per grain-step", "{:.3f}"],
                    ["ratio_3d_2d", "3D/2D (median)", "{:.2f}"], ["ratio_spread_text", "3D/2D over rounds", "{}"],
                    ["bytes_per_particle_2d", "2D bytes/particle", "{:.0f}"],
                    ["bytes_per_particle_3d", "3D bytes/particle", "{:.0f}"]],
        "machine": {"node": platform.node(), "processor": platform.processor() or platform.machine()},
        "spacing": SPACING, "h_factor_3d": args.h_factor_3d, "neighbour_skin_3d": args.skin_3d,
        "scenes": {"2d": {"grains": grains2, "walls": walls2, "bytes_per_particle": bytes2,
                          "phase_shares": phase_shares(sim2.core)},
                   "3d": {"grains": grains3, "walls": walls3, "bytes_per_particle": bytes3,
                          "phase_shares": phase_shares(sim3)}},
        "rows": rows,
    }
    print(json.dumps(result["scenes"]))
    args.output.write_text(json.dumps(result, indent=2) + "\n")


if __name__ == "__main__":
    main()
