"""Error against run time for one leg-wheel at several resolutions: the same wheel and
bed (reversed C-leg, legs 1.5 cm thick and 5 cm long, 30 × 5 cm bed, load 4.9 N, 0.2 s pause,
ω = 1.5 rad/s) at each Δx; mean slip, mean forward speed, final and maximum sinkage, and their
differences from the finest Δx given, with the wall time of each run.

    python benchmarks/validation/leg_wheel_resolution.py [--wheel W] [--t-end T] [dx ...]   (default 0.005 0.00375 0.0025)
"""

from __future__ import annotations

import argparse
import time

from terrasph.scenes.leg_wheel import LegWheel, run_leg_wheel

KEYS = ("mean_slip", "mean_forward_speed", "final_sinkage", "max_sinkage")

if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--wheel", default="reversed-c-leg")
    parser.add_argument("--t-end", type=float, default=1.0)
    parser.add_argument("spacings", type=float, nargs="*", default=[0.005, 0.00375, 0.0025])
    args = parser.parse_args()
    rows = []
    for dx in args.spacings:
        start = time.perf_counter()
        config = LegWheel(wheel=args.wheel, spacing=dx, thickness=0.015, leg_length=0.05, bed_width=0.3,
                          bed_depth=0.05, start_x=0.1, settle_time=0.2, t_end=args.t_end)
        summary = run_leg_wheel(config).summary()
        rows.append((dx, summary, time.perf_counter() - start))
        print(f"# dx {dx}: " + ", ".join(f"{k} {summary[k]:.5g}" for k in KEYS)
              + f", leaks {summary['leaked_particles']}, steps {summary['steps']}, wall {rows[-1][2]:.0f} s", flush=True)
    finest = min(rows, key=lambda r: r[0])[1]
    print(f"{args.wheel}, {args.t_end} s; differences from dx = {min(args.spacings)}")
    print("dx (mm)  slip     v_x (m/s)  final sink (cm)  max sink (cm)  |Δslip|  |Δv_x| (m/s)  |Δfinal| (cm)  wall (s)")
    for dx, s, wall in rows:
        print(f"{1000 * dx:6.2f}  {s['mean_slip']:7.3f}  {s['mean_forward_speed']:9.4f}  {100 * s['final_sinkage']:15.2f}"
              f"  {100 * s['max_sinkage']:13.2f}  {abs(s['mean_slip'] - finest['mean_slip']):7.3f}"
              f"  {abs(s['mean_forward_speed'] - finest['mean_forward_speed']):12.4f}"
              f"  {100 * abs(s['final_sinkage'] - finest['final_sinkage']):13.2f}  {wall:8.0f}")
