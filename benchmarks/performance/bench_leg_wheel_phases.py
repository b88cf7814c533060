"""Where the default leg-wheel's SPH step goes, phase by phase, at rest and driven.

    python benchmarks/performance/bench_leg_wheel_phases.py [--threads 2] [--rest 0.6] [--driven 0.2]
        [--numerics NAME=VALUE ...]

The scene is chapter 4's leg-wheel as ``LegWheel()`` builds it (C-leg wheel, Δx = 1.67 mm, 18 000
grains), its wheel held still for ``--rest`` simulated seconds and then turned for ``--driven``
more. For each window it prints the wall time per coupled step, the core's phases
(``core.phase_seconds``) in µs per step and the share of frozen grains at its end (with the
active domain on). To compare two builds, run it alternately with each (A B A B): absolute times
on a shared machine are noisy.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from bench_sph import parse_numerics
from terrasph import _core
from terrasph.scenes.leg_wheel import LegWheel, build_leg_wheel


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--rest", type=float, default=0.6, help="simulated s with the wheel held still")
    parser.add_argument("--driven", type=float, default=0.2, help="simulated s with the wheel turning")
    parser.add_argument("--numerics", nargs="*", default=[], metavar="NAME=VALUE")
    args = parser.parse_args()
    if not (args.threads >= 1 and args.rest > 0 and args.driven > 0):
        parser.error("parameters '--threads' >= 1, '--rest' > 0 and '--driven' > 0 are required")
    _core.set_num_threads(args.threads)
    wheel = LegWheel(numerics=parse_numerics(args.numerics))
    coupled = build_leg_wheel(wheel).coupling
    core = coupled.sim.core
    for label, spin, t_end in (("at rest", 0.0, args.rest), ("driven", wheel.omega, args.rest + args.driven)):
        coupled.robot.data.ctrl[0] = spin
        phases, steps = dict(core.phase_seconds), core.step
        start = time.perf_counter()
        coupled.advance(t_end)
        wall = time.perf_counter() - start
        n = core.step - steps
        per_step = {name: round((seconds - phases[name]) / n * 1e6, 1) for name, seconds in core.phase_seconds.items()}
        frozen = float(np.mean(core.field("frozen"))) if "frozen" in core.field_names("granular") else 0.0
        print(f"{label}: {n} steps, {wall / n * 1e6:.0f} us per coupled step, SPH phases (us per step) {per_step}, "
              f"frozen {frozen:.2f}", flush=True)


if __name__ == "__main__":
    main()
