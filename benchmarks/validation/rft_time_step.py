"""The RFT terrain's time step by convergence (docs/rft.md): the leg-wheel on RFT (generic map, 4 s)
at several MuJoCo steps.

    OMP_NUM_THREADS=1 python benchmarks/validation/rft_time_step.py [--wheels flat-leg c-leg] [--steps 1e-2 5e-3 2e-3 1e-3 5e-4]
        [--control-interval 1e-2]

Prints the driven phase's mean speed, slip, sinkage and spin per step (and the CPU time of the run).
With ``--control-interval 0`` the motor's command is set before every step (else every interval,
at least one step).
"""

from __future__ import annotations

import argparse
import time

from terrasph.scenes import leg_wheel
from terrasph.terrain.interface import Terrain, couple
from terrasph.terrain.rft_coupling import RFT_CONTROL_INTERVAL


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--wheels", nargs="+", default=["flat-leg", "c-leg"])
    parser.add_argument("--steps", nargs="+", type=float, default=[1e-2, 5e-3, 2e-3, 1e-3, 5e-4])
    parser.add_argument("--control-interval", type=float, default=RFT_CONTROL_INTERVAL)
    args = parser.parse_args()
    build = leg_wheel.build_leg_wheel
    print("| wheel | dt (ms) | v_x (m/s) | slip | mean sinkage (mm) | mean ω (rad/s) | CPU (s) |")
    print("|---|---|---|---|---|---|---|")
    for wheel in args.wheels:
        for dt in args.steps:
            def at_step(config: leg_wheel.LegWheel, dt: float = dt) -> Terrain:
                built = build(config).coupling
                return couple(built.robot, "rft", config.rft_table, surface=built.surface_level, time_step=dt,
                              control_interval=max(dt, args.control_interval))

            leg_wheel.build_leg_wheel = at_step  # run_leg_wheel builds through the module's name
            start = time.process_time()
            summary = leg_wheel.run_leg_wheel(leg_wheel.LegWheel(wheel=wheel, terrain="rft", t_end=4.0),
                                              plot=False).summary()
            print(f"| {wheel} | {1e3 * dt:g} | {summary['mean_forward_speed']:.4f} | {summary['mean_slip']:.3f} | "
                  f"{1e3 * summary['mean_sinkage']:.1f} | {summary['mean_omega']:.3f} | "
                  f"{time.process_time() - start:.2f} |", flush=True)
    leg_wheel.build_leg_wheel = build


if __name__ == "__main__":
    main()
