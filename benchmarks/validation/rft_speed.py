"""Speed of the RFT terrain's step (docs/rft.md): each leg-wheel on RFT (generic map, 6 s, the motor
commanded as in the scene) stepped by the native stepper alone, without the run loop's recording.

    OMP_NUM_THREADS=1 python benchmarks/validation/rft_speed.py [--wheels c-leg flat-leg ...] [--t-end 6] \
        [--rft-table generic|TABLE.json]

Prints per wheel the steps, the CPU time of the stepping (``time.process_time``: a machine shared
with other jobs does not inflate it as it does the wall time), the simulated seconds per CPU second,
the CPU time per step and the load evaluations per step (the start's and the Newton iterates').
"""

from __future__ import annotations

import argparse
import time
from typing import Any

from terrasph.scenes.leg_wheel import WHEELS, LegWheel, build_leg_wheel


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--wheels", nargs="+", default=list(WHEELS))
    parser.add_argument("--t-end", type=float, default=6.0)
    parser.add_argument("--rft-table", default="generic", help="a table with density 0 steps without the carried grains")
    args = parser.parse_args()
    print("| wheel | steps | stepping CPU (s) | simulated s per CPU s | CPU per step (µs) | load evaluations per step |")
    print("|---|---|---|---|---|---|")
    for wheel in args.wheels:
        config = LegWheel(wheel=wheel, terrain="rft", t_end=args.t_end, rft_table=args.rft_table)
        coupled = build_leg_wheel(config).coupling

        def motor(run: object, config: LegWheel = config, coupled: Any = coupled) -> None:
            coupled.robot.data.ctrl[0] = float(config.commanded_omega(coupled.time))

        start = time.process_time()
        coupled.advance(args.t_end, control=motor)
        cpu = time.process_time() - start
        print(f"| {wheel} | {coupled.step_count} | {cpu:.3f} | {args.t_end / cpu:.0f} | "
              f"{1e6 * cpu / coupled.step_count:.1f} | {coupled._native.load_evaluations / coupled.step_count:.2f} |",
              flush=True)


if __name__ == "__main__":
    main()
