"""The five leg-wheels of Fig. 4.2 and the plain wheel through the bed of glass beads: mean forward
speed and slip of the driven phase, final and maximum sinkage (below the undisturbed free
surface), cost of transport, leaks and wall time per wheel. Sizes are options, since the default
scene (Δx = 1.67 mm, 50 × 10 cm bed, 6 s) takes hours per wheel on a 2-core machine; the defaults
here are the README's coarse trial (Δx = 5 mm, legs 1.5 cm thick and 5 cm long, 30 × 5 cm bed).

    python benchmarks/studies/leg_wheel_morphologies.py [--spacing DX] [--thickness T] [--leg-length L]
        [--bed-width W] [--bed-depth D] [--settle S] [--t-end T] [--wheels w1,w2,...]
        [--numerics NAME=VALUE ...]

``--numerics`` overrides the scene's fidelity tier (terrasph.fidelity; docs/fidelity.md), e.g.
``cfl=1.0 freeze_speed=0.001 active_radius=0.1``.
"""

from __future__ import annotations

import argparse
import time

from terrasph.cli_common import add_numerics_option, numerics_overrides
from terrasph.scenes.leg_wheel import WHEELS, LegWheel, run_leg_wheel

if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for name, default in (("spacing", 0.005), ("thickness", 0.015), ("leg-length", 0.05), ("bed-width", 0.3),
                          ("bed-depth", 0.05), ("start-x", 0.1), ("settle", 0.2), ("t-end", 1.5)):
        parser.add_argument(f"--{name}", type=float, default=default)
    parser.add_argument("--wheels", default=",".join(WHEELS))
    add_numerics_option(parser)
    args = parser.parse_args()
    print(f"# {vars(args)}")
    print("wheel            mean v_x (m/s)  mean slip  final sinkage (cm)  max sinkage (cm)  CoT    leaks  wall (s)",
          flush=True)
    for wheel in args.wheels.split(","):
        start = time.perf_counter()
        config = LegWheel(wheel=wheel, spacing=args.spacing, thickness=args.thickness, leg_length=args.leg_length,
                          bed_width=args.bed_width, bed_depth=args.bed_depth, start_x=args.start_x,
                          settle_time=args.settle, t_end=args.t_end, numerics=numerics_overrides(args.numerics))
        s = run_leg_wheel(config).summary()
        print(f"{wheel:<16} {s['mean_forward_speed']:14.4f}  {s['mean_slip']:9.3f}  {100 * s['final_sinkage']:18.2f}"
              f"  {100 * s['max_sinkage']:16.2f}  {s['cost_of_transport']:5.2f}  {s['leaked_particles']:5d}"
              f"  {time.perf_counter() - start:8.1f}", flush=True)
