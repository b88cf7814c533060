"""Cost of rigid bodies and wall time of the default leg scene.

    python benchmarks/performance/bench_bodies.py [--threads 2] [--steps 400] [--repeats 3]

1. Wall time per simulated second of the default leg-rotation scene (chapter 3: C-leg, 24 × 15 cm
   bed, Δx = 2.13 mm), measured over `steps` steps of the settling pause and of the sweep.
2. The cost of a body: the same bed stepped with and without the leg (a scene without bodies
   runs the body-free force pass), interleaved `repeats` times; the ratio is the figure to quote.
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import time

from terrasph import _core
from terrasph.scenes.leg_rotation import LegRotation, build_leg_rotation
from terrasph.simulation import Simulation


def seconds_per_step(sim: Simulation, steps: int) -> float:
    sim.advance(1e9, max_steps=10)  # warm-up
    start = time.perf_counter()
    sim.advance(1e9, max_steps=steps)
    return (time.perf_counter() - start) / steps


def simulation(config: LegRotation, with_leg: bool) -> Simulation:
    scene, material, numerics = build_leg_rotation(config)
    if not with_leg:
        scene.walls = [w for w in scene.walls if w.name != "leg"]
    return Simulation(scene, material, numerics, width=config.width)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--steps", type=int, default=400)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    _core.set_num_threads(args.threads)

    config = LegRotation()
    print(f"default leg scene: {config.leg}, ω = {config.omega} rad/s, Δx = {1e3 * config.grid_spacing:.2f} mm, "
          f"{args.threads} threads")
    for phase, settle in (("settling pause", config.settle_time), ("sweep", 0.0)):
        sim = simulation(dataclasses.replace(config, settle_time=settle), with_leg=True)
        per_step = seconds_per_step(sim, args.steps)
        dt = sim.time / sim.step_count
        print(f"  {phase}: {len(sim.mass)} grains, {len(sim.core.wall_position)} wall particles, "
              f"dt = {dt:.3g} s, {per_step * 1e3:.2f} ms/step, {per_step / dt:.0f} s wall per simulated s "
              f"(the default run simulates {config.duration:.2f} s)", flush=True)

    with_leg, without = [], []
    for _ in range(args.repeats):
        with_leg.append(seconds_per_step(simulation(config, True), args.steps))
        without.append(seconds_per_step(simulation(config, False), args.steps))
    a, b = statistics.median(with_leg), statistics.median(without)
    print(f"cost of the leg: {a * 1e3:.2f} ms/step with it, {b * 1e3:.2f} ms/step without, ratio {a / b:.3f} "
          f"(median of {args.repeats}, interleaved)")


if __name__ == "__main__":
    main()
