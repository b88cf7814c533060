"""Cost of numerics variants of the default leg-wheel, interleaved window by window in one process.

    python benchmarks/performance/bench_interleaved.py --variant NAME:KEY=VALUE,... [--variant ...] [--threads 2]
        [--window 0.05] [--t-end 6.0]

Each variant is chapter 4's leg-wheel as ``LegWheel()`` builds it (C-leg wheel, Δx = 1.67 mm, 18 000
grains, 2 s pause then 1.5 rad/s), with the variant's numerics. All of them are built in this process
and advanced in turns by a window of simulated time (the order reversed every other window), the
motor commanded as ``run_leg_wheel`` does, so that a change of the machine's speed (on a shared
virtual machine up to ±25 % between runs a few minutes apart) falls on every variant alike. Prints,
per variant, its steps and wall seconds per simulated second, and the median and quartiles over the
windows of the first variant's wall time per simulated second over this one's (the speed-up against
the first). Only the cost: ``bench_levers.py leg-wheel`` gives the outcomes (slip, sinkage).
"""

from __future__ import annotations

import argparse
import statistics
import time

from bench_levers import parse_variant
from terrasph import _core
from terrasph.scenes.leg_wheel import LegWheel, build_leg_wheel
from terrasph.terrain.sph_coupling import CoupledSimulation


def advance(coupled: CoupledSimulation, wheel: LegWheel, t_end: float) -> int:
    """Coupled steps of `coupled` up to `t_end` (s), the motor commanded as run_leg_wheel does; returns the steps."""
    data = coupled.robot.data
    steps = 0
    while coupled.time < t_end * (1 - 1e-14):
        data.ctrl[0] = float(wheel.commanded_omega(coupled.time))
        coupled.step()
        steps += 1
    return steps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--variant", action="append", required=True, metavar="NAME:KEY=VALUE,...")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--window", type=float, default=0.05, help="simulated s each variant runs in its turn")
    parser.add_argument("--t-end", type=float, default=6.0, help="simulated s in all (the scene's duration)")
    args = parser.parse_args()
    if not (args.threads >= 1 and args.window > 0 and args.t_end > 0):
        parser.error("parameters '--threads' >= 1, '--window' > 0 and '--t-end' > 0 are required")
    if len(args.variant) < 2:
        parser.error("parameter '--variant' must be given at least twice (the first is the reference)")
    _core.set_num_threads(args.threads)
    variants = [parse_variant(text) for text in args.variant]
    wheels = {name: LegWheel(t_end=args.t_end, numerics=numerics) for name, numerics in variants}
    runs = {name: build_leg_wheel(wheel).coupling for name, wheel in wheels.items()}
    names = [name for name, _ in variants]
    wall = {name: [] for name in names}  # wall s per simulated s, window by window
    steps = dict.fromkeys(names, 0)
    seconds = dict.fromkeys(names, 0.0)
    windows = max(1, round(args.t_end / args.window))
    for k in range(windows):
        t_end = args.t_end * (k + 1) / windows
        for name in names if k % 2 == 0 else names[::-1]:
            t_start, start = runs[name].time, time.perf_counter()
            steps[name] += advance(runs[name], wheels[name], t_end)
            elapsed = time.perf_counter() - start
            seconds[name] += elapsed
            wall[name].append(elapsed / (runs[name].time - t_start))
    reference = names[0]
    print("| variant | steps | wall s per sim. s | speed-up against the first: median (quartiles) over the windows |")
    print("|---|---|---|---|")
    for name in names:
        ratios = [a / b for a, b in zip(wall[reference], wall[name])]
        low, _, high = statistics.quantiles(ratios, n=4) if len(ratios) > 1 else (ratios[0],) * 3
        print(f"| {name} | {steps[name]} | {seconds[name] / runs[name].time:.1f} | {statistics.median(ratios):.3f} ({low:.3f}–{high:.3f}) |",
              flush=True)


if __name__ == "__main__":
    main()
