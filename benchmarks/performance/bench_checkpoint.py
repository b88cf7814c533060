"""Cost of checkpoints: file size and write/restore time per 10 000 granular particles.

    python benchmarks/performance/bench_checkpoint.py [--sizes 10000 40000] [--repeats 5]

A bed of dry glass beads at rest (bench_sph.bed) is stepped 20 steps, then checkpointed `repeats`
times (the median write time is printed) and restored into a fresh simulation of the same scene.
A checkpoint holds every registered field of both particle sets, uncompressed float64.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time

from bench_sph import SPACING, bed
from terrasph.config import Material, Numerics


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", type=int, nargs="+", default=[10000, 40000])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    print("| granular | wall | checkpoint MB | MB per 10k | write s (median) | write s per 10k | restore s |")
    print("|---|---|---|---|---|---|---|")
    for size in args.sizes:
        sim = bed(size, Material(), Numerics(spacing=SPACING))
        sim.advance(1e9, max_steps=20)
        with tempfile.TemporaryDirectory() as folder:
            path = os.path.join(folder, "state.h5")
            writes = []
            for _ in range(args.repeats):
                start = time.perf_counter()
                sim.checkpoint(path)
                writes.append(time.perf_counter() - start)
            other = bed(size, Material(), Numerics(spacing=SPACING))
            start = time.perf_counter()
            other.restore(path)
            restore = time.perf_counter() - start
            megabytes = os.path.getsize(path) / 1e6
        n = len(sim.mass)
        write = statistics.median(writes)
        print(f"| {n} | {len(sim.core.wall_position)} | {megabytes:.2f} | {megabytes * 1e4 / n:.2f} | "
              f"{write:.3f} | {write * 1e4 / n:.3f} | {restore:.3f} |", flush=True)


if __name__ == "__main__":
    main()
