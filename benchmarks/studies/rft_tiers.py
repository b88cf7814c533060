"""The RFT tier of docs/rft.md: the chapter 3 leg rotations and the chapter 4 leg-wheels on the RFT
terrain (terrasph.terrain.rft) with a coefficient map, and the cost of each run.

    OMP_NUM_THREADS=1 python benchmarks/studies/rft_tiers.py [--rft-table generic|TABLE.json] [--legs-only]

Prints, per leg, the peak lift and thrust of the sweep at 0.2 rad/s (compare docs/benchmarks.md's
SPH table) and, per wheel, the leg-wheel run's mean speed, slip, final / max sinkage and cost of
transport (compare docs/robots.md's SPH table at Δx = 1.67 mm), with the wall time of each run and
the simulated seconds per CPU second of the leg-wheel runs (their whole run: building the robot,
stepping, the summary; no file written; CPU time, which a machine shared with other jobs does not
inflate as it does the wall time).
"""

from __future__ import annotations

import argparse
import time

from terrasph.scenes.leg_rotation import LEGS, LegRotation, run_leg_rotation
from terrasph.scenes.leg_wheel import WHEELS, LegWheel, run_leg_wheel


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rft-table", default="generic")
    parser.add_argument("--legs-only", action="store_true")
    args = parser.parse_args()
    print(f"coefficient map: {args.rft_table}")
    print("| leg | peak lift (N) | peak thrust (N) | wall (s) |")
    print("|---|---|---|---|")
    for leg in LEGS:
        start = time.perf_counter()
        result = run_leg_rotation(LegRotation(leg=leg, terrain="rft", rft_table=args.rft_table), progress=False,
                                  plot=False)
        print(f"| {leg} | {result.peak_lift:.3f} | {result.peak_thrust:.3f} | {time.perf_counter() - start:.3f} |",
              flush=True)
    if args.legs_only:
        return
    print("| wheel | mean v_x (m/s) | mean slip | final / max sinkage (cm) | CoT | wall (s) | CPU (s) | simulated s per CPU s |")
    print("|---|---|---|---|---|---|---|---|")
    for wheel in WHEELS:
        config = LegWheel(wheel=wheel, terrain="rft", rft_table=args.rft_table)
        start, cpu = time.perf_counter(), time.process_time()
        summary = run_leg_wheel(config, plot=False).summary()
        wall, cpu = time.perf_counter() - start, time.process_time() - cpu
        print(f"| {wheel} | {summary['mean_forward_speed']:.4f} | {summary['mean_slip']:.3f} | "
              f"{100 * summary['final_sinkage']:.2f} / {100 * summary['max_sinkage']:.2f} | "
              f"{summary['cost_of_transport']:.2f} | {wall:.1f} | {cpu:.1f} | {config.t_end / cpu:.2f} |", flush=True)


if __name__ == "__main__":
    main()
